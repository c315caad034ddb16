"""Forecasts and interpolation with intervals: the `Forecast` result and `dlr_forecast`."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import scipy  # scipy.stats loads on first use

from .._checks import as_float_array, check_finite
from .._kalman.models import as_models, n_hyper, state_dim
from .._kalman.nvr import check_nvr0, max_log10_nvr
from .._kalman.validate import estimate_name, validate_dlr_args, validate_nvr
from .._runtime import resolve_method, x64
from ._engine import block_masks, bucket_length, fit_tied_nvr, head, smooth_components


class Forecast(eqx.Module):
    r"""A series' signal estimated over its samples, its gaps and a horizon beyond its end, with intervals.

    For samples $k = 0..N+h-1$ ($N$ data, $h$ the `horizon`):

    - `y`: (N,) the data (NaN where missing).
    - `mean`: (N+h,) $E[\hat y_k | y_{1..N}]$, the signal ($h_k s_{k|N}$, without
      the observation noise): the fixed-interval smoother's estimate over the
      data and its gaps (interpolation), the Kalman filter's $k$-step-ahead
      prediction beyond sample N (the smoother adds nothing there).
    - `se`: (N+h,) the signal's standard error $\sqrt{\sigma^2 h_k P_{k|N} h_k^T}$.
    - `obs_se`: (N+h,) a new observation's $\sqrt{se_k^2 + \sigma^2}$: the
      prediction interval for a value of the series, not only its signal.
    - `sigma2`: the observation noise variance (estimated, in units of $y^2$).

    The intervals are Gaussian: the Kalman filter's, with the NVRs and
    $\sigma^2$ taken as known (their estimation uncertainty is not included).
    `interval`, `filled` and `plot` are host-side (NumPy): call them on a
    result, not inside `jax.jit`.
    """

    y: jnp.ndarray
    mean: jnp.ndarray
    se: jnp.ndarray
    obs_se: jnp.ndarray
    sigma2: jnp.ndarray

    @property
    @x64
    def horizon(self) -> int:
        """Number of samples forecast beyond the data."""
        return int(self.mean.shape[0] - self.y.shape[0])

    @x64
    def interval(self, level: float = 0.95, *, observation: bool = True):
        r"""(lower, upper), (N+h,) each: `mean` $\pm z_{(1+level)/2}$ `obs_se` (a new value of the series),
        or $\pm z$ `se` with `observation=False` (the signal)."""
        if not 0.0 < float(level) < 1.0:
            raise ValueError(f"`level` must lie in (0, 1); got {level!r}")
        q = float(scipy.stats.norm.ppf(0.5 + 0.5 * float(level)))
        mean = np.asarray(self.mean)
        half = q * np.asarray(self.obs_se if observation else self.se)
        return mean - half, mean + half

    @property
    @x64
    def filled(self):
        """(N,) the data with each missing sample replaced by its interpolation (`mean`)."""
        y = np.asarray(self.y)
        return np.where(np.isnan(y), np.asarray(self.mean)[: y.shape[0]], y)

    @x64
    def plot(self, ax=None, *, level: float = 0.95, start: int = 0, t=None):
        """Draw the data, the estimate and its `level` prediction interval from sample `start`; returns the axes.

        `t`: (N+h,) the time of each sample (default: the sample index).
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 3.2))
        n, total = self.y.shape[0], self.mean.shape[0]
        t = np.arange(total) if t is None else np.asarray(t)
        if t.shape != (total,):
            raise ValueError(f"`t` must have shape ({total},) (data and horizon); got {t.shape}")
        lo, hi = self.interval(level)
        sl = slice(start, total)
        ax.fill_between(t[sl], lo[sl], hi[sl], color="C0", alpha=0.2, lw=0, label=f"{100 * level:.0f} % interval")
        ax.plot(t[start:n], np.asarray(self.y)[start:], ".", ms=3, color="k", label="data")
        ax.plot(t[sl], np.asarray(self.mean)[sl], color="C0", lw=1.2, label="estimate")
        if total > n:
            ax.axvline(t[n - 1], color="0.5", lw=0.8, ls="--")
        ax.legend(loc="best", fontsize=8)
        return ax


def forecast_from(y, smoothed, column: int = 0) -> Forecast:
    """The `Forecast` of the `column`-th component of `smooth_components`' result (internal)."""
    s2 = smoothed.sigma2
    var = jnp.clip(smoothed.signal_var[:, column], 0.0)
    return Forecast(
        y=y,
        mean=smoothed.signal[:, column],
        se=jnp.sqrt(s2 * var),
        obs_se=jnp.sqrt(s2 * (var + 1.0)),
        sigma2=s2,
    )


def pad(y, horizon: int):
    """y followed by `horizon` NaNs (the samples to forecast)."""
    return jnp.concatenate([y, jnp.full((horizon,), jnp.nan)])


@x64
def dlr_forecast(y, z, *, z_future=None, model="RW", nvr=None, P0: float = 1e5, method: str | None = None) -> Forecast:
    r"""Forecasts and interpolation of a dynamic linear regression (`jaxsdp.dlr`'s model) with intervals.

    Model: $y_k = \sum_i z_{ik} \theta_{ik} + e_k$, the $\theta_i$ random-walk-family
    parameters (see `jaxsdp.dlr`). The forecast $h$ samples ahead needs the
    regressors there, `z_future` (h, p) (known inputs, a constant, harmonics):
    $\hat y_{N+j} = z_{N+j} \theta_{N+j|N}$, the Kalman filter's prediction, with
    variance $\sigma^2 (z_{N+j} P_{N+j|N} z_{N+j}^T)$ for the signal and
    $\sigma^2$ more for an observation. Missing samples of `y` (NaN) are
    interpolated by the fixed-interval smoother, with the smoother's
    intervals. One filter and one smoother pass over $N + h$ samples.

    **Arguments**: `y` (N,), NaN where missing; `z` (N, p) finite; `z_future`
    (h, p) or None (no horizon: interpolation only); `model`, `P0`, `method`
    as `jaxsdp.dlr`; `nvr` the NVRs (one per NVR of each block) or `"ml"`
    (maximum likelihood on the data first, `jaxsdp.ml_nvr`'s search).

    **Returns** a `Forecast` (`mean`, `se`, `obs_se` over N + h samples;
    `interval(level)`, `filled`, `plot()`).

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(0)
        >>> y = 0.5 * np.arange(100.0) + rng.normal(size=100)    # a line, slope 0.5
        >>> y[40:45] = np.nan                                     # a gap
        >>> fc = tvp.dlr_forecast(y, np.ones((100, 1)), z_future=np.ones((10, 1)), model="IRW", nvr=1e-6)
        >>> mean, se = np.asarray(fc.mean), np.asarray(fc.obs_se)
        >>> print(fc.horizon, np.round(mean[[42, 109]], 1), np.round(se[[42, 109]], 2))
        10 [21.1 54.6] [0.97 1.  ]
    """
    m = resolve_method(method)
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    h = 0
    if z_future is not None:
        zf = check_finite("z_future", as_float_array("z_future", z_future, ndim=2))
        if zf.shape[1] != z.shape[1]:
            raise ValueError(f"`z_future` must have the {z.shape[1]} columns of `z`; got shape {tuple(zf.shape)}")
        h = int(zf.shape[0])
    models = as_models(model, z.shape[1])
    estimate = estimate_name(nvr, n_hyper(models)) is not None
    y, z, nvr_checked, P0c, x0, models, _ = validate_dlr_args(
        y, z, models, jnp.zeros(n_hyper(models)) if estimate else nvr, P0, None, None
    )
    n = state_dim(models)
    N = y.shape[0]
    L = bucket_length(N + h)  # padded with NaNs (and zero regressors): one compilation per bucket of lengths
    zz = jnp.concatenate([z, *([zf] if h else []), jnp.zeros((L - N - h, z.shape[1]))])
    yy = pad(y, L - N)
    if estimate:
        b0 = jnp.log10(check_nvr0(validate_nvr(1e-4, models, name="nvr0")))
        fit = fit_tied_nvr(yy, zz, b0, P0c, x0, models, tuple(range(n_hyper(models))), n + 1, max_log10_nvr(None), m)
        nvr_checked = fit.nvr
    masks = block_masks(models, [tuple(range(len(models)))])
    sm = smooth_components(yy, zz, nvr_checked, P0c, x0, models, masks, n + 1, n, m)
    return forecast_from(y, head(sm, N + h))


__all__ = ["Forecast", "dlr_forecast", "forecast_from", "pad"]
