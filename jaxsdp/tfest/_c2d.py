"""Zero-order-hold discretisation of a continuous transfer function, with an optional input delay.

The input is held constant between samples (zero-order hold, ZOH), so the
sampled response is exact: with the controllable canonical realisation
(A, B, C, D) of G(s) (`jaxsdp.tfest._tf.tf2ss`) and the sampling interval
dt (s), the exponential of the augmented matrix

    expm([[A, B], [0, 0]] dt) = [[Ad, Bd], [0, 1]]

gives Ad = e^(A dt) and Bd = (integral from 0 to dt of e^(A t) dt) B, and the
discrete transfer function C (zI - Ad)^-1 Bd + D follows from
`jaxsdp.tfest._tf.ss2tf`. Everything is closed form and differentiable
(`jax.scipy.linalg.expm`, the Faddeev-LeVerrier characteristic polynomial),
and works under `jit`, `vmap` and `grad`.

An input delay tau = d dt + eps (d whole samples, 0 <= eps < dt) splits each
sampling interval at eps: x[k+1] = Ad x[k] + G0 u[k-d] + G1 u[k-d-1] with
G0 = (integral from 0 to dt - eps of e^(A t) dt) B and
G1 = e^(A (dt - eps)) (integral from 0 to eps of e^(A t) dt) B (the modified
z-transform); the direct term D then acts on u[k-d-1] when eps > 0.
"""

import functools

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np

from .._checks import is_concrete
from .._runtime import x64
from ._tf import check_tf, ss2tf, tf2ss

#: A delay within this fraction of a sample of a whole number of samples counts as whole.
DELAY_RTOL = 1e-9


def _zoh(a, b, h):
    """(e^(A h), (integral from 0 to h of e^(A t) dt) B) from one matrix exponential."""
    n = a.shape[0]
    m = jnp.zeros((n + 1, n + 1), dtype=a.dtype).at[:n, :n].set(a).at[:n, n].set(b)
    e = jsl.expm(m * h)
    return e[:n, :n], e[:n, n]


def _split_delay(delay, dt):
    """(whole samples d, fraction eps in seconds) of a static delay; eps = 0 for a whole number of samples."""
    if delay is None:
        return 0, 0.0
    if not is_concrete(delay):
        raise ValueError("`delay` must be a concrete number of seconds (it fixes the output length), not traced")
    try:
        tau = float(np.asarray(delay, dtype=float).reshape(()))
    except (TypeError, ValueError):
        raise ValueError(f"`delay` must be a number of seconds >= 0; got {delay!r}") from None
    if not (np.isfinite(tau) and tau >= 0):
        raise ValueError(f"`delay` must be finite and >= 0 (seconds); got {delay!r}")
    if tau == 0:
        return 0, 0.0
    if not is_concrete(dt):
        raise ValueError("`dt` must be concrete when a `delay` is given (the delay in samples fixes the output length)")
    dtf = float(np.asarray(dt, dtype=float).reshape(()))
    ratio = tau / dtf
    d = int(np.floor(ratio + DELAY_RTOL))
    frac = ratio - d
    if abs(frac) <= DELAY_RTOL:
        return d, 0.0
    return d, frac * dtf


@functools.partial(jax.jit, static_argnums=3)
def _discretise(num, den, dt, eps):
    """The ZOH model of num/den (num padded to the length of den); `eps`: the fractional delay (s), static."""
    a, b, c, dd = tf2ss(num, den)
    if eps == 0.0:
        ad, bd = _zoh(a, b, dt)
        return ss2tf(ad, bd, c, dd)
    phi1, g1 = _zoh(a, b, eps)  # the first eps seconds of each interval: the previous input still acts
    phi0, g0 = _zoh(a, b, dt - eps)
    ad = phi0 @ phi1
    n0, den_d = ss2tf(ad, g0, c, 0.0)
    n1, _ = ss2tf(ad, phi0 @ g1, c, 0.0)
    zero = jnp.zeros((1,), dtype=den_d.dtype)
    num_d = jnp.concatenate([n0, zero]) + jnp.concatenate([zero, n1 + dd * den_d])
    return num_d, jnp.concatenate([den_d, zero])


@x64
def c2d(num, den, dt, *, delay=None):
    r"""Zero-order-hold (ZOH) discretisation of a continuous transfer function $G(s) = B(s)/A(s)$.

    The input $u(t)$ is held constant over each sampling interval of `dt` $= \Delta t$
    seconds, so the discrete model reproduces the continuous response exactly
    at the sampling instants $t_k = k \Delta t$ (state $x_{k+1} = A_d x_k + B_d u_k$ with
    $A_d = e^{A \Delta t}$, $B_d = (\int_0^{\Delta t} e^{A t} dt) B$, one matrix
    exponential of the augmented matrix $[[A, B], [0, 0]] \Delta t$).

    Args:
      num: (m + 1,) coefficients of B(s), highest power of s first ($m \le n$).
      den: (n + 1,) coefficients of A(s), highest power first, monic (den[0] = 1).
      dt: sampling interval (s), > 0. May be traced (differentiable) when no `delay` is given.
      delay: optional input delay $\tau \ge 0$ in seconds (static), $G(s) e^{-s \tau}$:
        a whole number $d$ of samples multiplies the result by $z^{-d}$; a fractional
        part $\varepsilon$ ($0 < \varepsilon < \Delta t$) is handled exactly by the modified z-transform
        (the numerator gains one coefficient, the denominator a trailing zero).

    Returns:
      `(num_d, den_d)`: coefficients of $z^0, z^{-1}, ..., z^{-L}$ of
      $G(z) = num_d(z^{-1})/den_d(z^{-1})$, both of length $L + 1$, den_d[0] = 1. Without
      delay $L = n$, and the arrays equal the flattened outputs of
      `scipy.signal.cont2discrete((num, den), dt, method='zoh')`. With a
      delay of $d$ whole samples $L = n + d$: num_d starts with $d$ zeros and den_d
      ends with $d$ zeros (the positive-power reading $z^L ...$ is then also
      exact); a fractional part adds one more to each.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.tfest import c2d
        >>> num_d, den_d = c2d([1.0], [1.0, 1.0], 0.1)  # 1/(s + 1), dt = 0.1 s
        >>> np.round(np.asarray(num_d), 6).tolist(), np.round(np.asarray(den_d), 6).tolist()
        ([0.0, 0.095163], [1.0, -0.904837])
        >>> [len(p) for p in c2d([1.0], [1.0, 1.0], 0.1, delay=0.2)]  # two samples of delay
        [4, 4]
    """
    num, den = check_tf(num, den, kind="continuous")
    if is_concrete(dt):
        v = np.asarray(dt, dtype=float)
        if v.shape != () or not (np.isfinite(v) and v > 0):
            raise ValueError(f"`dt` must be a finite positive number of seconds; got {dt!r}")
    d, eps = _split_delay(delay, dt)
    num = jnp.concatenate([jnp.zeros((den.shape[0] - num.shape[0],)), num])  # one compiled program per n
    num_d, den_d = _discretise(num, den, jnp.asarray(dt, dtype=jnp.float64), eps)
    if d:
        zeros = jnp.zeros((d,), dtype=den_d.dtype)
        num_d, den_d = jnp.concatenate([zeros, num_d]), jnp.concatenate([den_d, zeros])
    return num_d, den_d
