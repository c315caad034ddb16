"""Figures of the EMPS study (paper Figs. 3-5 and the force reconstruction).

Every function returns a `matplotlib.figure.Figure` built with the
object-oriented API (no `pyplot`, no global state), so it works in notebooks
(the figure displays itself), in scripts and in the CLI
(`fig.savefig("fig3.pdf")`) with any backend, including Agg;
`save_emps_figures` writes them all as PNG, PDF or SVG.

Colours follow the paper: SDP estimates as red crosses with a pink
+-2 s.e. band, parametric (IDIM-LS or IDIM-SDP) models in blue. Every
panel has its x label and every parameter value in a legend its unit.
"""

import os
import pathlib
from typing import TYPE_CHECKING

import numpy as np

from ..._idim.ls import IDIMResult
from ..._runtime import x64
from ...plants.emps._idim_sdp import EMPSIDIMSDP
from ...plants.emps._model import asym_friction
from ...plants.emps._sdp_stage import EMPSSDPStage
from .._contract import Study, check_study
from .._figure_style import LEGEND, SDP_STYLE, ZOOM_STYLE, figure_output
from .._figure_style import as_float as _np
from .._figure_style import new_figure as _figure
from .._figure_style import panel as _panel

if TYPE_CHECKING:  # annotations only: `EMPSStudy.figures()` calls this module
    from matplotlib.figure import Figure


MODEL_STYLE = dict(color="tab:blue", marker=".", linestyle="none", markersize=3.0)
BAND_STYLE = dict(color="tab:red", alpha=0.15, linewidth=0)
# unit of the viscous friction coefficients
_NPMS = "N/(m/s)"


def _check_stage(stage):
    if not isinstance(stage, EMPSSDPStage):
        raise ValueError(f"`stage` must be an EMPSSDPStage (from emps_sdp_stage); got {type(stage).__name__}")


def _theta(r: IDIMResult) -> dict:
    return dict(zip(r.names, _np(r.theta)))


def _mass_value(idim) -> tuple[float, float] | None:
    """(M, std of M) of an IDIMResult or a number (std 0), or None."""
    if idim is None:
        return None
    if isinstance(idim, IDIMResult):
        names = list(idim.names)
        if "M" not in names:
            raise ValueError(f"`idim` has no parameter 'M'; names {idim.names}")
        i = names.index("M")
        return float(_np(idim.theta)[i]), float(_np(idim.std)[i])
    return float(idim), 0.0


def _band_label(band: float) -> str:
    return f"SDP $\\pm{band:g}$ s.e."


@x64
def fig_sdp_mass(
    stage: EMPSSDPStage, idim: IDIMResult | float | None = None, *, band: float = 2.0, verdict: str | None = None
) -> "Figure":
    """Paper Fig. 3: SDP mass M(ddq) (kg) against acceleration ddq (m/s^2), with the IDIM-LS constant.

    Red crosses: the SDP estimate along the sorted acceleration, with a
    shaded `band` x standard-error band; blue line: the IDIM-LS mass (from an
    `IDIMResult` with a parameter `M`, with its `band` x standard-deviation
    band, or a number); dashed: the SDP (acceleration-weighted) mass. The y
    range covers the estimate where the acceleration is informative
    (|ddq| above 10 % of its maximum); when the estimate near
    ddq = 0 leaves that range, the region is shaded grey and named in
    the legend. The title states the mass-constancy verdict: the stage's
    flag, or `verdict` (`emps_figures` passes "constancy not established"
    when the flag changes with the decimation, as the findings say).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> study = emps_study(emps_builtin_data(0)[0], check_decimation=False)
        >>> fig = fig_sdp_mass(study.sdp, study.idim)
        >>> fig.axes[0].get_legend() is not None
        True
    """
    _check_stage(stage)
    res = stage.result
    x, m, se = _np(res.x_sorted[0]), _np(res.par_sorted[0]), _np(res.parse_sorted[0])
    ls = _mass_value(idim)
    fig = _figure(figsize=(7.5, 4.5))
    ax = fig.add_subplot()
    # drawn above the IDIM-LS band, edged, so that a narrow band still shows
    ax.fill_between(
        x, m - band * se, m + band * se, label=_band_label(band), zorder=2.5, **{**BAND_STYLE, "alpha": 0.45}
    )
    ax.plot(x, m - band * se, color="tab:red", linewidth=0.5, zorder=2.6)
    ax.plot(x, m + band * se, color="tab:red", linewidth=0.5, zorder=2.6)
    ax.plot(x, m, label="SDP $\\hat M(\\ddot q)$", **{**SDP_STYLE, "markersize": 2.5})
    if ls is not None:
        m_ls, s_ls = ls
        label = f"IDIM-LS $M$ = {m_ls:.2f} kg"
        if s_ls > 0:
            ax.axhspan(m_ls - band * s_ls, m_ls + band * s_ls, color="tab:blue", alpha=0.15, linewidth=0)
            label += f" ($\\pm{band:g}$ s.d. = $\\pm${band * s_ls:.2f} kg)"
        ax.axhline(m_ls, color="tab:blue", linewidth=1.4, label=label)
    ax.axhline(stage.mass, color="k", linestyle="--", linewidth=0.8, label=f"SDP mass (weighted) = {stage.mass:.2f} kg")
    # y range: the estimate where it is informative (|ddq| above 10 % of its
    # range), at least +-2 % of the mass, so a constant curve looks constant.
    ref = ls[0] if ls is not None else stage.mass
    xmax = float(np.max(np.abs(x)))
    informative = np.abs(x) > 0.1 * xmax
    vals = m[informative] if np.any(informative) else m
    half = max(0.02 * abs(ref), 1.2 * np.max(np.abs(vals - ref)))
    lo, hi = ref - half, ref + half
    ax.set_ylim(lo, hi)
    if np.any((m < lo) | (m > hi)):
        ax.axvspan(
            -0.1 * xmax,
            0.1 * xmax,
            label=f"$|\\ddot q|$ < {0.1 * xmax:.2g} m/s$^2$: uninformative, clipped",
            **ZOOM_STYLE,
        )
    ax.set_xlabel("acceleration $\\ddot q$ (m/s$^2$)")
    ax.set_ylabel("mass (kg)")
    if verdict is None:
        verdict = "constant" if stage.mass_constant else "acceleration-dependent"
    ax.set_title(
        f"SDP mass against acceleration: NVR = {stage.nvr_mass:.2g}, {verdict} (threshold {stage.constant_nvr:.0e})"
    )
    ax.legend(loc="best", **LEGEND)
    ax.grid(alpha=0.3)
    return fig


def _linear_friction(th: dict, v):
    return th["Fv"] * v + th["Fc"] * np.sign(v) + th.get("offset", 0.0)


def _friction_axes(ax, v, d, se, model, model_label, band):
    ax.fill_between(v, d - band * se, d + band * se, label=_band_label(band), **BAND_STYLE)
    ax.plot(v, model, label=model_label, **MODEL_STYLE)
    ax.plot(v, d, label="SDP $\\hat d_{fric}(\\dot q)$", **SDP_STYLE)
    ax.set_xlabel("velocity $\\dot q$ (m/s)")
    ax.set_ylabel("friction force (N)")
    ax.grid(alpha=0.3)


@x64
def fig_friction_linear(
    stage: EMPSSDPStage, idim: IDIMResult, *, zoom: tuple[float, float] | None = None, band: float = 2.0
) -> "Figure":
    """Paper Fig. 4: SDP friction (N) against the linear friction model of IDIM-LS.

    Upper panel: d_fric(dq) (red crosses, shaded `band` x s.e.)
    and Fv dq + Fc sign(dq) + offset (blue dots)
    over the whole velocity range, the zoomed range shaded grey. Lower panel:
    enlargement of the negative velocities (`zoom` = (v_min, v_max), default
    the negative velocities away from the Coulomb step), where the asymmetry
    shows as a persistent gap between the two.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> study = emps_study(emps_builtin_data(0)[0], check_decimation=False)
        >>> fig = fig_friction_linear(study.sdp, study.idim)
        >>> len(fig.axes)
        2
    """
    _check_stage(stage)
    th = _theta(idim)
    missing = [k for k in ("Fv", "Fc") if k not in th]
    if missing:
        raise ValueError(f"`idim` must be the linear friction model (M, Fv, Fc[, offset]); missing {missing}")
    res = stage.result
    v, d, se = _np(res.x_sorted[1]), _np(res.par_sorted[1]), _np(res.parse_sorted[1])
    lin = _linear_friction(th, v)
    fig = _figure(figsize=(7.5, 7.0))
    ax1, ax2 = fig.subplots(2, 1, gridspec_kw=dict(height_ratios=[1.2, 1.0]))
    label = (
        f"IDIM-LS linear: $F_v$ = {th['Fv']:.1f} {_NPMS},\n"
        f"$F_c$ = {th['Fc']:.2f} N, offset = {th.get('offset', 0.0):.2f} N"
    )
    _friction_axes(ax1, v, d, se, lin, label, band)
    ax1.set_title(f"Friction: SDP (NVR = {stage.nvr_friction:.2g}) vs linear model")
    if zoom is None:
        vmin = float(v.min())
        zoom = (vmin, 0.1 * vmin) if vmin < 0 else (float(v.min()), float(v.max()))
    lo, hi = zoom
    sel = (v >= lo) & (v <= hi)
    ax1.axvspan(lo, hi, label="zoomed range (lower panel)", **ZOOM_STYLE)
    ax1.legend(loc="upper left", **LEGEND)
    if np.any(sel):
        _friction_axes(ax2, v[sel], d[sel], se[sel], lin[sel], "IDIM-LS linear", band)
        both = np.concatenate([d[sel], lin[sel]])
        pad = 0.08 * (both.max() - both.min() + 1e-12)
        ax2.set_ylim(both.min() - pad, both.max() + pad)
        if np.sum(sel) > 2 and np.ptp(v[sel]) > 0:
            slope = float(np.polyfit(v[sel], d[sel], 1)[0])
            ax2.set_title(
                f"Zoom on {lo:.3g} .. {hi:.3g} m/s: SDP slope {slope:.1f} vs linear $F_v$ = {th['Fv']:.1f} {_NPMS}",
                fontsize=10,
            )
    ax2.set_xlim(lo, hi)
    ax2.set_xlabel("velocity $\\dot q$ (m/s)")
    ax2.set_ylabel("friction force (N)")
    return fig


def _sym_limit(*arrays, pad: float = 0.08) -> float:
    """Half-range of a symmetric y axis that shows every finite value."""
    vals = np.concatenate([np.abs(a[np.isfinite(a)]) for a in arrays])
    top = float(vals.max()) if vals.size else 0.0
    return (1 + pad) * top if top > 0 else 1.0


def _nice_ticks(lo: float, hi: float, n: int = 5) -> np.ndarray:
    raw = (hi - lo) / n
    mag = 10 ** np.floor(np.log10(raw))
    step = mag * min(m for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    return np.arange(np.ceil(lo / step), np.floor(hi / step) + 1) * step


def _residual_axis(ax, diffs, ylabel: str, *, outlier_ratio: float = 4.0) -> None:
    """Symmetric y range showing every finite value of `diffs`. When a few
    values (the Coulomb step, smoothed by the decimation filter, next to
    0 m/s) exceed `outlier_ratio` x the bulk range (1.3 x the 98th
    percentile of |diff|), the axis is linear within the bulk range and
    logarithmic beyond it (symlog), so the bulk stays legible."""
    lim = _sym_limit(*diffs)
    vals = np.concatenate([np.abs(a[np.isfinite(a)]) for a in diffs])
    bulk = 1.3 * float(np.percentile(vals, 98)) if vals.size else 0.0
    if bulk > 0 and lim > outlier_ratio * bulk:
        decades = np.log10(lim / bulk)
        # the linear part takes about 60 % of the height
        ax.set_yscale("symlog", linthresh=bulk, linscale=1.3 * decades, base=10)
        ax.set_ylim(-lim, lim)
        inner = _nice_ticks(-bulk, bulk, 5)
        outer = []
        for k in range(int(np.floor(np.log10(bulk))), int(np.ceil(np.log10(lim))) + 1):
            # decades only: on the log part 1-2-5 ticks crowd together (5 beside 20)
            if 2.0 * (outer[-1] if outer else bulk) <= 10.0**k <= lim:
                outer.append(10.0**k)
        if not outer and 0.9 * lim >= 1.5 * bulk:  # no decade in the log part: label its end
            outer.append(float(f"{0.9 * lim:.2g}"))
        ticks = np.concatenate([-np.array(outer[::-1]), inner, np.array(outer)]) + 0.0  # no "-0"
        ax.set_yticks(ticks, labels=[f"{v:g}".replace("-", "\N{MINUS SIGN}") for v in ticks])
        ax.set_yticks([], minor=True)
        for y, label in ((-bulk, None), (bulk, f"$\\pm${bulk:.2g} N: linear scale within, log beyond")):
            ax.axhline(y, color="0.5", linewidth=0.7, linestyle=":", label=label)
    else:
        ax.set_ylim(-lim, lim)
    ax.set_ylabel(ylabel)


@x64
def fig_friction_asym(
    stage: EMPSSDPStage, idim_sdp: EMPSIDIMSDP, *, idim: IDIMResult | None = None, band: float = 2.0
) -> "Figure":
    """Paper Fig. 5: SDP friction (N) against the asymmetric model of eq. (17).

    Upper panel: d_fric(dq) (red crosses, shaded `band` x s.e.)
    and the IDIM-SDP asymmetric model fitted to it (blue dots). Lower panel:
    the SDP curve minus each parametric model (the asymmetric one, and the
    linear IDIM-LS model if `idim` is given), showing what the asymmetric
    model explains; its y range shows every difference (symmetric about 0).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> study = emps_study(emps_builtin_data(0)[0], check_decimation=False)
        >>> fig = fig_friction_asym(study.sdp, study.idim_sdp, idim=study.idim)
        >>> len(fig.axes)
        2
    """
    _check_stage(stage)
    if not isinstance(idim_sdp, EMPSIDIMSDP):
        raise ValueError(f"`idim_sdp` must be an EMPSIDIMSDP (from emps_idim_sdp); got {type(idim_sdp).__name__}")
    res = stage.result
    v, d, se = _np(res.x_sorted[1]), _np(res.par_sorted[1]), _np(res.parse_sorted[1])
    th = idim_sdp.theta
    asym = _np(asym_friction([th["Fv_pos"], th["Fc_pos"], th["Fv_neg"], th["Fc_neg"]], v))
    fig = _figure(figsize=(7.5, 7.0))
    ax1, ax2 = fig.subplots(2, 1, gridspec_kw=dict(height_ratios=[1.2, 1.0]))
    ax2.sharex(ax1)
    label = (
        f"IDIM-SDP asymmetric: $F_v^+$ = {th['Fv_pos']:.1f} {_NPMS}, $F_c^+$ = {th['Fc_pos']:.2f} N,\n"
        f"$F_v^-$ = {th['Fv_neg']:.1f} {_NPMS}, $F_c^-$ = {th['Fc_neg']:.2f} N"
    )
    _friction_axes(ax1, v, d, se, asym, label, band)
    ratio = th["Fv_neg"] / th["Fv_pos"]  # the legend's model's own ratio (IDIM-SDP)
    ax1.set_title(f"Friction: SDP vs asymmetric model (IDIM-SDP $F_v^-/F_v^+$ = {ratio:.2f})")
    ax1.legend(loc="upper left", **LEGEND)
    ax2.axhline(0.0, color="k", linewidth=0.6)
    diffs = [d - asym]
    if idim is not None:
        lin = _linear_friction(_theta(idim), v)
        diffs.append(d - lin)
        ax2.plot(
            v,
            d - lin,
            color="0.55",
            marker=".",
            linestyle="none",
            markersize=2.5,
            label=f"SDP - linear (rms {np.sqrt(np.mean((d - lin) ** 2)):.2f} N)",
        )
    ax2.plot(
        v,
        d - asym,
        color="tab:blue",
        marker=".",
        linestyle="none",
        markersize=2.5,
        label=f"SDP - asymmetric (rms {np.sqrt(np.mean((d - asym) ** 2)):.2f} N)",
    )
    _residual_axis(ax2, diffs, "SDP - model (N)")
    ax2.set_xlabel("velocity $\\dot q$ (m/s)")
    ax2.legend(loc="best", **LEGEND)
    ax2.grid(alpha=0.3)
    return fig


def _reversal_window(t, dq, *, width: float = 0.6, before: float = 0.2) -> tuple[float, float]:
    """A `width` s time window starting `before` s ahead of a direction
    reversal (sign change of `dq` between speeds above 20 % of its maximum),
    the reversal nearest the middle of the record; the middle of the record
    when there is none."""
    t, dq = _np(t), _np(dq)
    width = min(width, float(t[-1] - t[0]))
    fast = np.abs(dq) > 0.2 * np.max(np.abs(dq))
    idx = np.flatnonzero(fast)
    sgn = np.sign(dq[idx])
    # last fast sample before the sign change, first after: the reversal between them
    flips = np.flatnonzero(sgn[1:] != sgn[:-1])
    centre = 0.5 * (t[0] + t[-1])
    starts = [0.5 * (t[idx[k]] + t[idx[k + 1]]) - before for k in flips]
    starts = [s for s in starts if s >= t[0] and s + width <= t[-1]]
    if starts:
        start = min(starts, key=lambda s: abs(s + before - centre))
    else:
        start = centre - 0.5 * width
    return float(start), float(start + width)


@x64
def fig_force_reconstruction(
    stage: EMPSSDPStage,
    idim: IDIMResult | None = None,
    idim_asym: IDIMResult | None = None,
    *,
    bins: int = 60,
    zoom: tuple[float, float] | None = None,
) -> "Figure":
    r"""Measured force (N) against its reconstructions, with the residual histograms.

    (a) the measured (decimated) force and the SDP reconstruction
    M(ddq) ddq + d_fric(dq) over the record; (b) an
    enlargement of the time window `zoom` = (t_start, t_end) (s; default
    0.6 s around the direction reversal nearest the middle of the record,
    shaded in (a) and (c)) with every model; (c) the residuals over time;
    (d) histograms of the residuals of the SDP model and of the IDIM-LS
    models given (`idim`, `idim_asym`: their `fit` is on the
    parallel-decimated samples, the same force samples), with the relative
    errors $100 \|e\| / \|y\|$ (%).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> study = emps_study(emps_builtin_data(0)[0], check_decimation=False)
        >>> fig = fig_force_reconstruction(study.sdp, study.idim, study.idim_asym)
        >>> len(fig.axes)
        4
    """
    _check_stage(stage)
    y = _np(stage.y)
    n = y.shape[0]
    t = np.arange(n) * stage.dt
    models = [("SDP", _np(stage.result.fit), "tab:red", "--")]
    for name, r, c, ls in (
        ("IDIM-LS linear", idim, "tab:blue", ":"),
        ("IDIM-LS asymmetric", idim_asym, "tab:green", "-."),
    ):
        if r is not None:
            if r.fit.shape != (n,):
                raise ValueError(f"`{name}` result has {r.fit.shape[0]} samples; the SDP data have {n}")
            models.append((name, _np(r.fit), c, ls))
    lo, hi = _reversal_window(t, stage.dq) if zoom is None else (float(zoom[0]), float(zoom[1]))
    if not hi > lo:
        raise ValueError(f"`zoom` must be (t_start, t_end) with t_end > t_start; got {zoom}")
    fig = _figure(figsize=(7.5, 10.0))
    ax1, ax2, ax3, ax4 = fig.subplots(4, 1, gridspec_kw=dict(height_ratios=[1.1, 1.1, 0.9, 1.0]))
    ax3.sharex(ax1)
    # the two lie on each other: the measurement wide and light, the reconstruction thin and dark on top
    ax1.plot(t, y, color="0.6", linewidth=2.6, label="measured force")
    ax1.plot(t, models[0][1], color="darkred", linewidth=0.7, label="SDP reconstruction")
    ax1.axvspan(lo, hi, label="window of (b)", **ZOOM_STYLE)
    ax1.set_xlim(t[0], t[-1])
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("force (N)")
    _panel(ax1, "(a) Force over the record", dict(ncol=3))
    sel = (t >= lo) & (t <= hi)
    ax2.plot(t[sel], y[sel], color="k", linewidth=1.8, marker=".", markersize=4, label="measured")
    for k, (name, fit, c, ls) in enumerate(models):
        ax2.plot(t[sel], fit[sel], color=c, linewidth=1.2, linestyle=ls, zorder=3 - 0.1 * k, label=name)
    ax2.set_xlim(lo, hi)
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("force (N)")
    _panel(ax2, "(b) Direction reversal", dict(ncol=len(models) + 1))
    resid = {}
    for k, (name, fit, c, _) in enumerate(models):
        e = y - fit
        resid[name] = e
        rel = 100 * np.linalg.norm(e) / np.linalg.norm(y)
        # the smallest residual (the SDP's) on top, where the larger ones would hide it
        ax3.plot(t, e, color=c, linewidth=0.6, alpha=0.85, zorder=3 - rel / 100, label=f"{name} ({rel:.2f} %)")
    ax3.axvspan(lo, hi, **ZOOM_STYLE)
    ax3.set_xlabel("time (s)")
    ax3.set_ylabel("residual (N)")
    _panel(ax3, "(c) Residuals", dict(ncol=len(models)))
    allres = np.concatenate(list(resid.values()))
    lim = np.percentile(np.abs(allres), 99.5)
    edges = np.linspace(-lim, lim, bins + 1)
    for name, fit, c, _ in models:
        e = resid[name]
        rel = 100 * np.linalg.norm(e) / np.linalg.norm(y)
        ax4.hist(e, bins=edges, color=c, alpha=0.45, label=f"{name}: std {np.std(e):.2f} N, rel. error {rel:.2f} %")
    ax4.set_xlabel("residual (N); range: 99.5 % of all residuals")
    ax4.set_ylabel("count")
    _panel(ax4, "(d) Residual distribution")
    ax4.legend(loc="upper left", **LEGEND)
    return fig


#: File stems of `emps_figures` / `save_emps_figures`.
FIGURE_NAMES = ("fig3_sdp_mass", "fig4_friction_linear", "fig5_friction_asym", "force_reconstruction")


def _mass_verdict(study: Study) -> str | None:
    """Fig. 3's verdict when the mass-constancy flag changes with the decimation (the findings' "NOT established
    robustly"); None: the stage's own flag."""
    flags = {v["mass_constant"] for v in (study.mass_check or {}).values() if "mass_constant" in v}
    return "constancy not established (the flag changes with the decimation)" if len(flags) > 1 else None


@x64
def emps_figures(study: Study) -> dict[str, "Figure"]:
    """All figures of an `EMPSStudy`, keyed by `FIGURE_NAMES`: Figs. 3-5 and the force reconstruction.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> study = emps_study(emps_builtin_data(0)[0], check_decimation=False)
        >>> sorted(emps_figures(study))
        ['fig3_sdp_mass', 'fig4_friction_linear', 'fig5_friction_asym', 'force_reconstruction']
    """
    check_study(study, "EMPSStudy", "emps_study", argument="study")  # by name: its module imports this one
    return {
        "fig3_sdp_mass": fig_sdp_mass(study.sdp, study.idim, verdict=_mass_verdict(study)),
        "fig4_friction_linear": fig_friction_linear(study.sdp, study.idim),
        "fig5_friction_asym": fig_friction_asym(study.sdp, study.idim_sdp, idim=study.idim),
        "force_reconstruction": fig_force_reconstruction(study.sdp, study.idim, study.idim_asym),
    }


@x64
def save_emps_figures(
    study: Study, out: str | os.PathLike, *, fmt: str = "png", dpi: float = 150
) -> dict[str, pathlib.Path]:
    """Write the figures of `emps_figures(study)` in the directory `out` (must
    exist) as `<name>.<fmt>`; returns name -> path.

    `fmt`: one of `FIGURE_FORMATS` ("png", "pdf", "svg"); `dpi`: resolution
    (dots per inch, > 0) of raster output (the PNG pixel size; PDF and SVG
    are vector graphics).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_study
        >>> study = emps_study(emps_builtin_data(0)[0], check_decimation=False)
        >>> import tempfile
        >>> paths = save_emps_figures(study, tempfile.mkdtemp(), fmt="svg")
        >>> paths["fig3_sdp_mass"].suffix
        '.svg'
    """
    path_out = figure_output(fmt, dpi, out)
    check_study(study, "EMPSStudy", "emps_study", argument="study")  # by name: its module imports this one
    paths = {}
    for name, fig in emps_figures(study).items():
        path = path_out / f"{name}.{fmt}"
        fig.savefig(path, format=fmt, dpi=float(dpi))
        paths[name] = path
    return paths
