"""The robot study's figures: each joint's torque against the full model, and its residual's SDP friction curve."""

import math
from typing import TYPE_CHECKING

import numpy as np

from ...plants.robot._validation import joint_units
from .._contract import Study
from .._figure_style import new_figure
from ._report import verdicts

if TYPE_CHECKING:
    from matplotlib.figure import Figure


#: Characters of a verdict's reason shown in a panel title.
TITLE_REASON = 60


def _title(study: Study, j: int, numbers: str, *, reason: bool = True) -> tuple[str, str]:
    """A joint panel's title and colour: its numbers, or "not identifiable: <reason>" (its first sentence,
    shortened; without it when not `reason`) in red when the study's optional `verdicts` says so
    (`_report.verdicts`)."""
    name = study.names[j - 1]
    ok, why = verdicts(study).get(j, (True, ""))
    if ok:
        return f"{name}: {numbers}", "black"
    why = why.split("; ")[0].rstrip(".") if reason else ""
    if len(why) > TITLE_REASON:
        why = why[: TITLE_REASON - 3].rstrip() + "..."
    return f"{name}: not identifiable" + (f": {why}" if why else "") + f" ({numbers})", "tab:red"


def _source(study) -> str:
    """The data a figure shows, for its title: the study's source without folders."""
    import re

    return re.sub(r"[^\s()+,]*[/\\]", "", str(study.source)) or "robot study"


def fig_joints(study: Study) -> "Figure":
    """Per joint: measured torque (N m; force, N, for a prismatic joint) and the full model's fit over the decimated
    rows of the record against the log's time (s, from its first sample); rows at rest shaded."""
    i = study.idim
    rows = list(i.relative_error)
    cols = 2 if len(rows) > 1 else 1
    fig = new_figure(figsize=(11.0, 2.3 * math.ceil(len(rows) / cols) + 0.6))
    axes = np.atleast_1d(fig.subplots(math.ceil(len(rows) / cols), cols, squeeze=False)).ravel()
    y, mov = np.asarray(i.y), np.asarray(i.moving)
    fit = np.asarray(i.fit if i.record_fit is None else i.record_fit)  # Coulomb off at rest, as in the error
    record = slice(0, y.shape[0] - int(i.tail))
    if i.t is not None:
        t = np.asarray(i.t, dtype=float)
    else:  # a RobotIDIM without its times: from the first row kept
        t = np.arange(y.shape[0]) * float(i.inputs[rows[0] - 1].dt)
    t = t[record]
    if t.size and abs(t[0]) > 1e6:  # epoch time stamps: the axis counts from the record's start
        t = t - t[0]
    for ax, (k, j) in zip(axes, enumerate(rows)):
        u = joint_units(i.model.robot, j)
        rest = ~mov[record, k]
        ax.fill_between(
            t, 0.0, 1.0, where=rest, transform=ax.get_xaxis_transform(), color="0.9", linewidth=0, label="at rest"
        )
        ax.plot(t, fit[record, k], color="tab:blue", linewidth=1.6, label="full model")
        ax.plot(t, y[record, k], color="tab:orange", linewidth=0.6, label="measured")
        numbers = f"{i.relative_error[j]:.1f} % in motion, {i.relative_error_all.get(j, float('nan')):.1f} % whole"
        title, colour = _title(study, j, numbers)
        ax.set_title(title, loc="left", fontsize=9, color=colour)
        ax.set_ylabel("force (N)" if u["effort"] == "N" else f"torque ({u['effort']})")
        ax.set_xlim(t[0], t[-1])
        ax.grid(alpha=0.3)
    for ax in axes[len(rows) :]:
        ax.set_visible(False)
    axes[0].legend(loc="best", fontsize=8)
    for ax in axes[max(len(rows) - cols, 0) : len(rows)]:  # the lowest panel of each column
        ax.set_xlabel("time (s)")
    stacked = getattr(study, "stacked_relative_error", None)
    stacked = i.stacked_relative_error if stacked is None else stacked
    fig.suptitle(f"{_source(study)}: full model of every joint (stacked {stacked:.1f} %)", fontsize=11)
    return fig


def fig_sdp(study: Study) -> "Figure":
    """Per joint: the SDP friction curve of its residual (N m, or N) against its velocity (rad/s, or m/s for a
    prismatic joint), with its projection."""
    rows = list(study.sdp)
    cols = 3 if len(rows) > 2 else len(rows)
    fig = new_figure(figsize=(11.0, 2.8 * math.ceil(len(rows) / cols) + 0.6))
    axes = np.atleast_1d(fig.subplots(math.ceil(len(rows) / cols), cols, squeeze=False)).ravel()
    for ax, j in zip(axes, rows):
        s = study.sdp[j]
        res = s.result
        x, d = np.asarray(res.x_sorted[1]), np.asarray(res.d_sorted[1])
        ax.plot(x, d, linestyle="none", marker=".", markersize=1.5, color="tab:red", label="SDP curve")
        fv, fc, off = (float(s.friction[k]) for k in (f"Fv{j}", f"Fc{j}", "offset"))
        v = np.linspace(x.min(), x.max(), 400)
        ax.plot(v, fv * v + fc * np.sign(v) + off, "k--", linewidth=1.0, label="Fv dq + Fc sign dq")
        verdict = "mismatch" if s.shape.mismatch else "match"
        title, colour = _title(study, j, f"{s.relative_error_moving:.1f} %, {verdict}", reason=False)
        ax.set_title(title, loc="left", fontsize=9, color=colour)
        u = joint_units(study.idim.model.robot, j)
        ax.set_xlabel(f"velocity ({u['velocity']})")
        ax.set_ylabel(f"friction ({u['effort']})")
        ax.grid(alpha=0.3)
    for ax in axes[len(rows) :]:
        ax.set_visible(False)
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle(f"{_source(study)}: SDP of each joint's residual, the rigid body known", fontsize=11)
    return fig


def robot_figures(study: Study) -> dict:
    """name -> Figure: `joints` (and `sdp_curves` when the SDP ran)."""
    out = {"joints": fig_joints(study)}
    if study.sdp:
        out["sdp_curves"] = fig_sdp(study)
    return out
