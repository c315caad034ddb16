"""Zero-phase filtering and decimation in JAX (MATLAB-compatible `filter`, `filtfilt`, `decimate`).

Everything here is written with `jax.numpy`/`lax.scan`, so it is
differentiable (with respect to the data and the filter coefficients) and can
be `vmap`ped over a batch of signals. Filter *design* (Butterworth, Chebyshev)
is done once with `scipy.signal` from static Python numbers.
"""

import functools
import math
from typing import Literal

import jax
import jax.numpy as jnp
import numpy as np
import scipy  # scipy.signal loads on first use
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float_array, check_finite, check_value
from .._runtime import resolve_method, x64
from .._scan import linear_recurrence

_PADDINGS = ("matlab", "scipy")
DECIMATE_MODES = ("matlab", "scipy", "octave")


# --------------------------------------------------------------------------- #
# Helpers
# --------------------------------------------------------------------------- #


def _coefficients(b, a):
    """Validate and normalise (b, a): same length n, a[0] = 1."""
    b = as_float_array("b", b, ndim=1)
    a = as_float_array("a", a, ndim=1)
    if b.shape[0] == 0:
        raise ValueError(f"`b` must be non-empty; got shape {tuple(b.shape)}")
    if a.shape[0] == 0:
        raise ValueError(f"`a` must be non-empty; got shape {tuple(a.shape)}")
    b = check_finite("b", b)
    a = check_finite("a", a)
    a = check_value("a", a, lambda v: v[0] == 0, "leading coefficient a[0] must be non-zero")
    return _normalise(b, a)


@jax.jit
def _normalise(b, a):
    n = max(b.shape[0], a.shape[0])
    b = jnp.pad(b, (0, n - b.shape[0]))
    a = jnp.pad(a, (0, n - a.shape[0]))
    return b / a[0], a / a[0]


def check_signal(name: str, x, min_len: int):
    x = as_float_array(name, x, ndim=1)
    if x.shape[0] <= min_len:
        raise ValueError(
            f"`{name}` must have more than {min_len} samples (the padding length); got shape {tuple(x.shape)}"
        )
    x = check_finite(name, x)
    return x


def _compensated_sum(v):
    # Neumaier's compensated summation (v is a short, static-length vector):
    # sum(a) suffers cancellation when the poles are close to z = 1.
    total = v[0]
    comp = jnp.zeros((), dtype=v.dtype)
    for i in range(1, v.shape[0]):
        t = total + v[i]
        comp = comp + jnp.where(jnp.abs(total) >= jnp.abs(v[i]), (total - t) + v[i], (v[i] - t) + total)
        total = t
    return total + comp


@jax.jit
def _lfilter_zi(b, a):
    # Steady state of the direct-form II transposed filter for a unit step.
    # With DC gain K = sum(b)/sum(a) the state equations
    # z_i = z_{i+1} + b_{i+1} - a_{i+1} K give the reversed cumulative sum
    # z_i = sum_{j > i} (b_j - a_j K) (Likhterov & Kopeika 2003, as Octave's
    # `filtfilt`); this is the solution of scipy's `lfilter_zi` linear
    # system, but cheaper, and with compensated sums for K it is more
    # accurate when sum(a) is tiny (poles near z = 1).
    # `b`, `a` are normalised and of the same length. A filter with a pole
    # at z = 1 (sum(a) = 0) has no steady state: zeros are returned.
    a_sum = _compensated_sum(a)
    ok = a_sum != 0
    gain = _compensated_sum(b) / jnp.where(ok, a_sum, 1.0)
    zi = jnp.cumsum((b - gain * a)[::-1])[::-1][1:]
    return jnp.where(ok, zi, 0.0)


@jax.jit
def lfilter_scan(x, b, a, zi):
    """y = b/a x from state zi (b, a of equal length, a[0] = 1), direct-form II transposed, one `lax.scan`;
    returns (y, final state). The unchecked kernel of `lfilter`, for callers inside traced code."""
    n = b.shape[0]
    if n == 1:
        return b[0] * x, zi

    def step(z, xk):
        yk = b[0] * xk + z[0]
        z_shift = jnp.concatenate([z[1:], jnp.zeros((1,), dtype=z.dtype)])
        z_new = z_shift + b[1:] * xk - a[1:] * yk
        return z_new, yk

    zf, y = jax.lax.scan(step, zi, x)
    return y, zf


def sos_form(b, a):
    """(sos, zi) of concrete coefficients for the parallel path, or None when `b`, `a` are traced.

    `scipy.signal.tf2sos` sections and `sosfilt_zi` steady states (per unit input):
    the parallel filters run the cascade of second-order sections, each an exact
    two-state linear recurrence (`jaxsdp._scan.linear_recurrence`). The b/a
    companion form cannot be scanned in parallel: with poles near z = 1 (the
    decimation filter) the powers of its state matrix overflow float64.
    """
    try:
        bn, an = np.asarray(b, dtype=np.float64), np.asarray(a, dtype=np.float64)
    except (TypeError, jax.errors.TracerArrayConversionError):
        return None
    if bn.shape[0] < 2:
        return None
    sos = scipy.signal.tf2sos(bn, an)
    return jnp.asarray(sos), jnp.asarray(scipy.signal.sosfilt_zi(sos))


def parallel_sos(b, a, method):
    """`sos_form(b, a)` when `method` resolves to "parallel" (and b, a are concrete), else None."""
    return sos_form(b, a) if resolve_method(method) == "parallel" else None


def _sos_filter(x, sos, zi):
    # Each section in direct-form II transposed, y_k = b0 x_k + z_{k-1,0} and
    # z_k = A z_{k-1} + B x_k with A = [[-a1, 1], [-a2, 0]], B = [b1 - a1 b0, b2 - a2 b0],
    # started in the steady state of the cascade's first input x_0.
    y = x
    for s in range(sos.shape[0]):
        b0, b1, b2, _, a1, a2 = (sos[s, i] for i in range(6))
        A = jnp.stack([jnp.stack([-a1, jnp.ones_like(a1)]), jnp.stack([-a2, jnp.zeros_like(a2)])])
        z0 = zi[s] * x[0]
        c = jnp.outer(y, jnp.stack([b1 - a1 * b0, b2 - a2 * b0])).at[0].add(A @ z0)
        z = linear_recurrence(A, c)
        y = b0 * y + jnp.concatenate([z0[:1], z[:-1, 0]])
    return y


def padlen_for(n: int, padding: str) -> int:
    if padding == "matlab":
        return 3 * (n - 1)
    if padding == "scipy":
        return 3 * n
    raise ValueError(f"`padding` must be one of {_PADDINGS}; got {padding!r}")


@functools.partial(jax.jit, static_argnums=3)
def filtfilt_core(x, b, a, padlen: int, sos=None):
    # Odd reflection about the end points, steady-state initial conditions
    # scaled by the first sample, forward pass, then backward pass; with `sos`
    # (from `sos_form`) the passes are the parallel second-order-section scans.
    if padlen > 0:
        left = 2 * x[0] - x[padlen:0:-1]
        right = 2 * x[-1] - x[-2 : -padlen - 2 : -1]
        ext = jnp.concatenate([left, x, right])
    else:
        ext = x
    if sos is not None:
        y = _sos_filter(_sos_filter(ext, *sos)[::-1], *sos)[::-1]
        return y[padlen : padlen + x.shape[0]] if padlen > 0 else y
    zi = _lfilter_zi(b, a)
    y, _ = lfilter_scan(ext, b, a, zi * ext[0])
    y, _ = lfilter_scan(y[::-1], b, a, zi * y[-1])
    y = y[::-1]
    return y[padlen : padlen + x.shape[0]] if padlen > 0 else y


# --------------------------------------------------------------------------- #
# Public API
# --------------------------------------------------------------------------- #


@x64
def lfilter_zi(b: ArrayLike, a: ArrayLike) -> Float[Array, " n-1"]:
    r"""Steady-state initial conditions of `lfilter` for a unit step input.

    After normalising `a[0] = 1`, with the DC gain $K = \sum b / \sum a$:

    $$ zi_i = \sum_{j > i} (b_j - K a_j), \quad i = 0 .. n-2, $$

    the solution of `(I - A) zi = b[1:] - a[1:] b[0]` ($A$ the companion
    matrix) that `scipy.signal.lfilter_zi` solves, so that
    `lfilter(c * ones, b, a, zi=c * zi)` is constant from the first sample.
    Differentiable; zeros if `sum(a) == 0` (pole at $z = 1$, no steady state).

    **Arguments:** `b`, `a`: numerator and denominator coefficients
    (`a[0] != 0`), dimensionless.

    **Returns:** `zi`, shape `(max(len(a), len(b)) - 1,)`, per unit of input.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import lfilter, lfilter_zi
        >>> b, a = [0.2, 0.2], [1.0, -0.6]  # DC gain 0.4 / 0.4 = 1
        >>> zi = lfilter_zi(b, a)
        >>> np.round(np.asarray(zi), 6).tolist()
        [0.8]
        >>> np.round(np.asarray(lfilter(np.ones(4), b, a, zi=zi)), 6).tolist()
        [1.0, 1.0, 1.0, 1.0]
    """
    b, a = _coefficients(b, a)
    return _lfilter_zi(b, a)


@x64
def lfilter(
    x: ArrayLike,
    b: ArrayLike,
    a: ArrayLike,
    *,
    zi: ArrayLike | None = None,
    return_state: bool = False,
):
    r"""Filter a 1-D signal with the rational transfer function $b(z^{-1}) / a(z^{-1})$.

    $$ a_0 y_k = \sum_i b_i x_{k-i} - \sum_{i \ge 1} a_i y_{k-i}, $$

    implemented in direct-form II transposed as a single `lax.scan` (like
    MATLAB `filter` and `scipy.signal.lfilter`). `y` has the units of `x`
    times the (dimensionless) filter gain. Differentiable in `x`, `b`, `a`.

    **Arguments:**

    - `x`: input signal, shape `(N,)`.
    - `b`, `a`: numerator and denominator coefficients (`a[0] != 0`).
    - `zi`: initial state, shape `(max(len(a), len(b)) - 1,)`; zeros if `None`.
    - `return_state`: also return the final state.

    **Returns:** `y` of shape `(N,)`, or `(y, zf)` if `return_state`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import lfilter
        >>> y = lfilter([1.0, 2.0, 3.0, 4.0], [0.5, 0.5], [1.0])  # two-point moving average
        >>> np.asarray(y).tolist()
        [0.5, 1.5, 2.5, 3.5]
    """
    x = as_float_array("x", x, ndim=1)
    b, a = _coefficients(b, a)
    n = b.shape[0]
    if zi is None:
        zi = jnp.zeros((n - 1,), dtype=jnp.float64)
    else:
        zi = as_float_array("zi", zi, ndim=1)
        if zi.shape[0] != n - 1:
            raise ValueError(f"`zi` must have shape ({n - 1},) = max(len(a), len(b)) - 1; got shape {tuple(zi.shape)}")
    y, zf = lfilter_scan(x, b, a, zi)
    return (y, zf) if return_state else y


@x64
def filtfilt(
    x: ArrayLike,
    b: ArrayLike,
    a: ArrayLike,
    *,
    padding: Literal["matlab", "scipy"] = "matlab",
    method: str | None = None,
) -> Float[Array, " N"]:
    """Zero-phase forward-backward filtering of a 1-D signal.

    The signal is extended at both ends by odd reflection
    (`2 x[0] - x[L:0:-1]` before, `2 x[N-1] - x[N-2:N-2-L:-1]` after),
    filtered forwards with initial state `lfilter_zi(b, a) * ext[0]`,
    reversed, filtered again with initial state `lfilter_zi(b, a) * y[-1]`,
    reversed, and the padding is cut off. The magnitude response is $|H|^2$,
    the phase is zero; `y` has the units of `x`.

    **Arguments:**

    - `x`: signal, shape `(N,)`, finite.
    - `b`, `a`: filter coefficients.
    - `padding`: `"matlab"` (default; MATLAB/Octave `filtfilt`):
      `L = 3 (n - 1)` with `n = max(len(a), len(b))`; `"scipy"`: scipy's
      default `L = 3 n` (`scipy.signal.filtfilt(b, a, x)`).
    - `method`: "sequential" (the b/a recursion, one `lax.scan`), "parallel"
      (the same filter as second-order sections, each a parallel prefix scan:
      for GPUs), "auto" or None (the current setting; see
      `jaxsdp.set_kernel_method`). The parallel form agrees with
      `scipy.signal.sosfiltfilt` to ~1e-13 and with the sequential b/a form to
      that form's own rounding (1e-12 for a 4th-order Butterworth; 2.5e-8 for
      the 8th-order decimation filter, whose b/a recursion is the less accurate
      of the two). With traced `b`, `a` (differentiating w.r.t. the
      coefficients) it falls back to the sequential form.

    Matches `scipy.signal.filtfilt(b, a, x, padlen=L)` to rounding. For badly
    conditioned transfer functions (e.g. the 8th-order decimation filter)
    rounding is amplified by the recursion itself, and float64
    implementations agree only to ~1e-8 relative.

    Requires `N > L`. Differentiable in `x`, `b` and `a`; `vmap` over `x` for
    batches.

    **Returns:** `y`, shape `(N,)`.

    Example:
        >>> import numpy as np, scipy.signal
        >>> from jaxsdp import filtfilt
        >>> t = np.arange(1000) * 1e-3  # 1 s at 1 kHz
        >>> s = np.sin(2 * np.pi * 2 * t)
        >>> x = s + 0.1 * np.sin(2 * np.pi * 100 * t)  # 2 Hz signal + 100 Hz noise
        >>> b, a = scipy.signal.butter(4, 20 / 500)  # 20 Hz cut-off
        >>> y = filtfilt(x, b, a)
        >>> bool(np.max(np.abs(y - s)[100:-100]) < 0.01)  # no delay, noise removed
        True
        >>> bool(np.allclose(y, scipy.signal.filtfilt(b, a, x, padlen=3 * (len(b) - 1))))
        True
    """
    b, a = _coefficients(b, a)
    padlen = padlen_for(b.shape[0], padding)
    x = check_signal("x", x, padlen)
    return filtfilt_core(x, b, a, padlen, parallel_sos(b, a, method))


def _cheby1_design(r: int):
    # MATLAB `decimate`: cheby1(8, 0.05, 0.8/r), reducing the order while the
    # b/a design is numerically poor (gain at 0.8/r not -0.05 dB to 1e-6).
    rip = 0.05
    f = 0.8 / r
    for order in range(8, 0, -1):
        b, a = scipy.signal.cheby1(order, rip, f)
        z = np.exp(-1j * np.pi * f)
        mag_db = 20 * np.log10(abs(np.polyval(b[::-1], z) / np.polyval(a[::-1], z)))
        if not (np.all(b == 0) or abs(mag_db + rip) > 1e-6):
            return b, a
    raise ValueError(f"`r` = {r} is too large: no usable Chebyshev anti-aliasing filter")


@x64
def decimation_filter(r: int) -> tuple[np.ndarray, np.ndarray]:
    """The anti-aliasing filter `(b, a)` used by `decimate` for factor `r`.

    `scipy.signal.cheby1(8, 0.05, 0.8/r)` (type I Chebyshev, 0.05 dB ripple,
    cut-off at 0.8 of the new Nyquist frequency), in transfer-function form.
    Like MATLAB, the order is lowered from 8 while the b/a form is numerically
    poor (its gain at the cut-off is not -0.05 dB to within 1e-6 dB): the
    order stays 8 for `r <= 17`.

    **Arguments:** `r`: decimation factor, an integer `>= 2`.

    **Returns:** `(b, a)`, NumPy float64 arrays (dimensionless).

    Example:
        >>> from jaxsdp import decimation_filter
        >>> b, a = decimation_filter(10)
        >>> len(b), len(a)  # 8th order
        (9, 9)
    """
    r = check_factor(r)
    return _cheby1_design(r)


def check_factor(r) -> int:
    if isinstance(r, bool) or not isinstance(r, (int, np.integer)) or r < 2:
        raise ValueError(f"`r` must be an integer >= 2; got {r!r}")
    return int(r)


def decimate_start(n: int, r: int, mode: str) -> int:
    if mode == "matlab":
        nout = math.ceil(n / r)
        return r - (r * nout - n) - 1  # 0-based
    if mode in ("scipy", "octave"):
        return 0
    raise ValueError(f"`mode` must be one of {DECIMATE_MODES}; got {mode!r}")


@x64
def decimate(
    x: ArrayLike,
    r: int,
    *,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
    method: str | None = None,
) -> Float[Array, " M"]:
    """Low-pass filter then keep every `r`-th sample (MATLAB `decimate`).

    The anti-aliasing filter is `decimation_filter(r)` (8th-order Chebyshev
    type I, 0.05 dB ripple, cut-off `0.8/r` of Nyquist), applied with
    `filtfilt(..., padding="matlab")`. Output length `ceil(N / r)`, sampling
    period `r` times the input's, units of `x`.
    Note that, as in MATLAB, the even-order Chebyshev filter has its ripple
    minimum at DC: slow signals come out scaled by
    $10^{-0.1/20}$ = 0.98855 (0.05 dB, twice; harmless in parallel
    decimation, where every column and the output are scaled alike).

    **Arguments:**

    - `x`: signal, shape `(N,)`.
    - `r`: integer factor `>= 2` (static).
    - `mode`: which samples are kept.
        - `"matlab"` (default; MATLAB `decimate`, used for the published
          EMPS results): 1-based indices `nbeg, nbeg + r, ...` with
          `nbeg = r - (r * ceil(N/r) - N)`, i.e. the last sample is kept.
        - `"scipy"` / `"octave"`: indices `0, r, 2r, ...` (first sample kept),
          as `scipy.signal.decimate` and Octave's `decimate`. Note that the
          filtering is still MATLAB/Octave-style `filtfilt` in b/a form, not
          scipy's second-order-section `sosfiltfilt`.
    - `method`: the filter's kernels, as `filtfilt` (sequential b/a recursion
      or parallel second-order sections).

    **Returns:** the decimated signal, shape `(ceil(N / r),)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import decimate
        >>> y = decimate(np.ones(100), 10)
        >>> y.shape, round(float(y[0]), 5)  # the DC gain of the Chebyshev filter
        ((10,), 0.98855)
    """
    r, b, a, padlen, sos = _decimation_filter(r, mode, method)
    x = check_signal("x", x, padlen)
    start = decimate_start(x.shape[0], r, mode)
    return _decimate_core(x, jnp.asarray(b), jnp.asarray(a), start, padlen, r, sos)


def _decimation_filter(r, mode: str, method):
    """`decimate`'s checked factor and filter: (r, b, a, padding length, second-order sections or None)."""
    r = check_factor(r)
    if mode not in DECIMATE_MODES:
        raise ValueError(f"`mode` must be one of {DECIMATE_MODES}; got {mode!r}")
    b, a = _cheby1_design(r)
    return r, b, a, padlen_for(max(len(a), len(b)), "matlab"), parallel_sos(b, a, method)


@functools.partial(jax.jit, static_argnums=(4, 5))
def _decimate_core(x, b, a, start, padlen: int, r: int, sos=None):
    # Keep samples start, start + r, ..., always ceil(N / r) of them (the
    # start is dynamic so that both modes share one compilation).
    nout = -(-x.shape[0] // r)
    span = r * (nout - 1) + 1
    y = filtfilt_core(x, b, a, padlen, sos)
    return jax.lax.dynamic_slice(y, (start,), (span,))[::r]


def decimate_each(X, r: int, *, mode: str = "matlab", method: str | None = None):
    """`decimate` of every column of `X` (N, k), one column after the other through the same compiled filter
    (bit for bit `decimate` of each), the filter and the kept samples set up once: the parallel decimation of a
    regression's few columns. `X` must be checked (finite, float64, 2-D)."""
    r, b, a, padlen, sos = _decimation_filter(r, mode, method)
    if X.shape[0] <= padlen:
        raise ValueError(f"the signals must have more than {padlen} samples (the padding length); got {X.shape[0]}")
    start = decimate_start(X.shape[0], r, mode)
    b, a = jnp.asarray(b), jnp.asarray(a)
    return jnp.stack([_decimate_core(X[:, j], b, a, start, padlen, r, sos) for j in range(X.shape[1])], axis=1)


def decimate_columns(X, r: int, *, mode: str = "matlab", method: str | None = None):
    """`decimate` of every column of `X` (N, k) in one compiled program: the columns' filters run side by side
    (one `vmap` of the filter's scan), not one scan per column, so that a pipeline holding a few hundred columns
    (a robot's regressor) compiles and runs one filter. The same filter and samples as `decimate` per column.
    `X` must be checked (finite, float64, 2-D, longer than the padding)."""
    r, b, a, padlen, sos = _decimation_filter(r, mode, method)
    if X.shape[0] <= padlen:
        raise ValueError(f"the signals must have more than {padlen} samples (the padding length); got {X.shape[0]}")
    start = decimate_start(X.shape[0], r, mode)
    core = lambda x: _decimate_core(x, jnp.asarray(b), jnp.asarray(a), start, padlen, r, sos)  # noqa: E731
    return jax.vmap(core, in_axes=1, out_axes=1)(X)
