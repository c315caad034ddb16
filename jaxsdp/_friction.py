"""Friction models and the exact stick-slip step used by the plant simulators.

All friction models are small `eqx.Module`s mapping a velocity `v` to a
friction force `f(v)` (SI units: N for a linear axis, N m for a joint). They
all include the constant `offset` term of the papers' inverse dynamic models,
so that a plant reads

    M * ddq = u - f(dq)

with `u` the drive force/torque.

**Coulomb treatment.** Each model is affine on each side of `v = 0`:
`f(v) = c(s) + k(s) * v` on the side `s = sign(v)` (one affine piece per table
segment for `TabulatedFriction`). At `v = 0` the friction is set-valued,
`f(0) in [f(0-), f(0+)]` (Filippov / stick-slip). Between two controller
samples the drive force `u` is held constant, so the motion on one side of
zero is a linear ODE with the closed form (`x = k h / M`)

    v(h) = v0 * exp(-x) + a h phi1(x) / M
    q(h) = q0 + v0 h phi1(x) + a h^2 phi2(x) / M,     a = u - c(s),

with `phi1(x) = (1 - e^{-x}) / x` and `phi2(x) = (x - 1 + e^{-x}) / x^2`.
`_stick_slip_step` integrates this exactly, including the velocity zero
crossing: the crossing time is computed in closed form, the mass then sticks
(`v = 0` exactly) while `f(0-) <= u <= f(0+)`, or restarts on the other side
otherwise. For `LinearFriction` and `AsymmetricFriction` this is the exact
solution of the discontinuous ODE (for any step length); no smoothing of
`sign` is used. For `TabulatedFriction` the piece containing the current
velocity is used over the whole (sub)step: exact while the velocity stays in
one table segment, with an `O(h^2)` error each time a knot is crossed within
a step; use sub-steps to refine.

`__call__` uses the convention `sign(0) = 0`, i.e. `f(0) = (f(0-) + f(0+)) / 2`.
"""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._checks import is_concrete

# --------------------------------------------------------------------------
# Parameter handling
#
# A constraint is `(name, value, kind)` with kind one of "positive",
# "nonnegative", "finite" (scalar parameters), "finite[]" (array parameters) or
# "flag:<message>" (then `value` is a boolean that is True when invalid).
# Concrete values are checked eagerly and raise ValueError naming the argument;
# traced values are all guarded together by a single `eqx.branched_error_if`.

_DESCRIPTION = {
    "positive": "must be > 0 and finite",
    "nonnegative": "must be >= 0 and finite",
    "finite": "must be finite",
    "finite[]": "must be finite",
}


def _bad(value, kind, xnp=jnp):
    """True if `value` violates `kind` (`xnp`: numpy for concrete values, so
    that no tracer is created inside a caller's `jit`)."""
    if kind.startswith("flag:"):
        return xnp.asarray(value, dtype=bool)
    v = xnp.asarray(value)
    bad = ~xnp.isfinite(v)
    if kind == "positive":
        bad = bad | ~(v > 0)
    elif kind == "nonnegative":
        bad = bad | ~(v >= 0)
    return xnp.any(bad)


def _message(name, kind):
    msg = kind[5:] if kind.startswith("flag:") else _DESCRIPTION[kind]
    return f"`{name}` {msg}"


def _check_concrete(name, value, kind):
    value = np.asarray(value) if kind.startswith("flag:") else np.asarray(value, dtype=np.float64)
    if bool(_bad(value, kind, np)):
        shown = "" if kind.startswith("flag:") else f"; got {np.asarray(value)}"
        raise ValueError(_message(name, kind) + shown)


def _parameter(name: str, value, kind: str = "finite"):
    """Store a model parameter: concrete values are checked now (ValueError) and
    kept as NumPy float64 (no precision loss outside `jax.enable_x64`); traced
    values are stored as they are and checked when a simulator uses them."""
    if is_concrete(value):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"`{name}` must be numeric; got {type(value).__name__}: {e}") from None
        _check_concrete(name, arr, kind)
        return arr
    return value


def _check_parameters(x, constraints):
    """Validate constraints; return `x` guarded by one error_if for the traced ones.

    Scalar kinds also require a 0-d value (vmap over batches of parameters).
    """
    traced = []
    for name, value, kind in constraints:
        if kind in ("positive", "nonnegative", "finite") and jnp.ndim(value) != 0:
            raise ValueError(
                f"`{name}` must be a scalar inside the simulation (vmap over batches); "
                f"got shape {tuple(jnp.shape(value))}"
            )
        if is_concrete(value):
            _check_concrete(name, value, kind)
        else:
            traced.append((name, value, kind))
    if not traced:
        return x
    flags = jnp.stack([_bad(v, k) for _, v, k in traced])
    msgs = [_message(n, k) for n, _, k in traced]
    return eqx.branched_error_if(x, jnp.any(flags), jnp.argmax(flags), msgs)


def _to64(tree):
    """Convert the array leaves of a model to float64 JAX arrays."""
    return jax.tree_util.tree_map(
        lambda x: jnp.asarray(x, dtype=jnp.float64) if eqx.is_array_like(x) else x, tree
    )


# --------------------------------------------------------------------------
# Friction models


class AbstractFriction(eqx.Module):
    """A friction law `f(v)`, affine on each side of `v = 0`."""

    @abc.abstractmethod
    def branch(self, v, side):
        """Affine piece `f(w) ~ c + k * w` valid near `v` on side `side` of zero.

        `side > 0` selects the piece for `v >= 0` (at `v = 0`: the right limit
        `f(0+)`); otherwise the piece for `v <= 0`. Returns `(c, k)`.
        """

    @abc.abstractmethod
    def constraints(self, prefix: str = "friction"):
        """Validity constraints on the parameters (see `_check_parameters`)."""

    @eqx.filter_jit
    def __call__(self, v):
        """Friction force at velocity `v`, with `sign(0) = 0`."""
        v = jnp.asarray(v)
        cp, kp = self.branch(v, jnp.ones_like(v))
        cn, kn = self.branch(v, -jnp.ones_like(v))
        return jnp.where(v > 0, cp + kp * v, jnp.where(v < 0, cn + kn * v, 0.5 * (cp + cn)))


class LinearFriction(AbstractFriction):
    """Viscous + Coulomb + offset: `f(v) = Fv * v + Fc * sign(v) + offset`.

    `Fv` in N/(m/s) (or N m/(rad/s)), `Fc` and `offset` in N (or N m).
    `Fv >= 0` and `Fc >= 0` are required.
    """

    Fv: jax.Array
    Fc: jax.Array
    offset: jax.Array

    def __init__(self, Fv, Fc, offset=0.0):
        self.Fv = _parameter("Fv", Fv, "nonnegative")
        self.Fc = _parameter("Fc", Fc, "nonnegative")
        self.offset = _parameter("offset", offset)

    def branch(self, v, side):
        s = jnp.where(side > 0, 1.0, -1.0)
        return s * self.Fc + self.offset, self.Fv * jnp.ones_like(s)

    def constraints(self, prefix="friction"):
        return [
            (f"{prefix}.Fv", self.Fv, "nonnegative"),
            (f"{prefix}.Fc", self.Fc, "nonnegative"),
            (f"{prefix}.offset", self.offset, "finite"),
        ]


class AsymmetricFriction(AbstractFriction):
    """Direction-dependent friction (the paper's eq. 17 with an offset):

        f(v) = Fv_pos * v + Fc_pos + offset    for v > 0
        f(v) = Fv_neg * v - Fc_neg + offset    for v < 0

    All four coefficients must be `>= 0`.
    """

    Fv_pos: jax.Array
    Fc_pos: jax.Array
    Fv_neg: jax.Array
    Fc_neg: jax.Array
    offset: jax.Array

    def __init__(self, Fv_pos, Fc_pos, Fv_neg, Fc_neg, offset=0.0):
        self.Fv_pos = _parameter("Fv_pos", Fv_pos, "nonnegative")
        self.Fc_pos = _parameter("Fc_pos", Fc_pos, "nonnegative")
        self.Fv_neg = _parameter("Fv_neg", Fv_neg, "nonnegative")
        self.Fc_neg = _parameter("Fc_neg", Fc_neg, "nonnegative")
        self.offset = _parameter("offset", offset)

    def branch(self, v, side):
        pos = side > 0
        c = jnp.where(pos, self.Fc_pos, -self.Fc_neg) + self.offset
        k = jnp.where(pos, self.Fv_pos, self.Fv_neg)
        return c, k

    def constraints(self, prefix="friction"):
        names = ("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")
        return [(f"{prefix}.{n}", getattr(self, n), "nonnegative") for n in names] + [
            (f"{prefix}.offset", self.offset, "finite")
        ]


def _check_grid(v_grid, f_grid):
    if v_grid.ndim != 1 or f_grid.ndim != 1:
        raise ValueError(
            f"`v_grid` and `f_grid` must be 1-D; got shapes {v_grid.shape} and {f_grid.shape}"
        )
    if v_grid.shape != f_grid.shape:
        raise ValueError(
            f"`v_grid` and `f_grid` must have the same length; got {v_grid.shape[0]} and {f_grid.shape[0]}"
        )
    if v_grid.shape[0] < 2:
        raise ValueError("`v_grid` needs at least 2 points")


class TabulatedFriction(AbstractFriction):
    """Friction curve given on a velocity grid (e.g. an SDP estimate).

    Linear interpolation between knots and linear extrapolation beyond the end
    knots (with the slope of the end segments). `v_grid` must be strictly
    increasing, except that the value `0` may appear twice to encode a Coulomb
    jump: `f(0-)` is then the `f_grid` value at the first zero and `f(0+)` the
    one at the second. Without a repeated zero the curve is continuous and the
    mass never sticks (unless the drive force equals `f(0)` exactly).
    """

    v_grid: jax.Array
    f_grid: jax.Array

    def __init__(self, v_grid, f_grid):
        if is_concrete(v_grid) and is_concrete(f_grid):
            v = np.asarray(v_grid, dtype=np.float64)
            f = np.asarray(f_grid, dtype=np.float64)
            _check_grid(v, f)
            if not (np.all(np.isfinite(v)) and np.all(np.isfinite(f))):
                raise ValueError("`v_grid` and `f_grid` must be finite")
            dv = np.diff(v)
            if np.any(dv < 0):
                raise ValueError("`v_grid` must be increasing")
            if np.any((dv == 0) & (v[:-1] != 0)):
                raise ValueError("`v_grid` may repeat only the value 0 (a Coulomb jump)")
            if np.sum(v == 0) > 2:
                raise ValueError("`v_grid` may contain 0 at most twice")
            self.v_grid, self.f_grid = v, f
        else:
            v, f = jnp.asarray(v_grid), jnp.asarray(f_grid)
            _check_grid(v, f)
            self.v_grid, self.f_grid = v, f

    def branch(self, v, side):
        vg, fg = self.v_grid, self.f_grid
        n = vg.shape[0]
        right = jnp.searchsorted(vg, v, side="right")
        left = jnp.searchsorted(vg, v, side="left")
        idx = jnp.clip(jnp.where(side > 0, right, left) - 1, 0, n - 2)
        v0, v1, f0, f1 = vg[idx], vg[idx + 1], fg[idx], fg[idx + 1]
        width = v1 - v0
        safe = jnp.where(width > 0, width, 1.0)
        k = jnp.where(width > 0, (f1 - f0) / safe, 0.0)
        return f0 - k * v0, k

    def constraints(self, prefix="friction"):
        v = self.v_grid
        xnp = np if is_concrete(v) else jnp
        return [
            (f"{prefix}.v_grid", v, "finite[]"),
            (f"{prefix}.f_grid", self.f_grid, "finite[]"),
            (f"{prefix}.v_grid", xnp.any(xnp.diff(xnp.asarray(v)) < 0), "flag:must be increasing"),
        ]


# --------------------------------------------------------------------------
# Exact stick-slip step


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


def _stick_slip_step(q0, v0, u, mass, friction, h):
    """Advance `M ddq = u - f(dq)` by `h` with `u` constant; returns `(q, v)`.

    Exact for friction laws affine on each side of zero (see module docstring).
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


def _acceleration(v, u, mass, friction):
    """Right-limit acceleration `(u - f(v)) / M`, zero when stuck at `v = 0`."""
    s_rest = _rest_direction(u, friction)
    s = jnp.where(v > 0, 1.0, jnp.where(v < 0, -1.0, s_rest))
    c, k = friction.branch(v, s)
    return jnp.where(s != 0, (u - c - k * v) / mass, 0.0)
