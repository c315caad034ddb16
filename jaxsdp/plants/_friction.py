"""Friction models and the exact stick-slip step used by the plant simulators.

All friction models are small `eqx.Module`s mapping a velocity `v` to a
friction force `f(v)` (SI units: N for a linear axis, N m for a joint). They
all include the constant `offset` term of the papers' inverse dynamic models,
so that a plant reads

    M * ddq = u - f(dq)

with `u` the drive force/torque.

**Coulomb treatment.** Each model is affine on each side of `v = 0`:
`f(v) = c(s) + k(s) * v` on the side `s = sign(v)` (one affine piece per table
segment for `TabulatedFriction`), exposed by `branch(v, s)`; at `v = 0` the
friction is set-valued, `f(0) in [f(0-), f(0+)]`. The simulators integrate it
exactly with `jaxsdp.plants._stick_slip`.

`__call__` uses the convention `sign(0) = 0`, i.e. `f(0) = (f(0-) + f(0+)) / 2`.
"""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import FINITE, FINITE_ARRAY, NONNEGATIVE, flag, is_concrete
from .._runtime import x64
from ._parameters import parameter


class AbstractFriction(eqx.Module):
    r"""A friction law `f(v)`, affine on each side of `v = 0` (base class).

    Model: $f(v) = c(s) + k(s) v$ on the side $s = sign(v)$, set-valued at
    $v = 0$ ($f(0) \in [f(0^-), f(0^+)]$); a plant reads $M \ddot q = u - f(\dot q)$. Velocity
    in m/s (rad/s for a joint), force in N (N m). Subclasses define
    `branch(v, side) -> (c, k)` and `constraints(prefix)`; calling the law,
    `f(v)`, evaluates it with sign(0) = 0, i.e. $f(0) = (f(0^-) + f(0^+)) / 2$.
    Implementations: `LinearFriction`, `AsymmetricFriction`,
    `TabulatedFriction`.
    """

    @abc.abstractmethod
    def branch(self, v, side):
        """Affine piece `f(w) ~ c + k * w` valid near `v` on side `side` of zero.

        `side > 0` selects the piece for `v >= 0` (at `v = 0`: the right limit
        `f(0+)`); otherwise the piece for `v <= 0`. Returns `(c, k)`.
        """

    @abc.abstractmethod
    def constraints(self, prefix: str = "friction"):
        """Validity constraints on the parameters (see `check_parameters`)."""

    @x64
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

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import LinearFriction
        >>> f = LinearFriction(Fv=203.5, Fc=20.4, offset=-3.2)
        >>> np.round(np.asarray(f(np.array([-0.1, 0.0, 0.1]))), 2).tolist()  # N at -0.1, 0, 0.1 m/s
        [-43.95, -3.2, 37.55]
    """

    Fv: jax.Array
    Fc: jax.Array
    offset: jax.Array

    @x64
    def __init__(self, Fv, Fc, offset=0.0):
        self.Fv = parameter("Fv", Fv, NONNEGATIVE)
        self.Fc = parameter("Fc", Fc, NONNEGATIVE)
        self.offset = parameter("offset", offset)

    @x64
    def branch(self, v, side):
        s = jnp.where(side > 0, 1.0, -1.0)
        return s * self.Fc + self.offset, self.Fv * jnp.ones_like(s)

    @x64
    def constraints(self, prefix="friction"):
        return [
            (f"{prefix}.Fv", self.Fv, NONNEGATIVE),
            (f"{prefix}.Fc", self.Fc, NONNEGATIVE),
            (f"{prefix}.offset", self.offset, FINITE),
        ]


class AsymmetricFriction(AbstractFriction):
    r"""Direction-dependent friction (the paper's eq. 17 with an offset):

    $$ f(v) = F_v^+ v + F_c^+ + offset \quad (v > 0), $$

    $$ f(v) = F_v^- v - F_c^- + offset \quad (v < 0), $$

    `Fv_pos`, `Fv_neg` in N/(m/s) (or N m/(rad/s)), `Fc_pos`, `Fc_neg`,
    `offset` in N (or N m). All four coefficients must be `>= 0`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import AsymmetricFriction
        >>> f = AsymmetricFriction(166.7, 20.14, 240.4, 20.63)
        >>> np.round(np.asarray(f(np.array([-0.1, 0.1]))), 2).tolist()  # N
        [-44.67, 36.81]
    """

    Fv_pos: jax.Array
    Fc_pos: jax.Array
    Fv_neg: jax.Array
    Fc_neg: jax.Array
    offset: jax.Array

    @x64
    def __init__(self, Fv_pos, Fc_pos, Fv_neg, Fc_neg, offset=0.0):
        self.Fv_pos = parameter("Fv_pos", Fv_pos, NONNEGATIVE)
        self.Fc_pos = parameter("Fc_pos", Fc_pos, NONNEGATIVE)
        self.Fv_neg = parameter("Fv_neg", Fv_neg, NONNEGATIVE)
        self.Fc_neg = parameter("Fc_neg", Fc_neg, NONNEGATIVE)
        self.offset = parameter("offset", offset)

    @x64
    def branch(self, v, side):
        pos = side > 0
        c = jnp.where(pos, self.Fc_pos, -self.Fc_neg) + self.offset
        k = jnp.where(pos, self.Fv_pos, self.Fv_neg)
        return c, k

    @x64
    def constraints(self, prefix="friction"):
        names = ("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")
        return [(f"{prefix}.{n}", getattr(self, n), NONNEGATIVE) for n in names] + [
            (f"{prefix}.offset", self.offset, FINITE)
        ]


def _check_grid(v_grid, f_grid):
    if v_grid.ndim != 1 or f_grid.ndim != 1:
        raise ValueError(f"`v_grid` and `f_grid` must be 1-D; got shapes {v_grid.shape} and {f_grid.shape}")
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
    `v_grid` in m/s (rad/s), `f_grid` in N (N m).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import TabulatedFriction
        >>> f = TabulatedFriction([-1.0, 0.0, 0.0, 1.0], [-220.0, -20.0, 20.0, 220.0])  # Coulomb jump at 0
        >>> np.round(np.asarray(f(np.array([-0.5, 0.5]))), 3).tolist()
        [-120.0, 120.0]
    """

    v_grid: jax.Array
    f_grid: jax.Array

    @x64
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

    @x64
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

    @x64
    def constraints(self, prefix="friction"):
        v = self.v_grid
        xnp = np if is_concrete(v) else jnp
        return [
            (f"{prefix}.v_grid", v, FINITE_ARRAY),
            (f"{prefix}.f_grid", self.f_grid, FINITE_ARRAY),
            (f"{prefix}.v_grid", xnp.any(xnp.diff(xnp.asarray(v)) < 0), flag("must be increasing")),
        ]
