"""Figures of the TX40 study (paper section 3: Figs. 7-11, and the residual autocorrelation).

Every function takes a `TX40Study` (from `tx40_study`) and returns a
`matplotlib.figure.Figure` built with the object-oriented API (no `pyplot`,
no global state), so it works in notebooks, scripts and the CLI with any
backend, including Agg; `save_tx40_figures` writes them all as PNG, PDF or
SVG. The same functions draw Figs. 7-9 (only link 2 moving) and Figs. 10-11
(all links moving): the figure depends on the data, not on the function.

Colours follow the paper: SDP estimates as red crosses with a pink
+-2 s.e. band, the IDIM-LS model in blue, the parametric projection of the
SDP curves (the IDIM-SDP estimates) as black dashes. Units: joint angle q
in rad, velocity dq in rad/s, torque in N m, time in s.

**Offsets.** Only the sum of the two SDP curves' constants is identified
(the paper's offset2, split by the back-fitting between the curves), so the
shape figure draws every curve *without its constant*: the SDP curve minus
the offset of its own least-squares projection (`study.sdp.gravity` or
`study.sdp.friction`), the projection without that offset, and the IDIM-LS
effects -g MX cos q + g MY sin q and Fv dq + Fc sign(dq) without offset2.
The curves then show the gravity and friction torques of eqs. (20)-(21),
on the same footing; the offsets left out are stated in the figure's title.
"""

import math
import numbers
import os
import pathlib
from typing import TYPE_CHECKING, Literal

import numpy as np

from ..._runtime import x64
from ...plants.robot._joint_model import GRAVITY
from .._contract import Study, check_study
from .._figure_style import LEGEND, SDP_STYLE, as_float, figure_output, new_figure, panel
from ._figures_full import fig_full_model

if TYPE_CHECKING:  # annotations only: `TX40Study.figures()` calls this module
    from matplotlib.figure import Figure


#: File stems of `tx40_figures` / `save_tx40_figures`, in order.
FIGURE_NAMES = ("fig7_shapes", "fig8_sdp_reconstruction", "fig9_idim_ls_reconstruction", "fig_autocorrelation")
#: The further figure of a study with the full model (`fig_full_model`).
FULL_FIGURE = "fig_full_model"

BAND_STYLE = dict(color="tab:red", alpha=0.18, linewidth=0)
IDIM_STYLE = dict(color="tab:blue", linewidth=1.8, zorder=3)
PROJECTION_STYLE = dict(color="k", linewidth=1.2, linestyle="--", zorder=4)
CURVE_STYLE = {**SDP_STYLE, "markersize": 2.5, "markeredgewidth": 0.6}
_MODELS = {"sdp": ("multi-SDP", "tab:red"), "idim_ls": ("IDIM-LS", "tab:blue")}


def _grid(lo: float, hi: float, n: int = 400) -> np.ndarray:
    """`n` points per side over [lo, hi], split at 0 by a NaN so a Coulomb step is drawn as a jump."""
    eps = 1e-9 * max(hi - lo, 1e-12)
    parts = []
    if lo < 0:
        parts.append(np.linspace(lo, min(hi, -eps), n))
    if hi > 0:
        parts.append(np.linspace(max(lo, eps), hi, n))
    if len(parts) == 2:
        parts.insert(1, [np.nan])
    return np.concatenate(parts) if parts else np.array([lo, hi], dtype=float)


def _shape_panel(ax, x, d, se, curves, band: float, label: str, ylabel: str) -> None:
    """SDP curve (crosses) with its band, then the parametric `curves` ((x, y, label, style), ...)."""
    ax.fill_between(x, d - band * se, d + band * se, label=f"SDP $\\pm{band:g}$ s.e.", **BAND_STYLE)
    ax.plot(x, d, label=label, **CURVE_STYLE)
    for xx, yy, lab, style in curves:
        ax.plot(xx, yy, label=lab, **style)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)


@x64
def fig_shapes(study: Study, *, band: float = 2.0) -> "Figure":
    """Paper Figs. 7 and 10: the SDP friction and gravity curves against the IDIM-LS effects (N m).

    (a) Friction against the joint velocity dq (rad/s): the SDP curve
    d_dq(dq) along the sorted velocity (red crosses, `study.sdp.result`
    `x_sorted[1]`, `d_sorted[1]`) with its `band` x standard-error band,
    the IDIM-LS friction effect Fv dq + Fc sign(dq) (blue) and the
    projection of the SDP curve on `[dq, sign dq, 1]` (black dashes; its
    Fv, Fc are the paper's IDIM-SDP estimates).

    (b) Gravity against the joint angle q (rad): the SDP curve d_q(q)
    (`x_sorted[0]`, `d_sorted[0]`), the IDIM-LS gravity effect
    -g MX cos q + g MY sin q and the projection on `[-g cos q, g sin q, 1]`.

    Every curve is drawn without its constant (see the module's
    *Offsets*): the SDP curve minus its projection's offset, the
    projection and the IDIM-LS effect without theirs; the offsets left out
    are in the title. Where the SDP curve leaves the parametric lines
    (the paper's Fig. 10, all links moving) eq. (20) misses an effect.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, fig_shapes
        >>> fig = fig_shapes(example_study())
        >>> [ax.get_ylabel() for ax in fig.axes]
        ['friction torque (N m)', 'gravity torque (N m)']
    """
    check_study(study, "TX40Study", "tx40_study", argument="study")
    if not (isinstance(band, numbers.Real) and math.isfinite(band) and band >= 0):
        raise ValueError(f"`band` must be a finite number >= 0 (standard errors); got {band!r}")
    n, res, s = study.names(), study.sdp.result, study.sdp
    ls = study.idim.result
    xs, ds, ses = as_float(res.x_sorted), as_float(res.d_sorted), as_float(res.dse_sorted)
    fric, grav = s.friction, s.gravity
    fv, fc, mx, my = (float(ls[n[k]]) for k in ("Fv", "Fc", "MX", "MY"))
    pfv, pfc, pmx, pmy = float(fric[n["Fv"]]), float(fric[n["Fc"]]), float(grav[n["MX"]]), float(grav[n["MY"]])
    g = GRAVITY

    fig = new_figure(figsize=(11.0, 4.8))
    ax1, ax2 = fig.subplots(1, 2)
    v = _grid(float(xs[1].min()), float(xs[1].max()))
    _shape_panel(
        ax1,
        xs[1],
        ds[1] - float(fric["offset"]),
        ses[1],
        (
            (v, fv * v + fc * np.sign(v), f"IDIM-LS: $F_v$ = {fv:.2f} N m s/rad, $F_c$ = {fc:.2f} N m", IDIM_STYLE),
            (
                v,
                pfv * v + pfc * np.sign(v),
                f"projection: $F_v$ = {pfv:.2f} N m s/rad, $F_c$ = {pfc:.2f} N m",
                PROJECTION_STYLE,
            ),
        ),
        band,
        f"SDP friction curve $\\hat f(\\dot q)$ (NVR = {float(res.nvr[1]):.2g})",
        "friction torque (N m)",
    )
    ax1.axhline(0.0, color="k", linewidth=0.5)
    ax1.axvline(0.0, color="k", linewidth=0.5)
    ax1.set_xlabel("joint velocity $\\dot q$ (rad/s)")
    panel(ax1, f"(a) Friction of joint {study.joint}")
    ax1.legend(loc="upper left", **LEGEND)

    q = np.linspace(float(xs[0].min()), float(xs[0].max()), 400)
    _shape_panel(
        ax2,
        xs[0],
        ds[0] - float(grav["offset"]),
        ses[0],
        (
            (
                q,
                -g * mx * np.cos(q) + g * my * np.sin(q),
                f"IDIM-LS: MX = {mx:.3g} kg m, MY = {my:.3g} kg m",
                IDIM_STYLE,
            ),
            (
                q,
                -g * pmx * np.cos(q) + g * pmy * np.sin(q),
                f"projection: MX = {pmx:.3g} kg m, MY = {pmy:.3g} kg m",
                PROJECTION_STYLE,
            ),
        ),
        band,
        f"SDP gravity curve $\\hat g(q)$ (NVR = {float(res.nvr[0]):.2g})",
        "gravity torque (N m)",
    )
    ax2.set_xlabel("joint angle $q$ (rad)")
    panel(ax2, f"(b) Gravity of joint {study.joint}")
    ax2.legend(loc="best", **LEGEND)
    og, of = float(grav["offset"]), float(fric["offset"])
    fig.suptitle(
        f"SDP curves vs IDIM-LS effects, offsets removed (IDIM-LS {n['offset']} = {float(ls[n['offset']]):.3g} N m; "
        f"SDP projections {og:.3g} {'-' if of < 0 else '+'} {abs(of):.3g} = {s.offset_sum:.3g} N m)",
        fontsize=10,
    )
    return fig


def _with_gaps(idx: np.ndarray, *arrays):
    """`arrays` with a NaN inserted wherever the sample index `idx` jumps (samples at rest left out)."""
    cut = np.flatnonzero(np.diff(idx) > 1) + 1
    return [np.insert(np.asarray(a, dtype=float), cut, np.nan) for a in arrays]


@x64
def fig_reconstruction(study: Study, *, model: Literal["sdp", "idim_ls"] = "sdp", bins: int = 50) -> "Figure":
    r"""Paper Figs. 8, 9 and 11: measured against reconstructed joint torque (N m), and the normalised residual.

    (a) The measured torque and the reconstruction of `model` over the
    whole decimated record (s), samples at rest included, as the paper
    plots them (with a multi-SDP fitted on the samples in motion only,
    `fit_on="moving"`, those samples, the rest left out as gaps):

    - "sdp" (Figs. 8, 11): ZZ ddq + d_q(q) + d_dq(dq), `study.sdp.result.fit`;
    - "idim_ls" (Fig. 9): eq. (22) with the IDIM-LS estimates (`JointIDIM.record_fit`:
      at rest the Coulomb term is off, sign(dq) being the sign of noise there).

    (b) The histogram (`bins`, probability density) of the residual
    divided by its standard deviation, with the standard normal density.
    The title gives the relative error $100 \|y - fit\| / \|y\|$ (%) over
    those samples and over the samples in motion.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, fig_reconstruction
        >>> fig = fig_reconstruction(example_study(), model="idim_ls")
        >>> [ax.get_ylabel() for ax in fig.axes]
        ['joint torque (N m)', 'probability density']
    """
    check_study(study, "TX40Study", "tx40_study", argument="study")
    if model not in _MODELS:
        raise ValueError(f"`model` must be one of {tuple(_MODELS)}; got {model!r}")
    if isinstance(bins, bool) or not isinstance(bins, numbers.Integral) or bins < 1:
        raise ValueError(f"`bins` must be a positive integer; got {bins!r}")
    name, colour = _MODELS[model]
    idx, y, fits = _record(study)
    fit = fits[model]
    moving = np.asarray(study.sdp.moving, bool)
    rel = 100.0 * float(np.linalg.norm(y - fit) / np.linalg.norm(y))
    rel_moving = 100.0 * float(np.linalg.norm((y - fit)[moving]) / np.linalg.norm(y[moving]))
    t = idx * float(study.inputs.dt)
    e = y - fit
    sd = float(np.std(e))
    whole = idx.size == study.inputs.y.shape[0]

    fig = new_figure(figsize=(11.0, 4.6))
    ax1, ax2 = fig.subplots(1, 2, gridspec_kw=dict(width_ratios=[2.0, 1.0]))
    tt, yy, ff = _with_gaps(idx, t, y, fit)
    ax1.plot(tt, yy, color="0.5", linewidth=0.8, label="measured")
    ax1.plot(tt, ff, color=colour, linewidth=1.0, label=f"{name} reconstruction")
    ax1.set_xlim(float(t[0]), float(t[-1]))
    ax1.set_xlabel("time (s)" if whole else "time (s); gaps: the joint at rest, samples left out of the fits")
    ax1.set_ylabel("joint torque (N m)")
    what = "whole record" if whole else "samples in motion"
    panel(ax1, f"(a) Joint {study.joint} torque, {what} ({y.size} samples)", dict(ncol=2))

    z = e / sd if sd > 0 else e
    lim = _histogram_limit(study, y)  # one range for both models, so that Figs. 8 and 9 compare by eye
    ax2.hist(z, bins=np.linspace(-lim, lim, bins + 1), density=True, color=colour, alpha=0.5, label="residual")
    u = np.linspace(-lim, lim, 400)
    ax2.plot(u, np.exp(-0.5 * u**2) / math.sqrt(2 * math.pi), color="k", linewidth=1.2, label="N(0, 1)")
    ax2.set_xlim(-lim, lim)
    ax2.set_xlabel(f"residual / its std ({sd:.3g} N m)")
    ax2.set_ylabel("probability density")
    panel(ax2, "(b) Normalised residual")
    ax2.legend(loc="upper right", **LEGEND)
    fig.suptitle(
        f"{name} model of joint {study.joint}: relative error {rel:.2f} % ({what}), {rel_moving:.2f} % in motion",
        fontsize=11,
    )
    return fig


def _record(study: Study):
    """(sample indices, measured torque, {"sdp": fit, "idim_ls": fit}) on the samples the multi-SDP fitted."""
    s, i = study.sdp, study.idim
    y = as_float(s.y)
    if s.fit_on == "all":
        idx = np.arange(y.size)
        ls_fit = as_float(i.record_fit)
    else:
        idx = np.flatnonzero(np.asarray(i.moving))
        ls_fit = as_float(i.result.fit)
    fits = {"sdp": as_float(s.result.fit), "idim_ls": ls_fit}
    if not (idx.size == y.size == fits["sdp"].size == ls_fit.size):
        raise ValueError(f"the study's samples disagree: {idx.size} indices, {y.size} measured")
    return idx, y, fits


def _histogram_limit(study: Study, y: np.ndarray) -> float:
    """The half-width of the normalised-residual histograms: at least 4, covering both models' residuals."""
    lim = 4.0
    for fit in _record(study)[2].values():
        e = y - as_float(fit)
        sd = float(np.std(e))
        if e.size and sd > 0:
            lim = max(lim, float(np.ceil(np.max(np.abs(e / sd)))))
    return lim


def _p_text(p) -> str:
    p = float(p)
    return f"p = {p:.2g}" if p >= 1e-4 else "p < 0.0001"


def _stems(ax, w, shift: float, colour: str, label: str) -> None:
    lags = as_float(w.lags) + shift
    acf = as_float(w.acf)
    ax.vlines(lags, 0.0, acf, color=colour, linewidth=1.2)
    ax.plot(lags, acf, color=colour, marker="o", markersize=4, linestyle="none", label=label)


@x64
def fig_autocorrelation(study: Study) -> "Figure":
    """The residual autocorrelation of IDIM-LS and of the multi-SDP against its null (the paper's whiteness remarks).

    Stems: the autocorrelation r_k of each residual at lags k = 1..L
    (`study.idim.whiteness`, `study.sdp.whiteness`: IDIM-LS blue, shifted
    left, SDP red, shifted right). Black line: the null, the
    autocorrelation of white noise after the decimation filter (the
    residuals live at the decimated rate, so even a white torque noise is
    correlated at small lags); grey: its band at the test's level. The
    legend gives each residual's Ljung-Box Q, p-value and lags outside the
    band, the title the p-values: p below the level (0.05) means more serial
    correlation than the null (the paper's Figs. 9 and 11, all links moving).

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, fig_autocorrelation
        >>> fig = fig_autocorrelation(example_study())
        >>> fig.axes[0].get_xlabel()
        'lag (samples of 2 ms)'
    """
    check_study(study, "TX40Study", "tx40_study", argument="study")
    wi, ws = study.idim.whiteness, study.sdp.whiteness
    fig = new_figure(figsize=(8.0, 4.6))
    ax = fig.add_subplot()
    level = f"{100 * (1 - ws.alpha):g} %"
    same = np.allclose(as_float(wi.null), as_float(ws.null)) and np.allclose(as_float(wi.band), as_float(ws.band))
    for w in (ws,) if same else (ws, wi):  # one band when both residuals have the same length and decimation
        lags, null, half = as_float(w.lags), as_float(w.null), as_float(w.band)
        label = f"null $\\pm$ {level} band" if w is ws else None
        ax.fill_between(lags, null - half, null + half, color="0.8", alpha=0.7, linewidth=0, label=label)
    filtered = bool(np.any(as_float(ws.null) != 0))
    null_label = "null: white noise through the decimation filter" if filtered else "null: white noise"
    ax.plot(as_float(ws.lags), as_float(ws.null), color="k", linewidth=1.0, label=null_label)
    ax.axhline(0.0, color="k", linewidth=0.5)
    L = int(np.shape(ws.lags)[0])
    for w, shift, colour, name in ((wi, -0.15, "tab:blue", "IDIM-LS"), (ws, 0.15, "tab:red", "multi-SDP")):
        label = f"{name} residual: Q({L}) = {float(w.q):.1f}, {_p_text(w.p_value)}, {int(w.outside)}/{L} lags outside"
        _stems(ax, w, shift, colour, label)
    top = int(np.max(as_float(ws.lags)))
    ax.set_xlim(0.3, top + 0.7)
    step = max(1, top // 10)
    ax.set_xticks(np.arange(step, top + 1, step))
    dt_ms = 1e3 * float(study.inputs.dt)
    ax.set_xlabel(f"lag (samples of {dt_ms:.3g} ms)")
    ax.set_ylabel("autocorrelation")
    ax.grid(alpha=0.3)
    fig.legend(loc="outside lower center", ncol=2, **LEGEND)
    ax.set_title(
        f"Residual autocorrelation of joint {study.joint}, Ljung-Box: {_p_text(wi.p_value)} (IDIM-LS), "
        f"{_p_text(ws.p_value)} (multi-SDP)",
        loc="left",
        fontsize=10,
    )
    return fig


_BUILDERS = {
    "fig7_shapes": fig_shapes,
    "fig8_sdp_reconstruction": lambda study: fig_reconstruction(study, model="sdp"),
    "fig9_idim_ls_reconstruction": lambda study: fig_reconstruction(study, model="idim_ls"),
    "fig_autocorrelation": fig_autocorrelation,
    FULL_FIGURE: fig_full_model,
}


@x64
def tx40_figures(study: Study) -> dict[str, "Figure"]:
    """All figures of a `TX40Study`, keyed by `FIGURE_NAMES`: the shapes, both reconstructions, the autocorrelation.

    `fig7_shapes` (`fig_shapes`: the paper's Fig. 7, or Fig. 10 for
    all links moving), `fig8_sdp_reconstruction` (`fig_reconstruction`
    with model "sdp": Fig. 8 or 11), `fig9_idim_ls_reconstruction`
    (model "idim_ls": Fig. 9) and `fig_autocorrelation`; with the full model
    also `fig_full_model` (`_figures_full.fig_full_model`).

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, tx40_figures
        >>> list(tx40_figures(example_study()))
        ['fig7_shapes', 'fig8_sdp_reconstruction', 'fig9_idim_ls_reconstruction', 'fig_autocorrelation']
    """
    check_study(study, "TX40Study", "tx40_study", argument="study")
    return {name: _BUILDERS[name](study) for name in _names(study)}


def _names(study) -> tuple:
    return FIGURE_NAMES if study.full is None else FIGURE_NAMES + (FULL_FIGURE,)


@x64
def save_tx40_figures(
    study: Study, folder: str | os.PathLike, *, fmt: str = "png", dpi: float = 150
) -> list[pathlib.Path]:
    """Write the figures of `tx40_figures(study)` in the directory `folder` (must exist) as `<name>.<fmt>`.

    `fmt`: one of `FIGURE_FORMATS` ("png", "pdf", "svg"); `dpi`: resolution
    (dots per inch, > 0) of raster output (PDF and SVG are vector
    graphics). The figures are drawn one at a time and cleared once
    written. Returns the paths written, in the order of `FIGURE_NAMES`.

    Example:
        >>> import tempfile
        >>> from jaxsdp.studies.tx40 import example_study, save_tx40_figures
        >>> paths = save_tx40_figures(example_study(), tempfile.mkdtemp(), fmt="svg")
        >>> [p.name for p in paths][:2]
        ['fig7_shapes.svg', 'fig8_sdp_reconstruction.svg']
    """
    path_out = figure_output(fmt, dpi, folder, option="folder")
    check_study(study, "TX40Study", "tx40_study", argument="study")
    paths = []
    for name in _names(study):
        fig = _BUILDERS[name](study)
        path = path_out / f"{name}.{fmt}"
        try:
            fig.savefig(path, format=fmt, dpi=float(dpi))
        finally:
            fig.clear()
        paths.append(path)
    return paths
