"""The full-model identification regressor of one joint of a serial robot: base parameters and drive columns.

The drive torque of joint j is linear in the stacked link parameters theta
(`SerialRobot.parameter_names`) and in its drive's Ia_j, Fv_j, Fc_j, offset_j:

    tau_j = Y_j(q, dq, ddq) theta + Ia_j ddq_j + Fv_j dq_j + Fc_j sign(dq_j) + offset_j,

with Y_j = d tau_j / d theta the joint's row of the rigid-body regressor (by the
Newton-Euler recursion written for the regressor, `_regressor`; exact because
the model is linear). Many columns are zero (links before j do not load
joint j) or linear combinations of others, so only the base parameters are
identifiable: the row stacked over random states (`base_parameters`) gives the
first independent columns in the parameters' order and the combinations the
others enter (e.g. ZZ2 + Ia2, since both multiply ddq2 alone).
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..._runtime import x64
from ..._signal.regressors import Regressors
from ._regressor import regressor_rows
from ._serial import BaseParameters, SerialRobot, base_parameters

#: The drive columns appended to a joint's rigid-body row: ddq_j, dq_j, sign(dq_j), 1.
DRIVE_COLUMNS = ("Ia", "Fv", "Fc", "offset")
#: Random states used to find the base parameters.
BASE_STATES = 400


def drive_matrix(n: int, transmission) -> tuple[np.ndarray, np.ndarray]:
    """(C^-1, G = C^-T) of the drives' transmission C (q = C u, u the motor angles; identity without one)."""
    C = np.eye(n) if transmission is None else np.asarray(transmission, dtype=float)
    Cinv = np.linalg.inv(C)
    return Cinv, Cinv.T


def stacked_rows(robot: SerialRobot, q, dq, ddq, Cinv, G, rows: tuple, columns: tuple | None = None):
    """(N, len(rows), 14 n): the drive-torque rows of joints `rows` (0-based): the rigid-body columns (10 n, by the
    Newton-Euler recursion of the regressor: `regressor_rows`), each motor's Ia/Fv/Fc columns G_jk [ddu_k, du_k,
    sign du_k] (3 n, du = C^-1 dq), one offset per joint (n); `columns` (static): only those (the base columns of a
    model), each formed once, in the compiled program. A NumPy `G`'s zeros are left out of the program (a motor a
    joint does not feel gives a zero column)."""
    n = robot.n
    felt = np.abs(G) > 0 if isinstance(G, np.ndarray) else np.ones((n, n), bool)
    cols = tuple(range(14 * n)) if columns is None else tuple(int(c) for c in columns)
    return regressor_rows(robot, q, dq, ddq, Cinv, G, tuple(rows), cols, tuple(map(tuple, felt.tolist())))


def joint_motors(n: int, joint: int, transmission) -> tuple[int, ...]:
    """The motors (0-based) whose torque joint `joint`'s row feels: every k with G[j, k] != 0 (joint torques
    tau = G tau_u, G = C^-T), each with its inertia and friction in its own coordinate u_k = (C^-1 q)_k;
    without a transmission, the joint's own motor alone."""
    _, G = drive_matrix(n, transmission)
    return tuple(int(k) for k in np.flatnonzero(np.abs(G[joint - 1]) > 1e-12))


def _joint_columns(n: int, joint: int, transmission) -> np.ndarray:
    """The columns of `stacked_rows` that act on joint `joint`'s row: the rigid body, the motors it feels, its
    offset (the layout of `JointModel.full_names`)."""
    motors = joint_motors(n, joint, transmission)
    drive = [10 * n + 3 * k + i for k in motors for i in range(3)]
    return np.concatenate([np.arange(10 * n), drive, [13 * n + joint - 1]]).astype(int)


def _joint_row(robot: SerialRobot, q, dq, ddq, joint: int, transmission) -> jax.Array:
    """(N, 10 n + 3 motors + 1): joint `joint`'s row of `stacked_rows`, the columns that act on it."""
    Cinv, G = drive_matrix(robot.n, transmission)
    W = stacked_rows(robot, q, dq, ddq, Cinv, G, (joint - 1,))[:, 0, :]
    return W[:, _joint_columns(robot.n, joint, transmission)]


def motor_coordinate(n: int, joint: int, transmission) -> np.ndarray | None:
    """Row j of C^-1 when joint j's motor turns in another coordinate than q_j (u_j = (C^-1 q)_j: the TX40's
    motor 6, q5 + q6), where its friction lives; None when u_j = q_j."""
    row = drive_matrix(n, transmission)[0][joint - 1]
    return None if np.allclose(row, np.eye(n)[joint - 1]) else row


def check_states(n: int, q, dq, ddq) -> list:
    """`q`, `dq`, `ddq` as float64 arrays of one shape (N, n); ValueError naming the first that is not."""
    out = []
    for k, v in (("q", q), ("dq", dq), ("ddq", ddq)):
        v = jnp.asarray(v, dtype=jnp.float64)
        if v.ndim != 2 or v.shape[1] != n:
            raise ValueError(f"`{k}` must have shape (N, {n}); got {tuple(v.shape)}")
        out.append(v)
    if not out[0].shape == out[1].shape == out[2].shape:
        raise ValueError("`q`, `dq`, `ddq` must have one shape")
    return out


def random_states(n: int, states: int, seed: int) -> tuple:
    """(q, dq, ddq), each (states, n): q uniform in [-pi, pi], dq and ddq standard normal (the states the base
    parameters are found on)."""
    kq, kv, ka = jax.random.split(jax.random.key(seed), 3)
    shape = (states, n)
    q = jax.random.uniform(kq, shape, jnp.float64, -jnp.pi, jnp.pi)
    return q, jax.random.normal(kv, shape, jnp.float64), jax.random.normal(ka, shape, jnp.float64)


class JointModel(NamedTuple):
    """The full-model regressor of one joint and its base parameters (`joint_model`).

    **Fields:** `robot` (the `SerialRobot` whose kinematics define the
    regressor); `joint` (1-based); `base` (`BaseParameters` over
    `full_names`: rank, independent and dependent names, the combinations);
    `full_names` (the 10 n link parameters, then `Ia<j>, Fv<j>, Fc<j>,
    offset<j>`); `nominal` (rank,): the robot's own base parameter values.

    **Methods:** `names` (the base parameters, by their independent column);
    `regressors(q, dq, ddq)` (a `Regressors` (N, rank) on joint angles,
    rates and accelerations (N, n), MDH convention); `full_regressor` (N, 10 n + 4);
    `rigid_names` (the base parameters that are not the joint's own friction
    or offset); `gravity(q, values)` the joint's gravity torque from base
    parameter values.
    """

    robot: SerialRobot
    joint: int
    base: BaseParameters
    full_names: tuple
    nominal: np.ndarray
    transmission: np.ndarray | None = None

    @property
    @x64
    def names(self) -> tuple:
        """The base parameters' names: their independent column (the combination is in `base.names`)."""
        return self.base.independent

    @property
    @x64
    def rank(self) -> int:
        """Number of base parameters."""
        return self.base.rank

    @x64
    def rigid_names(self) -> tuple:
        """The base parameters whose torque the SDP of the residual takes as known: all but the joint's own
        motor's friction and the joint's offset (a coupled motor's friction in the row stays known)."""
        own = {f"{k}{self.joint}" for k in ("Fv", "Fc", "offset")}
        return tuple(k for k in self.names if k not in own)

    @x64
    def full_regressor(self, q, dq, ddq) -> jax.Array:
        """[d tau_j / d theta, (G_jk [ddu_k, du_k, sign du_k]) per motor k it feels, 1] at each state: (N, 10 n +
        3 motors + 1); without a transmission [d tau_j / d theta, ddq_j, dq_j, sign dq_j, 1]."""
        return _joint_row(self.robot, *check_states(self.robot.n, q, dq, ddq), self.joint, self.transmission)

    @x64
    def regressors(self, q, dq, ddq) -> Regressors:
        """The base columns of `full_regressor`, named after `names`: tau_j = X beta (beta the base parameters)."""
        X = self.full_regressor(q, dq, ddq)[:, np.asarray(self.base.columns)]
        return Regressors(X=X, names=self.names)

    @x64
    def gravity(self, q, values) -> jax.Array:
        """The joint's gravity torque (N m) at angles `q` (N, n) predicted by base parameter `values` (rank,)."""
        zero = jnp.zeros_like(jnp.asarray(q, dtype=jnp.float64))
        X = self.regressors(q, zero, zero).X
        own = np.array([k.startswith("offset") for k in self.names])  # the constant is not gravity
        return X[:, ~own] @ jnp.asarray(values, dtype=jnp.float64)[~own]


@x64
def joint_model(
    robot: SerialRobot,
    *,
    joint: int,
    transmission=None,
    states: int = BASE_STATES,
    seed: int = 0,
    tol: float = 1e-8,
) -> JointModel:
    r"""The base parameters of one joint's full model: its first independent columns on random states.

    `transmission` (the drives' C, `jaxsdp.data.Drives.transmission`; None:
    independent joints): the row then holds the inertia and friction of every
    motor the joint feels, in the motor's own coordinate (the TX40's joint 5
    feels motor 6, its joint 6 turns with $\dot q_5 + \dot q_6$), as `robot_model` does.

    The row $[Y_j, \ddot q_j, \dot q_j, sign(\dot q_j), 1]$ is stacked over `states` random
    states ($q$ uniform in $[-\pi, \pi]$, $\dot q$ and $\ddot q$ standard normal, seeded) and
    `base_parameters` (relative tolerance `tol` on R's diagonal) splits the
    $10 n + 4$ parameters into `rank` independent ones and the rest, which only
    enter through the combinations $\beta = \theta_{ind} + K \theta_{dep}$.

    **Returns:** a `JointModel` (its `nominal` the robot's base values).

    Example:
        >>> from jaxsdp.plants import joint_model, tx40_robot
        >>> m = joint_model(tx40_robot(), joint=2)
        >>> m.rank, "ZZ2" in m.names, "Ia2" in m.base.dependent  # ZZ2 and Ia2 both multiply ddq2 only
        (38, True, True)
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    if isinstance(joint, bool) or not isinstance(joint, int) or not 1 <= joint <= robot.n:
        raise ValueError(f"`joint` must be a joint number in 1..{robot.n}; got {joint!r}")
    if not isinstance(states, int) or states < 10 * robot.n + 4:
        raise ValueError(f"`states` must be an int >= {10 * robot.n + 4} (the number of parameters); got {states!r}")
    C = None if transmission is None else np.asarray(transmission, dtype=float)
    if C is not None and (C.shape != (robot.n, robot.n) or abs(np.linalg.det(C)) < 1e-12):
        raise ValueError(f"`transmission` must be an invertible ({robot.n}, {robot.n}) matrix; got shape {C.shape}")
    W = np.asarray(_joint_row(robot, *random_states(robot.n, states, seed), joint, C))
    motors = joint_motors(robot.n, joint, C)
    drive = [(f"{k}{m + 1}", float(getattr(robot, k)[m])) for m in motors for k in DRIVE_COLUMNS[:3]]
    drive.append((f"offset{joint}", float(robot.offset[joint - 1])))
    names = robot.parameter_names() + tuple(k for k, _ in drive)
    base = base_parameters(W, names, tol=tol)
    theta = np.concatenate([np.asarray(robot.inertial).ravel(), [v for _, v in drive]])
    nominal = base.values(theta)
    return JointModel(robot=robot, joint=int(joint), base=base, full_names=names, nominal=nominal, transmission=C)
