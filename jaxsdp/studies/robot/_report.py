"""The robot study's outputs: summary.json's dict, report.md and the console text."""

import numpy as np

from ...plants.robot._validation import joint_units
from .._contract import Study
from .._output import figure_markdown, finite_or_none, md_table, text_table
from ._friction_report import friction_markdown, friction_summary
from ._iv_report import iv_markdown, iv_summary
from ._physical_report import physical_markdown, physical_summary


def sd_inflation(whiteness) -> float:
    """How much a residual's autocorrelation understates the standard deviations of a least-squares fit on slowly
    varying regressors: sqrt(1 + 2 sum_k (1 - k / (L + 1)) r_k) over its L tested lags (Bartlett window)."""
    acf = np.asarray(whiteness.acf, dtype=float)
    lags = np.arange(1, acf.size + 1)
    return float(np.sqrt(max(1.0 + 2.0 * np.sum((1.0 - lags / (acf.size + 1)) * acf), 0.0)))


def _base_rows(study: Study) -> list[dict]:
    i = study.idim
    nominal = dict(zip(i.model.names, np.asarray(i.model.nominal, dtype=float)))
    combos = dict(zip(i.model.base.independent, i.model.base.names))
    return [
        {"name": k, "value": float(v), "rel_std": float(r), "combination": combos[k], "nominal": nominal[k]}
        for k, v, r in zip(i.result.names, np.asarray(i.result.theta), np.asarray(i.result.rel_std))
    ]


def _units(study: Study, j: int) -> dict:
    return joint_units(study.idim.model.robot, j)


def verdicts(study: Study) -> dict:
    """joint -> (identifiable, reason) from the study's optional `verdicts` (joint -> a pair (identifiable,
    reason), the reason a string or a sequence of sentences, joined by "; "); {} when it has none."""
    out = {}
    for j, (ok, why) in dict(getattr(study, "verdicts", None) or {}).items():
        why = why if isinstance(why, str) else "; ".join(str(w) for w in (why or ()))
        out[int(j)] = (bool(ok), why)
    return out


def _joints(study: Study) -> list[int]:
    """The joints identified, then those judged but left out of the fit."""
    rows = list(study.idim.relative_error)
    return rows + sorted(j for j in verdicts(study) if j not in rows)


def _cross_validation(study: Study) -> dict | None:
    """The study's optional `validation` (`robot_cross_validation`) with joints by name; None when absent."""
    cv = getattr(study, "validation", None)
    if cv is None:
        return None

    def named(d):
        return None if d is None else {study.names[j - 1]: v for j, v in d.items()}

    folds = [{**f, "samples": named(f["samples"]), "relative_error": named(f["relative_error"])} for f in cv["folds"]]
    return {
        **cv,
        "folds": folds,
        "relative_error": named(cv["relative_error"]),
        "in_sample": named(cv["in_sample"]),
    }


def study_summary(study: Study) -> dict:
    """summary.json: `joints` (per joint name: `relative_error` (rows in motion), `relative_error_all` (whole
    record, rows at rest included), `sdp_relative_error`, `whiteness`, `shape_mismatch`, `samples_used`,
    `min_speed` (the rest threshold, in `units["velocity"]`) and `units` (`effort`, `position`, `velocity`,
    `acceleration`: N m, rad, rad/s for a revolute joint; N, m, m/s for a prismatic one); `identifiable` and
    `reason` when the study judged the joints; a joint judged but left out of the fit has its numbers None),
    `base_parameters` (name, value, rel_std %, combination, nominal),
    `stacked_relative_error`, `rank`, `condition_number`, `cross_validation` (`robot_cross_validation` with
    joints by name, or None), `physical` (`physical_summary`: the physically consistent estimate, or None),
    `friction` (`friction_summary`: each joint's friction law, or None), `idim_iv` (`iv_summary`: the IDIM-IV
    beside its IDIM-LS start, or None),
    `warnings`, `plausible`, `scale_checks`, `findings`, `settings`, `data`,
    `timings`, `versions`."""
    i = study.idim
    judged = verdicts(study)
    joints = {}
    for j in _joints(study):
        entry = {"joint": j, "units": _units(study, j)}
        if j in i.relative_error:
            w = i.whiteness[j]
            s = None if study.sdp is None else study.sdp.get(j)
            entry |= {
                "relative_error": i.relative_error[j],
                "relative_error_all": i.relative_error_all.get(j),
                "sdp_relative_error": None if s is None else s.relative_error_moving,
                "shape_mismatch": None if s is None else bool(s.shape.mismatch),
                "whiteness": {
                    "white": bool(w.white),
                    "lag1": float(np.asarray(w.acf)[0]),
                    "p_value": float(w.p_value),
                    "sd_inflation": sd_inflation(w),
                },
                "samples_used": i.samples[j],
                "min_speed": float(i.min_speed[j]),
            }
        else:  # judged, left out of the fit
            entry |= dict.fromkeys(("relative_error", "relative_error_all", "sdp_relative_error"))
            entry |= {"shape_mismatch": None, "whiteness": None, "samples_used": 0, "min_speed": None}
        if j in judged:
            ok, why = judged[j]
            entry |= {"identifiable": ok, "reason": why or None}
        joints[study.names[j - 1]] = entry
    out = {
        "warnings": list(study.warnings),
        "plausible": bool(study.plausible),
        "scale_checks": list(study.scale_checks),
        "findings": list(study.findings),
        "joints": joints,
        "base_parameters": _base_rows(study),
        "stacked_relative_error": _stacked(study),
        "rank": i.model.rank,
        "description": [dict(r) for r in getattr(study, "description", ())],
        "condition_number": float(i.result.cond),
        "cross_validation": _cross_validation(study),
        "physical": physical_summary(study),
        "friction": friction_summary(study),
        "idim_iv": iv_summary(study),
        "settings": dict(study.settings),
        "data": {
            "source": study.source,
            "drives": study.drives,
            "samples": study.samples,
            "sample_time": study.sample_time,
            "resampled": study.resampled,
            "notes": list(getattr(study, "notes", ())),
        },
        "timings": {k: round(float(v), 4) for k, v in study.timings.items()},
        "fast_loops": study.fast_loops,
        "versions": dict(study.versions),
    }
    return finite_or_none(out)


def _stacked(study) -> float:
    """The stacked relative error (%) over the identifiable joints' rows (the fit's, when not judged)."""
    v = getattr(study, "stacked_relative_error", None)
    return study.idim.stacked_relative_error if v is None else v


def _description_rows(study) -> list[tuple]:
    out = []
    for r in getattr(study, "description", ()):
        ratio = r.get("ratio")
        out.append(
            (
                r["name"],
                f"{r['identified']:.4g}",
                f"{r['nominal']:.4g}",
                "-" if ratio is None else f"{ratio:.3g}",
                {True: "differs", False: "agrees", None: "-"}[r.get("flag")],
                r.get("note") or "",
            )
        )
    return out


def _pct(v) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{v:.1f} %"


def _joint_rows(study):
    i = study.idim
    judged = verdicts(study)
    rows = []
    for j in _joints(study):
        u = _units(study, j)
        if j in i.relative_error:
            s = None if study.sdp is None else study.sdp.get(j)
            row = (
                study.names[j - 1],
                u["effort"],
                _pct(i.relative_error[j]),
                _pct(i.relative_error_all.get(j)),
                "-" if s is None else _pct(s.relative_error_moving),
                "-" if s is None else ("mismatch" if s.shape.mismatch else "match"),
                "white" if bool(i.whiteness[j].white) else "correlated",
                f"{i.min_speed[j]:.3g} {u['velocity']}",
            )
        else:
            row = (study.names[j - 1], u["effort"], "not fitted") + ("-",) * 5
        if judged:
            ok, why = judged.get(j, (True, ""))
            row += ("yes" if ok else f"no: {why}" if why else "no",)
        rows.append(row)
    return rows


_JOINT_HEAD = (
    "joint",
    "torque unit",
    "full model (in motion)",
    "whole record",
    "full model + SDP",
    "SDP shape",
    "residual",
    "at rest below",
)


def _joint_head(study) -> tuple:
    return _JOINT_HEAD + (("identifiable",) if verdicts(study) else ())


def _cv_line(study) -> str | None:
    cv = getattr(study, "validation", None)
    if cv is None:
        return None
    held = ", ".join(f"{study.names[j - 1]} {_pct(v)}" for j, v in cv["relative_error"].items())
    return (
        f"Cross-validation ({len(cv['folds'])} blocks in time, {cv['fitted']} fitted): held-out relative error "
        f"{held} (stacked {_pct(cv['stacked_relative_error'])})"
    )


def _cv_markdown(study) -> list[str]:
    cv = getattr(study, "validation", None)
    if cv is None:
        return []
    folds = cv["folds"]

    def span(f):
        return f"block {f['fold']}" + ("" if f["time"] is None else f" ({f['time'][0]:.1f}-{f['time'][1]:.1f} s)")

    head = ("joint", "in sample", "held out", *(span(f) for f in folds))
    rows = [
        (
            study.names[j - 1],
            _pct(cv["in_sample"].get(j)),
            _pct(v),
            *("-" if f["relative_error"] is None else _pct(f["relative_error"].get(j)) for f in folds),
        )
        for j, v in cv["relative_error"].items()
    ]
    lines = [
        "## Cross-validation",
        "",
        f"The record split into {len(folds)} blocks in time; each block's rows in motion predicted by the fit on "
        "the other blocks (same base parameters, same rows). Held-out errors close to the in-sample ones: the "
        "estimates do not depend on which part of the motion they saw.",
        "",
        md_table(head, rows),
        "",
        f"Stacked: in sample {_pct(cv['stacked_in_sample'])}, held out {_pct(cv['stacked_relative_error'])}.",
        "",
    ]
    lines += [f"- Block {f['fold']} not fitted: {f['reason']}." for f in folds if f["reason"]]
    return lines + ([""] if any(f["reason"] for f in folds) else [])


def _rest_line(study) -> str:
    i = study.idim
    per = ", ".join(
        f"{study.names[j - 1]} {i.min_speed[j]:.3g} {_units(study, j)['velocity']}" for j in i.relative_error
    )
    return f"- At rest (rows left out of the fit and of the errors in motion): speed below {per}."


def text_output(study: Study) -> str:
    """What `jaxsdp robot` prints: the data line, the per-joint table, the stacked figures."""
    i = study.idim
    return "\n\n".join(
        [
            f"Data: {study.source}, {study.samples} samples, dt = {study.sample_time:g} s; drives: {study.drives}",
            text_table(_joint_head(study), _joint_rows(study)),
            f"Stacked: {i.model.rank} base parameters, relative error {_stacked(study):.1f} %, condition "
            f"number {float(i.result.cond):.3g}",
            *([line] if (line := _cv_line(study)) else []),
        ]
    )


def report_markdown(study: Study, figures=()) -> str:
    """report.md: warnings, data and settings, per-joint table, base parameters, cross-validation (when the
    study has one), findings, figures, timings."""
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
        *[f"- Note: {n}." for n in getattr(study, "notes", ())],
        f"- Processing: Butterworth order 4 at {st['cutoff_hz']:g} Hz + central differences, {st['drop']} samples "
        f"dropped at both ends, decimation by {st['decimate']}; each joint's rows at rest left out.",
        *[f"  - {v}" + ("" if v.endswith(".") else ".") for v in st.get("reasons", {}).values() if v != "given"],
        _rest_line(study),
        "",
        "## Per joint",
        "",
        "Relative error of each joint's torque (force for a prismatic joint), in motion (the rows fitted) and "
        "over the whole record (rows at rest included, the filter's end transients left out).",
        "",
        md_table(_joint_head(study), _joint_rows(study)),
        "",
        f"Stacked: {i.model.rank} base parameters, relative error {_stacked(study):.1f} %, condition number "
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
    ]
    if getattr(study, "description", ()):
        lines += [
            "## Against the description",
            "",
            "Each base parameter beside the value the URDF's inertias give for the same combination (compared "
            "where the description gives a non-negligible value and the estimate is well determined; a factor "
            "of more than three either way is flagged, with its likely cause in the warnings).",
            "",
            md_table(("base parameter", "identified", "URDF", "ratio", "verdict", "note"), _description_rows(study)),
            "",
        ]
    lines += iv_markdown(study)
    lines += physical_markdown(study)
    lines += friction_markdown(study)
    lines += _cv_markdown(study)
    lines += ["## Findings", ""] + [f"- {f}" for f in study.findings] + [""]
    if figures:
        lines += ["## Figures", ""] + [figure_markdown(p) for p in figures] + [""]
    lines += ["## Timings (s)", "", md_table(("stage", "s"), [(k, f"{v:.3f}") for k, v in study.timings.items()])]
    return "\n".join(lines) + "\n"
