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
import numpy as np

from ..._idim.trust import CAVEAT
from ..._records import JointLogs
from ..._runtime import x64
from ...data._drives import Drives
from ...plants.robot._joint_stages import MIN_SPEED
from ...plants.robot._plausibility import robot_checks
from ...plants.robot._serial import SerialRobot
from ...plants.robot._stacked import RobotIDIM, robot_idim_ls, robot_model, robot_residual_sdp
from .._contract import fast_loops, versions
from .._output import StageTimer

#: Stages of `robot_study` (keys of `timings`, besides `total`).
STAGES = ("model", "idim_ls", "sdp")


class RobotStudy(eqx.Module):
    """All results of `robot_study`.

    **Fields:** `idim` (`RobotIDIM`: base parameters, per-joint and stacked
    relative errors, whiteness), `sdp` (joint -> `JointSDP` of its residual,
    or None), `names` (the robot's joint names), `source`, `drives` (the
    description in words), `samples`, `sample_time` (s), `resampled` (how
    an irregular time column was resampled, or None), `settings`,
    `warnings`, `findings`, `timings` (stage -> s), `versions`, `fast_loops`.

    `scale_checks`: the identified inertia and the logs' speeds and
    accelerations against the description (`jaxsdp.plants.robot._plausibility.robot_checks`:
    units, time scale); `plausible`: False when one failed (or a friction
    estimate is negative): the findings then start with a caveat.
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


def _warnings(idim: RobotIDIM, sdp) -> list[str]:
    out = []
    poor = idim.poorly_excited()
    if poor:
        out.append(
            f"{len(poor)} of {idim.model.rank} base parameters are not excited by this trajectory (relative standard "
            f"deviation > 100 %: {', '.join(poor)}); their estimates are meaningless, the fit is not affected"
        )
    est = dict(zip(idim.result.names, np.asarray(idim.result.theta, dtype=float)))
    neg = [f"{k} = {v:.3g}" for k, v in est.items() if k[:2] in ("Fv", "Fc") and v < 0]
    if neg:
        out.append(f"negative friction estimates ({', '.join(neg)}): physically impossible; check the drives' signs")
    corr = [j for j, w in idim.whiteness.items() if not bool(w.white)]
    if corr:
        out.append(
            f"the residual of joints {', '.join(map(str, corr))} is serially correlated: the rigid-body model leaves "
            "structure in the torque (friction's shape, flexibility, couplings) or the noise is coloured; the "
            "relative standard deviations are then optimistic"
        )
    for j, s in (sdp or {}).items():
        if not bool(s.result.converged):
            out.append(f"joint {j}: the back-fitting of its residual's SDP did not converge (raise max_iter)")
    return out


def _findings(idim: RobotIDIM, sdp, names) -> list[str]:
    rel = idim.relative_error
    out = [
        f"All {len(rel)} joints identified at once with {idim.model.rank} base parameters: relative error "
        + ", ".join(f"{names[j - 1]} {v:.1f} %" for j, v in rel.items())
        + f" (stacked {idim.stacked_relative_error:.1f} %; condition number {float(idim.result.cond):.3g})."
    ]
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


@x64
def robot_study(
    logs: JointLogs,
    *,
    robot: SerialRobot,
    drives: Drives | None = None,
    joints=None,
    cutoff_hz: float = 100.0,
    decimate: int = 10,
    drop: int = 100,
    min_speed=MIN_SPEED,
    sdp: bool = True,
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> RobotStudy:
    """Identify every joint of `robot` at once from joint logs: stacked IDIM-LS, then the SDP of each residual.

    **Arguments:** `logs` (`JointLogs` of all the robot's joints: motor side
    when `drives` is given, converted by `Drives.convert`; else already in
    the model's convention); `robot` (`SerialRobot.from_urdf`, `from_mdh`,
    `tx40_robot`); `drives` (`Drives`: ratios, torque constants, offsets,
    coupling); `joints` (rows to identify, default all); `cutoff_hz`,
    `decimate`, `drop`: the processing (Butterworth + central differences,
    border removal at both ends, decimation); `min_speed` (rad/s or "auto");
    `sdp`: also the multi-SDP of each joint's residual; `progress`: callback
    with each stage name (`STAGES`).

    **Returns:** a `RobotStudy`.

    Example:
        >>> from jaxsdp.studies.robot import example_study
        >>> s = example_study()
        >>> s.names, round(s.idim.relative_error[1], 1)  # % (white torque noise of 2 N m)
        (('joint1', 'joint2'), 7.5)
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    if not isinstance(logs, JointLogs):
        raise ValueError(f"`logs` must be a JointLogs (jaxsdp.data.load_joint_logs); got {type(logs).__name__}")
    if drives is not None:
        if not isinstance(drives, Drives):
            raise ValueError(f"`drives` must be a jaxsdp.data.Drives; got {type(drives).__name__}")
        logs = drives.convert(logs)
    timed = StageTimer(progress)
    pre = dict(cutoff_hz=cutoff_hz, decimate=decimate, drop=drop)
    transmission = None if drives is None else drives.transmission
    model = timed("model", lambda: robot_model(robot, joints=joints, transmission=transmission))
    idim = timed("idim_ls", lambda: robot_idim_ls(logs, model, preprocessing=pre, min_speed=min_speed))
    curves = timed("sdp", lambda: robot_residual_sdp(idim)) if sdp else None
    scales, physical = robot_checks(idim, robot=robot, dt=float(logs.dt))
    warnings = physical + _warnings(idim, curves)
    plausible = not physical and not any(w.startswith("negative friction") for w in warnings)
    timings = timed.total()
    names = robot.names or tuple(f"joint{j}" for j in range(1, robot.n + 1))
    return RobotStudy(
        idim=idim,
        sdp=curves,
        names=tuple(names),
        source=logs.source if source is None else source,
        drives="none (joint-side logs)" if drives is None else repr(drives),
        samples=int(logs.q.shape[0]),
        sample_time=float(logs.dt),
        settings={
            "cutoff_hz": cutoff_hz,
            "decimate": int(decimate),
            "drop": int(drop),
            "min_speed": {int(j): float(v) for j, v in idim.min_speed.items()},
            "joints": list(model.rows),
            "sdp": bool(sdp),
        },
        warnings=tuple(warnings),
        findings=tuple(([] if plausible else [CAVEAT]) + _findings(idim, curves, names)),
        timings=timings,
        versions=versions(),
        fast_loops=fast_loops(),
        resampled=logs.resampled,
        scale_checks=tuple(scales),
        plausible=plausible,
    )
