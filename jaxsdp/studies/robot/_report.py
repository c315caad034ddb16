"""The robot study's outputs: summary.json's dict, report.md and the console text."""

from typing import TYPE_CHECKING

import numpy as np

from .._output import finite_or_none, md_table, text_table

if TYPE_CHECKING:
    from ._study import RobotStudy


def _base_rows(study: "RobotStudy") -> list[dict]:
    i = study.idim
    nominal = dict(zip(i.model.names, np.asarray(i.model.nominal, dtype=float)))
    combos = dict(zip(i.model.base.independent, i.model.base.names))
    return [
        {"name": k, "value": float(v), "rel_std": float(r), "combination": combos[k], "nominal": nominal[k]}
        for k, v, r in zip(i.result.names, np.asarray(i.result.theta), np.asarray(i.result.rel_std))
    ]


def study_summary(study: "RobotStudy") -> dict:
    """summary.json: `joints` (per joint name: `relative_error`, `sdp_relative_error`, `whiteness`,
    `shape_mismatch`), `base_parameters` (name, value, rel_std %, combination, nominal), `stacked_relative_error`,
    `rank`, `condition_number`, `warnings`, `plausible`, `scale_checks`, `findings`, `settings`, `data`, `timings`,
    `versions`."""
    i = study.idim
    joints = {}
    for j, rel in i.relative_error.items():
        w = i.whiteness[j]
        s = None if study.sdp is None else study.sdp[j]
        joints[study.names[j - 1]] = {
            "joint": j,
            "relative_error": rel,
            "sdp_relative_error": None if s is None else s.relative_error_moving,
            "shape_mismatch": None if s is None else bool(s.shape.mismatch),
            "whiteness": {"white": bool(w.white), "lag1": float(np.asarray(w.acf)[0]), "p_value": float(w.p_value)},
            "samples_used": i.samples[j],
        }
    out = {
        "warnings": list(study.warnings),
        "plausible": bool(study.plausible),
        "scale_checks": list(study.scale_checks),
        "findings": list(study.findings),
        "joints": joints,
        "base_parameters": _base_rows(study),
        "stacked_relative_error": i.stacked_relative_error,
        "rank": i.model.rank,
        "condition_number": float(i.result.cond),
        "settings": dict(study.settings),
        "data": {
            "source": study.source,
            "drives": study.drives,
            "samples": study.samples,
            "sample_time": study.sample_time,
            "resampled": study.resampled,
        },
        "timings": {k: round(float(v), 4) for k, v in study.timings.items()},
        "fast_loops": study.fast_loops,
        "versions": dict(study.versions),
    }
    return finite_or_none(out)


def _joint_rows(study):
    i = study.idim
    rows = []
    for j, rel in i.relative_error.items():
        s = None if study.sdp is None else study.sdp[j]
        rows.append(
            (
                study.names[j - 1],
                f"{rel:.1f} %",
                "-" if s is None else f"{s.relative_error_moving:.1f} %",
                "-" if s is None else ("mismatch" if s.shape.mismatch else "match"),
                "white" if bool(i.whiteness[j].white) else "correlated",
            )
        )
    return rows


_JOINT_HEAD = ("joint", "full model", "full model + SDP", "SDP shape", "residual")


def text_output(study: "RobotStudy") -> str:
    """What `jaxsdp robot` prints: the data line, the per-joint table, the stacked figures."""
    i = study.idim
    return "\n\n".join(
        [
            f"Data: {study.source}, {study.samples} samples, dt = {study.sample_time:g} s; drives: {study.drives}",
            text_table(_JOINT_HEAD, _joint_rows(study)),
            f"Stacked: {i.model.rank} base parameters, relative error {i.stacked_relative_error:.1f} %, condition "
            f"number {float(i.result.cond):.3g}",
        ]
    )


def report_markdown(study: "RobotStudy", figures=()) -> str:
    """report.md: warnings, data and settings, per-joint table, base parameters, findings, figures, timings."""
    i = study.idim
    lines = ["# Robot study: all joints at once", ""]
    if study.warnings:
        lines += ["## Warnings", ""] + [f"- {w}" for w in study.warnings] + [""]
    st = study.settings
    lines += [
        "## Data and settings",
        "",
        f"- Source: {study.source}; {study.samples} samples at {1 / study.sample_time:g} Hz; drives: {study.drives}.",
        *([f"- Time axis: {study.resampled}."] if study.resampled else []),
        f"- Processing: Butterworth order 4 at {st['cutoff_hz']:g} Hz + central differences, {st['drop']} samples "
        f"dropped at both ends, decimation by {st['decimate']}; each joint's rows at rest left out.",
        "",
        "## Per joint",
        "",
        md_table(_JOINT_HEAD, _joint_rows(study)),
        "",
        f"Stacked: {i.model.rank} base parameters, relative error {i.stacked_relative_error:.1f} %, condition number "
        f"{float(i.result.cond):.3g}.",
        "",
        "## Base parameters",
        "",
        md_table(
            ("base parameter", "estimate", "rel. std", "nominal", "combination"),
            [
                (r["name"], f"{r['value']:.4g}", f"{r['rel_std']:.2f} %", f"{r['nominal']:.4g}", r["combination"])
                for r in _base_rows(study)
            ],
        ),
        "",
        "## Findings",
        "",
    ]
    lines += [f"- {f}" for f in study.findings] + [""]
    if figures:
        lines += ["## Figures", ""] + [f"![{p}]({p})" for p in figures] + [""]
    lines += ["## Timings (s)", "", md_table(("stage", "s"), [(k, f"{v:.3f}") for k, v in study.timings.items()])]
    return "\n".join(lines) + "\n"
