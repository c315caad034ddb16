"""Joint logs brought to a rigid-body model's convention: joint-angle offsets and a coupled wrist (the TX40's)."""

import math

import jax.numpy as jnp
import numpy as np

from .._runtime import x64
from ._joint_logs import JointLogs, join_numbers

#: The TX40's joint-angle offsets from its logs' angles to the modified-DH angles of `tx40_robot` (rad, tx40.md).
TX40_JOINT_OFFSETS = (0.0, -math.pi / 2, math.pi / 2, 0.0, 0.0, 0.0)
#: The TX40's wrist coupling: the motor of joint 6 also turns with joint 5 (tx40.md).
TX40_WRIST_COUPLING = (5, 6)


def _coupling(coupling, joints):
    if coupling is None:
        return None
    try:
        a, b = (int(v) for v in coupling)
    except (TypeError, ValueError):
        raise ValueError(f"`coupling` must be None or a pair of joint numbers (a, b); got {coupling!r}") from None
    if a == b or a not in joints or b not in joints:
        raise ValueError(
            f"`coupling` ({a}, {b}) must name two different joints of the logs (joints {', '.join(map(str, joints))})"
        )
    return joints.index(a), joints.index(b)


def coupling_transmission(n: int, coupling) -> np.ndarray | None:
    """The transmission C (q = C u, u the motor angles divided by their ratios) of `model_convention`'s coupling
    (a, b): q_b = u_b - u_a, so C = I - e_b e_a^T; None without coupling."""
    if coupling is None:
        return None
    a, b = (int(v) for v in coupling)
    C = np.eye(n)
    C[b - 1, a - 1] = -1.0
    return C


@x64
def model_convention(logs: JointLogs, *, offsets=TX40_JOINT_OFFSETS, coupling=TX40_WRIST_COUPLING) -> JointLogs:
    """Joint logs read with diagonal gear ratios, brought to a rigid-body model's joint angles and torques.

    A log read by `load_joint_logs` holds q_j = pos_j / N_j and tau_j = N_j v_j.
    For a model in another angle convention and with a coupled wrist (the
    TX40: motor b turns with joint a, motor angles = C q with C = diag(N) +
    N_b e_b e_a^T, joint torques = D v with D = diag(N) + N_b e_a e_b^T):

        q_b <- q_b - q_a,    tau_a <- tau_a + tau_b    (coupling (a, b)),
        q_j <- q_j + offsets_j.

    **Arguments:** `logs` (`JointLogs`, all joints the model needs);
    `offsets` (one per log column, rad; default the TX40's
    (0, -pi/2, pi/2, 0, 0, 0), so that the log's upright-arm q2 = 0 becomes
    the MDH q2 = -pi/2); `coupling` (a, b) joint numbers or None (default the
    TX40's wrist, (5, 6)).

    **Returns:** a `JointLogs` in the model's convention (`converted` says how).

    Example:
        >>> import jax.numpy as jnp
        >>> from jaxsdp.data import JointLogs, model_convention
        >>> logs = JointLogs(q=jnp.ones((20, 6)), tau=jnp.ones((20, 6)), t=jnp.arange(20) * 2e-4, dt=2e-4,
        ...                  joints=(1, 2, 3, 4, 5, 6), source="logs", converted="diagonal")
        >>> m = model_convention(logs)
        >>> [round(float(v), 3) for v in m.q[0]], [float(v) for v in m.tau[0]]
        ([1.0, -0.571, 2.571, 1.0, 1.0, 0.0], [1.0, 1.0, 1.0, 1.0, 2.0, 1.0])
    """
    if not isinstance(logs, JointLogs):
        raise ValueError(f"`logs` must be a JointLogs (load_joint_logs); got {type(logs).__name__}")
    n = len(logs.joints)
    off = np.zeros(n) if offsets is None else np.asarray(offsets, dtype=np.float64)
    if off.shape != (n,) or not np.all(np.isfinite(off)):
        raise ValueError(f"`offsets` must be {n} finite angles (rad), one per log column; got {offsets!r}")
    pair = _coupling(coupling, logs.joints)
    q, tau = np.array(logs.q), np.array(logs.tau)
    dq = None if logs.dq is None else np.array(logs.dq)
    parts = []
    if pair is not None:
        a, b = pair
        q[:, b] -= q[:, a]
        if dq is not None:
            dq[:, b] -= dq[:, a]
        tau[:, a] += tau[:, b]
        parts.append(f"motor {logs.joints[b]} coupled with joint {logs.joints[a]} undone")
    q += off
    if np.any(off != 0):
        parts.append(f"joint-angle offsets {join_numbers(off)} rad")
    return JointLogs(
        q=jnp.asarray(q),
        tau=jnp.asarray(tau),
        t=logs.t,
        dt=logs.dt,
        joints=logs.joints,
        source=logs.source,
        converted="; ".join([logs.converted] + (parts or ["model convention = log convention"])),
        resampled=logs.resampled,
        dq=None if dq is None else jnp.asarray(dq),
        notes=logs.notes,
    )
