"""Monte Carlo of robot identification: are the base parameters' estimates unbiased and their intervals honest?

Each run draws a robot around a description (each link's ten inertial
parameters scaled by one factor, so that the body stays physical; viscous
and Coulomb friction scaled; all uniform within +-`spread`), simulates it
following one exciting trajectory under a fixed joint PD controller
(`RobotExperiment`, white torque noise), and identifies it with the robot
pipeline (`RobotPipeline`: IDIM-LS of every joint at once). The study is
`monte_carlo` over `run(key, draw) = pipeline(experiment(key, robot(draw)))`:
it holds no estimation code of its own.

Per base parameter the summary gives, against each run's true base values
(the drawn robot's full parameters mapped by the model's base combinations):
the bias, the spread of the error, the mean stated standard error over that
spread (`se_to_spread`), and the coverage of the stated 95 % intervals.
"""

import dataclasses
import pathlib

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._idim.estimators import IDIMIV
from ..._montecarlo import monte_carlo
from ..._runtime import x64
from ..._signal.preprocess import Butterworth, Preprocessing
from ...plants.robot._defaults import processing_defaults
from ...plants.robot._excitation import optimise_excitation
from ...plants.robot._pipeline import RobotExperiment, RobotPipeline
from ...plants.robot._serial import SerialRobot
from ...plants.robot._sim import simulate_robot, with_armature
from ...plants.robot._stacked import full_parameters, robot_model
from .._contract import Study
from .._output import fraction_pct, percentiles
from ._control import few_runs_warning
from ._robot_report import robot_figures, robot_report, robot_summary, robot_text
from ._shared import MIN_COVERAGE, Z95, run_record


@dataclasses.dataclass(frozen=True)
class RobotSettings:
    """Options of `robot_robustness`.

    `spread`: the drawn robots' parameters uniform within +- this fraction of the description's (inertial parameters
    by one factor per link, friction per joint); `torque_noise`: white noise on the logged torques, as a fraction of
    the standard deviation of each joint's torque on the nominal robot; `periods` of the exciting trajectory
    (`harmonics` per joint, base frequency `f0` Hz, optimised for `excite_steps` gradient steps); `dt` (s) the
    sample time; `cutoff_hz` (Hz), `decimate`, `drop` (samples at each end): the processing, None for the robot
    study's default on the reference trajectory (`processing_defaults`: the cut-off and the decimation from the
    sampling rate, the drop from the filter's start-up at the trajectory's ends; 40 Hz and 2 by default, where the
    TX40's intervals were measured honest; at 1 kHz the study's own cut-off and decimation cover less well);
    `rest_fraction`: rows where a joint moves slower than this fraction of its peak speed are left out (0.05 here,
    the pipeline's default 0.01: the low-pass filter smears each Coulomb step over about $1/(2 f_c)$ around a
    reversal, and at 0.01 those rows bias the joints' friction by more than a standard error); `joint_weights`: each
    joint's rows weighted by its residual standard deviation (`RobotPipeline`'s weighted least squares; True here:
    the joints' noise levels differ tenfold); `centred_torque`: the logged torque at $t_k$ is the mean of the
    torques held on either side (`RobotExperiment.centred`; False: the held command, half a sample off the motion).
    """

    spread: float = 0.1
    torque_noise: float = 0.01
    periods: int = 1
    harmonics: int = 5
    f0: float = 0.1
    excite_steps: int = 50
    dt: float = 1e-3
    cutoff_hz: float | None = 40.0
    decimate: int | None = 2
    drop: int | None = None
    rest_fraction: float = 0.05
    joint_weights: bool = True
    centred_torque: bool = True
    disturbance: float = 0.0
    iv: bool = False

    def __post_init__(self):
        if not isinstance(self.iv, bool):
            raise ValueError(f"`iv` must be True or False; got {self.iv!r}")
        if isinstance(self.disturbance, bool) or not isinstance(self.disturbance, (int, float)):
            raise ValueError(f"`disturbance` must be a number >= 0; got {self.disturbance!r}")
        if not 0.0 <= self.disturbance < np.inf:
            raise ValueError(f"`disturbance` must be a finite number >= 0; got {self.disturbance!r}")
        for name in ("spread", "torque_noise", "rest_fraction"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v < 1.0:
                raise ValueError(f"`{name}` must be a fraction in [0, 1); got {v!r}")
        for name in ("periods", "harmonics", "excite_steps", "decimate", "drop"):
            v = getattr(self, name)
            if v is None and name in ("decimate", "drop"):
                continue
            if isinstance(v, bool) or not isinstance(v, int) or v < (0 if name in ("excite_steps", "drop") else 1):
                raise ValueError(f"`{name}` must be a non-negative integer (periods, harmonics, decimate >= 1)")
        for name in ("f0", "dt", "cutoff_hz"):
            v = getattr(self, name)
            if v is None and name == "cutoff_hz":
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v < np.inf:
                raise ValueError(f"`{name}` must be a finite number > 0; got {v!r}")


class RobotRobustness(Study):
    """Result of `robot_robustness`: `names` the base parameters, `truth` (runs, rank) each run's true base values,
    `theta`, `se` (runs, rank) the estimates and their stated standard errors, `statistics` (per base parameter
    bias, spread, coverage; the coverage over the parameters, `cond`, `rank`, `joints`: what `summary()` adds to
    the run's figures), `warnings` (tuple of one-line messages), `settings`, `seed`, `runs`, `devices`,
    `chunk_size`, `seconds` (the run's wall time, s, compilation included), `runs_per_second`, `cond` (the
    trajectory's condition number), `source` (the robot described), `timings` (s per stage), `versions`,
    `fast_loops`.

    **Methods:** `summary()`, `report(figures=None)`, `text()`, `figures()` (the study contract,
    `jaxsdp.studies.montecarlo.summary` and the like), `with_timings(timings)`.
    """

    names: tuple = eqx.field(static=True)
    truth: np.ndarray
    theta: np.ndarray
    se: np.ndarray
    statistics: dict = eqx.field(static=True)
    warnings: tuple = eqx.field(static=True, converter=tuple)
    settings: RobotSettings = eqx.field(static=True)
    seed: int = eqx.field(static=True)
    runs: int = eqx.field(static=True)
    devices: int = eqx.field(static=True)
    chunk_size: int = eqx.field(static=True)
    seconds: float = eqx.field(static=True)
    runs_per_second: float = eqx.field(static=True)
    cond: float = eqx.field(static=True)
    source: str = eqx.field(static=True, default="built-in TX40")
    timings: dict = eqx.field(default_factory=dict)
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)
    iv_theta: np.ndarray | None = None
    iv_se: np.ndarray | None = None

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp montecarlo --study robot`, `robot_summary`): the run (runs,
        devices, `seconds` s, `runs_per_second`), settings, the robot, per base parameter the estimates'
        mean/std/p05/p95, `bias`, `error_std` (units of the parameter), `mean_reported_se`, `se_to_spread`,
        `coverage_95` (fraction), `bias_in_se`; the coverage over the parameters; `warnings`, `timings` (s)."""
        return robot_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md`, `robot_report`): the draws and the trajectory, the warnings, the
        base parameters' table (bias, error std, mean se, bias/se, se/spread, coverage %); `figures` (name ->
        file name) are embedded when given."""
        return robot_report(self, [pathlib.Path(name) for name in (figures or {}).values()])

    @x64
    def text(self) -> str:
        """What `jaxsdp montecarlo --study robot` prints (`robot_text`): the run (runs, devices, s, runs/s), the
        coverage (%) of the 95 % intervals over the base parameters, the lowest five."""
        return robot_text(self)

    @x64
    def figures(self) -> dict:
        """`mc_robot_coverage`: each base parameter's coverage (%) of the stated 95 % intervals and its bias in
        stated standard errors."""
        return robot_figures(self)


def drawn_robot(robot: SerialRobot, draw) -> SerialRobot:
    """`robot` with each link's inertial parameters scaled by `draw[:n]`, Fv by `draw[n:2n]`, Fc by `draw[2n:]`."""
    n = robot.n
    return eqx.tree_at(
        lambda r: (r.inertial, r.Fv, r.Fc),
        robot,
        (robot.inertial * draw[:n, None], robot.Fv * draw[n : 2 * n], robot.Fc * draw[2 * n :]),
    )


def summarise_robot(names, truth, theta, se, *, label: str = "IDIM-LS") -> tuple[dict, list]:
    """Per base parameter: bias, error spread, mean stated se, se / spread, coverage; overall coverage (`label`
    names the estimator in the warnings)."""
    ok = np.all(np.isfinite(theta), axis=1) & np.all(np.isfinite(se), axis=1)
    err = theta[ok] - truth[ok]
    params = {}
    for j, name in enumerate(names):
        e, s = err[:, j], se[ok, j]
        entry = percentiles(theta[ok, j])
        spread = float(e.std())
        entry.update(
            bias=float(e.mean()),
            error_std=spread,
            mean_reported_se=float(s.mean()),
            se_to_spread=float(s.mean() / spread) if spread > 0 else None,
            coverage_95=float(np.mean(np.abs(e) <= Z95 * s)),
            bias_in_se=float(e.mean() / s.mean()) if s.mean() > 0 else None,
        )
        params[name] = entry
    cover = np.array([p["coverage_95"] for p in params.values()])
    summary = dict(
        parameters=params,
        coverage_95=dict(median=float(np.median(cover)), min=float(cover.min()), max=float(cover.max())),
        below_min_coverage=[k for k, p in params.items() if p["coverage_95"] < MIN_COVERAGE],
        failed_runs=int((~ok).sum()),
    )
    warnings = few_runs_warning(int(theta.shape[0])) if label == "IDIM-LS" else []
    if summary["failed_runs"]:
        warnings.append(f"{label}: no finite estimate in {summary['failed_runs']} run(s) (left out of the statistics)")
    low = summary["below_min_coverage"]
    if low:
        worst = min(low, key=lambda k: params[k]["coverage_95"])
        warnings.append(
            f"{label}: the stated 95 % intervals of {len(low)} of {len(names)} base parameters cover the truth in "
            f"fewer than {100 * MIN_COVERAGE:.0f} % of the runs (worst {worst}: "
            f"{fraction_pct(params[worst]['coverage_95'])}, bias {params[worst]['bias_in_se']:+.1f} stated se): "
            "their standard errors understate the error (a bias of the processing or of the model, not noise)"
        )
    return summary, warnings


@x64
def robot_robustness(
    runs: int = 1000,
    *,
    robot: SerialRobot | None = None,
    source: str | None = None,
    seed: int = 0,
    settings: RobotSettings | None = None,
    chunk_size: int | None = None,
    devices=None,
    progress: bool = True,
) -> RobotRobustness:
    """Monte Carlo of robot identification: robots drawn around `robot`, simulated, identified by IDIM-LS.

    **Arguments:** `runs`; `robot` (a `SerialRobot`; default the built-in TX40, `jaxsdp.plants.tx40_robot`),
    `source` (its description in the report, e.g. the URDF file's name);
    `seed` (the draws and the noise); `settings` (`RobotSettings`: spread, noise, trajectory, processing);
    `chunk_size`, `devices`, `progress` as `jaxsdp.monte_carlo`.

    **Returns** a `RobotRobustness` (per-run estimates, `statistics`: bias, spread, se / spread and coverage of
    every base parameter; `warnings`).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.studies.montecarlo import RobotSettings, robot_robustness
        >>> arm = SerialRobot.from_mdh([[0, 0, 0, 0], [0, 0.4, 0, 0]], inertias=[(3.0, [0.2, 0, 0], np.zeros(6)),
        ...                            (1.5, [0.15, 0.02, 0], [0.01, 0, 0, 0.01, 0, 0.01])], Fv=1.0, Fc=0.5)
        >>> res = robot_robustness(4, robot=arm, settings=RobotSettings(excite_steps=10), progress=False)
        >>> res.theta.shape == res.truth.shape == (4, len(res.names))
        True
    """
    from ...plants.robot._tx40 import tx40_robot

    s = RobotSettings() if settings is None else settings
    if not isinstance(s, RobotSettings):
        raise ValueError(f"`settings` must be a RobotSettings; got {type(s).__name__}")
    robot_given = robot
    robot = tx40_robot() if robot is None else robot
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    model = robot_model(robot)
    excitation = optimise_excitation(model, harmonics=s.harmonics, f0=s.f0, max_steps=s.excite_steps, seed=seed)
    t = np.arange(0.0, s.periods / s.f0, s.dt)
    qr = jnp.asarray(excitation.excitation.states(t)[0])
    nominal = with_armature(robot, qr[0])
    model = robot_model(nominal)
    tau = np.asarray(simulate_robot(nominal, qr, dt=s.dt).tau)
    noise = jnp.asarray(s.torque_noise * tau.std(axis=0))
    disturbance = jnp.asarray(s.disturbance * tau.std(axis=0)) if s.disturbance > 0 else None
    experiment = RobotExperiment(
        qr, controller=nominal, torque_noise=noise, dt=s.dt, centred=s.centred_torque, disturbance=disturbance
    )
    processing = processing_defaults(s.dt, np.asarray(qr), cutoff_hz=s.cutoff_hz, decimate=s.decimate, drop=s.drop)
    options = dict(
        preprocessing=Preprocessing(
            Butterworth(processing.cutoff_hz), drop=processing.drop, decimate=processing.decimate
        ),
        rest_fraction=s.rest_fraction,
        joint_weights=s.joint_weights,
    )
    pipeline = RobotPipeline.of(model, **options)
    iv = RobotPipeline.of(model, **options, iv=IDIMIV(), loop=experiment) if s.iv else None
    n = robot.n
    draws = 1.0 + s.spread * np.random.default_rng(seed).uniform(-1.0, 1.0, (runs, 3 * n))

    def run(key, draw):
        logs = experiment(key, drawn_robot(nominal, draw))
        fit = pipeline(logs)
        out = dict(theta=fit.theta, se=fit.std)
        if s.iv:
            ivf = iv(logs)
            out.update(iv_theta=ivf.theta, iv_se=ivf.std, iterations=ivf.idim_iv.iterations,
                       converged=ivf.idim_iv.converged)  # fmt: skip
        return out

    out = monte_carlo(
        run, seed, runs, params=draws, chunk_size=chunk_size, devices=devices, progress=progress, desc="robot"
    )
    truth = np.stack([model.base.values(full_parameters(drawn_robot(nominal, jnp.asarray(d)))) for d in draws])
    theta, se = np.asarray(out.values["theta"], float), np.asarray(out.values["se"], float)
    summary, warnings = summarise_robot(model.names, truth, theta, se)
    iv_theta = iv_se = None
    if s.iv:
        iv_theta, iv_se = np.asarray(out.values["iv_theta"], float), np.asarray(out.values["iv_se"], float)
        iv_summary, iv_warnings = summarise_robot(model.names, truth, iv_theta, iv_se, label="IDIM-IV")
        iterations, converged = np.asarray(out.values["iterations"]), np.asarray(out.values["converged"], bool)
        iv_summary.update(
            iterations=dict(median=float(np.median(iterations)), max=int(iterations.max())),
            not_converged=int((~converged).sum()),
        )
        if iv_summary["not_converged"]:
            iv_warnings.append(
                f"IDIM-IV: {iv_summary['not_converged']} of {runs} run(s) stopped at max_iter without converging"
            )
        summary["iv"] = iv_summary
        warnings += iv_warnings
    few = len(few_runs_warning(runs))
    warnings = [*warnings[:few], *processing.warnings, *warnings[few:]]  # after the few-runs warning
    summary.update(
        cond=float(excitation.cond),
        rank=int(model.rank),
        joints=int(n),
        processing=dict(cutoff_hz=processing.cutoff_hz, decimate=processing.decimate, drop=processing.drop),
    )
    return RobotRobustness(
        names=tuple(model.names),
        truth=truth,
        theta=theta,
        se=se,
        statistics=summary,
        iv_theta=iv_theta,
        iv_se=iv_se,
        warnings=warnings,
        settings=s,
        cond=float(excitation.cond),
        source=("built-in TX40" if robot_given is None else "the robot given") if source is None else str(source),
        **run_record(out, seed),
    )
