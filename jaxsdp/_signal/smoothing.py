"""Smoothing-based derivative estimation (CAPTAIN `irwsm`-style).

The signal is modelled as a continuous-time double-integrated random walk
(white jerk, d^3q/dt^3 = w) sampled every dt, discretised exactly and
written in per-sample units:

    s_k = [q_k, dt q'_k, dt^2 q''_k],
    F = [[1, 1, 1/2], [0, 1, 1], [0, 0, 1]],
    Q = NVR [[1/20, 1/8, 1/6], [1/8, 1/3, 1/2], [1/6, 1/2, 1]],

and y_k = q_k + e_k. The fixed-interval smoother gives q, dq = s_2/dt and
ddq = s_3/dt^2 with standard errors. Because the model is a sampled
continuous process, all three estimates are zero-phase in the interior (a
model with noise on the last state only would put the acceleration half a
sample ahead).

**Frequency response.** With w = 2 pi f dt (rad/sample) the sampled signal
spectrum is NVR S(w), S(w) = sum_j (w + 2 pi j)^-6
= (16 + 13 cos w + cos^2 w) / (30 (2 - 2 cos w)^3), and in the interior the
position smoother is the zero-phase filter H(w) = NVR S / (1 + NVR S).
The cut-off frequency f_c, where H = 1/2 (the "half-power" point of
CAPTAIN's IRW smoothers), therefore fixes

    NVR = 30 (2 - 2 cos w_c)^3 / (16 + 13 cos w_c + cos^2 w_c)   ~ (2 - 2 cos w_c)^3.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import scipy.optimize

from .._checks import as_float_array, check_value
from .._kalman.general import concentrated_loglik, filter_criterion, fixed_interval_smoother, kalman_filter
from .._kalman.nvr import optimise_log10_nvr
from .._runtime import x64

_F = np.array([[1.0, 1.0, 0.5], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]])
_QC = np.array([[1 / 20, 1 / 8, 1 / 6], [1 / 8, 1 / 3, 1 / 2], [1 / 6, 1 / 2, 1.0]])


def _spectrum(c):
    """S(w) for c = cos w: spectrum of the sampled model per unit NVR."""
    return (16.0 + 13.0 * c + c * c) / (30.0 * (2.0 - 2.0 * c) ** 3)


@x64
def nvr_from_cutoff(cutoff_hz, dt):
    """NVR of the derivative smoother whose gain is 1/2 at `cutoff_hz` (Hz), sample time `dt` (s)."""
    c = jnp.cos(2.0 * jnp.pi * jnp.asarray(cutoff_hz) * dt)
    return 1.0 / _spectrum(c)


def cutoff_from_nvr(nvr, dt):
    """Inverse of `nvr_from_cutoff` (Hz): the root of the monotone map by `scipy.optimize.brentq`.

    NVRs at or above the Nyquist frequency's (`nvr_from_cutoff(1 / (2 dt))` = 480)
    give the Nyquist frequency.
    """
    dt = float(dt)
    hi = 0.5 / dt * (1 - 1e-9)

    def nvr_of(f):  # 1 / S(w), written without the division by zero at f = 0
        c = np.cos(2.0 * np.pi * f * dt)
        return 30.0 * (2.0 - 2.0 * c) ** 3 / (16.0 + 13.0 * c + c * c)

    def one(v):
        if np.isnan(v):
            return np.nan
        if not v > 0:
            return 0.0
        if v >= nvr_of(hi):
            return hi
        return scipy.optimize.brentq(lambda f: nvr_of(f) - v, 0.0, hi, xtol=1e-14 * hi, rtol=4 * np.finfo(float).eps)

    return np.vectorize(one, otypes=[float])(np.asarray(nvr, dtype=float))[()]


def smoother_gain(f_hz, nvr, dt):
    """Interior frequency response H(f) of the position smoother (zero phase)."""
    S = nvr * _spectrum(np.cos(2.0 * np.pi * np.asarray(f_hz) * dt))
    return S / (1.0 + S)


class Derivatives(eqx.Module):
    """Smoothed signal and derivatives with standard errors (units of q, q/s, q/s^2).

    `nvr` is the NVR used, `cutoff_hz` the corresponding cut-off frequency (Hz)
    where the smoother's gain is 1/2, `sigma2` the measurement noise variance
    estimate, `loglik` the concentrated log-likelihood.
    """

    q: jnp.ndarray
    dq: jnp.ndarray
    ddq: jnp.ndarray
    q_se: jnp.ndarray
    dq_se: jnp.ndarray
    ddq_se: jnp.ndarray
    nvr: jnp.ndarray
    sigma2: jnp.ndarray
    loglik: jnp.ndarray


def _system(nvr):
    return jnp.asarray(_F), nvr * jnp.asarray(_QC)


@eqx.filter_jit
def _smooth(q, dt, nvr, P0):
    F, Q = _system(nvr)
    x0 = jnp.zeros(3).at[0].set(jnp.nan_to_num(q[0]))
    H = jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0]), (q.shape[0], 3))
    filt = kalman_filter(q, H, F, Q, x0, P0 * jnp.eye(3))
    sm = fixed_interval_smoother(filt, F, Q)
    lik = concentrated_loglik(filt.innov, filt.innov_var, filt.observed, burn_in=4, sigma2_burn_in=3)
    se = jnp.sqrt(lik.sigma2 * jnp.clip(sm.P_smooth_diag, 0.0))
    scale = jnp.array([1.0, dt, dt * dt])
    x = sm.x_smooth / scale
    se = se / scale
    return Derivatives(x[:, 0], x[:, 1], x[:, 2], se[:, 0], se[:, 1], se[:, 2], nvr, lik.sigma2, lik.loglik)


@eqx.filter_jit
def _ml(q, b0, P0):
    x0 = jnp.zeros(3).at[0].set(jnp.nan_to_num(q[0]))
    H = jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0]), (q.shape[0], 3))

    def criterion(b):
        F, Q = _system(10.0 ** b[0])
        return filter_criterion(q, H, F, Q, x0, P0 * jnp.eye(3), burn_in=4)

    return optimise_log10_nvr(criterion, b0, scale=q.shape[0])


@x64
def smooth_derivatives(q, dt, *, nvr=None, cutoff_hz=None, nvr0: float = 1e-8, P0: float = 1e5) -> Derivatives:
    r"""Smoothed position, velocity and acceleration from a sampled signal.

    Fixed-interval smoothing with a double-integrated random walk (state
    $[q, \dot q, \ddot q]$, see the module docstring for the maths).
    Choose the smoothing by exactly one of:

    - `nvr`: the noise variance ratio directly;
    - `cutoff_hz`: the frequency (Hz) where the smoother's gain is 1/2;
    - neither: the NVR is estimated by maximum likelihood (BFGS on
      log10 NVR from `nvr0`, exact derivatives).

    `q` is (N,) (NaN = missing sample), `dt` the sample time in seconds.
    Returns a `Derivatives` with `q`, `dq`, `ddq` and their standard errors.
    """
    q = as_float_array("q", q, ndim=1)
    if q.shape[0] < 5:
        raise ValueError(f"`q` has {q.shape[0]} samples; at least 5 are needed (state dimension 3 + 2)")
    q = check_value("q", q, lambda a: ((a == np.inf) | (a == -np.inf)).any(), "contains inf")
    q = check_value("q", q, lambda a: ~(a == a).any(), "all values are NaN")
    dt = as_float_array("dt", dt, ndim=0)
    dt = check_value("dt", dt, lambda a: ~(a > 0), "sample time must be positive")
    if nvr is not None and cutoff_hz is not None:
        raise ValueError("give at most one of `nvr` and `cutoff_hz`")
    P0 = as_float_array("P0", P0, ndim=0)
    if cutoff_hz is not None:
        cutoff_hz = as_float_array("cutoff_hz", cutoff_hz, ndim=0)
        w = check_value(
            "cutoff_hz", cutoff_hz * dt, lambda a: ~((a > 0) & (a < 0.5)), "must lie in (0, Nyquist = 1/(2 dt))"
        )
        cutoff_hz = w / dt
        nvr = nvr_from_cutoff(cutoff_hz, dt)
    elif nvr is not None:
        nvr = as_float_array("nvr", nvr, ndim=0)
        nvr = check_value("nvr", nvr, lambda a: ~(a > 0), "must be positive")
    else:
        nvr0 = check_value("nvr0", as_float_array("nvr0", nvr0, ndim=0), lambda a: ~(a > 0), "must be positive")
        fit = _ml(q, jnp.log10(nvr0)[None], P0)
        nvr = fit.nvr[0]
    return _smooth(q, dt, nvr, P0)
