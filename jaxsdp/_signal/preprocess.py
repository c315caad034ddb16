"""Preprocessing of a measured motion for identification: derivatives, border removal, decimation.

The one data path of every study (EMPS axis, robot joint): from a measured
position q and the measured force or torque y, sampled every `dt`,

1. velocity and acceleration, by either
   - `"butterworth"`: zero-phase Butterworth low-pass of the position, then
     central differences twice (`butter_derivatives`; the EMPS benchmark's
     and the TX40 papers' processing), or
   - `"smooth"`: fixed-interval smoothing with a double-integrated random walk
     (`smooth_derivatives`; NVR from a cut-off, given, or by maximum
     likelihood);
2. the first `drop` samples of all four signals removed (filter start-up);
3. each signal decimated by `decimate` (`decimate`, zero-phase Chebyshev);
   regressors built on the full-rate signals are decimated the same way by
   `Preprocessed.regression` (parallel decimation).
"""

from typing import Literal

import equinox as eqx
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float_array, check_finite
from .._runtime import x64
from .butterworth import butter_derivatives
from .filtering import DECIMATE_MODES
from .filtering import decimate as decimate_signal
from .regressors import Regression, Regressors, parallel_decimate
from .smoothing import smooth_derivatives


class Preprocessed(eqx.Module):
    """Measured output and motion after `preprocess`.

    **Fields** (decimated, `M = ceil((N - drop) / decimate)` samples):
    `y` force/torque (units of the input `y`, e.g. N), `q` filtered position
    (units of the input `q`, e.g. m), `dq` velocity (per s), `ddq`
    acceleration (per s^2), `dt` their sampling period (s).

    **Fields** (filtered, first `drop` samples removed, not decimated,
    `N - drop` samples): `y_full`, `q_full`, `dq_full`, `ddq_full`, `dt_full`:
    the signals to build regressors on for `regression`.

    `drop`: the initial samples removed; `decimate`, `mode`: the decimation used;
    `description`: the processing in words (these and the two sample times static: host values).
    """

    y: Float[Array, " M"]
    q: Float[Array, " M"]
    dq: Float[Array, " M"]
    ddq: Float[Array, " M"]
    dt: float = eqx.field(static=True)
    y_full: Float[Array, " L"]
    q_full: Float[Array, " L"]
    dq_full: Float[Array, " L"]
    ddq_full: Float[Array, " L"]
    dt_full: float = eqx.field(static=True)
    drop: int = eqx.field(static=True)
    decimate: int = eqx.field(static=True)
    mode: str = eqx.field(static=True)
    description: str = eqx.field(static=True, default="")

    @x64
    def regression(self, regressors: Regressors) -> Regression:
        """Parallel-decimate regressors built on the full-rate signals, with the output.

        `regressors` is a `Regressors` evaluated on `q_full`, `dq_full`,
        `ddq_full` (e.g. `jaxsdp.plants.emps_regressors(p.dq_full, p.ddq_full)`);
        the result is the published IDIM-LS procedure's input:
        `idim_ls(reg.y, reg.X, names=reg.names)`.
        """
        if not isinstance(regressors, Regressors):
            raise ValueError(
                "`regressors` must be a Regressors built on the full-rate signals (q_full, dq_full, ddq_full); "
                f"got {type(regressors).__name__}"
            )
        if regressors.X.shape[0] != self.y_full.shape[0]:
            raise ValueError(
                f"`regressors` has {regressors.X.shape[0]} rows but the full-rate signals have "
                f"{self.y_full.shape[0]} samples: build it on `q_full`, `dq_full`, `ddq_full`"
            )
        return parallel_decimate(self.y_full, regressors, self.decimate, mode=self.mode)


def _check_int(name, v, lo):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        what = "a non-negative integer" if lo == 0 else f"an integer >= {lo}"
        raise ValueError(f"`{name}` must be {what}; got {v!r}")
    return int(v)


@x64
def preprocess(
    q: ArrayLike,
    y: ArrayLike,
    *,
    dt: float,
    derivatives: Literal["butterworth", "smooth"] = "butterworth",
    cutoff_hz: float | None = None,
    order: int = 4,
    nvr: float | None = None,
    drop: int = 0,
    decimate: int = 1,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
) -> Preprocessed:
    """Derivatives, border removal and decimation of a measured position `q` and output `y`.

    1. Velocity and acceleration, by `derivatives="butterworth"`: zero-phase
       Butterworth low-pass of the position, then central differences twice
       (`butter_derivatives`), or `"smooth"`: fixed-interval smoothing with a
       double-integrated random walk (`smooth_derivatives`).
    2. The first `drop` samples of `y`, `q`, `dq`, `ddq` removed (filter
       start-up).
    3. Each signal decimated by `decimate` (`jaxsdp.decimate`, zero-phase
       Chebyshev); regressors built on the full-rate signals are decimated
       the same way by `Preprocessed.regression` (parallel decimation).

    **Arguments:**

    - `q`: measured position (e.g. m or rad), shape `(N,)`; `y`: measured
      force/torque (e.g. N or N m), `(N,)`.
    - `dt`: sample time (s).
    - `derivatives`: `"butterworth"` (zero-phase Butterworth of `order` at
      `cutoff_hz`, required, then central differences, MATLAB `filtfilt`
      padding) or `"smooth"` (smoothing derivatives: the NVR from `cutoff_hz`,
      or `nvr`, or by maximum likelihood when both are None).
    - `drop`: initial samples removed (>= 0).
    - `decimate`: integer factor >= 1 (1: none); `mode`: which samples are
      kept (see `decimate`).

    **Returns:** a `Preprocessed`: decimated `y`, `q`, `dq` (per s), `ddq`
    (per s^2) with period `dt * decimate`, and the full-rate signals.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import preprocess
        >>> from jaxsdp.plants import emps_regressors
        >>> t = np.arange(2000) * 1e-3  # 2 s at 1 kHz
        >>> q = 0.1 * np.sin(2 * np.pi * t)  # m
        >>> y = 95.0 * np.gradient(np.gradient(q, 1e-3), 1e-3)  # N, a 95 kg mass
        >>> p = preprocess(q, y, dt=1e-3, cutoff_hz=20.0, drop=50, decimate=10)
        >>> p.y.shape, p.q_full.shape, round(p.dt, 6)
        ((195,), (1950,), 0.01)
        >>> reg = p.regression(emps_regressors(p.dq_full, p.ddq_full))
        >>> reg.names, reg.X.shape
        (('M', 'Fv', 'Fc', 'offset'), (195, 4))
    """
    q = as_float_array("q", q, ndim=1)
    y = as_float_array("y", y, ndim=1)
    if y.shape != q.shape:
        raise ValueError(f"`y` and `q` must have the same shape; got {tuple(y.shape)} and {tuple(q.shape)}")
    drop = _check_int("drop", drop, 0)
    if drop >= q.shape[0]:
        raise ValueError(f"`drop` = {drop} must be smaller than the number of samples {q.shape[0]}")
    decimate = _check_int("decimate", decimate, 1)
    if mode not in DECIMATE_MODES:
        raise ValueError(f"`mode` must be one of {DECIMATE_MODES}; got {mode!r}")
    y = check_finite("y", y)
    dt = float(dt)
    if derivatives == "butterworth":
        if cutoff_hz is None:
            raise ValueError("`cutoff_hz` is required with derivatives='butterworth'")
        if nvr is not None:
            raise ValueError("`nvr` is only used with derivatives='smooth'")
        der = butter_derivatives(q, dt, cutoff_hz=cutoff_hz, order=order, padding="matlab")
        how = f"Butterworth order {order} at {cutoff_hz:g} Hz + central differences"
    elif derivatives == "smooth":
        der = smooth_derivatives(q, dt, cutoff_hz=cutoff_hz, nvr=nvr)
        how = "smoothing derivatives " + (
            f"(cut-off {cutoff_hz:g} Hz)"
            if cutoff_hz is not None
            else f"(NVR {nvr:.3g})"
            if nvr is not None
            else "(ML NVR)"
        )
    else:
        raise ValueError(f"`derivatives` must be 'butterworth' or 'smooth'; got {derivatives!r}")
    full = [v[drop:] for v in (y, der.q, der.dq, der.ddq)]
    dec = full if decimate == 1 else [decimate_signal(v, decimate, mode=mode) for v in full]
    return Preprocessed(
        y=dec[0],
        q=dec[1],
        dq=dec[2],
        ddq=dec[3],
        dt=dt * decimate,
        y_full=full[0],
        q_full=full[1],
        dq_full=full[2],
        ddq_full=full[3],
        dt_full=dt,
        drop=drop,
        decimate=decimate,
        mode=mode,
        description=f"{how}, first {drop} samples dropped, decimation by {decimate} ({mode})",
    )


class Butterworth(eqx.Module):
    r"""Derivatives by a zero-phase Butterworth low-pass of the position (order `order`, cut-off `cutoff_hz`
    in Hz, MATLAB `filtfilt` padding) then central differences twice: $\dot q_k = (q_{k+1} - q_{k-1}) / 2\Delta t$.
    The EMPS benchmark's and the TX40 papers' processing."""

    cutoff_hz: float = eqx.field(static=True, default=100.0)
    order: int = eqx.field(static=True, default=4)

    def __check_init__(self):
        if isinstance(self.cutoff_hz, bool) or not isinstance(self.cutoff_hz, (int, float)) or not self.cutoff_hz > 0:
            raise ValueError(f"`cutoff_hz` must be a number > 0 (Hz); got {self.cutoff_hz!r}")
        _check_int("order", self.order, 1)

    def _options(self) -> dict:
        return dict(derivatives="butterworth", cutoff_hz=float(self.cutoff_hz), order=int(self.order), nvr=None)


class Smoothing(eqx.Module):
    r"""Derivatives by fixed-interval smoothing with a double-integrated random walk (`smooth_derivatives`): the NVR
    given as `nvr` (it wins over the cut-off), else from the cut-off `cutoff_hz` (Hz, 100 by default), or by
    maximum likelihood when both are None."""

    cutoff_hz: float | None = eqx.field(static=True, default=100.0)
    nvr: float | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        if self.nvr is not None and not (isinstance(self.nvr, (int, float)) and 0 < self.nvr < float("inf")):
            raise ValueError(f"`nvr` must be None or a finite number > 0; got {self.nvr!r}")

    def _options(self) -> dict:
        cutoff = None if self.nvr is not None else self.cutoff_hz
        return dict(derivatives="smooth", cutoff_hz=cutoff, order=4, nvr=self.nvr)


class Preprocessing(eqx.Module):
    r"""The processing of a measured motion, as an option object: `derivatives` (`Butterworth()` or
    `Smoothing()`), `drop` (first samples removed), `decimate` (factor), `mode` (which sample of each block
    the decimation keeps: "matlab", "scipy", "octave").

    `Preprocessing(...)(q, y, dt)` is `preprocess(q, y, dt=dt, ...)`: pure, it vmaps over records and
    differentiates; under `jax.jit` the sample time must be static (close over it, or `static_argnums`).
    The defaults are the EMPS benchmark's: Butterworth order 4 at
    100 Hz, 49 samples dropped, decimation by 10 (`Preprocessing.emps()` says so by name).
    """

    derivatives: Butterworth | Smoothing = Butterworth()
    drop: int = eqx.field(static=True, default=49)
    decimate: int = eqx.field(static=True, default=10)
    mode: str = eqx.field(static=True, default="matlab")

    def __check_init__(self):
        if not isinstance(self.derivatives, (Butterworth, Smoothing)):
            raise ValueError(
                f"`derivatives` must be jaxsdp.Butterworth(...) or jaxsdp.Smoothing(...); got {self.derivatives!r}"
            )
        _check_int("drop", self.drop, 0)
        _check_int("decimate", self.decimate, 1)
        if self.mode not in DECIMATE_MODES:
            raise ValueError(f"`mode` must be one of {DECIMATE_MODES}; got {self.mode!r}")

    @classmethod
    @x64
    def emps(cls) -> "Preprocessing":
        """The EMPS benchmark's processing: Butterworth order 4 at 100 Hz, 49 samples dropped, decimation by 10."""
        return cls(Butterworth(100.0, 4), drop=49, decimate=10, mode="matlab")

    def _options(self) -> dict:
        """The keyword arguments of `preprocess` (and of `emps_preprocess`) these options stand for."""
        return dict(**self.derivatives._options(), drop=self.drop, decimate=self.decimate, mode=self.mode)

    @x64
    def __call__(self, q, y, dt: float) -> Preprocessed:
        return self._run(q, y, dt)

    def _run(self, q, y, dt: float) -> Preprocessed:
        """`__call__` without the float64 entry wrapper, for pipelines (already inside it)."""
        return preprocess.__wrapped__(q, y, dt=dt, **self._options())
