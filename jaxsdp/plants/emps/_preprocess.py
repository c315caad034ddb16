"""The EMPS benchmark's standard processing and IDIM regressions, on the generic preprocessing."""

from typing import Literal

from ..._checks import as_float_array, check_finite
from ..._runtime import x64
from ..._signal.preprocess import Preprocessed, preprocess
from ._model import EMPS_DROP
from ._model import emps_regression as emps_regression  # moved down: re-exported here

#: Samples dropped at the start of the record (the benchmark's processing; `plants.EMPS_DROP`).
DROP = EMPS_DROP


def raw_position(data):
    """The position of an `EMPSData` (`qm`) or `Measurements` (`q`), unchecked; ValueError for other types."""
    q = getattr(data, "qm", None)
    if q is None:
        q = getattr(data, "q", None)
    if q is None or not hasattr(data, "force") or not hasattr(data, "dt"):
        raise ValueError(
            f"`data` must be an EMPSData or Measurements (with `qm`/`q`, `force` and `dt`); got {type(data).__name__}"
        )
    return q


def position_force(data):
    """(position, force, dt) of an `EMPSData` (`qm`) or `Measurements` (`q`), checked."""
    q = as_float_array("data.q", raw_position(data), ndim=1)
    force = as_float_array("data.force", data.force, ndim=1)
    if force.shape != q.shape:
        raise ValueError(
            f"`data.force` and the position must have the same shape; got {tuple(force.shape)} and {tuple(q.shape)}"
        )
    return q, check_finite("data.force", force), float(data.dt)


@x64
def emps_preprocess(
    data,
    *,
    derivatives: Literal["butterworth", "smooth"] = "butterworth",
    cutoff_hz: float | None = 100.0,
    order: int = 4,
    nvr: float | None = None,
    drop: int = DROP,
    decimate: int = 10,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
) -> Preprocessed:
    """The EMPS benchmark's standard IDIM processing (`jaxsdp.preprocess` with its settings).

    1. Zero-phase Butterworth (`order`, `cutoff_hz`, MATLAB `filtfilt`
       padding) on the whole position record, then central differences for
       the velocity and again for the acceleration; or, with
       `derivatives="smooth"`, smoothing derivatives (`cutoff_hz`, 100 Hz by
       default, or `nvr`; maximum likelihood with `cutoff_hz=None, nvr=None`).
    2. Drop the first `drop` samples of position, velocity, acceleration and
       force.
    3. Decimate each signal by `decimate` (`jaxsdp.decimate`, `mode`); use
       `emps_regression` for the parallel decimation of the regressors.

    With the defaults (100 Hz, order 4, drop 49, factor 10, MATLAB mode) the
    IDIM-LS estimates reproduce the published reference results
    (M = 95.1089, Fv = 203.5034, Fc = 20.3935, offset = -3.1648, relative
    error 4.083 %). `mode="octave"` (same as `"scipy"`: keep the first sample
    of each block) reproduces the Octave-generated reference inputs.

    **Arguments:**

    - `data`: an `EMPSData` (uses `qm`, `force`, `dt`) or a `Measurements`
      (uses `q`, `force`, `dt`).
    - the options of `jaxsdp.preprocess`, with the benchmark's defaults.

    **Returns:** a `jaxsdp.Preprocessed`: decimated force `y` (N), position
    `q` (m), `dq` (m/s), `ddq` (m/s^2) at `dt * decimate` (s), and the
    full-rate signals after the drop.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_preprocess
        >>> data, truth, _ = emps_builtin_data(0)  # 24,841 samples at 1 kHz
        >>> inputs = emps_preprocess(data)
        >>> inputs.y.shape, round(inputs.dt, 6), inputs.drop  # samples, s, samples
        ((2480,), 0.01, 49)
    """
    q, force, dt = position_force(data)
    return preprocess(
        q,
        force,
        dt=dt,
        derivatives=derivatives,
        cutoff_hz=cutoff_hz,
        order=order,
        nvr=nvr,
        drop=drop,
        decimate=decimate,
        mode=mode,
    )
