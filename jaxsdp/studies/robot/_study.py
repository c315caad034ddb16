"""The robot study: every joint of a serial robot identified at once from its description and joint logs.

`robot_study` brings the logs to the model's convention (`Drives`), builds
the stacked full model and its base parameters (`robot_model`), runs one
IDIM-LS on every joint's rows (`robot_idim_ls`) and the multi-SDP of each
joint's residual (`robot_residual_sdp`), and collects the warnings a careful
engineer would raise (poorly excited base parameters, negative friction,
serially correlated residuals, back-fitting that did not converge) and the
findings (which joints carry structure the rigid-body model misses).
"""

from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._idim.estimators import IDIMIV
from ..._idim.trust import CAVEAT
from ..._records import JointLogs
from ..._runtime import x64
from ...data._drives import Drives
from ...plants._friction_laws import FrictionLaw
from ...plants.robot._defaults import Processing, RobotProcessing, processing_defaults
from ...plants.robot._friction import RobotFriction, robot_friction
from ...plants.robot._judgement import (
    JointVerdict,
    combine,
    description_comparison,
    judge_estimates,
    screen_channels,
    stacked_error,
    velocity_check,
)
from ...plants.robot._physical import PhysicalEstimate, physical_estimate
from ...plants.robot._pipeline import RobotExperiment
from ...plants.robot._plausibility import robot_checks
from ...plants.robot._robot_idim import RobotIDIM, robot_idim_ls, robot_residual_sdp
from ...plants.robot._serial import SerialRobot
from ...plants.robot._sim import loop_bandwidth
from ...plants.robot._stacked import robot_model
from ...plants.robot._validation import robot_cross_validation
from .._contract import Study, fast_loops, versions
from .._output import StageTimer
from ._figures import robot_figures
from ._friction_report import friction_findings, friction_warnings
from ._iv_report import iv_findings, iv_warnings
from ._report import report_markdown, sd_inflation, study_summary, text_output

#: Stages of `robot_study` (keys of `timings`, besides `total`).
STAGES = ("model", "idim_ls", "physical", "sdp", "friction", "validation")


class RobotStudy(Study):
    """All results of `robot_study`.

    **Fields:** `idim` (`RobotIDIM`: base parameters, per-joint and stacked
    relative errors, whiteness), `sdp` (joint -> `JointSDP` of its residual,
    or None), `names` (the robot's joint names), `source`, `drives` (the
    description in words), `samples`, `sample_time` (s), `resampled` (how
    an irregular time column was resampled, or None), `settings`,
    `warnings`, `findings`, `timings` (stage -> s), `versions`, `fast_loops`.

    `scale_checks`: the identified inertia and the logs' speeds and
    accelerations against the description (`jaxsdp.plants.robot._plausibility.robot_checks`:
    units, time scale); `plausible`: False when one failed (or an estimate
    has a non-physical sign): the findings then start with a caveat.

    `verdicts`: joint -> `JointVerdict` (`identifiable`, `reasons`) for every
    joint asked for (a joint whose torque channel is empty, constant or at
    the noise level, or that barely moves, is judged before the fit and left
    out of it; one whose relative error reaches 100 % or whose estimates
    have non-physical signs is judged after it, and the fit is repeated
    without it); `description`: each base parameter beside the URDF's value
    of the same combination (`description_comparison`); `validation`: the
    cross-validation in blocks of time (`robot_cross_validation`) or None;
    `processing`: the processing's values and the reason of each
    (`Processing`); `stacked_relative_error`: % over the identifiable
    joints' rows; `notes`: what the loader did (columns ignored, jittered
    stamps resampled); `physical`: the physically consistent estimate
    (`jaxsdp.plants.robot.physical_estimate` of the IDIM-LS one: every link
    a rigid body, motor inertias and friction positive) or None; `friction`:
    each motor's friction law (`jaxsdp.plants.robot.robot_friction`:
    proposed by BIC, kept where it lowers the joint's cross-validated
    error, estimated jointly with the rigid body) or None.
    """

    idim: RobotIDIM
    sdp: dict | None
    names: tuple = eqx.field(static=True)
    source: str = eqx.field(static=True)
    drives: str = eqx.field(static=True)
    samples: int = eqx.field(static=True)
    sample_time: float = eqx.field(static=True)
    settings: dict = eqx.field(static=True)
    warnings: tuple = eqx.field(static=True, default=())
    findings: tuple = eqx.field(static=True, default=())
    timings: dict = eqx.field(static=True, default_factory=dict)
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)
    resampled: str | None = eqx.field(static=True, default=None)
    scale_checks: tuple = eqx.field(static=True, default=())
    plausible: bool = eqx.field(static=True, default=True)
    verdicts: dict = eqx.field(static=True, default_factory=dict)
    description: tuple = eqx.field(static=True, default=())
    validation: dict | None = eqx.field(static=True, default=None)
    processing: Processing | None = eqx.field(static=True, default=None)
    stacked_relative_error: float | None = eqx.field(static=True, default=None)
    notes: tuple = eqx.field(static=True, default=())
    physical: PhysicalEstimate | None = None
    friction: RobotFriction | None = None

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp robot`): `joints` (per joint name: relative errors %,
        whiteness, the SDP of its residual, units, verdict), `base_parameters` (values, relative standard
        deviations %), `stacked_relative_error` (%), `rank`, `condition_number`, `cross_validation`, the checks,
        `warnings`, `findings`, `settings`, `data`, `timings` (s), `versions` (`study_summary`)."""
        return study_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md` of `jaxsdp robot`): warnings, data and settings, the per-joint
        relative errors (%), the base parameters, the cross-validation, the findings, the figures (name -> file
        name, linked when given) and the timings (s)."""
        return report_markdown(self, list(dict(figures or {}).values()))

    @x64
    def text(self) -> str:
        """What `jaxsdp robot` prints: the data line (samples, sample time s), the per-joint table (relative
        errors %) and the stacked fit (rank, relative error %, condition number); the warnings are printed
        once, on stderr, by the command."""
        return text_output(self)

    @x64
    def figures(self) -> dict:
        """name -> matplotlib Figure: `joints` (each joint's measured and fitted torque, N m, or force, N,
        against time, s) and `sdp_curves` (each residual's SDP friction curve against velocity) when the SDP
        ran (`robot_figures`)."""
        return robot_figures(self)


#: A base parameter is "not excited" when its relative standard deviation is above 100 % and its standard
#: deviation moves the stacked torque by at least this much (% of the torque's norm, rows in motion): a parameter
#: whose true value is about 0 has a large relative standard deviation however well the trajectory pins it down.
MIN_UNCERTAIN_TORQUE = 0.5


def torque_shares(idim: RobotIDIM) -> dict:
    """Base parameter -> how much its standard deviation moves the stacked torque (% of the torque's norm, rows
    in motion): 100 std_k ||X_k|| / ||y||."""
    moving = np.asarray(idim.moving)
    X, y = np.asarray(idim.X)[moving], np.asarray(idim.y)[moving]
    theta, rel = np.asarray(idim.result.theta, dtype=float), np.asarray(idim.result.rel_std, dtype=float)
    std = np.abs(theta) * rel / 100.0
    ynorm = max(float(np.linalg.norm(y)), 1e-300)
    return {k: float(100.0 * std[i] * np.linalg.norm(X[:, i]) / ynorm) for i, k in enumerate(idim.result.names)}


#: The serial-correlation warning: a residual that is not white and whose autocorrelation makes the stated standard
#: deviations optimistic by at least this factor (`sd_inflation`); a weaker correlation is a finding.
MAX_SD_INFLATION = 2.0


def correlated(idim: RobotIDIM) -> dict:
    """Joint -> `sd_inflation` of each residual the whiteness test rejects."""
    return {j: sd_inflation(w) for j, w in idim.whiteness.items() if not bool(w.white)}


def _weak_correlation(idim: RobotIDIM, names) -> list[str]:
    weak = {j: v for j, v in correlated(idim).items() if 1.0 < v < MAX_SD_INFLATION}  # x <= 1: not optimistic
    if not weak:
        return []
    return [
        f"The residual of joints {', '.join(f'{names[j - 1]} (x{v:.2g})' for j, v in weak.items())} is serially "
        f"correlated, weakly: the standard deviations are optimistic by less than a factor of {MAX_SD_INFLATION:g} "
        "(resampled stamps, the derivatives' noise or a small unmodelled effect)."
    ]


def _small_parameters(idim: RobotIDIM) -> list[str]:
    """A finding: the base parameters whose relative standard deviation is above 100 % but whose uncertainty
    does not move the torques (`MIN_UNCERTAIN_TORQUE`)."""
    shares = torque_shares(idim)
    small = [k for k in idim.poorly_excited() if shares[k] < MIN_UNCERTAIN_TORQUE]
    if not small:
        return []
    return [
        f"{len(small)} base parameters have a relative standard deviation above 100 % but one standard deviation "
        f"moves the torques by less than {MIN_UNCERTAIN_TORQUE:g} % ({', '.join(small)}): they are about zero or "
        "negligible on this trajectory, not a sign of poor excitation."
    ]


def _warnings(idim: RobotIDIM, sdp, names) -> list[str]:
    out = []
    shares = torque_shares(idim)
    poor = [k for k in idim.poorly_excited() if shares[k] >= MIN_UNCERTAIN_TORQUE]
    if poor:
        out.append(
            f"{len(poor)} of {idim.model.rank} base parameters are not excited by this trajectory (relative standard "
            f"deviation > 100 % and one standard deviation moves the torques by {MIN_UNCERTAIN_TORQUE:g} % or more: "
            f"{', '.join(poor)}); their estimates are meaningless, the fit is not affected"
        )
    strong = {j: v for j, v in correlated(idim).items() if v >= MAX_SD_INFLATION}
    if strong:
        out.append(
            f"the residual of joints {', '.join(f'{names[j - 1]} (x{v:.2g})' for j, v in strong.items())} is "
            "serially correlated: the rigid-body model leaves structure in the torque (friction's shape, "
            "flexibility, couplings) or the noise is coloured; the relative standard deviations are then optimistic "
            "by about these factors"
        )
    for j, s in (sdp or {}).items():
        if not bool(s.result.converged):
            out.append(
                f"joint {names[j - 1]}: the back-fitting of its residual's SDP did not converge (call "
                "jaxsdp.plants.robot.robot_residual_sdp with a larger max_iter)"
            )
    return out


def _verdict_warnings(verdicts: dict, names) -> list[str]:
    """One warning per joint judged not identifiable, its reasons in one sentence."""
    return [
        f"joint {names[j - 1]} is not identifiable from these logs and is left out of the fit: {'; '.join(v.reasons)}"
        for j, v in verdicts.items()
        if not v.identifiable
    ]


def _findings(idim: RobotIDIM, sdp, names, verdicts: dict, stacked: float | None) -> list[str]:
    good = [j for j in idim.relative_error if verdicts.get(j) is None or verdicts[j].identifiable]
    left = [names[j - 1] for j, v in verdicts.items() if not v.identifiable]
    rel, whole = idim.relative_error, idim.relative_error_all
    out = [
        f"{len(good)} joint(s) identified at once with {idim.model.rank} base parameters: relative error in motion "
        + ", ".join(f"{names[j - 1]} {rel[j]:.1f} % (whole record {whole[j]:.1f} %)" for j in good)
        + ("" if stacked is None else f" (stacked {stacked:.1f} %")
        + f"; condition number {float(idim.result.cond):.3g})."
    ]
    if left:
        out.append(f"Not identifiable from these logs (left out of the fit, see the warnings): {', '.join(left)}.")
    if sdp:
        lower = {j: s.relative_error_moving for j, s in sdp.items()}
        out.append(
            "The SDP of each joint's residual (the rigid body known) gives "
            + ", ".join(f"{names[j - 1]} {v:.1f} %" for j, v in lower.items())
            + "."
        )
        mism = [names[j - 1] for j, s in sdp.items() if s.shape.mismatch]
        if mism:
            out.append(
                f"Joints whose residual carries structure the rigid-body model misses (the SDP curves depart from "
                f"viscous + Coulomb friction and a constant, shape test): {', '.join(mism)}."
            )
        else:
            out.append("No joint's residual departs from viscous + Coulomb friction (shape test).")
    return out


def _inflation(idim: RobotIDIM, joints) -> float:
    """The largest factor by which a fitted joint's serially correlated residual makes the standard errors too
    small (`sd_inflation`; 1 for white residuals)."""
    return max([1.0] + [sd_inflation(idim.whiteness[j]) for j in joints if j in idim.whiteness])


def _loop(logs, robot) -> RobotExperiment:
    """The closed loop IDIM-IV simulates for its instruments: the logged angles as the reference, the
    description's PD with gravity feed-forward (`RobotExperiment`: critically damped on its inertia at
    `loop_bandwidth(dt)`, 10 Hz or the sample rate over 40 if lower: the PD acts once per sample), the logs'
    sample time, no noise (the controller of the real robot is not known; a loop that follows the logged motion
    closely gives noise-free states near the logged ones, the instruments' purpose). The loop is run once on the
    description before any IV iteration: a loop that diverges is refused here with its reason, not as a NaN
    inside the iterations."""
    n = robot.n
    dt = float(logs.dt)
    bandwidth = loop_bandwidth(dt)
    experiment = RobotExperiment(jnp.asarray(np.asarray(logs.q, dtype=float)), robot, jnp.zeros(n), dt=dt)
    q = np.asarray(experiment.simulate(robot).q)
    if not np.all(np.isfinite(q)):
        raise ValueError(
            f"IDIM-IV's instruments come from the robot simulated following the logged angles under a PD at "
            f"{bandwidth:g} Hz; on these logs ({1 / dt:g} samples/s) the description's own loop diverges, so "
            f"no instrument can be built: estimate by IDIM-LS (`iv=None`)"
        )
    return experiment


def _fit(logs, robot, rows, transmission, processing, min_speed, drives_given, timed, iv=None):
    """The stacked model of `rows` and its IDIM-LS (with `iv`: the IDIM-IV started from it, its instruments the
    identified robot following the logged angles under `_loop`); the joints judged after the fit and the sign
    warnings."""
    model = timed("model", lambda: robot_model(robot, joints=rows, transmission=transmission))
    loop = None if iv is None else _loop(logs, robot)
    idim = timed(
        "idim_ls",
        lambda: robot_idim_ls(logs, model, preprocessing=processing, min_speed=min_speed, iv=iv, loop=loop),
    )
    judged, signs = judge_estimates(idim, drives_given=drives_given)
    return idim, judged, signs


@x64
def robot_study(
    logs: JointLogs,
    *,
    robot: SerialRobot,
    drives: Drives | None = None,
    joints=None,
    processing: RobotProcessing | None = None,
    sdp: bool = True,
    physical: bool = True,
    iv: IDIMIV | None = None,
    friction: FrictionLaw | tuple | None = None,
    folds: int = 2,
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> RobotStudy:
    """Identify every joint of `robot` at once from joint logs: stacked IDIM-LS, then the SDP of each residual.

    **Arguments:** `logs` (`JointLogs` of all the robot's joints: motor side
    when `drives` is given, converted by `Drives.convert`; else already in
    the model's convention); `robot` (`SerialRobot.from_urdf`, `from_mdh`,
    `tx40_robot`); `drives` (`Drives`: ratios, torque constants, offsets,
    coupling); `joints` (rows to identify, default all); `processing`
    (`jaxsdp.plants.robot.RobotProcessing`: cut-off, decimation, ends dropped,
    rest threshold; None or each field None for the value that suits the
    logs, `processing_defaults` with `noise_limited=True`: from the sampling
    rate, the motion's band, the encoders' noise and the logs' ends; the
    report states each value and its reason), checked before any work;
    `sdp`: also the multi-SDP of
    each identifiable joint's residual; `physical`: also the physically
    consistent estimate (`physical_estimate`, regularised toward the
    description), each joint's relative error beside the unconstrained
    one's; `iv`: a `jaxsdp.IDIMIV` to estimate by the iterated
    bias-compensated IDIM-IV from the IDIM-LS estimate (its instruments the
    identified robot simulated noise free following the logged angles under
    a PD loop on the description, `_loop`; the estimate, its errors, the
    physical estimate and the friction laws are then the IV's; joint-side
    drives only); `friction`: candidate friction laws (a `jaxsdp.plants.FrictionLaw`
    or a tuple of them, the four laws of `jaxsdp.plants` for all): each motor's
    law read off its residual and estimated with the rigid body
    (`robot_friction`; None: viscous + Coulomb only); `folds`: blocks of time of the
    cross-validation (0: none); `progress`: callback with each stage name
    (`STAGES`).

    Each joint is judged: before the fit from its logs (a torque channel
    mostly exact zeros or constant, torque at the noise level, a joint that
    barely moves: left out of the fit, whose rows would bias the shared
    parameters), after it from its estimates (relative error of 100 % or
    more, motor inertia, friction or joint-space inertia negative beyond
    their standard deviation: the fit is repeated once without it).

    **Returns:** a `RobotStudy`.

    Example:
        >>> from jaxsdp.studies.robot import example_study
        >>> s = example_study()
        >>> s.names, round(s.idim.relative_error[1], 1)  # % (white torque noise of 2 N m, decimated by 2)
        (('joint1', 'joint2'), 16.2)
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    if not isinstance(logs, JointLogs):
        raise ValueError(f"`logs` must be a JointLogs (jaxsdp.data.load_joint_logs); got {type(logs).__name__}")
    if isinstance(folds, bool) or not isinstance(folds, int) or folds < 0 or folds == 1:
        raise ValueError(f"`folds` must be 0 (no cross-validation) or an int >= 2; got {folds!r}")
    if iv is not None and not isinstance(iv, IDIMIV):
        raise ValueError(f"`iv` must be a jaxsdp.IDIMIV or None; got {type(iv).__name__}")
    coupled = drives is not None and not np.allclose(drives.transmission, np.eye(drives.n))
    if iv is not None and coupled:
        raise ValueError(
            "IDIM-IV simulates the robot for its instruments with each joint driven by its own motor; these drives "
            "couple motors (a transmission matrix), which the simulator does not model yet: estimate by IDIM-LS "
            "(`iv=None`)"
        )
    if friction is not None:
        laws = (friction,) if isinstance(friction, FrictionLaw) else friction
        laws = tuple(laws) if isinstance(laws, (tuple, list)) else ()
        if not laws or not all(isinstance(law, FrictionLaw) for law in laws):
            raise ValueError(
                f"`friction` must be a jaxsdp.plants.FrictionLaw, a tuple of them or None; got {friction!r}"
            )
    if drives is not None:
        if not isinstance(drives, Drives):
            raise ValueError(f"`drives` must be a jaxsdp.data.Drives; got {type(drives).__name__}")
        logs = drives.convert(logs)
    names = tuple(robot.names or tuple(f"joint{j}" for j in range(1, robot.n + 1)))
    wanted = list(range(1, robot.n + 1)) if joints is None else [int(j) for j in joints]
    options = RobotProcessing() if processing is None else processing
    if not isinstance(options, RobotProcessing):
        raise ValueError(f"`processing` must be a jaxsdp.plants.RobotProcessing; got {type(options).__name__}")
    min_speed = options.min_speed
    processing = processing_defaults(
        logs.dt,
        np.asarray(logs.q),
        cutoff_hz=options.cutoff_hz,
        decimate=options.decimate,
        drop=options.drop,
        min_speed=min_speed,
        noise_limited=True,
        names=[names[j - 1] for j in logs.joints] if len(logs.joints) == robot.n else None,
        prismatic=[robot._is_prismatic(j - 1) for j in logs.joints] if len(logs.joints) == robot.n else None,
    )
    timed = StageTimer(progress)
    transmission = None if drives is None or (iv is not None and not coupled) else drives.transmission
    screened = screen_channels(logs, robot, rest_threshold=min_speed)
    verdicts = {j: screened[j] for j in wanted}
    rows = [j for j in wanted if verdicts[j].identifiable]
    if not rows:
        why = "; ".join(r for j in wanted for r in verdicts[j].reasons)
        raise ValueError(f"no joint can be identified from these logs: {why}")
    fit = (logs, robot, rows, transmission, processing.preprocessing, min_speed, drives is not None, timed, iv)
    idim, judged, signs = _fit(*fit)
    bad = [j for j in rows if not judged.get(j, JointVerdict(True)).identifiable]
    if bad and len(bad) < len(rows):  # refit once without them: their rows would bias the shared parameters
        verdicts = combine(verdicts, {j: judged[j] for j in bad})
        rows = [j for j in rows if j not in bad]
        idim, judged, more = _fit(logs, robot, rows, *fit[3:])
        signs = signs + more
    verdicts = combine(verdicts, judged)
    good = [j for j in rows if verdicts[j].identifiable]
    consistent = timed("physical", lambda: physical_estimate(idim.result, idim.model)) if physical else None
    curves = timed("sdp", lambda: robot_residual_sdp(idim, joints=good)) if sdp and good else None
    laws_fit = None
    if friction is not None and good:
        laws_fit = timed("friction", lambda: robot_friction(idim, laws=laws, folds=max(folds, 2), sdp=curves))
    rows_left = int(idim.y.shape[0]) - int(idim.tail)
    validation = None
    if folds and rows_left >= 10 * folds:
        validation = timed("validation", lambda: robot_cross_validation(idim, folds=folds))
    scales, implausible = robot_checks(idim, robot=robot, dt=float(logs.dt))
    description, compared = description_comparison(idim, robot)
    warnings = (
        list(processing.warnings)
        + implausible
        + _verdict_warnings(verdicts, names)
        + signs
        + compared
        + velocity_check(logs, idim.inputs, robot=robot)
        + _warnings(idim, curves, names)
        + ([] if consistent is None else list(consistent.warnings(inflation=_inflation(idim, good))))
        + friction_warnings(laws_fit)
        + iv_warnings(idim)
    )
    plausible = not implausible and not signs
    stacked = stacked_error(idim, good) if good else None
    timings = timed.total()
    return RobotStudy(
        idim=idim,
        sdp=curves,
        names=names,
        source=logs.source if source is None else source,
        drives="none (joint-side logs)" if drives is None else repr(drives),
        samples=int(logs.q.shape[0]),
        sample_time=float(logs.dt),
        settings={
            "cutoff_hz": float(processing.cutoff_hz),
            "decimate": int(processing.decimate),
            "drop": int(processing.drop),
            "min_speed": {int(j): float(v) for j, v in idim.min_speed.items()},
            "joints": list(wanted),
            "fitted": list(idim.model.rows),
            "sdp": bool(sdp),
            "estimator": "IDIM-LS" if iv is None else "IDIM-IV",
            "iv_loop_hz": None if iv is None else loop_bandwidth(float(logs.dt)),
            "friction": None if friction is None else [type(law).__name__ for law in laws],
            "folds": int(folds),
            "reasons": dict(processing.reasons),
        },
        warnings=tuple(warnings),
        findings=tuple(
            ([] if plausible else [CAVEAT])
            + _findings(idim, curves, names, verdicts, stacked)
            + _small_parameters(idim)
            + _weak_correlation(idim, names)
            + ([] if consistent is None else list(consistent.notes()))
            + iv_findings(idim)
            + friction_findings(laws_fit, names)
        ),
        timings=timings,
        versions=versions(),
        fast_loops=fast_loops(),
        resampled=logs.resampled,
        scale_checks=tuple(scales),
        plausible=plausible,
        verdicts=verdicts,
        description=tuple(description),
        validation=validation,
        processing=processing,
        stacked_relative_error=stacked,
        notes=tuple(getattr(logs, "notes", ()) or ()),
        physical=consistent,
        friction=laws_fit,
    )
