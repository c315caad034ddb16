"""Dynamic AR and ARX models (time-variable coefficients as random walks) and their time-frequency spectrum."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._checks import as_float_array, check_finite, is_concrete, nonnegative_int, positive_int
from .._kalman.models import as_model, state_dim
from .._kalman.nvr import check_nvr0, max_log10_nvr
from .._kalman.validate import estimate_name, nvr_vector, validate_regression
from .._runtime import resolve_method, x64
from ._engine import (
    block_masks,
    bucket_length,
    check_observed,
    checked_burn_in,
    checked_P0,
    fit_tied_nvr,
    head,
    smooth_components,
)
from ._forecast import Forecast


class DARResult(eqx.Module):
    r"""Result of `jaxsdp.tvp.dar` and `jaxsdp.tvp.darx`.

    Model:

    $$ y_k - \bar y = \sum_{i=1}^{n_a} \phi_{ik} (y_{k-i} - \bar y) + \sum_{j=0}^{n_b-1} \beta_{jk} u_{k-d-j} + e_k $$

    - `coef`, `coef_se`: (N, n_a + n_b) the smoothed coefficients $\phi_1..\phi_{n_a}$ then
      $\beta_0..\beta_{n_b-1}$, and their standard errors.
    - `na`: the AR order (the first `na` columns of `coef`); `start`: the first sample with all its lags
      (the samples before it have no fit).
    - `mean`: $\bar y$, the mean removed from y first (0 with `demean=False`).
    - `fit`: (N,) the one-step fit $\sum \phi_{ik} (y_{k-i} - \bar y) + ...$ + $\bar y$ (NaN where a lag or
      $y_k$ is missing);
      `resid`: y - fit.
    - `nvr`, `nvr_estimated`, `nvr_fit`, `sigma2`, `loglik`, `J`, `definite`: as `jaxsdp.dlr`.
    - `forecast`: the `Forecast`: the one-step fit and its standard error over the data, then (`dar(...,
      horizon=h)`, `darx(..., u_future=...)`) the AR(X) iterated h steps beyond it with the last coefficients.
    """

    coef: jnp.ndarray
    coef_se: jnp.ndarray
    na: int = eqx.field(static=True)
    start: int = eqx.field(static=True)
    mean: jnp.ndarray
    fit: jnp.ndarray
    resid: jnp.ndarray
    nvr: jnp.ndarray
    sigma2: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    definite: jnp.ndarray
    nvr_estimated: jnp.ndarray
    nvr_fit: eqx.Module | None = None
    forecast: Forecast | None = None


class Spectrum(eqx.Module):
    r"""The time-frequency spectrum of a dynamic AR model (`jaxsdp.tvp.darsp`).

    - `freq`: (F,) frequencies, in cycles per sample times 1/`dt` (Hz when `dt` is in seconds).
    - `power`: (N, F) $\sigma^2 \Delta t / |1 - \sum_i \phi_{ik} e^{-j 2\pi f \Delta t i}|^2$ at each sample k
      (NaN before the first sample with its lags; over gaps, from the smoothed coefficients).
    - `peak`: (N,) the frequency of the highest power at each sample.
    """

    freq: jnp.ndarray
    power: jnp.ndarray
    peak: jnp.ndarray

    @x64
    def plot(self, ax=None, *, t=None, db: bool = True):
        """The spectrum over time as an image (dB by default), the peak frequency drawn on it; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 3.5))
        power = np.asarray(self.power)
        n = power.shape[0]
        t = np.arange(n) if t is None else np.asarray(t)
        if t.shape != (n,):
            raise ValueError(f"`t` must have shape ({n},); got {t.shape}")
        with np.errstate(divide="ignore", invalid="ignore"):
            img = 10.0 * np.log10(power) if db else power
        freq = np.asarray(self.freq)
        mesh = ax.pcolormesh(t, freq, img.T, shading="auto", cmap="viridis")
        ax.plot(t, np.asarray(self.peak), color="w", lw=0.8, ls="--", label="peak")
        ax.set_ylabel("frequency")
        ax.figure.colorbar(mesh, ax=ax, label="power (dB)" if db else "power")
        ax.legend(loc="upper right", fontsize=8)
        return ax


def _lagged(yd, u, na, nb, delay):
    """Target and regressors of the (AR)X regression: rows whose lags are missing get a NaN target and zeros."""
    N = yd.shape[0]
    cols = []
    for i in range(1, na + 1):
        cols.append(jnp.concatenate([jnp.full((i,), jnp.nan), yd[: N - i]]))
    for j in range(nb):
        lag = delay + j
        cols.append(jnp.concatenate([jnp.full((lag,), jnp.nan), u[: N - lag]]) if lag else u)
    Z = jnp.stack(cols, axis=1)
    missing = jnp.any(jnp.isnan(Z), axis=1)
    return jnp.where(missing, jnp.nan, yd), jnp.where(jnp.isnan(Z), 0.0, Z)


def _fit(y, u, na, nb, delay, model, nvr, nvr0, tied, demean, P0, burn_in, method, horizon=0, u_future=None):
    """The DAR/DARX estimate (`dar` and `darx` call it)."""
    m = resolve_method(method)
    y = as_float_array("y", y, ndim=1)
    N = int(y.shape[0])
    p = na + nb
    if N < 2 * (p + delay) + 4:
        raise ValueError(f"`y` has {N} samples; the model needs at least {2 * (p + delay) + 4}")
    if u is None:
        u = jnp.zeros((N,))
    _, _, P0 = validate_regression(y, jnp.zeros((N, 1)), min_samples=1, carrier=checked_P0(P0))
    mu = jnp.nanmean(y) if demean else jnp.zeros(())
    target, Z = _lagged(y - mu, u, na, nb, delay)
    start = max(na, delay + nb - 1)  # the first sample with all its lags
    models = (as_model(model),) * p
    k = models[0].n_nvr
    n_nvr = k if tied else k * p
    index = tuple(list(range(k)) * p) if tied else tuple(range(k * p))
    n = state_dim(models)
    P0 = check_observed(target, n, carrier=P0)
    L = bucket_length(N)  # NaN padding: one compilation per bucket of lengths
    yy = jnp.concatenate([target, jnp.full((L - N,), jnp.nan)])
    zz = jnp.concatenate([Z, jnp.zeros((L - N, p))])
    # the likelihood skips the first dim(s) + 1 observed samples that have their lags (dlr's convention: rows without
    # their lags are missing samples, which the burn-in does not count)
    bi = n + 1 if burn_in is None else checked_burn_in(burn_in, N)
    fit = None
    what = "one NVR per coefficient, or one with tied=True"
    if estimate_name(nvr, k, unit="coefficient"):
        b0 = jnp.log10(check_nvr0(nvr_vector("nvr0", nvr0, n_nvr, what)))
        fit = fit_tied_nvr(yy, zz, b0, P0, jnp.zeros(n), models, index, bi, max_log10_nvr(None), m)
        nvr_c = fit.nvr
    else:
        nvr_c = nvr_vector("nvr", nvr, n_nvr, what)
    masks = block_masks(models, [tuple(range(p))])
    nvr_b = nvr_c[np.asarray(index)] if n_nvr else jnp.zeros((0,))
    sm = head(smooth_components(yy, zz, nvr_b, P0, jnp.zeros(n), models, masks, bi, n, m), N)
    first = np.cumsum([0] + [b.dim for b in models])[:-1]
    coef = sm.state[:, first]
    fitted = jnp.where(jnp.isnan(target), jnp.nan, sm.signal[:, 0] + mu)
    exo = None
    if u_future is not None:  # the inputs' part of each forecast: sum_j beta_j u_{N+i-d-j}, from u or u_future
        horizon = int(u_future.shape[0])
        idx = N + np.arange(horizon)[:, None] - delay - np.arange(nb)[None, :]
        exo = jnp.concatenate([u, u_future])[idx] @ coef[-1, na:]
    return DARResult(
        coef=coef,
        coef_se=jnp.sqrt(sm.sigma2 * jnp.clip(sm.state_var[:, first], 0.0)),
        na=na,
        start=start,
        mean=mu,
        fit=fitted,
        resid=y - fitted,
        nvr=nvr_c,
        sigma2=sm.sigma2,
        loglik=sm.loglik,
        J=sm.J,
        definite=sm.definite,
        nvr_estimated=jnp.asarray(fit is not None),
        nvr_fit=fit,
        forecast=_ar_forecast(y, fitted, sm, coef[-1, :na], mu, horizon, exo),
    )


def _ar_forecast(y, fitted, sm, phi, mu, horizon: int, exo=None) -> Forecast:
    """The one-step fit over the data, then the AR(X) iterated `horizon` steps with the last coefficients.

    Beyond the data: x_{N+j} = sum_i phi_i x_{N+j-i} + exo_j (deviations from the mean; `exo` (h,) the known
    inputs' part, None for none), the companion form's covariance P_j = A P_{j-1} A^T + sigma^2 e_1 e_1^T from
    P_0 = 0 (the last lags known; the inputs add no variance): a new value's variance P_j[0, 0], the forecast's
    own sigma^2 less (the coefficients' uncertainty is not included).
    """
    s2 = sm.sigma2
    var_in = jnp.where(jnp.isnan(fitted), jnp.nan, s2 * jnp.clip(sm.signal_var[:, 0], 0.0))
    if horizon == 0:
        return Forecast(y=y, mean=fitted, se=jnp.sqrt(var_in), obs_se=jnp.sqrt(var_in + s2), sigma2=s2)
    p = phi.shape[0]
    past = y[::-1][:p] - mu
    if p == 0:  # no AR part (darx with na = 0): one state whose coefficient is 0
        phi, past, p = jnp.zeros(1), jnp.zeros(1), 1
    A = jnp.zeros((p, p)).at[0].set(phi).at[1:, :-1].set(jnp.eye(p - 1))
    e1 = jnp.zeros(p).at[0].set(1.0)
    exo = jnp.zeros(horizon) if exo is None else exo

    def step(carry, ex):
        x, P = carry
        x = A @ x + ex * e1
        P = A @ P @ A.T + s2 * jnp.outer(e1, e1)
        return (x, P), (x[0], P[0, 0])

    _, (mean_f, var_f) = lax.scan(step, (past, jnp.zeros((p, p))), exo)
    mean = jnp.concatenate([fitted, mean_f + mu])
    se = jnp.concatenate([jnp.sqrt(var_in), jnp.sqrt(jnp.clip(var_f - s2, 0.0))])
    obs = jnp.concatenate([jnp.sqrt(var_in + s2), jnp.sqrt(var_f)])
    return Forecast(y=y, mean=mean, se=se, obs_se=obs, sigma2=s2)


def _check_last_observed(y, n: int, name: str) -> None:
    """The last n samples of y (the forecast's first lags) must be observed (checked when y is concrete)."""
    last = y[y.shape[0] - n :]
    if n and is_concrete(last) and not np.all(np.isfinite(np.asarray(last))):
        raise ValueError(f"`{name}`: the last {n} samples of `y` (the forecast's first lags) must be observed")


@x64
def dar(
    y,
    order: int,
    *,
    model="RW",
    nvr="ml",
    nvr0=1e-4,
    tied: bool = False,
    demean: bool = True,
    P0: float = 1e5,
    burn_in: int | None = None,
    horizon: int = 0,
    method: str | None = None,
) -> DARResult:
    r"""Dynamic autoregression: AR coefficients that vary in time as random walks, NVRs by maximum likelihood.

    Model, with $\bar y$ the mean of the observed samples (`demean`):

    $$ y_k - \bar y = \sum_{i=1}^{p} \phi_{ik} (y_{k-i} - \bar y) + e_k, \quad e_k \sim N(0, \sigma^2), $$

    each $\phi_i$ a `model` block (`RW` by default; `IRW` for smoother
    coefficients) with its own NVR, or one NVR shared by all with
    `tied=True` (fewer hyperparameters for a high order). This is
    `jaxsdp.dlr` on the lagged series; a sample whose lags are missing (the
    first p, and p after each NaN) is skipped. Remove a trend first (e.g.
    `dhr`'s): the model is of a stationary-looking series. `darsp` gives its
    spectrum at every sample.

    **Arguments**: `y` (N,) NaN where missing; `order` p >= 1; `nvr` values
    (one per coefficient, or one with `tied`) or `"ml"` from `nvr0`; `P0`,
    `burn_in`, `method` as `jaxsdp.dlr`.

    `horizon` h >= 0: forecasts h samples beyond the data (`forecast`), the
    AR iterated with the last coefficients (their random walks' expected
    value), intervals from the companion form (the coefficients' own
    uncertainty not included); the last p samples must be observed.

    **Returns** a `DARResult` (`coef` (N, p), `coef_se`, `fit`, `resid`, NVRs, $\sigma^2$, `forecast`).

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(0)
        >>> phi = np.linspace(0.9, -0.5, 600)                   # a drifting AR(1) coefficient
        >>> y = np.zeros(600)
        >>> for k in range(1, 600):
        ...     y[k] = phi[k] * y[k - 1] + rng.normal()
        >>> res = tvp.dar(y, 1)
        >>> print(np.round(np.asarray(res.coef)[[100, 300, 500], 0], 1))
        [ 0.7  0.1 -0.3]
    """
    order = positive_int("order", order)
    horizon = nonnegative_int("horizon", horizon)
    if horizon:
        _check_last_observed(as_float_array("y", y, ndim=1), order, "horizon")
    return _fit(y, None, order, 0, 0, model, nvr, nvr0, tied, demean, P0, burn_in, method, horizon)


@x64
def darx(
    y,
    u,
    *,
    na: int,
    nb: int,
    delay: int = 0,
    model="RW",
    nvr="ml",
    nvr0=1e-4,
    tied: bool = False,
    demean: bool = True,
    P0: float = 1e5,
    burn_in: int | None = None,
    u_future=None,
    method: str | None = None,
) -> DARResult:
    r"""Dynamic ARX: AR and input coefficients that vary in time as random walks, NVRs by maximum likelihood.

    Model:

    $$ y_k - \bar y = \sum_{i=1}^{n_a} \phi_{ik} (y_{k-i} - \bar y) + \sum_{j=0}^{n_b-1} \beta_{jk} u_{k-d-j} + e_k $$

    $d$ the `delay` in samples, the coefficients `model` blocks with their
    NVRs as in `jaxsdp.tvp.dar`. Least squares on these regressors is biased
    when the noise is not white (the lagged outputs carry it, and with
    coloured noise the maximum-likelihood NVRs also grow to follow it): for
    a system whose coefficients are constant, `jaxsdp.tfest.rivbj` estimates
    them without that bias.

    **Arguments**: `y` (N,), `u` (N,) finite; `na` >= 0, `nb` >= 1, `delay` >= 0; the rest as `dar`.

    `u_future` (h,) finite, the input over the h samples beyond the data, or
    None (no forecast): forecasts h = len(u_future) samples ahead
    (`forecast`), the ARX iterated with the last coefficients and the known
    inputs (u_{N+j-d-i} from `u` where that sample is in the data, from
    `u_future` beyond; with d >= h, `u_future` sets only the horizon),
    intervals from the AR part's companion form as `dar`'s (the inputs add no
    variance; the coefficients' own uncertainty is not included); the last
    `na` samples of `y` must be observed.

    **Returns** a `DARResult` (`coef` columns $\phi_1..\phi_{n_a}, \beta_0..\beta_{n_b-1}$, `forecast`).

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(1)
        >>> u = rng.normal(size=800)
        >>> gain = np.where(np.arange(800) < 400, 1.0, 2.0)      # the input gain doubles at k = 400
        >>> y = np.zeros(800)
        >>> for k in range(1, 800):
        ...     y[k] = 0.5 * y[k - 1] + gain[k] * u[k - 1] + 0.1 * rng.normal()
        >>> res = tvp.darx(y, u, na=1, nb=1, delay=1, u_future=np.ones(3))   # and 3 samples ahead, u = 1
        >>> print(np.round(np.asarray(res.coef)[[200, 600]], 2))
        [[0.5  1.  ]
         [0.5  2.03]]
        >>> print(np.round(np.asarray(res.forecast.mean)[-3:], 2))
        [-0.2   1.78  2.76]
    """
    na = int(na)
    if na < 0:
        raise ValueError(f"`na` must be >= 0; got {na}")
    nb = positive_int("nb", nb)
    delay = int(delay)
    if delay < 0:
        raise ValueError(f"`delay` must be >= 0; got {delay}")
    y = as_float_array("y", y, ndim=1)
    u = check_finite("u", as_float_array("u", u, ndim=1))
    if u.shape != y.shape:
        raise ValueError(f"`u` must have the shape of `y` {tuple(y.shape)}; got {tuple(u.shape)}")
    if u_future is not None:
        u_future = check_finite("u_future", as_float_array("u_future", u_future, ndim=1))
        _check_last_observed(y, na, "u_future")
    return _fit(y, u, na, nb, delay, model, nvr, nvr0, tied, demean, P0, burn_in, method, u_future=u_future)


@x64
def darsp(result: DARResult, *, n_freq: int = 256, dt: float = 1.0) -> Spectrum:
    r"""The time-frequency spectrum of a dynamic AR model: the AR spectrum at every sample.

    $$ S_k(f) = \sigma^2 \Delta t / |1 - \sum_{i=1}^{p} \phi_{ik} e^{-j 2\pi f \Delta t i}|^2, $$

    from the smoothed coefficients of `jaxsdp.tvp.dar` (or the AR part of
    `darx`), at `n_freq` frequencies from 0 to the Nyquist $1 / (2 \Delta t)$
    (`dt` the sample time: 1 gives cycles per sample). `peak` is the
    frequency of highest power at each sample: the instantaneous frequency of
    a resonance that moves.

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(2)
        >>> theta = 2 * np.pi * np.linspace(0.05, 0.2, 2000)       # a resonance sweeping 0.05 -> 0.2 cycles/sample
        >>> y = np.zeros(2000)
        >>> for k in range(2, 2000):
        ...     y[k] = 2 * 0.95 * np.cos(theta[k]) * y[k - 1] - 0.95**2 * y[k - 2] + rng.normal()
        >>> sp = tvp.darsp(tvp.dar(y, 2), dt=1.0)
        >>> print(np.round(np.asarray(sp.peak)[[500, 1000, 1500]], 2))
        [0.09 0.12 0.16]
    """
    if not isinstance(result, DARResult):
        raise ValueError(f"`result` must be a DARResult (from jaxsdp.tvp.dar or darx); got {type(result).__name__}")
    n_freq = positive_int("n_freq", n_freq)
    dt = float(dt)
    if not (dt > 0.0 and np.isfinite(dt)):
        raise ValueError(f"`dt` must be finite and positive; got {dt}")
    if result.na == 0:
        raise ValueError("`result` has no AR part (na = 0): its spectrum is flat")
    freq = jnp.linspace(0.0, 0.5 / dt, n_freq)
    phi = result.coef[:, : result.na]
    lags = jnp.arange(1, result.na + 1)
    e = jnp.exp(-2j * jnp.pi * freq[:, None] * dt * lags[None, :])  # (F, p)
    A = 1.0 - phi.astype(jnp.complex128) @ e.T  # (N, F)
    power = result.sigma2 * dt / jnp.abs(A) ** 2
    valid = (jnp.arange(phi.shape[0]) >= result.start)[:, None]
    power = jnp.where(valid, power, jnp.nan)
    peak = jnp.where(valid[:, 0], freq[jnp.argmax(jnp.where(valid, power, -jnp.inf), axis=1)], jnp.nan)
    return Spectrum(freq=freq, power=power, peak=peak)


__all__ = ["DARResult", "Spectrum", "dar", "darsp", "darx"]
