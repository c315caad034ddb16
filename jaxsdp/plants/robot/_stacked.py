"""All joints at once: the stacked full-model regressor of a serial robot, its base parameters, and IDIM-LS.

The drive torques of the chosen joints are linear in the stacked link
parameters theta (`SerialRobot.parameter_names`), in each motor's inertia,
viscous and Coulomb friction (in the motor's own coordinate, entering every
joint row the motor drives: `jaxsdp.data.Drives.motor_regressor`; without a
coupling, the usual per-joint Ia_j, Fv_j, Fc_j) and in one offset per joint:

    tau = Y(q, dq, ddq) theta + G (Ia ddu + Fv du + Fc sign(du)) + offset,   du = C^-1 dq,  G = C^-T.

Stacked over states and joints, QR with column pivoting on random states
(`base_parameters`) gives the identifiable base parameters and the
combinations the others enter; IDIM-LS on the logs' samples (parallel
decimation, each joint's rows at rest left out) estimates them.
"""

import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._idim.ls import IDIMResult, idim_ls
from ..._records import JointLogs
from ..._runtime import x64
from ..._signal.filtering import decimate_start
from ..._signal.regressors import Regressors
from ._joint import (
    BASE_STATES,
    check_states,
    drive_matrix,
    in_parameter_order,
    random_states,
    stacked_rows,
)
from ._joint_full import POORLY_EXCITED, all_joints_preprocessed, in_motor_coordinate, poorly_excited
from ._joint_stages import MIN_SPEED, moving_mask, residual_whiteness, rest_threshold
from ._serial import BaseParameters, SerialRobot, base_parameters


class RobotModel(NamedTuple):
    """The stacked full model of a robot's chosen joints (`robot_model`).

    **Fields:** `robot`; `rows` (the joints modelled, 1-based); `base`
    (`BaseParameters` over `full_names`); `full_names` (the 10 n link
    parameters, then `Ia<k>, Fv<k>, Fc<k>` per motor k, then `offset<j>`);
    `nominal` (rank,): the robot's own base parameter values; `transmission`
    (the drives' C, or None for independent joints).
    """

    robot: SerialRobot
    rows: tuple
    base: BaseParameters
    full_names: tuple
    nominal: np.ndarray
    transmission: np.ndarray | None

    @property
    @x64
    def names(self) -> tuple:
        """The base parameters' names (their independent column; the combinations are in `base.names`)."""
        return self.base.independent

    @property
    @x64
    def rank(self) -> int:
        """Number of base parameters."""
        return self.base.rank

    @x64
    def full_regressor(self, q, dq, ddq) -> jax.Array:
        """(N, len(rows), p): every parameter's column at each state, joint by joint."""
        n = self.robot.n
        q, dq, ddq = check_states(n, q, dq, ddq)
        Cinv, G = drive_matrix(n, self.transmission)
        return stacked_rows(self.robot, q, dq, ddq, Cinv, G, tuple(j - 1 for j in self.rows))

    @x64
    def regressor(self, q, dq, ddq) -> jax.Array:
        """(N, len(rows), rank): the base columns of `full_regressor`."""
        return self.full_regressor(q, dq, ddq)[:, :, np.asarray(self.base.columns)]


@x64
def robot_model(
    robot: SerialRobot,
    *,
    joints=None,
    transmission=None,
    states: int = BASE_STATES,
    seed: int = 0,
    tol: float = 1e-8,
) -> RobotModel:
    """The base parameters of the stacked model of `joints` (default all), by QR with column pivoting.

    The rows of the chosen joints, stacked over `states` random states (q
    uniform in [-pi, pi], dq and ddq standard normal, seeded), split the
    parameters into `rank` independent ones and the combinations the others
    enter. `transmission`: the drives' C (`jaxsdp.data.Drives.transmission`;
    None: independent joints).

    Example:
        >>> from jaxsdp.data import Drives
        >>> from jaxsdp.plants import tx40_robot
        >>> from jaxsdp.plants.robot import robot_model
        >>> m = robot_model(tx40_robot(), transmission=Drives.builtin("tx40").transmission)
        >>> m.rank, "Fv6" in m.names  # motor 6's friction, in its coordinate dq5 + dq6
        (58, True)
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    n = robot.n
    rows = tuple(range(1, n + 1)) if joints is None else tuple(int(j) for j in joints)
    if not rows or any(not 1 <= j <= n for j in rows) or len(set(rows)) != len(rows):
        raise ValueError(f"`joints` must be distinct joint numbers in 1..{n}; got {joints!r}")
    C = None if transmission is None else np.asarray(transmission, dtype=float)
    if C is not None and C.shape != (n, n):
        raise ValueError(f"`transmission` must be ({n}, {n}); got {C.shape}")
    p = 14 * n
    if not isinstance(states, int) or states * len(rows) < p:
        raise ValueError(f"`states` must be an int with states x joints >= {p}; got {states!r}")
    Cinv, G = drive_matrix(n, C)
    W = np.asarray(stacked_rows(robot, *random_states(n, states, seed), Cinv, G, tuple(j - 1 for j in rows)))
    names = (
        robot.parameter_names()
        + tuple(f"{k}{j}" for j in range(1, n + 1) for k in ("Ia", "Fv", "Fc"))
        + tuple(f"offset{j}" for j in range(1, n + 1))
    )
    base = in_parameter_order(base_parameters(W.reshape(-1, W.shape[-1]), names, tol=tol), names)
    nominal = base.values(full_parameters(robot))
    return RobotModel(robot=robot, rows=rows, base=base, full_names=names, nominal=nominal, transmission=C)


def full_parameters(robot: SerialRobot) -> np.ndarray:
    """The full parameter vector of `robot_model`'s `full_names`: 10 n inertial, (Ia, Fv, Fc) per joint, offsets."""
    drives = np.stack([np.asarray(robot.Ia), np.asarray(robot.Fv), np.asarray(robot.Fc)], axis=1).ravel()
    return np.concatenate([np.asarray(robot.inertial).ravel(), drives, np.asarray(robot.offset)])


class RobotIDIM(eqx.Module):
    """IDIM-LS of a robot's joints, all at once (`robot_idim_ls`).

    **Fields:** `result` (`IDIMResult` over the base parameters: values,
    standard deviations, relative ones %, condition number), `model`
    (`RobotModel`), `relative_error` (joint -> % on its rows used, those in
    motion), `relative_error_all` (joint -> % of `record_fit` over the whole
    record: every decimated row, rows at rest included; only the `tail` rows
    of the filter's end transient left out),
    `stacked_relative_error` (%), `whiteness` (joint -> `Whiteness` of its
    residual), `samples` (joint -> rows used), `y`, `fit`, `moving` ((M,
    joints) decimated torques, the model's fit and the rows used), `X` ((M,
    joints, rank) the decimated base regressor), `min_speed` (joint -> the
    rest threshold used, rad/s or m/s for a prismatic joint), `record_fit`
    ((M, joints): the model over the whole record, each motor's Coulomb term
    off where that motor is at rest, `record_fit`), `t` ((M,) s:
    the log's time of each decimated row, `logs.t[0]` plus the dropped
    samples and the decimation's phase), `tail` (the last rows, left out of
    every error: the zero-phase filter's end transient).
    """

    result: IDIMResult
    y: jax.Array
    X: jax.Array
    fit: jax.Array
    moving: jax.Array
    whiteness: dict
    model: RobotModel
    inputs: tuple
    relative_error: dict = eqx.field(static=True)
    stacked_relative_error: float = eqx.field(static=True)
    samples: dict = eqx.field(static=True)
    min_speed: dict = eqx.field(static=True)
    relative_error_all: dict = eqx.field(static=True, default_factory=dict)
    record_fit: jax.Array | None = None
    t: jax.Array | None = None
    tail: int = eqx.field(static=True, default=0)

    @x64
    def poorly_excited(self, limit: float = POORLY_EXCITED) -> tuple:
        """Base parameters with a relative standard deviation above `limit` (%)."""
        return poorly_excited(self.result, limit)


@x64
def robot_idim_ls(
    logs: JointLogs,
    model: RobotModel,
    *,
    preprocessing: dict | None = None,
    min_speed=MIN_SPEED,
) -> RobotIDIM:
    """IDIM-LS of every joint of `model` at once, on joint logs in the model's convention.

    Each joint's angle is processed as the one-joint studies do
    (`joint_preprocess` with `preprocessing`: Butterworth + central
    differences, border removal at both ends, decimation); the stacked regressor is built
    at the full rate on all joints' filtered states and decimated like the
    torques (parallel decimation); each joint's rows at rest (|dq_j| below
    its `min_speed`, default 1 % of its peak speed) are left out; one LS on
    all the rows left (`idim_ls`). Each joint's relative error is given on
    its rows in motion (`relative_error`) and over the whole record, rows at
    rest included (`relative_error_all`, the figure other toolboxes quote).

    **Returns:** a `RobotIDIM`.

    Example:
        >>> import numpy as np
        >>> import jax.numpy as jnp
        >>> from jaxsdp.data import JointLogs
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.plants.robot import robot_idim_ls, robot_model
        >>> arm = SerialRobot.from_mdh([[0.0, 0.0, 0.0, 0.0]], inertias=[(2.0, [0.5, 0.0, 0.0], np.zeros(6))],
        ...                            Fv=3.0, Fc=1.0)
        >>> t = np.arange(0, 10, 1e-3)[:, None]
        >>> q, dq, ddq = np.sin(t), np.cos(t), -np.sin(t)  # a horizontal arm: no gravity torque
        >>> logs = JointLogs(q=jnp.asarray(q), tau=arm.drive_torques(q, dq, ddq), t=jnp.asarray(t[:, 0]),
        ...                  dt=1e-3, joints=(1,), source="sim", converted="none")
        >>> res = robot_idim_ls(logs, robot_model(arm))
        >>> {k: round(float(v), 3) for k, v in zip(res.result.names, res.result.theta)}  # ZZ1 = 2 * 0.5^2
        {'ZZ1': 0.5, 'Fv1': 3.0, 'Fc1': 1.0, 'offset1': 0.0}
    """
    if not isinstance(logs, JointLogs):
        raise ValueError(f"`logs` must be a JointLogs; got {type(logs).__name__}")
    pre_kw = {} if preprocessing is None else dict(preprocessing)
    inputs, (q, dq, ddq) = all_joints_preprocessed(logs, model.robot, pre_kw)
    W = model.regressor(q, dq, ddq)  # (N full, rows, rank)
    ys, Xs, keeps, thresholds = [], [], [], {}
    for i, j in enumerate(model.rows):
        own = inputs[j - 1]
        reg = own.regression(Regressors(X=W[:, i, :], names=model.names))
        keep = moving_mask(own, min_speed)
        thresholds[j] = rest_threshold(own, min_speed)
        ys.append(reg.y)
        Xs.append(reg.X)
        keeps.append(keep)
    y = jnp.stack(ys, axis=1)
    X = jnp.stack(Xs, axis=1)
    moving = np.stack(keeps, axis=1)
    # the zero-phase filter's end transient: as many samples as the start's drop, left out at the end too
    tail = -(-int(inputs[0].drop) // int(inputs[0].decimate))
    if tail:
        moving[-tail:] = False
    result = idim_ls(y[moving], X[moving], names=model.names)
    fit = jnp.einsum("mjp,p->mj", X, jnp.asarray(result.theta))
    whole = record_fit(np.asarray(X), np.asarray(result.theta), model, inputs, min_speed)
    rel, rel_all, white, samples = {}, {}, {}, {}
    yy, ff = np.asarray(y), np.asarray(fit)
    record = slice(0, yy.shape[0] - tail)
    for i, j in enumerate(model.rows):
        k = moving[:, i]
        e = yy[k, i] - ff[k, i]
        rel[j] = relative_error(e, yy[k, i])
        rel_all[j] = relative_error(yy[record, i] - whole[record, i], yy[record, i])
        white[j] = residual_whiteness(jnp.asarray(e), inputs[j - 1].decimate)
        samples[j] = int(k.sum())
    e_all = (yy - ff)[moving]
    return RobotIDIM(
        result=result,
        y=y,
        X=X,
        fit=fit,
        moving=jnp.asarray(moving),
        model=model,
        relative_error=rel,
        stacked_relative_error=relative_error(e_all, yy[moving]),
        whiteness=white,
        inputs=tuple(inputs),
        samples=samples,
        min_speed=thresholds,
        relative_error_all=rel_all,
        record_fit=jnp.asarray(whole),
        t=jnp.asarray(row_times(logs, inputs[0], yy.shape[0])),
        tail=tail,
    )


def record_fit(X: np.ndarray, theta: np.ndarray, model: RobotModel, inputs, min_speed=MIN_SPEED) -> np.ndarray:
    """(M, joints): the model `X theta` over the whole record, each motor k's Coulomb column `Fc<k>` set to 0 on
    the rows where it is at rest (|du_k| below `rest_threshold(., min_speed)` of its coordinate du_k: the
    joint's dq_k without a coupling, `in_motor_coordinate`). There sign(du_k) is the sign of noise, and the
    friction passes through the stick region within +-Fc_k, which the model does not describe: the one-joint
    studies' definition (`JointIDIM.record_fit`). In motion it is the fit."""
    X = np.array(X, dtype=float)
    for c, name in enumerate(model.names):
        if not (name.startswith("Fc") and name[2:].isdigit()):
            continue
        k = int(name[2:])
        own, _ = in_motor_coordinate(inputs[k - 1], inputs, k, model.transmission)
        X[np.abs(np.asarray(own.dq)) < rest_threshold(own, min_speed), :, c] = 0.0
    return X @ np.asarray(theta, dtype=float)


def relative_error(e, y) -> float:
    """100 ||e|| / ||y|| (%); inf when y is all zeros (and e is not), NaN when both are."""
    ne, ny = float(np.linalg.norm(e)), float(np.linalg.norm(y))
    if ny > 0.0:
        return 100.0 * ne / ny
    return math.inf if ne > 0.0 else math.nan


def row_times(logs: JointLogs, inputs, rows: int) -> np.ndarray:
    """(rows,) s: the log's time of each decimated row of `inputs` (a `Preprocessed` of `logs`): `logs.t[0]`
    plus the `drop` samples removed and the decimation's phase (`decimate` keeps every r-th sample from
    `decimate_start`)."""
    r = int(inputs.decimate)
    start = 0 if r == 1 else decimate_start(int(inputs.y_full.shape[0]), r, inputs.mode)
    k = int(inputs.drop) + start + r * np.arange(rows)
    return float(np.asarray(logs.t)[0]) + k * float(inputs.dt_full)


def own_columns(model: RobotModel, joint: int) -> np.ndarray:
    """Mask of the base parameters that are joint `joint`'s own friction and offset (Fv, Fc, offset)."""
    own = {f"{k}{joint}" for k in ("Fv", "Fc", "offset")}
    return np.array([name in own for name in model.names])


@x64
def robot_residual_sdp(res: RobotIDIM, *, joints=None, model=("RW", "RW"), tol: float = 0.01, max_iter: int = 20):
    """The multi-SDP of each joint's torque once the full model's rigid body (and the other motors) is known.

    For joint j: y_j - known_j = d_q(q_j) + d_dq(dq_j) + e, known_j the
    stacked model's fit without the joint's own Fv, Fc and offset
    (`own_columns`), the curves in the joint's own angle and velocity (for
    a coupled motor, the velocity of its own coordinate (C^-1 dq)_j, where
    its friction lives: the TX40's motor 6, dq5 + dq6)
    (`joint_multi_sdp`: back-fitting on every sample, projections and the
    shape test on the samples in motion). What the curves find is what the
    rigid-body model misses on that joint: friction's shape, a position
    dependence (a cable, a spring, flexibility), coupling left out.

    **Returns:** `{joint: JointSDP}` for `joints` (default all of `res`).
    """
    from ..._sdp.multi import MultiBackfitting
    from ._joint_stages import joint_multi_sdp

    rows = res.model.rows if joints is None else tuple(int(j) for j in joints)
    theta = jnp.asarray(res.result.theta)
    out = {}
    for j in rows:
        if j not in res.model.rows:
            raise ValueError(f"joint {j} is not one of the identified joints {res.model.rows}")
        i = res.model.rows.index(j)
        own, coupled = in_motor_coordinate(res.inputs[j - 1], res.inputs, j, res.model.transmission)
        moving = moving_mask(own, "auto") if coupled else np.asarray(res.moving)[:, i]
        keep = ~own_columns(res.model, j)
        known = res.X[:, i, :][:, keep] @ theta[keep]
        out[j] = joint_multi_sdp(
            own,
            known=known,
            inertia_source="full model",
            moving=moving,
            joint=j,
            sdp=MultiBackfitting(model=model, tol=tol, max_iter=max_iter),
        )
    return out
