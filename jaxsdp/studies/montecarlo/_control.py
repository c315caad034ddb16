"""Monte Carlo robustness of the SDP controllers (paper section 4: "relatively robust").

The controllers are designed once on the nominal model (`nominal_design`:
SDP-PD on the identified friction, PIP-LQ on the SRIVC model of that loop,
the hand-tuned loop gain); the plant is then drawn n times and each draw
runs the three closed loops (the benchmark's linear PD, SDP-PD, PIP-SDP)
for a step. With `drive="ideal"` (default, the paper's setting) the drive
has no delay and no saturation, so that the peak force can be held against
the real drive's saturation; with `drive="real"` the loops run through the
real drive (one-sample delay, force saturation), the SDP-PD and the
PIP-SDP's inner loop at the largest wn the delay allows on the nominal
model (`NominalDesign.wn_real`), as the control study's real-drive runs.
Draws of the asymmetric plant (M, Fv+, Fc+, Fv-, Fc-):

- `"uniform"`: each parameter uniform within +-`spread` (default 20 %) of its
  nominal value, independently;
- `"covariance"`: Gaussian with the asymmetric IDIM-LS estimate's covariance
  (the statistical uncertainty of the identification), clipped at 0.

Per draw and controller (`step_statistics`): settling time to the 2 % band
(s; inf if it never settles), overshoot (%), peak velocity (m/s) against
the 0.15 m/s limit, peak force (N) against the drive's saturation, and
stability (finite and bounded response).
"""

import pathlib

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._montecarlo import monte_carlo
from ..._runtime import x64
from ...control import (
    PIPSDP,
    REAL_DRIVE,
    SDPPD,
    ControlSettings,
    LinearPD,
    NominalDesign,
    nominal_design,
    simulate_control,
)
from ...control._metrics import AT_LIMIT_MARGIN, LIMIT_RTOL
from ...plants import AsymmetricFriction, EMPSPlant
from .._contract import Study
from .._output import fraction_pct, percentiles
from ._figures import control_figures
from ._report import control_report, control_summary, control_text
from ._shared import CONTROLLERS, ENVELOPE_STRIDE, LABELS, METRICS, PARAMETERS, run_record, sdp_pd_wn


@x64
def step_statistics(t, q, dq, force, target, *, band=0.02):
    r"""Step-response figures in JAX (vmappable): settling time, overshoot, peaks, stability.

    With $e = (q - target) / target$, the relative error of the position:

    - `settling_time_s`: time (s, from `t[0]`) after which $|e| \le$ `band`
      (a fraction, default 2 %) for good; inf if $|e| >$ `band` at the end or
      the response is unstable;
    - `overshoot_pct`: $100 \max(0, \max e)$ (%);
    - `peak_velocity`: $\max |\dot q|$ (units of `dq`, m/s for the EMPS);
    - `peak_force`: $\max |force|$ (units of `force`, N for the EMPS);
    - `stable`: $q$ finite and $|q| < 10 |target|$ throughout; `settled`:
      stable and within the band at the end.

    `t`, `q`, `dq`, `force`: (N,) time (s), position, velocity and force of
    one response; `target` the step's final value (units of `q`, not 0).
    Returns a dict of scalar arrays, so that `jax.vmap` over the responses
    gives one (runs,) array per figure.

    Example:
        >>> import jax.numpy as jnp
        >>> from jaxsdp.studies.montecarlo import step_statistics
        >>> t = jnp.linspace(0.0, 1.0, 1001)  # s
        >>> q = 0.1 * (1.0 - jnp.exp(-t / 0.05))  # m: a first-order step to 0.1 m, time constant 50 ms
        >>> s = step_statistics(t, q, jnp.gradient(q, t), 50.0 * (0.1 - q), 0.1)
        >>> round(float(s["settling_time_s"]), 3), float(s["overshoot_pct"]), bool(s["stable"])  # 0.05 ln 50 s
        (0.196, 0.0, True)
    """
    e = (q - target) / target
    outside = jnp.abs(e) > band
    N = q.shape[0]
    last = jnp.max(jnp.where(outside, jnp.arange(N), -1))
    settled = ~outside[-1]
    settling = jnp.where(settled, jnp.where(last >= 0, t[jnp.minimum(last + 1, N - 1)] - t[0], 0.0), jnp.inf)
    stable = jnp.all(jnp.isfinite(q)) & (jnp.max(jnp.abs(q)) < 10.0 * jnp.abs(target))
    return dict(
        settling_time_s=jnp.where(stable, settling, jnp.inf),
        overshoot_pct=100.0 * jnp.maximum(0.0, jnp.max(e)),
        peak_velocity=jnp.max(jnp.abs(dq)),
        peak_force=jnp.max(jnp.abs(force)),
        stable=stable,
        settled=settled & stable,
    )


def uniform_around(mean, runs: int, *, spread: float, seed: int) -> np.ndarray:
    """(runs, len(mean)) draws, each parameter uniform within +-`spread` (a fraction) of its `mean`, independently."""
    mean = np.asarray(mean, dtype=float)
    return mean * (1.0 + spread * np.random.default_rng(seed).uniform(-1.0, 1.0, (runs, mean.size)))


def draw_plants(nominal: NominalDesign, runs: int, *, draws: str, spread: float, seed: int) -> np.ndarray:
    """(runs, 5) plant parameters (M, Fv+, Fc+, Fv-, Fc-) drawn around the nominal asymmetric model."""
    mean = np.array([nominal.asymmetric[k] for k in PARAMETERS], dtype=float)
    if draws == "uniform":
        return uniform_around(mean, runs, spread=spread, seed=seed)
    if draws == "covariance":
        if nominal.asymmetric_cov is None:
            raise ValueError("`draws='covariance'` needs the asymmetric IDIM-LS covariance in the nominal design")
        rng = np.random.default_rng(seed)
        return np.maximum(rng.multivariate_normal(mean, np.asarray(nominal.asymmetric_cov), size=runs), 0.0)
    raise ValueError(f"`draws` must be 'uniform' or 'covariance'; got {draws!r}")


def _closed_loops(nominal: NominalDesign, settings: ControlSettings, drive: str):
    s = settings
    real = drive == "real"
    r_pd = jnp.full(int(round((s.t_real if real else s.t_pd) / s.dt)), s.step)
    r_c = jnp.full(int(round(s.t_cascade / s.dt)), s.step)
    sdp = SDPPD(nominal.model, wn=sdp_pd_wn(nominal, s, drive), eta=s.eta, velocity=s.velocity)
    plant_drive = REAL_DRIVE if real else None
    pip = PIPSDP(sdp, nominal.design, loop_gain=nominal.loop_gain, ratio=s.ratio, hold=s.hold, max_accel=s.max_accel)
    ctrls = dict(linear_pd=(LinearPD(), r_pd), sdp_pd=(sdp, r_pd), pip_sdp=(pip, r_c))

    def run(key, theta):
        del key  # the draws are the plants; the closed loops are noise-free
        plant = EMPSPlant(theta[0], AsymmetricFriction(theta[1], theta[2], theta[3], theta[4]))
        out = {}
        for name, (ctrl, r) in ctrls.items():
            sim = simulate_control(ctrl, r, plant=plant, q0=0.0, dt=s.dt, drive=plant_drive)
            out[name] = step_statistics(sim.t, sim.q, sim.dq, sim.force, s.step)
            if name == "pip_sdp":
                out["envelope"] = sim.q[::ENVELOPE_STRIDE]
        return out

    return run


class ControlRobustness(Study):
    """Result of `control_robustness`: the draws, per-run statistics and their summary.

    `parameters` (runs, 5) the drawn plants (`PARAMETERS`); `stats`
    controller -> metric -> (runs,) numpy; `envelope` (runs, K) PIP-SDP step
    responses every `ENVELOPE_STRIDE` samples; `statistics` controller -> metric
    -> mean/std/p05/p95 over the stable runs, plus the fractions stable,
    settled, within the velocity limit and above the drive's saturation
    (`summary()["controllers"]`, JSON-ready); `nominal` the design; `drive` ("ideal" or "real"); `draws`,
    `spread`, `seed`, `runs`, `devices`, `chunk_size`, `seconds` (the run's wall time, s, compilation included),
    `runs_per_second`; `warnings` (tuple of one-line messages).
    `timings` (s per stage, the run as `study`), `versions` (jaxsdp, jax) and
    `fast_loops`.

    **Methods:** `summary()`, `report(figures=None)`, `text()`, `figures()` (the study contract,
    `jaxsdp.studies.montecarlo.summary` and the like), `with_timings(timings)`.
    """

    parameters: np.ndarray
    stats: dict
    envelope: np.ndarray
    statistics: dict = eqx.field(static=True)
    nominal: NominalDesign
    settings: ControlSettings = eqx.field(static=True)
    drive: str = eqx.field(static=True)
    draws: str = eqx.field(static=True)
    spread: float = eqx.field(static=True)
    seed: int = eqx.field(static=True)
    runs: int = eqx.field(static=True)
    devices: int = eqx.field(static=True)
    chunk_size: int = eqx.field(static=True)
    seconds: float = eqx.field(static=True)
    runs_per_second: float = eqx.field(static=True)
    warnings: tuple = eqx.field(static=True, converter=tuple)
    timings: dict = eqx.field(default_factory=dict)
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp montecarlo --study control`, `control_summary`): the run
        (runs, devices, `seconds` s, `runs_per_second`), the draws, the SDP-PD's wn (rad/s), the nominal and drawn
        plants (M kg, Fv N s/m, Fc N), every controller's settling time (s), overshoot (%), peak velocity (m/s)
        and force (N) as mean/std/p05/p95 with its fractions, `warnings`, `timings` (s), `versions`."""
        return control_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md`, `control_report`): the draws, the warnings, the drawn plants'
        table and the step responses' table (settling s, overshoot %, peaks m/s and N); `figures` (name -> file
        name) are embedded when given."""
        return control_report(self, [pathlib.Path(name) for name in (figures or {}).values()])

    @x64
    def text(self) -> str:
        """What `jaxsdp montecarlo --study control` prints (`control_text`): the run (runs, devices, s, runs/s),
        then per controller the stable, settled and within-limit shares (%) and the settling time (s)."""
        return control_text(self)

    @x64
    def figures(self) -> dict:
        """`control_figures`: `mc_envelope` (PIP-SDP step responses, position mm against time s) and
        `mc_settling` (settling time, s, against each drawn parameter)."""
        return control_figures(self)


#: Fewer runs than this make coverage fractions and spreads noise (the binomial std of a 95 % coverage from
#: 30 runs is 4 %; from 1 run a coverage is 0 or 100 %).
MIN_RUNS = 30


def few_runs_warning(runs: int) -> list[str]:
    """A warning when `runs` is too few for the study's fractions and spreads to mean anything."""
    if runs >= MIN_RUNS:
        return []
    return [
        f"only {runs} run(s): coverages, fractions and spreads from fewer than {MIN_RUNS} runs are not meaningful "
        "(each run moves a coverage by " + f"{100 / runs:.0f} %); use 100 or more (`runs`)"
    ]


def summarise(stats: dict, *, v_limit: float, force_limit: float) -> dict:
    """controller -> {metric: {mean, std, p05, p95}, fractions}: continuous figures over the stable runs.

    `above_saturation`: share of the runs whose peak force reaches `force_limit` (with an ideal drive:
    exceeds what the real drive could give; with the real drive: saturates); `at_force_limit`: share of the
    runs "at the limit" (`jaxsdp.control._metrics.force_verdict`: peak force within `AT_LIMIT_MARGIN`, 5 %,
    below the limit, or on it: no force margin)."""
    out = {}
    for name, st in stats.items():
        ok = np.asarray(st["stable"], bool)
        entry = {m: percentiles(np.asarray(st[m], float)[ok]) for m in METRICS}
        pv, pf = np.asarray(st["peak_velocity"]), np.asarray(st["peak_force"])
        entry.update(
            stable_fraction=float(ok.mean()),
            settled_fraction=float(np.asarray(st["settled"], bool).mean()),
            within_velocity_limit=float(np.mean(ok & (pv <= v_limit))),
            above_saturation=float(np.mean(ok & (pf >= force_limit * (1 - 1e-9)))),
            at_force_limit=float(
                np.mean(ok & (pf >= (1 - AT_LIMIT_MARGIN) * force_limit) & (pf <= force_limit * (1 + LIMIT_RTOL)))
            ),
        )
        out[name] = entry
    return out


@x64
def control_robustness(
    runs: int = 1000,
    *,
    draws: str = "uniform",
    spread: float = 0.2,
    drive: str = "ideal",
    seed: int = 0,
    nominal: NominalDesign | None = None,
    settings: ControlSettings | None = None,
    chunk_size: int | None = None,
    devices=None,
    progress: bool = True,
) -> ControlRobustness:
    """Monte Carlo robustness of linear PD, SDP-PD and PIP-SDP designed on the nominal model.

    The controllers are designed once on the nominal model (`nominal`); the
    asymmetric plant (M kg, Fv+ N s/m, Fc+ N, Fv- N s/m, Fc- N) is drawn
    `runs` times around it, and each draw runs the three closed loops for
    a step (`settings.step`, m), noise-free. Per draw and controller,
    `step_statistics` gives the settling time to the 2 % band (s), the
    overshoot (%), the peak velocity (m/s, against `settings.v_limit`), the
    peak force (N, against the real drive's saturation) and stability.

    **Arguments:** `runs` (draws), `draws` ("uniform": each parameter
    uniform within +-`spread`, a fraction in (0, 1), of its nominal value;
    "covariance": Gaussian with the asymmetric IDIM-LS estimate's
    covariance, clipped at 0), `drive` ("ideal": no delay, no saturation,
    the paper's setting; "real": the real drive's one-sample delay and
    force saturation, SDP-PD and the PIP-SDP's inner loop at
    `nominal.wn_real`), `seed` (the draws), `nominal` (a `NominalDesign`;
    default `nominal_design(settings=settings)`, on the built-in EMPS data),
    `settings` (`ControlSettings`: step, wn, eta, horizons, velocity limit),
    `chunk_size`, `devices`, `progress` as `jaxsdp.monte_carlo`.

    **Returns** a `ControlRobustness` (per-run `stats`, their `statistics` over
    the stable runs, the PIP-SDP `envelope`, `warnings`).

    Example:
        >>> from jaxsdp.studies.montecarlo import control_robustness
        >>> res = control_robustness(16, progress=False)  # 16 plants within +-20 % of the nominal one
        >>> res.parameters.shape, [res.statistics[c]["stable_fraction"] for c in ("linear_pd", "sdp_pd", "pip_sdp")]
        ((16, 5), [1.0, 1.0, 1.0])
        >>> st = {c: res.statistics[c]["settling_time_s"] for c in ("linear_pd", "sdp_pd")}  # s
        >>> st["sdp_pd"]["p95"] < st["linear_pd"]["p05"]  # SDP-PD settles faster on (nearly) every plant
        True
    """
    s = ControlSettings() if settings is None else settings
    if not (isinstance(spread, (int, float)) and 0.0 < float(spread) < 1.0):
        raise ValueError(f"`spread` must lie in (0, 1); got {spread!r}")
    if drive not in ("ideal", "real"):
        raise ValueError(f"`drive` must be 'ideal' or 'real'; got {drive!r}")
    nominal = nominal_design(settings=s) if nominal is None else nominal
    if drive == "real" and not np.isfinite(nominal.wn_real):
        raise ValueError("`drive='real'`: the nominal design has no wn the drive's delay allows (`wn_real` is NaN)")
    theta = draw_plants(nominal, runs, draws=draws, spread=float(spread), seed=seed)
    out = monte_carlo(
        _closed_loops(nominal, s, drive),
        seed,
        runs,
        params=theta,
        chunk_size=chunk_size,
        devices=devices,
        progress=progress,
        desc="control robustness",
    )
    vals = out.values
    stats = {c: vals[c] for c in CONTROLLERS}
    force_limit = float(REAL_DRIVE.force_limit)
    summary = summarise(stats, v_limit=s.v_limit, force_limit=force_limit)
    warnings = few_runs_warning(runs)
    warnings += [f"nominal design: {w}" for w in nominal.warnings]  # every draw's controllers rest on it
    for c in ("sdp_pd", "pip_sdp"):
        frac = summary[c]["stable_fraction"]
        if frac < 1.0:
            warnings.append(f"{c}: unstable in {fraction_pct(1 - frac, digits=1)} of the drawn plants")
    if summary["pip_sdp"]["within_velocity_limit"] < summary["pip_sdp"]["stable_fraction"]:
        share = fraction_pct(1 - summary["pip_sdp"]["within_velocity_limit"], digits=1)
        warnings.append(f"pip_sdp: the step exceeds the {s.v_limit} m/s limit in {share} of the drawn plants")
    if drive == "ideal":  # with the real drive the force saturates at the limit by construction
        over = [
            f"{LABELS[c]} in {fraction_pct(summary[c]['above_saturation'], digits=1)} "
            f"(mean peak {summary[c]['peak_force']['mean']:.4g} N)"
            for c in CONTROLLERS
            if summary[c]["above_saturation"] > 0
        ]
        if over:
            warnings.append(
                f"infeasible on the EMPS drive (|F| <= {force_limit:g} N): the peak force exceeds the drive's limit "
                f"for {', '.join(over)} of the drawn plants (ideal drive; `drive='real'` shows them saturated)"
            )
    near = [
        f"{LABELS[c]} in {fraction_pct(summary[c]['at_force_limit'], digits=1)}"
        for c in CONTROLLERS
        if summary[c]["at_force_limit"] > 0
    ]
    if near:
        warnings.append(
            f"at the EMPS drive's limit (peak |F| within {100 * AT_LIMIT_MARGIN:g} % of {force_limit:g} N, no force "
            f"margin): {', '.join(near)} of the drawn plants" + (" (the drive saturates)" if drive == "real" else "")
        )
    return ControlRobustness(
        parameters=theta,
        stats=stats,
        envelope=np.asarray(vals["envelope"]),
        statistics=summary,
        nominal=nominal,
        settings=s,
        drive=drive,
        draws=draws,
        spread=float(spread),
        warnings=warnings,
        **run_record(out, seed),
    )
