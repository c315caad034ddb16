"""TX40 link 2 ("only link 2 moving", paper section 3.4.1) under PD joint control.

Plant, the paper's eqs. (20)-(21) (SI units, joint side):

    ZZ2 * ddq + tau_grav(q) + f(dq) = tau,
    tau_grav(q) = -g * MX2 * cos(q) + g * MY2 * sin(q),
    f(dq) = Fv2 * dq + Fc2 * sign(dq) + offset2,

with the reference values of the paper's Table 4 as defaults (ZZ2 1.60 kg m^2,
MX2 2.80 kg m, MY2 0, Fv2 5.68 N m s/rad, Fc2 7.77 N m, offset2 0).

Controller (discrete, default 5 kHz): PD on the joint error, backward
difference for the derivative,

    tau(k) = sat( kp * e(k) + kd * (e(k) - e(k-1)) / dt ),   e = qr - q_meas,

applied through `delay` (0 or 1) samples, zero-order hold.

Integration between samples: `substeps` steps per sample; on each, gravity is
frozen at the predicted mid-step position `q + dq h / 2` (second order) and
the friction is integrated exactly with the stick-slip flow of
`jaxsdp.plants._stick_slip` (closed-form zero crossing and sticking, no smoothing).

The full 6-joint serial chain from the modified Denavit-Hartenberg table
(Table 3) is not implemented: the paper gives the geometry but not the
inertial parameters of the other links.
"""

import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp

from ..._checks import FINITE, FINITE_ARRAY, NONNEGATIVE, POSITIVE
from ..._runtime import x64
from .._friction import AbstractFriction, LinearFriction
from .._parameters import check_parameters, parameter, to64
from .._sampling import quantise_rounding, sampled_signal, time_grid
from .._stick_slip import acceleration, stick_slip_step
from ._joint_model import GRAVITY

# Reference values of the paper's Table 4.
TX40_LINK2_REFERENCE = dict(ZZ2=1.60, MX2=2.80, MY2=0.0, Fv2=5.68, Fc2=7.77, offset2=0.0)
#: Gear ratios N_j = motor angle / joint angle of the TX40's six joints (`tx40.md`).
TX40_GEAR_RATIOS = (32.0, 32.0, 45.0, -48.0, 45.0, 32.0)


class TX40Link2(eqx.Module):
    r"""Second link of the TX40: inertia `ZZ2` (kg m^2), first moments `MX2`, `MY2`
    (kg m), friction law (N m), gravity `g` (m/s^2).

    Model (the paper's eqs. 20-21), joint angle $q$ in rad, torque in N m:

    $$ ZZ_2 \ddot q + \tau_{grav}(q) + f(\dot q) = \tau, \quad \tau_{grav}(q) = -g MX_2 \cos q + g MY_2 \sin q, $$

    with `friction` an `AbstractFriction` $f$ (default `LinearFriction(Fv2,
    Fc2, offset2)`). Defaults are the paper's Table 4 values
    (`TX40_LINK2_REFERENCE`).
    """

    ZZ2: jax.Array
    MX2: jax.Array
    MY2: jax.Array
    friction: AbstractFriction
    g: jax.Array

    @x64
    def __init__(
        self,
        ZZ2=TX40_LINK2_REFERENCE["ZZ2"],
        MX2=TX40_LINK2_REFERENCE["MX2"],
        MY2=TX40_LINK2_REFERENCE["MY2"],
        friction: AbstractFriction | None = None,
        g=GRAVITY,
    ):
        self.ZZ2 = parameter("ZZ2", ZZ2, POSITIVE)
        self.MX2 = parameter("MX2", MX2)
        self.MY2 = parameter("MY2", MY2)
        if friction is None:
            r = TX40_LINK2_REFERENCE
            friction = LinearFriction(r["Fv2"], r["Fc2"], r["offset2"])
        if not isinstance(friction, AbstractFriction):
            raise ValueError(f"`friction` must be a friction model; got {type(friction).__name__}")
        self.friction = friction
        self.g = parameter("g", g)

    @x64
    def gravity(self, q):
        """`tau_grav(q) = -g MX2 cos(q) + g MY2 sin(q)` (N m)."""
        return -self.g * self.MX2 * jnp.cos(q) + self.g * self.MY2 * jnp.sin(q)

    @x64
    def inverse_dynamics(self, q, dq, ddq):
        """Torque of eq. (20), `ZZ2 ddq + tau_grav(q) + f(dq)` (with `sign(0) = 0`)."""
        return self.ZZ2 * ddq + self.gravity(q) + self.friction(dq)

    @x64
    def constraints(self):
        own = [("ZZ2", self.ZZ2, POSITIVE)] + [(n, getattr(self, n), FINITE) for n in ("MX2", "MY2", "g")]
        return own + self.friction.constraints("friction")


class PDController(eqx.Module):
    r"""Discrete PD joint controller: `kp` (N m/rad), `kd` (N m s/rad),
    saturation `tau_max` (N m), `delay` (static, 0 or 1 samples).

    Defaults: critically damped 10 Hz loop on the reference inertia,
    $k_p = ZZ_2 \omega^2$, $k_d = 2 ZZ_2 \omega$, $\omega = 2 \pi \cdot 10$ rad/s; `tau_max = 100` N m.
    """

    kp: jax.Array
    kd: jax.Array
    tau_max: jax.Array
    delay: int = eqx.field(static=True)

    @x64
    def __init__(self, kp=1.60 * (2 * math.pi * 10) ** 2, kd=2 * 1.60 * 2 * math.pi * 10, tau_max=100.0, delay=1):
        self.kp = parameter("kp", kp)
        self.kd = parameter("kd", kd)
        self.tau_max = parameter("tau_max", tau_max, POSITIVE)
        if delay not in (0, 1):
            raise ValueError(f"`delay` must be 0 or 1; got {delay!r}")
        self.delay = int(delay)

    @x64
    def constraints(self):
        return [("kp", self.kp, FINITE), ("kd", self.kd, FINITE), ("tau_max", self.tau_max, POSITIVE)]


class TX40Simulation(NamedTuple):
    """Sampled closed-loop trajectories of `simulate_tx40_link2`, all of shape `(N,)`, at `t_k`.

    **Fields:** `t` (s); `q` (rad), `dq` (rad/s): joint state at `t_k`; `ddq`
    (rad/s^2): acceleration just after `t_k` (right limit); `q_meas` (rad):
    the position the controller read (with noise/quantisation); `tau` (N m):
    torque acting on `[t_k, t_{k+1})`, so that eq. (20) holds sample by sample.
    """

    t: jax.Array
    q: jax.Array
    dq: jax.Array
    ddq: jax.Array
    q_meas: jax.Array
    tau: jax.Array


@eqx.filter_jit
def _simulate(qr, t, dt, plant, controller, q0, dq0, tau0, noise, quantum, substeps):
    c = controller
    h_all = jnp.diff(t, append=t[-1] + (t[-1] - t[-2] if t.shape[0] > 1 else dt))
    e_prev0 = qr[0] - q0 + dq0 * dt  # consistent with a constant initial velocity

    def step(carry, inp):
        q, v, e_prev, tau_prev = carry
        qr_k, h, w_k = inp
        qm = quantise_rounding(q + w_k, quantum)
        e = qr_k - qm
        tau_c = jnp.clip(c.kp * e + c.kd * (e - e_prev) / dt, -c.tau_max, c.tau_max)
        tau = tau_prev if c.delay else tau_c
        a = acceleration(v, tau - plant.gravity(q), plant.ZZ2, plant.friction)
        hs = h / substeps

        def sub(_, x):
            u = tau - plant.gravity(x[0] + 0.5 * hs * x[1])  # gravity at the mid-step prediction
            return stick_slip_step(x[0], x[1], u, plant.ZZ2, plant.friction, hs)

        qn, vn = sub(0, (q, v)) if substeps == 1 else jax.lax.fori_loop(0, substeps, sub, (q, v))
        return (qn, vn, e, tau_c), (q, v, a, qm, tau)

    carry0 = (q0, dq0, e_prev0, tau0)
    _, (q, dq, ddq, qm, tau) = jax.lax.scan(step, carry0, (qr, h_all, noise))
    return TX40Simulation(t=t, q=q, dq=dq, ddq=ddq, q_meas=qm, tau=tau)


@x64
def simulate_tx40_link2(
    qr,
    *,
    plant: TX40Link2 | None = None,
    controller: PDController | None = None,
    dt=2e-4,
    t=None,
    q0=None,
    dq0=0.0,
    tau0=0.0,
    measurement_noise=None,
    quantum=None,
    substeps: int = 4,
) -> TX40Simulation:
    r"""Simulate TX40 link 2 under PD control (default 5 kHz, `dt = 2e-4` s).

    **Arguments:** `qr` reference joint position (rad) `(N,)`; `plant`
    (`TX40Link2`, default Table 4 reference values); `controller`
    (`PDController`); `dt` controller period (s); `t` optional strictly
    increasing sample times; `q0` (default `qr[0]`), `dq0` initial state;
    `tau0` torque applied on the first interval when `delay = 1` (N m);
    `measurement_noise` `(N,)` added to the position the controller reads;
    `quantum` encoder step (rad; `None` or 0: none); `substeps` plant sub-steps per sample.

    **Returns:** a `TX40Simulation`. Differentiable w.r.t. plant and
    controller parameters; `vmap`-able.

    Model: the plant $ZZ_2 \ddot q + \tau_{grav}(q) + f(\dot q) = \tau$ (`TX40Link2`) under
    the PD law $\tau(k) = clip(k_p e(k) + k_d (e(k) - e(k-1)) / \Delta t, \pm \tau_{max})$,
    $e = q_r - q_{meas}$, applied `delay` samples later with a zero-order hold.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import TX40Link2, quintic_reference, simulate_tx40_link2
        >>> t = np.arange(2500) * 2e-4  # 0.5 s at 5 kHz
        >>> ref = quintic_reference(t, knot_times=[0.0, 0.3], knot_positions=[0.0, 0.5])  # rad
        >>> sim = simulate_tx40_link2(ref.q)
        >>> bool(np.max(np.abs(sim.q - ref.q)) < 0.01)  # rad
        True
        >>> tau = TX40Link2().inverse_dynamics(sim.q, sim.dq, sim.ddq)  # eq. (20), N m
        >>> bool(np.allclose(tau[1:], sim.tau[1:]))
        True
    """
    plant = TX40Link2() if plant is None else plant
    controller = PDController() if controller is None else controller
    if not isinstance(plant, TX40Link2):
        raise ValueError(f"`plant` must be a TX40Link2; got {type(plant).__name__}")
    if not isinstance(controller, PDController):
        raise ValueError(f"`controller` must be a PDController; got {type(controller).__name__}")
    if not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"`substeps` must be a positive int; got {substeps!r}")
    qr = sampled_signal("qr", qr)
    n = qr.shape[0]
    t, dt, cons = time_grid("qr", n, t, dt)
    noise = (
        jnp.zeros(n) if measurement_noise is None else sampled_signal("measurement_noise", measurement_noise, n, "qr")
    )
    q0 = qr[0] if q0 is None else jnp.asarray(q0, dtype=jnp.float64)
    dq0 = jnp.asarray(dq0, dtype=jnp.float64)
    tau0 = jnp.asarray(tau0, dtype=jnp.float64)
    quantum = jnp.asarray(0.0 if quantum is None else quantum, dtype=jnp.float64)
    cons = (
        cons
        + plant.constraints()
        + controller.constraints()
        + [
            ("qr", qr, FINITE_ARRAY),
            ("measurement_noise", noise, FINITE_ARRAY),
            ("q0", q0, FINITE),
            ("dq0", dq0, FINITE),
            ("tau0", tau0, FINITE),
            ("quantum", quantum, NONNEGATIVE),
        ]
    )
    qr = check_parameters(qr, cons)
    dt = jnp.asarray(dt, dtype=jnp.float64)
    return _simulate(qr, t, dt, to64(plant), to64(controller), q0, dq0, tau0, noise, quantum, substeps)
