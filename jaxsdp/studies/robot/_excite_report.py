"""The excitation study's outputs: summary.json's dict, report.md, the console text, the trajectory figure and CSV."""

import pathlib
from typing import TYPE_CHECKING

import numpy as np

from ..._runtime import x64
from .._contract import Study
from .._figure_style import new_figure
from .._output import figure_markdown, finite_or_none, md_table, text_table

if TYPE_CHECKING:
    from matplotlib.figure import Figure


#: Samples per period in trajectory.csv and the figure.
CSV_SAMPLES = 1000


def _period(study: Study):
    ex = study.result.excitation
    t = np.linspace(0.0, 1.0 / ex.f0, CSV_SAMPLES, endpoint=False)
    return t, *(np.asarray(v) for v in ex.states(t))


def excitation_summary(study: Study) -> dict:
    """summary.json: `condition_number`, `condition_number_start`, `steps`, `trajectory` (f0 Hz, per joint name
    `q0` rad, `a`, `b` rad/s: the Fourier coefficients, `range` rad, `peak_velocity` rad/s, `peak_acceleration`
    rad/s^2), `limits`, `recovery` (per base parameter: nominal, estimate, se, z, torque_share %), `largest_z`
    (the recovery row of the largest |z|), `largest_torque_share` (%: the largest torque share of a difference),
    `warnings`, `findings`, `settings`, `timings`, `versions`."""
    r = study.result
    ex = r.excitation
    _, q, dq, ddq = _period(study)
    joints = {
        name: {
            "q0": float(ex.q0[k]),
            "a": np.asarray(ex.a[k]).tolist(),
            "b": np.asarray(ex.b[k]).tolist(),
            "range": [float(q[:, k].min()), float(q[:, k].max())],
            "peak_velocity": float(np.abs(dq[:, k]).max()),
            "peak_acceleration": float(np.abs(ddq[:, k]).max()),
        }
        for k, name in enumerate(study.names)
    }
    recovery = study.recovery()
    out = {
        "warnings": list(study.warnings),
        "findings": list(study.findings),
        "condition_number": r.cond,
        "condition_number_start": r.cond_start,
        "steps": r.steps,
        "trajectory": {"f0_hz": float(ex.f0), "harmonics": int(ex.a.shape[1]), "joints": joints},
        "limits": dict(r.limits),
        "recovery": recovery,
        "largest_z": max(recovery, key=lambda x: abs(x["z"])) if recovery else None,
        "largest_torque_share": max((x["torque_share"] for x in recovery), default=None),
        "stacked_relative_error": None if study.check is None else study.check.stacked_relative_error,
        "settings": dict(study.settings),
        "timings": {k: round(float(v), 4) for k, v in study.timings.items()},
        "fast_loops": study.fast_loops,
        "versions": dict(study.versions),
    }
    return finite_or_none(out)


def _recovery_rows(study):
    return [
        (
            x["name"],
            f"{x['nominal']:.5g}",
            f"{x['estimate']:.5g}",
            f"{x['se']:.2g}",
            f"{x['z']:+.1f}",
            f"{x['torque_share']:.3f} %",
        )
        for x in study.recovery()
    ]


_HEAD = ("base parameter", "description", "identified", "std", "z", "torque share")


def excitation_text(study: Study) -> str:
    """What `jaxsdp robot --excite` prints."""
    r = study.result
    parts = [
        f"Exciting trajectory: {r.excitation.a.shape[1]} harmonics of {r.excitation.f0:g} Hz per joint; condition "
        f"number {r.cond_start:.4g} (random start) -> {r.cond:.4g} (optimised, {r.steps} steps)"
    ]
    if study.check is not None:
        parts.append(text_table(_HEAD, _recovery_rows(study)))
    return "\n\n".join(parts + list(study.findings[1:]))


def excitation_markdown(study: Study, figures=()) -> str:
    """report.md of `jaxsdp robot --excite`."""
    r = study.result
    lines = ["# Exciting trajectory", ""]
    if study.warnings:
        lines += ["## Warnings", ""] + [f"- {w}" for w in study.warnings] + [""]
    lines += ["## Findings", ""] + [f"- {f}" for f in study.findings] + [""]
    lim = r.limits
    rows = [
        (
            name,
            f"[{lim['q'][k][0]:.3g}, {lim['q'][k][1]:.3g}]",
            f"{lim['velocity'][k]:.3g}",
            f"{lim['acceleration'][k]:.3g}",
        )
        for k, name in enumerate(study.names)
    ]
    lines += [
        "## Trajectory",
        "",
        "q_j(t) = q0_j + sum_l a_jl / (l w) sin(l w t) - b_jl / (l w) cos(l w t), w = 2 pi f0; the coefficients "
        "minimise log cond of the stacked base regressor over one period (BFGS with exact gradients), then are "
        "scaled until every limit holds (checked between the samples too). One period sampled in trajectory.csv "
        "(t s, q rad, dq rad/s, ddq rad/s^2 per joint); the coefficients in summary.json.",
        "",
        f"Condition number: {r.cond_start:.4g} from the random start, {r.cond:.4g} optimised.",
        "",
        "Limits used (position rad, velocity rad/s, acceleration rad/s^2):",
        "",
        md_table(("joint", "position", "velocity", "acceleration"), rows),
        "",
    ]
    if study.check is not None:
        c = study.settings["check"]
        lines += [
            "## Check: the simulated robot identified on it",
            "",
            f"{c['periods']} period(s) simulated under joint PD control at {1 / c['dt_s']:g} Hz "
            f"(`simulate_robot`), white torque noise of {100 * c['torque_noise']:g} % of each joint's rms torque; "
            "IDIM-LS on the samples in motion. Joints without armature in the description get 2 % of the largest "
            "diagonal entry of the mass matrix (the simulation needs an invertible one). z = (identified - "
            "description) / std; torque share: how much the difference moves the torques it fits (% of their "
            "norm). A parameter counts as recovered within 4 std or below 0.2 % of the torques (the closed-loop "
            "simulation and the regularised Coulomb law leave systematic errors of that size).",
            "",
            md_table(_HEAD, _recovery_rows(study)),
            "",
        ]
    if figures:
        lines += ["## Figures", ""] + [figure_markdown(f) for f in figures] + [""]
    t = study.timings
    lines += ["## Timings", "", ", ".join(f"{k} {v:.2f} s" for k, v in t.items()), ""]
    return "\n".join(lines)


def fig_trajectory(study: Study) -> "Figure":
    """Per joint over one period: position (rad) with its limits, velocity (rad/s), acceleration (rad/s^2)."""
    t, q, dq, ddq = _period(study)
    lim = study.result.limits
    fig = new_figure(figsize=(11.0, 7.0))
    axes = fig.subplots(3, 1, sharex=True)
    for k, name in enumerate(study.names):
        (line,) = axes[0].plot(t, q[:, k], linewidth=1.0, label=name)
        for v in lim["q"][k]:
            axes[0].axhline(v, color=line.get_color(), linestyle=":", linewidth=0.7)
        axes[1].plot(t, dq[:, k], linewidth=1.0, color=line.get_color())
        axes[2].plot(t, ddq[:, k], linewidth=1.0, color=line.get_color())
    for ax, label in zip(axes, ("position (rad)", "velocity (rad/s)", "acceleration (rad/s$^2$)")):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8, ncol=min(len(study.names), 6))
    axes[2].set_xlabel("time (s), one period")
    r = study.result
    fig.suptitle(
        f"Exciting trajectory: condition number {r.cond_start:.4g} (random start) -> {r.cond:.4g}; dotted: limits",
        fontsize=11,
    )
    return fig


@x64
def write_trajectory(study: Study, folder) -> list[str]:
    """Write trajectory.csv in `folder`: one period of the optimised trajectory at 1000 instants, columns `t` (s),
    then `q_<name>` (rad), `dq_<name>` (rad/s), `ddq_<name>` (rad/s^2) per joint; returns the file names.

    Example:
        >>> import tempfile
        >>> import numpy as np
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.studies.robot import ExcitationDesign, excitation_study, write_trajectory
        >>> arm = SerialRobot.from_mdh([[0, 0, 0, 0]], inertias=[(2.0, [0.3, 0, 0], np.zeros(6))], Fv=1.0, Fc=0.5)
        >>> s = excitation_study(arm, design=ExcitationDesign(harmonics=2, samples=40, max_steps=10), check=False)
        >>> write_trajectory(s, tempfile.mkdtemp())
        ['trajectory.csv']
    """
    t, q, dq, ddq = _period(study)
    head = ["t"] + [f"{p}_{n}" for p in ("q", "dq", "ddq") for n in study.names]
    path = pathlib.Path(folder) / "trajectory.csv"
    np.savetxt(path, np.column_stack([t, q, dq, ddq]), delimiter=",", header=",".join(head), comments="", fmt="%.10g")
    return [path.name]
