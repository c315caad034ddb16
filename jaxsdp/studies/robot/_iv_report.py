"""The robot study's IDIM-IV in summary.json and report.md (issue 45, item 5)."""

import numpy as np

from .._output import md_table

#: A parameter IDIM-IV moved by more than this many of its standard errors from IDIM-LS is named in the findings.
SHIFT_SE = 2.0


def iv_summary(study) -> dict | None:
    """summary.json's `idim_iv`: `converged`, `failed` (a simulated iterate diverged: the loop stopped there),
    `iterations`, `relative_error` (% of the stacked torques, rows used), `loop_hz` (the bandwidth of the PD loop
    simulated for the instruments), `parameters` (per base parameter: `ls` the IDIM-LS start, `iv` and `std` the
    IDIM-IV estimate and its standard error, `shift` (iv - ls) / std); None when the study ran IDIM-LS only."""
    fit = getattr(study.idim, "iv", None)
    if fit is None:
        return None
    theta = np.asarray(study.idim.result.theta, dtype=float)
    std = np.abs(theta) * np.asarray(study.idim.result.rel_std, dtype=float) / 100.0
    start = np.asarray(fit.start, dtype=float)
    shift = (theta - start) / np.where(std > 0, std, np.nan)
    return {
        "converged": bool(fit.converged),
        "failed": bool(fit.failed),
        "iterations": int(fit.iterations),
        "relative_error": float(fit.relative_error),
        "loop_hz": study.settings.get("iv_loop_hz"),
        "parameters": [
            {"name": n, "ls": float(a), "iv": float(b), "std": float(c), "shift": float(d)}
            for n, a, b, c, d in zip(study.idim.result.names, start, theta, std, shift)
        ],
    }


def iv_warnings(idim) -> list[str]:
    fit = getattr(idim, "iv", None)
    if fit is None or bool(fit.converged):
        return []
    k = int(fit.iterations)
    if bool(fit.failed):
        return [
            f"IDIM-IV stopped after {k} iterations: the next iterate's robot diverged in the loop simulated for "
            "the instruments (a PD on the description following the logged angles), so no instrument could be "
            f"built from it; the estimate is {'the IDIM-LS start' if k == 0 else f'iteration {k}'}: treat its "
            "intervals as least squares' (biased in closed loop), or identify from logs sampled faster"
        ]
    return [
        f"IDIM-IV did not converge in {k} iterations: the estimate is the last iterate; compare "
        "it with IDIM-LS's (report.md, IDIM-IV) before using it"
    ]


def iv_findings(idim) -> list[str]:
    fit = getattr(idim, "iv", None)
    if fit is None:
        return []
    theta = np.asarray(idim.result.theta, dtype=float)
    std = np.abs(theta) * np.asarray(idim.result.rel_std, dtype=float) / 100.0
    shift = (theta - np.asarray(fit.start, dtype=float)) / np.where(std > 0, std, np.nan)
    moved = [f"{n} ({s:+.1f})" for n, s in zip(idim.result.names, shift) if np.isfinite(s) and abs(s) > SHIFT_SE]
    head = f"IDIM-IV converged in {int(fit.iterations)} iterations" if bool(fit.converged) else "IDIM-IV"
    return [
        f"{head}; "
        + (
            f"it moved {len(moved)} base parameters by more than {SHIFT_SE:g} standard errors from IDIM-LS "
            f"(the closed loop's bias on least squares): {', '.join(moved)}."
            if moved
            else f"no base parameter moved by more than {SHIFT_SE:g} standard errors from IDIM-LS."
        )
    ]


def iv_markdown(study) -> list[str]:
    s = iv_summary(study)
    if s is None:
        return []
    rows = [
        (p["name"], f"{p['ls']:.4g}", f"{p['iv']:.4g}", f"{p['std']:.2g}", f"{p['shift']:+.2f}")
        for p in s["parameters"]
    ]
    return [
        "## IDIM-IV",
        "",
        "The estimate of this study is the iterated bias-compensated IDIM-IV, started from IDIM-LS: its instruments "
        "the regressors of the identified robot simulated noise free following the logged angles under a PD loop "
        f"on the description (critically damped at {s['loop_hz']:g} Hz), processed like the logs (instruments are "
        "uncorrelated with the torque noise, which the closed loop feeds back into the measured motion and so into "
        "least squares' regressors). "
        f"{'Converged' if s['converged'] else 'NOT converged'} in {s['iterations']} iterations; relative error "
        f"{s['relative_error']:.2f} %.",
        "",
        md_table(("base parameter", "IDIM-LS", "IDIM-IV", "std", "shift (std)"), rows),
        "",
    ]
