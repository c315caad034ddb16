"""The trend with AR perturbations (the toolbox's `univ`): a random-walk-family trend plus a stationary AR(p)."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._checks import any_nonfinite, as_float_array, check_value, nonnegative_int, positive_int
from .._kalman.general import filter_criterion
from .._kalman.models import as_model
from .._kalman.nvr import LOG10_NVR_BOUNDS, check_nvr0, optimise_log10_nvr
from .._kalman.validate import nvr_vector, validate_regression
from .._runtime import x64
from ._engine import (
    bucket_length,
    check_observed,
    checked_burn_in,
    checked_P0,
    smooth_system,
)
from ._forecast import Forecast, pad

#: The search keeps every partial autocorrelation within this of +-1 (statsmodels' transform's x within +-70.7).
MAX_PACF = 0.9999
_U_MAX = MAX_PACF / np.sqrt(1.0 - MAX_PACF**2)


class UnivResult(eqx.Module):
    r"""Result of `jaxsdp.tvp.univ`: the trend and the AR perturbation over the N data and the h forecast samples.

    - `trend`, `trend_se`: (N+h,) the trend $T_k$ (smoothed over the data and its gaps, extrapolated beyond) and
      its standard error.
    - `perturbation`, `perturbation_se`: (N+h,) the AR component $e_k$ and its standard error (beyond the data
      its mean decays to 0 as the AR's).
    - `resid`: (N,) $y_k - T_k - e_k$, the irregular's estimate (0 without `irregular`; NaN where y is missing).
    - `ar`: (p,) the AR coefficients $a_1..a_p$ ($e_k = \sum_i a_i e_{k-i} + \eta_k$); `pacf`: (p,) their partial
      autocorrelations (each in (-1, 1): a stationary AR).
    - `nvr`: the variance ratios, relative to $\sigma^2$: the trend model's NVR(s), then the irregular's
      $var(\varepsilon) / \sigma^2$ with `irregular=True`.
    - `sigma2`: $\sigma^2 = var(\eta)$, the AR innovations' variance (concentrated out: its ML value).
    - `loglik`, `J`: the concentrated log-likelihood and criterion (as `jaxsdp.dlr`'s), over the samples after
      `burn_in`; `definite`: the smoother's variances came out non-negative and finite.
    - `forecast`: the `Forecast` of the series' signal $T_k + e_k$ (its `obs_se` adds the irregular).
    - `estimated`: bool, some hyperparameters were estimated; `fit`: the `NVRFit` of the search (None when every
      hyperparameter was given). Its vector is $b$ = [$\log_{10}$ of the estimated ratios, then the AR's
      unconstrained parameters $x_i$] (`log10_nvr`, `log10_nvr_se` hold $b$ and its standard errors; `fit.nvr` holds the
      ratios, NaN at the AR's entries); `converged`, `at_bound`, `status`, `reason` as for `jaxsdp.ml_nvr`
      (an AR parameter at its bound: a partial autocorrelation at +-0.9999, the AR at a unit root).
    """

    trend: jnp.ndarray
    trend_se: jnp.ndarray
    perturbation: jnp.ndarray
    perturbation_se: jnp.ndarray
    resid: jnp.ndarray
    ar: jnp.ndarray
    pacf: jnp.ndarray
    nvr: jnp.ndarray
    sigma2: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    definite: jnp.ndarray
    forecast: Forecast
    estimated: jnp.ndarray
    fit: eqx.Module | None = None


def constrain_ar(x):
    """AR coefficients of a stationary AR from unconstrained x (p,): statsmodels' `constrain_stationary_univariate`
    (Monahan 1984): r_k = x_k / sqrt(1 + x_k^2) in (-1, 1), the partial autocorrelations -r_k, Durbin-Levinson."""
    r = x / jnp.sqrt(1.0 + x * x)
    prev = []
    for k in range(x.shape[0]):
        prev = [prev[i] + r[k] * prev[k - i - 1] for i in range(k)] + [r[k]]
    return -jnp.stack(prev)


def ar_pacf(a):
    """Partial autocorrelations (p,) of AR coefficients a (p,) by the step-down Levinson recursion (NumPy or JAX).

    a_i^(k-1) = (a_i^(k) + c_k a_(k-i)^(k)) / (1 - c_k^2), c_k = a_k^(k); the AR is stationary iff every |c_k| < 1.
    """
    xp = np if isinstance(a, np.ndarray) else jnp
    cur = [a[i] for i in range(a.shape[0])]
    out = []
    for k in range(len(cur), 0, -1):
        c = cur[k - 1]
        out.append(c)
        cur = [(cur[i] + c * cur[k - 2 - i]) / (1.0 - c * c) for i in range(k - 1)]
    return xp.stack(out[::-1])


def unconstrain_ar(a):
    """The inverse of `constrain_ar`: x (p,) from stationary AR coefficients a (p,)."""
    c = ar_pacf(a)
    return -c / jnp.sqrt(1.0 - c * c)


def ar_covariance(a):
    """(p, p) stationary covariance of the companion state [e_k, ..., e_(k-p+1)] of e_k = sum a_i e_(k-i) + eta_k,
    var(eta) = 1: the autocovariances g_0..g_p from the (p+1) linear equations g_j - sum_i a_i g_|j-i| = [j = 0]
    (the solution of the discrete Lyapunov equation P = A P A^T + e_1 e_1^T), P_ij = g_|i-j|."""
    p = a.shape[0]
    E = np.zeros((p, p + 1, p + 1))
    for i in range(1, p + 1):
        for j in range(p + 1):
            E[i - 1, j, abs(j - i)] = 1.0
    M = jnp.eye(p + 1) - jnp.tensordot(a, jnp.asarray(E), axes=1)
    g = jnp.linalg.solve(M, jnp.zeros(p + 1).at[0].set(1.0))
    return g[np.abs(np.subtract.outer(np.arange(p), np.arange(p)))]


def _system(tm, a, nvr_trend, P0):
    """F, Q (units of sigma^2), P0 (the diffuse trend's, the AR's stationary) and h of [trend states, AR states]."""
    nT, p = tm.dim, a.shape[0]
    n = nT + p
    A = jnp.zeros((p, p)).at[0].set(a).at[1:, :-1].set(jnp.eye(p - 1))
    F = jnp.zeros((n, n)).at[:nT, :nT].set(tm.transition()).at[nT:, nT:].set(A)
    Q = jnp.zeros((n, n)).at[:nT, :nT].set(tm.noise(nvr_trend)).at[nT, nT].set(1.0)
    P = jnp.zeros((n, n)).at[:nT, :nT].set(P0 * jnp.eye(nT)).at[nT:, nT:].set(ar_covariance(a))
    h = np.zeros(n)
    h[0] = h[nT] = 1.0
    return F, Q, P, h


def _unpack(b, nvr, ar, k, p):
    """The ratios and AR coefficients from the search vector b (the estimated ones) and the given ones."""
    if nvr is None:
        nvr, b = 10.0 ** b[:k], b[k:]
    if ar is None:
        ar = constrain_ar(b[:p])
    return nvr, ar


@eqx.filter_jit
def _univ(y, nvr, ar, b0, P0, tm, p: int, irregular: bool, burn_in: int) -> UnivResult:
    """The search (when b0 is given), the smoother and the result, on y padded with NaNs to its bucket of lengths
    (one compiled program per bucket; `univ` cuts the result's series to the data and the horizon)."""
    k = tm.n_nvr + int(irregular)
    n = tm.dim + p
    x0 = jnp.zeros(n)

    def parts(b):
        v, a = _unpack(b, nvr, ar, k, p)
        F, Q, P, h = _system(tm, a, v[: tm.n_nvr], P0)
        return v, a, F, Q, P, jnp.broadcast_to(jnp.asarray(h), (y.shape[0], n)), v[-1] if irregular else 0.0

    fit = None
    if b0 is not None:

        def criterion(b):
            _, _, F, Q, P, H, r = parts(b)
            return filter_criterion(y, H, F, Q, x0, P, burn_in=burn_in, obs_var=r)

        n_ratio = b0.shape[0] - (p if ar is None else 0)
        lo = np.concatenate([np.full(n_ratio, LOG10_NVR_BOUNDS[0]), np.full(b0.shape[0] - n_ratio, -_U_MAX)])
        hi = np.concatenate([np.full(n_ratio, LOG10_NVR_BOUNDS[1]), np.full(b0.shape[0] - n_ratio, _U_MAX)])
        fit = optimise_log10_nvr(criterion, b0, scale=jnp.sum(~jnp.isnan(y)), bounds=(lo, hi))
        # `fit.nvr` holds ratios only: NaN at the AR's entries (10**x of an unconstrained AR parameter means nothing)
        fit = eqx.tree_at(lambda f: f.nvr, fit, jnp.where(np.arange(b0.shape[0]) < n_ratio, fit.nvr, jnp.nan))
        b = fit.log10_nvr
    else:
        b = jnp.zeros((0,))
    v, a, F, Q, P, H, r = parts(b)
    masks = np.zeros((3, n))
    masks[0, : tm.dim] = masks[1, tm.dim :] = masks[2] = 1.0
    sm = smooth_system(y, H, F, Q, x0, P, masks, burn_in, burn_in, "sequential", obs_var=r)
    # (the signal's variance is 0 to rounding at a sample observed without irregular: not part of the test)
    definite = (
        (jnp.min(sm.state_var) >= 0) & jnp.isfinite(jnp.sum(sm.signal_var)) & (jnp.min(sm.signal_var[:, :2]) >= 0)
    )
    s2 = sm.sigma2
    se = jnp.sqrt(s2 * jnp.clip(sm.signal_var, 0.0))
    forecast = Forecast(y=y, mean=sm.signal[:, 2], se=se[:, 2], obs_se=jnp.sqrt(se[:, 2] ** 2 + r * s2), sigma2=r * s2)
    return UnivResult(
        trend=sm.signal[:, 0],
        trend_se=se[:, 0],
        perturbation=sm.signal[:, 1],
        perturbation_se=se[:, 1],
        resid=y - sm.signal[:, 2],
        ar=a,
        pacf=ar_pacf(a),
        nvr=v,
        sigma2=s2,
        loglik=sm.loglik,
        J=sm.J,
        definite=definite,
        forecast=forecast,
        estimated=jnp.asarray(fit is not None),
        fit=fit,
    )


def _check_ar(ar, p: int, name: str = "ar"):
    a = as_float_array(name, ar, ndim=1)
    if a.shape != (p,):
        raise ValueError(f"`{name}` must have shape ({p},) (one coefficient per lag); got {tuple(a.shape)}")
    a = check_value(name, a, any_nonfinite, "must be finite")
    unstable = "must be a stationary AR (partial autocorrelations in (-1, 1): roots of 1 - sum a_i z^i outside |z| = 1)"
    return check_value(name, a, _nonstationary, unstable)


def _nonstationary(a):
    """Whether AR coefficients a (NumPy or JAX) are not those of a stationary AR (a NaN counts as not)."""
    with np.errstate(all="ignore"):
        return ~(abs(ar_pacf(a)) < 1.0).all()


@x64
def univ(
    y,
    ar_order: int,
    *,
    trend="IRW",
    irregular: bool = False,
    nvr="ml",
    nvr0=None,
    ar=None,
    ar0=None,
    horizon: int = 0,
    P0: float = 1e5,
    burn_in: int | None = None,
) -> UnivResult:
    r"""Trend plus AR(p) perturbations (the toolbox's `univ`/`univopt`), hyperparameters by maximum likelihood.

    Model, for samples $k = 0..N-1$:

    $$ y_k = T_k + e_k (+ \varepsilon_k), \quad e_k = \sum_{i=1}^{p} a_i e_{k-i} + \eta_k,
       \quad \eta_k \sim N(0, \sigma^2), $$

    the trend $T$ one `trend` block (`IRW` by default, a smooth trend; `RW`,
    `LLT`, `SRW`, `Constant`: the models of `jaxsdp.dlr`) whose NVR(s) are
    relative to $\sigma^2$, the AR innovations' variance; $e$ a stationary
    AR(p), the perturbation about the trend; with `irregular=True` a white
    observation noise $\varepsilon_k \sim N(0, NVR_\varepsilon \sigma^2)$ as
    well. This is statsmodels' `UnobservedComponents(level=..., autoregressive=p,
    irregular=...)`: the tests check the likelihoods equal at the same variances.

    State space: [the trend's states, $e_k .. e_{k-p+1}$] (the AR in companion
    form); the trend's prior diffuse ($P_0$ times the identity, as `dhr`), the
    AR's its stationary covariance (the discrete Lyapunov equation's
    solution), so the likelihood is exact; $\sigma^2$ is concentrated out
    and the likelihood skips the first `burn_in` samples (default: the
    trend's states, statsmodels' convention for this model).

    Estimated by default (`nvr="ml"`, `ar=None`), by the BFGS loop of
    `jaxsdp.ml_nvr` with exact forward-mode gradients: the trend's NVR(s)
    and the irregular's ratio as $\log_{10}$, from `nvr0` (by default 1e-4
    for the trend, as `dhr`, and 1 for the irregular: the likelihood is flat
    in $\log_{10}$ of a small ratio, and a search started there stays); the
    AR through its partial autocorrelations $c_i = -x_i / \sqrt{1 + x_i^2}$
    (statsmodels' transform, Monahan 1984: every $x$ gives a stationary AR),
    from `ar0` (by default 0). Give `nvr` values, `ar` coefficients or both
    to fix them.
    `horizon` h forecasts: the trend extrapolated, the AR's mean decaying to
    0 ($a$ iterated), intervals from the filter. NaN samples are
    interpolated by the smoother, with intervals. One filter and one
    smoother pass (`lax.scan`, sequential kernels) at the estimate;
    jit/vmap/grad through it all.

    **Arguments**: `y` (N,) NaN where missing; `ar_order` p >= 1; `trend` a
    model name or instance; `nvr` "ml" or the ratios (the trend's NVR(s),
    then the irregular's); `nvr0` the search's start (None: the defaults
    above; a scalar for all or one per ratio); `ar` None or (p,) stationary
    coefficients, `ar0` the same for the search's start; `horizon` int >= 0;
    `P0` the diffuse prior's variance (units of $\sigma^2$); `burn_in` int.

    **Returns** a `UnivResult` (trend, perturbation, their standard errors,
    AR coefficients, ratios, $\sigma^2$, log-likelihood, `Forecast`).

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(3)
        >>> e = np.zeros(400)
        >>> for k in range(2, 400):                                        # AR(2) perturbations
        ...     e[k] = 1.2 * e[k - 1] - 0.5 * e[k - 2] + 0.1 * rng.normal()
        >>> y = 0.002 * np.arange(400.0) ** 1.5 + e                       # a smooth trend
        >>> res = tvp.univ(y, 2, horizon=20)
        >>> print(bool(res.fit.converged), np.round(np.asarray(res.ar), 2))
        True [ 1.16 -0.48]
        >>> k = [399, 419]                                                 # the last sample, 20 samples ahead
        >>> print(np.round(np.asarray(res.trend)[k], 2), np.round(0.002 * np.array(k) ** 1.5, 2))
        [15.98 17.17] [15.94 17.15]
        >>> print(np.round(np.asarray(res.perturbation)[k], 2))           # the AR part decays toward 0
        [-0.06 -0.  ]
    """
    p = positive_int("ar_order", ar_order)
    if trend is None:
        raise ValueError("`trend` is None: `univ` is a trend plus AR perturbations (for an AR alone, see `dar`)")
    tm = as_model(trend)
    irregular = bool(irregular)
    horizon = nonnegative_int("horizon", horizon)
    y = as_float_array("y", y, ndim=1)
    N = int(y.shape[0])
    n = tm.dim + p
    y, _, P0 = validate_regression(y, jnp.zeros((N, 1)), min_samples=n + 2, carrier=checked_P0(P0))
    P0 = check_observed(y, n, carrier=P0)
    bi = tm.dim if burn_in is None else checked_burn_in(burn_in, N)
    k = tm.n_nvr + int(irregular)
    what = "the trend model's NVRs (one, two for LLT, none for Constant), then the irregular's with irregular=True"
    a_fixed = None if ar is None else _check_ar(ar, p)
    b0 = []
    if isinstance(nvr, str):
        if nvr != "ml":
            raise ValueError(f'`nvr` must be the variance ratios or "ml" (estimate them); got {nvr!r}')
        v_fixed = None
        if k:
            start = nvr0 if nvr0 is not None else np.r_[np.full(tm.n_nvr, 1e-4), np.ones(int(irregular))]
            b0.append(jnp.log10(check_nvr0(nvr_vector("nvr0", start, k, what))))
        elif a_fixed is not None:
            raise ValueError('`nvr="ml"` with `ar` given: the trend is Constant, there is nothing to estimate')
        else:
            v_fixed = jnp.zeros((0,))
    else:
        v_fixed = nvr_vector("nvr", nvr, k, what)
    if a_fixed is None:
        b0.append(jnp.zeros(p) if ar0 is None else unconstrain_ar(_check_ar(ar0, p, "ar0")))
    b0 = jnp.concatenate(b0) if b0 else None
    T, L = N + horizon, bucket_length(N + horizon)  # padded with NaNs: one compilation per bucket of lengths
    res = _univ(pad(y, L - N), v_fixed, a_fixed, b0, P0, tm, p, irregular, bi)
    series = lambda r: (r.trend, r.trend_se, r.perturbation, r.perturbation_se, r.forecast.mean, r.forecast.se)
    res = eqx.tree_at(series, res, tuple(a[:T] for a in series(res)))
    fc = res.forecast
    return eqx.tree_at(lambda r: (r.resid, r.forecast.y, r.forecast.obs_se), res, (res.resid[:N], y, fc.obs_se[:T]))


__all__ = ["MAX_PACF", "UnivResult", "ar_covariance", "ar_pacf", "constrain_ar", "univ", "unconstrain_ar"]
