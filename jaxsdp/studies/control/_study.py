"""The SDP control study of the EMPS (paper section 4): one function, `control_study`, stage by stage.

1. **friction**: the EMPS identification study (`jaxsdp.studies.emps`) on the
   built-in closed-loop data (or a measurement file) gives the linear
   IDIM-LS model (c1..c4), the friction SDP curve and the IDIM-SDP
   asymmetric law: the three friction forms of Fig. 13.
2. **sdp_pd** (Fig. 14): SDP-PD (hybrid friction) and the benchmark's linear
   PD, step 0 -> `step` m, in the paper's setting (no drive delay, no
   saturation), on the true plant (`jaxsdp.control.true_plant`).
3. **real_drive**: the same with the drive's one-sample delay, with its
   saturation, and the largest wn whose overshoot stays under 2 % with the
   delay (a vmapped grid over wn).
4. **srivc**: a closed-loop experiment of the SDP-PD loop (random steps of
   the reference, 5 % output noise by standard deviation, eq. 27; white, or
   coloured by `ident_noise_colour`) identified as a continuous-time TF by
   SRIVC, or by RIVCBJ with a noise model (`estimator`; SRIVC then runs on the
   same data for comparison), then `c2d` at the outer period.
5. **pip**: PIP-LQ on that model (ew, uw, xw), and on the paper's model (30).
6. **cascade**: PIP-SDP on the plant; the loop gain LG that just meets the
   velocity limit (the paper's hand tuning, done by a vmapped grid), the
   paper's LG = 5, and the cascade under the real drive with the wn of 3.
7. **gradients**: d cost / d (wn, eta, ew, uw, xw, LG) through design and
   simulation against central differences, and a gradient-based (BFGS)
   tuning of (wn, eta, LG, ew, xw) on the real drive that meets the velocity
   limit with a faster settling, with a stated convergence test (`_tuning`).
"""

import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from ..._checks import checked_call
from ..._runtime import follows_method, x64
from ...control._closed_loop import REAL_DRIVE, Drive, simulate_control
from ...control._metrics import AT_LIMIT_MARGIN, LIMIT_RTOL, force_verdict, step_metrics, tracking_cost
from ...control._model import control_model
from ...control._nominal import (
    MAX_OVERSHOOT,
    FrictionEstimate,
    cascade_simulation,
    friction_forms,
    ident_warning,
    identify_friction,
    nominal_design,
    step_input,
)
from ...control._pip import pip_lq, pip_simulate
from ...control._sdp_pd import SDPPD, LinearPD
from .._contract import fast_loops, versions
from ._settings import ControlSettings, ControlStudy
from ._shared import PAPER_MODEL, bounded_response
from ._tuning import tune_cascade, tuning_warnings

STAGES = ("friction", "design", "sdp_pd", "real_drive", "pip", "cascade", "gradients")


def _metrics(sim, target, y0=0.0):
    if not bounded_response(sim.q, y0, target):
        none = dict.fromkeys(("settling_time_s", "overshoot_pct", "rise_time_s", "max_velocity", "max_force"))
        return dict(none, settled=False, stable=False, within_drive_limit=None, drive_verdict=None)
    m = step_metrics(sim.t, sim.q, target, y0=y0, velocity=sim.dq, force=sim.force)
    return dict(
        settling_time_s=m.settling_time,
        overshoot_pct=m.overshoot,
        rise_time_s=m.rise_time,
        max_velocity=m.peak_velocity,
        max_force=m.peak_force,
        settled=m.settled,
        stable=True,
        within_drive_limit=bool(float(m.peak_force) <= DRIVE_LIMIT * (1 + LIMIT_RTOL)),
        drive_verdict=force_verdict(m.peak_force, DRIVE_LIMIT),
    )


#: The EMPS drive's force limit (N); a design above it in simulation cannot run on the machine.
DRIVE_LIMIT = float(REAL_DRIVE.force_limit)
#: The verdict of a design within `AT_LIMIT_MARGIN` of the drive's limit (`force_verdict`).
AT_LIMIT = "at the limit"


def infeasible_warning(designs: dict) -> list[str]:
    """One warning naming the designs (label -> metrics) whose simulated peak force exceeds the drive's limit."""
    over = [f"{label} ({m['max_force']:.4g} N)" for label, m in designs.items() if m.get("within_drive_limit") is False]
    if not over:
        return []
    return [
        f"infeasible on the EMPS drive (|F| <= {DRIVE_LIMIT:g} N): {', '.join(over)} need more force than the drive "
        "gives; they are the paper's idealised (ideal-drive) comparisons, the rows with the drive's saturation show "
        "what the machine would do"
    ]


def at_limit_warning(designs: dict) -> list[str]:
    """One warning naming the designs (label -> metrics) whose simulated peak force is at the drive's limit
    (within `AT_LIMIT_MARGIN` of it: `force_verdict`)."""
    near = [f"{label} ({m['max_force']:.4g} N)" for label, m in designs.items() if m.get("drive_verdict") == AT_LIMIT]
    if not near:
        return []
    return [
        f"at the EMPS drive's limit (peak |F| within {100 * AT_LIMIT_MARGIN:g} % of {DRIVE_LIMIT:g} N): "
        f"{', '.join(near)}: no force margin; the drive saturates, or nearly, on this step, and a larger step, load "
        "or friction would saturate it longer"
    ]


def tuned_force_warning(tuned: dict, hand: dict) -> list[str]:
    """The warning of a gradient-tuned design (metrics with `max_command`, `saturated`) at the drive's limit,
    saying whether the tuning pushed it there; `hand` the hand-tuned design's metrics on the same drive."""
    if tuned.get("drive_verdict") != AT_LIMIT:
        return []
    text = (
        f"the gradient-tuned design is at the EMPS drive's limit (peak |F| {tuned['max_force']:.4g} N, within "
        f"{100 * AT_LIMIT_MARGIN:g} % of {DRIVE_LIMIT:g} N)"
    )
    if tuned["saturated"]:
        text += (
            f": the tuning itself pushed it onto the limit: its step commands up to {tuned['max_command']:.4g} N, "
            "which the drive clips (the saturation is active at the tuned optimum: the tuning's cost has no force "
            "term, so it buys speed with force up to the limit)"
        )
    elif hand.get("drive_verdict") == "feasible":
        text += f": the tuning moved it there from the hand-tuned design's {hand['max_force']:.4g} N"
    return [text + "; it leaves no force margin: prefer the hand-tuned design where one is needed"]


def _pip_summary(design):
    return dict(
        gains={k: float(v) for k, v in design.named_gains().items()},
        closed_loop_poles=[[float(p.real), float(p.imag)] for p in np.asarray(design.closed_loop_poles)],
        weights=dict(ew=float(design.ew), uw=float(design.uw), xw=float(design.xw)),
    )


def _pip_step(design, settings, samples=200):
    """Unit-step figures of a PIP design on its own model (discrete, period ratio * dt), LG = 1 and the paper's."""
    dt = settings.ratio * settings.dt
    t = np.arange(samples) * dt
    out = {}
    for lg in (1.0, settings.paper_lg):
        sim = pip_simulate(design, design.num, design.den, jnp.ones(samples), loop_gain=lg)
        y = np.asarray(sim.y)
        key = f"loop_gain_{lg:g}"
        if not bounded_response(y, 0.0, 1.0):
            out[key] = dict(stable=False)
            continue
        m = step_metrics(t, y, 1.0, y0=0.0)
        out[key] = dict(
            stable=True,
            settling_time_s=m.settling_time,
            overshoot_pct=m.overshoot,
            max_input=float(np.max(np.abs(np.asarray(sim.u)))),
        )
    out["dt"] = dt
    return out


def _cascade_cost(settings, model, num_d, den_d, r, drive=None):
    """Smooth cost of the PIP-SDP step: IAE plus a velocity-limit penalty, as a function of the design."""

    def cost(p):
        wn, eta, ew, uw, xw, lg = p
        design = pip_lq(num_d, den_d, ew=ew, uw=uw, xw=xw)
        sim = cascade_simulation(settings, model, design, lg, r, drive=drive, wn=wn, eta=eta)
        return tracking_cost(sim.t, sim.q, sim.r, dq=sim.dq, v_max=settings.v_limit, weight=1e4)

    return cost


def _gradients(settings, model, num_d, den_d, lg0, r, wn_real):
    cascade_cost = _cascade_cost(settings, model, num_d, den_d, r)
    p0 = jnp.array([settings.wn, settings.eta, settings.ew, settings.uw, settings.xw, lg0])
    grad = np.asarray(jax.jit(jax.grad(cascade_cost))(p0))

    def cost(p):  # the finite differences' values: one program whose checks are outputs (cached across runs)
        return checked_call(cascade_cost, p)

    fd = []
    for i in range(6):
        h = 1e-5 * max(abs(float(p0[i])), 1e-3)
        e = jnp.zeros(6).at[i].set(h)
        fd.append(float((cost(p0 + e) - cost(p0 - e)) / (2 * h)))
    names = ("wn", "eta", "ew", "uw", "xw", "loop_gain")
    out = dict(
        parameters=dict(zip(names, np.asarray(p0).tolist())),
        cost=float(cost(p0)),
        gradient=dict(zip(names, grad.tolist())),
        finite_difference=dict(zip(names, fd)),
        max_rel_diff=float(np.max(np.abs(grad - fd) / np.maximum(np.abs(fd), 1e-12 + 1e-6 * np.max(np.abs(fd))))),
    )
    tuned = None
    if settings.tune_iterations > 0 and np.isfinite(wn_real):  # it starts from the largest wn the delay allows
        # BFGS on the bounded, scaled (wn, eta, LG, ew, xw) with the real drive (delay, saturation), uw = 1
        # setting the scale of the LQ weights, from the hand-tuned design and from a few slower inner loops: the
        # cost is flat in wn near 250 rad/s, where the inner loop is much faster than the outer one (`_tuning`).
        real_cost = _cascade_cost(settings, model, num_d, den_d, r, drive=REAL_DRIVE)

        def tune_cost(p):
            wn, eta, lg, ew, xw = p
            return real_cost(jnp.stack([wn, eta, ew, jnp.asarray(settings.uw, p.dtype), xw, lg]))

        hand = dict(wn=wn_real, eta=settings.eta, loop_gain=lg0, ew=settings.ew, xw=settings.xw)
        tuned = tune_cascade(
            tune_cost,
            hand,
            wn_real=wn_real,
            starts=(wn_real, *settings.tune_starts),
            max_steps=settings.tune_iterations,
        )
        tuned = dict(
            drive="real (one-sample delay, +-351.5 N)",
            improved=tuned["cost"] < tuned["hand_tuned_cost"],
            uw=settings.uw,
            **tuned,
        )
    return out, tuned


@x64
@follows_method
def control_study(
    data=None,
    *,
    friction: FrictionEstimate | None = None,
    settings: ControlSettings | None = None,
    progress: Callable[[str], None] | None = None,
    method: str | None = None,
) -> ControlStudy:
    """Run the SDP control study of the EMPS (paper section 4) with per-stage timings.

    **Arguments:** `data`: None (the built-in EMPS closed-loop data set; the
    friction SDP is identified from it as the paper did from its PD
    experiment) or a path / `EMPSData` for `jaxsdp.studies.emps.emps_study`;
    `friction`: a `FrictionEstimate` to use instead of identifying one from
    `data` (e.g. from your own identification, or to re-run the control part);
    `settings`: a `ControlSettings`; `progress`: called with each stage name
    (see `STAGES`) as it starts; `method`: the Kalman and IIR kernels of
    every stage (None: the current setting, see `jaxsdp.set_kernel_method`).

    **Returns:** a `ControlStudy`.

    Example:
        >>> from jaxsdp.studies.control import ControlSettings
        >>> ControlSettings().wn, ControlSettings().v_limit  # rad/s, m/s
        (250.0, 0.15)
    """
    s = ControlSettings() if settings is None else settings
    timings, warnings, sims = {}, [], {}
    clock = [time.perf_counter()]

    def stage(name):
        now = time.perf_counter()
        if timings:
            timings[list(timings)[-1]] = now - clock[0]
        clock[0] = now
        timings[name] = 0.0
        if progress is not None:
            progress(name)

    stage("friction")
    if friction is None:
        friction, w = identify_friction(data, seed=s.seed)
        warnings += w
    elif data is not None:
        raise ValueError("give `data` or `friction`, not both")
    elif not isinstance(friction, FrictionEstimate):
        raise ValueError(f"`friction` must be a FrictionEstimate; got {type(friction).__name__}")
    fric, model, forms = friction_forms(friction)
    n_pd = int(round(s.t_pd / s.dt))
    r = step_input(s, n_pd)

    stage("design")
    nominal = nominal_design(friction, settings=s)  # the designs the Monte Carlo study holds fixed
    design, lg_hand, wn_max, ident = nominal.design, nominal.loop_gain, nominal.wn_real, nominal.srivc
    num_d, den_d = jnp.asarray(ident["discrete_num"]), jnp.asarray(ident["discrete_den"])
    sims["ident"] = nominal.experiment

    stage("sdp_pd")
    sdp_ctrl = SDPPD(model, wn=s.wn, eta=s.eta, velocity=s.velocity)
    sims["sdp_pd"] = simulate_control(sdp_ctrl, r, q0=0.0, dt=s.dt)
    sims["linear_pd"] = simulate_control(LinearPD(), r, q0=0.0, dt=s.dt)
    for form in ("tabulated", "parametric"):
        alt = SDPPD(control_model(fric["idim_ls"], friction=forms[form]), wn=s.wn, eta=s.eta, velocity=s.velocity)
        sims[f"sdp_pd_{form}"] = simulate_control(alt, r, q0=0.0, dt=s.dt)
    kp, _ = sdp_ctrl.gains(0.1)
    sdp_pd = dict(_metrics(sims["sdp_pd"], s.step), kp=float(kp), wn=s.wn, eta=s.eta, friction_form="hybrid")
    sdp_pd["other_forms"] = {f: _metrics(sims[f"sdp_pd_{f}"], s.step) for f in ("tabulated", "parametric")}
    linear_pd = _metrics(sims["linear_pd"], s.step)

    stage("real_drive")
    rr = step_input(s, int(round(s.t_real / s.dt)))
    saturated = Drive(force_limit=REAL_DRIVE.force_limit)
    sims["delay"] = simulate_control(sdp_ctrl, rr, q0=0.0, dt=s.dt, drive=Drive(delay=1))
    sims["saturation"] = simulate_control(sdp_ctrl, rr, q0=0.0, dt=s.dt, drive=saturated)
    slow = SDPPD(model, wn=wn_max, eta=s.eta, velocity=s.velocity)
    sims["delay_wn_max"] = simulate_control(slow, rr, q0=0.0, dt=s.dt, drive=Drive(delay=1))
    sims["real_wn_max"] = simulate_control(slow, rr, q0=0.0, dt=s.dt, drive=REAL_DRIVE)
    real = dict(
        delay=dict(_metrics(sims["delay"], s.step), wn=s.wn),
        saturation=dict(_metrics(sims["saturation"], s.step), wn=s.wn, force_limit=float(REAL_DRIVE.force_limit)),
        largest_wn_delay=wn_max,
        delay_largest_wn=dict(_metrics(sims["delay_wn_max"], s.step), wn=wn_max),
        delay_and_saturation=dict(_metrics(sims["real_wn_max"], s.step), wn=wn_max),
        wn_grid=list(s.wn_grid),
        overshoot_grid=nominal.overshoots.tolist(),
        max_overshoot_pct=MAX_OVERSHOOT,
    )
    if not np.isfinite(wn_max):
        text = f"no wn in the grid keeps the overshoot under {MAX_OVERSHOOT} % with the drive's delay"
        warnings.append(text + ("; the gradient tuning, which starts there, is skipped" if s.tune_iterations else ""))
    if not ident["converged"]:
        warnings.append(ident_warning(ident))

    stage("pip")
    pip = _pip_summary(design)
    paper_design = pip_lq(PAPER_MODEL["num"], PAPER_MODEL["den"], ew=s.ew, uw=s.uw, xw=s.xw)
    paper = _pip_summary(paper_design)
    paper["step"] = _pip_step(paper_design, s)

    stage("cascade")
    n_c = int(round(s.t_cascade / s.dt))
    rc = step_input(s, n_c)
    sims["pip_sdp"] = cascade_simulation(s, model, design, lg_hand, rc)
    sims["pip_sdp_paper_lg"] = cascade_simulation(s, model, design, s.paper_lg, rc)
    sims["pip_sdp_real"] = cascade_simulation(s, model, design, lg_hand, rc, drive=REAL_DRIVE, wn=wn_max)
    pip_sdp = dict(
        _metrics(sims["pip_sdp"], s.step),
        loop_gain=lg_hand,
        v_limit=s.v_limit,
        tuning="largest loop gain whose step response keeps |dq| <= v_limit (the paper's hand tuning)",
    )
    pip_sdp["paper_loop_gain"] = dict(_metrics(sims["pip_sdp_paper_lg"], s.step), loop_gain=s.paper_lg)
    pip_sdp["real_drive"] = dict(_metrics(sims["pip_sdp_real"], s.step), loop_gain=lg_hand, wn=wn_max)
    if not pip_sdp["paper_loop_gain"]["stable"]:
        warnings.append(
            f"PIP-SDP with the paper's loop gain LG = {s.paper_lg:g} is unstable on this identified model: "
            f"the paper's LG fits its slower model (30); LG = {lg_hand:.3g} just meets {s.v_limit} m/s here"
        )
    if pip_sdp["real_drive"]["max_velocity"] > s.v_limit * 1.05:
        warnings.append(
            f"with the real drive the PIP-SDP step peaks at {pip_sdp['real_drive']['max_velocity']:.3g} m/s, "
            f"above the {s.v_limit} m/s limit"
        )

    stage("gradients")
    grads, tuned = _gradients(s, model, num_d, den_d, lg_hand, rc, wn_max)
    if tuned is not None:
        td = pip_lq(num_d, den_d, ew=tuned["ew"], uw=tuned["uw"], xw=tuned["xw"])
        sims["pip_sdp_tuned"] = cascade_simulation(
            s, model, td, tuned["loop_gain"], rc, drive=REAL_DRIVE, wn=tuned["wn"], eta=tuned["eta"]
        )
        tuned.update(_metrics(sims["pip_sdp_tuned"], s.step))
        tuned["max_command"] = float(np.max(np.abs(np.asarray(sims["pip_sdp_tuned"].command))))
        tuned["saturated"] = bool(tuned["max_command"] > DRIVE_LIMIT * (1 + LIMIT_RTOL))
        grads["tuned"] = tuned
        warnings += tuning_warnings(tuned)
        if not tuned["improved"]:
            warnings.append("the gradient-based tuning did not improve on the hand-tuned loop gain (see report)")
        if not tuned["stable"] or (tuned["max_velocity"] or np.inf) > s.v_limit * 1.02:
            warnings.append(
                f"the gradient-tuned design breaks the {s.v_limit} m/s limit or is unstable "
                f"(peak {tuned['max_velocity']} m/s)"
            )
        warnings += tuned_force_warning(tuned, pip_sdp["real_drive"])
    warnings += infeasible_warning(
        {
            f"SDP-PD wn {s.wn:g} (ideal drive)": sdp_pd,
            "linear PD (ideal drive)": linear_pd,
            f"SDP-PD wn {s.wn:g} with the delay": real["delay"],
            f"SDP-PD wn {wn_max:g} with the delay": real["delay_largest_wn"],
            f"PIP-SDP cascade LG {lg_hand:.3g} (ideal drive)": pip_sdp,
        }
    )
    warnings += at_limit_warning(
        {
            f"SDP-PD wn {s.wn:g} with saturation only": real["saturation"],
            f"SDP-PD wn {wn_max:g} with the delay and saturation": real["delay_and_saturation"],
            f"PIP-SDP cascade LG {lg_hand:.3g} (ideal drive)": pip_sdp,
            f"PIP-SDP cascade LG {lg_hand:.3g} with the real drive": pip_sdp["real_drive"],
        }
    )
    stage("done")
    timings.pop("done")
    return ControlStudy(
        settings=s,
        source=fric["source"],
        friction=fric,
        sdp_pd=sdp_pd,
        linear_pd=linear_pd,
        real_drive=real,
        srivc=ident,
        pip=pip,
        pip_paper_model=paper,
        pip_sdp=pip_sdp,
        gradients=grads,
        sims=sims,
        warnings=tuple(warnings),
        timings=timings,
        versions=versions(),
        fast_loops=fast_loops(),
    )
