"""The TX40 report's sections on the experiment, the paper's table side by side, the shape test and the
processing's effect (`report_markdown` calls them; summary.json's keys come from the same numbers)."""

from .._contract import Study
from .._output import md_table
from ._paper import PAPER_Z, paper_comparison


def motion_rows(study: Study) -> list[tuple]:
    """(joint, range rad, rms speed rad/s, moves) per logged joint."""
    return [
        (str(j), f"{m['range']:.3g}", f"{m['rms_speed']:.3g}", "yes" if m["moves"] else "no")
        for j, m in study.motion.items()
    ]


def experiment_markdown(study: Study) -> list[str]:
    """Which joints move, and the reference table chosen (and why)."""
    if not study.motion:
        return []
    return [
        "## The experiment: which joints move",
        "",
        md_table(("joint", "range (rad)", "rms speed (rad/s)", "moves"), motion_rows(study)),
        "",
        f"Reference: {study.reference_label if study.reference else 'none'}; {study.reference_reason}.",
        "",
    ]


def _z(v) -> str:
    return "-" if v is None else f"{v:+.1f}"


def _num(v) -> str:
    return "-" if v is None else f"{v:.4g}"


def comparison_rows(cmp: dict) -> list[tuple]:
    """Rows (parameter, paper IDIM-LS (rsd), jaxsdp IDIM-LS, z, paper SDP (rsd), jaxsdp SDP, z)."""
    rows = []
    for name, ls in cmp["idim_ls"].items():
        sd = cmp["sdp"].get(name)
        rows.append(
            (
                name,
                f"{ls['paper']:.4g} ({ls['paper_rel_std']:g} %)",
                _num(ls["jaxsdp"]),
                _z(ls["z"]),
                "fixed" if sd is None else f"{sd['paper']:.4g} ({sd['paper_rel_std']:g} %)",
                "fixed" if sd is None else _num(sd["jaxsdp"]),
                "-" if sd is None else _z(sd["z"]),
            )
        )
    re = cmp["relative_error"]
    rows.append(
        (
            "relative error (whole record)",
            f"{re['idim_ls']['paper']:.1f} %",
            f"{re['idim_ls']['jaxsdp']:.1f} %",
            "",
            f"{re['sdp']['paper']:.1f} %",
            f"{re['sdp']['jaxsdp']:.1f} %",
            "",
        )
    )
    it = cmp["iterations"]
    rows.append(("back-fitting iterations", "", "", "", _num(it["paper"]), str(it["jaxsdp"]), ""))
    return rows


#: Heads of the side-by-side table (report.md and the console).
COMPARISON_HEAD = ("parameter", "paper IDIM-LS", "jaxsdp", "z", "paper SDP", "jaxsdp", "z")


def comparison_text(study: Study) -> str | None:
    """The console's side-by-side table: the paper's published estimates (its Table 4 or 5) beside the study's,
    each difference in the paper's standard deviations; None without a paper table."""
    from .._output import text_table

    cmp = paper_comparison(study)
    if cmp is None:
        return None
    table = study.reference_label.replace("paper ", "").replace(" reference values", "")
    return (
        f"The paper's {table}: its published estimates beside jaxsdp's; z = (jaxsdp - paper) / the paper's standard "
        f"deviation (largest IDIM-LS |z| {cmp['max_abs_z']['idim_ls']:.1f}, target {PAPER_Z:g}):\n"
        + text_table(COMPARISON_HEAD, comparison_rows(cmp))
    )


def comparison_markdown(study: Study) -> list[str]:
    """The paper's table beside the study's estimates, each difference in the paper's standard deviations."""
    cmp = paper_comparison(study)
    if cmp is None:
        return []
    worst = cmp["max_abs_z"]["idim_ls"]
    return [
        f"## The paper's {study.reference_label.replace('paper ', '').replace(' reference values', '')}, side by side",
        "",
        md_table(COMPARISON_HEAD, comparison_rows(cmp)),
        "",
        "z = (jaxsdp - paper) / the paper's standard deviation (its relative standard deviation times its "
        f"estimate). IDIM-LS: largest |z| {worst:.1f} (target {PAPER_Z:g}). The SDP offset is the sum of the two "
        "curves' offsets. Relative errors over the whole record, samples at rest included (the paper's "
        "definition, ||e|| / ||y|| over all N_S samples).",
        "",
    ]


def shape_markdown(study: Study) -> list[str]:
    """The shape test, its statistic and threshold, and its verdict at the neighbouring settings."""
    sh = study.sdp.shape
    lines = [
        "## Do the SDP curves follow eq. (20)'s shapes?",
        "",
        "The parametric model (the curves' projections, 5 parameters) and the SDP model (the two curves, their "
        "effective degrees of freedom the trace of the smoothers' hat matrices) each give an unbiased residual "
        "variance on the samples in motion; the statistic is the share of the parametric model's residual variance "
        "that the curves explain, 100 (1 - s2_sdp / s2_par) %. A curve that only follows noise explains about its "
        "degrees of freedom' worth, which the counts remove; the verdict is an effect size, since with thousands "
        "of serially correlated samples an F-test rejects any model, a simulated parametric truth included.",
        "",
        f"- This run: {sh.statistic:.1f} % (threshold {sh.threshold:g} %; {sh.edf:.0f} degrees of freedom, "
        f"{sh.samples} samples in motion; s2_par {sh.variance_parametric:.4g}, s2_sdp {sh.variance_sdp:.4g} "
        "(N m)^2): " + ("mismatch." if sh.mismatch else "match."),
    ]
    if study.checks is not None:
        rows = [
            (r["setting"], f"{r['statistic']:.1f} %", "mismatch" if r["mismatch"] else "match")
            for r in study.checks["shape"]
        ]
        lines += [
            f"- At neighbouring settings: **{study.checks['verdict']}**"
            + (" (the verdicts differ: fragile)" if study.checks["verdict"] == "fragile" else " at every one"),
            "",
            md_table(("setting", "statistic", "verdict"), rows),
        ]
    return lines + [""]


def sensitivity_markdown(study: Study) -> list[str]:
    """How far each IDIM-LS estimate moves at neighbouring settings."""
    if study.checks is None or not study.checks["sensitivity"]:
        return []
    rows = study.checks["sensitivity"]
    names = [k for k in rows[0] if k != "setting"]
    unit = "the paper's standard deviations" if study.published is not None else "their stated standard deviations"
    table = [(r["setting"], *(_z(r[k]) for k in names)) for r in rows]
    moves = []
    for name in names:
        big = [r["setting"] for r in rows if r[name] is not None and abs(r[name]) >= 1.0]
        if big:
            moves.append(f"{name}: {', '.join(big)}")
    return [
        "## Which processing choice moves which parameter",
        "",
        f"IDIM-LS re-run with one setting changed; each entry is the move of the estimate in {unit}.",
        "",
        md_table(("setting", *names), table),
        "",
        "Moves of one standard deviation or more: " + ("; ".join(moves) if moves else "none") + ".",
        "",
    ]
