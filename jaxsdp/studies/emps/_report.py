"""The EMPS study's report: findings, recovery of a known truth, `report.md` and the printed text."""

import numpy as np

from ..._idim.trust import CAVEAT, asymmetry_test, nvr_text
from ..._runtime import x64
from ..._version import __version__
from ...plants.emps._model import EMPS_ASYM_NAMES
from .._output import figure_markdown, md_table, sci
from ._simulation_check import REPRODUCES

#: Tolerances (%) of the parameter recovery on the built-in plant.
RECOVERY_TOL = dict(M=1.0, Fv_pos=5.0, Fc_pos=5.0, Fv_neg=5.0, Fc_neg=5.0, fv_ratio=5.0)

_SIM_FORMAT = dict(position=".4f", velocity=".3f", acceleration=".2f", force=".2f")


def fv_ratio_se(res) -> tuple[float, float, bool]:
    """(Fv-/Fv+, its standard error by the delta method, whether it differs from 1 beyond its error) of an
    asymmetric-friction `IDIMResult`."""
    names = list(res.names)
    th = np.asarray(res.theta, dtype=float)
    cov = np.asarray(res.cov, dtype=float)
    r, se, asym = asymmetry_test(th, cov, i=names.index("Fv_pos"), j=names.index("Fv_neg"))
    return float(r), float(se), bool(asym)


_RECOVERED = {"idim_ls_asym": "IDIM-LS asymmetric", "idim_sdp": "IDIM-SDP curve fit", "idim_iv": "IDIM-IV"}

#: |estimate - truth| above this many stated standard deviations means the standard deviation understates the error.
MAX_Z = 3.0


@x64
def recovery(summary, truth) -> dict:
    """Relative errors (%) of the recovered parameters against the truth, and their size in stated
    standard deviations (`z`): |z| > `MAX_Z` means the stated uncertainty does not cover the error
    (listed in `understated`, with a warning in `warnings`).

    `summary`: `EMPSStudy.summary()`; `truth`: parameter -> true value
    (`M`, `Fv_pos`, `Fc_pos`, `Fv_neg`, `Fc_neg`, `fv_ratio`).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> data, truth, _ = emps_builtin_data(0)
        >>> study = emps_study(data, check_decimation=False)
        >>> summary = study.summary()
        >>> rec = recovery(summary, truth)
        >>> round(rec["idim_ls_asym"]["M"], 2), abs(rec["z"]["idim_ls_asym"]["Fv_pos"]) > 3
        (0.25, True)
    """
    out = {}
    z_all, understated = {}, []
    for key in [k for k in _RECOVERED if summary.get(k)]:
        est = summary[key]
        ratio = est["Fv_neg"] / est["Fv_pos"]
        errs = {k: 100.0 * (est[k] - truth[k]) / truth[k] for k in EMPS_ASYM_NAMES}
        errs["fv_ratio"] = 100.0 * (ratio - truth["fv_ratio"]) / truth["fv_ratio"]
        out[key] = errs
        std = est.get("std") or est.get("curve_fit", {}).get("std", {})
        z = {k: (est[k] - truth[k]) / std[k] for k in std if k in truth and std[k] > 0}
        z_all[key] = z
        label = _RECOVERED[key]
        understated += [f"{label} {k} {z[k]:+.1f} std" for k in z if abs(z[k]) > MAX_Z]
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
    out["z"] = z_all
    out["understated"] = understated
    out["warnings"] = (
        [
            "recovery: the stated standard deviations do not cover the error against the truth ("
            + ", ".join(understated)
            + f"; |error| > {MAX_Z:g} std): the estimates carry a bias from the filtering and decimation "
            "(present without noise too) that the standard deviations do not include; the bias-compensated IDIM-IV "
            '(`estimator="iv"`) removes most of it'
        ]
        if understated
        else []
    )
    return out


def _z(rec, key, k) -> str:
    z = rec.get("z", {}).get(key, {}).get(k)
    return "" if z is None else f"{z:+.1f}"


def _mass_finding(study, summary) -> str:
    s, i = summary["sdp"], summary["idim_ls"]
    stage = study.sdp
    nvr = nvr_text(stage.nvr_mass, float(stage.log10_nvr_se[0]), stage.nvr_bound[0], max_nvr=stage.max_nvr)
    threshold = f"threshold {sci(stage.constant_nvr)}"
    check = {d: v for d, v in study.mass_check.items() if "mass_constant" in v}
    others = {d: v for d, v in check.items() if d != int(round(study.inputs.decimate))}
    masses = ", ".join(f"{v['mass']:.2f}" for v in check.values())
    if others and len({v["mass_constant"] for v in check.values()}) > 1:
        desc = "; ".join(
            f"decimation {d}: NVR {sci(v['nvr_mass'])} ({'constant' if v['mass_constant'] else 'dependent'})"
            for d, v in check.items()
        )
        return (
            f"Mass constancy is NOT established robustly: the SDP mass NVR flag changes with the decimation factor "
            f"({desc}; {threshold}). The evidence is a local ML estimate of the mass NVR, which these data do not "
            f"pin down (the built-in plant, whose mass is constant, is flagged dependent at decimation 5 too). "
            f"What is robust: the acceleration-weighted SDP mass ({masses} kg at these settings) agrees with "
            f"IDIM-LS {i['M']:.2f} kg."
        )
    if others:
        agree = " and ".join(f"{d} (NVR {sci(v['nvr_mass'])})" for d, v in others.items())
        robust = f"; the same conclusion at decimation {agree}"
    else:
        robust = " (not checked at other decimation factors)"
    if s["mass_constant"]:
        return (
            f"Mass is acceleration-independent: SDP mass NVR {nvr}, below the {threshold}{robust}; "
            f"SDP mass {s['mass']:.2f} kg vs IDIM-LS {i['M']:.2f} kg."
        )
    return (
        f"Mass appears acceleration-dependent: SDP mass NVR {nvr}, above the {threshold}{robust}; "
        f"SDP acceleration-weighted mass {s['mass']:.2f} kg vs IDIM-LS {i['M']:.2f} kg (see Fig. 3)."
    )


@x64
def findings(study, summary) -> list[str]:
    """Short interpretation, one sentence per finding, each with the evidence it rests on.

    When a physical check failed (`study.plausible` is False) the list starts
    with a caveat: the findings then describe the fit, not the machine.
    `summary` is `study.summary()`, optionally with `"simulation"`
    (`simulation_check`) and `"recovery"` (`recovery`) added.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> data, truth, _ = emps_builtin_data(0)
        >>> study = emps_study(data, check_decimation=False)
        >>> summary = study.summary()
        >>> findings(study, summary)[0][:35]
        'Mass is acceleration-independent: S'
    """
    s, i, a = summary["sdp"], summary["idim_ls"], summary["idim_ls_asym"]
    out = [] if study.plausible else [CAVEAT]
    out.append(_mass_finding(study, summary))
    if study.sdp.nvr_bound[1] == "upper":
        out.append(
            f"The friction NVR is at its cap max_nvr = {study.sdp.max_nvr:g}: the friction curve is as flexible as "
            "allowed and follows the data closely; its standard error is not defined there."
        )
    r, se, asymmetric = fv_ratio_se(study.idim_asym)
    r_sdp = summary["idim_sdp"]["fv_ratio"]
    if asymmetric:
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
    iv = summary.get("idim_iv")
    if iv:
        ls = summary["idim_ls_asym"]
        z = {k: (iv[k] - ls[k]) / ls["std"][k] for k in ls["std"]}
        worst = max(z, key=lambda k: abs(z[k]))
        state = "converged" if iv["converged"] else "NOT converged"
        verdict = (
            "the IDIM-LS estimates carry a bias larger than their stated standard deviations"
            if abs(z[worst]) > MAX_Z
            else "IDIM-LS and IDIM-IV agree within the stated uncertainty"
        )
        out.append(
            f"IDIM-IV ({iv['variant']}, {iv['iterations']} iterations, {state}) against IDIM-LS: largest difference "
            f"{worst} {100 * (iv[worst] - ls[worst]) / abs(ls[worst]):+.2f} % ({z[worst]:+.1f} IDIM-LS std): {verdict}."
        )
    sim = summary.get("simulation") or {"skipped": "not run (see simulation_check)"}
    if sim.get("position") is not None:
        limits = sim.get("limits") or REPRODUCES
        verdict = "reproduces" if sim.get("reproduces", True) else "does NOT reproduce"
        out.append(
            f"Closed-loop simulation of the IDIM-LS model {verdict} the data: relative error position "
            f"{sim['position']:.4f} %, velocity {sim['velocity']:.3f} %, acceleration {sim['acceleration']:.2f} %, "
            f"force {sim['force']:.2f} % (test: each within "
            + ", ".join(f"{k} {v:g} %" for k, v in limits.items())
            + ")."
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


def _findings(study, summary) -> list[str]:
    """The study's own findings (drawn by `emps_study`), or drawn from `summary` for a study without them."""
    return list(study.findings) if study.findings else findings(study, summary)


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


@x64
def report_markdown(study, summary, figures) -> str:
    """The `report.md` text: warnings, findings, tables, recovery, simulation check, figures
    (linked by relative file name; `figures`: name -> path), timings.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> data, truth, _ = emps_builtin_data(0)
        >>> study = emps_study(data, check_decimation=False)
        >>> summary = study.summary()
        >>> report_markdown(study, summary, {}).splitlines()[0]
        '# EMPS identification report'
    """
    d = summary["data"]
    parts = ["# EMPS identification report", ""]
    src = f"**Data:** {d['source']}, {d['samples']} samples, sample time {d['sample_time']:g} s; {study.preprocessing}."
    parts += [src, ""]
    if summary.get("truth") and "plant" in d:
        parts += [f"Built-in plant: {d['plant']}; {d['excitation']}; {d['measurement']}; force: {d['force']}.", ""]
    if summary.get("warnings"):
        parts += ["## Warnings", ""] + [f"- **Warning:** {w}" for w in summary["warnings"]] + [""]
    parts += ["## Findings", ""] + [f"- {f}" for f in _findings(study, summary)] + [""]

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
    st = study.sdp
    nvr_m, nvr_f = (
        nvr_text(v, float(e), b, max_nvr=st.max_nvr)
        for v, e, b in zip((st.nvr_mass, st.nvr_friction), np.asarray(st.log10_nvr_se, dtype=float), st.nvr_bound)
    )

    parts += ["## SDP stage: y = M(ddq) ddq + d_fric(dq)", ""]
    parts.append(
        md_table(
            ["quantity", "value"],
            [
                ["NVR of M(ddq)", nvr_m],
                ["NVR of d_fric(dq)", nvr_f],
                ["mass", ("constant (acceleration-independent)" if s["mass_constant"] else "state-dependent")],
                ["SDP mass (acceleration-weighted)", f"{s['mass']:.4f} kg"],
                ["relative error", f"{s['relative_error']:.3f} %"],
            ],
        )
    )
    parts.append("")

    if study.mass_check:
        parts += ["### Mass constancy at neighbouring decimation factors", ""]
        rows = [
            [str(d), "skipped: " + v["skipped"], "", ""]
            if "skipped" in v
            else [
                str(d),
                sci(v["nvr_mass"]),
                "constant" if v["mass_constant"] else "acceleration-dependent",
                f"{v['mass']:.3f}",
            ]
            for d, v in study.mass_check.items()
        ]
        parts += [md_table(["decimation", "mass NVR", "flag", "weighted SDP mass (kg)"], rows), ""]

    # Table 2
    p = study.idim_sdp
    curve = {"M": (p.mass, None)}
    curve.update(_params_rows(p.friction))
    asym = _params_rows(study.idim_asym)
    iv = None if study.idim_iv is None else _params_rows(study.idim_iv.result)
    header = ["parameter", "IDIM-SDP (curve fit)", "IDIM-LS asymmetric"] + (["IDIM-IV"] if iv else [])
    truth = summary.get("truth")
    if truth:
        header.append("truth")
    rows = []
    for n in EMPS_ASYM_NAMES:
        v, r = curve[n]
        row = [LABELS[n], f"{v:.4f}" + ("" if r is None else f" ({r:.2f} %)"), f"{asym[n][0]:.4f} ({asym[n][1]:.2f} %)"]
        if iv:
            row.append(f"{iv[n][0]:.4f} ({iv[n][1]:.2f} %)")
        if truth:
            row.append(f"{truth[n]:g}")
        rows.append(row)
    ests = [summary["idim_ls_asym"]] + ([summary["idim_iv"]] if iv else [])
    ratio_row = ["Fv-/Fv+", f"{summary['idim_sdp']['fv_ratio']:.3f}"] + [
        f"{e['Fv_neg'] / e['Fv_pos']:.3f}" for e in ests
    ]
    err_row = ["relative error", f"{summary['idim_sdp']['relative_error']:.3f} %"] + [
        f"{e['relative_error']:.3f} %" for e in ests
    ]
    if truth:
        ratio_row.append(f"{truth['fv_ratio']:.3f}")
        err_row.append("")
    rows += [ratio_row, err_row]
    if iv:
        parts += [
            f"IDIM-IV: {summary['idim_iv']['variant']}; {summary['idim_iv']['iterations']} iterations, "
            f"{'converged' if summary['idim_iv']['converged'] else 'NOT converged'}.",
            "",
        ]
    parts += ["## Table 2. IDIM-SDP, asymmetric friction model (eq. 17)", "", md_table(header, rows), ""]
    parts += friction_markdown(summary.get("friction"))

    rec = summary.get("recovery")
    if rec:
        parts += ["## Recovery of the built-in plant's parameters", ""]
        keys = (*EMPS_ASYM_NAMES, "fv_ratio")
        parts.append(
            md_table(
                ["error vs truth (%)"] + [LABELS.get(k, "Fv-/Fv+") for k in keys],
                [
                    ["IDIM-LS asymmetric"] + [f"{rec['idim_ls_asym'][k]:+.2f}" for k in keys],
                    ["IDIM-SDP"] + [f"{rec['idim_sdp'][k]:+.2f}" for k in keys],
                ]
                + ([["IDIM-IV"] + [f"{rec['idim_iv'][k]:+.2f}" for k in keys]] if "idim_iv" in rec else [])
                + [["tolerance"] + [f"+-{RECOVERY_TOL[k]:g}" for k in keys]]
                + [
                    [f"{label}: error in stated std"] + [_z(rec, key, k) for k in keys]
                    for key, label in _RECOVERED.items()
                    if key in rec
                ],
            )
        )
        flags = (
            f"Mass flagged constant: {'yes' if rec['mass_constant'] else 'no'}; "
            f"all within tolerances: {'yes' if rec['within_tolerances'] else 'no: ' + ', '.join(rec['failed'])}."
        )
        parts += ["", flags, ""]

    sim = summary.get("simulation") or {"skipped": "not run (see simulation_check)"}
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
        parts += [figure_markdown(path, caption.split(":")[0]), "", f"*{caption}*", ""]

    t = summary.get("timings", study.timings)
    parts += ["## Timings (s, including JAX compilation)", ""]
    parts.append(md_table(["stage", "seconds"], [[k, f"{v:.2f}"] for k, v in t.items()]))
    footer = (
        f"Generated by `jaxsdp emps` (jaxsdp {__version__}); machine-readable results in [summary.json](summary.json)."
    )
    parts += ["", footer, ""]
    return "\n".join(parts)


@x64
def text_output(study, summary) -> str:
    """What the command prints on stdout: the paper's tables, the checks and the findings (the warnings are
    printed once, on stderr, by the command; they head `report.md`).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> data, truth, _ = emps_builtin_data(0)
        >>> study = emps_study(data, check_decimation=False)
        >>> summary = study.summary()
        >>> "Table 1. IDIM-LS" in text_output(study, summary)
        True
    """
    parts = [study.tables(warnings=False)]
    sim = summary.get("simulation") or {"skipped": "not run (see simulation_check)"}
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
        cols = [(key, label) for key, label in _RECOVERED.items() if key in rec]
        lines = [
            f"{'parameter':<10} {'truth':>9} " + " ".join(f"{lab:>20} {'err %':>7} {'(std)':>6}" for _, lab in cols)
        ]
        for k in EMPS_ASYM_NAMES:
            lines.append(
                f"{k:<10} {tr[k]:9.3f} "
                + " ".join(f"{summary[key][k]:20.3f} {rec[key][k]:+7.2f} {_z(rec, key, k):>6}" for key, _ in cols)
            )
        ratio = " ".join(
            f"{summary[key]['Fv_neg'] / summary[key]['Fv_pos']:20.3f} {rec[key]['fv_ratio']:+7.2f} {'':>6}"
            for key, _ in cols
        )
        lines.append(f"{'Fv-/Fv+':<10} {tr['fv_ratio']:9.3f} " + ratio)
        lines.append("(std): error in stated standard deviations")
        parts.append("Built-in plant: recovered vs true parameters\n" + "\n".join(lines))
    parts.append("Findings\n" + "\n".join(f"- {f}" for f in _findings(study, summary)))
    return "\n\n".join(parts)


def friction_markdown(friction: dict | None) -> list[str]:
    """report.md's "Friction law" section (`EMPSFriction.summary`): each law's parameters, BIC, relative error and
    distance to the SDP curve; the chosen law's held-out error beside the asymmetric linear law's."""
    if not friction:
        return []
    rows = []
    for name, law in friction["laws"].items():
        params = ", ".join(f"{k} {p['value']:.4g} (+-{p['std']:.2g})" for k, p in law["parameters"].items())
        mismatch = "-" if law["curve_mismatch"] is None else f"{law['curve_mismatch']:.1f} %"
        mark = " (chosen)" if name == friction["chosen"] else ""
        rows.append((name + mark, params, f"{law['bic']:.1f}", f"{law['relative_error']:.2f} %", mismatch))
    cv = friction["cross_validated"]
    held = ", ".join(f"{k} {v:.2f} %" for k, v in cv.items())
    how = "least BIC among the candidates" if friction["criterion"] == "BIC" else "the law given"
    return [
        "## Friction law",
        "",
        "y = M ddq + offset + f(dq; p), fitted by nonlinear least squares on the decimated rows for each law; "
        f"chosen: {friction['chosen']} ({how}). Curve mismatch: the law plus the offset against the SDP friction "
        "curve (Fig. 4), rms over the curve's rms.",
        "",
        md_table(("law", "parameters (N, m/s)", "BIC", "relative error", "curve mismatch"), rows),
        "",
        f"Held-out relative error (two blocks of time, each predicted by the fit on the other): {held}.",
        "",
    ]
