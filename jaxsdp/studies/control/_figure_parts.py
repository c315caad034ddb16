"""Shared parts of the control study's figures: access to the study's fields, step figures, styles, an example study.

The figures read only the study's fields, so any object with them works;
`example_study()` is a small synthetic stand-in for the doctests.
"""

import math
import types

import numpy as np

from ...control._closed_loop import ControlSimulation
from ...control._metrics import step_metrics
from ...control._nominal import FrictionEstimate
from .._figure_style import as_float
from ._shared import bounded_response

BAND = 0.02  # settling band, fraction of the step
MM = 1e3  # m -> mm
# friction forms: hybrid in red (SDP part) and blue (fitted lines), as the paper's Fig. 13
HYBRID_IN = dict(color="tab:red", linewidth=2.6)
HYBRID_OUT = dict(color="tab:blue", linewidth=2.6)
TABULATED = dict(color="tab:green", linewidth=1.2, linestyle="--")
PARAMETRIC = dict(color="k", linewidth=1.1, linestyle="-.")
STEP_COLOURS = {
    "sdp_pd": "tab:red",
    "linear_pd": "tab:blue",
    "delay": "tab:orange",
    "delay_wn_max": "tab:green",
    "saturation": "tab:purple",
    "real_wn_max": "tab:brown",
}
CASCADE = (("pip_sdp", "tab:blue"), ("pip_sdp_tuned", "tab:red"), ("pip_sdp_real", "tab:green"))  # key, colour


# --------------------------------------------------------------------------- #
# Access to the study (duck-typed: a ControlStudy or any object with its fields)
# --------------------------------------------------------------------------- #


def study_field(study, name):
    if not hasattr(study, name):
        raise ValueError(
            f"`study` must be a ControlStudy (from control_study) or have its fields; it has no `{name}` "
            f"(got {type(study).__name__})"
        )
    return getattr(study, name)


def friction_fields(study) -> dict:
    """`study.friction` of a ControlStudy, or the same fields from a `FrictionEstimate`."""
    if isinstance(study, FrictionEstimate):
        return dict(curve=(study.velocity, study.friction), asymmetric=study.asymmetric)
    return study_field(study, "friction")


def study_sim(study, key, *, required=True):
    sims = study_field(study, "sims")
    if key not in sims:
        if required:
            raise ValueError(f"`study.sims` has no {key!r} simulation; it has {sorted(sims)}")
        return None
    s = sims[key]
    if key == "ident":
        return {k: as_float(s[k]) for k in ("t", "r", "y", "y_model")}
    return ControlSimulation(*(as_float(a) for a in s))


def finite_response(sim) -> bool:
    """The simulation stays finite and within 10 steps of its start (the study's stability test)."""
    return bounded_response(sim.q, float(sim.q[0]), float(sim.r[-1]))


def response_metrics(sim):
    """step_metrics of a position step, or None when the response diverges."""
    if not finite_response(sim):
        return None
    return step_metrics(sim.t, sim.q, float(sim.r[-1]), y0=float(sim.q[0]), band=BAND, velocity=sim.dq)


def ms_text(x: float) -> str:
    return f"{1e3 * x:.0f} ms" if x < 1 else f"{x:.2f} s"


def step_label(name: str, m) -> str:
    if m is None:
        return f"{name}: unstable"
    ts = f"$t_s$ = {ms_text(m.settling_time)}" if m.settled else "not settled"
    return f"{name}: {ts}, overshoot {m.overshoot:.1f} %"


def mark_settling(ax, m, colour, y):
    """Dotted vertical at the settling time, labelled at height `y` (fraction of the axes)."""
    if m is not None and m.settled:
        ax.axvline(m.settling_time, color=colour, linewidth=0.9, linestyle=":")
        ax.annotate(
            ms_text(m.settling_time),
            (m.settling_time, y),
            xycoords=ax.get_xaxis_transform(),
            xytext=(3, 0),
            textcoords="offset points",
            color=colour,
            fontsize=8,
            va="center",
            bbox=dict(boxstyle="round,pad=0.15", facecolor="white", edgecolor="none", alpha=0.8),
        )


def settling_band(ax, target_mm, step_mm, *, legend=True):
    half = BAND * abs(step_mm)
    label = f"$\\pm${100 * BAND:g} % band" if legend else None
    ax.axhspan(target_mm - half, target_mm + half, color="0.6", alpha=0.3, linewidth=0, label=label)


def fmt3(x) -> str:
    try:
        return f"{float(x):.3g}"
    except (TypeError, ValueError):
        return "?"


# --------------------------------------------------------------------------- #
# A synthetic stand-in for the examples
# --------------------------------------------------------------------------- #


def second_order(t, wn, eta, step):
    """Step response (and velocity) of wn^2 / (s^2 + 2 eta wn s + wn^2), eta < 1 or = 1."""
    if eta < 1:
        wd = wn * math.sqrt(1 - eta**2)
        e = np.exp(-eta * wn * t)
        x = 1 - e * (np.cos(wd * t) + eta * wn / wd * np.sin(wd * t))
        v = e * wn**2 / wd * np.sin(wd * t)
    else:
        x = 1 - (1 + wn * t) * np.exp(-wn * t)
        v = wn**2 * t * np.exp(-wn * t)
    return step * x, step * v


def example_sim(t, step, wn, eta, *, force_limit=None, lag=0.0):
    q, dq = second_order(np.maximum(t - lag, 0.0), wn, eta, step)
    force = 95.0 * np.gradient(dq, t) + 200.0 * dq
    if force_limit is not None:
        force = np.clip(force, -force_limit, force_limit)
    aux = second_order(t, 2 * wn, 1.0, step)[0] if lag else np.zeros_like(t)
    r = np.full_like(t, step)
    return ControlSimulation(t, r, q, dq, np.gradient(dq, t), q, force, force, aux)


def example_study():
    """A small synthetic stand-in for a `ControlStudy` with the fields the figures read (for the examples).

    Second-order step responses instead of simulations, an analytic friction
    curve instead of an SDP estimate: cheap, not the study's results.
    """
    rng = np.random.default_rng(0)
    v = np.linspace(-0.12, 0.12, 481)
    f = np.where(v > 0, 165 * v + 20, 240 * v - 20) * (1 - np.exp(-np.abs(v) / 0.004))
    t = np.arange(400) * 1e-3
    tc = np.arange(2000) * 1e-3
    sims = dict(
        sdp_pd=example_sim(t, 0.05, 250.0, 1.0),
        linear_pd=example_sim(t, 0.05, 160.0, 0.37),
        delay=example_sim(t, 0.05, 250.0, 0.5),
        delay_wn_max=example_sim(t, 0.05, 210.0, 0.8),
        saturation=example_sim(t, 0.05, 25.0, 0.3, force_limit=351.5),
        real_wn_max=example_sim(t, 0.05, 25.0, 0.3, force_limit=351.5, lag=1e-3),
        pip_sdp=example_sim(tc, 0.05, 4.0, 1.0, lag=0.01),
        pip_sdp_tuned=example_sim(tc, 0.05, 6.0, 0.9, lag=0.01),
        pip_sdp_real=example_sim(tc, 0.05, 4.0, 1.0, force_limit=351.5, lag=0.011),
    )
    ti = np.arange(4000) * 1e-3
    ri = np.repeat(rng.uniform(-0.05, 0.05, 20), 200)
    b, a = 0.2, 0.8  # a first-order loop at 1 kHz
    x = np.zeros_like(ri)
    for k in range(1, ri.size):
        x[k] = a * x[k - 1] + b * ri[k - 1]
    y = x + 0.05 * np.std(x) * rng.standard_normal(x.size)
    sims["ident"] = dict(t=ti, r=ri, y=y, y_model=x)
    return types.SimpleNamespace(
        settings=types.SimpleNamespace(wn=250.0, v_limit=0.15, step=0.05),
        friction=dict(
            curve=(v, f),
            velocity_range=[-0.12, 0.12],
            asymmetric=dict(M=95.0, Fv_pos=165.0, Fc_pos=20.0, Fv_neg=240.0, Fc_neg=20.0),
        ),
        real_drive=dict(largest_wn_delay=210.0, delay_largest_wn=dict(wn=210.0)),
        pip_sdp=dict(loop_gain=0.013, real_drive=dict(wn=210.0), paper_loop_gain=dict(stable=False, loop_gain=5.0)),
        gradients=dict(tuned=dict(loop_gain=0.014, wn=10.0, ew=10.0, xw=1.0)),
        srivc=dict(num=[223.1], den=[1.0, 223.1], fit_pct=99.7, noise_pct=5.0),
        sims=sims,
    )
