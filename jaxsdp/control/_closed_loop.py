"""Digital control of the continuous EMPS plant: drive, velocity estimate, one simulator for every controller.

The plant is the continuous `jaxsdp.plants.EMPSPlant`, M ddq = F - f(dq),
integrated exactly between samples (`jaxsdp.plants` stick-slip flow). At
each sample t_k = k dt the controller reads the measured position qm(k)
(optionally with noise and encoder quantisation) and the reference r(k),
and computes a force command c(k) (N). The **drive** turns commands into the
force on the plant, held over the sample (zero-order hold):

    F(t) = sat(c(k - delay)),   t in [t_k, t_k+1),   sat = clip to +-force_limit.

`Drive()` is the paper's setting for SDP control (no delay, no saturation);
`REAL_DRIVE` is the EMPS's drive: one sample of delay and +-10 V * gtau
= +-351.5 N (`../shared/data/emps/README.md`).

The plant step and the benchmark's FIR velocity estimate are the plant
family's (`jaxsdp.plants.emps._plant.closed_loop_scan`, `fir_velocity`), the
ones `simulate_emps` runs with the benchmark controller. A controller is an
`eqx.Module` subclassing `AbstractController` with
`init(q0)` (its memory at rest at q0) and
`step(state, r, qm, v, dt) -> (command, state)`; `v` is the plant's true
velocity, which only the `velocity="state"` option of a controller reads
(an idealised sensor for checks against analytic responses). The
simulation is one `lax.scan` over samples; jit, vmap (over controllers,
plants, references) and grad all work.
"""

import abc
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import FINITE, FINITE_ARRAY, NONNEGATIVE, POSITIVE, as_float_array, is_concrete
from .._runtime import x64
from ..plants._friction import AsymmetricFriction
from ..plants._parameters import check_parameters, to64
from ..plants.emps._plant import BENCHMARK_GAINS, EMPSPlant, closed_loop_scan, fir_velocity

GTAU = BENCHMARK_GAINS["gtau"]  # N/V, the EMPS drive gain
VELOCITY_MODES = ("fir", "difference", "state")


class Drive(eqx.Module):
    """Power drive between controller and plant: `delay` samples (static, 0 or 1) and a force limit (N).

    $F(t) = clip(c(k - delay), -F_{lim}, F_{lim})$ on $[t_k, t_{k+1})$ ($F_{lim}$ = `force_limit`).
    Default: no delay, no limit (the paper's simulations). `REAL_DRIVE`
    is the EMPS's: delay 1, limit 10 V * 35.15 N/V = 351.5 N.

    Example:
        >>> from jaxsdp.control import Drive
        >>> d = Drive(delay=1, force_limit=351.5)
        >>> d.delay, float(d.force_limit)
        (1, 351.5)
    """

    force_limit: jax.Array
    delay: int = eqx.field(static=True, default=0)

    @x64
    def __init__(self, *, delay: int = 0, force_limit=np.inf):
        if delay not in (0, 1):
            raise ValueError(f"`delay` must be 0 or 1 (samples); got {delay!r}")
        self.delay = int(delay)
        if is_concrete(force_limit):
            fl = np.asarray(force_limit, dtype=np.float64)
            if fl.ndim != 0 or not fl > 0:
                raise ValueError(f"`force_limit` must be a positive scalar (N; inf: no limit); got {force_limit!r}")
            force_limit = fl
        self.force_limit = force_limit

    @x64
    def apply(self, command):
        return jnp.clip(command, -self.force_limit, self.force_limit)


REAL_DRIVE = Drive(delay=1, force_limit=10.0 * GTAU)


class VelocityState(NamedTuple):
    qm_prev: jax.Array
    qf_prev: jax.Array


def velocity_init(q0) -> VelocityState:
    q0 = jnp.asarray(q0, dtype=jnp.float64)
    return VelocityState(q0, q0)


def velocity_estimate(mode: str, state: VelocityState, qm, v, dt):
    """Velocity the controller uses (m/s) and the new memory.

    - "fir": the benchmark's, qf(k) = (qm(k) + qm(k-1)) / 2, dqf = (qf(k) - qf(k-1)) / dt
      (a 1-sample lag on average);
    - "difference": (qm(k) - qm(k-1)) / dt (half a sample lag);
    - "state": the plant's true velocity (an ideal sensor, for checks).
    """
    dqf, qf = fir_velocity(qm, state.qm_prev, state.qf_prev, dt)
    if mode == "fir":
        dq = dqf
    elif mode == "difference":
        dq = (qm - state.qm_prev) / dt
    else:
        dq = v
    return dq, VelocityState(qm, qf)


class AbstractController(eqx.Module):
    """A digital controller of the EMPS: force command (N) from reference and measured position.

    Subclasses implement `init(q0)` and `step(state, r, qm, v, dt) -> (command, state)`;
    `aux(state)` (optional) exposes an internal signal (e.g. the inner
    reference of a cascade) recorded by `simulate_control`.
    """

    @abc.abstractmethod
    def init(self, q0):
        """Controller memory at rest at position q0 (m)."""

    @abc.abstractmethod
    def step(self, state, r, qm, v, dt):
        """One sample: `(command N, new state)`."""

    @x64
    def aux(self, state):
        return jnp.zeros(())


class ControlSimulation(NamedTuple):
    """Closed-loop trajectories at the samples $t_k$, shape (N,) each.

    `t` (s), `r` reference (m), `q` (m) and `dq` (m/s) plant state at t_k,
    `ddq` (m/s^2) acceleration just after t_k, `q_meas` (m) the position the
    controller read, `command` (N) the controller's output $c(k)$, `force` (N)
    the drive force on $[t_k, t_{k+1})$ (delayed, saturated), `aux` the
    controller's internal signal (`AbstractController.aux`, e.g. a cascade's
    inner reference, m).
    """

    t: jax.Array
    r: jax.Array
    q: jax.Array
    dq: jax.Array
    ddq: jax.Array
    q_meas: jax.Array
    command: jax.Array
    force: jax.Array
    aux: jax.Array


@eqx.filter_jit
def _simulate(controller, r, plant, drive, dt, q0, dq0, noise, quantum, substeps):
    def law(state, r_k, qm, v):
        command, state = controller.step(state, r_k, qm, v, dt)
        return command, state, controller.aux(state)

    q, dq, ddq, qm, cmd, force, aux = closed_loop_scan(
        law,
        controller.init(q0),
        r,
        jnp.full(r.shape, dt),
        plant,
        apply=drive.apply,
        delay=drive.delay,
        q0=q0,
        dq0=dq0,
        u0=jnp.zeros_like(q0),
        noise=noise,
        quantum=quantum,
        substeps=substeps,
    )
    t = jnp.arange(r.shape[0]) * dt
    return ControlSimulation(t=t, r=r, q=q, dq=dq, ddq=ddq, q_meas=qm, command=cmd, force=force, aux=aux)


@x64
def simulate_control(
    controller: AbstractController,
    reference,
    *,
    plant: EMPSPlant | None = None,
    drive: Drive | None = None,
    dt=1e-3,
    q0=None,
    dq0=0.0,
    measurement_noise=None,
    quantum=None,
    substeps: int = 1,
) -> ControlSimulation:
    r"""Simulate a digital controller on the continuous EMPS plant.

    **Arguments:**

    - `controller`: an `AbstractController` (`SDPPD`, `LinearPD`, `PIPSDP`, ...).
    - `reference`: (N,) reference position r(k) (m), one value per sample.
    - `plant`: the true plant, an `EMPSPlant` (default: `true_plant()`, the
      asymmetric IDIM-LS model of the real EMPS).
    - `drive`: `Drive` (default `Drive()`: no delay, no saturation;
      `REAL_DRIVE` for the EMPS's).
    - `dt`: sample period (s); `q0` (default r(0)), `dq0`: initial state.
    - `measurement_noise`: optional (N,) additive position noise (m);
      `quantum`: optional encoder step (m).
    - `substeps`: plant sub-steps per sample (exact with 1 for linear and
      asymmetric friction; use more for a `TabulatedFriction` plant).

    **Returns:** a `ControlSimulation`.

    Model: $M \ddot q = F(t) - f(\dot q)$ with $F$ from the drive (zero-order hold),
    integrated exactly between samples (stick-slip flow).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.control import LinearPD, simulate_control
        >>> sim = simulate_control(LinearPD(), np.full(300, 0.05), q0=0.0)
        >>> round(float(sim.q[-1]), 3)  # m, after 0.3 s
        0.05
    """
    plant = true_plant() if plant is None else plant
    drive = Drive() if drive is None else drive
    if not isinstance(controller, AbstractController):
        raise ValueError(f"`controller` must be an AbstractController; got {type(controller).__name__}")
    if not isinstance(plant, EMPSPlant):
        raise ValueError(f"`plant` must be an EMPSPlant; got {type(plant).__name__}")
    if not isinstance(drive, Drive):
        raise ValueError(f"`drive` must be a Drive; got {type(drive).__name__}")
    if not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"`substeps` must be a positive int; got {substeps!r}")
    r = as_float_array("reference", reference, ndim=1)
    n = r.shape[0]
    if n < 2:
        raise ValueError("`reference` needs at least 2 samples")
    noise = jnp.zeros(n) if measurement_noise is None else as_float_array("measurement_noise", measurement_noise, 1)
    if noise.shape != (n,):
        raise ValueError(f"`measurement_noise` has shape {tuple(noise.shape)}; expected ({n},)")
    q0 = r[0] if q0 is None else jnp.asarray(q0, dtype=jnp.float64)
    dq0 = jnp.asarray(dq0, dtype=jnp.float64)
    quantum = jnp.asarray(0.0 if quantum is None else quantum, dtype=jnp.float64)
    cons = plant.constraints() + [
        ("dt", dt, POSITIVE),
        ("reference", r, FINITE_ARRAY),
        ("measurement_noise", noise, FINITE_ARRAY),
        ("q0", q0, FINITE),
        ("dq0", dq0, FINITE),
        ("quantum", quantum, NONNEGATIVE),
    ]
    r = check_parameters(r, cons)
    dt = jnp.asarray(dt, dtype=jnp.float64)
    return _simulate(to64(controller), r, to64(plant), to64(drive), dt, q0, dq0, noise, quantum, substeps)


@x64
def true_plant() -> EMPSPlant:
    """The asymmetric IDIM-LS model of the real EMPS (README of the data): the true plant of the control study.

    M = 95.1540 kg, Fv+ 166.7061, Fv- 240.4236 N/(m/s), Fc+ 20.1440, Fc- 20.6277 N, no offset.

    Example:
        >>> from jaxsdp.control import true_plant
        >>> round(float(true_plant().M), 3)
        95.154
    """
    return EMPSPlant(95.1540, AsymmetricFriction(166.7061, 20.1440, 240.4236, 20.6277))
