"""The one-joint model of a robot joint (the paper's eqs. 20-22): one joint seen as a one-degree-of-freedom arm.

$$ \tau = ZZ \\ddot q - g MX \\cos q + g MY \\sin q + F_v \\dot q + F_c sign(\\dot q) + offset $$

Its regressors and the bases of its gravity and friction SDP curves, for any joint of any robot (the joint's number
names the parameters). The TX40's link 2 (`_tx40_link2`) is one such joint; the general robot path uses this module,
not the TX40's.
"""

import jax.numpy as jnp

from ..._runtime import x64
from ..._signal.regressors import Regressors, regressors

#: Standard gravity (m/s^2) of the one-joint model's gravity columns.
GRAVITY = 9.81


def _names(joint) -> dict:
    if isinstance(joint, bool) or not isinstance(joint, int) or joint < 1:
        raise ValueError(f"`joint` must be a joint number >= 1; got {joint!r}")
    return {k: f"{k}{joint}" for k in ("ZZ", "MX", "MY", "Fv", "Fc", "offset")}


@x64
def gravity_basis(q, *, joint: int = 2, g=GRAVITY) -> Regressors:
    r"""Basis of a gravity SDP curve $d_q(q)$ (paper section 3.4): columns `[-g cos q, g sin q, 1]`.

    $d_q(q) = MX \cdot (-g \cos q) + MY \cdot g \sin q + offset_q$, parameters named
    `MX<joint>`, `MY<joint>` (kg m) and `offset` (N m), for `q` in rad.

    Example:
        >>> from jaxsdp.plants import gravity_basis
        >>> gravity_basis([0.0], g=9.81).X.tolist(), gravity_basis([0.0]).names
        ([[-9.81, 0.0, 1.0]], ('MX2', 'MY2', 'offset'))
    """
    n = _names(joint)
    q = jnp.asarray(q, dtype=jnp.float64)
    return regressors({n["MX"]: -g * jnp.cos(q), n["MY"]: g * jnp.sin(q), "offset": 1.0})


@x64
def friction_basis(dq, *, joint: int = 2) -> Regressors:
    r"""Basis of a friction SDP curve $d_{\dot q}(\dot q)$ (paper section 3.4): columns `[dq, sign dq, 1]`.

    $d_{\dot q}(\dot q) = F_v \dot q + F_c sign(\dot q) + offset_{\dot q}$, parameters named `Fv<joint>`
    (N m s/rad), `Fc<joint>` (N m) and `offset` (N m), for `dq` in rad/s
    (`sign(0) = 0`).

    Example:
        >>> from jaxsdp.plants import friction_basis
        >>> friction_basis([-0.5, 0.0]).X.tolist()
        [[-0.5, -1.0, 1.0], [0.0, 0.0, 1.0]]
    """
    n = _names(joint)
    dq = jnp.asarray(dq, dtype=jnp.float64)
    return regressors({n["Fv"]: dq, n["Fc"]: jnp.sign(dq), "offset": 1.0})


@x64
def joint_regressors(q, dq, ddq, *, joint: int = 2, g=GRAVITY) -> Regressors:
    r"""Regressors of one robot joint seen as a one-degree-of-freedom arm (the paper's eq. 22).

    $$ \tau = ZZ \ddot q - g MX \cos q + g MY \sin q + F_v \dot q + F_c sign(\dot q) + offset, $$

    columns `[ddq, -g cos q, g sin q, dq, sign dq, 1]` named `ZZ<j>, MX<j>,
    MY<j>, Fv<j>, Fc<j>, offset<j>` for joint j (kg m^2, kg m, kg m, N m s/rad,
    N m, N m for `q` in rad, `dq` in rad/s, `ddq` in rad/s^2 and the torque
    in N m; `sign(0) = 0`). The gravity columns assume the joint axis is
    horizontal and the rest of the arm still (eq. 20).

    **Arguments:** `q`, `dq`, `ddq` (N,); `joint` the joint number for the
    names (default 2); `g` (m/s^2).

    **Returns:** a `jaxsdp.Regressors` with `X` of shape `(N, 6)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import joint_regressors
        >>> reg = joint_regressors(np.array([0.0]), np.array([0.5]), np.array([2.0]))
        >>> reg.names
        ('ZZ2', 'MX2', 'MY2', 'Fv2', 'Fc2', 'offset2')
        >>> np.asarray(reg.X).round(2).tolist()
        [[2.0, -9.81, 0.0, 0.5, 1.0, 1.0]]
    """
    n = _names(joint)
    q, dq, ddq = (jnp.asarray(v, dtype=jnp.float64) for v in (q, dq, ddq))
    if not (q.ndim == dq.ndim == ddq.ndim == 1 and q.shape == dq.shape == ddq.shape):
        raise ValueError(
            f"`q`, `dq`, `ddq` must be 1-D of one length; got {tuple(q.shape)}, {tuple(dq.shape)}, {tuple(ddq.shape)}"
        )
    cols = {
        n["ZZ"]: ddq,
        n["MX"]: -g * jnp.cos(q),
        n["MY"]: g * jnp.sin(q),
        n["Fv"]: dq,
        n["Fc"]: jnp.sign(dq),
        n["offset"]: 1.0,
    }
    return regressors(cols)
