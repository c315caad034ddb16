"""The controllers designed on the nominal EMPS model: friction identification, SDP-PD, SRIVC, PIP-LQ, loop gain.

What the control study (`jaxsdp.studies.control.control_study`) and the Monte
Carlo robustness study (`jaxsdp.studies.montecarlo.control_robustness`) both
stand on, in the order the paper designs them:

1. `identify_friction`: the EMPS fits (`jaxsdp.plants.emps.emps_fits`) give
   the linear IDIM-LS model (c1..c4), the friction SDP curve and the
   asymmetric IDIM-LS law (`FrictionEstimate`); `friction_forms` turns them
   into the tabulated, hybrid and parametric friction of Fig. 13 and the
   SDP control model.
2. `largest_wn`: the largest SDP-PD natural frequency keeping the overshoot
   under `MAX_OVERSHOOT` with the drive's one-sample delay (a vmapped grid).
3. `srivc_experiment`: the SDP-PD loop excited by random steps, its output
   noisy, identified by SRIVC and discretised at the outer period.
4. PIP-LQ on that model; `hand_tuned_loop_gain`: the largest PIP-SDP loop
   gain keeping |dq| under the velocity limit (the paper's hand tuning).

`nominal_design` runs them all (`NominalDesign`); `ControlSettings` holds the
options (the paper's by default).
"""

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .._runtime import x64
from ..data._emps_builtin import emps_builtin_data
from ..data._loaders import load_record
from ..plants._friction import AsymmetricFriction
from ..plants.emps._checks import check_emps_data
from ..plants.emps._fits import emps_fits
from ..plants.emps._model import EMPS_ASYM_NAMES, EMPS_DROP
from ..plants.emps._plant import BENCHMARK_GAINS
from ..plants.emps._preprocess import emps_preprocess
from ..tfest._c2d import c2d
from ..tfest._srivc import srivc
from ._cascade import PIPSDP
from ._closed_loop import Drive, simulate_control
from ._model import control_model, sdp_friction
from ._pip import pip_lq
from ._sdp_pd import SDPPD

#: The EMPS benchmark's decimation factor, used for the friction identification.
DECIMATE = 10


#: The inner reference's acceleration limit of the default cascade (m/s^2): 80 % of what the EMPS drive's
#: 351.5 N gives the axis (M 95.15 kg) beyond its Coulomb friction (20.6 N); the margin covers the viscous
#: friction and the inner loop's tracking error.
CASCADE_ACCEL = 0.8 * (10.0 * BENCHMARK_GAINS["gtau"] - 20.63) / 95.15


@dataclasses.dataclass(frozen=True)
class ControlSettings:
    """Options of `control_study` (defaults: the paper's section 4).

    `wn` (rad/s), `eta`: SDP-PD design; `velocity`: the controllers' velocity
    estimate ("fir", the benchmark's); `step` (m) and `t_pd` (s): the Fig. 14
    step, `t_real` (s) its horizon
    with the real drive (saturation is slow); `wn_grid`: candidates for the largest wn with the drive's delay;
    `ident_seconds`, `ident_hold` (s), `ident_noise` (fraction of the output
    std), `n`, `m`: the SRIVC experiment and model orders; `ratio`: outer /
    inner period (10: 100 Hz over 1 kHz); `ew`, `uw`, `xw`: PIP weights;
    `paper_lg`: the paper's loop gain; `v_limit` (m/s); `t_cascade` (s);
    `lg_grid`: loop gains tried for the hand tuning; `tune_iterations`: BFGS
    steps of the gradient tuning (0: skip), `tune_starts`: its starting inner
    wn values (rad/s); `seed`: noise and excitation; `dt` (s): inner period;
    `hold`, `max_accel` (m/s^2, None: no limit): how the cascade's inner
    reference follows the PIP between outer samples (`PIPSDP`): ramped, its
    acceleration limited to `CASCADE_ACCEL`, what the EMPS drive can give, so
    that the default cascade stays within the drive's 351.5 N ("zoh", None:
    the paper's held reference, +-5 kN on the ideal drive).
    """

    wn: float = 250.0
    eta: float = 1.0
    velocity: str = "fir"
    step: float = 0.05
    t_pd: float = 0.4
    t_real: float = 1.0
    wn_grid: tuple = tuple(float(w) for w in np.arange(100.0, 301.0, 5.0))
    ident_seconds: float = 10.0
    ident_hold: float = 0.2
    ident_noise: float = 0.05
    n: int = 2
    m: int = 0
    ratio: int = 10
    ew: float = 10.0
    uw: float = 1.0
    xw: float = 1.0
    paper_lg: float = 5.0
    v_limit: float = 0.15
    t_cascade: float = 3.0
    lg_grid: tuple = tuple(float(g) for g in np.geomspace(1e-3, 10.0, 81))
    tune_iterations: int = 30
    tune_starts: tuple = (10.0, 30.0)
    seed: int = 0
    dt: float = 1e-3
    hold: str = "linear"
    max_accel: float | None = CASCADE_ACCEL


MAX_OVERSHOOT = 2.0  # %, for the largest wn under the drive's delay


class FrictionEstimate(NamedTuple):
    """What the control study needs from an identification: the friction SDP curve and the IDIM-LS models.

    `velocity`, `friction`: (N,) the SDP friction curve (m/s, N);
    `idim_ls`: dict M, Fv, Fc, offset (linear model, gives c1..c4);
    `asymmetric`: dict M, Fv_pos, Fc_pos, Fv_neg, Fc_neg (eq. 17);
    `source`: where it came from; `nvr`: the friction SDP's NVR;
    `asymmetric_cov`: (5, 5) covariance of the asymmetric estimate (in that
    order), None when unknown.
    """

    velocity: np.ndarray
    friction: np.ndarray
    idim_ls: dict
    asymmetric: dict
    source: str
    nvr: float = float("nan")
    asymmetric_cov: np.ndarray | None = None


def identify_friction(data=None, *, seed: int = 0) -> tuple[FrictionEstimate, list]:
    """The friction the control study's controllers use, identified from EMPS data (built-in when `data` is None).

    The EMPS identification's stages with the benchmark's settings (checks,
    `emps_preprocess`, `emps_fits`: IDIM-LS of both friction models, the SDP
    stage with ML NVRs, IDIM-SDP), exactly as `jaxsdp.studies.emps.emps_study`
    runs them. `data`: None, a path (`.mat` or CSV, `jaxsdp.data.load_record`),
    an `EMPSData` or a `Measurements`; `seed`: the built-in data set's noise.

    Returns the `FrictionEstimate` and the fits' warnings (signs,
    conditioning, NVR bounds, convergence).

    Example:
        >>> from jaxsdp.control import FrictionEstimate
        >>> FrictionEstimate._fields[:2]
        ('velocity', 'friction')
    """
    if data is None:
        data, _, _ = emps_builtin_data(seed=seed)
        source = "built-in EMPS closed-loop simulation (jaxsdp.data.emps_builtin_data)"
    else:
        source = str(data) if isinstance(data, str) else type(data).__name__
    record, _ = load_record(data)
    check_emps_data(record, drop=EMPS_DROP, decimate=DECIMATE)
    fits = emps_fits(emps_preprocess(record, drop=EMPS_DROP, decimate=DECIMATE))
    physical, fit = fits.checks()
    res, asym = fits.sdp.result, fits.idim_asym
    est = FrictionEstimate(
        velocity=np.asarray(res.x_sorted[1]),
        friction=np.asarray(res.par_sorted[1]),
        idim_ls={k: float(fits.idim[k]) for k in ("M", "Fv", "Fc", "offset")},
        asymmetric={k: float(asym[k]) for k in ASYM},
        source=source,
        nvr=float(fits.sdp.nvr_friction),
        asymmetric_cov=np.asarray(asym.cov)[np.ix_(*[[asym.names.index(k) for k in ASYM]] * 2)],
    )
    return est, physical + fit


#: The asymmetric plant's parameters, in the order of `FrictionEstimate.asymmetric_cov` (`plants.EMPS_ASYM_NAMES`).
ASYM = EMPS_ASYM_NAMES


class NominalDesign(NamedTuple):
    """The controllers designed on the nominal model (what a robustness study holds fixed).

    `model`: the SDP control model (hybrid friction form); `design`: the
    PIP-LQ design of the SRIVC model of the SDP-PD loop; `loop_gain`: the
    hand-tuned PIP-SDP loop gain; `asymmetric`, `asymmetric_cov`: the
    asymmetric IDIM-LS plant (M, Fv_pos, Fc_pos, Fv_neg, Fc_neg) and its
    covariance; `srivc`: the identified loop model; `warnings`; `wn_real`:
    the largest SDP-PD wn (rad/s) keeping the overshoot under 2 % with the
    drive's one-sample delay (what the real drive allows). The evidence the
    choices rest on: `experiment` (the SRIVC closed-loop experiment: `t`,
    `r`, `y`, `y_model`), `overshoots` (%, over `ControlSettings.wn_grid`
    with the delay) and `peaks` (peak |dq| in m/s over `lg_grid`).
    """

    model: object
    design: object
    loop_gain: float
    asymmetric: dict
    asymmetric_cov: np.ndarray | None
    srivc: dict
    warnings: list
    wn_real: float = float("nan")
    experiment: dict | None = None
    overshoots: np.ndarray | None = None
    peaks: np.ndarray | None = None


@x64
def nominal_design(friction: FrictionEstimate | None = None, *, settings=None, data=None) -> NominalDesign:
    """The designs on the nominal model that `control_study` runs and the Monte Carlo control study holds
    fixed: friction (from `friction`, else identified from `data`, built-in when None) -> SDP-PD model, the
    largest wn the drive's delay allows, SRIVC of the SDP-PD loop, PIP-LQ, and the largest loop gain keeping
    |dq| <= v_limit; `settings` a `ControlSettings`.

    Example:
        >>> from jaxsdp.studies.control import NominalDesign
        >>> NominalDesign._fields[:3]
        ('model', 'design', 'loop_gain')
    """
    s = ControlSettings() if settings is None else settings
    friction, warnings = (friction, []) if friction is not None else identify_friction(data, seed=s.seed)
    warnings = list(warnings)
    _, model, _ = friction_forms(friction)
    wn_real, overshoots = largest_wn(model, s, step_input(s, int(round(s.t_pd / s.dt))))
    ident, experiment = srivc_experiment(model, s)
    if not ident["converged"]:
        warnings.append(SRIVC_WARNING)
    design = pip_lq(jnp.asarray(ident["discrete_num"]), jnp.asarray(ident["discrete_den"]), ew=s.ew, uw=s.uw, xw=s.xw)
    lg, peaks = hand_tuned_loop_gain(s, model, design, step_input(s, int(round(s.t_cascade / s.dt))))
    cov = None if friction.asymmetric_cov is None else np.asarray(friction.asymmetric_cov)
    return NominalDesign(
        model,
        design,
        float(lg),
        dict(friction.asymmetric),
        cov,
        ident,
        warnings,
        wn_real,
        experiment=experiment,
        overshoots=np.asarray(overshoots),
        peaks=np.asarray(peaks),
    )


SRIVC_WARNING = "SRIVC did not converge on the closed-loop experiment: the PIP design rests on that model"


def friction_forms(est: FrictionEstimate):
    v, f, asym = est.velocity, est.friction, est.asymmetric
    forms = dict(
        tabulated=sdp_friction(v, f, form="tabulated"),
        hybrid=sdp_friction(v, f, form="hybrid"),
        parametric=AsymmetricFriction(*(max(float(asym[k]), 0.0) for k in ("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"))),
    )
    model = control_model(est.idim_ls, friction=forms["hybrid"])
    out = dict(
        source=est.source,
        idim_ls=dict(est.idim_ls),
        c=[float(model.c1), float(model.c2), float(model.c3), float(model.c4)],
        asymmetric=dict(asym),
        velocity_range=[float(np.min(v)), float(np.max(v))],
        sdp_nvr=est.nvr,
        curve=(np.asarray(v), np.asarray(f)),
    )
    return out, model, forms


def step_input(settings, n_samples):
    return jnp.full(n_samples, settings.step)


def last_passing(grid, ok) -> float:
    """The last grid value of the run of passing values that starts at the grid's first (NaN if it fails)."""
    run = np.cumprod(ok).astype(bool)
    return float(np.asarray(grid)[run][-1]) if run.any() else float("nan")


def largest_wn(model, settings, r):
    """Largest wn of the grid below which every design keeps the overshoot under MAX_OVERSHOOT with the delay."""
    wns = jnp.asarray(settings.wn_grid)

    def overshoot(wn):
        sim = simulate_control(
            SDPPD(model, wn=wn, eta=settings.eta, velocity=settings.velocity),
            r,
            q0=0.0,
            drive=Drive(delay=1),
            dt=settings.dt,
        )
        return 100 * jnp.max((sim.q - settings.step) / settings.step)

    os_ = np.asarray(jax.jit(jax.vmap(overshoot))(wns))
    best = last_passing(settings.wn_grid, np.nan_to_num(os_, nan=np.inf) < MAX_OVERSHOOT)
    return best, os_


def srivc_experiment(model, settings):
    rng = np.random.default_rng(settings.seed)
    hold = max(1, int(round(settings.ident_hold / settings.dt)))
    n = int(round(settings.ident_seconds / settings.dt))
    levels = rng.uniform(-settings.step, settings.step, n // hold + 1)
    r = np.repeat(levels, hold)[:n]
    ctrl = SDPPD(model, wn=settings.wn, eta=settings.eta, velocity=settings.velocity)
    sim = simulate_control(ctrl, r, q0=0.0, dt=settings.dt)
    x = np.asarray(sim.q)
    y = x + settings.ident_noise * np.std(x) * rng.normal(size=n)
    res = srivc(y, r, settings.dt, n=settings.n, m=settings.m)
    num_d, den_d = c2d(res.num, res.den, settings.ratio * settings.dt)
    out = dict(
        num=np.asarray(res.num).tolist(),
        den=np.asarray(res.den).tolist(),
        num_se=np.asarray(res.num_se).tolist(),
        den_se=np.asarray(res.den_se).tolist(),
        discrete_num=np.asarray(num_d).tolist(),
        discrete_den=np.asarray(den_d).tolist(),
        discrete_dt=settings.ratio * settings.dt,
        iterations=int(res.iterations),
        converged=bool(res.converged),
        noise_pct=100 * settings.ident_noise,
        fit_pct=float(100 * (1 - np.sum((np.asarray(res.y_model) - y) ** 2) / np.sum((y - y.mean()) ** 2))),
        n=settings.n,
        m=settings.m,
    )
    return out, dict(t=np.asarray(sim.t), r=r, y=y, y_model=np.asarray(res.y_model))


def cascade_simulation(settings, model, design, lg, r, drive=None, wn=None, eta=None):
    """PIP-SDP step on the plant; wn and eta default to the settings'."""
    wn = settings.wn if wn is None else wn
    inner = SDPPD(model, wn=wn, eta=settings.eta if eta is None else eta, velocity=settings.velocity)
    ctrl = PIPSDP(inner, design, loop_gain=lg, ratio=settings.ratio, hold=settings.hold, max_accel=settings.max_accel)
    return simulate_control(ctrl, r, q0=0.0, dt=settings.dt, drive=drive)


def hand_tuned_loop_gain(settings, model, design, r):
    lgs = jnp.asarray(settings.lg_grid)

    def peak(lg):
        sim = cascade_simulation(settings, model, design, lg, r)
        return jnp.max(jnp.abs(sim.dq))

    peaks = np.nan_to_num(np.asarray(jax.jit(jax.vmap(peak))(lgs)), nan=np.inf)
    return last_passing(settings.lg_grid, peaks <= settings.v_limit), peaks
