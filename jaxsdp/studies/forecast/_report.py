"""The forecast study's outputs: summary.json's dict, report.md, the printed text and forecast.csv."""

import io

import numpy as np

from ..._kalman.models import as_model
from ..._runtime import x64
from .._contract import Study
from .._output import figure_markdown, finite_or_none, fraction_pct, md_table, sci, text_table

#: What the hold-out coverage is worth, said after it.
COVERAGE_NOTE = (
    "The coverage of one split's forecasts is only indicative: their errors are correlated through the trend and "
    "the amplitudes, so that no binomial test applies; the one-step errors' whiteness tests the model."
)
#: Forecast rows the report and the printed text show (all of them are in summary.json and forecast.csv).
REPORT_ROWS = 24
TEXT_ROWS = 12


def component_names(trend, periods) -> list[str]:
    """The DHR's NVR entries in order: the trend's (two for LLT), then one per period."""
    n = 0 if trend is None else as_model(trend).n_nvr
    names = ["trend"] if n == 1 else [f"trend ({w})" for w in ("level", "slope")[:n]]
    return names + [f"period {p:g}" for p in periods]


#: What a component whose NVR is 0 is, by trend model and component name.
_STILL = {
    ("IRW", "trend"): "a straight line",
    ("RW", "trend"): "a constant level",
    ("LLT", "trend (level)"): "a level without a random walk of its own",
    ("LLT", "trend (slope)"): "a constant slope",
}


def bound_note(fit, trend, periods) -> str | None:
    """One sentence on the NVRs of `fit` at the search's lower bound (the data cannot tell them from zero: a
    normal result, not a warning), None when there are none."""
    f = fit.nvr_fit
    if f is None:
        return None
    names = component_names(trend, periods)
    low = [(c, b) for c, at, b in zip(names, np.asarray(f.at_bound), np.asarray(f.log10_nvr)) if at and b <= 0]
    if not low:
        return None
    what = [
        f"{c} ({'a constant amplitude' if c.startswith('period') else _STILL.get((str(trend).upper(), c), 'fixed')})"
        for c, _ in low
    ]
    return (
        f"At the NVR search's lower bound (1e{low[0][1]:.0f}), where the data cannot tell an NVR from zero: "
        f"{'; '.join(what)}. This is a normal result; these NVRs have no standard error."
    )


def naive_season(periods) -> int:
    """The seasonal naive forecast's season: the longest period rounded (1 without periods: the last value)."""
    return max(1, int(round(max(periods)))) if periods else 1


def seasonal_naive(hold, holdout: int, season: int) -> np.ndarray:
    """(holdout,) the seasonal naive forecast of the held-out samples: each the value `season` samples before
    it, repeated from the last season of the data fitted (`hold`, its gaps filled by the smoother)."""
    filled = np.asarray(hold.forecast.filled)
    n_fit = filled.shape[0]
    j = np.arange(holdout)
    return filled[n_fit - season + j % season]


def _n(v) -> str:
    """A value of the series: six significant digits."""
    return "-" if v is None or not np.isfinite(v) else f"{v:.6g}"


def _forecast_rows(study) -> list[dict]:
    fc, n = study.fit.forecast, study.y.shape[0]
    k = np.arange(n, n + study.horizon)
    lo, hi = fc.interval(study.level)
    labels = study.axis.labels(study.axis.at(k)) if study.axis.stamps is not None else [None] * len(k)
    mean, se, obs_se = (np.asarray(a)[n:] for a in (fc.mean, fc.se, fc.obs_se))
    return [
        dict(sample=int(k[i]), time=labels[i], mean=float(mean[i]), lower=float(lo[n + i]), upper=float(hi[n + i]),
             se=float(se[i]), obs_se=float(obs_se[i]))
        for i in range(len(k))
    ]  # fmt: skip


def _holdout(study) -> dict | None:
    if study.holdout_fit is None:
        return None
    m, h, n = study.holdout_metrics, study.holdout_fit, study.y.shape[0]
    start = n - study.holdout
    lo, hi = h.forecast.interval(study.level)
    times = study.axis.labels(study.axis.at(np.arange(start, n))) if study.axis.stamps is not None else None
    y, mean = np.asarray(study.y), np.asarray(h.forecast.mean)
    rows = [
        dict(
            sample=k,
            time=None if times is None else times[k - start],
            y=float(y[k]),
            mean=float(mean[k]),
            lower=float(lo[k]),
            upper=float(hi[k]),
            inside=bool(lo[k] <= y[k] <= hi[k]) if np.isfinite(y[k]) else None,
        )
        for k in range(start, n)
    ]
    return dict(
        m,
        fitted=start,
        nvr=np.asarray(h.nvr).tolist(),
        nvr_converged=None if h.nvr_fit is None else bool(h.nvr_fit.converged),
        rows=rows,
    )


def _nvr(study) -> dict:
    fit, f = study.fit, study.fit.nvr_fit
    names = component_names(study.trend, study.periods)
    se = [None] * len(names) if f is None else np.asarray(f.log10_nvr_se).tolist()
    at = [False] * len(names) if f is None else np.asarray(f.at_bound).tolist()
    return dict(
        estimated=f is not None,
        components=[
            dict(component=c, nvr=float(v), log10_nvr=float(np.log10(v)) if v > 0 else None, log10_se=s, at_bound=b)
            for c, v, s, b in zip(names, np.asarray(fit.nvr).tolist(), se, at)
        ],
        converged=None if f is None else bool(f.converged),
        reason=None if f is None else f.reason,
        steps=None if f is None else int(f.steps),
        note=bound_note(fit, study.trend, study.periods),
    )


def _series(study) -> dict:
    a, n = study.axis, study.y.shape[0]
    first_last = [None, None] if a.stamps is None else [a.label(a.stamps[0]), a.label(a.stamps[-1])]
    return dict(
        name=study.name,
        samples=n,
        missing=int(np.isnan(np.asarray(study.y)).sum()),
        time=dict(kind=a.kind, column=a.name or None, first=first_last[0], last=first_last[1], step=a.step_text()),
    )


@x64
def forecast_summary(study: Study) -> dict:
    """summary.json's content: `source`, `series` (name, samples, missing, time axis), `model` (trend, periods in
    samples and in time), `nvr` (each component's NVR, log10 and its standard error, bound; convergence; a
    `note` on those at the search's lower bound), `sigma2`, `loglik`, `definite`, `whiteness`, `forecast`
    (`level`, `horizon`, `rows`: sample, time, mean, lower, upper, se of the signal, obs_se of a new value),
    `holdout` (None, or the metrics, the hold-out fit's NVRs and `rows`: sample, time, y, mean, lower, upper,
    inside), `warnings`, `timings`, `fast_loops`, `versions`; inf and NaN as null.

    Example:
        >>> from jaxsdp.studies.forecast._report import forecast_summary
        >>> callable(forecast_summary)
        True
    """
    fit = study.fit
    out = dict(
        source=study.source,
        series=_series(study),
        model=dict(
            kind="dynamic harmonic regression",
            trend=study.trend,
            cycle="RW",
            periods=list(study.periods),
            periods_in_time=[study.axis.span(p) for p in study.periods],
        ),
        nvr=_nvr(study),
        sigma2=float(fit.sigma2),
        loglik=float(fit.loglik),
        definite=bool(fit.definite),
        whiteness=study.whiteness,
        forecast=dict(level=study.level, horizon=study.horizon, rows=_forecast_rows(study)),
        holdout=_holdout(study),
        warnings=list(study.warnings),
        timings={k: round(v, 3) for k, v in study.timings.items()},
        fast_loops=study.fast_loops,
        versions=dict(study.versions),
    )
    return finite_or_none(out)


def forecast_csv(study: Study) -> str:
    """The forecast rows as CSV text: sample, time, mean, lower, upper, se, obs_se, trend, seasonal."""
    n = study.y.shape[0]
    trend, seasonal = (np.asarray(a)[n:] for a in (study.fit.trend, study.fit.seasonal))
    buf = io.StringIO()
    buf.write("sample,time,mean,lower,upper,se,obs_se,trend,seasonal\n")
    for r, t, s in zip(_forecast_rows(study), trend, seasonal):
        cells = [r["sample"], "" if r["time"] is None else r["time"]]
        cells += [repr(float(v)) for v in (r["mean"], r["lower"], r["upper"], r["se"], r["obs_se"], t, s)]
        buf.write(",".join(str(c) for c in cells) + "\n")
    return buf.getvalue()


def _pct(level) -> str:
    return f"{100 * level:g} %"


def _model_line(study) -> str:
    trend = f"{study.trend} trend"
    if not study.periods:
        return f"{trend} alone (no periods)"
    spans = ", ".join(f"{p:g}" for p in study.periods)
    return f"{trend} + harmonics of {spans} samples with random-walk amplitudes (one NVR per harmonic)"


def _nvr_rows(study, summary) -> list:
    spans = ["-" if c.startswith("trend") else study.axis.span(float(c.split()[1])) for c in _names(study)]
    return [
        (c["component"], s, sci(c["nvr"]), _se(c["log10_se"]),
         "yes" if c["at_bound"] else "")
        for c, s in zip(summary["nvr"]["components"], spans)
    ]  # fmt: skip


def _se(v) -> str:
    """The standard error of a log10 NVR: "-" without one, "flat" beyond 10 decades (the likelihood is flat)."""
    return "-" if v is None else (f"{v:.2f}" if v < 10 else "flat")


def _names(study):
    return component_names(study.trend, study.periods)


def _how(summary) -> str:
    v = summary["nvr"]
    if not v["estimated"]:
        return "NVRs given"
    return f"NVRs by maximum likelihood ({v['reason']}, {v['steps']} steps)"


def _whiteness_line(w) -> str:
    if w is None:
        return "One-step prediction errors: too few for a whiteness test."
    verdict = "white" if w["white"] else "not white"
    return (
        f"One-step prediction errors ({w['n']}, standardised): lag-1 autocorrelation {w['lag1']:.2f}, Ljung-Box "
        f"p = {w['p_value']:.2g} over {w['lags']} lags: {verdict} at 5 %."
    )


def _holdout_line(h, level) -> str:
    how = ", its NVRs estimated on those" if h["nvr_converged"] is not None else ""
    if h["observed"] == 0:
        return f"Hold-out: none of the last {h['samples']} samples is observed; nothing to compare."
    return (
        f"Hold-out (the last {h['samples']} samples forecast from the first {h['fitted']}{how}): "
        f"RMSE {h['rmse']:.4g}, MAE {h['mae']:.4g}, bias {h['bias']:+.3g}; the {_pct(level)} intervals hold "
        f"{h['inside']} of {h['observed']} ({fraction_pct(h['coverage'], digits=1)}); seasonal naive RMSE "
        f"{h['naive_rmse']:.4g}. {COVERAGE_NOTE}"
    )


def _table_rows(rows, *, time: bool) -> tuple[list, list]:
    header = ["sample"] + (["time"] if time else []) + ["mean", "lower", "upper"]
    body = [
        [r["sample"]] + ([r["time"]] if time else []) + [_n(r["mean"]), _n(r["lower"]), _n(r["upper"])] for r in rows
    ]
    return header, body


def _data_line(study, summary) -> str:
    s = summary["series"]
    t = s["time"]
    span = f", {t['first']} to {t['last']}, step {t['step']}" if t["kind"] != "index" else ""
    return f"{s['samples']} samples ({s['missing']} missing){span}"


@x64
def report_markdown(study: Study, figures: dict) -> str:
    """report.md: warnings, the data, the model and its NVRs, the diagnostics, the hold-out check, the forecast
    table, the figures and the timings.

    Example:
        >>> from jaxsdp.studies.forecast._report import report_markdown
        >>> callable(report_markdown)
        True
    """
    s = forecast_summary(study)
    lines = [f"# Forecast of {study.name}", "", f"Source: {study.source}.", ""]
    if study.warnings:
        lines += ["## Warnings", ""] + [f"- {w}" for w in study.warnings] + [""]
    lines += ["## Data", "", f"{study.name}: {_data_line(study, s)}.", ""]
    if study.axis.kind != "index" and study.periods:
        spans = "; ".join(f"{p:g} samples = {study.axis.span(p)}" for p in study.periods)
        lines += [f"The model counts time in samples: {spans}.", ""]
    lines += [
        "## Model",
        "",
        f"Dynamic harmonic regression (`jaxsdp.tvp.dhr`): {_model_line(study)}; {_how(s)}.",
        "",
        md_table(["component", "period in time", "NVR", "se of log10 NVR", "on a bound"], _nvr_rows(study, s)),
        "",
        *([s["nvr"]["note"], ""] if s["nvr"]["note"] else []),
        f"Noise variance sigma^2 = {s['sigma2']:.4g}, log-likelihood {s['loglik']:.6g}.",
        "",
        _whiteness_line(s["whiteness"]),
        "",
    ]
    h = s["holdout"]
    if h is not None:
        lines += ["## Hold-out check", "", _holdout_line(h, study.level), ""]
        if h["observed"]:
            header = ["RMSE", "MAE", "bias", f"{_pct(study.level)} coverage", "seasonal naive RMSE"]
            cov = fraction_pct(h["coverage"], digits=1)
            row = [f"{h['rmse']:.4g}", f"{h['mae']:.4g}", f"{h['bias']:+.3g}", cov, f"{h['naive_rmse']:.4g}"]
            lines += [md_table(header, [row]), ""]
    rows = s["forecast"]["rows"]
    lines += ["## Forecast", ""]
    if rows:
        header, body = _table_rows(rows[:REPORT_ROWS], time=study.axis.kind != "index")
        more = f" (the first {REPORT_ROWS} of {len(rows)})" if len(rows) > REPORT_ROWS else ""
        lines += [
            f"{study.horizon} samples after the data, with {_pct(study.level)} intervals for a new value of the "
            f"series{more}. Every row, with standard errors, trend and seasonal part: "
            "[forecast.csv](forecast.csv) (written by `jaxsdp forecast`; `csv()` of the result in Python).",
            "",
            md_table(header, body),
        ]
    else:
        lines += ["No horizon: nothing forecast after the data."]
    if figures:
        lines += ["", "## Figures", ""] + [figure_markdown(f) for f in figures.values()]
    lines += [
        "",
        "## Timings (s)",
        "",
        md_table(["stage", "seconds"], [(k, f"{v:.2f}") for k, v in study.timings.items()]),
    ]
    return "\n".join(lines) + "\n"


@x64
def text_output(study: Study) -> str:
    """The printed text: the data, the model and its NVRs, the diagnostics, the hold-out check and the first
    forecasts (the warnings are printed once, on stderr, by the command; they head report.md).

    Example:
        >>> from jaxsdp.studies.forecast._report import text_output
        >>> callable(text_output)
        True
    """
    s = forecast_summary(study)
    lines = [f"Forecast of {study.name} ({study.source}): {_data_line(study, s)}"]
    lines += [f"Model: {_model_line(study)}; {_how(s)}"]
    table = text_table(["component", "period in time", "NVR", "se(log10)", "on a bound"], _nvr_rows(study, s))
    lines += ["  " + line for line in table.splitlines()]
    lines += [s["nvr"]["note"]] if s["nvr"]["note"] else []
    lines += [f"sigma^2 {s['sigma2']:.4g}, log-likelihood {s['loglik']:.6g}", _whiteness_line(s["whiteness"])]
    if s["holdout"] is not None:
        lines += [_holdout_line(s["holdout"], study.level)]
    rows = s["forecast"]["rows"]
    if rows:
        header, body = _table_rows(rows[:TEXT_ROWS], time=study.axis.kind != "index")
        lines += ["", f"Forecast, {study.horizon} samples, {_pct(study.level)} intervals:"]
        lines += ["  " + line for line in text_table(header, body, align="right").splitlines()]
        if len(rows) > TEXT_ROWS:
            lines += [f"  (the first {TEXT_ROWS} of {len(rows)}; all in forecast.csv)"]
    return "\n".join(lines)
