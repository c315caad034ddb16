"""What `jaxsdp montecarlo` writes: the JSON-ready summaries and report.md of both Monte Carlo studies."""

import dataclasses

import numpy as np

from ..._runtime import x64
from ..._version import __version__
from ...plants.emps._model import EMPS_ASYM_NAMES as ASYM
from .._contract import Study, check_study
from .._output import figure_markdown, finite_or_none, fraction_pct, md_table, percentiles
from ._shared import ASYM_NAMES, CONTROLLERS, METRICS, MIN_COVERAGE, sdp_pd_wn

_RUN_KEYS = ("runs", "devices", "chunk_size", "seconds", "runs_per_second", "seed")
CONTROLLER_LABELS = {"linear_pd": "linear PD", "sdp_pd": "SDP-PD", "pip_sdp": "PIP-SDP"}
METRIC_LABELS = {
    "settling_time_s": "settling time (s, 2 %)",
    "overshoot_pct": "overshoot (%)",
    "peak_velocity": "peak velocity (m/s)",
    "peak_force": "peak force (N)",
}


def _run_info(res) -> dict:
    out = {k: getattr(res, k) for k in _RUN_KEYS}
    out["seconds"] = round(float(out["seconds"]), 3)
    out["runs_per_second"] = round(float(out["runs_per_second"]), 2)
    return out


def _environment(res) -> dict:
    """timings (s), the command's total when it ran, versions and the fast-loop status."""
    out = {"timings": {k: round(float(v), 3) for k, v in res.timings.items()}}
    if "total" in res.timings:
        out["total_seconds"] = round(float(res.timings["total"]), 3)
    return {**out, "fast_loops": res.fast_loops, "versions": dict(res.versions)}


def identification_summary(res: Study) -> dict:
    """JSON-ready summary (`summary.json`): run figures, settings, truth, per estimator and parameter
    `mean`, `std`, `p05`, `p95` (of the estimates), `bias`, `bias_pct`, `error_std`, `error_std_pct` (of
    estimate - truth), `mean_reported_se`, `se_to_spread` (over `error_std`), `coverage_95`, the IV, SDP and
    asymmetry figures, `warnings`."""
    nominal = dict(zip(ASYM_NAMES, np.mean(res.truth, axis=0).tolist()))
    out = dict(
        study="identification",
        jaxsdp=__version__,
        **_run_info(res),
        settings=dataclasses.asdict(res.settings),
        truth=nominal,
        warnings=list(res.warnings),
        **res.statistics,
        **_environment(res),
    )
    return finite_or_none(out)


def control_summary(res: Study) -> dict:
    """JSON-ready summary (`summary.json`): run figures, the draws, the drawn parameters' and every
    controller's metrics as `mean`, `std`, `p05`, `p95` with the stability, settling, velocity-limit and
    saturation fractions, `warnings`."""
    s = res.settings
    out = dict(
        study="control",
        jaxsdp=__version__,
        **_run_info(res),
        draws=res.draws,
        spread=res.spread if res.draws == "uniform" else None,
        drive=res.drive,
        sdp_pd_wn=sdp_pd_wn(res.nominal, s, res.drive),
        nominal={k: float(res.nominal.asymmetric[k]) for k in ASYM},
        parameters={k: percentiles(res.parameters[:, j]) for j, k in enumerate(ASYM)},
        step=dict(step=s.step, v_limit=s.v_limit, wn=s.wn, eta=s.eta, ratio=s.ratio),
        controllers=res.statistics,
        warnings=list(res.warnings),
        **_environment(res),
    )
    return finite_or_none(out)


def _fmt(v, spec=".4g"):
    return "n/a" if v is None or not np.isfinite(v) else format(v, spec)


def _pct(v):
    """A fraction of the runs in %: never rounded onto 0 % or 100 % unless exact (`fraction_pct`)."""
    return fraction_pct(v)


def _stages_run(settings) -> str:
    """The optional stages the identification runs ran, as a clause of the report's first sentence."""
    stages = ["bias-compensated IDIM-IV"] if settings.iv else []
    stages += ["SDP stage and IDIM-SDP"] if settings.sdp else []
    return (", " + ", ".join(stages)) if stages else " (IDIM-IV and the SDP stage not run)"


def identification_report(res: Study, figures=()) -> str:
    """report.md of the identification Monte Carlo study."""
    s, sm = res.settings, res.statistics
    parts = [
        "# Monte Carlo: EMPS identification (built-in plant)",
        "",
        f"{res.runs} closed-loop experiments on the built-in EMPS (24,841 samples at 1 kHz), each identified by the "
        "whole EMPS study: derivatives (100 Hz Butterworth, decimation by 10), IDIM-LS (linear and asymmetric "
        f"friction){_stages_run(s)}. Noise: "
        f"{s.position_noise:g} encoder count(s) of white position noise, quantised to one count; "
        f"{s.force_noise:g} N of white force noise; plants "
        + ("the truth in every run." if s.plant_spread == 0 else f"uniform within +-{100 * s.plant_spread:g} %.")
        + f" {res.devices} device(s), chunks of {res.chunk_size}, {res.seconds:.1f} s "
        f"({res.runs_per_second:.1f} runs/s, compilation included), seed {res.seed}.",
        "",
    ]
    if res.warnings:
        parts += ["## Warnings", ""] + [f"- {w}" for w in res.warnings] + [""]
    parts += [
        "## Estimates against the truth",
        "",
        "Bias and error std: mean and standard deviation over the runs of the error (estimate - truth of the "
        "run) in % of the truth, so that a spread of the plants is not counted as error; `se/spread`: mean "
        "stated standard error over the standard deviation of that error (1: honest spread); `coverage`: share "
        "of the runs whose stated 95 % interval (estimate +- 1.96 se) contains the truth (goal >= "
        f"{100 * MIN_COVERAGE:.0f} %). Parameters without a truth (linear friction model): error std is the "
        "estimates' std, and only when every run has the same plant.",
        "",
    ]
    same_plant = s.plant_spread == 0
    for key, est in sm["estimators"].items():
        rows = []
        for name, e in est["parameters"].items():
            mean = e["mean"]
            rel = lambda v: "n/a" if v is None or not mean else f"{100 * v / abs(mean):.3f}"  # noqa: E731
            if e["error_std_pct"] is not None:
                spread = f"{e['error_std_pct']:.3f}"
            else:  # no truth: the estimates' spread is the error's only when the plant is the same in every run
                spread = rel(e["std"]) if same_plant else "n/a"
            rows.append(
                [
                    name,
                    _fmt(mean),
                    "n/a" if e["bias_pct"] is None else f"{e['bias_pct']:+.3f}",
                    spread,
                    rel(e["mean_reported_se"]),
                    _fmt(e["se_to_spread"], ".2f"),
                    _pct(e["coverage_95"]),
                ]
            )
        header = ["parameter", "mean", "bias %", "error std %", "mean stated se %", "se/spread", "coverage 95 %"]
        parts += [f"### {est['label']}", "", md_table(header, rows), ""]
        if est["failed_runs"]:
            parts += [f"{est['failed_runs']} run(s) without a finite estimate are left out.", ""]
    parts += ["## Findings", ""]
    a = sm["asymmetry"]
    parts.append(
        f"- Asymmetric viscous friction (|Fv-/Fv+ - 1| > max(3 se, 0.05), asymmetric IDIM-LS) found in "
        f"{_pct(a['found_fraction'])} of the runs; Fv-/Fv+ {_fmt(a['fv_ratio']['mean'])} "
        f"(5-95 %: {_fmt(a['fv_ratio']['p05'])}-{_fmt(a['fv_ratio']['p95'])}), true {_fmt(a['true_fv_ratio']['mean'])}."
    )
    if "sdp" in sm:
        d = sm["sdp"]
        parts.append(
            f"- SDP stage: mass flagged constant (NVR < {d['constant_nvr']:g}) in {_pct(d['mass_constant_fraction'])} "
            f"of the runs (log10 mass NVR {_fmt(d['log10_mass_nvr']['mean'], '.2f')}); friction NVR at its cap in "
            f"{_pct(d['friction_nvr_at_cap_fraction'])}; back-fitting converged in {_pct(d['converged_fraction'])}; "
            f"IDIM-SDP Fv-/Fv+ {_fmt(d['fv_ratio']['mean'])}."
        )
    if "idim_iv" in sm:
        iv = sm["idim_iv"]
        parts.append(
            f"- IDIM-IV converged in {_pct(iv['converged_fraction'])} of the runs, "
            f"{_fmt(iv['iterations']['mean'], '.1f')} iterations on average (at most {iv['max_iter']})."
        )
    parts.append("")
    if figures:
        parts += ["## Figures", ""] + [figure_markdown(f) for f in figures] + [""]
    return "\n".join(parts)


def control_report(res: Study, figures=()) -> str:
    """report.md of the control-robustness Monte Carlo study."""
    s = res.settings
    how = (
        f"uniform within +-{100 * res.spread:g} % of the nominal values"
        if res.draws == "uniform"
        else "Gaussian with the asymmetric IDIM-LS covariance"
    )
    wn = sdp_pd_wn(res.nominal, s, res.drive)
    if res.drive == "real":
        drive = "the real drive (one-sample delay, force saturation)"
    else:
        drive = "an ideal drive (no delay, no saturation)"
    parts = [
        "# Monte Carlo: robustness of the SDP controllers (EMPS)",
        "",
        f"{res.runs} plants (M, Fv+, Fc+, Fv-, Fc-) drawn {how}; the controllers are designed once on the nominal "
        f"model (SDP-PD wn {wn:g} rad/s, PIP-LQ on the SRIVC model of that loop) and run a {s.step:g} m step on "
        f"each drawn plant with {drive}. {res.devices} device(s), chunks of "
        f"{res.chunk_size}, {res.seconds:.1f} s ({res.runs_per_second:.0f} runs/s, compilation included), "
        f"seed {res.seed}.",
        "",
    ]
    if res.warnings:
        parts += ["## Warnings", ""] + [f"- {w}" for w in res.warnings] + [""]
    rows = [
        [k, _fmt(float(res.nominal.asymmetric[k])), _fmt(float(np.mean(v))), _fmt(float(np.std(v)))]
        for k, v in zip(ASYM, res.parameters.T)
    ]
    parts += ["## Drawn plants", "", md_table(["parameter", "nominal", "mean", "std"], rows), ""]
    header = ["controller", "stable", "settled", f"|dq| <= {s.v_limit:g} m/s", "above saturation", "at the force limit"]
    header += [METRIC_LABELS[m] + " mean (5-95 %)" for m in METRICS]
    rows = []
    for c in CONTROLLERS:
        e = res.statistics[c]
        row = [CONTROLLER_LABELS[c]] + [
            _pct(e[k])
            for k in (
                "stable_fraction",
                "settled_fraction",
                "within_velocity_limit",
                "above_saturation",
                "at_force_limit",
            )
        ]
        row += [f"{_fmt(e[m]['mean'])} ({_fmt(e[m]['p05'])}-{_fmt(e[m]['p95'])})" for m in METRICS]
        rows.append(row)
    parts += ["## Step responses", "", md_table(header, rows), ""]
    if figures:
        parts += ["## Figures", ""] + [figure_markdown(f) for f in figures] + [""]
    return "\n".join(parts)


def _run_line(res, study: str) -> str:
    return (
        f"{study} Monte Carlo: {res.runs} runs on {res.devices} device(s) in {res.seconds:.1f} s "
        f"({res.runs_per_second:.1f} runs/s)"
    )


def identification_text(res: Study) -> str:
    """The identification study's console summary: the run's figures, then one line per estimator (bias %,
    coverage of the 95 % intervals, per parameter)."""
    lines = [_run_line(res, "Identification")]
    for est in res.statistics["estimators"].values():
        cells = [
            f"{n} {e['bias_pct']:+.2f} % ({_pct(e['coverage_95'])})"
            for n, e in est["parameters"].items()
            if e["bias_pct"] is not None and e["coverage_95"] is not None
        ]
        lines.append(f"  {est['label']}: bias (coverage 95 %) " + ", ".join(cells))
    return "\n".join(lines)


def control_text(res: Study) -> str:
    """The control study's console summary: the run's figures, then one line per controller (stable, settled
    and within the velocity limit, %, and the settling time, s)."""
    lines = [_run_line(res, "Control")]
    for c in CONTROLLERS:
        e = res.statistics[c]
        ts = e["settling_time_s"]
        lines.append(
            f"  {CONTROLLER_LABELS[c]}: stable {_pct(e['stable_fraction'])}, "
            f"settled {_pct(e['settled_fraction'])}, "
            f"within {res.settings.v_limit:g} m/s {_pct(e['within_velocity_limit'])}, settling "
            f"{_fmt(ts['mean'], '.3f')} s (5-95 %: {_fmt(ts['p05'], '.3f')}-{_fmt(ts['p95'], '.3f')})"
        )
    return "\n".join(lines)


@x64
def text_output(res) -> str:
    """The console summary of either study (the result's own `text()`): run figures, then one line per
    estimator or controller.

    Example:
        >>> from jaxsdp.studies.montecarlo import control_robustness, text_output
        >>> lines = text_output(control_robustness(16, progress=False)).splitlines()
        >>> [line.split(":")[0].strip() for line in lines[1:]]
        ['linear PD', 'SDP-PD', 'PIP-SDP']
    """
    return check_study(res, argument="res").text()
