"""The excitation study: an exciting trajectory for a robot, optimised by gradient and checked by identification.

`excitation_study` (the back end of `jaxsdp robot --excite`) optimises a
Fourier trajectory per joint (`optimise_excitation`: log condition number of
the stacked base regressor over one period, within the joint limits), then
checks what it buys: the robot of the description is simulated following the
trajectory under joint PD control (`simulate_robot`, 1 kHz, white torque
noise of 1 % of each joint's rms torque) and identified by IDIM-LS on those
logs (`robot_idim_ls`); each base parameter is compared with the
description's value in its own standard errors.

The check's plant is the description's rigid body with its own armature and
friction; where a joint has no armature (`Ia = 0`, as in URDF files, which
hold none) a small one (2 % of the largest diagonal entry of the mass matrix
at the start) keeps the simulated mass matrix invertible; the identification
then recovers it as well.
"""

from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._records import JointLogs
from ..._runtime import x64
from ...plants.robot._excitation import ExcitationResult, optimise_excitation
from ...plants.robot._robot_idim import RobotIDIM, robot_idim_ls
from ...plants.robot._serial import SerialRobot
from ...plants.robot._sim import simulate_robot, with_armature
from ...plants.robot._stacked import robot_model
from .._contract import Study, fast_loops, versions
from .._output import StageTimer
from ._excite_report import excitation_markdown, excitation_summary, excitation_text, fig_trajectory

#: Stages of `excitation_study` (keys of `timings`, besides `total`).
EXCITE_STAGES = ("optimise", "simulate", "identify")
#: A base parameter is not recovered when its estimate is more than `RECOVERY_Z` standard errors from the
#: description's value and the difference moves the torques by more than `RECOVERY_SHARE` % of their norm (below
#: that, the systematic error of the closed-loop simulation and the Coulomb law's regularisation, not the design).
RECOVERY_Z = 4.0
RECOVERY_SHARE = 0.2
#: Torque noise of the check, relative to each joint's rms torque.
CHECK_NOISE = 0.01
#: The check's sample time (s); joints without armature get `plants.robot._sim.ARMATURE_FRACTION` of max diag M.
CHECK_DT = 1e-3


class ExcitationStudy(Study):
    """All results of `excitation_study`.

    **Fields:** `result` (`ExcitationResult`: the optimised `excitation`, the
    random `start`, `cond`, `cond_start`, `steps`, `limits`); `check` (the
    `RobotIDIM` on the simulated logs, or None); `nominal` (rank,) the
    description's base parameter values (with the check's armature);
    `names`; `source`; `settings`; `warnings`; `findings`; `timings`;
    `versions`; `fast_loops`.
    """

    result: ExcitationResult
    check: RobotIDIM | None
    nominal: np.ndarray
    names: tuple = eqx.field(static=True)
    source: str = eqx.field(static=True)
    settings: dict = eqx.field(static=True)
    warnings: tuple = eqx.field(static=True, default=())
    findings: tuple = eqx.field(static=True, default=())
    timings: dict = eqx.field(static=True, default_factory=dict)
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)

    @x64
    def recovery(self) -> list[dict]:
        """Per base parameter: `name`, `nominal`, `estimate`, `se`, `z` = (estimate - nominal) / se, `torque_share`
        = 100 |estimate - nominal| ||X_i|| / ||y|| (%: how much the difference moves the torques it fits)."""
        return _recovery(self.check, self.nominal)

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp robot --excite`): `condition_number` (start and
        optimised), `trajectory` (f0 Hz; per joint the Fourier coefficients, range rad, peak velocity rad/s and
        acceleration rad/s^2), `limits`, `recovery` (z, torque share %), `warnings`, `findings`, `settings`,
        `timings` (s), `versions` (`excitation_summary`)."""
        return excitation_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md` of `jaxsdp robot --excite`): warnings, findings, the trajectory and
        its limits (rad, rad/s, rad/s^2), the simulated check's recovery table, the figures (name -> file name,
        linked when given) and the timings (s)."""
        return excitation_markdown(self, list(dict(figures or {}).values()))

    @x64
    def text(self) -> str:
        """What `jaxsdp robot --excite` prints: the condition numbers (random start, optimised), the recovery
        table of the simulated check (z, torque share %) and its findings; the warnings are printed once, on
        stderr, by the command."""
        return excitation_text(self)

    @x64
    def figures(self) -> dict:
        """name -> matplotlib Figure: `trajectory` (one period of each joint's position rad with its limits,
        velocity rad/s and acceleration rad/s^2, `fig_trajectory`)."""
        return {"trajectory": fig_trajectory(self)}


def _recovery(check, nominal) -> list[dict]:
    if check is None:
        return []
    r = check.result
    th, se = np.asarray(r.theta, dtype=float), np.asarray(r.std, dtype=float)
    z = np.where(se > 0, (th - nominal) / np.where(se > 0, se, 1.0), np.inf)
    mov = np.asarray(check.moving)
    X = np.asarray(check.X)[mov]  # (rows used, rank)
    y = np.asarray(check.y)[mov]
    share = 100 * np.abs(th - nominal) * np.linalg.norm(X, axis=0) / np.linalg.norm(y)
    return [
        {"name": k, "nominal": float(n), "estimate": float(v), "se": float(s), "z": float(zz), "torque_share": float(c)}
        for k, n, v, s, zz, c in zip(r.names, nominal, th, se, z, share)
    ]


def _simulate(robot, ex, *, periods, seed) -> JointLogs:
    t = np.arange(0.0, periods / ex.f0, CHECK_DT)
    qr = np.asarray(ex.states(t)[0])
    sim = simulate_robot(robot, qr, dt=CHECK_DT)
    tau = np.asarray(sim.tau)
    if not np.isfinite(tau).all() or not np.isfinite(np.asarray(sim.q)).all():
        raise ValueError("the simulated robot diverged following the trajectory; check the description's inertias")
    rng = np.random.default_rng(seed)
    tau = tau + CHECK_NOISE * tau.std(axis=0) * rng.normal(size=tau.shape)
    joints = tuple(range(1, robot.n + 1))
    return JointLogs(
        q=sim.q, tau=jnp.asarray(tau), t=jnp.asarray(t), dt=CHECK_DT, joints=joints, source="sim", converted="none"
    )


def _identify(logs, model):
    return robot_idim_ls(logs, model, preprocessing=dict(cutoff_hz=40.0, decimate=2, drop=200))


def _warnings(res: ExcitationResult, study_rows, max_steps) -> list[str]:
    out = []
    if res.cond > 1e3:
        out.append(
            f"the optimised condition number is still {res.cond:.3g}: some base parameters stay poorly excited "
            "(more harmonics, wider limits or a longer period)"
        )
    bad = [r["name"] for r in study_rows if abs(r["z"]) > RECOVERY_Z and r["torque_share"] > RECOVERY_SHARE]
    if bad:
        out.append(
            f"{len(bad)} base parameter(s) not recovered on the simulated check (more than {RECOVERY_Z:g} standard "
            f"errors off, moving the torques by more than {RECOVERY_SHARE:g} %: {', '.join(bad)})"
        )
    return out


class ExcitationDesign(eqx.Module):
    """The exciting trajectory's design, the options of `optimise_excitation` that `excitation_study` sets.

    `harmonics` per joint, `f0` (Hz: one period is 1/f0 s), `samples` per period (the grid on which the condition
    number is computed), `max_steps` (BFGS steps), `acceleration_limits` ((n,) rad/s^2, or None: 10); the
    position and velocity limits are the description's.
    """

    harmonics: int = eqx.field(static=True, default=5)
    f0: float = eqx.field(static=True, default=0.1)
    samples: int = eqx.field(static=True, default=100)
    max_steps: int = eqx.field(static=True, default=100)
    acceleration_limits: object = eqx.field(static=True, default=None)

    def __check_init__(self):
        for name in ("harmonics", "samples", "max_steps"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"`{name}` must be a positive int; got {v!r}")
        if isinstance(self.f0, bool) or not isinstance(self.f0, (int, float)) or not 0 < self.f0 < np.inf:
            raise ValueError(f"`f0` must be a frequency > 0 (Hz); got {self.f0!r}")


@x64
def excitation_study(
    robot: SerialRobot,
    *,
    joints=None,
    design: ExcitationDesign | None = None,
    check: bool = True,
    periods: int = 2,
    seed: int = 0,
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> ExcitationStudy:
    """Optimise an exciting trajectory for `robot` and check it by identifying the simulated robot on it.

    **Arguments:** `robot` (`SerialRobot`); `joints` (rows of the regressor
    whose condition number is minimised, default all); `design`
    (`ExcitationDesign`: harmonics, base frequency, samples per period,
    steps, acceleration limits; None for its defaults), `seed` (random
    start, check noise): see `optimise_excitation` (position and velocity
    limits are the description's); `check`: simulate and identify over
    `periods` periods; `progress`: callback with each stage name
    (`EXCITE_STAGES`).

    **Returns:** an `ExcitationStudy`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.studies.robot import ExcitationDesign, excitation_study
        >>> arm = SerialRobot.from_mdh([[0, 0, 0, 0], [0, 0.4, 0, 0]], inertias=[(3.0, [0.2, 0, 0], np.zeros(6)),
        ...                            (1.5, [0.15, 0.02, 0], [0.01, 0, 0, 0.01, 0, 0.01])], Fv=1.0, Fc=0.5)
        >>> design = ExcitationDesign(harmonics=3, f0=0.2, samples=40, max_steps=20)
        >>> s = excitation_study(arm, design=design, periods=1)
        >>> bool(s.result.cond < s.result.cond_start), max(abs(r["z"]) for r in s.recovery()) < 4
        (True, True)
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    if not isinstance(periods, int) or periods < 1:
        raise ValueError(f"`periods` must be a positive int; got {periods!r}")
    design = ExcitationDesign() if design is None else design
    if not isinstance(design, ExcitationDesign):
        raise ValueError(f"`design` must be an ExcitationDesign; got {type(design).__name__}")
    harmonics, f0, samples, max_steps = design.harmonics, design.f0, design.samples, design.max_steps
    timed = StageTimer(progress)
    model = robot_model(robot, joints=joints)
    res = timed(
        "optimise",
        lambda: optimise_excitation(
            model,
            harmonics=harmonics,
            f0=f0,
            samples=samples,
            max_steps=max_steps,
            acceleration_limits=design.acceleration_limits,
            seed=seed,
        ),
    )
    ident, nominal = None, model.nominal
    if check:
        plant = with_armature(robot, res.excitation.q0)
        plant_model = robot_model(plant, joints=joints)
        logs = timed("simulate", lambda: _simulate(plant, res.excitation, periods=periods, seed=seed))
        ident = timed("identify", lambda: _identify(logs, plant_model))
        nominal = plant_model.nominal
    nominal = np.asarray(nominal, dtype=float)
    rows = _recovery(ident, nominal)
    findings = [
        f"Condition number of the stacked base regressor ({model.rank} base parameters) over one period: "
        f"{res.cond_start:.4g} from the random start, {res.cond:.4g} optimised ({res.cond_start / res.cond:.3g} x "
        f"lower, {res.steps} BFGS steps"
        + (", the step limit: more steps may lower it further" if res.steps >= max_steps else "")
        + "), within the joint limits."
    ]
    if rows:
        worst = max(abs(r["z"]) for r in rows)
        share = max(r["torque_share"] for r in rows)
        findings.append(
            f"The simulated robot identified on {periods} period(s) of it: every base parameter within "
            f"{worst:.2g} standard errors of the description's value, no difference moving the torques by more "
            f"than {share:.2g} %; stacked relative error {ident.stacked_relative_error:.2f} % (the "
            f"{100 * CHECK_NOISE:g} % torque noise)."
        )
    settings = {
        "harmonics": int(harmonics),
        "f0_hz": float(f0),
        "period_s": 1.0 / float(f0),
        "samples": int(samples),
        "max_steps": int(max_steps),
        "seed": int(seed),
        "joints": list(model.rows),
        "check": {"periods": int(periods), "dt_s": CHECK_DT, "torque_noise": CHECK_NOISE} if check else None,
    }
    return ExcitationStudy(
        result=res,
        check=ident,
        nominal=nominal,
        names=tuple(robot.names or tuple(f"joint{j}" for j in range(1, robot.n + 1))),
        source=source or "",
        settings=settings,
        warnings=tuple(_warnings(res, rows, max_steps)),
        findings=tuple(findings),
        timings=timed.total(),
        versions=versions(),
        fast_loops=fast_loops(),
    )
