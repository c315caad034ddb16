r"""The joint-torque regressor of a serial robot by the Newton-Euler recursion written for it (no differentiation).

Link k's wrench about its origin, in its frame, is linear in its parameters
$\phi_k$ = `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` (`_serial`'s notation):

    F_k = M dv_k + dw_k x MS + w_k x (w_k x MS),   N_k = J dw_k + w_k x (J w_k) + MS x dv_k.

Joint j's torque is the sum over the links k >= j it carries of the wrench's
component along j's axis, taken in frame k with the joint's unit screw
$(u_{jk}, v_{jk}) = (R_{jk}^T a_j, R_{jk}^T (a_j \times p_{jk}))$ (revolute;
prismatic $(0, R_{jk}^T a_j)$): $\tau_j = \sum_k u_{jk} \cdot N_k + v_{jk} \cdot F_k$. The screw moves
link by link like a twist,

    u_{j,k} = R_k^T u_{j,k-1},   v_{j,k} = R_k^T (v_{j,k-1} + u_{j,k-1} x p_k),

and the block of row j and link k is, with $L(x)$ the 3 x 6 map $J x = L(x) \phi_J$,

    d tau_j / d phi_J = L(dw)^T u + L(w)^T (u x w),
    d tau_j / d MS    = dv x u + v x dw + (v x w) x w,
    d tau_j / d M     = v . dv

(zero for k < j). The recursion (forward for w, dw, dv; the screws) is
written on batches of scalars, the components of 3-vectors and entries of
rotations as arrays over the states.

**One pass over the states.** Each entry is a short expression of shared
intermediates; as separate outputs, XLA-CPU compiles one loop per entry and
forms the whole recursion again in each (measured 0.4 s on 45,000 TX40
states, against 0.22 s for reverse-mode differentiation of the torques, and
0.33 s for `lax.scan`s over the links, whose loop bodies do the same). The
entries are therefore the operands of one variadic reduction over a doubled
state axis (each state twice, kept by `max`: exact), which XLA compiles to one
loop that forms the recursion once per state and writes every entry (0.03 s
for the TX40's 231 nonzero entries): whole rows, at most `GROUP` entries per
loop, the motors' entries in a loop of their own. One stack then writes the
rows in their final layout. The drive columns
$G_{jk} [\ddot u_k, \dot u_k, sign(\dot u_k)]$ ($\dot u = C^{-1} \dot q$) are entries of the same
loops; a motor the joint does not feel (a zero of a NumPy G) is a constant zero.

**Derivatives.** The reduction has none, so the derivative (forward and
reverse mode) is that of the same rows formed the old way, by reverse-mode
differentiation of the Newton-Euler torques (`jax.custom_jvp`; differentiating
the recursion's expressions instead compiles about 5 times longer).
`SerialRobot._rnea`'s derivative is the reference in the tests.
"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _add(*vs):
    return tuple(sum(c) for c in zip(*vs, strict=True))


def _scale(s, a):
    return tuple(s * x for x in a)


def _rt(R, v):
    """R^T v with R a 3 x 3 nested tuple."""
    return tuple(R[0][c] * v[0] + R[1][c] * v[1] + R[2][c] * v[2] for c in range(3))


def _frame(R0, p0, a, q, prismatic: bool):
    """(R_j, p_j) of a joint at angle or position q (an array over the states); R0, p0, a its origin and axis."""
    if prismatic:
        return R0, tuple(p0[r] + (R0[r][0] * a[0] + R0[r][1] * a[1] + R0[r][2] * a[2]) * q for r in range(3))
    c, s = jnp.cos(q), jnp.sin(q)
    C = 1.0 - c
    K = ((0.0, -a[2], a[1]), (a[2], 0.0, -a[0]), (-a[1], a[0], 0.0))
    rot = [[(c if r == k else 0.0) + s * K[r][k] + C * a[r] * a[k] for k in range(3)] for r in range(3)]
    R = tuple(tuple(sum(R0[r][i] * rot[i][k] for i in range(3)) for k in range(3)) for r in range(3))
    return R, p0


def _block(u, v, w, dw, dv) -> list:
    """The 10 entries d tau_j / d phi_k of a joint's screw (u, v) on a link's motion (w, dw, dv)."""
    y = _cross(u, w)
    jj = [
        dw[0] * u[0] + w[0] * y[0],
        dw[1] * u[0] + dw[0] * u[1] + w[1] * y[0] + w[0] * y[1],
        dw[2] * u[0] + dw[0] * u[2] + w[2] * y[0] + w[0] * y[2],
        dw[1] * u[1] + w[1] * y[1],
        dw[2] * u[1] + dw[1] * u[2] + w[2] * y[1] + w[1] * y[2],
        dw[2] * u[2] + w[2] * y[2],
    ]
    ms = _add(_cross(dv, u), _cross(v, dw), _cross(_cross(v, w), w))
    return jj + list(ms) + [v[0] * dv[0] + v[1] * dv[1] + v[2] * dv[2]]


def _entries(robot, Cinv, G, wanted: tuple, q, dq, ddq) -> list:
    """The entries `wanted` ((row j, column c) pairs, 0-based) of the drive-torque regressor at the states q, dq, ddq
    (..., n), each an array over the states: rigid-body (c < 10 n, link c // 10 >= j) or a motor's (10 n <= c <
    13 n: G_jk [ddu_k, du_k, sign du_k][i], c = 10 n + 3 k + i, du = C^-1 dq)."""
    rotation, translation, axis, g = robot.rotation, robot.translation, robot.axis, robot.g
    n = robot.n
    prismatic = tuple(robot._is_prismatic(j) for j in range(n))
    rigid = [(j, c) for j, c in wanted if c < 10 * n]
    last = max((c // 10 for _, c in rigid), default=-1)
    zero = jnp.zeros(q.shape[:-1], q.dtype)
    vec = lambda x: tuple(x[r] for r in range(3))
    w, dw, dv = (zero,) * 3, (zero,) * 3, (zero, zero, zero + g)
    frames, motion = [], []
    for j in range(last + 1):
        a = vec(axis[j])
        R, p = _frame(tuple(vec(rotation[j, r]) for r in range(3)), vec(translation[j]), a, q[..., j], prismatic[j])
        dv = _rt(R, _add(dv, _cross(dw, p), _cross(w, _cross(w, p))))
        wr = _rt(R, w)
        qd, qdd = dq[..., j], ddq[..., j]
        if prismatic[j]:
            w, dw = wr, _rt(R, dw)
            dv = _add(dv, _scale(2.0, _cross(w, _scale(qd, a))), _scale(qdd, a))
        else:
            w = _add(wr, _scale(qd, a))
            dw = _add(_rt(R, dw), _cross(wr, _scale(qd, a)), _scale(qdd, a))
        frames.append((R, p))
        motion.append((w, dw, dv))
    blocks = {}
    for j in sorted({j for j, _ in rigid}):
        links = {c // 10 for jj, c in rigid if jj == j}
        a = tuple(axis[j, r] + zero for r in range(3))
        u, v = ((zero,) * 3, a) if prismatic[j] else (a, (zero,) * 3)
        for k in range(j, max(links) + 1):
            if k > j:
                R, p = frames[k]
                u, v = _rt(R, u), _rt(R, _add(v, _cross(u, p)))
            if k in links:
                blocks[j, k] = _block(u, v, *motion[k])
    return [blocks[j, c // 10][c % 10] if c < 10 * n else _motor_entry(G, Cinv, j, c, n, dq, ddq) for j, c in wanted]


def _motor_entry(G, Cinv, j, c, n, dq, ddq):
    k, i = divmod(c - 10 * n, 3)
    value = sum(Cinv[k, m] * (ddq if i == 0 else dq)[..., m] for m in range(n))
    return G[j, k] * (jnp.sign(value) if i == 2 else value)


#: Most entries per pass (whole rows; a row of more has its own): a pass's compile time grows faster than its
#: entries, and erratically when a pass splits rows or mixes motor entries in (measured with 12 joints: 16 s for
#: row-aligned passes of up to 128, 112 s and 145 s for passes split anywhere; 7 joints' 280 entries in one
#: pass 5 s)
GROUP = 128


def _layout(n: int, rows: tuple, cols: tuple, felt: tuple) -> tuple:
    """The entries of the (len(rows), len(cols)) rows that are not constants: rigid body of a link at or after the
    joint, motor columns of a motor the joint feels (`felt`[j][k]); the offsets are 1 on their joint, else 0."""

    def nonzero(j, c):
        return c // 10 >= j if c < 10 * n else c < 13 * n and felt[j][(c - 10 * n) // 3]

    return tuple((j, c) for j in rows for c in cols if nonzero(j, c))


def _assemble(values: dict, n, rows, cols, like):
    """(N, len(rows), len(cols)) from the entries `values` ((j, c) -> (N,)) and the constants, in one stack (its
    loop writes the result once: a gather from a stacked source reads it twice)."""
    zero, one = jnp.zeros(like.shape[0], like.dtype), jnp.ones(like.shape[0], like.dtype)
    out = [values.get((j, c), one if c == 13 * n + j else zero) for j in rows for c in cols]
    return jnp.stack(out, axis=-1).reshape(like.shape[0], len(rows), len(cols))


@functools.partial(jax.custom_jvp, nondiff_argnums=(0,))
def _fused(spec, robot, Cinv, G, q, dq, ddq):
    """The rows by one pass over the states (the module's docstring)."""
    rows, cols, felt = spec
    n = robot.n
    wanted = _layout(n, rows, cols, felt)
    twice = [jnp.stack([x, x], axis=1) for x in (q, dq, ddq)]  # a broadcast: XLA splits the loop again (3x slower)
    low = jnp.array(-jnp.inf, q.dtype)
    values = {}
    groups = [[]]
    for row in rows:  # whole rows, as many as fit in GROUP entries, per pass
        keys = [(j, c) for j, c in wanted if j == row and c < 10 * n]
        if groups[-1] and len(groups[-1]) + len(keys) > GROUP:
            groups.append([])
        groups[-1] += keys
    groups.append([(j, c) for j, c in wanted if c >= 10 * n])
    for keys in filter(None, groups):
        part = _entries(robot, Cinv, G, keys, *twice)
        part = jax.lax.reduce(tuple(part), (low,) * len(part), lambda x, y: tuple(map(jnp.maximum, x, y)), (1,))
        values.update(zip(keys, part, strict=True))
    return _assemble(values, n, rows, cols, q)


def _by_derivative(spec, robot, Cinv, G, q, dq, ddq):
    """The same rows with the rigid body's by reverse-mode differentiation of the Newton-Euler torques, and one
    gather: `_fused`'s derivative (the reduction has none; differentiating `_entries` compiles ~5x longer,
    and an entry-by-entry selection here ~20x)."""
    rows, cols, felt = spec
    n, N = robot.n, q.shape[0]
    wanted = _layout(n, rows, cols, felt)
    rigid = tuple(sorted({j for j, c in wanted if c < 10 * n}))
    idx = jnp.asarray(rigid, dtype=int)

    def one(a, b, c):
        return jax.jacrev(lambda th: robot._rnea(th.reshape(n, 10), a, b, c, robot.g)[idx])(robot.inertial.ravel())

    Y = jax.vmap(one)(q, dq, ddq).reshape(N, -1) if rigid else jnp.zeros((N, 0), q.dtype)
    motor = jnp.stack([ddq @ Cinv.T, dq @ Cinv.T, jnp.sign(dq @ Cinv.T)], axis=-1).reshape(N, 3 * n)
    drive = (jnp.repeat(G[jnp.asarray(rows)], 3, axis=1)[None] * motor[:, None, :]).reshape(N, -1)
    source = jnp.concatenate([Y, drive, jnp.zeros((N, 1), q.dtype), jnp.ones((N, 1), q.dtype)], axis=-1)
    at, nonzero = {j: i for i, j in enumerate(rigid)}, set(wanted)
    base, zero = Y.shape[1], source.shape[1] - 2
    index = []
    for r, j in enumerate(rows):
        for c in cols:
            if (j, c) not in nonzero:
                index.append(zero + 1 if c == 13 * n + j else zero)
            elif c < 10 * n:
                index.append(10 * n * at[j] + c)
            else:
                index.append(base + 3 * n * r + c - 10 * n)
    return source[:, np.asarray(index)].reshape(N, len(rows), len(cols))


@_fused.defjvp
def _fused_jvp(spec, primals, tangents):
    return jax.jvp(lambda *args: _by_derivative(spec, *args), primals, tangents)


@eqx.filter_jit
def regressor_rows(robot, q, dq, ddq, Cinv, G, rows: tuple, cols: tuple, felt: tuple) -> jax.Array:
    """(N, len(rows), len(cols)): the drive-torque regressor's rows `rows` (joints, 0-based) and columns `cols`
    (0-based in `[theta (10 n), Ia, Fv, Fc per motor (3 n), offsets (n)]`) at the states q, dq, ddq (N, n), with
    the drives' C^-1 and G = C^-T (n, n); `felt` (n x n bools, static): G's structure (False: a zero column).
    Derivatives (in the states, the kinematics, the drives; forward and reverse mode) are those of the
    Newton-Euler torques' derivative (`jax.custom_jvp`)."""
    Cinv, G = jnp.asarray(Cinv, q.dtype), jnp.asarray(G, q.dtype)
    return _fused((tuple(rows), tuple(cols), tuple(felt)), robot, Cinv, G, q, dq, ddq)
