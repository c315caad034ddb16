"""What `jaxsdp montecarlo --study robot` writes: the summary, report.md, console text and figure of the robot
Monte Carlo (`robot_robustness`)."""

import dataclasses

import numpy as np

from ..._version import __version__
from .._contract import Study
from .._figure_style import new_figure, panel
from .._output import figure_markdown, finite_or_none, fraction_pct, md_table
from ._shared import MIN_COVERAGE

_RUN_KEYS = ("runs", "devices", "chunk_size", "seconds", "runs_per_second", "seed")


def robot_summary(res: Study) -> dict:
    """JSON-ready summary (`summary.json`): run figures, settings, the robot, per base parameter `mean`, `std`,
    `p05`, `p95` (estimates), `bias`, `error_std` (estimate - truth), `mean_reported_se`, `se_to_spread`,
    `coverage_95`, `bias_in_se`; the coverage over the parameters; `warnings`."""
    run = {k: getattr(res, k) for k in _RUN_KEYS}
    run["seconds"] = round(float(run["seconds"]), 3)
    run["runs_per_second"] = round(float(run["runs_per_second"]), 3)
    out = dict(
        study="robot",
        jaxsdp=__version__,
        **run,
        robot=res.source,
        settings=dataclasses.asdict(res.settings),
        warnings=list(res.warnings),
        **res.statistics,
        timings={k: round(float(v), 3) for k, v in res.timings.items()},
        fast_loops=res.fast_loops,
        versions=dict(res.versions),
    )
    return finite_or_none(out)


def robot_report(res: Study, figures=()) -> str:
    """report.md of the robot Monte Carlo study."""
    s, sm = res.settings, res.statistics
    pr = sm["processing"]
    given = None not in (s.cutoff_hz, s.decimate, s.drop)
    parts = [
        f"# Monte Carlo: robot identification ({res.source})",
        "",
        f"{res.runs} robots drawn around the description ({sm['joints']} joints, {sm['rank']} base parameters): "
        f"each link's inertial parameters scaled by one factor and each joint's viscous and Coulomb friction "
        f"scaled, uniform within +-{100 * s.spread:g} %; each simulated for {s.periods} period(s) of an exciting "
        f"trajectory ({s.harmonics} harmonics at {s.f0:g} Hz, condition number {res.cond:.3g}) under a fixed joint "
        f"PD controller at {1 / s.dt:g} Hz, with white torque noise of {100 * s.torque_noise:g} % of each joint's "
        f"torque spread"
        + (
            f", a white torque disturbance on the plant of {100 * s.disturbance:g} % of it (not in the log)"
            if s.disturbance
            else ""
        )  # fmt: skip
        + f", and identified by IDIM-LS of every joint at once (Butterworth at {pr['cutoff_hz']:g} Hz, "
        f"{pr['drop']} samples dropped at each end, decimation by {pr['decimate']}, rows at rest left out; "
        f"{'the processing given' if given else 'the robot study processing defaults for this trajectory'}). "
        f"{res.devices} device(s), {res.seconds:.1f} s "
        f"({res.runs_per_second:.2f} runs/s, compilation included), seed {res.seed}.",
        "",
    ]
    if res.warnings:
        parts += ["## Warnings", ""] + [f"- {w}" for w in res.warnings] + [""]
    cover = sm["coverage_95"]
    parts += [
        "## Base parameters against the truth",
        "",
        "The truth of each run is the drawn robot's base parameters. Bias and error std: mean and standard "
        "deviation of the error (estimate - truth of the run); `bias/se`: the bias over the mean stated standard "
        "error; `se/spread`: mean stated standard error over the error's standard deviation (1: honest); "
        f"`coverage`: share of the runs whose 95 % interval contains the truth (goal >= {100 * MIN_COVERAGE:.0f} %). "
        f"Over the {len(res.names)} parameters: median coverage {fraction_pct(cover['median'])}, minimum "
        f"{fraction_pct(cover['min'])}.",
        "",
    ]
    parts += [_table(sm["parameters"]), ""]
    iv = sm.get("iv")
    if iv is not None:
        c = iv["coverage_95"]
        parts += [
            "## IDIM-IV against the truth",
            "",
            "The iterated bias-compensated IDIM-IV of the same records: instruments from the identified robot "
            "simulated noise free under the same controller and reference, processed like the logs, on the same rows "
            f"and weights; Newey-West intervals. Iterations: median {iv['iterations']['median']:g}, at most "
            f"{iv['iterations']['max']}; {iv['not_converged']} run(s) not converged. Over the {len(res.names)} "
            f"parameters: median coverage {fraction_pct(c['median'])}, minimum {fraction_pct(c['min'])} (IDIM-LS: "
            f"{fraction_pct(cover['median'])}, {fraction_pct(cover['min'])}).",
            "",
            _table(iv["parameters"]),
            "",
        ]
    for path in figures:
        parts += [figure_markdown(path), ""]
    return "\n".join(parts)


def robot_text(res: Study) -> str:
    """The console summary: run figures, the coverage over the base parameters, the worst ones."""
    sm = res.statistics
    cover = sm["coverage_95"]
    worst = sorted(sm["parameters"].items(), key=lambda kv: kv[1]["coverage_95"])[:5]
    lines = [
        f"Robot Monte Carlo ({res.source}): {res.runs} runs on {res.devices} device(s) in {res.seconds:.1f} s "
        f"({res.runs_per_second:.2f} runs/s)",
    ]
    for label, st in (("IDIM-LS", sm), ("IDIM-IV", sm.get("iv"))):
        if st is None:
            continue
        cover = st["coverage_95"]
        worst = sorted(st["parameters"].items(), key=lambda kv: kv[1]["coverage_95"])[:5]
        lines += [
            f"  {label}, {len(res.names)} base parameters: coverage of the 95 % intervals median "
            f"{fraction_pct(cover['median'])}, min {fraction_pct(cover['min'])}; "
            f"{len(st['below_min_coverage'])} below {100 * MIN_COVERAGE:.0f} %",
            "  lowest: "
            + ", ".join(f"{k} {fraction_pct(p['coverage_95'])} (bias {p['bias_in_se']:+.1f} se)" for k, p in worst),
        ]
    return "\n".join(lines)


def _table(params: dict) -> str:
    rows = [
        [
            name,
            f"{p['bias']:+.4g}",
            f"{p['error_std']:.4g}",
            f"{p['mean_reported_se']:.4g}",
            "-" if p["bias_in_se"] is None else f"{p['bias_in_se']:+.2f}",
            "-" if p["se_to_spread"] is None else f"{p['se_to_spread']:.2f}",
            fraction_pct(p["coverage_95"]),
        ]
        for name, p in params.items()
    ]
    return md_table(["parameter", "bias", "error std", "mean se", "bias/se", "se/spread", "coverage"], rows)


def robot_figures(res: Study) -> dict:
    """`mc_robot_coverage`: each base parameter's coverage of the 95 % intervals and its bias in stated se."""
    p = res.statistics["parameters"]
    names = list(p)
    x = np.arange(len(names))
    fig = new_figure(figsize=(max(8.0, 0.16 * len(names)), 6.0))
    a, b = fig.subplots(2, 1, sharex=True)
    a.bar(x, [100 * p[k]["coverage_95"] for k in names], color="tab:blue")
    a.axhline(95, color="k", lw=0.8, ls="--", label="95 % (honest intervals)")
    a.axhline(100 * MIN_COVERAGE, color="tab:red", lw=0.8, ls=":", label=f"{100 * MIN_COVERAGE:.0f} %")
    a.set_ylabel("coverage (%)")
    a.set_ylim(0, 105)
    panel(a, f"(a) coverage of the stated 95 % intervals, {res.runs} runs", legend={})
    b.bar(x, [p[k]["bias_in_se"] or 0.0 for k in names], color="tab:orange")
    b.axhline(0, color="k", lw=0.8)
    b.set_ylabel("bias / mean stated se")
    b.set_xticks(x, names, rotation=90, fontsize=7)
    panel(b, "(b) bias in stated standard errors")
    return {"mc_robot_coverage": fig}
