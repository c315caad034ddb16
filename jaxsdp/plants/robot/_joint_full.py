"""Beyond the paper: one joint identified with the full six-joint rigid-body model, then the SDP stage on its residual.

1. `joint_full_model`: IDIM-LS of joint j with the full-model regressor
   (`jaxsdp.plants.joint_model`: the base parameters of the joint's row of
   the Newton-Euler regressor, the actuator inertia, viscous and Coulomb
   friction and the offset), every joint's angle processed as the one-joint
   study's (Butterworth, central differences, parallel decimation), on the
   samples where joint j moves, with the residual whiteness test. The logs
   must be in the model's convention (`jaxsdp.data.model_convention`); a
   wrong convention shows as a gravity torque far from the nominal model's
   (`gravity_deviation`).
2. `coupling_explained`: how much of the one-joint multi-SDP curves'
   departure from their parametric shapes (eq. 20) the coupling torque
   (full model minus the one-joint parametric model) explains.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._idim.ls import IDIMResult, idim_ls
from ..._records import JointLogs
from ..._runtime import x64
from ..._signal.preprocess import Preprocessed
from ..._signal.regressors import Regression
from ..._signal.whiteness import Whiteness
from ._joint import JointModel, joint_model, motor_coordinate
from ._joint_stages import JointSDP, joint_preprocess, moving_mask, residual_whiteness
from ._serial import SerialRobot

#: Above this gravity deviation (% of the nominal gravity torque) the joint-angle convention is suspect.
MAX_GRAVITY_DEVIATION = 50.0
#: Base parameters whose relative standard deviation exceeds this (%) are reported as not excited.
POORLY_EXCITED = 100.0


class JointFullModel(eqx.Module):
    r"""IDIM-LS of one joint with the full rigid-body model (`joint_full_model`).

    **Fields:** `result` (`IDIMResult` of the base parameters, SI units:
    kg m^2, kg m, kg, N m s/rad, N m), `model` (`JointModel`: the base
    parameters' combinations and the robot's nominal values), `regression`
    (decimated `y`, `X`, all samples), `moving` (mask of the samples used),
    `fit` (N m, at the samples used), `relative_error` (%), `gravity_deviation`
    (%: $100 \|g_{id} - g_{nom}\| / \max(\|g_{nom}\|, \|y\| / 10)$ of the joint's gravity
    torque over the samples used, identified against nominal; the floor
    keeps a joint that gravity hardly loads, a wrist, from reading huge), `whiteness`, `joint`.
    """

    result: IDIMResult
    model: JointModel
    regression: Regression
    moving: jnp.ndarray
    fit: jnp.ndarray
    relative_error: float
    gravity_deviation: float
    whiteness: Whiteness
    joint: int = eqx.field(static=True)

    @x64
    def nominal(self) -> dict:
        """Base parameter name -> the robot's nominal value."""
        return dict(zip(self.model.names, (float(v) for v in self.model.nominal)))

    @x64
    def estimates(self) -> dict:
        """Base parameter name -> estimate."""
        return dict(zip(self.result.names, (float(v) for v in np.asarray(self.result.theta))))

    @x64
    def rel_std(self) -> dict:
        """Base parameter name -> relative standard deviation (%)."""
        return dict(zip(self.result.names, (float(v) for v in np.asarray(self.result.rel_std))))

    @x64
    def poorly_excited(self, limit: float = POORLY_EXCITED) -> tuple:
        """Base parameters with a relative standard deviation above `limit` (%)."""
        return poorly_excited(self.result, limit)


def poorly_excited(result: IDIMResult, limit: float = POORLY_EXCITED) -> tuple:
    """The names of `result`'s parameters with a relative standard deviation above `limit` (%, or NaN)."""
    return tuple(k for k, v in zip(result.names, np.asarray(result.rel_std)) if not v <= limit)


def in_motor_coordinate(own: Preprocessed, inputs, joint: int, transmission) -> tuple[Preprocessed, bool]:
    """The joint's inputs `own` with their velocity in its motor's coordinate du_j = (C^-1 dq)_j where that differs
    from dq_j (`motor_coordinate`: the TX40's motor 6, dq5 + dq6), where the motor's friction lives; and whether
    it did. `inputs`: every joint's `Preprocessed`."""
    row = motor_coordinate(len(inputs), joint, transmission)
    if row is None:
        return own, False
    dq = jnp.stack([p.dq for p in inputs], axis=1)
    return eqx.tree_at(lambda p: p.dq, own, dq @ jnp.asarray(row)), True


def check_all_joints(logs: JointLogs, robot: SerialRobot) -> None:
    """ValueError unless the logs hold every joint of `robot`, as columns 1..n in order."""
    if tuple(logs.joints) != tuple(range(1, robot.n + 1)):
        raise ValueError(
            f"the full model needs the logs of all {robot.n} joints (columns 1..{robot.n}); got joints {logs.joints}"
        )


def all_joints_preprocessed(logs: JointLogs, robot: SerialRobot, pre_kw: dict) -> tuple[list[Preprocessed], tuple]:
    """Every joint's `joint_preprocess` (options `pre_kw`) and the filtered full-rate (q, dq, ddq), each (N, n),
    after checking that the logs hold all the robot's joints (`check_all_joints`)."""
    check_all_joints(logs, robot)
    inputs = [joint_preprocess(logs, joint=j, **pre_kw) for j in logs.joints]
    full = tuple(jnp.stack([getattr(p, k) for p in inputs], axis=1) for k in ("q_full", "dq_full", "ddq_full"))
    return inputs, full


@x64
def joint_full_model(
    logs: JointLogs,
    *,
    robot: SerialRobot,
    joint: int = 2,
    min_speed: float,
    preprocessing: dict,
    model: JointModel | None = None,
    transmission=None,
) -> tuple[JointFullModel, Preprocessed]:
    """IDIM-LS of joint `joint` with the full-model regressor (base parameters, friction, offset).

    tau_j = X_base(q, dq, ddq) beta + e, X_base the base columns of
    [d tau_j / d theta, ddq_j, dq_j, sign dq_j, 1] built at the full rate on
    every joint's filtered angle, rates and accelerations and decimated like
    the torque (parallel decimation); LS on the samples with |dq_j| >= `min_speed`.

    **Arguments:** `logs` (`JointLogs` of all joints in the model's
    convention: `jaxsdp.data.model_convention`); `robot` (its kinematics and
    nominal parameters); `joint`; `min_speed` (rad/s); `preprocessing`
    (keyword arguments of `joint_preprocess`); `model` (a `JointModel`,
    default `joint_model(robot, joint=joint, transmission=transmission)`);
    `transmission` (the drives' C: the coupled motors' inertia and friction
    in the rows they enter, in their own coordinates; None: independent).

    **Returns:** (`JointFullModel`, the joint's `Preprocessed` inputs; for a
    joint whose motor turns in another coordinate (`motor_coordinate`: the
    TX40's joint 6, u6 = q5 + q6) their velocity is that coordinate's, where
    the motor's friction lives, ready for the SDP of the residual).
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    model = joint_model(robot, joint=joint, transmission=transmission) if model is None else model
    inputs, (q, dq, ddq) = all_joints_preprocessed(logs, robot, preprocessing)
    own = inputs[joint - 1]
    keep = moving_mask(own, min_speed)
    reg = own.regression(model.regressors(q, dq, ddq))
    result = idim_ls(reg.y[keep], reg.X[keep], names=reg.names)
    theta = jnp.asarray(result.theta)
    fit = reg.X[keep] @ theta
    y = reg.y[keep]
    q_dec = jnp.stack([p.q for p in inputs], axis=1)[keep]
    g_id = model.gravity(q_dec, theta)
    g_nom = model.gravity(q_dec, model.nominal)
    # relative to the nominal gravity torque, or to a tenth of the torque where gravity hardly loads the
    # joint (a wrist joint: the nominal is ~0 and any identified gravity would read as a huge percentage)
    scale = jnp.maximum(jnp.linalg.norm(g_nom), 0.1 * jnp.linalg.norm(y))
    dev = float(100.0 * jnp.linalg.norm(g_id - g_nom) / jnp.maximum(scale, 1e-12))
    out = JointFullModel(
        result=result,
        model=model,
        regression=reg,
        moving=jnp.asarray(keep),
        fit=fit,
        relative_error=float(100.0 * jnp.linalg.norm(y - fit) / jnp.linalg.norm(y)),
        gravity_deviation=dev,
        whiteness=residual_whiteness(result.residuals, own.decimate),
        joint=int(joint),
    )
    own, _ = in_motor_coordinate(own, inputs, joint, model.transmission)
    return out, own


def full_rigid_torque(full: JointFullModel) -> jnp.ndarray:
    """The full model's torque but the joint's own friction and offset (`JointModel.rigid_names`: the rigid
    body, the actuators' inertia, a coupled motor's friction) at every decimated sample (N m)."""
    rigid = np.isin(np.asarray(full.regression.names), full.model.rigid_names())
    return full.regression.X[:, rigid] @ jnp.asarray(full.result.theta)[rigid]


def coupling_explained(full: JointFullModel, sdp: JointSDP) -> dict:
    """How much of the one-joint SDP curves' departure from eq. (20) the coupling torque explains.

    On the samples in motion (both models' fits), the departure m = (d_q + d_dq) - (projections)
    and the coupling c = full-model fit - the one-joint parametric fit;
    `explained` = 100 (m . c)^2 / (|m|^2 |c|^2) (%, the R^2 of m on c), with
    `departure` and `coupling` 100 |m| / |y| and 100 |c| / |y| (% of the torque).
    """
    if sdp.fit_on != "all" or sdp.y.shape != full.regression.y.shape:
        raise ValueError("the one-joint multi-SDP must be fitted on every decimated sample (fit_on='all')")
    # on the samples both models count in motion (a coupled joint's masks differ: its angle is converted)
    both = np.asarray(sdp.moving, bool) & np.asarray(full.moving, bool)
    known = sdp.inertia * sdp.ddq
    m = (jnp.sum(sdp.result.d, axis=1) - (sdp.parametric_fit - known))[both]
    c = (full.regression.X @ jnp.asarray(full.result.theta) - sdp.parametric_fit)[both]
    nm, nc, ny = (float(jnp.linalg.norm(v)) for v in (m, c, sdp.y[both]))
    r2 = float(jnp.dot(m, c) ** 2 / (nm**2 * nc**2)) if nm > 0 and nc > 0 else 0.0
    return {"explained": 100.0 * r2, "departure": 100.0 * nm / ny, "coupling": 100.0 * nc / ny}
