"""Exact stick-slip integration of `M ddq = u - f(dq)` for friction laws affine on each side of zero.

Each model is affine on each side of `v = 0`:
`f(v) = c(s) + k(s) * v` on the side `s = sign(v)` (one affine piece per table
segment for `TabulatedFriction`). At `v = 0` the friction is set-valued,
`f(0) in [f(0-), f(0+)]` (Filippov / stick-slip). Between two controller
samples the drive force `u` is held constant, so the motion on one side of
zero is a linear ODE with the closed form (`x = k h / M`)

    v(h) = v0 * exp(-x) + a h phi1(x) / M
    q(h) = q0 + v0 h phi1(x) + a h^2 phi2(x) / M,     a = u - c(s),

with `phi1(x) = (1 - e^{-x}) / x` and `phi2(x) = (x - 1 + e^{-x}) / x^2`.
`stick_slip_step` integrates this exactly, including the velocity zero
crossing: the crossing time is computed in closed form, the mass then sticks
(`v = 0` exactly) while `f(0-) <= u <= f(0+)`, or restarts on the other side
otherwise. For `LinearFriction` and `AsymmetricFriction` this is the exact
solution of the discontinuous ODE (for any step length); no smoothing of
`sign` is used. For `TabulatedFriction` the piece containing the current
velocity is used over the whole (sub)step: exact while the velocity stays in
one table segment, with an `O(h^2)` error each time a knot is crossed within
a step; use sub-steps to refine.

Hand-written rather than a generic ODE solver (diffrax): the closed form is exact across the
Coulomb discontinuity at any step length, where an adaptive solver must locate every velocity
zero crossing with events and still chatters while sticking.
"""

import jax.numpy as jnp


def _phis(x):
    """`phi1(x) = (1 - e^{-x}) / x` and `phi2(x) = (x - 1 + e^{-x}) / x^2`.

    Stable and differentiable at `x = 0` (Taylor series for `|x| < 1e-3`).
    """
    small = jnp.abs(x) < 1e-3
    xs = jnp.where(small, 1.0, x)
    em = jnp.expm1(-xs)
    phi1 = jnp.where(small, 1.0 - x / 2 + x**2 / 6 - x**3 / 24, -em / xs)
    phi2 = jnp.where(small, 0.5 - x / 6 + x**2 / 24 - x**3 / 120, (xs + em) / xs**2)
    return phi1, phi2


def _log1p_ratio(y):
    """`log1p(y) / y`, stable at `y = 0`, for `y > -1`."""
    small = jnp.abs(y) < 1e-6
    ys = jnp.where(small, 1.0, y)
    return jnp.where(small, 1.0 - y / 2 + y**2 / 3, jnp.log1p(ys) / ys)


def _affine_flow(v0, a, k, mass, h):
    """Exact flow of `M dv/dt = a - k v` over time `h` (`a`, `k` constant).

    Returns the displacement `q(h) - q(0)` and the velocity `v(h)`.
    """
    phi1, phi2 = _phis(k * h / mass)
    dq = v0 * h * phi1 + a * h**2 * phi2 / mass
    v = v0 * (1.0 - k * h / mass * phi1) + a * h * phi1 / mass  # e^{-x} = 1 - x phi1(x)
    return dq, v


def _rest_direction(u, friction):
    """Direction in which a mass at rest starts moving under drive `u` (0: stays)."""
    c_pos, _ = friction.branch(0.0, 1.0)
    c_neg, _ = friction.branch(0.0, -1.0)
    return jnp.where(u > c_pos, 1.0, jnp.where(u < c_neg, -1.0, 0.0))


def stick_slip_step(q0, v0, u, mass, friction, h):
    """Advance `M ddq = u - f(dq)` by `h` with `u` constant; returns `(q, v)`.

    Exact for friction laws affine on each side of zero, f(v) = c + k v: there
    `v(h) = v0 exp(-x) + a h phi1(x) / M`, `x = k h / M`, `a = u - c`.
    Phase A moves on the side of `v0` for `t_A = min(h, t*)`, where `t*` is the
    closed-form time at which the velocity reaches zero,
    `t* = (M / k) log1p(-k v0 / a)` (`t* = -M v0 / a` if `k = 0`). Phase B
    starts from rest for the remaining `h - t_A`: it sticks (`v = 0` exactly)
    if `f(0-) <= u <= f(0+)`, otherwise it moves on the side given by
    `_rest_direction`. Both phases are evaluated together as a length-2 vector.
    """
    s_rest = _rest_direction(u, friction)
    moving = v0 != 0
    s1 = jnp.where(v0 > 0, 1.0, -1.0)
    c1, k1 = friction.branch(v0, s1)
    a1 = u - c1
    decel = moving & (s1 * a1 < 0)  # net force at v = 0+ opposes the motion
    a1s = jnp.where(decel, a1, -s1)
    y = -k1 * v0 / a1s
    reach = decel & (y > -1.0)  # false: the velocity never reaches zero
    ys = jnp.where(reach, y, 0.0)
    t_star = -mass * v0 / a1s * _log1p_ratio(ys)
    cross = reach & (t_star <= h)
    t_a = jnp.where(moving, jnp.where(cross, t_star, h), 0.0)
    c2, k2 = friction.branch(0.0, s_rest)
    a2 = jnp.where(s_rest != 0, u - c2, 0.0)
    dq, v = _affine_flow(
        jnp.stack([v0, jnp.zeros_like(v0)]),
        jnp.stack([a1, a2]),
        jnp.stack([k1, k2]),
        mass,
        jnp.stack([t_a, h - t_a]),
    )
    q = q0 + dq[0] + dq[1]
    v = jnp.where(moving & ~cross, v[0], v[1])
    return q, v


def acceleration(v, u, mass, friction):
    """Right-limit acceleration `(u - f(v)) / M`, zero when stuck at `v = 0`."""
    s_rest = _rest_direction(u, friction)
    s = jnp.where(v > 0, 1.0, jnp.where(v < 0, -1.0, s_rest))
    c, k = friction.branch(v, s)
    return jnp.where(s != 0, (u - c - k * v) / mass, 0.0)
