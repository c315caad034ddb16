"""The robot study's friction laws in summary.json and report.md (issue 45, item 4)."""

from .._output import md_table

#: A law's parameters in words, for the report.
_PARAMETER = {
    "Fv": "viscous",
    "Fv+": "viscous, positive speeds",
    "Fv-": "viscous, negative speeds",
    "Fc": "Coulomb",
    "Fs": "static (Stribeck)",
    "vs": "Stribeck speed",
    "veps": "smoothing speed",
}


def friction_summary(study) -> dict | None:
    """summary.json's `friction` (`RobotFriction.summary`, joints and motors by the robot's joint names): per
    motor the law chosen, the one proposed by BIC, its parameters (value, std), the candidates' BIC and relative
    error %, the distance of each to the SDP curve %; per joint the relative error and the held-out error %,
    linear and chosen; `reverted`, `converged`, `folds`, `min_gain`; None when the stage did not run."""
    fr = getattr(study, "friction", None)
    return None if fr is None else _named(fr, study.names)


def _named(fr, names) -> dict:
    s = fr.summary()
    s["motors"] = {names[int(k.split("_")[1]) - 1]: v for k, v in s["motors"].items()}
    s["joints"] = {names[int(k.split("_")[1]) - 1]: v for k, v in s["joints"].items()}
    s["reverted"] = [names[k - 1] for k in s["reverted"]]
    return s


def friction_findings(fr, names) -> list[str]:
    """One finding: each joint's law and its held-out error against the linear model's (`fr` a
    `RobotFriction` or None, `names` the robot's joint names)."""
    if fr is None:
        return []
    s = _named(fr, names)
    parts = []
    for name, j in s["joints"].items():
        law = s["motors"].get(name, {}).get("chosen", "ViscousCoulomb")
        cv = j["cross_validated"]
        parts.append(f"{name} {law} ({cv['chosen']:.2f} % held out, linear {cv['linear']:.2f} %)")
    return ["Friction laws (proposed by BIC, kept where they lower the held-out error): " + ", ".join(parts) + "."]


def friction_warnings(fr) -> list[str]:
    """A warning when the joint fit did not converge (`fr` a `RobotFriction` or None)."""
    if fr is None or fr.converged:
        return []
    return [
        "the joint fit of the friction laws with the rigid body did not converge: the laws' parameters and "
        "standard errors in the report are those of the last iterate"
    ]


def friction_markdown(study) -> list[str]:
    """report.md's section: per joint the law kept and the errors, per motor the candidates and the parameters."""
    s = friction_summary(study)
    if s is None:
        return []
    rows = []
    for name, j in s["joints"].items():
        m = s["motors"].get(name)
        e, cv = j["relative_error"], j["cross_validated"]
        rows.append(
            (
                name,
                "-" if m is None else m["proposed"],
                "ViscousCoulomb" if m is None else m["chosen"],
                f"{e['linear']:.2f}",
                f"{e['chosen']:.2f}",
                f"{cv['linear']:.2f}",
                f"{cv['chosen']:.2f}",
            )
        )
    candidates, parameters = [], []
    for name, m in s["motors"].items():
        for law, c in m["candidates"].items():
            mismatch = (m.get("curve_mismatch") or {}).get(law)
            candidates.append(
                (
                    name,
                    law + (" (proposed)" if law == m["proposed"] else ""),
                    f"{c['bic']:.1f}",
                    f"{c['relative_error']:.2f}",
                    "-" if mismatch is None else f"{mismatch:.1f}",
                )
            )
        for p, v in m["parameters"].items():
            base = p.rstrip("0123456789")
            parameters.append((name, p, _PARAMETER.get(base, base), f"{v['value']:.4g}", f"{v['std']:.2g}"))
    reverted = s["reverted"]
    return [
        "## Friction laws",
        "",
        "Each motor's law proposed by the least BIC on its partial residual (the torque less the IDIM-LS model "
        "without the motor's own friction, each law evaluated at the full rate and decimated like the torques), "
        f"kept only where it lowers its joint's error held out in {s['folds']} blocks of time by at least "
        f"{100 * s['min_gain']:g} % of the linear model's; the laws kept estimated jointly with every other base "
        f"parameter (Levenberg-Marquardt, {'converged' if s['converged'] else 'NOT converged'})."
        + (f" Proposals reverted to viscous + Coulomb: {', '.join(reverted)}." if reverted else ""),
        "",
        md_table(
            ("joint", "proposed", "kept", "linear %", "kept %", "linear held out %", "kept held out %"),
            rows,
        ),
        "",
        md_table(("joint", "law", "BIC", "rel. error %", "to the SDP curve %"), candidates),
        "",
        md_table(("joint", "parameter", "meaning", "value", "std"), parameters),
        "",
    ]
