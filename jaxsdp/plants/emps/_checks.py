"""Up-front checks of an EMPS record: refuse data the study cannot identify, before any work.

`check_emps_data` turns the late, untidy failures of degenerate records
(all-zero or constant force, a position that never moves or moves one way
only, a record too short after border removal and decimation, NaN/inf) into
one-line `ValueError`s, raised before preprocessing starts.
"""

import math

import numpy as np

from ..._checks import MIN_FIT_SAMPLES, positive_int
from ..._runtime import x64
from ._preprocess import DROP, raw_position

#: Fewest decimated samples the regressions and the SDP stage are given.
MIN_DECIMATED = MIN_FIT_SAMPLES

#: Fewest decimated samples moving in each direction. The asymmetric
#: friction model fits a viscous and a Coulomb coefficient separately for
#: positive and negative velocity (`Fv_pos, Fc_pos` and `Fv_neg, Fc_neg`):
#: with no sample on one side two regressor columns are zero and the
#: regression is singular; 10 per side leaves those two parameters a few
#: degrees of freedom.
MIN_MOVING = 10

#: A sample moves when its displacement over one decimation block exceeds
#: this fraction of the position range (per raw sample of the block): above
#: float rounding and an encoder count for any realistic travel (the EMPS
#: record: 0.25 m range, 0.25 um per 1 ms sample, i.e. 0.25 mm/s, 5 counts).
MOVING_FRACTION = 1e-6


def check_length(n: int, *, drop: int = DROP, decimate: int = 10, advice: str | None = None) -> None:
    """Raise `ValueError` if `n` samples leave fewer than `MIN_DECIMATED` after dropping `drop` and decimating."""
    kept = (n - drop) // decimate
    if kept < MIN_DECIMATED:
        advice = "use a smaller decimation factor or a longer record" if advice is None else advice
        raise ValueError(
            f"{n} samples leave {max(kept, 0)} after dropping {drop} and decimating by {decimate}; "
            f"need at least {MIN_DECIMATED} ({advice})"
        )


def _vector(name: str, x) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"`data.{name}` is not numeric") from None
    if arr.ndim != 1:
        raise ValueError(f"`data.{name}` must be 1-D; got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        raise ValueError(
            f"`data.{name}` contains {int(bad.sum())} NaN/inf value(s), the first at sample {int(np.argmax(bad))}"
        )
    return arr


@x64
def check_emps_data(data, *, drop: int = DROP, decimate: int = 10, cutoff_hz: float | None = None) -> None:
    r"""Check that an EMPS record can be identified; raise a one-line `ValueError` if not.

    **Arguments:**

    - `data`: an `EMPSData` (uses `qm`, `force`, `dt`) or a `Measurements`
      (uses `q`, `force`, `dt`).
    - `drop`, `decimate`: the border removal and decimation the study will
      apply (the checks look at the samples it keeps).
    - `cutoff_hz`: the derivative filter's cut-off (Hz) the study will use,
      or None. It must lie below the Nyquist frequency $1/(2 dt)$; when it
      does not, the message gives the record's sampling rate and, for a
      step of 0.1 s or more (an electromechanical axis sampled at 10 Hz or
      less), the likely cause: a time column in milliseconds.

    **Checks**, in this order: position and force are finite 1-D vectors of
    equal length and `dt` is positive; at least `MIN_DECIMATED` (50) samples
    remain after dropping `drop` and decimating by `decimate`; on the kept
    samples, the force is not all zero nor constant and the position is not
    constant; at least `MIN_MOVING` x `decimate` samples (10 decimated
    samples) move in each direction, a sample moving when its displacement
    over one decimation block exceeds `MOVING_FRACTION` (1e-6) of the
    position range per raw sample (the asymmetric friction model needs both
    directions).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.data import Measurements
        >>> from jaxsdp.plants.emps import check_emps_data
        >>> t = np.arange(2000) * 1e-3  # s
        >>> check_emps_data(Measurements(t=t, q=np.sin(t), force=np.ones(2000), dt=1e-3))
        Traceback (most recent call last):
        ...
        ValueError: the force is constant (1) in all 1951 samples kept ...: nothing to identify
    """
    if isinstance(drop, bool) or not isinstance(drop, (int, np.integer)) or drop < 0:
        raise ValueError(f"`drop` must be an integer >= 0; got {drop!r}")
    positive_int("decimate", decimate)
    q = _vector("q", raw_position(data))
    force = _vector("force", data.force)
    if force.shape != q.shape:
        raise ValueError(f"`data.force` and the position differ in length: {force.shape[0]} and {q.shape[0]}")
    try:
        dt = float(data.dt)
    except (TypeError, ValueError):
        raise ValueError(f"`data.dt` must be a number; got {data.dt!r}") from None
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"`data.dt` must be a positive finite sampling period; got {dt}")
    if cutoff_hz is not None and not cutoff_hz < 0.5 / dt:
        raise ValueError(
            f"the derivative filter's cut-off {cutoff_hz:g} Hz is not below the Nyquist frequency {0.5 / dt:g} Hz "
            f"of a record sampled every {dt:g} s ({1 / dt:g} Hz)"
            + (
                "; a time column in milliseconds gives such a step: convert it to seconds "
                "(jaxsdp.data.load_measurements(path, scale={'time': 1e-3}))"
                if dt >= 0.1
                else "; choose a lower cut-off"
            )
        )
    n = q.shape[0]
    check_length(n, drop=drop, decimate=decimate)

    q, force = q[drop:], force[drop:]
    kept = f"all {q.shape[0]} samples kept (after dropping the first {drop})"
    if not force.any():
        raise ValueError(f"the force is zero in {kept}: nothing to identify (check the force column or gtau * vir)")
    if force.min() == force.max():
        raise ValueError(f"the force is constant ({force[0]:g}) in {kept}: nothing to identify")
    span = float(q.max() - q.min())
    if span == 0:
        raise ValueError(f"the position is constant ({q[0]:g}) in {kept}: the axis never moves")
    step = q[decimate:] - q[:-decimate]
    threshold = MOVING_FRACTION * span * decimate
    pos, neg = int((step > threshold).sum()), int((step < -threshold).sum())
    need = MIN_MOVING * decimate
    if min(pos, neg) < need:
        raise ValueError(
            f"too few moving samples: {pos} move forward and {neg} backward (a sample moves when its displacement "
            f"over the next {decimate} sample(s) exceeds {decimate} x {MOVING_FRACTION:g} x the position range "
            f"{span:.6g}); the asymmetric friction model needs at least {need} ({MIN_MOVING} decimated samples) "
            "in each direction"
        )
