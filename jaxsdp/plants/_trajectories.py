"""Reference trajectories and measurement noise for data generation.

Every generator evaluates a closed-form trajectory at given sample times `t`
(shape `(N,)`), so shapes are static and everything is `jit`/`vmap`/`grad`-able
in the trajectory parameters. Trajectories are returned as a `Trajectory`
(position, velocity, acceleration). Noise is drawn from an explicit PRNG key.
"""

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from .._checks import as_float_array, is_concrete
from .._runtime import x64

# Encoder of the EMPS: 50,000 counts per motor revolution. The benchmark
# expresses the position on the load side; the smallest increment found in
# DATA_EMPS.mat `qm` is 5e-8 m, i.e. a lead of 50,000 * 5e-8 = 2.5 mm per
# revolution. We use this lead so that simulated quantisation matches the data.
EMPS_COUNTS_PER_REV = 50_000
EMPS_LEAD = 2.5e-3  # m / rev (load-side travel per motor revolution)


class Trajectory(NamedTuple):
    """Sampled trajectory, as returned by the reference generators.

    **Fields:** `q` position (m or rad), `dq` velocity (m/s or rad/s), `ddq`
    acceleration (m/s^2 or rad/s^2), each of shape `(N,)` at the sample
    times given to the generator.
    """

    q: jax.Array
    dq: jax.Array
    ddq: jax.Array


def _times(t):
    return as_float_array("t", t, ndim=1)


def _knots(name, x, n=None):
    x = as_float_array(name, x, ndim=1)
    if n is not None and x.shape[0] != n:
        raise ValueError(f"`{name}` must have {n} entries; got {x.shape[0]}")
    return x


@x64
def bang_bang_reference(t, *, velocities, switch_times, accel, q0=0.0) -> Trajectory:
    r"""Piecewise-constant velocity with bang-bang acceleration transitions.

    Starting at rest at `q0`, the velocity moves to `velocities[i]` from time
    `switch_times[i]` on, with constant acceleration of magnitude `accel`
    (the EMPS benchmark's reference has this shape, with `accel` about
    0.842 m/s^2 and plateaus of +-0.042, 0.083, 0.125 m/s). Switch times
    should leave each transition `|dv_i| / accel` to complete.

    $$ \dot q(t) = \sum_i \Delta v_i \cdot clip((t - T_i) / d_i, 0, 1), \quad d_i = |\Delta v_i| / accel, $$

    with $\Delta v_i$ = `velocities[i] - velocities[i-1]`, $T_i$ = `switch_times[i]`;
    `q` and `ddq` are its exact integral and derivative.

    **Arguments:** `t` sample times (s), shape `(N,)`; `velocities` (m/s or
    rad/s) and `switch_times` (s), one per move; `accel` (m/s^2), `q0` (m).

    **Returns:** a `Trajectory`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import bang_bang_reference
        >>> t = np.arange(10) * 0.1  # s
        >>> r = bang_bang_reference(t, velocities=[0.1, 0.0], switch_times=[0.0, 0.5], accel=1.0)
        >>> np.round(np.asarray(r.dq), 3).tolist()  # m/s
        [0.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.0, 0.0, 0.0, 0.0]
        >>> round(float(r.q[-1]), 4)  # m travelled
        0.05
    """
    t = _times(t)
    vel = _knots("velocities", velocities)
    T = _knots("switch_times", switch_times, vel.shape[0])
    return _bang_bang(t, vel, T, jnp.asarray(accel, dtype=jnp.float64), jnp.asarray(q0, dtype=jnp.float64))


@jax.jit
def _bang_bang(t, vel, T, accel, q0):
    dv = jnp.diff(vel, prepend=0.0)
    d = jnp.abs(dv) / accel
    ds = jnp.where(d > 0, d, 1.0)
    tau = t[:, None] - T[None, :]
    inside = (tau >= 0) & (tau < d)
    ramp = jnp.clip(tau / ds, 0.0, 1.0)
    integ = jnp.where(tau <= 0, 0.0, jnp.where(tau < d, tau**2 / (2 * ds), tau - d / 2))
    q = q0 + integ @ dv
    dq = ramp @ dv
    ddq = jnp.where(inside, 1.0 / ds, 0.0) @ dv
    return Trajectory(q, dq, ddq)


# Quintic Hermite basis on s in [0, 1]: q(s) = H0 q_i + H1 T v_i + H2 T^2 a_i + H3 T^2 a_{i+1}
# + H4 T v_{i+1} + H5 q_{i+1}; row k holds the coefficients of s^0..s^5 of H_k.
_HERMITE = (
    (1.0, 0.0, 0.0, -10.0, 15.0, -6.0),
    (0.0, 1.0, 0.0, -6.0, 8.0, -3.0),
    (0.0, 0.0, 0.5, -1.5, 1.5, -0.5),
    (0.0, 0.0, 0.0, 0.5, -1.0, 0.5),
    (0.0, 0.0, 0.0, -4.0, 7.0, -3.0),
    (0.0, 0.0, 0.0, 10.0, -15.0, 6.0),
)


@x64
def quintic_reference(t, *, knot_times, knot_positions, knot_velocities=None, knot_accelerations=None) -> Trajectory:
    """Chain of fifth-order polynomial moves through knots (rest-to-rest, or through via-points).

    On move $i$, $[T_i, T_{i+1}]$ with duration $h_i$, the position is the
    quintic with the knots' position, velocity and acceleration at both ends
    (quintic Hermite interpolation, $s = (t - T_i) / h_i$ in $[0, 1]$):

    $$
    q(t) = H_0(s) q_i + H_1(s) h_i v_i + H_2(s) h_i^2 a_i + H_3(s) h_i^2 a_{i+1}
    + H_4(s) h_i v_{i+1} + H_5(s) q_{i+1}.
    $$

    Without velocities and accelerations (zero at every knot) each move is
    the rest-to-rest $q_i + (q_{i+1} - q_i)(10 s^3 - 15 s^4 + 6 s^5)$, the
    classic robot excitation; with them, the arm passes through via-points
    without stopping. Holds the end values outside `[T_0, T_last]` (so the
    first and last knots must be at rest). Repeat a position to dwell.

    **Arguments:** `t` sample times (s), shape `(N,)`; `knot_times` (s,
    strictly increasing) and `knot_positions` (m or rad), same length `>= 2`;
    optional `knot_velocities` (m/s or rad/s) and `knot_accelerations`
    (m/s^2 or rad/s^2), same length, zero at the first and last knot.

    **Returns:** a `Trajectory`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import quintic_reference
        >>> r = quintic_reference(np.array([0.0, 0.25, 0.5, 1.0]), knot_times=[0.0, 0.5], knot_positions=[0.0, 1.0])
        >>> np.round(np.asarray(r.q), 4).tolist(), np.round(np.asarray(r.dq), 4).tolist()  # rad, rad/s
        ([0.0, 0.5, 1.0, 1.0], [0.0, 3.75, 0.0, 0.0])
        >>> v = quintic_reference(np.array([0.5]), knot_times=[0.0, 0.5, 1.0], knot_positions=[0.0, 1.0, 0.0],
        ...                       knot_velocities=[0.0, 2.0, 0.0])
        >>> float(v.dq[0])  # through the via-point at 2 rad/s
        2.0
    """
    t = _times(t)
    kt = _knots("knot_times", knot_times)
    n = kt.shape[0]
    kq = _knots("knot_positions", knot_positions, n)
    if n < 2:
        raise ValueError("need at least 2 knots")
    ends = []
    for name, v in (("knot_velocities", knot_velocities), ("knot_accelerations", knot_accelerations)):
        v = jnp.zeros(n) if v is None else _knots(name, v, n)
        if is_concrete(v) and (float(v[0]) != 0.0 or float(v[-1]) != 0.0):
            raise ValueError(f"`{name}` must be 0 at the first and last knot (the reference holds its ends)")
        ends.append(v)
    if is_concrete(kt) and not bool(jnp.all(jnp.diff(kt) > 0)):
        raise ValueError("`knot_times` must be strictly increasing")
    return _quintic_chain(t, kt, kq, *ends)


@jax.jit
def _quintic_chain(t, kt, kq, kv, ka):
    i = jnp.clip(jnp.searchsorted(kt, t, side="right") - 1, 0, kt.shape[0] - 2)
    h = kt[i + 1] - kt[i]
    s = jnp.clip((t - kt[i]) / h, 0.0, 1.0)
    inside = (t > kt[0]) & (t < kt[-1])
    C = jnp.asarray(_HERMITE)
    powers = jnp.stack([s**k for k in range(6)], axis=-1)
    d1 = jnp.stack([k * s ** max(k - 1, 0) for k in range(6)], axis=-1)
    d2 = jnp.stack([k * (k - 1) * s ** max(k - 2, 0) for k in range(6)], axis=-1)
    w = jnp.stack([kq[i], h * kv[i], h**2 * ka[i], h**2 * ka[i + 1], h * kv[i + 1], kq[i + 1]], axis=-1)
    coef = w @ C  # (N, 6) polynomial coefficients in s
    q = jnp.sum(coef * powers, axis=-1)
    dq = jnp.where(inside, jnp.sum(coef * d1, axis=-1) / h, 0.0)
    ddq = jnp.where(inside, jnp.sum(coef * d2, axis=-1) / h**2, 0.0)
    return Trajectory(q, dq, ddq)


@x64
def step_reference(t, *, step_times, levels, q0=0.0) -> Trajectory:
    """Steps: `q(t) = levels[i]` for `step_times[i] <= t < step_times[i+1]`, `q0` before.

    Velocity and acceleration are returned as zeros (Dirac impulses omitted).

    **Arguments:** `t` sample times (s), shape `(N,)`; `step_times` (s) and
    `levels` (m or rad), one per step; `q0` the level before the first step.

    **Returns:** a `Trajectory`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import step_reference
        >>> r = step_reference(np.array([0.0, 0.5, 1.0, 1.5]), step_times=[0.5, 1.0], levels=[1.0, -1.0])
        >>> np.asarray(r.q).tolist()
        [0.0, 1.0, -1.0, -1.0]
    """
    t = _times(t)
    lv = _knots("levels", levels)
    T = _knots("step_times", step_times, lv.shape[0])
    return _steps(t, lv, T, jnp.asarray(q0, dtype=jnp.float64))


@jax.jit
def _steps(t, lv, T, q0):
    jumps = jnp.diff(lv, prepend=q0)
    q = q0 + (t[:, None] >= T[None, :]).astype(t.dtype) @ jumps
    z = jnp.zeros_like(q)
    return Trajectory(q, z, z)


@x64
def white_noise(key, n: int, *, sigma) -> jax.Array:
    r"""`n` samples of zero-mean Gaussian noise with standard deviation `sigma`.

    $w_k = \sigma \cdot N(0, 1)$ ($\sigma$ = `sigma`), independent, drawn from the JAX PRNG `key`; units
    of `sigma` (e.g. m for position noise). Returns shape `(n,)`.

    Example:
        >>> import jax, numpy as np
        >>> from jaxsdp.plants import white_noise
        >>> w = white_noise(jax.random.key(0), 10000, sigma=0.01)
        >>> w.shape, round(float(np.std(w)), 3)
        ((10000,), 0.01)
    """
    return _white_noise(key, n, jnp.asarray(sigma, dtype=jnp.float64))


@functools.partial(jax.jit, static_argnums=1)
def _white_noise(key, n, sigma):
    return sigma * jax.random.normal(key, (n,), dtype=jnp.float64)


@x64
def encoder_quantum(counts_per_rev: int = EMPS_COUNTS_PER_REV, lead: float = EMPS_LEAD) -> float:
    """Position increment of one encoder count, `lead / counts_per_rev`.

    Defaults: 50,000 counts/rev and a 2.5 mm/rev load-side lead, i.e. 5e-8 m,
    the increment observed in the EMPS data. `lead` in m/rev (or rad/rev for
    a joint, e.g. `2 pi / gear ratio`); the result in the units of `lead`.

    Example:
        >>> from jaxsdp.plants import encoder_quantum
        >>> encoder_quantum()  # m
        5e-08
    """
    if counts_per_rev <= 0 or lead <= 0:
        raise ValueError("`counts_per_rev` and `lead` must be > 0")
    return lead / counts_per_rev


@x64
def quantise(x, quantum) -> jax.Array:
    r"""Round to the nearest multiple of `quantum` (zero-mean error, uniform on +-quantum/2).

    $y = quantum \cdot round(x / quantum)$, elementwise; `x` and `quantum` in the
    same units (e.g. m, with `quantum = encoder_quantum()`).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import quantise
        >>> np.round(np.asarray(quantise(np.array([0.12, -0.26, 0.31]), 0.1)), 6).tolist()
        [0.1, -0.3, 0.3]
    """
    return _quantise(jnp.asarray(x, dtype=jnp.float64), jnp.asarray(quantum, dtype=jnp.float64))


@jax.jit
def _quantise(x, quantum):
    return jnp.round(x / quantum) * quantum


@x64
def measure(key, q, *, sigma=0.0, quantum=None) -> jax.Array:
    """Measured position: `quantise(q + sigma * N(0, 1), quantum)`.

    White Gaussian noise of standard deviation `sigma` (units of `q`, e.g.
    m), then rounding to the encoder step `quantum` (None: no rounding).
    Vmappable over `key` (independent noise realisations) and over `q`.
    Returns shape `(N,)` like `q`.

    Example:
        >>> import jax, numpy as np
        >>> from jaxsdp.plants import encoder_quantum, measure
        >>> m = measure(jax.random.key(1), np.zeros(5), sigma=1e-7, quantum=encoder_quantum())
        >>> counts = np.asarray(m) / encoder_quantum()
        >>> bool(np.allclose(counts, np.round(counts)))  # whole encoder counts
        True
    """
    q = as_float_array("q", q, ndim=1)
    y = q + _white_noise(key, q.shape[0], jnp.asarray(sigma, dtype=jnp.float64))
    return y if quantum is None else _quantise(y, jnp.asarray(quantum, dtype=jnp.float64))
