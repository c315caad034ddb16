"""Derivatives by zero-phase Butterworth filtering and central differences (the EMPS benchmark's processing)."""

import functools
import math
from typing import Literal, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import scipy  # scipy.signal loads on first use
from jaxtyping import Array, ArrayLike, Float

from .._checks import is_concrete
from .._runtime import x64
from .filtering import check_signal, filtfilt_core, padlen_for, parallel_sos


class FilteredDerivatives(NamedTuple):
    """Filtered position and its first two derivatives (same length as input).

    **Fields:** `q` filtered signal (units of the input), `dq` its derivative
    (units/s), `ddq` second derivative (units/s²).
    """

    q: Float[Array, " N"]
    dq: Float[Array, " N"]
    ddq: Float[Array, " N"]


def _concrete_positive_float(name: str, v) -> float:
    if not is_concrete(v):
        raise ValueError(f"`{name}` must be a concrete number (it sets the filter design), not traced")
    try:
        arr = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a number; got {v!r}") from None
    if arr.shape != ():
        raise ValueError(f"`{name}` must be a scalar; got shape {arr.shape}")
    out = float(arr)
    if not (math.isfinite(out) and out > 0):
        raise ValueError(f"`{name}` must be positive and finite; got {out}")
    return out


@x64
def butter_derivatives(
    q: ArrayLike,
    dt: float,
    *,
    cutoff_hz: float,
    order: int = 4,
    padding: Literal["matlab", "scipy"] = "matlab",
    method: str | None = None,
) -> FilteredDerivatives:
    """Zero-phase Butterworth smoothing followed by central differences.

        q_f = filtfilt(b, a, q),   b, a = scipy.signal.butter(order, cutoff_hz / (fs / 2)),  fs = 1 / dt,
        dq  = gradient(q_f) / dt,
        ddq = gradient(dq) / dt,

    with central differences inside, (dq[k+1] - dq[k-1]) / (2 dt), and
    one-sided differences at the two ends (as `numpy.gradient`).

    **Arguments:**

    - `q`: sampled signal, shape `(N,)`, finite.
    - `dt`: sampling period in seconds (concrete, positive).
    - `cutoff_hz`: Butterworth cut-off in Hz (`0 < cutoff_hz < fs/2`). Note that
      the zero-phase magnitude is the square of the Butterworth one, so the
      -6 dB point is at `cutoff_hz`.
    - `order`: Butterworth order (default 4).
    - `padding`: `filtfilt` padding convention (default `"matlab"`).
    - `method`: the filter's kernels (`jaxsdp.filtfilt`'s sequential b/a
      recursion or parallel second-order sections; None: the current setting).

    **Returns:** a `FilteredDerivatives` with `q` (units of the input), `dq`
    (per s), `ddq` (per s^2), each of shape `(N,)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import butter_derivatives
        >>> t = np.arange(1000) * 1e-3  # 1 s at 1 kHz
        >>> d = butter_derivatives(np.sin(2 * np.pi * t), 1e-3, cutoff_hz=20.0)  # q in m
        >>> round(float(d.dq[500]), 3), round(float(d.ddq[250]), 2)  # -2 pi m/s, -(2 pi)^2 m/s^2
        (-6.283, -39.48)
    """
    dt = _concrete_positive_float("dt", dt)
    cutoff_hz = _concrete_positive_float("cutoff_hz", cutoff_hz)
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
        raise ValueError(f"`order` must be a positive integer; got {order!r}")
    nyquist = 0.5 / dt
    if cutoff_hz >= nyquist:
        raise ValueError(f"`cutoff_hz` = {cutoff_hz} must be below the Nyquist frequency 1/(2 dt) = {nyquist}")
    b, a = scipy.signal.butter(int(order), cutoff_hz / nyquist)
    padlen = padlen_for(max(len(a), len(b)), padding)
    q = check_signal("q", q, padlen)
    qf, dq, ddq = _butter_core(q, jnp.asarray(b), jnp.asarray(a), dt, padlen, parallel_sos(b, a, method))
    return FilteredDerivatives(q=qf, dq=dq, ddq=ddq)


@functools.partial(jax.jit, static_argnums=4)
def _butter_core(q, b, a, dt, padlen: int, sos=None):
    qf = filtfilt_core(q, b, a, padlen, sos)
    dq = jnp.gradient(qf, dt)
    return qf, dq, jnp.gradient(dq, dt)
