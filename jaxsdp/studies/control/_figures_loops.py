"""Figures of the PIP-SDP cascade and of the SRIVC (or RIVCBJ) model of the SDP-PD loop (control study)."""

import math
from typing import TYPE_CHECKING

import numpy as np

from ..._runtime import x64
from ...control._closed_loop import REAL_DRIVE
from .._figure_style import LEGEND, ZOOM_STYLE, as_float, new_figure, panel
from ._figure_parts import (
    CASCADE,
    MM,
    example_study,  # noqa: F401  (used by the examples)
    fmt3,
    ms_text,
    response_metrics,
    settling_band,
    study_field,
    study_sim,
)
from ._report import ratio_range

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# --------------------------------------------------------------------------- #
# PIP-SDP cascade
# --------------------------------------------------------------------------- #


@x64
def fig_cascade(study, *, zoom: float = 0.08) -> "Figure":
    r"""PIP-SDP cascade step responses: position (mm), velocity (m/s), drive force (N) against time (s).

    Three designs share the panels: the hand-tuned loop gain LG (the
    largest that keeps $|\dot q| \le$ `v_limit`, `sims["pip_sdp"]`), the
    gradient-tuned design (`sims["pip_sdp_tuned"]`, when the study ran the
    tuning) and the hand-tuned design with the real drive (delay and force
    limit, `sims["pip_sdp_real"]`, dashed). (a) Position with the inner
    reference r_in that the PIP loop feeds the SDP-PD loop (dotted, same
    colour), the reference and the +-2 % band; (b) velocity with the
    +-v_limit lines; (c) drive force with the real drive's limit; (d), (e)
    velocity and force over the `zoom` s around the hand-tuned design's
    velocity peak (shaded in (b)), where the PIP's held output, updated at
    the outer rate, shows. When the paper's LG is unstable on the identified
    model, the title says so (that response diverges and is not drawn).

    Example:
        >>> fig = fig_cascade(example_study())
        >>> [ax.get_ylabel() for ax in fig.axes]
        ['position (mm)', 'velocity (m/s)', 'drive force (N)', 'velocity (m/s)', 'drive force (N)']
    """
    settings = study_field(study, "settings")
    v_limit = float(settings.v_limit)
    pip = getattr(study, "pip_sdp", {}) or {}
    tuned = (getattr(study, "gradients", {}) or {}).get("tuned") or {}
    base = study_sim(study, "pip_sdp")
    target, y0 = float(base.r[-1]), float(base.q[0])
    lim = float(REAL_DRIVE.force_limit)
    labels = {
        "pip_sdp": f"hand-tuned LG = {fmt3(pip.get('loop_gain'))}, $\\omega_n$ = {fmt3(settings.wn)}",
        "pip_sdp_tuned": (
            f"gradient-tuned LG = {fmt3(tuned.get('loop_gain'))}, $\\omega_n$ = {fmt3(tuned.get('wn'))}, "
            f"ew = {fmt3(tuned.get('ew'))}, xw = {fmt3(tuned.get('xw'))}"
        ),
        "pip_sdp_real": f"hand-tuned LG, real drive, $\\omega_n$ = {fmt3((pip.get('real_drive') or {}).get('wn'))}",
    }
    fig = new_figure(figsize=(7.5, 12.5))
    grid = fig.add_gridspec(4, 2, height_ratios=[1.5, 0.8, 0.8, 0.8])
    ax1, ax2, ax3 = (fig.add_subplot(grid[i, :]) for i in range(3))
    ax4, ax5 = fig.add_subplot(grid[3, 0]), fig.add_subplot(grid[3, 1])
    ax1.plot(base.t, MM * base.r, color="k", linewidth=0.9, linestyle="--", label="reference")
    settling_band(ax1, MM * target, MM * (target - y0))
    i_peak = int(np.nanargmax(np.abs(base.dq))) if np.all(np.isfinite(base.dq)) else 0
    zlo = max(float(base.t[0]), float(base.t[i_peak]) - 0.25 * zoom)
    zhi = min(float(base.t[-1]), zlo + zoom)
    zsel = (base.t >= zlo) & (base.t <= zhi)
    peak_force = lim
    for key, c in CASCADE:
        sim = study_sim(study, key, required=False)
        if sim is None:
            continue
        m = response_metrics(sim)
        ls = "--" if key == "pip_sdp_real" else "-"
        label = labels[key]
        if m is None:
            label += ": unstable"
        else:
            ts = f"$t_s$ = {ms_text(m.settling_time)}" if m.settled else f"not settled in {sim.t[-1]:.2g} s"
            label += f"\n{ts}, peak |$\\dot q$| = {m.peak_velocity:.3f} m/s"
        # the real-drive run often lies on the ideal one: drawn dashed over a wider, lighter solid line
        wide = dict(linewidth=3.0, alpha=0.45) if key == "pip_sdp" else dict(linewidth=1.5)
        ax1.plot(sim.t, MM * sim.q, color=c, linestyle=ls, label=label, **wide)
        ax1.plot(sim.t, MM * sim.aux, color=c, linewidth=1.0, linestyle=":")
        for ax, x in ((ax2, sim.dq), (ax3, sim.force)):
            ax.plot(sim.t, x, color=c, linewidth=2.0 if key == "pip_sdp" else 0.8, linestyle=ls)
        for ax, x in ((ax4, sim.dq), (ax5, sim.force)):
            ax.plot(sim.t[zsel], x[zsel], color=c, linewidth=1.1, linestyle=ls, marker=".", markersize=2.5)
        if np.all(np.isfinite(sim.force)):
            peak_force = max(peak_force, float(np.max(np.abs(sim.force))))
    ax1.plot([], [], color="0.3", linewidth=1.0, linestyle=":", label="inner reference $r_{in}$ (same colour)")
    for s in (-1, 1):
        for ax in (ax2, ax4):
            ax.axhline(
                s * v_limit, color="k", linewidth=0.8, linestyle="--", label=f"$\\pm${v_limit:g} m/s" if s > 0 else None
            )
        for ax in (ax3, ax5):
            ax.axhline(s * lim, color="k", linewidth=0.8, linestyle=":", label="real drive limit" if s > 0 else None)
    ax2.axvspan(zlo, zhi, label="window of (d), (e)", **ZOOM_STYLE)
    ax3.axvspan(zlo, zhi, **ZOOM_STYLE)
    for ax in (ax2, ax4):
        ax.set_ylim(-1.25 * v_limit, 1.25 * v_limit)
        ax.set_ylabel("velocity (m/s)")
    for ax in (ax3, ax5):
        ax.set_ylim(-1.15 * peak_force, 1.15 * peak_force)
        ax.set_ylabel("drive force (N)")
    for ax in (ax1, ax2, ax3):
        ax.set_xlim(base.t[0], base.t[-1])
    for ax in (ax4, ax5):
        ax.set_xlim(zlo, zhi)
        ax.tick_params(axis="x", labelsize=8)
    for ax in (ax1, ax2, ax3, ax4, ax5):
        ax.set_xlabel("time (s)")
    ax1.set_ylabel("position (mm)")
    panel(ax1, "(a) Position and inner reference")
    ax1.legend(loc="lower right", **LEGEND)
    panel(ax2, f"(b) Velocity, limit $\\pm${v_limit:g} m/s", dict(ncol=2))
    panel(ax3, f"(c) Drive force, real drive limit $\\pm${lim:.1f} N")
    panel(ax4, "(d) Velocity, zoom")
    panel(ax5, "(e) Drive force, zoom")
    paper = pip.get("paper_loop_gain") or {}
    title = "PIP-SDP cascade: a PIP loop at the outer rate sets the SDP-PD loop's reference"
    if paper and not paper.get("stable", True):
        title += f"\n(the paper's LG = {fmt3(paper.get('loop_gain'))} is unstable on this identified model: not drawn)"
    fig.suptitle(title, fontsize=10)
    return fig


# --------------------------------------------------------------------------- #
# SRIVC / RIVCBJ
# --------------------------------------------------------------------------- #


def _poly(c, var="s") -> str:
    c = [float(x) for x in c]
    n = len(c) - 1
    terms = []
    for i, a in enumerate(c):
        p = n - i
        if a == 0:
            continue
        mag = abs(a)
        coef = "" if (mag == 1 and p > 0) else _num(mag)
        power = "" if p == 0 else (var if p == 1 else f"{var}$^{p}$")
        sep = " " if coef and power else ""
        sign = "-" if a < 0 else "+"
        terms.append((sign, f"{coef}{sep}{power}"))
    if not terms:
        return "0"
    text = ("-" if terms[0][0] == "-" else "") + terms[0][1]
    for sign, t in terms[1:]:
        text += f" {sign} {t}"
    return text


def _zpoly(c) -> str:
    """A monic polynomial in z^-1 (coefficients of z^0, z^-1, ...): [1, -0.95] -> "1 - 0.95 z$^{-1}$"."""
    text = _num(float(c[0]))
    for k, a in enumerate(c[1:], start=1):
        if float(a) != 0:
            text += f" {'-' if a < 0 else '+'} {_num(abs(float(a)))} z$^{{-{k}}}$"
    return text


def _ratio(c, d) -> str:
    """C(z^-1)/D(z^-1) as text: ([1], [1, -0.95]) -> "1 / (1 - 0.95 z$^{-1}$)"."""
    c, d = (_zpoly(p) if len(p) == 1 else f"({_zpoly(p)})" for p in (c, d))
    return f"{c} / {d}"


def _num(x: float) -> str:
    """5 significant digits, no exponent between 1e-3 and 1e7: 176969.5 -> 176970, 1295.64 -> 1295.6, 250.0 -> 250."""
    if x == 0 or not (1e-3 <= abs(x) < 1e7):
        return f"{x:.4g}"
    text = f"{x:.{max(0, 4 - int(math.floor(math.log10(abs(x)))))}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def _pole(p) -> str:
    p = complex(p)
    if abs(p.imag) < 1e-6 * max(1.0, abs(p)):
        return _num(p.real)
    return f"{_num(p.real)} {'+' if p.imag > 0 else '-'} {_num(abs(p.imag))}j"


def _step_times(r, t):
    jumps = np.flatnonzero(np.diff(r) != 0) + 1
    return t[jumps]


@x64
def fig_srivc(study, *, window: float = 2.0, zoom: float = 0.06) -> "Figure":
    """SRIVC (or RIVCBJ) identification of the SDP-PD closed loop: model output against the noisy data (mm), and
    residual.

    The closed-loop experiment `sims["ident"]` (reference r: random steps;
    y: the measured position with output noise) and the output of the
    continuous-time model B(s)/A(s) that the study's estimator identified
    (`study.srivc`, its `estimator` named in the title and legends with the
    fit; with RIVCBJ also its noise model C/D and its standard errors against
    SRIVC's on the same data). (a) `window` s of the record
    (shaded in (c)); (b) `zoom` s around one reference step in that window
    (shaded in (a)), where the model's dynamics show against the noise; (c)
    the residual y - y_model over the whole record, with +-2 standard
    deviations. The title gives the model, its poles and static gain, and
    for comparison, the poles of the SDP-PD design
    wn^2 / (s^2 + 2 eta wn s + wn^2) (the ideal continuous-time loop).

    Example:
        >>> fig = fig_srivc(example_study())
        >>> [ax.get_ylabel() for ax in fig.axes]
        ['position (mm)', 'position (mm)', 'residual (mm)']
    """
    d = study_sim(study, "ident")
    info = study_field(study, "srivc")
    name = str(info.get("estimator", "srivc")).upper()
    t, r, y, ym = d["t"], d["r"], d["y"], d["y_model"]
    if not (window > 0 and zoom > 0):
        raise ValueError(f"`window` and `zoom` must be positive (s); got {window!r}, {zoom!r}")
    # the window: `window` s in the middle of the record
    span = float(t[-1] - t[0])
    w = min(window, span)
    lo = float(t[0]) + 0.5 * (span - w)
    hi = lo + w
    sel = (t >= lo) & (t <= hi)
    steps = [s for s in _step_times(r, t) if lo + 0.2 * zoom <= s <= hi - zoom]
    centre = min(steps, key=lambda s: abs(s - 0.5 * (lo + hi))) if steps else 0.5 * (lo + hi)
    zlo, zhi = centre - 0.2 * zoom, centre + 0.8 * zoom
    zsel = (t >= zlo) & (t <= zhi)
    e = y - ym
    sd = float(np.std(e))

    fig = new_figure(figsize=(7.5, 9.0))
    ax1, ax2, ax3 = fig.subplots(3, 1, gridspec_kw=dict(height_ratios=[1.1, 1.0, 0.8]))
    data_style = dict(color="0.45", marker=".", linestyle="none", markersize=2.0)
    ax1.plot(t[sel], MM * y[sel], label="measured y (noisy)", **data_style)
    ax1.step(t[sel], MM * r[sel], where="post", color="k", linewidth=0.8, linestyle="--", label="reference r")
    ax1.plot(t[sel], MM * ym[sel], color="tab:red", linewidth=1.2, label=f"{name} model output")
    ax1.axvspan(zlo, zhi, **ZOOM_STYLE)
    ax1.set_xlim(lo, hi)
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("position (mm)")
    panel(ax1, f"(a) {w:g} s of the record", dict(ncol=3))
    ax2.plot(t[zsel], MM * y[zsel], label="measured y", **dict(data_style, markersize=4.0))
    ax2.step(t[zsel], MM * r[zsel], where="post", color="k", linewidth=0.8, linestyle="--", label="reference r")
    ax2.plot(t[zsel], MM * ym[zsel], color="tab:red", linewidth=1.5, label=f"{name} model output")
    ax2.set_xlim(zlo, zhi)
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("position (mm)")
    panel(ax2, f"(b) {1e3 * zoom:.0f} ms zoom", dict(ncol=3))
    ax3.plot(t, MM * e, color="tab:red", linewidth=0.5, alpha=0.8, label=f"y - model (std {MM * sd:.3g} mm)")
    for s in (-1, 1):
        ax3.axhline(s * 2 * MM * sd, color="k", linewidth=0.8, linestyle=":", label="$\\pm$2 std" if s > 0 else None)
    ax3.axvspan(lo, hi, label="window of (a)", **ZOOM_STYLE)
    ax3.set_xlim(t[0], t[-1])
    ax3.set_xlabel("time (s)")
    ax3.set_ylabel("residual (mm)")
    panel(ax3, "(c) Residual", dict(ncol=3))
    fit = info.get("fit_pct")
    noise = info.get("noise_pct")
    num, den = as_float(info["num"]), as_float(info["den"])
    title = f"{name} model of the SDP-PD loop: G(s) = ({_poly(num)}) / ({_poly(den)})"
    poles = np.roots(den)
    extra = ["poles " + ", ".join(_pole(p) for p in poles) + " rad/s", f"static gain {num[-1] / den[-1]:.4g}"]
    if fit is not None:
        extra.append(f"fit {float(fit):.2f} %")
    colour = info.get("noise_colour")
    if noise is not None and colour is None:
        extra.append(f"output noise {float(noise):g} % of the position std")
    title += "\n" + ", ".join(extra)
    if noise is not None and colour is not None:
        title += (
            f"\noutput noise {float(noise):g} % of the position std, coloured by {_ratio(colour['c'], colour['d'])}"
        )
    if info.get("c") is not None:
        title += f"\nnoise model C/D = {_ratio(info['c'], info['d'])}"
        ref = info.get("compare_srivc")
        if ref is not None:
            ours, srivc = ([*x["num_se"], *x["den_se"][1:]] for x in (info, ref))  # a0 = 1 is not estimated
            ratios = [e / f for e, f in zip(ours, srivc) if f > 0]
            title += f", standard errors {ratio_range(min(ratios), max(ratios))} times SRIVC's"
    settings = getattr(study, "settings", None)
    wn, eta = getattr(settings, "wn", None), getattr(settings, "eta", None)
    if wn is not None and eta is not None:
        design = np.roots([1.0, 2 * float(eta) * float(wn), float(wn) ** 2])
        title += (
            f"\nSDP-PD design $\\omega_n^2/(s^2 + 2 \\eta \\omega_n s + \\omega_n^2)$ "
            f"($\\omega_n$ = {float(wn):g} rad/s, $\\eta$ = {float(eta):g}): poles "
            + ", ".join(_pole(p) for p in design)
            + " rad/s"
        )
    fig.suptitle(title, fontsize=10)
    return fig
