"""Figures of the Monte Carlo studies: estimate histograms, step-response envelopes, settling-time scatter."""

import math
import os
import pathlib

import numpy as np

from ..._runtime import x64
from ...plants.emps._model import EMPS_ASYM_NAMES as ASYM
from .._contract import Study
from .._figure_style import LEGEND, figure_output, new_figure, panel
from .._output import fraction_pct
from ._shared import ASYM_NAMES, CONTROLLERS, ENVELOPE_STRIDE, ESTIMATORS, LABELS, Z95

#: Estimators drawn in the histograms (asymmetric model), with their colours.
HIST_ESTIMATORS = {"idim_ls_asym": "tab:blue", "idim_iv": "tab:green", "idim_sdp": "tab:red"}
CONTROLLER_COLOURS = {"linear_pd": "0.5", "sdp_pd": "tab:blue", "pip_sdp": "tab:red"}
UNITS = {"M": "kg", "Fv_pos": "N/(m/s)", "Fc_pos": "N", "Fv_neg": "N/(m/s)", "Fc_neg": "N"}


@x64
def identification_figures(res: Study) -> dict:
    """{"mc_estimates": Figure}: per parameter, histograms of the asymmetric-model estimates (IDIM-LS,
    IDIM-IV, IDIM-SDP) in % of the truth, the truth (0), and the normal law N(mean, mean stated se^2)
    that each estimator's standard errors claim.

    Example:
        >>> from jaxsdp.studies.montecarlo import IdentificationSettings, identification_figures
        >>> from jaxsdp.studies.montecarlo import identification_robustness
        >>> res = identification_robustness(2, settings=IdentificationSettings(iv=False, sdp=False), progress=False)
        >>> list(identification_figures(res))
        ['mc_estimates']
    """
    fig = new_figure(figsize=(11.0, 6.5))
    axes = fig.subplots(2, 3).ravel()
    for j, name in enumerate(ASYM_NAMES):
        ax = axes[j]
        truth = res.truth[:, j]
        for key, colour in HIST_ESTIMATORS.items():
            if key not in res.estimates:
                continue
            th = np.asarray(res.estimates[key]["theta"], float)[:, j]
            se = np.asarray(res.estimates[key]["se"], float)[:, j]
            ok = np.isfinite(th)
            err = 100.0 * (th[ok] - truth[ok]) / truth[ok]
            if err.size == 0:
                continue
            ax.hist(err, bins=30, density=True, alpha=0.45, color=colour, label=ESTIMATORS[key][0].split(" (")[0])
            s = 100.0 * np.nanmean(se[ok] / truth[ok]) if np.any(np.isfinite(se[ok])) else np.nan
            if np.isfinite(s) and s > 0:
                x = np.linspace(err.mean() - 4 * s, err.mean() + 4 * s, 200)
                ax.plot(x, np.exp(-0.5 * ((x - err.mean()) / s) ** 2) / (s * math.sqrt(2 * math.pi)), color=colour)
        ax.axvline(0.0, color="k", linewidth=1.2, label="truth")
        ax.set_xlabel("estimate - truth (% of the truth)")
        ax.set_ylabel("probability density (1/%)")
        ax.set_title(f"{name} ({UNITS[name]})", fontsize=10, loc="left")
        ax.grid(alpha=0.3)
    ax = axes[-1]
    ax.axis("off")
    handles, labels = axes[0].get_legend_handles_labels()
    ax.legend(handles, labels, loc="lower left", bbox_to_anchor=(0.0, 0.0), **LEGEND)
    ax.text(
        0.0,
        0.9,
        "Bars: Monte Carlo estimates.\nCurves: the normal law of the stated\nstandard errors "
        f"(mean +- {Z95:.2f} se is the\nstated 95 % interval).\nAn honest estimator's curve matches\nits bars and "
        "its bars straddle 0.",
        va="top",
        fontsize=9,
    )
    fig.suptitle(f"EMPS identification, {res.runs} Monte Carlo runs", fontsize=11)
    return {"mc_estimates": fig}


@x64
def control_figures(res: Study) -> dict:
    """{"mc_envelope": PIP-SDP step responses (median, 25-75 % and 5-95 % bands, extremes),
    "mc_settling": settling time against each drawn parameter, per controller}.

    Example:
        >>> from jaxsdp.studies.montecarlo import control_figures, control_robustness
        >>> sorted(control_figures(control_robustness(16, progress=False)))
        ['mc_envelope', 'mc_settling']
    """
    s = res.settings
    env = np.asarray(res.envelope, float)
    t = np.arange(env.shape[1]) * s.dt * ENVELOPE_STRIDE
    fig = new_figure(figsize=(8.0, 6.0))
    ax, dev = fig.subplots(2, 1, sharex=True, height_ratios=(2.2, 1.0))
    ok = np.all(np.isfinite(env), axis=1)
    bands = (("all runs", 0, 6, 0.15), ("5-95 %", 1, 5, 0.3), ("25-75 %", 2, 4, 0.5))
    if ok.any():
        p = 1e3 * np.percentile(env[ok], [0, 5, 25, 50, 75, 95, 100], axis=0)  # mm, as the other figures
        for label, lo, hi, alpha in bands:
            ax.fill_between(t, p[lo], p[hi], color="tab:red", alpha=alpha, linewidth=0)
            # the spread is small beside the step: drawn again about the median, in micrometres, where the legend
            # names the bands (in (a) they may be thinner than a line)
            dev.fill_between(
                t, 1e3 * (p[lo] - p[3]), 1e3 * (p[hi] - p[3]), color="tab:red", alpha=alpha, linewidth=0, label=label
            )
        ax.plot(t, p[3], color="darkred", linewidth=1.2, label="median (bands in (b))")
        dev.axhline(0.0, color="darkred", linewidth=1.0, label="median")
        dev.legend(loc="upper right", ncols=2, **LEGEND)
    ax.axhline(1e3 * s.step, color="k", linestyle="--", linewidth=0.8, label="reference")
    ax.set_ylabel("position (mm)")
    ax.set_title(f"(a) PIP-SDP step responses over {res.runs} drawn plants ({res.draws})", fontsize=10, loc="left")
    ax.legend(loc="lower right", ncols=2, **LEGEND)
    dev.set_title("(b) the same bands about the median", fontsize=10, loc="left")
    dev.set_ylabel("deviation ($\\mu$m)")
    dev.set_xlabel("time (s)")
    for a in (ax, dev):
        a.grid(alpha=0.3)

    fig2 = new_figure(figsize=(11.0, 6.0))
    axes = fig2.subplots(2, 3).ravel()
    for j, name in enumerate(ASYM):
        ax = axes[j]
        for c in CONTROLLERS:
            ts = np.asarray(res.stats[c]["settling_time_s"], float)
            fin = np.isfinite(ts)
            ax.plot(res.parameters[fin, j], ts[fin], ".", markersize=2.5, alpha=0.5, color=CONTROLLER_COLOURS[c])
        ax.axvline(float(res.nominal.asymmetric[name]), color="k", linewidth=0.8)
        ax.set_xlabel(f"{name} ({UNITS[name]})")
        ax.set_ylabel("settling time (s)")
        ax.set_yscale("log")
        panel(ax, name)
    ax = axes[-1]
    ax.axis("off")
    for c in CONTROLLERS:
        frac = res.statistics[c]["settled_fraction"]
        label = f"{LABELS[c]} (settled in {fraction_pct(frac)} of the runs)"
        ax.plot([], [], "o", color=CONTROLLER_COLOURS[c], label=label)
    ax.legend(loc="upper left", **LEGEND)
    fig2.suptitle("Settling time (2 %) against the drawn plant parameters; vertical lines: nominal", fontsize=11)
    return {"mc_envelope": fig, "mc_settling": fig2}


@x64
def save_figures(figures: dict, out: str | os.PathLike, *, fmt: str = "png", dpi: float = 150) -> list[pathlib.Path]:
    """Write `figures` (name -> Figure) into the existing directory `out` as `<name>.<fmt>`; returns the paths.

    `fmt`: "png", "pdf" or "svg"; `dpi`: raster resolution (> 0).

    Example:
        >>> import tempfile
        >>> from jaxsdp.studies.montecarlo import control_figures, control_robustness, save_figures
        >>> paths = save_figures(control_figures(control_robustness(16, progress=False)), tempfile.mkdtemp(), fmt="svg")
        >>> [p.name for p in paths]
        ['mc_envelope.svg', 'mc_settling.svg']
    """
    path_out = figure_output(fmt, dpi, out)
    paths = []
    for name, fig in figures.items():
        path = path_out / f"{name}.{fmt}"
        fig.savefig(path, format=fmt, dpi=float(dpi))
        paths.append(path)
    return paths
