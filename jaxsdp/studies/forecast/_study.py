"""The forecast study: a dynamic harmonic regression of one series, its forecasts with intervals, a hold-out check
of those forecasts against the last samples, and the diagnostics a user reads before trusting them.

Stages (keys of `timings`): `holdout` (with `holdout` > 0: the DHR fitted on all but the last `holdout` samples,
its NVRs estimated on those alone, forecasting the held-out ones), `fit` (the DHR on every sample, forecasting
`horizon` samples beyond), `diagnostics` (the one-step prediction errors of that fit and their whiteness).
"""

from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._checks import OptionError
from ..._kalman.models import as_model
from ..._runtime import follows_method, x64
from ..._signal.whiteness import whiteness
from ...data._series import TimeAxis, time_axis
from ...tvp import DHRResult, dhr
from .._contract import Study, fast_loops, versions
from .._output import StageTimer
from ._figures import forecast_figures
from ._report import (
    component_names,
    forecast_csv,
    forecast_summary,
    naive_season,
    report_markdown,
    seasonal_naive,
    text_output,
)

#: Fewer cycles of the longest period than this in the data: warned (a harmonic seen once is a guess).
MIN_CYCLES = 2.0
#: A horizon longer than this many longest periods: warned (the intervals then mostly say how little is known).
MAX_HORIZON_PERIODS = 3.0
#: Significance of the whiteness test of the one-step errors.
ALPHA = 0.05


class ForecastStudy(Study):
    """Everything `forecast_study` computed: the fit, its forecasts, the hold-out check and the diagnostics.

    **Fields:** `y` (N,) the series (NaN where missing); `fit` the `jaxsdp.tvp.DHRResult` on every sample
    (`fit.forecast`: mean, standard errors and intervals over the data and the `horizon` samples after it);
    `holdout_fit` the DHR fitted on all but the last `holdout` samples, forecasting them and the `horizon`
    after them (None with `holdout` 0); `holdout_metrics` (dict, empty without hold-out: `rmse`, `mae`,
    `bias`, `coverage` of the `level` intervals (indicative only: one split's multi-step errors are correlated),
    `inside`, `observed`, `naive_rmse` of the seasonal naive forecast; `holdout_check`); `whiteness` (dict: the
    Ljung-Box test of the fit's standardised one-step prediction errors, None for too short a series);
    `axis` the `TimeAxis` of the samples; `periods`, `horizon`, `holdout`, `level`, `trend`, `name`, `source`
    as given; `warnings`, `timings` (s per stage), `versions`, `fast_loops`.

    **Methods:** `summary()`, `report(figures=None)`, `text()`, `figures()` (the study contract), `csv()` (the
    forecast table as CSV text), `with_timings(timings)`. A result is immutable.
    """

    y: jnp.ndarray
    fit: DHRResult
    holdout_fit: DHRResult | None
    axis: TimeAxis
    periods: tuple = eqx.field(static=True)
    horizon: int = eqx.field(static=True)
    holdout: int = eqx.field(static=True)
    level: float = eqx.field(static=True)
    trend: str = eqx.field(static=True)
    name: str = eqx.field(static=True)
    source: str = eqx.field(static=True)
    holdout_metrics: dict = eqx.field(static=True, default_factory=dict)
    whiteness: dict | None = eqx.field(static=True, default=None)
    warnings: tuple = eqx.field(static=True, default=())
    timings: dict = eqx.field(default_factory=dict)
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp forecast`): `series`, `model`, `nvr` (values, standard
        errors of log10, convergence), `sigma2`, `loglik`, `whiteness`, `forecast` (rows: sample, time, mean,
        lower, upper, se), `holdout` (metrics and rows, or None), `warnings`, `timings` (s), `versions`."""
        return forecast_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md` of `jaxsdp forecast`): warnings, the data, the model and its NVRs,
        the hold-out check, the forecast table, the figures (name -> file name, embedded when given), timings."""
        return report_markdown(self, dict(figures or {}))

    @x64
    def text(self) -> str:
        """What `jaxsdp forecast` prints: the model, its NVRs, the hold-out check and the first forecasts (the
        warnings are printed once, on stderr, by the command)."""
        return text_output(self)

    @x64
    def figures(self) -> dict:
        """The figures, keyed by file stem: `forecast` (data, fit and forecast with its interval), `decomposition`
        (trend, seasonal, residual) and, with a hold-out, `holdout` (the held-out samples against their band)."""
        return forecast_figures(self)

    @x64
    def csv(self) -> str:
        """The forecast as CSV text (`forecast.csv` of `jaxsdp forecast`): one row per forecast sample with its
        sample number, time, mean, `level` interval, standard error, trend and seasonal part."""
        return forecast_csv(self)


def n_states(trend, periods) -> int:
    """The DHR's state count: the trend model's states, then two per period (one at the period 2)."""
    return (0 if trend is None else as_model(trend).dim) + sum(1 + (p != 2.0) for p in periods)


def check_options(y, *, periods, horizon, holdout, level, trend="IRW") -> tuple:
    """The periods as floats, after checking the options against the series `y` (N,) (`OptionError` naming the
    argument): periods >= 2 samples, distinct and within the data fitted (all but the `holdout` last
    samples), `horizon` and `holdout` integers >= 0, `level` in (0, 1), and at least the model's state count
    + 2 observed samples in the data fitted (with a hold-out, in the part before it)."""
    for arg, v in (("horizon", horizon), ("holdout", holdout)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
            raise OptionError(f"`{arg}` must be an integer >= 0 (samples); got {v!r}")
    if not isinstance(level, (int, float, np.floating)) or not 0.0 < float(level) < 1.0:
        raise OptionError(f"`level` must lie in (0, 1) (0.95 for 95 % intervals); got {level!r}")
    p = tuple(float(v) for v in np.atleast_1d(np.asarray(periods, dtype=np.float64)))
    if any(not (np.isfinite(v) and v >= 2.0) for v in p) or len(set(p)) != len(p):
        raise OptionError(f"`periods` must be distinct periods in samples, each at least 2; got {list(p)}")
    y = np.asarray(y, dtype=np.float64)
    n = y.shape[0]
    fitted = n - int(holdout)
    if fitted < 2:
        raise OptionError(f"`holdout` ({holdout}) leaves {fitted} of the {n} samples to fit; hold out fewer")
    if p and max(p) > fitted:
        where = f"the {fitted} samples fitted (the {n} less the `holdout` {holdout})" if holdout else f"the {n} samples"
        raise OptionError(
            f"`periods`: {max(p):g} samples is longer than {where}: a harmonic must complete one cycle in the data"
        )
    states, seen = n_states(trend, p), int(np.isfinite(y[:fitted]).sum())
    if seen < states + 2:
        model = f"the {trend} trend and {len(p)} period(s)" if trend is not None else f"{len(p)} period(s)"
        if holdout:
            raise OptionError(
                f"`holdout` ({holdout}) leaves {seen} observed samples to fit, too few for the {states} states of "
                f"{model} (at least {states + 2}): hold out fewer, or give fewer `periods`"
            )
        raise OptionError(
            f"`periods`: the series has {seen} observed samples, too few for the {states} states of {model} (at "
            f"least {states + 2}): give fewer `periods`"
        )
    return p


def _axis(time, dt, n: int) -> TimeAxis:
    if time is not None and dt is not None:
        raise ValueError("give `time` (the samples' time stamps) or `dt` (their step), not both")
    if isinstance(time, TimeAxis):
        axis = time
    elif time is not None:
        axis = time_axis(time, name="time")
    elif dt is not None:
        if not isinstance(dt, (int, float, np.floating)) or not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"`dt` must be a positive number (the sampling step); got {dt!r}")
        return TimeAxis(stamps=np.arange(n) * float(dt), step=float(dt), name="dt")
    else:
        return TimeAxis(stamps=None, step=None)
    if axis.stamps is not None and axis.stamps.shape[0] != n:
        raise ValueError(f"`time` has {axis.stamps.shape[0]} stamps for the {n} samples of `y`")
    return axis


def one_step_errors(fit: DHRResult, states: int) -> np.ndarray:
    """The DHR's standardised one-step prediction errors v_k / sqrt(sigma^2 f_k) (`DHRResult.innov`,
    `innov_var`), observed samples only, after the first `states` + 1 (the diffuse start the likelihood skips)."""
    e = (np.asarray(fit.innov) / np.sqrt(np.asarray(fit.innov_var)))[states + 1 :]
    return e[np.isfinite(e)]


def whiteness_check(e: np.ndarray, periods) -> dict | None:
    """The Ljung-Box test of the one-step errors `e` at 2 x the longest period's lags (10 at least, N/5 at most);
    None when there are fewer than 10 errors."""
    n = e.shape[0]
    lags = min(max(10, 2 * int(round(max(periods, default=5.0)))), n // 5)
    if n < 10 or lags < 1:
        return None
    w = whiteness(e, max_lag=lags, alpha=ALPHA)
    return dict(lags=lags, n=n, lag1=float(w.lag1), q=float(w.q), p_value=float(w.p_value), white=bool(w.white))


def holdout_check(y, hold: DHRResult, holdout: int, level: float, periods) -> dict:
    """Out-of-sample metrics of the hold-out forecast on the observed held-out samples: RMSE, MAE, bias (mean of
    forecast - value), the `level` interval's coverage (`inside` of `observed`: indicative only, the errors of
    one split's multi-step forecasts being correlated through the trend and the amplitudes, so that no binomial
    test applies; the one-step errors' whiteness tests the model), and the seasonal naive forecast's RMSE (each
    value forecast by the training data's value one longest period, rounded, earlier; the last value without
    periods; gaps filled)."""
    n_fit = y.shape[0] - holdout
    n = y.shape[0]
    test = np.asarray(y)[n_fit:]
    mean = np.asarray(hold.forecast.mean)[n_fit:n]
    lo, hi = (v[n_fit:n] for v in hold.forecast.interval(level))
    seen = np.isfinite(test)
    m = int(seen.sum())
    season = naive_season(periods)
    naive = seasonal_naive(hold, holdout, season)
    inside = (test >= lo) & (test <= hi)
    k = int(inside[seen].sum())
    err = (mean - test)[seen]
    rmse = float(np.sqrt(np.mean(err**2))) if m else None
    return dict(
        samples=holdout,
        observed=m,
        rmse=rmse,
        mae=float(np.mean(np.abs(err))) if m else None,
        bias=float(np.mean(err)) if m else None,
        level=float(level),
        inside=k,
        coverage=k / m if m else None,
        naive_season=season,
        naive_rmse=float(np.sqrt(np.mean((naive - test)[seen] ** 2))) if m else None,
    )


def _fit_warnings(fit: DHRResult, names, prefix: str = "", bounds: bool = True) -> list[str]:
    """A search that did not converge, an NVR at the search's upper bound (at the lower bound the data cannot
    tell it from zero, a normal result: `_report.bound_note` says it), covariances no longer definite."""
    out = []
    f = fit.nvr_fit
    if f is not None:
        if not bool(f.converged):
            out.append(
                f"{prefix}the NVR search did not converge ({f.reason}); the forecasts rest on NVRs that may not "
                "maximise the likelihood: give `nvr` values, or fewer `periods`"
            )
        for name, at, b in zip(names, np.asarray(f.at_bound), np.asarray(f.log10_nvr)) if bounds else ():
            if at and b > 0:
                out.append(
                    f"{prefix}the NVR of the {name} is at the search's upper bound (1e{b:.0f}): the {name} follows "
                    "the noise; that NVR has no standard error"
                )
    if not bool(fit.definite):
        out.append(f"{prefix}the filter's covariances lost positive definiteness: the intervals are not to be trusted")
    return out


def study_warnings(study_parts: dict) -> list[str]:
    """What a user must know before trusting the forecasts (see `forecast_study`)."""
    s = study_parts
    y, periods, n = s["y"], s["periods"], s["y"].shape[0]
    names = component_names(s["trend"], periods)
    out = _fit_warnings(s["fit"], names)
    if s["hold"] is not None:
        out += _fit_warnings(s["hold"], names, "hold-out fit: ", bounds=False)
    if periods and n / max(periods) < MIN_CYCLES:
        out.append(
            f"the data hold {n / max(periods):.3g} cycles of the longest period ({max(periods):g} samples); fewer than "
            f"{MIN_CYCLES:g} cannot tell a cycle from the trend: the seasonal estimate is a guess"
        )
    missing = int(np.isnan(y).sum())
    if missing:
        out.append(
            f"{missing} of the {n} samples are missing (NaN): the smoother fills them, with their intervals; they do "
            "not enter the likelihood"
        )
    h, longest = s["horizon"], max(periods, default=0.0)
    if (longest and h > MAX_HORIZON_PERIODS * longest) or h > n:
        ref = f"{h / longest:.3g} times the longest period" if longest else "samples"
        out.append(
            f"the horizon ({h} samples, {ref}) reaches far beyond the data's patterns: the intervals assume the "
            "trend's and amplitudes' random walks go on as fitted, and mostly show how little is known there"
        )
    w = s["whiteness"]
    if w is not None and not w["white"]:
        out.append(
            f"the one-step prediction errors are not white (Ljung-Box p = {w['p_value']:.2g} over {w['lags']} lags, "
            f"lag-1 autocorrelation {w['lag1']:.2f}): the model leaves structure in the data, and its intervals "
            "may be too narrow; a missing period, another trend model or an outlier may be the cause"
        )
    m = s["metrics"]
    if m and m["observed"] and m["rmse"] > m["naive_rmse"]:
        out.append(
            f"hold-out: the forecasts' RMSE ({m['rmse']:.4g}) is above the seasonal naive forecast's "
            f"({m['naive_rmse']:.4g}, each value repeated from {m['naive_season']} samples earlier)"
        )
    return out


@x64
@follows_method
def forecast_study(
    y,
    *,
    periods,
    horizon: int,
    time=None,
    dt: float | None = None,
    trend: str = "IRW",
    nvr="ml",
    level: float = 0.95,
    holdout: int = 0,
    name: str = "y",
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
    method: str | None = None,
) -> ForecastStudy:
    r"""Forecast a series with a dynamic harmonic regression, check the forecasts on held-out samples, diagnose.

    The model is `jaxsdp.tvp.dhr`'s: $y_k = T_k + \sum_i (a_{ik} \cos(2\pi k / P_i) + b_{ik} \sin(2\pi k / P_i)) + e_k$,
    the trend $T$ a `trend` random-walk-family block, each harmonic's amplitudes random walks sharing an NVR,
    the NVRs by maximum likelihood (`nvr="ml"`) or given. The forecasts are the Kalman filter's $j$-step
    predictions, with intervals for a new value of the series ($\pm z$ `obs_se`) at `level`.

    **Arguments:** `y` (N,) the series, NaN where missing; `periods` the harmonics' periods in samples (12, 6,
    4, 3, 2.4, 2 for a monthly series' year and its harmonics; () for the trend alone); `horizon` the samples
    to forecast after the data; `time` the samples' time stamps (numbers or `numpy.datetime64`, regular: a
    step, or calendar months) or `dt` their step, for the labels of the forecasts and to say what a period is in
    time (the model counts samples either way); `trend` "IRW", "LLT" or "RW"; `nvr` "ml" or the NVRs (the
    trend's, then one per period); `level` of the intervals; `holdout` K: also fit on all but the last K
    samples (its NVRs estimated there), forecast those and compare (RMSE, coverage, seasonal naive RMSE);
    `name` the series' name for labels; `source` a description (the file); `progress` called with each stage's
    name; `method` the kernels ("sequential", "parallel", "auto").

    **Warnings** (`ForecastStudy.warnings`): an NVR search that did not converge or an NVR on the search's
    upper bound, fewer than 2 cycles of the longest period, missing samples, a horizon beyond 3 longest periods
    or the data's length, one-step prediction errors that are not white (Ljung-Box at 5 %) and hold-out
    forecasts worse than the seasonal naive. NVRs at the search's lower bound (the data cannot tell them from
    zero: a straight-line trend, a constant amplitude) are a normal result, noted in the report. The hold-out
    coverage is reported as a count, not tested: one split's multi-step errors are correlated.

    **Returns** a `ForecastStudy`. `OptionError` (a `ValueError`) for options that do not fit the series.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.studies.forecast import forecast_study
        >>> k = np.arange(144.0)
        >>> y = 0.05 * k + np.cos(2 * np.pi * k / 12) + 0.1 * np.random.default_rng(0).normal(size=144)
        >>> study = forecast_study(y, periods=[12], horizon=12, holdout=12, nvr=(1e-6, 1e-4))
        >>> m = study.holdout_metrics
        >>> print(m["observed"], m["rmse"] < 0.2, m["rmse"] < m["naive_rmse"])
        12 True True
        >>> print(len(study.csv().splitlines()) - 1, study.axis.kind)  # 12 forecast rows; samples without time
        12 index
    """
    y_np = np.asarray(y, dtype=np.float64)
    if y_np.ndim != 1:
        raise ValueError(f"`y` must be 1-D (one series); got shape {y_np.shape}")
    n = y_np.shape[0]
    periods = check_options(y_np, periods=periods, horizon=horizon, holdout=holdout, level=level, trend=trend)
    axis = _axis(time, dt, n)
    horizon, holdout, level = int(horizon), int(holdout), float(level)
    timer = StageTimer(progress)
    model = dict(trend=trend, nvr=nvr)
    hold = None
    if holdout:
        # forecasting the held-out samples and the horizon after them: the two fits' series (data and horizon)
        # then have the same length, and share one compiled program
        hold = timer("holdout", lambda: dhr(y_np[: n - holdout], periods, horizon=holdout + horizon, **model))
    fit = timer("fit", lambda: dhr(y_np, periods, horizon=horizon, **model))
    e = timer("diagnostics", lambda: one_step_errors(fit, n_states(trend, periods)))
    white = whiteness_check(e, periods)
    metrics = holdout_check(y_np, hold, holdout, level, periods) if hold is not None else {}
    parts = dict(
        y=y_np, periods=periods, trend=trend, fit=fit, hold=hold, horizon=horizon, whiteness=white, metrics=metrics
    )
    return ForecastStudy(
        y=jnp.asarray(y_np),
        fit=fit,
        holdout_fit=hold,
        axis=axis,
        periods=periods,
        horizon=horizon,
        holdout=holdout,
        level=level,
        trend=str(trend),
        name=str(name),
        source=f"a series of {n} samples" if source is None else str(source),
        holdout_metrics=metrics,
        whiteness=white,
        warnings=tuple(study_warnings(parts)),
        timings=timer.total(),
        versions=versions(),
        fast_loops=fast_loops(),
    )


__all__ = [
    "ForecastStudy",
    "check_options",
    "forecast_study",
    "holdout_check",
    "n_states",
    "one_step_errors",
    "whiteness_check",
]
