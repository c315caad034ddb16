r"""WORK IN PROGRESS (issue 46, item 1; not wired in, not tested by the suite): the rigid-body regressor of a
serial robot by the Newton-Euler recursion written for it, on whole batches with the states last.

$\tau_j = \sum_{k \ge j} Y_{jk} \theta_k$, $\theta_k$ link k's `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]`. Forward: each
link's $\omega$, $\dot\omega$, $\dot v$ in its frame (as `SerialRobot._rnea`). Backward, by co-wrenches: joint j's
torque is $c_f \cdot f + c_n \cdot n$ of the wrench at its frame, with $(c_f, c_n) = (0, a_j)$ for a revolute joint
and $(a_j, 0)$ for a prismatic one; carried up to link k through each joint's wrench transform ($f' = R f$,
$n' = R n + p \times R f$), $c_f \leftarrow R^T (c_f + c_n \times p)$, $c_n \leftarrow R^T c_n$; then
$Y_{jk} = c_f \cdot F_k + c_n \cdot N_k$, written entry by entry without the 6 x 10 block of link k:
$J$-part $L(\dot\omega)^T c_n + L(\omega)^T (c_n \times \omega)$, $MS$-part
$c_f \times \dot\omega + \omega \times (\omega \times c_f) + \dot v \times c_n$, $M$-part $c_f \cdot \dot v$.

Every quantity is an array with the states last ((3, N) vectors, (3, 3, N) rotations) and every product is
written out as elementwise sums, which XLA's CPU code fuses and vectorises; a vmap of the per-state recursion,
or batched 3 x 3 matrix products, ran 4-8 times slower. Measured 2026-11-27 on the 2-core AMD EPYC machine, TX40
on 45,000 states, after compile: 0.24 s (equal to the Jacobian of `_rnea` to 4e-16), against 0.40 s for the
reverse-mode regressor of today and 0.135 s for pinocchio's loop (`benchmarks/robot_stacked.py`): not there
yet. Next: find where the remaining time goes (the 130 MB output written as 360 stacked rows; the transpose to
(N, n, 10 n) the callers want), and whether XLA runs these fusions on one core.
"""

import jax.numpy as jnp


def _mtv(R, v):
    return jnp.stack([R[0, i] * v[0] + R[1, i] * v[1] + R[2, i] * v[2] for i in range(3)])


def _cross(a, b):
    return jnp.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _kinematics(robot, q, dq, ddq):
    """Per link (R, p, w, dw, dv), states last: q, dq, ddq (n, N)."""
    N = q.shape[1]
    z = jnp.zeros((3, N), q.dtype)
    w, dw, dv = z, z, z.at[2].set(robot.g)
    out = []
    for j in range(robot.n):
        a, R0, p0 = robot.axis[j], robot.rotation[j], robot.translation[j]
        if robot._is_prismatic(j):
            R = jnp.broadcast_to(R0[:, :, None], (3, 3, N))
            p = p0[:, None] + (R0 @ a)[:, None] * q[j][None]
        else:
            c, s = jnp.cos(q[j]), jnp.sin(q[j])
            K = jnp.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
            rot = [[(c if i == k else 0.0) + s * K[i, k] + (1 - c) * a[i] * a[k] for k in range(3)] for i in range(3)]
            R = jnp.stack(
                [jnp.stack([R0[i, 0] * rot[0][k] + R0[i, 1] * rot[1][k] + R0[i, 2] * rot[2][k] for k in range(3)])
                 for i in range(3)]
            )  # fmt: skip
            p = jnp.broadcast_to(p0[:, None], (3, N))
        dv = _mtv(R, dv + _cross(dw, p) + _cross(w, _cross(w, p)))
        wr = _mtv(R, w)
        qa = a[:, None] * dq[j][None]
        if robot._is_prismatic(j):
            w, dw = wr, _mtv(R, dw)
            dv = dv + 2.0 * _cross(w, qa) + a[:, None] * ddq[j][None]
        else:
            w = wr + qa
            dw = _mtv(R, dw) + _cross(wr, qa) + a[:, None] * ddq[j][None]
        out.append((R, p, w, dw, dv))
    return out


def _entries(cf, cn, w, dw, dv):
    """The 10 entries c_f . F + c_n . N of one link's parameters."""
    u = _cross(cn, w)
    inertia = [
        dw[0] * cn[0] + w[0] * u[0],
        dw[1] * cn[0] + dw[0] * cn[1] + w[1] * u[0] + w[0] * u[1],
        dw[2] * cn[0] + dw[0] * cn[2] + w[2] * u[0] + w[0] * u[2],
        dw[1] * cn[1] + w[1] * u[1],
        dw[2] * cn[1] + dw[1] * cn[2] + w[2] * u[1] + w[1] * u[2],
        dw[2] * cn[2] + w[2] * u[2],
    ]
    ms = _cross(cf, dw) + _cross(w, _cross(w, cf)) + _cross(dv, cn)
    return inertia + [ms[0], ms[1], ms[2], cf[0] * dv[0] + cf[1] * dv[1] + cf[2] * dv[2]]


def ne_regressor_t(robot, q, dq, ddq):
    """(n, 10 n, N): the regressor of the states q, dq, ddq (N, n), states last."""
    n, N = robot.n, q.shape[0]
    links = _kinematics(robot, q.T, dq.T, ddq.T)
    zero = jnp.zeros((N,), q.dtype)
    out = []
    for j in range(n):
        a = jnp.broadcast_to(robot.axis[j][:, None], (3, N))
        cf, cn = (a, jnp.zeros_like(a)) if robot._is_prismatic(j) else (jnp.zeros_like(a), a)
        row = [zero] * (10 * j)
        for k in range(j, n):
            R, p, w, dw, dv = links[k]
            if k > j:
                cf, cn = _mtv(R, cf + _cross(cn, p)), _mtv(R, cn)
            row += _entries(cf, cn, w, dw, dv)
        out.append(jnp.stack(row, axis=0))
    return jnp.stack(out, axis=0)
