"""All joints at once: the stacked full-model regressor of a serial robot and its base parameters.

The drive torques of the chosen joints are linear in the stacked link
parameters theta (`SerialRobot.parameter_names`), in each motor's inertia,
viscous and Coulomb friction (in the motor's own coordinate, entering every
joint row the motor drives: `jaxsdp.data.Drives.motor_regressor`; without a
coupling, the usual per-joint Ia_j, Fv_j, Fc_j) and in one offset per joint:

    tau = Y(q, dq, ddq) theta + G (Ia ddu + Fv du + Fc sign(du)) + offset,   du = C^-1 dq,  G = C^-T.

Stacked over states and joints, the first independent columns on random states
(`base_parameters`, in the parameters' order) give the identifiable base parameters and the
combinations the others enter; IDIM-LS on the logs' samples (parallel
decimation, each joint's rows at rest left out) estimates them
(`RobotPipeline`, and `robot_idim_ls` with its host-side reading).
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._runtime import x64
from ._joint import (
    BASE_STATES,
    check_states,
    drive_matrix,
    random_states,
    stacked_rows,
)
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
        return self._stacked(q, dq, ddq, None)

    @x64
    def regressor(self, q, dq, ddq) -> jax.Array:
        """(N, len(rows), rank): the base columns of `full_regressor`."""
        return self._stacked(q, dq, ddq, tuple(int(c) for c in np.asarray(self.base.columns)))

    def _stacked(self, q, dq, ddq, columns):
        n = self.robot.n
        q, dq, ddq = check_states(n, q, dq, ddq)
        Cinv, G = drive_matrix(n, self.transmission)
        return stacked_rows(self.robot, q, dq, ddq, Cinv, G, tuple(j - 1 for j in self.rows), columns)


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
    """The base parameters of the stacked model of `joints` (default all): its first independent columns.

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
    base = base_parameters(W.reshape(-1, W.shape[-1]), names, tol=tol)
    nominal = base.values(full_parameters(robot))
    return RobotModel(robot=robot, rows=rows, base=base, full_names=names, nominal=nominal, transmission=C)


def full_parameters(robot: SerialRobot) -> np.ndarray:
    """The full parameter vector of `robot_model`'s `full_names`: 10 n inertial, (Ia, Fv, Fc) per joint, offsets."""
    drives = np.stack([np.asarray(robot.Ia), np.asarray(robot.Fv), np.asarray(robot.Fc)], axis=1).ravel()
    return np.concatenate([np.asarray(robot.inertial).ravel(), drives, np.asarray(robot.offset)])


def with_full_parameters(robot: SerialRobot, full) -> SerialRobot:
    """`robot` with the full parameter vector `full` (`full_parameters`' layout; pure JAX): its inertial
    parameters, motor inertias, friction and offsets replaced, the kinematics kept."""
    n = robot.n
    full = jnp.asarray(full)
    drives = full[10 * n : 13 * n].reshape(n, 3)
    new = (full[: 10 * n].reshape(n, 10), drives[:, 0], drives[:, 1], drives[:, 2], full[13 * n :])
    return eqx.tree_at(lambda r: (r.inertial, r.Ia, r.Fv, r.Fc, r.offset), robot, new)
