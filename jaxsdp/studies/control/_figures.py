"""Figures of the SDP control study (paper section 4: Figs. 13 and 14, the PIP-SDP cascade, SRIVC).

Every function takes a `ControlStudy` (from `control_study`) and returns a
`matplotlib.figure.Figure` built with the object-oriented API (no `pyplot`,
no global state), so it works in notebooks, scripts and the CLI with any
backend, including Agg; `save_control_figures` writes them all as PNG, PDF
or SVG. The functions read only the study's fields (`friction`, `sims`,
`settings`, `real_drive`, `pip_sdp`, `gradients`, `srivc`), so any object
with those fields works too.

Positions are shown in mm (the steps are tens of mm), times in s, forces in
N; step figures (2 % settling time, overshoot) come from
`jaxsdp.control.step_metrics` on the plotted simulations.
"""

import math
import os
import pathlib
from typing import TYPE_CHECKING

import numpy as np

from ..._runtime import x64
from ...control._closed_loop import REAL_DRIVE
from ...control._model import sdp_friction
from ...plants._friction import AsymmetricFriction
from .._figure_style import LEGEND, SDP_STYLE, ZOOM_STYLE, as_float, figure_output, new_figure, panel
from ._figure_parts import (
    HYBRID_IN,
    HYBRID_OUT,
    MM,
    PARAMETRIC,
    STEP_COLOURS,
    TABULATED,
    example_study,  # noqa: F401  (used by the examples)
    friction_fields,
    mark_settling,
    response_metrics,
    settling_band,
    step_label,
    study_field,
    study_sim,
)
from ._figures_loops import fig_cascade, fig_srivc

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_NPMS = "N/(m/s)"
#: File stems of `control_figures` / `save_control_figures`, in order.
CONTROL_FIGURE_NAMES = ("fig13_friction_forms", "fig14_step_responses", "pip_sdp_cascade", "srivc_fit")

# --------------------------------------------------------------------------- #
# Fig. 13: friction forms
# --------------------------------------------------------------------------- #


@x64
def fig_friction_forms(study, *, extent: float = 3.0) -> "Figure":
    """Paper Fig. 13: the friction force (N) the controllers compensate, against velocity (m/s), in three forms.

    (a) Over `extent` times the measured velocity range (shaded grey), from
    the SDP friction curve `study.friction["curve"]` (red crosses):

    - hybrid (the SDP-PD's, `sdp_friction(form="hybrid")`): the SDP curve
      inside the measured range (red), straight lines fitted to its outer
      parts beyond it (blue);
    - tabulated (`sdp_friction(form="tabulated")`, green dashes): the SDP
      curve alone, held constant beyond the data;
    - parametric eq. (17) (black dash-dots): the IDIM-SDP asymmetric law
      f(v) = Fv+ v + Fc+ (v > 0), Fv- v - Fc- (v < 0) from
      `study.friction["asymmetric"]` (negative coefficients clipped to 0, as
      the study does).

    (b) The measured range enlarged: the SDP forms cross zero velocity
    continuously, the parametric law jumps by Fc+ + Fc-.

    `study` may also be a `FrictionEstimate` (from `identify_friction`),
    to draw the forms before running the control study.

    Example:
        >>> fig = fig_friction_forms(example_study())
        >>> [ax.get_ylabel() for ax in fig.axes]
        ['friction force (N)', 'friction force (N)']
    """
    fric = friction_fields(study)
    v, f = (as_float(a) for a in fric["curve"])
    lo, hi = (float(x) for x in fric.get("velocity_range", (v.min(), v.max())))
    if not (extent >= 1 and math.isfinite(extent)):
        raise ValueError(f"`extent` must be a finite number >= 1; got {extent!r}")
    asym = fric["asymmetric"]
    th = {k: max(float(asym[k]), 0.0) for k in ("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")}
    laws = dict(
        hybrid=sdp_friction(v, f, form="hybrid"),
        tabulated=sdp_friction(v, f, form="tabulated"),
        parametric=AsymmetricFriction(**th),
    )
    every = max(1, v.size // 400)
    fig = new_figure(figsize=(7.5, 8.5))
    ax1, ax2 = fig.subplots(2, 1, gridspec_kw=dict(height_ratios=[1.25, 1.0]))
    for ax, (a, b) in ((ax1, (extent * lo, extent * hi)), (ax2, (1.05 * lo, 1.05 * hi))):
        # both sides of zero sampled separately: the parametric law's Coulomb jump stays a jump
        vp = np.r_[np.linspace(a, 0.0, 600, endpoint=False), 0.0, np.linspace(hi * 1e-9, b, 600)]
        vals = {k: as_float(law(vp)) for k, law in laws.items()}
        ax.axvspan(lo, hi, label=f"measured velocity range ({lo:.3g} .. {hi:.3g} m/s)", **ZOOM_STYLE)
        ax.axhline(0.0, color="k", linewidth=0.5)
        ax.axvline(0.0, color="k", linewidth=0.5)
        ax.plot(v[::every], f[::every], label="SDP estimate $\\hat d_{fric}(\\dot q)$", zorder=2, **SDP_STYLE)
        inside = (vp >= lo) & (vp <= hi)
        ax.plot(
            np.where(inside, vp, np.nan), vals["hybrid"], label="hybrid: SDP inside the measured range", **HYBRID_IN
        )
        ax.plot(np.where(vp <= lo, vp, np.nan), vals["hybrid"], label="hybrid: fitted lines beyond it", **HYBRID_OUT)
        ax.plot(np.where(vp >= hi, vp, np.nan), vals["hybrid"], **HYBRID_OUT)
        ax.plot(vp, vals["tabulated"], label="tabulated: SDP curve, held constant beyond", **TABULATED)
        par_v = np.where(vp == 0, np.nan, vp)  # no vertical segment through the jump
        ax.plot(
            par_v,
            vals["parametric"],
            label=(
                f"parametric (17): $F_v^+$ = {th['Fv_pos']:.1f}, $F_v^-$ = {th['Fv_neg']:.1f} {_NPMS},\n"
                f"$F_c^+$ = {th['Fc_pos']:.2f}, $F_c^-$ = {th['Fc_neg']:.2f} N"
            ),
            **PARAMETRIC,
        )
        ax.set_xlim(a, b)
        ax.set_xlabel("velocity $\\dot q$ (m/s)")
        ax.set_ylabel("friction force (N)")
        ax.grid(alpha=0.3)
    panel(ax1, f"(a) Friction forms over {extent:g}x the measured velocity range")
    ax1.legend(loc="upper left", **LEGEND)
    panel(ax2, "(b) The measured range: the SDP forms are continuous at 0, the parametric law jumps")
    return fig


# --------------------------------------------------------------------------- #
# Fig. 14: step responses
# --------------------------------------------------------------------------- #


def _wn(d, default):
    try:
        w = float(d["wn"])
    except (KeyError, TypeError, ValueError):
        return default
    return w if math.isfinite(w) else default


def _position_panel(ax, ref, y0, target, *, legend=True):
    ax.plot(ref.t, MM * ref.r, color="k", linewidth=0.9, linestyle="--", label="reference" if legend else None)
    settling_band(ax, MM * target, MM * (target - y0), legend=legend)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("position (mm)")


@x64
def fig_step_responses(study) -> "Figure":
    """Paper Fig. 14: SDP-PD vs the benchmark's linear PD position steps (mm), then the real drive.

    (a) The paper's setting (no drive delay, no saturation): SDP-PD
    (`sims["sdp_pd"]`, hybrid friction) and linear PD (`sims["linear_pd"]`)
    with the reference, the +-2 % band and the settling times (dotted
    verticals; legend: settling time and overshoot). (b) The SDP-PD with the
    real drive's one-sample delay, at the design wn (`"delay"`) and at the
    largest wn that keeps the overshoot under 2 % with the delay
    (`"delay_wn_max"`), the ideal response (a) in grey. (c) The SDP-PD with
    the real drive's +-351.5 N force limit at the design wn
    (`"saturation"`) and with both defects at the largest wn
    (`"real_wn_max"`); (d) their drive force (N), with the peak force the
    ideal design asks for.

    Example:
        >>> fig = fig_step_responses(example_study())
        >>> [ax.get_xlabel() for ax in fig.axes]
        ['time (s)', 'time (s)', 'time (s)', 'time (s)']
    """
    sdp, lin = study_sim(study, "sdp_pd"), study_sim(study, "linear_pd")
    settings = study_field(study, "settings")
    real = getattr(study, "real_drive", {}) or {}
    wn = float(getattr(settings, "wn", float("nan")))
    wn_max = _wn(real.get("delay_largest_wn", {}), float(real.get("largest_wn_delay", float("nan"))))
    target, y0 = float(sdp.r[-1]), float(sdp.q[0])
    lim = float(REAL_DRIVE.force_limit)
    t_end = float(sdp.t[-1])

    fig = new_figure(figsize=(7.5, 12.0))
    ax1, ax2, ax3, ax4 = fig.subplots(4, 1, gridspec_kw=dict(height_ratios=[1.0, 0.9, 0.9, 0.6]))
    # (a) the paper's setting
    _position_panel(ax1, sdp, y0, target)
    settle = []
    for k, (key, sim, name) in enumerate(
        (("linear_pd", lin, "linear PD"), ("sdp_pd", sdp, f"SDP-PD ($\\omega_n$ = {wn:g} rad/s)"))
    ):
        m = response_metrics(sim)
        ax1.plot(sim.t, MM * sim.q, color=STEP_COLOURS[key], linewidth=1.5, label=step_label(name, m))
        mark_settling(ax1, m, STEP_COLOURS[key], 0.5 - 0.09 * k)
        if m is not None and m.settled:
            settle.append(m.settling_time)
    ax1.set_xlim(sdp.t[0], min(t_end, max(2.5 * max(settle, default=t_end), 0.1 * t_end)))
    panel(ax1, "(a) Paper's setting: no drive delay, no saturation")
    ax1.legend(loc="lower right", **LEGEND)

    # (b) delay, (c) force limit, (d) force of (c)
    panels = (
        (
            ax2,
            (
                ("delay", f"1-sample delay, $\\omega_n$ = {wn:g}"),
                ("delay_wn_max", f"1-sample delay, $\\omega_n$ = {wn_max:g} (largest with < 2 % overshoot)"),
            ),
            "(b) SDP-PD with the drive's one-sample delay",
            "lower right",
        ),
        (
            ax3,
            (
                ("saturation", f"$\\pm${lim:.1f} N limit, $\\omega_n$ = {wn:g}"),
                ("real_wn_max", f"delay and limit (real drive), $\\omega_n$ = {wn_max:g}"),
            ),
            "(c) SDP-PD with the drive's force limit",
            "lower right",
        ),
    )
    t_real = t_end
    for ax, cases, title, loc in panels:
        ax.plot(sdp.t, MM * sdp.q, color="0.6", linewidth=2.5, alpha=0.6, label="ideal drive (a)")
        t_panel = t_end
        settling_band(ax, MM * target, MM * (target - y0), legend=False)
        ax.axhline(MM * target, color="k", linewidth=0.9, linestyle="--", label="reference (a step at t = 0)")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("position (mm)")
        for k, (key, name) in enumerate(cases):
            sim = study_sim(study, key, required=False)
            if sim is None:
                continue
            m = response_metrics(sim)
            c, ls = STEP_COLOURS[key], ("--" if key == "real_wn_max" else "-")
            q = np.where(np.abs(sim.q - y0) < 3 * abs(target - y0), sim.q, np.nan)  # a diverging one leaves
            ax.plot(sim.t, MM * q, color=c, linewidth=1.3, linestyle=ls, label=step_label(name, m))
            t_panel = max(t_panel, float(sim.t[-1]))  # the real-drive runs may be longer than (a)
            mark_settling(ax, m, c, 0.5 - 0.14 * k)  # labels far enough apart not to overlap
            if ax is ax3 and np.all(np.isfinite(sim.force)):
                ax4.plot(sim.t, sim.force, color=c, linewidth=1.2, linestyle=ls)
                t_real = max(t_real, float(sim.t[-1]))
        if t_panel > t_end:  # the ideal run (a) is shorter: it has settled, so hold its end to the axis's
            ax.plot([t_end, t_panel], [MM * float(sdp.q[-1])] * 2, color="0.6", linewidth=2.5, alpha=0.6)
        ax.set_xlim(sdp.t[0], t_panel)
        panel(ax, title)
        ax.legend(loc=loc, **LEGEND)
    for s in (-1, 1):
        ax4.axhline(s * lim, color="k", linewidth=0.8, linestyle=":", label=f"$\\pm${lim:.1f} N" if s > 0 else None)
    ax4.set_ylim(-1.3 * lim, 1.3 * lim)
    ax4.set_xlim(sdp.t[0], t_real)
    ax4.set_xlabel("time (s)")
    ax4.set_ylabel("drive force (N)")
    peak = float(np.max(np.abs(sdp.force))) if np.all(np.isfinite(sdp.force)) else float("nan")
    big = f"{peak / 1e3:.0f} kN" if peak >= 1e4 else f"{peak:.0f} N"
    panel(ax4, f"(d) Drive force of (c); the ideal drive's peak is {big} ({peak / lim:.0f}x the limit)")
    ax4.legend(loc="upper right", **LEGEND)
    return fig


# --------------------------------------------------------------------------- #
# All figures
# --------------------------------------------------------------------------- #


@x64
def control_figures(study) -> dict[str, "Figure"]:
    """All figures of a `ControlStudy`, keyed by `CONTROL_FIGURE_NAMES`: Figs. 13 and 14, the cascade, SRIVC.

    Example:
        >>> sorted(control_figures(example_study()))
        ['fig13_friction_forms', 'fig14_step_responses', 'pip_sdp_cascade', 'srivc_fit']
    """
    return dict(
        zip(
            CONTROL_FIGURE_NAMES,
            (fig_friction_forms(study), fig_step_responses(study), fig_cascade(study), fig_srivc(study)),
        )
    )


@x64
def save_control_figures(study, out: str | os.PathLike, *, fmt: str = "png", dpi: float = 150) -> list[pathlib.Path]:
    """Write the figures of `control_figures(study)` in the directory `out` (must exist) as `<name>.<fmt>`.

    `fmt`: one of `FIGURE_FORMATS` ("png", "pdf", "svg"); `dpi`: resolution
    (dots per inch, > 0) of raster output (PDF and SVG are vector graphics).
    Returns the paths written, in the order of `CONTROL_FIGURE_NAMES`.

    Example:
        >>> import tempfile
        >>> paths = save_control_figures(example_study(), tempfile.mkdtemp(), dpi=30)
        >>> [p.name for p in paths]
        ['fig13_friction_forms.png', 'fig14_step_responses.png', 'pip_sdp_cascade.png', 'srivc_fit.png']
    """
    path_out = figure_output(fmt, dpi, out)
    paths = []
    for name, fig in control_figures(study).items():
        path = path_out / f"{name}.{fmt}"
        fig.savefig(path, format=fmt, dpi=float(dpi))
        paths.append(path)
    return paths
