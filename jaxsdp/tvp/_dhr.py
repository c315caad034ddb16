"""Dynamic harmonic regression: a trend and harmonics of given periods with time-variable amplitudes."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import as_float_array, nonnegative_int
from .._kalman.models import as_model, state_dim
from .._kalman.nvr import check_nvr0, max_log10_nvr
from .._kalman.validate import estimate_name, nvr_vector, validate_regression
from .._runtime import resolve_method, x64
from ._dhr_spectrum import spectral_nvr
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
from ._forecast import Forecast, forecast_from, pad


class DHRResult(eqx.Module):
    r"""Result of `jaxsdp.tvp.dhr`: the components over the N data and the h forecast samples.

    - `periods`: (m,) the harmonics' periods, in samples.
    - `trend`, `trend_se`: (N+h,) the trend $T_k$ and its standard error (zeros without a trend).
    - `cycles`, `cycles_se`: (N+h, m) each harmonic $a_{ik} \cos(\omega_i k) + b_{ik} \sin(\omega_i k)$.
    - `amplitude`: (N+h, m) each harmonic's amplitude $\sqrt{a_{ik}^2 + b_{ik}^2}$.
    - `seasonal`, `seasonal_se`: (N+h,) the sum of the harmonics.
    - `adjusted`: (N,) the seasonally adjusted series $y_k$ - `seasonal` (NaN where y is missing).
    - `resid`: (N,) $y_k$ - trend - seasonal.
    - `innov`, `innov_var`: (N,) the one-step prediction errors $v_k$ (the Kalman filter's $y_k$ minus its
      prediction from the samples before) and their variances $\sigma^2 f_k$, as `jaxsdp.dlr`'s (NaN where y is
      missing): $v_k / \sqrt{\sigma^2 f_k}$ are the standardised errors, about N(0, 1) and white for a model
      that fits, after the first n + 1 (n states), which carry the diffuse start and stay out of the likelihood.
    - `forecast`: the `Forecast` of the whole signal (trend + seasonal): its
      mean and intervals over the data, its gaps and the horizon.
    - `nvr`: the components' NVRs (the trend's first, then each harmonic's: one per harmonic for RW and IRW);
      `nvr_estimated`, `nvr_fit` (the `NVRFit` when estimated, else None).
    - `sigma2`, `loglik`, `J`, `definite`: as `jaxsdp.dlr`.
    """

    periods: jnp.ndarray
    trend: jnp.ndarray
    trend_se: jnp.ndarray
    cycles: jnp.ndarray
    cycles_se: jnp.ndarray
    amplitude: jnp.ndarray
    seasonal: jnp.ndarray
    seasonal_se: jnp.ndarray
    adjusted: jnp.ndarray
    resid: jnp.ndarray
    innov: jnp.ndarray
    innov_var: jnp.ndarray
    forecast: Forecast
    nvr: jnp.ndarray
    sigma2: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    definite: jnp.ndarray
    nvr_estimated: jnp.ndarray
    nvr_fit: eqx.Module | None = None


class _Design(eqx.Module):
    """The regression of a DHR (host-side, static): blocks, regressor columns and their grouping."""

    models: tuple
    index: tuple  # the blocks' NVR slots -> the components' NVRs
    groups: tuple  # block indices of: all, trend, each harmonic, all harmonics
    pairs: tuple  # (first, second or -1) block of each harmonic
    n_nvr: int


def _periods(periods) -> np.ndarray:
    p = np.atleast_1d(np.asarray(periods, dtype=np.float64))
    if p.ndim != 1:
        raise ValueError(f"`periods` must be a sequence of periods (in samples); got shape {p.shape}")
    if not np.all(np.isfinite(p)) or np.any(p < 2.0):
        raise ValueError(
            f"`periods` must be finite and at least 2 samples (a shorter period aliases onto a longer one); got {p}"
        )
    if len(np.unique(p)) != len(p):
        raise ValueError(f"`periods` has a period twice: {p}")
    return p


def _design(trend, cycle, periods, tie: bool = False) -> _Design:
    models, index, groups, pairs = [], [], [], []
    k = 0
    if trend is not None:
        tm = as_model(trend)
        models.append(tm)
        index += list(range(k, k + tm.n_nvr))
        k += tm.n_nvr
    trend_blocks = tuple(range(len(models)))
    cm = as_model(cycle)
    shared = list(range(k, k + cm.n_nvr)) if tie and len(periods) else None
    for p in periods:
        slots = shared or list(range(k, k + cm.n_nvr))
        first = len(models)
        models.append(cm)
        index += slots
        second = -1
        if p != 2.0:  # at the Nyquist period the sine is zero at every sample
            second = len(models)
            models.append(cm)
            index += slots
        pairs.append((first, second))
        k += 0 if shared else cm.n_nvr
    k += cm.n_nvr if shared else 0
    harmonic_blocks = [tuple(b for b in pair if b >= 0) for pair in pairs]
    everything = tuple(range(len(models)))
    groups = (everything, trend_blocks, *harmonic_blocks, tuple(b for h in harmonic_blocks for b in h))
    return _Design(models=tuple(models), index=tuple(index), groups=groups, pairs=tuple(pairs), n_nvr=k)


@x64
def harmonic_regressors(n: int, periods, *, trend: bool = True) -> np.ndarray:
    """(n, q) regressors of a DHR at samples k = 0..n-1: [1,] then cos, sin of 2 pi k / P per period
    (the cosine only at P = 2): `jaxsdp.dlr` on them with one model per column is the DHR with untied NVRs.

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> np.round(tvp.harmonic_regressors(4, [4.0, 2.0]), 3).tolist()
        [[1.0, 1.0, 0.0, 1.0], [1.0, 0.0, 1.0, -1.0], [1.0, -1.0, 0.0, 1.0], [1.0, -0.0, -1.0, -1.0]]
    """
    k = np.arange(n, dtype=np.float64)
    cols = [np.ones(n)] if trend else []
    for p in _periods(periods):
        w = 2.0 * np.pi / p
        cols.append(np.cos(w * k))
        if p != 2.0:
            cols.append(np.sin(w * k))
    return np.stack(cols, axis=1) if cols else np.zeros((n, 0))


def _spectral_start(y, periods, design) -> np.ndarray:
    """log10 NVRs of the DHR fitted to the AR spectrum of the data (`_dhr_spectrum.spectral_nvr`)."""
    omegas = [0.0] * (len(design.models) - sum(1 if s < 0 else 2 for _, s in design.pairs))
    for (_, s), p in zip(design.pairs, periods, strict=True):
        omegas += [2.0 * np.pi / p] * (1 if s < 0 else 2)
    return spectral_nvr(np.asarray(y), design.models, design.index, omegas, design.n_nvr)[0]


#: The fixed start of `dhr`'s NVR search with `nvr0="auto"` (the other is the frequency-domain estimate).
AUTO_NVR0 = 1e-4

#: What the entries of a DHR's NVR vector are (for the shape error).
_WHAT = (
    "the trend model's NVRs (one, two for LLT, none for Constant), then the cycle model's for each period "
    "(once for all periods with tie_periods=True)"
)


@x64
def dhr(
    y,
    periods,
    *,
    trend="IRW",
    cycle="RW",
    nvr="ml",
    nvr0="auto",
    tie_periods: bool = False,
    horizon: int = 0,
    P0: float = 1e5,
    burn_in: int | None = None,
    method: str | None = None,
) -> DHRResult:
    r"""Dynamic harmonic regression: trend plus harmonics with time-variable amplitudes, NVRs by maximum likelihood.

    Model, for samples $k = 0..N-1$ and periods $P_i$ (in samples, $\omega_i = 2\pi / P_i$):

    $$ y_k = T_k + \sum_i ( a_{ik} \cos(\omega_i k) + b_{ik} \sin(\omega_i k) ) + e_k,
       \quad e_k \sim N(0, \sigma^2), $$

    the trend $T$ one `trend` block (`IRW` by default: a smooth trend; `RW`,
    `LLT`, `Constant`, or None for no trend), each harmonic's $a_i$ and $b_i$
    two `cycle` blocks (`RW` by default) that share one NVR (so the model of
    a harmonic does not depend on its phase: with RW amplitudes it is
    statsmodels' stochastic trigonometric seasonal, rotated). At $P_i = 2$
    the sine is dropped (zero at every sample). This is `jaxsdp.dlr` on the
    regressors $[1, \cos\omega_1 k, \sin\omega_1 k, ...]$ with tied NVRs.

    The NVRs (one for the trend, two for an `LLT` trend, then one per
    period, or one for all periods with `tie_periods=True`: statsmodels'
    trigonometric seasonal with one variance for all its harmonics, which
    lets the seasonal shape drift less freely) are estimated by maximum likelihood by default (`nvr="ml"`, from
    `nvr0`): the concentrated likelihood of `jaxsdp.ml_nvr`, exact gradients,
    every NVR in the search's bounds (see `NVRFit`). Give `nvr` values to
    skip the search. `nvr="spectrum"` is the frequency-domain estimate alone
    (the toolbox's `dhropt` default, Young, Pedregal & Tych 1999): the log of
    the model's pseudo-spectrum σ² (1 + Σ NVR_j g_j(ω)) fitted by least
    squares to the log of the AR spectrum (Burg, order by AIC) of the
    differenced series (NaN samples interpolated linearly for it), no
    likelihood search. The likelihood can have more than one optimum in the
    NVRs (on the weekly CO2 record, `benchmarks/dhr.py --weekly`, the search
    from 1e-4 stops at a lower one than the search from the spectrum), so
    the default `nvr0="auto"` searches from both, 1e-4 for every NVR
    and the frequency-domain estimate, and keeps the higher likelihood
    (`nvr_fit` is that search's; twice the time of one search);
    `nvr0="spectrum"` or NVR values search from that one start only.
    `horizon` forecasts h samples beyond the data;
    NaN samples of `y` are interpolated; every component comes with its
    standard error from the smoother.

    **Arguments**: `y` (N,) NaN where missing; `periods` a sequence of
    periods in samples, each finite, >= 2 and distinct (a monthly series'
    annual cycle and its harmonics: 12, 6, 4, 3, 2.4, 2); `horizon` an int >=
    0; `P0`, `burn_in`, `method` as `jaxsdp.dlr`.

    **Returns** a `DHRResult` (trend, cycles, amplitude, seasonal,
    adjusted, the `Forecast`, NVRs, $\sigma^2$, log-likelihood).

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(1)
        >>> k = np.arange(240.0)
        >>> amp = 1.0 + k / 240.0                                      # a growing annual cycle
        >>> y = 0.02 * k + amp * np.cos(2 * np.pi * k / 12) + 0.2 * rng.normal(size=240)
        >>> res = tvp.dhr(y, [12.0], horizon=24)
        >>> print(bool(res.nvr_fit.converged), np.round(np.asarray(res.amplitude)[[12, 228], 0], 1))
        True [1.1 1.9]
        >>> lo, hi = res.forecast.interval(0.95)                         # the last forecast's 95 % interval
        >>> print(res.forecast.horizon, np.round([lo[-1], res.forecast.mean[-1], hi[-1]], 2))
        24 [6.43 6.86 7.29]
    """
    m = resolve_method(method)
    periods = _periods(periods)
    if not isinstance(tie_periods, bool):
        raise ValueError(f"`tie_periods` must be True or False; got {tie_periods!r}")
    design = _design(trend, cycle, periods, tie_periods)
    if not design.models:
        raise ValueError("nothing to fit: `trend` is None and `periods` is empty")
    horizon = nonnegative_int("horizon", horizon)
    y = as_float_array("y", y, ndim=1)
    N = int(y.shape[0])
    if len(periods) and periods.max() > N:
        raise ValueError(
            f"`periods`: {periods.max():g} samples is longer than the data ({N} samples): a harmonic that does not "
            "complete one cycle cannot be told apart from the trend"
        )
    T, L = N + horizon, bucket_length(N + horizon)  # padded with NaNs: one compilation per bucket of lengths
    z_all = jnp.asarray(harmonic_regressors(L, periods, trend=trend is not None))
    z = z_all[:N]
    n = state_dim(design.models)
    y, z, P0 = validate_regression(y, z, min_samples=n + 2, carrier=checked_P0(P0))
    P0 = check_observed(y, n, carrier=P0)
    bi = n + 1 if burn_in is None else checked_burn_in(burn_in, N)
    x0 = jnp.zeros(n)
    fit = None
    if estimate_name(nvr, design.n_nvr, estimates=("ml", "spectrum")):
        auto = isinstance(nvr0, str) and nvr0 == "auto"
        if nvr == "spectrum" or (isinstance(nvr0, str) and nvr0 == "spectrum"):
            b0 = jnp.asarray(_spectral_start(y, periods, design))
        elif isinstance(nvr0, str) and not auto:
            raise ValueError(f'`nvr0` must be NVR values, "spectrum" or "auto"; got {nvr0!r}')
        else:
            b0 = jnp.log10(check_nvr0(nvr_vector("nvr0", AUTO_NVR0 if auto else nvr0, design.n_nvr, _WHAT)))
        if nvr == "ml":

            def search(start):
                return fit_tied_nvr(
                    pad(y, L - N), z_all, start, P0, x0, design.models, design.index, bi, max_log10_nvr(None), m
                )

            fit = search(b0)
            if auto and len(periods):  # the second start (a trend alone has no spectral start of its own)
                other = search(jnp.asarray(_spectral_start(y, periods, design)))
                better = jnp.isfinite(other.J) & (other.J < fit.J)
                fit = jax.tree.map(lambda a, b: jnp.where(better, a, b), other, fit)
            nvr_c = fit.nvr
        else:
            nvr_c = 10.0**b0
    else:
        nvr_c = nvr_vector("nvr", nvr, design.n_nvr, _WHAT)
    nvr_blocks = nvr_c[np.asarray(design.index, dtype=int)] if design.n_nvr else jnp.zeros((0,))
    masks = block_masks(design.models, design.groups)
    sm = head(smooth_components(pad(y, L - N), z_all, nvr_blocks, P0, x0, design.models, masks, bi, n, m), T)
    se = jnp.sqrt(sm.sigma2 * jnp.clip(sm.signal_var, 0.0))
    n_h = len(periods)
    starts = np.cumsum([0] + [b.dim for b in design.models])
    a = jnp.stack([sm.state[:, starts[f]] for f, _ in design.pairs], axis=1) if n_h else jnp.zeros((T, 0))
    b = (
        jnp.stack([sm.state[:, starts[s]] if s >= 0 else jnp.zeros(T) for _, s in design.pairs], axis=1)
        if n_h
        else jnp.zeros((T, 0))
    )
    seasonal = sm.signal[:, -1]
    return DHRResult(
        periods=jnp.asarray(periods),
        trend=sm.signal[:, 1],
        trend_se=se[:, 1],
        cycles=sm.signal[:, 2 : 2 + n_h],
        cycles_se=se[:, 2 : 2 + n_h],
        amplitude=jnp.sqrt(a**2 + b**2),
        seasonal=seasonal,
        seasonal_se=se[:, -1],
        adjusted=y - seasonal[:N],
        resid=y - sm.signal[:N, 0],
        innov=sm.innov[:N],
        innov_var=sm.sigma2 * sm.innov_var[:N],
        forecast=forecast_from(y, sm, 0),
        nvr=nvr_c,
        sigma2=sm.sigma2,
        loglik=sm.loglik,
        J=sm.J,
        definite=sm.definite,
        nvr_estimated=jnp.asarray(fit is not None),
        nvr_fit=fit,
    )


__all__ = ["DHRResult", "dhr", "harmonic_regressors"]
