"""The robot study's physically consistent estimate in summary.json and report.md (issue 45)."""

import numpy as np

from ...plants.robot._inertia import link_body
from .._output import md_table


def link_bodies(theta: np.ndarray, n: int) -> list[dict]:
    """Each link's body from the full parameters: mass (kg), centre of mass (m, link frame), inertia about the
    centre of mass `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]` (kg m^2, link frame axes) and its principal moments."""
    out = []
    for k in range(n):
        m, c, J = link_body(theta[10 * k : 10 * k + 10])
        out.append(
            {
                "mass": m,
                "com": c.tolist(),
                "inertia_com": [J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2]],
                "principal_moments": np.linalg.eigvalsh(0.5 * (J + J.T)).tolist(),
            }
        )
    return out


def physical_summary(study) -> dict | None:
    """summary.json's `physical`: `converged`, `steps`, `prior_weight`, `distance` (from the unconstrained
    estimate, in its standard errors), `largest_shift` (the base parameter consistency moved most, in its
    standard errors), `relative_error` (joint name -> unconstrained and physical %, rows in motion), `links`
    (name -> mass kg, com m, inertia about the com kg m^2, principal moments, `edge`), `parameters` (every full
    parameter: value, std, source "data" / "combined" / "prior")."""
    est = getattr(study, "physical", None)
    if est is None:
        return None
    i = study.idim
    n = len(study.names)
    shift = np.abs(np.asarray(est.shift))
    k = int(np.argmax(shift))
    physical = est.relative_error(i)
    bodies = link_bodies(np.asarray(est.theta), n)
    for body, edge in zip(bodies, np.asarray(est.edge)):
        body["edge"] = float(edge)
    return {
        "converged": bool(est.converged),
        "steps": int(est.steps),
        "prior_weight": est.prior_weight,
        "distance": float(est.distance),
        "largest_shift": {"name": est.base_names[k], "standard_errors": float(np.asarray(est.shift)[k])},
        "relative_error": {
            study.names[j - 1]: {"unconstrained": i.relative_error[j], "physical": physical[j]}
            for j in physical
            if j in i.relative_error
        },
        "links": {f"link{k + 1}": b for k, b in enumerate(bodies)},
        "parameters": [
            {"name": name, "value": float(v), "std": float(s), "source": src}
            for name, v, s, src in zip(est.names, np.asarray(est.theta), np.asarray(est.std), est.source)
        ],
    }


def physical_markdown(study) -> list[str]:
    """report.md's section: the cost of consistency per joint, how far it moved the estimate, each link's body."""
    summary = physical_summary(study)
    if summary is None:
        return []
    rows = [
        (name, f"{e['unconstrained']:.2f}", f"{e['physical']:.2f}", f"{e['physical'] - e['unconstrained']:+.2f}")
        for name, e in summary["relative_error"].items()
    ]
    shift = summary["largest_shift"]
    bodies = [
        (
            link,
            f"{b['mass']:.4g}",
            ", ".join(f"{v:.4g}" for v in b["com"]),
            ", ".join(f"{v:.3g}" for v in b["principal_moments"]),
            "yes" if b["edge"] < 1e-6 else "",
        )
        for link, b in summary["links"].items()
    ]
    sources = [p["source"] for p in summary["parameters"]]
    return [
        "## Physically consistent estimate",
        "",
        "The physical robot nearest to the IDIM-LS estimate in its covariance: every link a rigid body (pseudo-"
        "inertia positive definite: positive mass, inertia about the centre of mass positive definite, triangle "
        "inequalities), motor inertias and friction positive (`physical_estimate`), the directions the data do not "
        f"see held at the description (log-det divergence, weight {summary['prior_weight']:g}). "
        f"{'Converged' if summary['converged'] else 'NOT converged'} in {summary['steps']} minimiser steps; distance "
        f"from the unconstrained estimate {summary['distance']:.2f} (in its standard errors), the largest move "
        f"{shift['name']} by {shift['standard_errors']:+.2f} standard errors.",
        "",
        md_table(("joint", "unconstrained %", "physical %", "cost of consistency (points)"), rows),
        "",
        f"Of the {len(sources)} full parameters, {sources.count('data')} are identified by the data, "
        f"{sources.count('combined')} enter the base parameters only in combinations (the data fix the "
        f"combination, the description splits it) and {sources.count('prior')} are not seen at all (the "
        "description's values).",
        "",
        md_table(("link", "mass kg", "centre of mass m", "principal moments kg m^2", "on the edge"), bodies),
        "",
    ]
