"""Figures of the EMPS study (paper Figs. 3-5 and the force reconstruction).

Every function returns a `matplotlib.figure.Figure` built with the
object-oriented API (no `pyplot`, no global state), so it works in notebooks
(the figure displays itself), in scripts and in the CLI
(`fig.savefig("fig3.png")`) with any backend, including Agg.

Colours follow the paper: SDP estimates as red crosses, parametric (IDIM-LS
or IDIM-SDP) models as blue dots.
"""

import os
import pathlib
from typing import TYPE_CHECKING

import numpy as np

from ..._idim.ls import IDIMResult
from ...plants._emps_model import asym_friction
from ._idim_sdp import EMPSIDIMSDP
from ._sdp_stage import EMPSSDPStage
from ._study import EMPSStudy

if TYPE_CHECKING:
    from matplotlib.figure import Figure

SDP_STYLE = dict(color="tab:red", marker="x", linestyle="none", markersize=3.5, markeredgewidth=0.8)
MODEL_STYLE = dict(color="tab:blue", marker=".", linestyle="none", markersize=3.0)
BAND_STYLE = dict(color="tab:red", alpha=0.15, linewidth=0)


def _figure(**kw) -> "Figure":
    # matplotlib is imported on first use: it takes longer to import than the rest of jaxsdp.
    from matplotlib.figure import Figure

    return Figure(layout="constrained", **kw)


def _np(a):
    return np.asarray(a, dtype=float)


def _check_stage(stage):
    if not isinstance(stage, EMPSSDPStage):
        raise ValueError(f"`stage` must be an EMPSSDPStage (from emps_sdp_stage); got {type(stage).__name__}")


def _theta(r: IDIMResult) -> dict:
    return dict(zip(r.names, _np(r.theta)))


def _mass_value(idim) -> float | None:
    if idim is None:
        return None
    if isinstance(idim, IDIMResult):
        th = _theta(idim)
        if "M" not in th:
            raise ValueError(f"`idim` has no parameter 'M'; names {idim.names}")
        return float(th["M"])
    return float(idim)


def fig_sdp_mass(stage: EMPSSDPStage, idim: IDIMResult | float | None = None, *, band: float = 2.0) -> "Figure":
    r"""Paper Fig. 3: SDP mass $\hat M(\ddot q)$ against acceleration, with the IDIM-LS constant.

    Red crosses: the SDP estimate along the sorted acceleration, with a
    shaded `band` x standard-error band; blue: the IDIM-LS mass (from an
    `IDIMResult` with a parameter `M`, or a number); dashed: the SDP
    (acceleration-weighted) mass.
    """
    _check_stage(stage)
    res = stage.result
    x, m, se = _np(res.x_sorted[0]), _np(res.par_sorted[0]), _np(res.parse_sorted[0])
    m_ls = _mass_value(idim)
    fig = _figure(figsize=(7.5, 4.5))
    ax = fig.add_subplot()
    ax.fill_between(x, m - band * se, m + band * se, label=f"SDP $\\pm{band:g}$ s.e.", **BAND_STYLE)
    ax.plot(x, m, label="SDP $\\hat M(\\ddot q)$", **SDP_STYLE)
    if m_ls is not None:
        ax.plot(x, np.full_like(x, m_ls), label=f"IDIM-LS $M$ = {m_ls:.2f} kg", **MODEL_STYLE)
    ax.axhline(stage.mass, color="k", linestyle="--", linewidth=0.8, label=f"SDP mass (weighted) = {stage.mass:.2f} kg")
    # y range: the estimate where it is informative (|ddq| above 10 % of its
    # range), at least +-2 % of the mass, so a constant curve looks constant.
    ref = m_ls if m_ls is not None else stage.mass
    informative = np.abs(x) > 0.1 * np.max(np.abs(x))
    vals = m[informative] if np.any(informative) else m
    half = max(0.02 * abs(ref), 1.2 * np.max(np.abs(vals - ref)))
    ax.set_ylim(ref - half, ref + half)
    ax.set_xlabel("acceleration $\\ddot q$ (m/s$^2$)")
    ax.set_ylabel("mass (kg)")
    flag = "constant" if stage.mass_constant else "state-dependent"
    ax.set_title(f"Acceleration-dependent mass: NVR = {stage.nvr_mass:.2g} ({flag})")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def _linear_friction(th: dict, v):
    return th["Fv"] * v + th["Fc"] * np.sign(v) + th.get("offset", 0.0)


def _friction_axes(ax, v, d, se, model, model_label, band):
    ax.fill_between(v, d - band * se, d + band * se, **BAND_STYLE)
    ax.plot(v, model, label=model_label, **MODEL_STYLE)
    ax.plot(v, d, label="SDP $\\hat d_{fric}(\\dot q)$", **SDP_STYLE)
    ax.grid(alpha=0.3)


def fig_friction_linear(
    stage: EMPSSDPStage, idim: IDIMResult, *, zoom: tuple[float, float] | None = None, band: float = 2.0
) -> "Figure":
    r"""Paper Fig. 4: SDP friction against the linear friction model of IDIM-LS.

    Upper panel: $\hat d_{fric}(\dot q)$ (red crosses, shaded `band` x s.e.)
    and $F_v\dot q + F_c\operatorname{sign}\dot q + \text{offset}$ (blue dots)
    over the whole velocity range. Lower panel: enlargement of the negative
    velocities (`zoom` = (v_min, v_max), default the negative velocities
    away from the Coulomb step), where the asymmetry shows as a persistent
    gap between the two.
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
    label = f"IDIM-LS linear: $F_v$={th['Fv']:.1f}, $F_c$={th['Fc']:.2f}, offset={th.get('offset', 0.0):.2f}"
    _friction_axes(ax1, v, d, se, lin, label, band)
    ax1.set_xlabel("velocity $\\dot q$ (m/s)")
    ax1.set_ylabel("friction force (N)")
    ax1.set_title(f"Friction: SDP (NVR = {stage.nvr_friction:.2g}) vs linear model")
    ax1.legend(loc="upper left", fontsize=8)
    if zoom is None:
        vmin = float(v.min())
        zoom = (vmin, 0.1 * vmin) if vmin < 0 else (float(v.min()), float(v.max()))
    lo, hi = zoom
    sel = (v >= lo) & (v <= hi)
    ax1.axvspan(lo, hi, color="0.85", alpha=0.5, zorder=0)
    if np.any(sel):
        _friction_axes(ax2, v[sel], d[sel], se[sel], lin[sel], "IDIM-LS linear", band)
        both = np.concatenate([d[sel], lin[sel]])
        pad = 0.08 * (both.max() - both.min() + 1e-12)
        ax2.set_ylim(both.min() - pad, both.max() + pad)
        if np.sum(sel) > 2 and np.ptp(v[sel]) > 0:
            slope = float(np.polyfit(v[sel], d[sel], 1)[0])
            ax2.set_title(
                f"Zoom on {lo:.3g}..{hi:.3g} m/s: SDP slope {slope:.1f} vs linear $F_v$ = {th['Fv']:.1f} N/(m/s)",
                fontsize=10,
            )
    ax2.set_xlim(lo, hi)
    ax2.set_xlabel("velocity $\\dot q$ (m/s)")
    ax2.set_ylabel("friction force (N)")
    return fig


def fig_friction_asym(
    stage: EMPSSDPStage, idim_sdp: EMPSIDIMSDP, *, idim: IDIMResult | None = None, band: float = 2.0
) -> "Figure":
    r"""Paper Fig. 5: SDP friction against the asymmetric model of eq. (17).

    Upper panel: $\hat d_{fric}(\dot q)$ (red crosses) and the IDIM-SDP
    asymmetric model fitted to it (blue dots). Lower panel: the SDP curve
    minus each parametric model (the asymmetric one, and the linear IDIM-LS
    model if `idim` is given), showing what the asymmetric model explains.
    """
    _check_stage(stage)
    if not isinstance(idim_sdp, EMPSIDIMSDP):
        raise ValueError(f"`idim_sdp` must be an EMPSIDIMSDP (from emps_idim_sdp); got {type(idim_sdp).__name__}")
    res = stage.result
    v, d, se = _np(res.x_sorted[1]), _np(res.par_sorted[1]), _np(res.parse_sorted[1])
    th = idim_sdp.theta
    asym = _np(asym_friction([th["Fv_pos"], th["Fc_pos"], th["Fv_neg"], th["Fc_neg"]], v))
    fig = _figure(figsize=(7.5, 7.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True, gridspec_kw=dict(height_ratios=[1.2, 1.0]))
    label = (
        f"IDIM-SDP asymmetric: $F_v^+$={th['Fv_pos']:.1f}, $F_c^+$={th['Fc_pos']:.2f}, "
        f"$F_v^-$={th['Fv_neg']:.1f}, $F_c^-$={th['Fc_neg']:.2f}"
    )
    _friction_axes(ax1, v, d, se, asym, label, band)
    ax1.set_ylabel("friction force (N)")
    ax1.set_title(f"Friction: SDP vs asymmetric model ($F_v^-/F_v^+$ = {idim_sdp.fv_ratio:.2f})")
    ax1.legend(loc="upper left", fontsize=8)
    ax2.axhline(0.0, color="k", linewidth=0.6)
    if idim is not None:
        lin = _linear_friction(_theta(idim), v)
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
    # the Coulomb step is smoothed by the decimation filter: clip the y range
    # to the bulk of the differences so the comparison away from 0 is legible
    diffs = [d - asym] + ([d - _linear_friction(_theta(idim), v)] if idim is not None else [])
    lim = 1.3 * max(np.percentile(np.abs(x), 98) for x in diffs)
    ax2.set_ylim(-lim, lim)
    ax2.set_xlabel("velocity $\\dot q$ (m/s)")
    ax2.set_ylabel("SDP - model (N)")
    ax2.legend(loc="upper left", fontsize=8)
    ax2.grid(alpha=0.3)
    return fig


def fig_force_reconstruction(
    stage: EMPSSDPStage,
    idim: IDIMResult | None = None,
    idim_asym: IDIMResult | None = None,
    *,
    bins: int = 60,
) -> "Figure":
    r"""Measured force against its reconstructions, with the residual histograms.

    Top: the measured (decimated) force and the SDP reconstruction
    $\hat M(\ddot q)\ddot q + \hat d_{fric}(\dot q)$ over time; middle left:
    residuals over time; bottom: histogram of the residuals of the SDP model
    and of the IDIM-LS models given (`idim`, `idim_asym`: their `fit` is on
    the parallel-decimated samples, the same force samples), with the
    relative errors $100\|e\|/\|y\|$.
    """
    _check_stage(stage)
    y = _np(stage.y)
    n = y.shape[0]
    t = np.arange(n) * stage.dt
    models = [("SDP", _np(stage.result.fit), "tab:red")]
    for name, r, c in (("IDIM-LS linear", idim, "tab:blue"), ("IDIM-LS asymmetric", idim_asym, "tab:green")):
        if r is not None:
            if r.fit.shape != (n,):
                raise ValueError(f"`{name}` result has {r.fit.shape[0]} samples; the SDP data have {n}")
            models.append((name, _np(r.fit), c))
    fig = _figure(figsize=(9.0, 7.5))
    gs = fig.add_gridspec(3, 1, height_ratios=[1.3, 0.9, 1.0])
    ax1 = fig.add_subplot(gs[0])
    ax2 = fig.add_subplot(gs[1], sharex=ax1)
    ax3 = fig.add_subplot(gs[2])
    ax1.plot(t, y, color="k", linewidth=1.4, label="measured force")
    ax1.plot(t, models[0][1], color="tab:red", linewidth=0.8, linestyle="--", label="SDP reconstruction")
    ax1.set_ylabel("force (N)")
    ax1.set_title("Measured and reconstructed force")
    ax1.legend(loc="upper right", fontsize=8)
    ax1.grid(alpha=0.3)
    resid = {}
    for k, (name, fit, c) in enumerate(models):
        e = y - fit
        resid[name] = e
        rel = 100 * np.linalg.norm(e) / np.linalg.norm(y)
        # SDP (k = 0) drawn on top of the parametric models
        ax2.plot(t, e, color=c, linewidth=0.6, alpha=0.85, zorder=3 - 0.1 * k, label=f"{name} ({rel:.2f} %)")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("residual (N)")
    ax2.legend(loc="upper right", fontsize=7, ncol=len(models))
    ax2.grid(alpha=0.3)
    allres = np.concatenate(list(resid.values()))
    lim = np.percentile(np.abs(allres), 99.5)
    edges = np.linspace(-lim, lim, bins + 1)
    for name, fit, c in models:
        e = resid[name]
        rel = 100 * np.linalg.norm(e) / np.linalg.norm(y)
        ax3.hist(e, bins=edges, color=c, alpha=0.45, label=f"{name}: std {np.std(e):.2f} N, rel. error {rel:.2f} %")
    ax3.set_xlabel("residual (N); range: 99.5 % of all residuals")
    ax3.set_ylabel("count")
    ax3.legend(loc="upper left", fontsize=8)
    ax3.grid(alpha=0.3)
    return fig


#: File stems of `emps_figures` / `save_emps_figures`.
FIGURE_NAMES = ("fig3_sdp_mass", "fig4_friction_linear", "fig5_friction_asym", "force_reconstruction")


def emps_figures(study: EMPSStudy) -> dict[str, "Figure"]:
    """All figures of an `EMPSStudy`, keyed by `FIGURE_NAMES`."""
    if not isinstance(study, EMPSStudy):
        raise ValueError(f"`study` must be an EMPSStudy (from emps_study); got {type(study).__name__}")
    return {
        "fig3_sdp_mass": fig_sdp_mass(study.sdp, study.idim),
        "fig4_friction_linear": fig_friction_linear(study.sdp, study.idim),
        "fig5_friction_asym": fig_friction_asym(study.sdp, study.idim_sdp, idim=study.idim),
        "force_reconstruction": fig_force_reconstruction(study.sdp, study.idim, study.idim_asym),
    }


def save_emps_figures(study: EMPSStudy, out_dir: str | os.PathLike, *, dpi: int = 120) -> dict[str, pathlib.Path]:
    """Write the figures of `emps_figures(study)` as PNGs in `out_dir` (must
    exist); returns name -> path."""
    out = pathlib.Path(out_dir)
    if not out.is_dir():
        raise ValueError(f"`out_dir`: not a directory: {out}")
    paths = {}
    for name, fig in emps_figures(study).items():
        path = out / f"{name}.png"
        fig.savefig(path, dpi=dpi)
        paths[name] = path
    return paths
