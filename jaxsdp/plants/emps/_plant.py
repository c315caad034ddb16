"""Closed-loop simulation of the EMPS benchmark (plant + its digital controller).

Plant (continuous time, SI units):

    M * ddq = gtau * vir_applied - f(dq),     f from `jaxsdp.plants._friction`

with `f(dq) = Fv dq + Fc sign(dq) + offset` for the benchmark's linear model.

Controller (discrete, period `dt`, the benchmark's `Simulink_EMPS_Rigide`):

    qf(k)  = b0 * qm(k) + b1 * qm(k-1)                     FIR position filter
    dqf(k) = (qf(k) - qf(k-1)) / dt                        backward difference
    vir(k) = sat_[-vmax, vmax]( kv * (kp * (qg(k) - qm(k)) - dqf(k)) )
    vir_applied(t) = vir(k-1)   for t in [t_k, t_{k+1})    one-sample delay, ZOH
    force(t_k) = gtau * vir_applied(t_k)                     drive force on the plant

The proportional term uses the unfiltered position `qm(k)`: with the measured
`qm` of `DATA_EMPS.mat`, this reproduces the recorded `vir` to 0.24 %
(relative 2-norm), whereas `kp * (qg - qf)` gives 112 %.

Validation on `DATA_EMPS.mat` (IDIM-LS parameters, driven by the measured
`qg`, `q0 = qm[0]`; measured signals through the standard 100 Hz Butterworth
+ central differences, simulated states used directly, first 49 samples
dropped): relative errors position 0.0016 %, velocity 0.230 %, acceleration
8.2 %, force 5.85 % (the published Simulink figures are 0.0138 / 0.229 / 8.60
/ 5.85 %). With `EMPSController(delay=0)` they fall to 0.0011 / 0.126 / 5.7 /
4.6 %, which suggests the real computation delay is shorter than one sample;
`delay=1` is the default because it is the benchmark's description.

Between samples the drive force is constant, so the plant is integrated with
the exact stick-slip flow of `jaxsdp.plants._stick_slip.stick_slip_step` (closed-form
exponential solution, closed-form velocity zero crossing, exact sticking while
`f(0-) <= u <= f(0+)`); no smoothing of `sign`. The whole simulation is one
`lax.scan` over controller samples (`closed_loop_scan`, shared with the
control layer's controllers).
"""

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

# The benchmark controller's gains (DATA_EMPS.mat): kp 1/s, kv V/(m/s), drive gain gtau N/V.
BENCHMARK_GAINS = dict(kp=160.18, kv=243.45, gtau=35.15065188)
# IDIM-LS estimates published with the benchmark data.
EMPS_IDIM_LS = dict(M=95.1089, Fv=203.5034, Fc=20.3935, offset=-3.1648)


class EMPSPlant(eqx.Module):
    r"""Rigid EMPS axis: mass `M` (kg) and a friction law (N).

    Model: $M \ddot q = force - f(\dot q)$, position in m, force in N, `friction` an
    `AbstractFriction` $f$ (default `LinearFriction(Fv, Fc, offset)`).
    Defaults are the benchmark's IDIM-LS estimates `EMPS_IDIM_LS`
    (M 95.1089 kg, Fv 203.5034 N/(m/s), Fc 20.3935 N, offset -3.1648 N).
    """

    M: jax.Array
    friction: AbstractFriction

    @x64
    def __init__(self, M=EMPS_IDIM_LS["M"], friction: AbstractFriction | None = None):
        self.M = parameter("M", M, POSITIVE)
        if friction is None:
            friction = LinearFriction(EMPS_IDIM_LS["Fv"], EMPS_IDIM_LS["Fc"], EMPS_IDIM_LS["offset"])
        if not isinstance(friction, AbstractFriction):
            raise ValueError(f"`friction` must be a friction model; got {type(friction).__name__}")
        self.friction = friction

    @x64
    def constraints(self):
        return [("M", self.M, POSITIVE)] + self.friction.constraints("friction")


class EMPSController(eqx.Module):
    r"""The benchmark's cascade P/velocity controller (defaults from DATA_EMPS.mat).

    `kp` (1/s) outer position gain, `kv` (V/(m/s)) velocity gain, `gtau` (N/V)
    drive gain, `vmax` (V) saturation, `(b0, b1)` FIR position filter,
    `delay` (static, 0 or 1) samples between computing `vir(k)` and applying it.
    Control law at sample $k$ (period `dt` $= \Delta t$):

    $$ q_f(k) = b_0 q_m(k) + b_1 q_m(k-1), \quad \dot q_f(k) = (q_f(k) - q_f(k-1)) / \Delta t, $$

    $$ vir(k) = clip(k_v (k_p (q_g(k) - q_m(k)) - \dot q_f(k)), -v_{max}, v_{max}), $$

    $$ force = g_\tau vir(k - delay), $$

    held over the sample (zero-order hold).
    """

    kp: jax.Array
    kv: jax.Array
    gtau: jax.Array
    vmax: jax.Array
    b0: jax.Array
    b1: jax.Array
    delay: int = eqx.field(static=True)

    @x64
    def __init__(
        self,
        kp=BENCHMARK_GAINS["kp"],
        kv=BENCHMARK_GAINS["kv"],
        gtau=BENCHMARK_GAINS["gtau"],
        vmax=10.0,
        b0=0.5,
        b1=0.5,
        delay=1,
    ):
        self.kp = parameter("kp", kp)
        self.kv = parameter("kv", kv)
        self.gtau = parameter("gtau", gtau, POSITIVE)
        self.vmax = parameter("vmax", vmax, POSITIVE)
        self.b0 = parameter("b0", b0)
        self.b1 = parameter("b1", b1)
        if delay not in (0, 1):
            raise ValueError(f"`delay` must be 0 or 1; got {delay!r}")
        self.delay = int(delay)

    @x64
    def constraints(self):
        rules = dict(kp=FINITE, kv=FINITE, gtau=POSITIVE, vmax=POSITIVE, b0=FINITE, b1=FINITE)
        return [(n, getattr(self, n), rule) for n, rule in rules.items()]


class EMPSInitial(eqx.Module):
    """The closed loop's state at the first sample: position `q` (m; None: the reference's first value), velocity
    `dq` (m/s; the controller's memory is set consistently with a constant `dq`), and the controller output `vir`
    (V) applied over the first interval. Leaves: the simulation is differentiable with respect to each."""

    q: float | jax.Array | None = None
    dq: float | jax.Array = 0.0
    vir: float | jax.Array = 0.0

    def _values(self, qg):
        """(q0, dq0, vir0) as float64 arrays, `q` None read from the reference `qg`."""
        q0 = qg[0] if self.q is None else jnp.asarray(self.q, dtype=jnp.float64)
        return q0, jnp.asarray(self.dq, dtype=jnp.float64), jnp.asarray(self.vir, dtype=jnp.float64)


def check_initial(initial) -> "EMPSInitial":
    """`initial` (None: `EMPSInitial()`), checked to be an `EMPSInitial`."""
    initial = EMPSInitial() if initial is None else initial
    if not isinstance(initial, EMPSInitial):
        raise ValueError(f"`initial` must be a jaxsdp.plants.EMPSInitial; got {type(initial).__name__}")
    return initial


class EMPSSimulation(NamedTuple):
    """Sampled closed-loop trajectories, all of shape `(N,)`, at `t_k`.

    - `t` (s); `q` (m), `dq` (m/s): plant state at `t_k`;
    - `ddq` (m/s^2): acceleration just after `t_k` (right limit), so that
      `M * ddq = force - f(dq)` holds sample by sample (zero while stuck);
    - `q_meas` (m): the position the controller read (with noise/quantisation);
    - `vir` (V): controller output computed at `t_k` from `q_meas[k]`;
    - `force` (N): drive force acting on the plant on `[t_k, t_{k+1})`,
      `gtau * vir[k - delay]` (`vir0` before the first sample). This is what the
      benchmark's Simulink model logs as `gtau * vir_s`.
    """

    t: jax.Array
    q: jax.Array
    dq: jax.Array
    ddq: jax.Array
    q_meas: jax.Array
    vir: jax.Array
    force: jax.Array


def fir_velocity(qm, qm_prev, qf_prev, dt, b0=0.5, b1=0.5):
    """The benchmark's velocity estimate: FIR position filter qf(k) = b0 qm(k) + b1 qm(k-1), then the
    backward difference dqf(k) = (qf(k) - qf(k-1)) / dt (m/s). Returns `(dqf, qf)`.

    With b0 = b1 = 1/2 (the benchmark's) it lags the position by one sample on average; used by
    `EMPSController` and by the control layer's controllers (`jaxsdp.control.LinearPD`, `SDPPD`).

    Example:
        >>> dqf, qf = fir_velocity(2e-3, 1e-3, 0.0, 1e-3)  # m, m, m, s
        >>> round(float(qf), 6), round(float(dqf), 3)  # m, m/s
        (0.0015, 1.5)
    """
    qf = b0 * qm + b1 * qm_prev
    return (qf - qf_prev) / dt, qf


def closed_loop_scan(controller_step, state0, r, h, plant, *, apply, delay, q0, dq0, u0, noise, quantum, substeps):
    """The one closed-loop simulator of the EMPS axis: a digital controller on the continuous plant.

    At each sample k, one `lax.scan` step: the controller reads
    qm(k) = quantise(q(t_k) + w(k)) and returns `(command, state, aux) =
    controller_step(state, r(k), qm(k), v(t_k))`; the drive applies
    u = `apply(command(k - delay))` (delay 0 or 1; `u0` before the first
    sample), held over [t_k, t_k + h(k)); the plant M ddq = u - f(dq) is
    integrated exactly (stick-slip flow) in `substeps` equal sub-steps.

    Serves the benchmark controller (`simulate_emps`: command = vir in V,
    `apply` = gtau vir) and every controller of the control layer
    (`jaxsdp.control.simulate_control`: command in N, `apply` the `Drive`'s
    saturation). Returns `(q, dq, ddq, qm, command, u, aux)`, each stacked
    over the samples (`aux` as the controller returns it, None for none).
    """
    M, fr = plant.M, plant.friction

    def step(carry, inp):
        q, v, state, prev = carry
        r_k, h_k, w_k = inp
        qm = quantise_rounding(q + w_k, quantum)
        command, state, aux = controller_step(state, r_k, qm, v)
        u = apply(prev if delay else command)
        a = acceleration(v, u, M, fr)
        hs = h_k / substeps
        sub = lambda _, x: stick_slip_step(x[0], x[1], u, M, fr, hs)  # noqa: E731
        qn, vn = sub(0, (q, v)) if substeps == 1 else jax.lax.fori_loop(0, substeps, sub, (q, v))
        return (qn, vn, state, command), (q, v, a, qm, command, u, aux)

    _, out = jax.lax.scan(step, (q0, dq0, state0, u0), (r, h, noise))
    return out


@eqx.filter_jit
def simulate_closed_loop(qg, t, dt, plant, controller, q0, dq0, vir0, noise, quantum, substeps):
    c = controller
    h_all = jnp.diff(t, append=t[-1] + (t[-1] - t[-2] if t.shape[0] > 1 else dt))  # last interval repeated
    # Controller memory consistent with a constant initial velocity dq0.
    memory0 = (q0 - dq0 * dt, q0 - 1.5 * dq0 * dt)

    def benchmark_law(memory, qg_k, qm, v):
        dqf, qf = fir_velocity(qm, memory[0], memory[1], dt, c.b0, c.b1)
        vir = jnp.clip(c.kv * (c.kp * (qg_k - qm) - dqf), -c.vmax, c.vmax)
        return vir, (qm, qf), None

    q, dq, ddq, qm, vir, force, _ = closed_loop_scan(
        benchmark_law,
        memory0,
        qg,
        h_all,
        plant,
        apply=lambda vir: c.gtau * vir,
        delay=c.delay,
        q0=q0,
        dq0=dq0,
        u0=vir0,
        noise=noise,
        quantum=quantum,
        substeps=substeps,
    )
    return EMPSSimulation(t=t, q=q, dq=dq, ddq=ddq, q_meas=qm, vir=vir, force=force)


@x64
def simulate_emps(
    qg,
    *,
    plant: EMPSPlant | None = None,
    controller: EMPSController | None = None,
    dt=1e-3,
    t=None,
    initial: EMPSInitial | None = None,
    measurement_noise=None,
    quantum=None,
    substeps: int = 1,
) -> EMPSSimulation:
    r"""Simulate the EMPS in closed loop with its benchmark controller.

    **Arguments:**

    - `qg`: reference position (m), shape `(N,)`, one value per controller sample.
    - `plant`: `EMPSPlant` (default: IDIM-LS parameters, linear friction).
    - `controller`: `EMPSController` (default: the benchmark's gains).
    - `dt`: controller period (s), used for the backward difference and, if
      `t` is not given, for the sample times `t_k = k dt`.
    - `t`: optional strictly increasing sample times `(N,)`; the plant is then
      integrated over the actual intervals `t_{k+1} - t_k`.
    - `initial`: the state at the first sample (`EMPSInitial`: position, default
      `qg[0]`, velocity, default 0, the controller's memory consistent with a constant
      velocity, and the controller output applied on the first interval, V).
    - `measurement_noise`: optional `(N,)` additive position noise seen by the
      controller (m), e.g. from `jaxsdp.plants.white_noise`.
    - `quantum`: optional encoder quantisation step (m, `> 0`) applied to the
      position the controller reads (e.g. `encoder_quantum()`); `None` or 0:
      no quantisation.
    - `substeps`: plant sub-steps per sample. The linear and asymmetric
      friction laws are integrated exactly with 1; increase for
      `TabulatedFriction`.

    **Returns:** an `EMPSSimulation`.

    Model: the plant $M \ddot q = force - f(\dot q)$ (exact stick-slip integration
    between samples) under the `EMPSController` law with a zero-order hold.
    Differentiable w.r.t. all plant and controller parameters, `qg` and
    `initial`; runs under `jit` and `vmap` (vmap over plants/controllers whose
    leaves carry a batch axis).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import EMPSPlant, bang_bang_reference, simulate_emps
        >>> t = np.arange(1000) * 1e-3  # 1 s at 1 kHz
        >>> ref = bang_bang_reference(t, velocities=[0.1, 0.0], switch_times=[0.1, 0.5], accel=1.0)
        >>> sim = simulate_emps(ref.q)
        >>> round(float(sim.q[-1]), 4), bool(np.max(np.abs(sim.q - ref.q)) < 1e-3)  # m
        (0.04, True)
        >>> p, moving = EMPSPlant(), np.asarray(sim.dq) != 0
        >>> bool(np.allclose((p.M * sim.ddq + p.friction(sim.dq))[moving], sim.force[moving]))
        True
    """
    plant = EMPSPlant() if plant is None else plant
    controller = EMPSController() if controller is None else controller
    if not isinstance(plant, EMPSPlant):
        raise ValueError(f"`plant` must be an EMPSPlant; got {type(plant).__name__}")
    if not isinstance(controller, EMPSController):
        raise ValueError(f"`controller` must be an EMPSController; got {type(controller).__name__}")
    if not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"`substeps` must be a positive int; got {substeps!r}")
    qg = sampled_signal("qg", qg)
    n = qg.shape[0]
    t, dt, cons = time_grid("qg", n, t, dt)
    noise = jnp.zeros(n) if measurement_noise is None else sampled_signal("measurement_noise", measurement_noise, n)
    q0, dq0, vir0 = check_initial(initial)._values(qg)
    quantum = jnp.asarray(0.0 if quantum is None else quantum, dtype=jnp.float64)
    cons = (
        cons
        + plant.constraints()
        + controller.constraints()
        + [
            ("qg", qg, FINITE_ARRAY),
            ("measurement_noise", noise, FINITE_ARRAY),
            ("initial.q", q0, FINITE),
            ("initial.dq", dq0, FINITE),
            ("initial.vir", vir0, FINITE),
            ("quantum", quantum, NONNEGATIVE),
        ]
    )
    qg = check_parameters(qg, cons)
    dt = jnp.asarray(dt, dtype=jnp.float64)
    return simulate_closed_loop(qg, t, dt, to64(plant), to64(controller), q0, dq0, vir0, noise, quantum, substeps)
