"""The robot study's figures: each joint's torque against the full model, and its residual's SDP friction curve."""

import math
from typing import TYPE_CHECKING

import numpy as np

from .._figure_style import new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ._study import RobotStudy


def fig_joints(study: "RobotStudy") -> "Figure":
    """Per joint: measured torque and the full model's fit (N m) over the decimated samples in motion (s)."""
    i = study.idim
    rows = list(i.relative_error)
    cols = 2 if len(rows) > 1 else 1
    fig = new_figure(figsize=(11.0, 2.3 * math.ceil(len(rows) / cols) + 0.6))
    axes = np.atleast_1d(fig.subplots(math.ceil(len(rows) / cols), cols, squeeze=False)).ravel()
    y, fit, mov = np.asarray(i.y), np.asarray(i.fit), np.asarray(i.moving)
    for ax, (k, j) in zip(axes, enumerate(rows)):
        t = np.arange(y.shape[0]) * float(i.inputs[j - 1].dt)
        yy, ff = np.where(mov[:, k], y[:, k], np.nan), np.where(mov[:, k], fit[:, k], np.nan)
        ax.plot(t, yy, color="0.5", linewidth=0.8, label="measured")
        ax.plot(t, ff, color="tab:blue", linewidth=0.9, label="full model")
        ax.set_title(f"{study.names[j - 1]}: {i.relative_error[j]:.1f} %", loc="left", fontsize=9)
        ax.set_ylabel("torque (N m)")
        ax.grid(alpha=0.3)
    for ax in axes[len(rows) :]:
        ax.set_visible(False)
    axes[0].legend(loc="best", fontsize=8)
    for ax in axes[-cols:]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"Full model of every joint (stacked {i.stacked_relative_error:.1f} %)", fontsize=11)
    return fig


def fig_sdp(study: "RobotStudy") -> "Figure":
    """Per joint: the SDP friction curve of its residual (N m) against its velocity (rad/s), with its projection."""
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
        ax.set_title(f"{study.names[j - 1]}: {s.relative_error_moving:.1f} %, {verdict}", loc="left", fontsize=9)
        ax.set_xlabel("velocity (rad/s)")
        ax.set_ylabel("friction (N m)")
        ax.grid(alpha=0.3)
    for ax in axes[len(rows) :]:
        ax.set_visible(False)
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle("SDP of each joint's residual, the rigid body known: friction curves", fontsize=11)
    return fig


def robot_figures(study: "RobotStudy") -> dict:
    """name -> Figure: `joints` (and `sdp_curves` when the SDP ran)."""
    out = {"joints": fig_joints(study)}
    if study.sdp:
        out["sdp_curves"] = fig_sdp(study)
    return out
