"""Exciting trajectories by gradient: Fourier series per joint minimising the base regressor's condition number.

Each joint follows a finite Fourier series of the fundamental w_f = 2 pi f0
(the usual form in robot identification, periodic, with closed-form rates):

    q_j(t) = q0_j + sum_{l=1..L} a_jl / (l w_f) sin(l w_f t) - b_jl / (l w_f) cos(l w_f t),

so dq_j = sum a_jl cos(l w_f t) + b_jl sin(l w_f t). The coefficients
minimise log cond(W) of the stacked base regressor W (`RobotModel.regressor`)
over one period sampled at `samples` instants, plus a quadratic penalty on
the excursions beyond the joint position, velocity and acceleration limits,
with exact gradients through the Newton-Euler regressor (BFGS, optimistix).
The result is then scaled about q0 until every limit holds exactly.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ..._runtime import x64


class Excitation(eqx.Module):
    """A Fourier-series trajectory per joint (see the module): `a`, `b` (n, L) rad/s, `q0` (n,) rad, `f0` Hz.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants.robot import Excitation
        >>> ex = Excitation(a=np.array([[1.0]]), b=np.zeros((1, 1)), q0=np.zeros(1), f0=0.5)
        >>> q, dq, ddq = ex.states(np.array([0.0, 0.5]))  # dq = cos(pi t): 1 at t = 0
        >>> float(dq[0, 0]), round(float(q[1, 0]), 4)  # q = sin(pi t) / pi
        (1.0, 0.3183)
    """

    a: jax.Array
    b: jax.Array
    q0: jax.Array
    f0: float = eqx.field(static=True)

    @x64
    def states(self, t):
        """(q rad, dq rad/s, ddq rad/s^2), each (len(t), n), at the instants `t` (s)."""
        t = jnp.asarray(t, dtype=jnp.float64)
        L = self.a.shape[1]
        w = 2 * jnp.pi * self.f0 * jnp.arange(1, L + 1)
        s, c = jnp.sin(t[:, None] * w), jnp.cos(t[:, None] * w)  # (N, L)
        q = self.q0 + s @ (self.a / w).T - c @ (self.b / w).T
        dq = c @ self.a.T + s @ self.b.T
        ddq = -s @ (self.a * w).T + c @ (self.b * w).T
        return q, dq, ddq


class ExcitationResult(eqx.Module):
    """`optimise_excitation`'s outcome: `excitation`, `cond` and `cond_start` (of the stacked base regressor over
    one period), `start` (the random start), `steps`, `limits` (the limits used).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.plants.robot import optimise_excitation, robot_model
        >>> arm = SerialRobot.from_mdh([[0, 0, 0, 0]], inertias=[(2.0, [0.3, 0, 0], np.zeros(6))], Fv=1.0, Fc=0.5)
        >>> res = optimise_excitation(robot_model(arm), harmonics=2, samples=40, max_steps=20)
        >>> sorted(res.limits)
        ['acceleration', 'q', 'velocity']
    """

    excitation: Excitation
    start: Excitation
    cond: float = eqx.field(static=True)
    cond_start: float = eqx.field(static=True)
    steps: int = eqx.field(static=True)
    limits: dict = eqx.field(static=True)


def _cond(model, ex, t):
    q, dq, ddq = ex.states(t)
    W = model.regressor(q, dq, ddq)
    s = jnp.linalg.svd(W.reshape(-1, W.shape[-1]), compute_uv=False)
    return s[0] / s[-1]


def _excess(ex, t, lo, hi, vmax, amax):
    q, dq, ddq = ex.states(t)
    r = jax.nn.relu
    return (
        jnp.sum(r(q - hi) ** 2 + r(lo - q) ** 2)
        + jnp.sum(r(jnp.abs(dq) - vmax) ** 2)
        + jnp.sum(r(jnp.abs(ddq) - amax) ** 2)
    )


def _fit_limits(ex, t, lo, hi, vmax, amax):
    """Scale the trajectory about q0 (q0 inside the limits) until every limit holds."""
    q, dq, ddq = (np.asarray(v) for v in ex.states(t))
    q0 = np.asarray(ex.q0)
    dev = q - q0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = [
            np.where(dev > 0, (hi - q0) / dev, np.where(dev < 0, (lo - q0) / dev, np.inf)).min(),
            (vmax / np.abs(dq)).min(),
            (amax / np.abs(ddq)).min(),
        ]
    k = min(1.0, *[float(v) for v in ratios]) * 0.999
    return eqx.tree_at(lambda e: (e.a, e.b), ex, (ex.a * k, ex.b * k))


@x64
def optimise_excitation(
    model,
    *,
    harmonics: int = 5,
    f0: float = 0.1,
    samples: int = 200,
    q_limits=None,
    velocity_limits=None,
    acceleration_limits=None,
    seed: int = 0,
    max_steps: int = 200,
) -> ExcitationResult:
    """A Fourier exciting trajectory for `model` (`robot_model`) minimising the condition number of its stacked
    base regressor, within the joint limits (see the module).

    `q_limits` (n, 2) rad (default: the robot's URDF limits, else +-pi),
    `velocity_limits` (n,) rad/s (default: the URDF's, else 2), `acceleration_limits`
    (n,) rad/s^2 (default 10); `harmonics` L, `f0` (Hz, one period 1/f0 s),
    `samples` per period, a seeded random start inside the limits.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.plants.robot import optimise_excitation, robot_model
        >>> arm = SerialRobot.from_mdh([[0, 0, 0, 0], [0, 0.4, 0, 0]], inertias=[(3.0, [0.2, 0, 0], np.zeros(6)),
        ...                            (1.5, [0.15, 0.02, 0], [0.01, 0, 0, 0.01, 0, 0.01])], Fv=1.0, Fc=0.5)
        >>> res = optimise_excitation(robot_model(arm), harmonics=3, samples=60, max_steps=40)
        >>> bool(res.cond < res.cond_start)
        True
    """
    robot = model.robot
    n = robot.n
    lim = robot.limits or {}
    names = robot.names or ()

    def urdf(k, default):
        vals = [lim.get(nm, (np.nan,) * 4)[k] for nm in names] if names else []
        return np.array([v if np.isfinite(v) else default for v in vals]) if vals else np.full(n, default)

    if q_limits is None:
        lo, hi = urdf(0, -np.pi), urdf(1, np.pi)
    else:
        ql = np.asarray(q_limits, dtype=float)
        if ql.shape != (n, 2) or not np.all(ql[:, 0] < ql[:, 1]):
            raise ValueError(f"`q_limits` must be ({n}, 2) rows (lower, upper) with lower < upper")
        lo, hi = ql[:, 0], ql[:, 1]
    vmax = urdf(2, 2.0) if velocity_limits is None else np.broadcast_to(np.asarray(velocity_limits, float), (n,))
    amax = (
        np.full(n, 10.0)
        if acceleration_limits is None
        else np.broadcast_to(np.asarray(acceleration_limits, float), (n,))
    )
    if not (np.all(vmax > 0) and np.all(amax > 0)):
        raise ValueError("velocity and acceleration limits must be positive")
    if not (isinstance(harmonics, int) and harmonics >= 1 and samples * n >= model.rank):
        raise ValueError(f"need harmonics >= 1 and samples x joints >= {model.rank} (the base parameters)")
    t = jnp.arange(samples) / (samples * f0)
    rng = np.random.default_rng(seed)
    scale = 0.3 * np.minimum(vmax, (hi - lo) * np.pi * f0)[:, None] / harmonics
    start = Excitation(
        a=jnp.asarray(rng.normal(size=(n, harmonics)) * scale),
        b=jnp.asarray(rng.normal(size=(n, harmonics)) * scale),
        q0=jnp.asarray(0.5 * (lo + hi)),
        f0=float(f0),
    )
    dense = jnp.linspace(0.0, 1.0 / f0, 20 * samples)  # the limits are checked between the samples too
    start = _fit_limits(start, dense, lo, hi, vmax, amax)
    lo_j, hi_j, v_j, a_j = (jnp.asarray(v) for v in (lo, hi, vmax, amax))

    def loss(params, _):
        ex = eqx.tree_at(lambda e: (e.a, e.b), start, params)
        return jnp.log(_cond(model, ex, t)) + 1e3 * _excess(ex, t, lo_j, hi_j, v_j, a_j)

    sol = optx.minimise(loss, optx.BFGS(rtol=1e-6, atol=1e-8), (start.a, start.b), max_steps=max_steps, throw=False)
    best = _fit_limits(eqx.tree_at(lambda e: (e.a, e.b), start, sol.value), dense, lo, hi, vmax, amax)
    return ExcitationResult(
        excitation=best,
        start=start,
        cond=float(_cond(model, best, t)),
        cond_start=float(_cond(model, start, t)),
        steps=int(sol.stats["num_steps"]),
        limits={"q": np.stack([lo, hi], 1).tolist(), "velocity": vmax.tolist(), "acceleration": amax.tolist()},
    )
