"""The full-model figure of the TX40 study (`--model full`): the SDP curves with and without the coupling known.

Left: the friction curve d_dq(dq) of the one-joint multi-SDP (y - ZZ ddq)
and of the full model's residual (y - rigid-body torque), each without the
constant of its projection, against the robot's nominal Fv dq + Fc sign(dq).
Right: the q-curve d_q(q): the one-joint model's gravity curve (which also
absorbs the coupling) and what is left of it once the full rigid-body model
is known. Units: q rad, dq rad/s, torque N m.
"""

from typing import TYPE_CHECKING

import numpy as np

from ..._runtime import x64
from .._contract import Study, check_study
from .._figure_style import LEGEND, SDP_STYLE, as_float, new_figure

if TYPE_CHECKING:  # annotations only: `TX40Study.figures()` calls this module
    from matplotlib.figure import Figure


FULL_STYLE = dict(marker=".", linestyle="none", color="tab:green", markersize=2.5)
NOMINAL_STYLE = dict(color="k", linewidth=1.2, linestyle="--", zorder=4)


def _curve(sdp, column: int, x):
    order = np.argsort(as_float(x), kind="stable")
    proj = sdp.gravity if column == 0 else sdp.friction
    d = as_float(sdp.result.d[:, column]) - float(proj["offset"])
    return as_float(x)[order], d[order]


def _offset(study) -> float:
    off = study.settings.get("joint_offsets") or []
    return float(off[study.joint - 1]) if len(off) >= study.joint else 0.0


@x64
def fig_full_model(study: Study) -> "Figure":
    """Friction and q-curves of the one-joint multi-SDP and of the full model + SDP (N m).

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, fig_full_model
        >>> fig_full_model(example_study())
        Traceback (most recent call last):
        ...
        ValueError: the study has no full model: run tx40_study(..., `full_model=FullModel()`)
    """
    check_study(study, "TX40Study", "tx40_study", argument="study")
    if study.full is None:
        raise ValueError("the study has no full model: run tx40_study(..., `full_model=FullModel()`)")
    j, s, fs = study.joint, study.sdp, study.full_sdp
    robot = study.full.model.robot
    fig = new_figure(figsize=(10.0, 4.0))
    ax1, ax2 = fig.subplots(1, 2)
    for sdp, style, label in (
        (s, {**SDP_STYLE, "markersize": 2.5}, "one-joint multi-SDP"),
        (fs, FULL_STYLE, "full model + SDP"),
    ):
        x, d = _curve(sdp, 1, sdp.dq)
        ax1.plot(x, d, label=label, **style)
    x = np.linspace(float(np.min(as_float(s.dq))), float(np.max(as_float(s.dq))), 400)
    fv, fc = float(robot.Fv[j - 1]), float(robot.Fc[j - 1])
    ax1.plot(x, fv * x + fc * np.sign(x), label="nominal Fv dq + Fc sign dq", **NOMINAL_STYLE)
    ax1.set_xlabel(f"dq{j} (rad/s)")
    ax1.set_ylabel("friction torque (N m)")
    ax1.set_title(f"(a) friction curve d_dq(dq{j})", fontsize=10, loc="left")
    ax1.legend(loc="best", **LEGEND)
    ax1.grid(alpha=0.3)
    for sdp, style, label in (
        (s, {**SDP_STYLE, "markersize": 2.5}, "one-joint: gravity + coupling"),
        (fs, FULL_STYLE, "left once the rigid body is known"),
    ):
        shift = 0.0 if sdp is s else _offset(study)  # the full model's angles back to the log's convention
        x, d = _curve(sdp, 0, as_float(sdp.q) - shift)
        ax2.plot(x, d, label=f"{label} (rms {float(np.sqrt(np.mean(d**2))):.2g} N m)", **style)
    ax2.axhline(0.0, color="k", linewidth=0.6)
    ax2.set_xlabel(f"q{j} (rad, the logs' convention)")
    ax2.set_ylabel("q-dependent torque (N m)")
    ax2.set_title(f"(b) q-curve d_q(q{j}): near 0 once the rigid body is known", fontsize=10, loc="left")
    ax2.legend(loc="best", **LEGEND)
    ax2.grid(alpha=0.3)
    return fig
