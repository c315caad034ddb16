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

from .._checks import as_float_array, check_positive, check_value, check_values, no_spread
from .._kalman.general import concentrated_loglik, filter_criterion, fixed_interval_smoother, kalman_filter
from .._kalman.nvr import NVRFit, check_nvr0, optimise_log10_nvr
from .._runtime import resolve_method, x64

_F = np.array([[1.0, 1.0, 0.5], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]])
_QC = np.array([[1 / 20, 1 / 8, 1 / 6], [1 / 8, 1 / 3, 1 / 2], [1 / 6, 1 / 2, 1.0]])


def _spectrum(c):
    """S(w) for c = cos w: spectrum of the sampled model per unit NVR."""
    return (16.0 + 13.0 * c + c * c) / (30.0 * (2.0 - 2.0 * c) ** 3)


@x64
def nvr_from_cutoff(cutoff_hz, dt):
    r"""NVR of the derivative smoother whose gain is 1/2 at `cutoff_hz` (Hz), sample time `dt` (s).

    With $\omega_c = 2 \pi f_c \Delta t$ (rad/sample; $f_c$ = `cutoff_hz`, $\Delta t$ = `dt`),
    $NVR = 1 / S(\omega_c)$ where
    $S(\omega) = (16 + 13 \cos \omega + \cos^2 \omega) / (30 (2 - 2 \cos \omega)^3)$ is the spectrum
    of the sampled double-integrated random walk per unit NVR; roughly
    $NVR \sim (2 - 2 \cos \omega_c)^3 \sim \omega_c^6$ for a cut-off well below Nyquist.
    Dimensionless; inverse of `jaxsdp.cutoff_from_nvr`.

    Example:
        >>> import jaxsdp
        >>> print(f"{float(jaxsdp.nvr_from_cutoff(10.0, 1e-3)):.3e}")
        6.153e-08
    """
    c = jnp.cos(2.0 * jnp.pi * jnp.asarray(cutoff_hz) * dt)
    return 1.0 / _spectrum(c)


@x64
def cutoff_from_nvr(nvr, dt):
    r"""Inverse of `nvr_from_cutoff`: the cut-off frequency (Hz) of the derivative smoother with this NVR.

    The root of the monotone map $NVR(f) = 1 / S(2 \pi f \Delta t)$ (see
    `jaxsdp.nvr_from_cutoff`) by `scipy.optimize.brentq`, for sample time
    `dt` (s) $= \Delta t$. NVRs at or above the Nyquist frequency's
    (`nvr_from_cutoff(1 / (2 dt))` = 480) give the Nyquist frequency; $NVR \le 0$
    gives 0 and NaN gives NaN. Runs in numpy (not traceable).

    Example:
        >>> import jaxsdp
        >>> print(round(float(jaxsdp.cutoff_from_nvr(6.153e-08, 1e-3)), 2))
        10.0
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
    """Result of `jaxsdp.smooth_derivatives`: smoothed signal and derivatives with standard errors.

    - `q`, `dq`, `ddq`: (N,) position, velocity, acceleration (units of q, q/s, q/s^2);
      `q_se`, `dq_se`, `ddq_se`: their standard errors.
    - `nvr`: the NVR used (`jaxsdp.cutoff_from_nvr(nvr, dt)` gives its cut-off
      frequency in Hz); `sigma2`: the measurement noise variance estimate
      (units of q^2); `loglik`: the concentrated log-likelihood.
    - `nvr_fit`: the `NVRFit` when the NVR was estimated by maximum
      likelihood (check `converged`, `at_bound`, `reason`), else None.
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
    nvr_fit: NVRFit | None = None


def _system(nvr):
    return jnp.asarray(_F), nvr * jnp.asarray(_QC)


@eqx.filter_jit
def _smooth(q, dt, nvr, P0, method="sequential"):
    F, Q = _system(nvr)
    x0 = jnp.zeros(3).at[0].set(jnp.nan_to_num(q[0]))
    H = jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0]), (q.shape[0], 3))
    filt = kalman_filter(q, H, F, Q, x0, P0 * jnp.eye(3), method=method)
    sm = fixed_interval_smoother(filt, F, Q, method=method)
    lik = concentrated_loglik(filt.innov, filt.innov_var, filt.observed, burn_in=4, sigma2_burn_in=3)
    se = jnp.sqrt(lik.sigma2 * jnp.clip(sm.P_smooth_diag, 0.0))
    scale = jnp.array([1.0, dt, dt * dt])
    x = sm.x_smooth / scale
    se = se / scale
    return Derivatives(x[:, 0], x[:, 1], x[:, 2], se[:, 0], se[:, 1], se[:, 2], nvr, lik.sigma2, lik.loglik)


@eqx.filter_jit
def _ml(q, b0, P0, method="sequential"):
    x0 = jnp.zeros(3).at[0].set(jnp.nan_to_num(q[0]))
    H = jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0]), (q.shape[0], 3))

    def criterion(b):
        F, Q = _system(10.0 ** b[0])
        return filter_criterion(q, H, F, Q, x0, P0 * jnp.eye(3), burn_in=4, method=method)

    return optimise_log10_nvr(criterion, b0, scale=q.shape[0])


@x64
def smooth_derivatives(
    q, dt, *, nvr=None, cutoff_hz=None, nvr0: float = 1e-8, P0: float = 1e5, method: str | None = None
) -> Derivatives:
    r"""Smoothed position, velocity and acceleration from a sampled signal (CAPTAIN `irwsm`-style).

    Model: $y_k = q_k + e_k$, $q$ a continuous-time double-integrated random walk
    (white jerk, $d^3 q / dt^3 = w$) sampled every `dt` $= \Delta t$ seconds, with state
    $s_k = [q_k, \Delta t q'_k, \Delta t^2 q''_k]$, $F = [[1, 1, 1/2], [0, 1, 1], [0, 0, 1]]$
    and $Q = NVR [[1/20, 1/8, 1/6], [1/8, 1/3, 1/2], [1/6, 1/2, 1]]$. The
    fixed-interval smoother gives $q$, $\dot q = s_2 / \Delta t$ and $\ddot q = s_3 / \Delta t^2$, all
    zero-phase in the interior, with standard errors. In the interior the
    position smoother is the zero-phase filter $H(f) = NVR \cdot S / (1 + NVR \cdot S)$,
    whose gain is 1/2 at the cut-off (see `jaxsdp.nvr_from_cutoff`).

    Choose the smoothing by exactly one of:

    - `nvr`: the noise variance ratio directly (finite, > 0);
    - `cutoff_hz`: the frequency (Hz) where the smoother's gain is 1/2, in $(0, 1/(2 \Delta t))$;
    - neither: the NVR is estimated by maximum likelihood (BFGS on
      $\log_{10} NVR$ from `nvr0`, finite in [1e-30, 1e6], exact derivatives); the
      result's `nvr_fit` says whether the search converged or hit a bound.

    `q` is (N,) (NaN = missing sample; not all NaN, no inf, and not constant
    when the NVR is estimated), `dt` the sample time in seconds. `method`: the
    Kalman kernels ("sequential", "parallel", "auto" or None for the current
    setting; see `jaxsdp.dlr`).
    Returns a `Derivatives` with `q`, `dq`, `ddq` and their standard errors.

    Example:
        >>> import numpy as np, jaxsdp
        >>> t = np.arange(0.0, 1.0, 1e-3)
        >>> d = jaxsdp.smooth_derivatives(np.sin(2 * np.pi * t), 1e-3, cutoff_hz=20.0)
        >>> print(np.round([d.dq[500], d.ddq[250]], 1))            # 2 pi cos(pi), -(2 pi)^2
        [ -6.3 -39.5]
    """
    q = as_float_array("q", q, ndim=1)
    if q.shape[0] < 5:
        raise ValueError(f"`q` has {q.shape[0]} samples; at least 5 are needed (state dimension 3 + 2)")
    q = check_value("q", q, lambda a: ((a == np.inf) | (a == -np.inf)).any(), "contains inf")
    q = check_value("q", q, lambda a: ~(a == a).any(), "all values are NaN")
    dt = as_float_array("dt", dt, ndim=0)
    dt = check_value("dt", dt, lambda a: ~((a > 0) & (a < np.inf)), "sample time must be finite and positive")
    if nvr is not None and cutoff_hz is not None:
        raise ValueError("give at most one of `nvr` and `cutoff_hz`")
    P0 = as_float_array("P0", P0, ndim=0)
    P0 = check_positive("P0", P0)
    fit = None
    if cutoff_hz is not None:
        cutoff_hz = as_float_array("cutoff_hz", cutoff_hz, ndim=0)
        w = check_value(
            "cutoff_hz", cutoff_hz * dt, lambda a: ~((a > 0) & (a < 0.5)), "must lie in (0, Nyquist = 1/(2 dt))"
        )
        cutoff_hz = w / dt
        nvr = nvr_from_cutoff(cutoff_hz, dt)
    elif nvr is not None:
        nvr = as_float_array("nvr", nvr, ndim=0)
        nvr = check_value("nvr", nvr, lambda a: ~((a > 0) & (a < np.inf)), "must be finite and positive")
    else:
        nvr0 = check_nvr0(as_float_array("nvr0", nvr0, ndim=0))
        nvr0 = check_values([("q", q, no_spread, "has zero variance (all observed values equal)")], carrier=nvr0)
        fit = _ml(q, jnp.log10(nvr0)[None], P0, resolve_method(method))
        nvr = fit.nvr[0]
    out = _smooth(q, dt, nvr, P0, resolve_method(method))
    return out if fit is None else eqx.tree_at(lambda d: d.nvr_fit, out, fit, is_leaf=lambda v: v is None)
