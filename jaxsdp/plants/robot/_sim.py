"""Closed-loop simulation of a serial robot (`SerialRobot`): joint PD control with gravity feed-forward.

Controller (discrete, period dt, one-sample delay by default), per joint j:

    tau_k = clip(kp_j e_k + kd_j (e_k - e_{k-1}) / dt + g_hat_j(q_meas), +-tau_max_j),   e = q_ref - q_meas,

g_hat the model's gravity torques at the measured angles (the feed-forward
of an industrial controller). Plant, between samples (`substeps` steps of h):

    (M(q) + diag(Ia)) ddq = tau - c(q, dq) - g(q) - Fv dq - Fc tanh(dq / eps) - offset,

integrated semi-implicitly: the velocity update solves
(M + diag(Ia) + h D) dv = h rhs with D = diag(Fv + Fc sech^2(dq / eps) / eps)
the friction's slope (stable for the steep Coulomb law), then q += h dq; the
mass matrix is evaluated once per sample (it changes by about dq dt over an
interval), the bias and friction torques at every step. The recorded ddq
uses the exact M at t_k, so tau = drive_torques(q, dq, ddq) at the samples.
`eps` (rad/s) regularises the Coulomb step: with eps = 1e-3 rad/s the law is
Fc sign(dq) to 1e-8 above 0.01 rad/s, the speed below which the TX40 study
leaves samples out.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._linalg import spd_solve
from ..._runtime import x64
from ._serial import SerialRobot

#: Armature given to joints without one, relative to the largest diagonal entry of the mass matrix at the start.
ARMATURE_FRACTION = 0.02


def with_armature(robot: SerialRobot, q0) -> SerialRobot:
    """The robot with armature `ARMATURE_FRACTION * max diag M(q0)` on the joints that have none (a URDF holds
    none; the simulated mass matrix must stay invertible)."""
    m = float(np.max(np.diag(np.asarray(robot.mass_matrix(jnp.asarray(q0))))))
    Ia = np.asarray(robot.Ia, dtype=float)
    return eqx.tree_at(lambda r: r.Ia, robot, jnp.asarray(np.where(Ia > 0, Ia, ARMATURE_FRACTION * m)))


class RobotSimulation(NamedTuple):
    """Sampled trajectories of `simulate_robot`, each (N, n) at t_k: `q` (rad), `dq` (rad/s), `ddq`
    (rad/s^2, just after t_k), `q_meas` (rad, what the controller read), `tau` (N m, the drive torques
    acting on [t_k, t_k+1)); `t` (N,) s."""

    t: jax.Array
    q: jax.Array
    dq: jax.Array
    ddq: jax.Array
    q_meas: jax.Array
    tau: jax.Array


def _rhs(robot, q, v, tau, eps):
    bias = robot.inverse_dynamics(q, v, jnp.zeros_like(q))
    fric = robot.Fv * v + robot.Fc * jnp.tanh(v / eps) + robot.offset
    x = jnp.exp(-2.0 * jnp.abs(v / eps))  # sech^2(v / eps) = 4 x / (1 + x)^2, finite with its derivatives
    slope = robot.Fv + robot.Fc / eps * 4.0 * x / (1.0 + x) ** 2
    return tau - bias - fric, slope


@eqx.filter_jit
def simulate_loop(robot, ctrl, qr, dt, kp, kd, tau_max, quantum, noise, eps, substeps, delay, disturbance=None):
    """The loop of `simulate_robot`; `disturbance` (N, n) N m (None: none) is added to the drive torque the plant
    receives over each sample interval and not to the `tau` returned (a torque the drive's current does not
    show: friction ripple, cogging, an unmodelled load)."""
    h = dt / substeps

    def quantise(x):
        return jnp.where(quantum > 0, jnp.round(x / jnp.where(quantum > 0, quantum, 1.0)) * quantum, x)

    def sub(_, state):
        q, v, tau, M = state
        rhs, slope = _rhs(robot, q, v, tau, eps)
        A = M + h * jnp.diag(slope)
        dv = spd_solve(A, h * rhs)
        v = v + dv
        return q + h * v, v, tau, M

    def step(carry, inp):
        q, v, e_prev, tau_prev = carry
        qr_k, w_k, d_k = inp
        qm = quantise(q + w_k)
        e = qr_k - qm
        ff = ctrl.gravity_torques(qm)
        tau_c = jnp.clip(kp * e + kd * (e - e_prev) / dt + ff, -tau_max, tau_max)
        tau = tau_prev if delay else tau_c
        M = robot.mass_matrix(q) + jnp.diag(robot.Ia)  # held over the sample interval (changes by ~dq dt)
        rhs, _ = _rhs(robot, q, v, tau + d_k, eps)
        a = spd_solve(M, rhs)
        qn, vn, _, _ = jax.lax.fori_loop(0, substeps, sub, (q, v, tau + d_k, M))
        return (qn, vn, e, tau_c), (q, v, a, qm, tau)

    q0 = qr[0]
    tau0 = ctrl.gravity_torques(q0)
    carry = (q0, jnp.zeros_like(q0), jnp.zeros_like(q0), tau0)
    d = jnp.zeros_like(qr) if disturbance is None else disturbance
    _, (q, v, a, qm, tau) = jax.lax.scan(step, carry, (qr, noise, d))
    t = jnp.arange(qr.shape[0]) * dt
    return RobotSimulation(t=t, q=q, dq=v, ddq=a, q_meas=qm, tau=tau)


#: The PD loop's default bandwidth (Hz), lowered for slow control rates (`loop_bandwidth`).
LOOP_BANDWIDTH_HZ = 10.0
#: Samples per period of the loop's bandwidth at least: a PD critically damped at w acting once per sample with
#: one sample of delay on a double integrator is stable for w dt < 0.32 (its poles' radius is least, 0.87, near
#: w dt = 0.22); 40 samples (w dt = 0.16) keeps twice that margin for a plant lighter than the controller's model.
LOOP_SAMPLES_PER_PERIOD = 40.0
#: w dt above which the delayed PD loop is unstable (refused).
_UNSTABLE_OMEGA_DT = 0.3


def loop_bandwidth(dt: float) -> float:
    """The PD loop's default bandwidth for a control period `dt` (s): 10 Hz, or 1 / (40 dt) if lower (Hz)."""
    return min(LOOP_BANDWIDTH_HZ, 1.0 / (dt * LOOP_SAMPLES_PER_PERIOD))


def check_loop(dt: float, bandwidth_hz: float, delay: int = 1) -> None:
    """Refuse a PD loop that its one sample of delay makes unstable (2 pi f dt above 0.3), naming the limit."""
    if delay and 2 * np.pi * bandwidth_hz * dt > _UNSTABLE_OMEGA_DT:
        top = _UNSTABLE_OMEGA_DT / (2 * np.pi * dt)
        raise ValueError(
            f"a PD critically damped at {bandwidth_hz:g} Hz acting once per {dt:g} s with one sample of delay is "
            f"unstable (2 pi f dt = {2 * np.pi * bandwidth_hz * dt:.2f} > {_UNSTABLE_OMEGA_DT}): take a bandwidth "
            f"of at most {top:.3g} Hz (the default, `bandwidth_hz=None`, takes {loop_bandwidth(dt):.3g} Hz)"
        )


@x64
def simulate_robot(
    robot: SerialRobot,
    qr,
    *,
    dt: float = 2e-4,
    bandwidth_hz: float | None = None,
    tau_max=None,
    quantum=None,
    measurement_noise=None,
    eps: float = 1e-3,
    substeps: int = 4,
    delay: int = 1,
    controller_model: SerialRobot | None = None,
) -> RobotSimulation:
    r"""Simulate a `SerialRobot` under joint PD control with gravity feed-forward at a fixed period.

    Controller, per joint: $\tau_k = clip(k_p e_k + k_d (e_k - e_{k-1}) / \Delta t + \hat g(q_{meas}), \pm \tau_{max})$,
    $e = q_{ref} - q_{meas}$, applied one sample later (`delay`). Plant:
    $(M(q) + diag(I_a)) \ddot q = \tau - c(q, \dot q) - g(q) - F_v \dot q - F_c \tanh(\dot q / \varepsilon) - offset$,
    `substeps` semi-implicit steps per sample (the friction's slope taken
    implicitly, so the steep Coulomb law stays stable).

    **Arguments:** `robot`; `qr` (N, n) joint references (rad), starting at
    rest; `dt` control period (s, default 2e-4: 5 kHz); `bandwidth_hz`: each
    joint's PD is critically damped at this frequency $\omega$ on its inertia
    $J_j = M_{jj}(q_{r,0}) + I_{a,j}$ ($k_p = J \omega^2$, $k_d = 2 J \omega$; default `loop_bandwidth(dt)`:
    10 Hz, or $1 / (40 \Delta t)$ for slower control rates; a loop with $\omega \Delta t > 0.3$ and one sample of
    delay is unstable and refused); `tau_max` (n,) torque
    limits (N m, default none); `quantum` (n,) encoder steps (rad, joint
    side; default none); `measurement_noise` (N, n) added to the angles the
    controller reads; `eps` (rad/s) Coulomb regularisation; `substeps` plant
    steps per sample; `delay` 0 or 1 samples; `controller_model`: the
    robot model the controller uses for its gains and gravity feed-forward
    (default `robot` itself; fix it to simulate a candidate plant under the
    real, fixed controller, as identification through the simulator does).

    **Returns:** a `RobotSimulation` (`q`, `dq`, `ddq`, `q_meas`, `tau`, each (N, n)).
    The drive torque satisfies `tau = robot.drive_torques(q, dq, ddq)` up to
    the Coulomb regularisation.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import simulate_robot, tx40_robot
        >>> robot = tx40_robot()
        >>> t = np.arange(500) * 2e-4
        >>> qr = np.outer(1 - np.cos(2 * np.pi * t), np.full(6, 0.05))  # rad
        >>> sim = simulate_robot(robot, qr)
        >>> sim.q.shape, bool(np.max(np.abs(sim.q - qr)) < 0.01)
        ((500, 6), True)
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    ctrl = robot if controller_model is None else controller_model
    if not isinstance(ctrl, SerialRobot) or ctrl.n != robot.n:
        raise ValueError(f"`controller_model` must be a SerialRobot with {robot.n} joints")
    n = robot.n
    qr = jnp.asarray(qr, dtype=jnp.float64)
    if qr.ndim != 2 or qr.shape[1] != n or qr.shape[0] < 2:
        raise ValueError(f"`qr` must have shape (N, {n}) with N >= 2; got {tuple(qr.shape)}")
    if delay not in (0, 1) or not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"`delay` must be 0 or 1 and `substeps` a positive int; got {delay!r}, {substeps!r}")
    if bandwidth_hz is None and dt > 0:
        bandwidth_hz = loop_bandwidth(dt)
    if not (dt > 0 and bandwidth_hz > 0 and eps > 0):
        raise ValueError("`dt`, `bandwidth_hz` and `eps` must be positive")
    check_loop(dt, bandwidth_hz, delay)
    J = jnp.diag(ctrl.mass_matrix(qr[0])) + ctrl.Ia
    w = 2 * jnp.pi * bandwidth_hz
    kp, kd = J * w**2, 2 * J * w
    tau_max = jnp.full(n, jnp.inf) if tau_max is None else jnp.broadcast_to(jnp.asarray(tau_max, jnp.float64), (n,))
    quantum = jnp.zeros(n) if quantum is None else jnp.broadcast_to(jnp.asarray(quantum, jnp.float64), (n,))
    noise = jnp.zeros_like(qr) if measurement_noise is None else jnp.asarray(measurement_noise, jnp.float64)
    if noise.shape != qr.shape:
        raise ValueError(f"`measurement_noise` must have the shape of `qr` {tuple(qr.shape)}; got {noise.shape}")
    return simulate_loop(robot, ctrl, qr, float(dt), kp, kd, tau_max, quantum, noise, float(eps), substeps, delay)
