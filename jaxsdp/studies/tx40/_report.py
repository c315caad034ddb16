"""The TX40 study's outputs: summary.json's dict, the Table 4/5 layout, report.md and the console text."""

import numpy as np

from ..._idim.trust import CAVEAT
from ..._runtime import x64
from .._contract import Study
from .._output import figure_markdown, finite_or_none, md_table, text_table
from ._paper import PAPER_Z, paper_comparison
from ._report_common import named_estimates, whiteness_summary
from ._report_full import full_markdown, full_summary, full_text
from ._report_paper import (
    comparison_markdown,
    comparison_text,
    experiment_markdown,
    sensitivity_markdown,
    shape_markdown,
)

ORDER = ("ZZ", "Fv", "Fc", "MX", "MY", "offset")


#: |estimate - truth| (or the difference of two estimates) above this many stated standard deviations: the
#: stated uncertainty does not cover it (the threshold of the warnings and of the "confirm" finding).
MAX_Z = 3.0
#: The parameters the IDIM-SDP projections and IDIM-LS both estimate (the offset is split differently).
COMPARED = ("Fv", "Fc", "MX", "MY")


def _stated(value: float, rel_std_pct: float) -> float:
    return abs(value) * rel_std_pct / 100.0


@x64
def recovery(study: Study) -> dict | None:
    """For simulated data: each estimate against the truth, `{column: {name: error}}`.

    The error is relative (%) where the truth is not 0, absolute (in the
    parameter's unit) where it is (MY, offset of the built-in data); `z` is
    (estimate - truth) / stated standard deviation (|z| > `MAX_Z`: the stated
    uncertainty does not cover the error, `recovery_warnings`). None for real
    data (no truth).

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, recovery
        >>> abs(recovery(example_study())["idim_ls"]["ZZ2"]["error_pct"]) < 2  # %
        True
    """
    if study.truth is None:
        return None
    n = study.names()
    ls, ls_rel = named_estimates(study.idim.result)
    sdp_est = study.sdp_estimates()
    sdp, sdp_rel = {k: v for k, (v, _) in sdp_est.items()}, {k: r for k, (_, r) in sdp_est.items()}
    out = {}
    for col, est, rel in (("idim_ls", ls, ls_rel), ("sdp", sdp, sdp_rel)):
        row = {}
        for k in ORDER:
            name = n[k]
            if name not in est or name not in study.truth:
                continue
            t, v = study.truth[name], est[name]
            sd = _stated(v, rel.get(name, float("nan")))
            row[name] = {"estimate": v, "truth": t} | (
                {"error_pct": 100.0 * (v - t) / abs(t)} if t != 0 else {"error_abs": v - t}
            )
            row[name]["z"] = (v - t) / sd if sd > 0 else None
        out[col] = row
    return out


def recovery_warnings(rec: dict | None) -> list[str]:
    """One warning when a stated standard deviation does not cover an estimate's error against the truth
    (|z| > `MAX_Z`), naming each such estimate and its error in standard deviations."""
    if rec is None:
        return []
    labels = {"idim_ls": "IDIM-LS", "sdp": "IDIM-SDP projection"}
    off = [
        f"{labels[col]} {name} {e['z']:+.1f} std ({e['error_pct']:+.2f} %)"
        if "error_pct" in e
        else f"{labels[col]} {name} {e['z']:+.1f} std"
        for col, row in rec.items()
        for name, e in row.items()
        if e.get("z") is not None and abs(e["z"]) > MAX_Z
    ]
    if not off:
        return []
    return [
        "recovery: the stated standard deviations do not cover the error against the truth ("
        + ", ".join(off)
        + f"; |error| > {MAX_Z:g} std): these estimates are biased beyond what their relative standard deviations "
        "say; read them with the error, not the stated %, as their uncertainty"
    ]


def projection_agreement(study: Study) -> dict:
    """The IDIM-SDP projections against the IDIM-LS estimates: name -> (projection - IDIM-LS) / combined
    stated standard deviation, for `COMPARED` (the test behind the "confirm" finding: all within `MAX_Z`)."""
    n = study.names()
    ls, ls_rel = named_estimates(study.idim.result)
    out = {}
    for k in COMPARED:
        name = n[k]
        v, rel = study.sdp_estimates()[name]
        sd = float(np.hypot(_stated(v, rel), _stated(ls[name], ls_rel[name])))
        out[name] = (v - ls[name]) / sd if sd > 0 else None
    return out


@x64
def study_summary(study: Study) -> dict:
    """summary.json's content (JSON-safe: inf and NaN as null).

    Keys: `idim_ls` (parameters, `relative_error`, `rel_std` %, `condition_number`),
    `sdp` (`relative_error`, `iterations`, `converged`, `nvr`, `gravity`,
    `friction`, `offset_sum`, `parametric_relative_error`, ...), `whiteness`,
    `data`, `timings`, `settings`, `reference`, `recovery`, `warnings`,
    `plausible`, `scale_checks` (`_checks.scale_checks`); with the full model
    also `full_model`, `full_model_sdp` and `coupling` (`_report_full.full_summary`).

    Example:
        >>> from jaxsdp.studies.tx40 import example_study
        >>> s = example_study().summary()
        >>> sorted(s["sdp"]["gravity"]), s["sdp"]["converged"]
        (['MX2', 'MY2', 'offset'], True)
    """
    n, i, s = study.names(), study.idim, study.sdp
    theta, rel = named_estimates(i.result)
    g, _ = named_estimates(s.gravity)
    f, _ = named_estimates(s.friction)
    res = s.result
    out = {
        "warnings": list(study.warnings),
        "plausible": bool(study.plausible),
        "scale_checks": list(study.scale_checks),
        "joint": study.joint,
        "idim_ls": {
            **theta,
            "relative_error": float(i.result.relative_error),
            "relative_error_record": i.relative_error_record,
            "rel_std": rel,
            "condition_number": float(i.result.cond),
            "samples_used": int(np.sum(np.asarray(i.moving))),
        },
        "sdp": {
            "relative_error": s.relative_error,
            "relative_error_moving": s.relative_error_moving,
            "fit_on": s.fit_on,
            "iterations": int(res.iterations),
            "converged": bool(res.converged),
            "nvr": {"gravity": float(res.nvr[0]), "friction": float(res.nvr[1])},
            "nvr_log10_se": {"gravity": float(res.log10_nvr_se[0]), "friction": float(res.log10_nvr_se[1])},
            "edf": {"gravity": float(res.edf[0]), "friction": float(res.edf[1])},
            "nvr_converged": [bool(v) for v in np.asarray(res.nvr_converged)],
            "model": list(s.model),
            "tol": s.tol,
            "inertia": {n["ZZ"]: s.inertia, "source": s.inertia_source},
            "gravity": {n["MX"]: g[n["MX"]], n["MY"]: g[n["MY"]], "offset": g["offset"]},
            "friction": {n["Fv"]: f[n["Fv"]], n["Fc"]: f[n["Fc"]], "offset": f["offset"]},
            "rel_std": {k: v[1] for k, v in study.sdp_estimates().items()},
            "offset_sum": s.offset_sum,
            "parametric_relative_error": s.parametric_relative_error,
            "parametric_relative_error_moving": s.parametric_relative_error_moving,
            "curve_mismatch": {"gravity": s.mismatch[0], "friction": s.mismatch[1]},
            "shape_mismatch": bool(s.shape.mismatch),
            "shape_test": {
                "statistic": s.shape.statistic,
                "threshold": s.shape.threshold,
                "edf": s.shape.edf,
                "samples": s.shape.samples,
                "variance_parametric": s.shape.variance_parametric,
                "variance_sdp": s.shape.variance_sdp,
                "verdict": study.shape_verdict,
                "settings": None if study.checks is None else list(study.checks["shape"]),
            },
            "change_history": [float(v) for v in np.asarray(res.change_history) if np.isfinite(v)],
        },
        "whiteness": {"idim_ls": whiteness_summary(i.whiteness), "sdp": whiteness_summary(s.whiteness)},
        "reference": {
            "name": study.reference_name,
            "label": study.reference_label,
            "reason": study.reference_reason,
            "values": study.reference,
            "published": study.published,
        },
        "paper_comparison": paper_comparison(study),
        "sensitivity": None if study.checks is None else list(study.checks["sensitivity"]),
        "recovery": recovery(study),
        "settings": dict(study.settings),
        "timings": {k: round(float(v), 4) for k, v in study.timings.items()},
        "data": {
            "source": study.source,
            "samples": study.samples,
            "sample_time": study.sample_time,
            "preprocessing": study.preprocessing,
            "samples_used": int(np.sum(np.asarray(i.moving))),
            "decimated_samples": int(study.inputs.y.shape[0]),
            "dt_decimated": float(study.inputs.dt),
            "files": list(study.data_files),
            "moving_joints": [j for j, m in study.motion.items() if m["moves"]],
            "motion": {str(j): dict(m) for j, m in study.motion.items()},
        },
    }
    out.update(full_summary(study))
    out["fast_loops"] = study.fast_loops
    out["versions"] = dict(study.versions)
    return finite_or_none(out)


def table_rows(study: Study) -> list[tuple]:
    """Rows (parameter, IDIM-LS, IDIM-SDP, reference) of the paper's Table 4/5 layout, as strings."""
    n = study.names()
    theta, rel = named_estimates(study.idim.result)
    sdp = study.sdp_estimates()
    rows = []
    for k in ORDER:
        name = n[k]
        ls = f"{theta[name]:.4g} ({rel[name]:.2f}%)"
        if k == "ZZ":
            sd = f"X (fixed {study.sdp.inertia:.4g}, {study.sdp.inertia_source})"
        else:
            v, r = sdp[name]
            sd = f"{v:.4g} ({r:.2f}%)" + (" (sum of 2 offsets)" if k == "offset" else "")
        ref = "-" if study.reference is None or name not in study.reference else f"{study.reference[name]:.4g}"
        rows.append((name, ls, sd, ref))
    i, s = study.idim, study.sdp
    rows.append(("relative error (whole record)", f"{i.relative_error_record:.1f}%", f"{s.relative_error:.1f}%", "X"))
    rows.append(
        ("relative error (in motion)", f"{float(i.result.relative_error):.1f}%", f"{s.relative_error_moving:.1f}%", "X")
    )
    rows.append(("parametric rebuild (whole record)", "-", f"{s.parametric_relative_error:.1f}%", "X"))
    return rows


def multi_sdp_line(study: Study) -> str:
    """The back-fitting outcome, the per-curve NVRs with their standard errors, degrees of freedom, offsets."""
    s = study.sdp
    res = s.result
    nvr = []
    for k, label in enumerate(("gravity", "friction")):
        se = float(res.log10_nvr_se[k])
        err = f" (log10 s.e. {se:.2g})" if np.isfinite(se) else ""
        nvr.append(f"{label} {float(res.nvr[k]):.3g}{err}, {float(res.edf[k]):.0f} dof")
    return (
        f"Multi-SDP: {res.reason}; NVR {'; '.join(nvr)}; offsets gravity {s.gravity['offset']:.4g} + friction "
        f"{s.friction['offset']:.4g} = {s.offset_sum:.4g} N m; {s.shape.text()}"
    )


def _table_title(study) -> str:
    return f"Table 4/5 layout. Joint {study.joint}: IDIM-LS and IDIM-SDP estimates (relative standard deviation)"


def study_tables(study: Study, *, warnings: bool = True) -> str:
    """Text tables of a `TX40Study` (its warnings first, unless `warnings=False`)."""
    head = ("parameter", "IDIM-LS", "IDIM-SDP", study.reference_label if study.reference else "reference")
    s = study.sdp
    parts = []
    if warnings and study.warnings:
        parts.append("WARNINGS\n" + "\n".join(f"- {w}" for w in study.warnings))
    parts += [
        f"Data: {study.source}, {study.samples} samples, dt = {study.sample_time:g} s; {study.preprocessing}; "
        f"{int(np.sum(np.asarray(study.idim.moving)))} samples in motion (|dq| >= {study.idim.min_speed:.3g} rad/s)"
        + (f"\nReference: {study.reference_reason}" if study.reference_reason else ""),
        _table_title(study) + "\n" + text_table(head, table_rows(study)),
        *([side] if (side := comparison_text(study)) else []),
        multi_sdp_line(study)
        + ("" if study.checks is None else f"; at neighbouring settings: {study.checks['verdict']}"),
        f"Whiteness (decimated residuals): IDIM-LS {study.idim.whiteness.text()}\n"
        f"                                 SDP     {s.whiteness.text()}",
    ]
    return "\n\n".join(parts)


@x64
def text_output(study: Study) -> str:
    """What `jaxsdp tx40` prints on stdout: the data line, the Table 4/5 layout, the multi-SDP outcome and
    the whiteness tests (the warnings go to stderr separately).

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, text_output
        >>> "IDIM-SDP" in text_output(example_study())
        True
    """
    return "\n\n".join(t for t in (study.tables(warnings=False), full_text(study)) if t)


@x64
def report_markdown(study: Study, figures=()) -> str:
    """report.md: warnings, data and settings (with the defaults' rationale), the Table 4/5 layout, recovery
    (simulated data), residual whiteness, the paper's published values, findings, figures and timings.

    `figures`: file names (relative to the report) to embed.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, report_markdown
        >>> report_markdown(example_study()).splitlines()[0]
        '# TX40 study, joint 2 (paper section 3)'
    """
    s, i = study.sdp, study.idim
    lines = [f"# TX40 study, joint {study.joint} (paper section 3)", ""]
    if study.warnings:
        lines += ["## Warnings", ""] + [f"- {w}" for w in study.warnings] + [""]
        if not study.plausible:
            lines += [CAVEAT, ""]
    st = study.settings
    lines += [
        "## Data and settings",
        "",
        f"- Source: {study.source}; {study.samples} samples at {1 / study.sample_time:g} Hz.",
        f"- Processing: {study.preprocessing}.",
        f"- Samples in motion (|dq| >= {st['min_speed']:.3g} rad/s, {st.get('min_speed_rule', 'given')}) used by "
        f"IDIM-LS and the curves' projections: {int(np.sum(np.asarray(i.moving)))} of {study.inputs.y.shape[0]} "
        "(at rest, static friction holds the joint and eq. (21) does not apply). The back-fitting uses "
        + ("every sample (the curves are free functions)." if s.fit_on == "all" else "the same samples."),
        f"- Multi-SDP: inertia fixed at {s.inertia:.4g} kg m^2 ({s.inertia_source}); models {', '.join(s.model)}; "
        f"NVRs by maximum likelihood at every iteration (cap {st['max_nvr']}); tol {100 * s.tol:g} % (the paper's "
        f"1 %); at most {st['max_iter']} iterations.",
        "- Why these defaults: the Butterworth at 100 Hz and decimation to 500 Hz are the EMPS benchmark's and the "
        "paper's processing; the rest threshold at 1 % of the joint's peak speed leaves out the samples where the "
        "velocity's sign is unreliable and the Stribeck region (on the real all-joints logs it brings every IDIM-LS "
        "estimate within 2.5 of the paper's standard deviations; see the sensitivity table); RW curves with ML NVRs "
        "let the data set each curve's smoothness; the inertia comes from IDIM-LS unless a CAD value is given, as "
        "the paper fixes it before the back-fitting.",
        "",
        "## " + _table_title(study),
        "",
        md_table(
            ("parameter", "IDIM-LS", "IDIM-SDP", study.reference_label if study.reference else "reference"),
            table_rows(study),
        ),
        "",
        f"The IDIM-SDP column is the parametric projection of the SDP curves: gravity on [-g cos q, g sin q, 1], "
        f"friction on [dq, sign dq, 1]; its offset is the sum of the two curves' offsets "
        f"({s.gravity['offset']:.4g} + {s.friction['offset']:.4g} N m), since only the sum is identified.",
        "",
        multi_sdp_line(study) + ".",
        "",
    ]
    lines += experiment_markdown(study) + comparison_markdown(study) + shape_markdown(study)
    lines += sensitivity_markdown(study)
    rec = recovery(study)
    if rec is not None:
        rows = []
        for name, ls in rec["idim_ls"].items():
            sd = rec["sdp"].get(name)
            fmt = lambda e: (
                "-"
                if e is None
                else (f"{e['error_pct']:+.2f} %" if "error_pct" in e else f"{e['error_abs']:+.4f} (abs.)")
            )
            rows.append((name, f"{ls['truth']:.4g}", fmt(ls), fmt(sd)))
        lines += [
            "## Recovery of the simulated truth",
            "",
            md_table(("parameter", "truth", "IDIM-LS error", "IDIM-SDP error"), rows),
            "",
        ]
    lines += [
        "## Residual whiteness",
        "",
        "Residuals at the decimated rate are tested against white noise passed through the decimation filter "
        "(lag-1 autocorrelation about +0.18 by itself), not against white noise.",
        "",
        f"- IDIM-LS: {i.whiteness.text()}",
        f"- SDP: {s.whiteness.text()}",
        "",
    ]
    lines += ["## Findings", ""] + [f"- {f}" for f in (study.findings or findings(study))] + [""]
    lines += full_markdown(study)
    if figures:
        lines += ["## Figures", ""] + [figure_markdown(p) for p in figures] + [""]
    lines += ["## Timings (s)", "", md_table(("stage", "s"), [(k, f"{v:.3f}") for k, v in study.timings.items()])]
    return "\n".join(lines) + "\n"


@x64
def findings(study: Study) -> list[str]:
    """The study's conclusions in words: the relative errors of IDIM-LS (eq. 22), of the multi-SDP model
    and of the parametric model rebuilt from its curves (%), whether the curves follow eq. (20)'s shapes,
    and whether the residuals are white.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, findings
        >>> findings(example_study())[1].startswith("The SDP curves follow")
        True
    """
    s, i = study.sdp, study.idim
    le, se, pe = i.relative_error_record, s.relative_error, s.parametric_relative_error
    out = [
        f"Over the whole record (the paper's definition), IDIM-LS explains the torque to {le:.1f} % relative "
        f"error, the multi-SDP model to {se:.1f} %, the parametric model rebuilt from the SDP curves to {pe:.1f} % "
        f"(in motion: {float(i.result.relative_error):.1f}, {s.relative_error_moving:.1f} and "
        f"{s.parametric_relative_error_moving:.1f} %)."
    ]
    agreement = projection_agreement(study)
    apart = [f"{k} {z:+.1f}" for k, z in agreement.items() if z is not None and abs(z) > MAX_Z]
    verdict = study.shape_verdict
    where = "" if study.checks is None else f", at every neighbouring setting tried ({len(study.checks['shape'])})"
    if verdict == "fragile":
        out.append(
            "Whether the SDP curves follow eq. (20)'s shapes depends on the processing (fragile: see the shape "
            f"test's table); this run: {s.shape.text()}."
        )
    elif verdict == "mismatch":
        out.append(
            f"The SDP curves do not follow the gravity and friction shapes of eq. (20): {s.shape.evidence()}{where}; "
            "the one-joint model is mis-specified for these data (the paper's finding when all links move: the "
            "coupling of the moving links)."
        )
    elif apart:
        out.append(
            f"The SDP curves follow the gravity and friction shapes of eq. (20) ({s.shape.evidence()}{where}), but "
            f"their parametric projections do not confirm the IDIM-LS estimates: {', '.join(apart)} combined "
            f"standard deviations apart (test: every one of {', '.join(agreement)} within {MAX_Z:g})."
        )
    else:
        out.append(
            f"The SDP curves follow the gravity and friction shapes of eq. (20) ({s.shape.evidence()}{where}), and "
            f"the IDIM-SDP projections confirm the IDIM-LS estimates: {', '.join(agreement)} within {MAX_Z:g} "
            "combined standard deviations (the paper's finding when only link 2 moves)."
        )
    cmp = paper_comparison(study)
    if cmp is not None:
        far = [f"{k} {r['z']:+.1f}" for k, r in cmp["idim_ls"].items() if r["z"] is not None and abs(r["z"]) > PAPER_Z]
        label = study.reference_label.replace(" reference values", "")
        out.append(
            f"Against {label}: every IDIM-LS estimate lies within {PAPER_Z:g} of the paper's standard deviations "
            f"(largest |z| {cmp['max_abs_z']['idim_ls']:.1f})."
            if not far
            else f"Against {label}: IDIM-LS estimates beyond {PAPER_Z:g} of the paper's standard deviations: "
            f"{', '.join(far)}."
        )
    white = bool(i.whiteness.white) and bool(s.whiteness.white)
    out.append(
        "Both residuals are as white as decimated measurement noise."
        if white
        else "A residual is serially correlated: see the warnings."
    )
    return out
