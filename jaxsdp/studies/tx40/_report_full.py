"""The full-model part of the TX40 study's outputs (`--model full`): summary.json's keys, tables, report section."""

import numpy as np

from ...plants.robot._joint_full import POORLY_EXCITED
from ...plants.robot._joint_stages import JointSDP
from .._contract import Study
from .._output import md_table, text_table
from ._report_common import named_estimates, whiteness_summary

#: Points of the sorted friction curve written to summary.json (evenly spaced in the sorted order).
CURVE_POINTS = 400


def departure(sdp: JointSDP) -> float:
    """100 |d_q + d_dq - projections| / |y| (%) on the samples in motion: how far a multi-SDP's curves are
    from their parametric shapes."""
    mov = np.asarray(sdp.moving, bool)
    m = np.sum(np.asarray(sdp.result.d)[mov], axis=1) - np.asarray(sdp.gravity.fit + sdp.friction.fit)
    return float(100.0 * np.linalg.norm(m) / np.linalg.norm(np.asarray(sdp.y)[mov]))


def _friction_curve(sdp: JointSDP) -> dict:
    dq = np.asarray(sdp.dq, dtype=float)
    order = np.argsort(dq, kind="stable")
    pick = order[np.unique(np.linspace(0, order.size - 1, min(CURVE_POINTS, order.size)).round().astype(int))]
    return {
        "dq": dq[pick].tolist(),
        "d": np.asarray(sdp.result.d[:, 1], dtype=float)[pick].tolist(),
        "se": np.asarray(sdp.result.dse[:, 1], dtype=float)[pick].tolist(),
        "points": int(pick.size),
        "of": int(order.size),
    }


def full_summary(study: Study) -> dict:
    """summary.json's `full_model`, `full_model_sdp` and `coupling` (empty without `full_model=True`).

    `full_model`: `relative_error` (%), `rank`, `base_parameters` (name: value),
    `rel_std` (name: %), `nominal` (name: the robot's value), `combinations`
    (name: the combination it stands for), `gravity_deviation` (%),
    `poorly_excited`, `whiteness`, `samples_used`. `full_model_sdp`:
    `relative_error`, `iterations`, `converged`, `nvr`, `friction` (the
    projection's Fv, Fc, offset), `friction_curve` (the friction SDP sorted
    by dq: `dq`, `d`, `se`, at most 400 points), `parametric_relative_error`,
    `curve_mismatch`. `coupling`: `explained`, `departure`, `coupling`,
    `departure_full` (% , `coupling_explained`).
    """
    f, s = study.full, study.full_sdp
    if f is None:
        return {}
    fr, _ = named_estimates(s.friction)
    gr, _ = named_estimates(s.gravity)
    j = study.joint
    return {
        "full_model": {
            "relative_error": f.relative_error,
            "rank": f.model.rank,
            "base_parameters": f.estimates(),
            "rel_std": f.rel_std(),
            "nominal": f.nominal(),
            "combinations": dict(zip(f.model.names, f.model.base.names)),
            "gravity_deviation": f.gravity_deviation,
            "poorly_excited": list(f.poorly_excited()),
            "whiteness": whiteness_summary(f.whiteness),
            "samples_used": int(np.sum(np.asarray(f.moving))),
        },
        "full_model_sdp": {
            "relative_error": s.relative_error,
            "relative_error_moving": s.relative_error_moving,
            "iterations": int(s.result.iterations),
            "converged": bool(s.result.converged),
            "nvr": {"gravity": float(s.result.nvr[0]), "friction": float(s.result.nvr[1])},
            "model": list(s.model),
            "friction": {f"Fv{j}": fr[f"Fv{j}"], f"Fc{j}": fr[f"Fc{j}"], "offset": fr["offset"]},
            "gravity_left": {f"MX{j}": gr[f"MX{j}"], f"MY{j}": gr[f"MY{j}"], "offset": gr["offset"]},
            "friction_curve": _friction_curve(s),
            "parametric_relative_error": s.parametric_relative_error,
            "curve_mismatch": {"gravity": s.mismatch[0], "friction": s.mismatch[1]},
            "whiteness": whiteness_summary(s.whiteness),
        },
        "coupling": dict(study.coupling) | {"departure_full": departure(s)},
    }


def _est(v, r) -> str:
    return f"{v:.4g} ({r:.2f}%)"


def comparison_rows(study: Study) -> list[tuple]:
    """Rows (quantity, paper IDIM-LS, paper SDP, link-2 model, link-2 multi-SDP, full model, full model + SDP)."""
    j, f, fs = study.joint, study.full, study.full_sdp
    ls, lr = named_estimates(study.idim.result)
    sdp = study.sdp_estimates()
    fe, fr = f.estimates(), f.rel_std()
    ff, ffr = named_estimates(fs.friction)
    pub = study.published or {"idim_ls": {}, "sdp": {}}
    fmt = lambda d, k: "-" if d.get(k) is None else f"{d[k]:.4g}"
    rows = [
        (
            "relative error (whole record)",
            fmt(pub["idim_ls"], "relative_error") + ("%" if pub["idim_ls"] else ""),
            fmt(pub["sdp"], "relative_error") + ("%" if pub["sdp"] else ""),
            f"{study.idim.relative_error_record:.1f}%",
            f"{study.sdp.relative_error:.1f}%",
            "-",
            f"{fs.relative_error:.1f}%",
        ),
        (
            "relative error (in motion)",
            "-",
            "-",
            f"{float(study.idim.result.relative_error):.1f}%",
            f"{study.sdp.relative_error_moving:.1f}%",
            f"{f.relative_error:.1f}%",
            f"{fs.relative_error_moving:.1f}%",
        ),
    ]
    for k in ("Fv", "Fc"):
        name = f"{k}{j}"
        rows.append(
            (
                name,
                fmt(pub["idim_ls"], name),
                fmt(pub["sdp"], name),
                _est(ls[name], lr[name]),
                _est(*sdp[name]),
                _est(fe[name], fr[name]),
                _est(ff[name], ffr[name]),
            )
        )
    off = f"offset{j}"
    rows.append(
        (
            off,
            fmt(pub["idim_ls"], off),
            fmt(pub["sdp"], off),
            _est(ls[off], lr[off]),
            _est(*sdp[off]),
            _est(fe[off], fr[off]) if off in fe else "-",
            f"{fs.offset_sum:.4g} (SDP constant)",
        )
    )
    zz = f"ZZ{j}"
    rows.append(
        (
            f"{zz} (effective)",
            fmt(pub["idim_ls"], zz),
            "X",
            _est(ls[zz], lr[zz]),
            f"X (fixed {study.sdp.inertia:.4g})",
            _est(fe[zz], fr[zz]) + " (base: with Ia)" if zz in fe else "-",
            "X (rigid body known)",
        )
    )
    return rows


COMPARISON_HEAD = (
    "quantity",
    "paper IDIM-LS",
    "paper IDIM-SDP",
    "link-2 model",
    "link-2 multi-SDP",
    "full model",
    "full model + SDP",
)


def base_rows(study: Study) -> list[tuple]:
    """Rows (base parameter, estimate (rel. std), nominal, combination) of the full model."""
    f = study.full
    est, rel, nom = f.estimates(), f.rel_std(), f.nominal()
    rows = []
    for name, combo in zip(f.model.names, f.model.base.names):
        flag = " *" if not rel[name] <= POORLY_EXCITED else ""
        rows.append((name, _est(est[name], rel[name]) + flag, f"{nom[name]:.4g}", combo))
    return rows


def full_findings(study: Study) -> list[str]:
    """The full model's conclusions in words (relative errors, the coupling, convention check)."""
    f, fs, c = study.full, study.full_sdp, study.coupling
    after = departure(fs)
    le = float(study.idim.result.relative_error)
    out = [
        f"With the full six-joint rigid-body model ({f.model.rank} base parameters), IDIM-LS explains joint "
        f"{study.joint}'s torque to {f.relative_error:.1f} % (link-2 model: {le:.1f} %); its residual is "
        + ("as white as decimated measurement noise: the noise floor." if bool(f.whiteness.white) else "not white.")
    ]
    verdict = "are" if c["departure"] > 0 and after < 0.5 * c["departure"] else "are not fully"
    out.append(
        f"The link-2 multi-SDP curves depart from eq. (20)'s shapes by {c['departure']:.1f} % of the torque; the "
        f"coupling torque the full model adds ({c['coupling']:.1f} % of the torque) explains {c['explained']:.0f} % "
        f"of that departure's variance on its own, and with the rigid-body coupling known the SDP curves depart "
        f"by {after:.1f} %: the mismatch curves {verdict} explained by the coupling terms."
    )
    out.append(
        f"Full model + SDP (friction and any q-dependence left by the rigid-body model): "
        f"{fs.relative_error_moving:.1f} % in motion ({fs.relative_error:.1f} % over the whole record) "
        f"relative error; its friction projection gives Fv{study.joint} = {fs.friction[f'Fv{study.joint}']:.4g} "
        f"N m s/rad, Fc{study.joint} = {fs.friction[f'Fc{study.joint}']:.4g} N m."
    )
    out.append(
        f"Convention check: the identified gravity torque of joint {study.joint} is {f.gravity_deviation:.0f} % from "
        "the nominal robot's"
        + (" (consistent)." if f.gravity_deviation <= 50 else " (inconsistent: see the warnings).")
    )
    return out


def full_markdown(study: Study) -> list[str]:
    """report.md's lines for the full model (empty without `full_model=True`)."""
    f = study.full
    if f is None:
        return []
    st = study.settings
    head = [
        "## Beyond the paper: the full six-joint model",
        "",
        f"Joint {study.joint} identified with the full rigid-body model (modified-DH Newton-Euler regressor of the "
        f"robot, base parameters the first independent columns in the parameters' order: rank {f.model.rank}), "
        f"then the multi-SDP of its "
        f"residual with the rigid-body torque known. Logs brought to the model's convention with joint offsets "
        f"{st.get('joint_offsets')} rad and wrist coupling {st.get('wrist_coupling')}.",
        "",
        md_table(COMPARISON_HEAD, comparison_rows(study)),
        "",
    ]
    return (
        head
        + [f"- {x}" for x in full_findings(study)]
        + [
            "",
            "### Base parameters (full model)",
            "",
            "`*`: not excited by this trajectory (relative standard deviation above 100 %). The nominal column is the "
            "robot model's (for the built-in data: the truth).",
            "",
            md_table(("base parameter", "estimate (rel. std)", "nominal", "combination"), base_rows(study)),
            "",
        ]
    )


def full_text(study: Study) -> str:
    """Console text of the full model: the comparison table and the findings ('' without it)."""
    if study.full is None:
        return ""
    return (
        "Full six-joint model (beyond the paper)\n"
        + text_table(COMPARISON_HEAD, comparison_rows(study))
        + "\n"
        + "\n".join(f"- {x}" for x in full_findings(study))
    )
