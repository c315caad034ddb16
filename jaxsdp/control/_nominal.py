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
   noisy (white, or coloured by `ControlSettings.ident_noise_colour`),
   identified by SRIVC or RIVCBJ (`ControlSettings.estimator`) and
   discretised at the outer period.
4. PIP-LQ on that model; `hand_tuned_loop_gain`: the largest PIP-SDP loop
   gain keeping |dq| under the velocity limit (the paper's hand tuning).

`nominal_design` runs them all (`NominalDesign`); `ControlSettings` holds the
options (the paper's by default).
"""

import dataclasses
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
import scipy  # scipy.signal loads on first use

from .._checks import checked_map
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
from ..tfest._riv import MAX_NOISE_ORDER, rivcbj
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
    std), `n`, `m`: the identification experiment and model orders;
    `estimator`: "srivc" (white-noise output error) or "rivcbj" (hybrid
    Box-Jenkins, `jaxsdp.tfest.rivcbj`, also fitting a discrete ARMA noise
    model C/D of orders `noise_orders` = (nc, nd); SRIVC is then run on the
    same data for comparison); `ident_noise_colour`: None (white measurement
    noise) or a pair (C, D) of monic polynomials in z^-1 (coefficients of
    z^0, z^-1, ...; D stable) filtering the noise, rescaled to the white
    noise's std (an AR(1) noise 1/(1 - A z^-1): `((1.0,), (1.0, -A))`);
    `ratio`: outer /
    inner period (10: 100 Hz over 1 kHz); `ew`, `uw`, `xw`: PIP weights;
    `paper_lg`: the paper's loop gain; `v_limit` (m/s); `t_cascade` (s);
    `lg_grid`: loop gains tried for the hand tuning; `tune_iterations`: the
    most BFGS steps of one run of the gradient tuning (a run from each start,
    and each restart; 0: skip the tuning), `tune_starts`: its starting inner
    wn values (rad/s) besides the hand-tuned design's; `seed`: noise and excitation; `dt` (s): inner period;
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
    estimator: str = "srivc"
    noise_orders: tuple = (1, 1)
    ident_noise_colour: tuple | None = None
    ratio: int = 10
    ew: float = 10.0
    uw: float = 1.0
    xw: float = 1.0
    paper_lg: float = 5.0
    v_limit: float = 0.15
    t_cascade: float = 3.0
    lg_grid: tuple = tuple(float(g) for g in np.geomspace(1e-3, 10.0, 81))
    tune_iterations: int = 200
    tune_starts: tuple = (10.0, 30.0)
    seed: int = 0
    dt: float = 1e-3
    hold: str = "linear"
    max_accel: float | None = CASCADE_ACCEL

    def __post_init__(self):
        if self.estimator not in ESTIMATORS:
            raise ValueError(f"`estimator` must be one of {', '.join(ESTIMATORS)}; got {self.estimator!r}")
        orders = tuple(self.noise_orders) if isinstance(self.noise_orders, (tuple, list)) else ()
        if len(orders) != 2 or not all(
            isinstance(k, (int, np.integer)) and not isinstance(k, bool) and 0 <= k <= MAX_NOISE_ORDER for k in orders
        ):
            raise ValueError(
                f"`noise_orders` must be two integers (nc, nd) in 0..{MAX_NOISE_ORDER}; got {self.noise_orders!r}"
            )
        object.__setattr__(self, "noise_orders", tuple(int(k) for k in orders))
        if self.ident_noise_colour is not None:
            object.__setattr__(self, "ident_noise_colour", _noise_colour(self.ident_noise_colour))


#: The estimators of the closed-loop identification (`ControlSettings.estimator`).
ESTIMATORS = ("srivc", "rivcbj")


def _noise_colour(colour) -> tuple:
    """`ControlSettings.ident_noise_colour` checked: ((C...), (D...)) monic, finite, D stable; else ValueError."""
    what = "`ident_noise_colour` must be None or a pair (C, D) of monic polynomials in z^-1, D stable"
    try:
        c, d = (tuple(float(v) for v in np.atleast_1d(np.asarray(poly, dtype=float))) for poly in colour)
    except (TypeError, ValueError):
        raise ValueError(f"{what}; got {colour!r}") from None
    if not (c and d and c[0] == 1.0 and d[0] == 1.0 and np.all(np.isfinite(c + d))):
        raise ValueError(f"{what}; got {colour!r}")
    if len(d) > 1 and np.max(np.abs(np.roots(d))) >= 1:
        raise ValueError(f"{what}: the roots of D must lie inside the unit circle; got D = {list(d)}")
    return (c, d)


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


@x64
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
    physical, fit = fits.checks(cap="`max_nvr` of emps_study; the control study identifies with its defaults")
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
    PIP-LQ design of the identified model of the SDP-PD loop; `loop_gain`: the
    hand-tuned PIP-SDP loop gain; `asymmetric`, `asymmetric_cov`: the
    asymmetric IDIM-LS plant (M, Fv_pos, Fc_pos, Fv_neg, Fc_neg) and its
    covariance; `srivc`: the identified loop model (`srivc_experiment`'s dict,
    by SRIVC or RIVCBJ: its `estimator`); `warnings`; `wn_real`:
    the largest SDP-PD wn (rad/s) keeping the overshoot under 2 % with the
    drive's one-sample delay (what the real drive allows). The evidence the
    choices rest on: `experiment` (the identification experiment: `t`,
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
    r"""The designs on the nominal model that `control_study` runs and the Monte Carlo control study holds
    fixed: friction (from `friction`, else identified from `data`, built-in when None) -> SDP-PD model, the
    largest wn the drive's delay allows, SRIVC (or RIVCBJ, `settings.estimator`) of the SDP-PD loop, PIP-LQ,
    and the largest loop gain keeping $|\dot q| \le$ `v_limit`; `settings` a `ControlSettings`.

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
        warnings.append(ident_warning(ident))
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


def ident_warning(ident: dict) -> str:
    """The warning for an identification (`srivc_experiment`'s dict) that did not converge, naming its estimator."""
    if ident.get("estimator", "srivc") == "srivc":
        return SRIVC_WARNING
    name = ident["estimator"].upper()
    text = f"{name} did not converge on the closed-loop experiment ({ident.get('reason')}): the PIP design rests on it"
    c, d = ident.get("c"), ident.get("d")
    if c is not None and d is not None and len(c) == len(d) > 1 and np.max(np.abs(np.subtract(c, d))) < 0.1:
        text += (
            f"; its noise model's zeros and poles nearly cancel (C = {_rounded(c)}, D = {_rounded(d)}): the noise "
            "looks white, and C/D is then not identifiable (smaller noise orders, or SRIVC, fit it)"
        )
    return text


def _rounded(poly) -> list:
    return [round(float(v), 3) for v in poly]


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

    os_ = np.asarray(checked_map(overshoot, wns))  # one program, no host callback: cached across runs
    best = last_passing(settings.wn_grid, np.nan_to_num(os_, nan=np.inf) < MAX_OVERSHOOT)
    return best, os_


def srivc_experiment(model, settings):
    """The closed-loop identification experiment of the SDP-PD loop and its continuous-time model.

    Random steps r (m, levels uniform in +-`step`, held `ident_hold` s) drive
    the SDP-PD loop for `ident_seconds` s at `dt`; the measured position is
    y = x + `ident_noise` std(x) e (m), e standard white noise, or that noise
    filtered by C/D (`ident_noise_colour`) and rescaled to its std. The model
    B(s)/A(s) (orders `n`, `m`, from r to y) is fitted by `settings.estimator`:
    `srivc`, or `rivcbj` with a noise model C/D of orders `noise_orders`, and
    then also by SRIVC on the same data (`compare_srivc`).

    Returns `(ident, experiment)`: `ident` a dict of plain numbers: `estimator`,
    `num`, `den`, `num_se`, `den_se` (B(s), A(s) highest power first; A
    monic, s in 1/s), `discrete_num`, `discrete_den` (ZOH at
    `discrete_dt` = `ratio` dt s), `iterations`, `converged`, `noise_pct` (%),
    `fit_pct` (%), `n`, `m`; `noise_colour` ({c, d}) when the noise is
    coloured; with rivcbj also `nc`, `nd`, `c`, `d`, `c_se`, `d_se` (C(z^-1),
    D(z^-1) at `dt`), `rt2`, `yic`, `reason` and `compare_srivc` (num, den,
    num_se, den_se, iterations, converged, fit_pct of SRIVC). `experiment`:
    `t` (s), `r`, `y`, `y_model` (m).
    """
    rng = np.random.default_rng(settings.seed)
    hold = max(1, int(round(settings.ident_hold / settings.dt)))
    n = int(round(settings.ident_seconds / settings.dt))
    levels = rng.uniform(-settings.step, settings.step, n // hold + 1)
    r = np.repeat(levels, hold)[:n]
    ctrl = SDPPD(model, wn=settings.wn, eta=settings.eta, velocity=settings.velocity)
    sim = simulate_control(ctrl, r, q0=0.0, dt=settings.dt)
    x = np.asarray(sim.q)
    e = rng.normal(size=n)
    colour = settings.ident_noise_colour
    if colour is not None:
        coloured = scipy.signal.lfilter(colour[0], colour[1], e)
        e = coloured * (np.std(e) / np.std(coloured))
    y = x + settings.ident_noise * np.std(x) * e
    white = srivc(y, r, settings.dt, n=settings.n, m=settings.m)
    if settings.estimator == "rivcbj":
        nc, nd = settings.noise_orders
        res = rivcbj(y, r, settings.dt, n=settings.n, m=settings.m, nc=nc, nd=nd)
    else:
        res = white
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
        fit_pct=_fit_pct(res, y),
        n=settings.n,
        m=settings.m,
        estimator=settings.estimator,
    )
    if colour is not None:
        out["noise_colour"] = dict(c=list(colour[0]), d=list(colour[1]))
    if settings.estimator == "rivcbj":
        out.update(
            nc=nc,
            nd=nd,
            **{k: np.asarray(getattr(res, k)).tolist() for k in ("c", "d", "c_se", "d_se")},
            rt2=float(res.rt2),
            yic=float(res.yic),
            reason=str(res.reason),
            compare_srivc=dict(
                estimator="srivc",
                **{k: np.asarray(getattr(white, k)).tolist() for k in ("num", "den", "num_se", "den_se")},
                iterations=int(white.iterations),
                converged=bool(white.converged),
                fit_pct=_fit_pct(white, y),
            ),
        )
    return out, dict(t=np.asarray(sim.t), r=r, y=y, y_model=np.asarray(res.y_model))


def _fit_pct(res, y) -> float:
    """100 (1 - sum (y_model - y)^2 / sum (y - mean y)^2): the simulated model's fit (%)."""
    return float(100 * (1 - np.sum((np.asarray(res.y_model) - y) ** 2) / np.sum((y - y.mean()) ** 2)))


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

    peaks = np.nan_to_num(np.asarray(checked_map(peak, lgs)), nan=np.inf)
    return last_passing(settings.lg_grid, peaks <= settings.v_limit), peaks
