"""The forecast study's figures: the series with its fit and forecast band, the decomposition, the hold-out check."""

import numpy as np
import scipy  # scipy.stats loads on first use

from ..._runtime import x64
from .._figure_style import LEGEND, as_float, new_figure, panel
from ._report import seasonal_naive

#: The figures' names (file stems), in order; `holdout` only with a hold-out.
FIGURE_NAMES = ("forecast", "decomposition", "holdout")


def _x(study, total: int):
    """The abscissa of samples 0..total-1: their time, or the sample numbers."""
    t = study.axis.at(np.arange(total))
    return np.arange(total) if t is None else t


def _xlabel(study) -> str:
    a = study.axis
    if a.kind == "index":
        return "sample"
    return f"{a.name or 'time'} (step {a.step_text()})"


def _zoom_start(study, n: int) -> int:
    """The first sample of the close-up: four longest periods (or a quarter of the data) before the end."""
    span = 4 * max(study.periods) if study.periods else n / 4
    return max(0, n - int(np.ceil(max(span, 2 * study.horizon, 24))))


def fig_forecast(study):
    """The series, its fit and forecast with the `level` interval for a new value: all of it, and a close-up."""
    fc, n = study.fit.forecast, study.y.shape[0]
    t = _x(study, n + study.horizon)
    fig = new_figure(figsize=(8.0, 6.0))
    top, bottom = fig.subplots(2, 1)
    fc.plot(top, level=study.level, t=t)
    panel(top, f"{study.name}: data, fit and forecast")
    fc.plot(bottom, level=study.level, start=_zoom_start(study, n), t=t)
    panel(bottom, "close-up on the end of the data and the horizon")
    bottom.set_xlabel(_xlabel(study))
    for ax in (top, bottom):
        ax.set_ylabel(study.name)
    return fig


def _band(ax, t, mean, se, z, color, label):
    ax.fill_between(t, mean - z * se, mean + z * se, color=color, alpha=0.2, lw=0)
    ax.plot(t, mean, color=color, lw=1.1, label=label)


def fig_decomposition(study):
    """The trend over the data (with its interval), the seasonal part (the sum of the harmonics, with its
    interval) and the residual y - trend - seasonal, over the data and the horizon."""
    fit, n = study.fit, study.y.shape[0]
    total = n + study.horizon
    t = _x(study, total)
    z = float(scipy.stats.norm.ppf(0.5 + 0.5 * study.level))
    fig = new_figure(figsize=(8.0, 7.0))
    axes = fig.subplots(3, 1, sharex=True)
    axes[0].plot(t[:n], as_float(study.y), ".", ms=2.5, color="k", label="data")
    _band(axes[0], t, as_float(fit.trend), as_float(fit.trend_se), z, "C0", f"trend ({study.trend})")
    panel(axes[0], f"trend, {100 * study.level:g} % interval", legend=dict(ncol=2))
    _band(axes[1], t, as_float(fit.seasonal), as_float(fit.seasonal_se), z, "C1", "seasonal")
    panel(axes[1], "seasonal part (the harmonics' sum)" if study.periods else "no periods: no seasonal part")
    axes[2].plot(t[:n], as_float(fit.resid), ".", ms=2.5, color="C2")
    axes[2].axhline(0.0, color="0.5", lw=0.8)
    panel(axes[2], "residual: data - trend - seasonal")
    for ax, label in zip(axes, (study.name, "seasonal", "residual")):
        ax.set_ylabel(label)
    axes[2].set_xlabel(_xlabel(study))
    return fig


def fig_holdout(study):
    """The hold-out check: the data before the held-out samples, their forecast with its `level` interval, the
    held-out values (those outside the interval marked) and the seasonal naive forecast."""
    h, n, k = study.holdout_fit, study.y.shape[0], study.holdout
    start = max(0, n - k - max(2 * k, int(np.ceil(2 * max(study.periods, default=0.0)))))
    t = _x(study, n)
    y = as_float(study.y)
    lo, hi = h.forecast.interval(study.level)
    mean = as_float(h.forecast.mean)
    fig = new_figure(figsize=(8.0, 3.6))
    ax = fig.add_subplot()
    fit_part = slice(start, n - k)
    held = slice(n - k, n)
    ax.plot(t[fit_part], y[fit_part], ".", ms=3, color="k", label="data fitted")
    ax.fill_between(t[held], lo[held], hi[held], color="C0", alpha=0.2, lw=0, label=f"{100 * study.level:g} % interval")
    ax.plot(t[start:n], mean[start:n], color="C0", lw=1.1, label="fit and forecast")
    naive = seasonal_naive(h, k, study.holdout_metrics["naive_season"])
    ax.plot(t[held], naive, color="C1", lw=0.9, ls="--", label="seasonal naive")
    test = y[held]
    outside = ~((test >= lo[held]) & (test <= hi[held])) & np.isfinite(test)
    ax.plot(t[held][~outside], test[~outside], "o", ms=3.5, color="C2", label="held out, inside")
    if outside.any():
        ax.plot(t[held][outside], test[outside], "x", ms=6, color="tab:red", label="held out, outside")
    ax.axvline(t[n - k - 1], color="0.5", lw=0.8, ls="--")
    m = study.holdout_metrics
    title = f"hold-out: the last {k} samples forecast from the others"
    if m["observed"]:
        title += f" (RMSE {m['rmse']:.3g}, {m['inside']} of {m['observed']} inside)"
    panel(ax, title)
    ax.legend(loc="best", **LEGEND)
    ax.set_xlabel(_xlabel(study))
    ax.set_ylabel(study.name)
    return fig


@x64
def forecast_figures(study) -> dict:
    """Every figure of a `ForecastStudy`, keyed by its file stem (`FIGURE_NAMES`; `holdout` with a hold-out).

    Example:
        >>> from jaxsdp.studies.forecast import FIGURE_NAMES
        >>> FIGURE_NAMES
        ('forecast', 'decomposition', 'holdout')
    """
    out = {"forecast": fig_forecast(study), "decomposition": fig_decomposition(study)}
    if study.holdout_fit is not None:
        out["holdout"] = fig_holdout(study)
    return out
