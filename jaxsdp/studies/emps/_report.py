"""The EMPS study's report: findings, recovery of a known truth, `report.md` and the printed text."""

import math

import numpy as np

from ..._version import __version__
from .._output import md_table, sci

#: Tolerances (%) of the parameter recovery on the built-in plant.
RECOVERY_TOL = dict(M=1.0, Fv_pos=5.0, Fc_pos=5.0, Fv_neg=5.0, Fc_neg=5.0, fv_ratio=5.0)

_SIM_FORMAT = dict(position=".4f", velocity=".3f", acceleration=".2f", force=".2f")


def _fv_ratio_se(res) -> tuple[float, float]:
    names = list(res.names)
    th = np.asarray(res.theta, dtype=float)
    cov = np.asarray(res.cov, dtype=float)
    i, j = names.index("Fv_pos"), names.index("Fv_neg")
    a, b = th[i], th[j]
    r = b / a
    var = r**2 * (cov[j, j] / b**2 + cov[i, i] / a**2 - 2 * cov[i, j] / (a * b))
    return float(r), float(math.sqrt(max(var, 0.0)))


def recovery(summary, truth) -> dict:
    """Relative errors (%) of the recovered parameters against the truth."""
    out = {}
    for key in ("idim_ls_asym", "idim_sdp"):
        est = summary[key]
        ratio = est["Fv_neg"] / est["Fv_pos"]
        errs = {k: 100.0 * (est[k] - truth[k]) / truth[k] for k in ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")}
        errs["fv_ratio"] = 100.0 * (ratio - truth["fv_ratio"]) / truth["fv_ratio"]
        out[key] = errs
    failed = [
        f"{label} {k} {out[key][k]:+.2f} %"
        for key, label in (("idim_ls_asym", "IDIM-LS"), ("idim_sdp", "IDIM-SDP"))
        for k, tol in RECOVERY_TOL.items()
        if not abs(out[key][k]) <= tol
    ]
    out["mass_constant"] = bool(summary["sdp"]["mass_constant"])
    if not out["mass_constant"]:
        failed.append("mass not flagged constant")
    out["tolerances"] = dict(RECOVERY_TOL)
    out["within_tolerances"] = not failed
    out["failed"] = failed
    return out


def findings(study, summary) -> list[str]:
    """Short interpretation, one sentence per finding."""
    s, i, a = summary["sdp"], summary["idim_ls"], summary["idim_ls_asym"]
    out = []
    if s["mass_constant"]:
        out.append(
            f"Mass is acceleration-independent: NVR {sci(s['nvr_mass'])} (threshold {sci(study.sdp.constant_nvr)}); "
            f"SDP mass {s['mass']:.2f} kg vs IDIM-LS {i['M']:.2f} kg."
        )
    else:
        out.append(
            f"Mass appears acceleration-dependent: NVR {sci(s['nvr_mass'])} (threshold {sci(study.sdp.constant_nvr)}); "
            f"SDP weighted mass {s['mass']:.2f} kg vs IDIM-LS {i['M']:.2f} kg (see Fig. 3)."
        )
    r, se = _fv_ratio_se(study.idim_asym)
    r_sdp = summary["idim_sdp"]["fv_ratio"]
    if abs(r - 1.0) > max(3 * se, 0.05):
        side = "negative" if r > 1 else "positive"
        pct = 100 * (max(r, 1 / r) - 1)
        out.append(
            f"Friction is asymmetric: Fv-/Fv+ = {r:.3f} +- {se:.3f} (IDIM-LS), {r_sdp:.3f} (IDIM-SDP curve fit): "
            f"viscous friction {pct:.0f} % larger for {side} velocities."
        )
    else:
        out.append(f"Friction is close to symmetric: Fv-/Fv+ = {r:.3f} +- {se:.3f} (IDIM-LS), {r_sdp:.3f} (IDIM-SDP).")
    out.append(
        f"Force relative error: IDIM-LS {i['relative_error']:.2f} % (linear friction), "
        f"{a['relative_error']:.2f} % (asymmetric), SDP model {s['relative_error']:.2f} %."
    )
    sim = summary["simulation"]
    if sim.get("position") is not None:
        out.append(
            f"Closed-loop simulation of the IDIM-LS model reproduces the data: relative error position "
            f"{sim['position']:.4f} %, velocity {sim['velocity']:.3f} %, acceleration {sim['acceleration']:.2f} %, "
            f"force {sim['force']:.2f} %."
        )
    else:
        out.append(f"Closed-loop simulation check skipped: {sim.get('skipped')}.")
    rec = summary.get("recovery")
    if rec:
        e = rec["idim_ls_asym"]
        worst = max(("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"), key=lambda k: abs(e[k]))
        tol = "M 1 %, friction coefficients and Fv-/Fv+ 5 %, mass flagged constant"
        verdict = (
            f"within the tolerances ({tol})"
            if rec["within_tolerances"]
            else f"outside the tolerances ({tol}): {', '.join(rec['failed'])}"
        )
        out.append(
            f"Recovery of the true parameters (asymmetric IDIM-LS): M {e['M']:+.2f} %, worst friction coefficient "
            f"{worst} {e[worst]:+.2f} %, Fv-/Fv+ {e['fv_ratio']:+.2f} %; {verdict}."
        )
    return out


def _params_rows(res, names=None):
    names = tuple(res.names) if names is None else names
    th = np.asarray(res.theta, dtype=float)
    rs = np.asarray(res.rel_std, dtype=float)
    return {n: (float(v), float(r)) for n, v, r in zip(res.names, th, rs) if n in names}


LABELS = {
    "M": "M (kg)",
    "Fv": "Fv (N/(m/s))",
    "Fc": "Fc (N)",
    "offset": "offset (N)",
    "Fv_pos": "Fv+ (N/(m/s))",
    "Fc_pos": "Fc+ (N)",
    "Fv_neg": "Fv- (N/(m/s))",
    "Fc_neg": "Fc- (N)",
}

FIGURE_CAPTIONS = {
    "fig3_sdp_mass": "Fig. 3: SDP mass against acceleration (red) and the IDIM-LS mass (blue).",
    "fig4_friction_linear": "Fig. 4: SDP friction (red) against the linear friction model of IDIM-LS (blue); "
    "lower panel: negative velocities.",
    "fig5_friction_asym": "Fig. 5: SDP friction against the asymmetric model of eq. (17) (IDIM-SDP), and the "
    "differences.",
    "force_reconstruction": "Force reconstruction: measured force, SDP and IDIM-LS reconstructions, residuals "
    "and their histograms.",
}


def report_markdown(study, summary, figures) -> str:
    """The `report.md` text (figures linked by relative file name)."""
    d = summary["data"]
    parts = ["# EMPS identification report", ""]
    src = f"**Data:** {d['source']}, {d['samples']} samples, sample time {d['sample_time']:g} s; {study.preprocessing}."
    parts += [src, ""]
    if summary.get("truth"):
        parts += [f"Built-in plant: {d['plant']}; {d['excitation']}; {d['measurement']}; force: {d['force']}.", ""]
    parts += ["## Findings", ""] + [f"- {f}" for f in findings(study, summary)] + [""]

    # Table 1
    rows1 = _params_rows(study.idim)
    parts += ["## Table 1. IDIM-LS, linear friction model", ""]
    parts.append(
        md_table(
            ["parameter", "IDIM-LS estimate (rel. std.)"],
            [[LABELS.get(n, n), f"{v:.4f} ({r:.2f} %)"] for n, (v, r) in rows1.items()]
            + [["relative error", f"{summary['idim_ls']['relative_error']:.3f} %"]],
        )
    )
    parts.append("")

    # SDP stage
    s = summary["sdp"]
    se = s.get("log10_nvr_se") or [None, None]

    def fmt_se(v):
        return "flat likelihood" if v is None or v > 10 else f"+-{v:.2f}"

    parts += ["## SDP stage: y = M(ddq) ddq + d_fric(dq)", ""]
    parts.append(
        md_table(
            ["quantity", "value"],
            [
                ["NVR of M(ddq)", f"{sci(s['nvr_mass'])} (log10 s.e.: {fmt_se(se[0])})"],
                ["NVR of d_fric(dq)", f"{s['nvr_friction']:.3g} (log10 s.e.: {fmt_se(se[1])})"],
                ["mass", ("constant (acceleration-independent)" if s["mass_constant"] else "state-dependent")],
                ["SDP mass (acceleration-weighted)", f"{s['mass']:.4f} kg"],
                ["relative error", f"{s['relative_error']:.3f} %"],
            ],
        )
    )
    parts.append("")

    # Table 2
    p = study.idim_sdp
    curve = {"M": (p.mass, None)}
    curve.update(_params_rows(p.friction))
    asym = _params_rows(study.idim_asym)
    header = ["parameter", "IDIM-SDP (curve fit)", "IDIM-LS asymmetric"]
    truth = summary.get("truth")
    if truth:
        header.append("truth")
    rows = []
    for n in ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"):
        v, r = curve[n]
        row = [LABELS[n], f"{v:.4f}" + ("" if r is None else f" ({r:.2f} %)"), f"{asym[n][0]:.4f} ({asym[n][1]:.2f} %)"]
        if truth:
            row.append(f"{truth[n]:g}")
        rows.append(row)
    ratio_row = [
        "Fv-/Fv+",
        f"{summary['idim_sdp']['fv_ratio']:.3f}",
        f"{summary['idim_ls_asym']['Fv_neg'] / summary['idim_ls_asym']['Fv_pos']:.3f}",
    ]
    err_row = [
        "relative error",
        f"{summary['idim_sdp']['relative_error']:.3f} %",
        f"{summary['idim_ls_asym']['relative_error']:.3f} %",
    ]
    if truth:
        ratio_row.append(f"{truth['fv_ratio']:.3f}")
        err_row.append("")
    rows += [ratio_row, err_row]
    parts += ["## Table 2. IDIM-SDP, asymmetric friction model (eq. 17)", "", md_table(header, rows), ""]

    rec = summary.get("recovery")
    if rec:
        parts += ["## Recovery of the built-in plant's parameters", ""]
        keys = ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg", "fv_ratio")
        parts.append(
            md_table(
                ["error vs truth (%)"] + [LABELS.get(k, "Fv-/Fv+") for k in keys],
                [
                    ["IDIM-LS asymmetric"] + [f"{rec['idim_ls_asym'][k]:+.2f}" for k in keys],
                    ["IDIM-SDP"] + [f"{rec['idim_sdp'][k]:+.2f}" for k in keys],
                    ["tolerance"] + [f"+-{RECOVERY_TOL[k]:g}" for k in keys],
                ],
            )
        )
        flags = (
            f"Mass flagged constant: {'yes' if rec['mass_constant'] else 'no'}; "
            f"all within tolerances: {'yes' if rec['within_tolerances'] else 'no: ' + ', '.join(rec['failed'])}."
        )
        parts += ["", flags, ""]

    sim = summary["simulation"]
    parts += ["## Closed-loop simulation check", ""]
    if sim.get("position") is not None:
        method = (
            "The IDIM-LS model (linear friction) simulated in closed loop with the benchmark controller, "
            "driven by the reference `qg`; relative errors against the data "
            f"(first {study.inputs.drop} samples dropped; "
            "measured position filtered as for IDIM, simulated states used directly; force: data `gtau*vir` "
            "against the drive force on the simulated plant)."
        )
        parts += [
            method,
            "",
            md_table(
                ["signal", "relative error"],
                [[k, f"{sim[k]:{_SIM_FORMAT[k]}} %"] for k in _SIM_FORMAT],
            ),
            "",
        ]
    else:
        parts += [f"Skipped: {sim.get('skipped')}.", ""]

    parts += ["## Figures", ""]
    for name, path in figures.items():
        caption = FIGURE_CAPTIONS.get(name, name)
        parts += [f"![{caption.split(':')[0]}]({path.name})", "", f"*{caption}*", ""]

    t = summary["timings"]
    parts += ["## Timings (s, including JAX compilation)", ""]
    parts.append(md_table(["stage", "seconds"], [[k, f"{v:.2f}"] for k, v in t.items()]))
    footer = (
        f"Generated by `jaxsdp emps` (jaxsdp {__version__}); machine-readable results in [summary.json](summary.json)."
    )
    parts += ["", footer, ""]
    return "\n".join(parts)


def text_output(study, summary) -> str:
    """What the command prints: the paper's tables, the checks and the findings."""
    parts = [study.tables()]
    sim = summary["simulation"]
    if sim.get("position") is not None:
        parts.append(
            "Closed-loop simulation of the IDIM-LS model vs data (relative errors)\n"
            + "\n".join(f"  {k:<13} {sim[k]:9.4f} %" for k in ("position", "velocity", "acceleration", "force"))
        )
    else:
        parts.append(f"Closed-loop simulation check skipped: {sim.get('skipped')}")
    rec = summary.get("recovery")
    if rec:
        tr = summary["truth"]
        a, p = summary["idim_ls_asym"], summary["idim_sdp"]
        lines = [f"{'parameter':<10} {'truth':>9} {'IDIM-LS asym':>13} {'err %':>7} {'IDIM-SDP':>10} {'err %':>7}"]
        for k in ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"):
            lines.append(
                f"{k:<10} {tr[k]:9.3f} {a[k]:13.3f} {rec['idim_ls_asym'][k]:+7.2f} "
                f"{p[k]:10.3f} {rec['idim_sdp'][k]:+7.2f}"
            )
        lines.append(
            f"{'Fv-/Fv+':<10} {tr['fv_ratio']:9.3f} {a['Fv_neg'] / a['Fv_pos']:13.3f} "
            f"{rec['idim_ls_asym']['fv_ratio']:+7.2f} {p['fv_ratio']:10.3f} {rec['idim_sdp']['fv_ratio']:+7.2f}"
        )
        parts.append("Built-in plant: recovered vs true parameters\n" + "\n".join(lines))
    parts.append("Findings\n" + "\n".join(f"- {f}" for f in findings(study, summary)))
    return "\n\n".join(parts)
