"""The built-in simulated TX40 "all joints moving" experiment (paper section 3.4.2), written as real TX40 logs.

**Plant and control.** The nominal six-joint TX40 (`jaxsdp.plants.tx40_robot`:
modified DH of Table 3, recursive Newton-Euler, actuator inertia, viscous and
Coulomb friction and offsets) under six joint PD controllers with gravity
feed-forward at 5 kHz (`simulate_robot`, 10 Hz bandwidth), 9 s (45,000
samples). Every joint follows quintic moves through via-points of its own
smooth four-tone path (`ALL_JOINTS_TONES`), so link 2 feels the inertial,
centrifugal, Coriolis and gravity coupling of the others: the torque the
one-joint model (20) leaves out.

**Measurement.** 2^16-count motor encoders on every joint, logged torques
plus white noise of 5 N m (joint side), as the built-in link-2 experiment.

**Log convention** (`tx40.md`): the files hold what a real TX40 logs, motor
angles pos = C q_log and motor torques v = D^-1 tau, where the log's joint
angles are the MDH angles plus `LOG_OFFSETS` (q2_log = q2 + pi/2,
q3_log = q3 - pi/2) and the wrist is coupled (motor 6 turns with joint 5:
C = diag(N) + N6 e6 e5^T, D = diag(N) + N6 e5 e6^T). Read with diagonal
ratios (`load_joint_logs(..., ratios=TX40_GEAR_RATIOS)`), joints 1-4 come out
exact (joint 2 in the paper's convention); joints 5-6 need the wrist
coupling undone.
"""

import jax
import numpy as np

from .._runtime import x64
from ..plants._trajectories import white_noise
from ..plants.robot._sim import simulate_robot
from ..plants.robot._tx40 import tx40_robot
from ..plants.robot._tx40_link2 import TX40_GEAR_RATIOS
from ._model_convention import TX40_JOINT_OFFSETS
from ._tx40_builtin import COUNTS_PER_REV, DT, SAMPLES, TORQUE_NOISE, TX40Builtin, via_point_path, written_logs

#: Joint angles in the logs minus the MDH angles of `tx40_robot` (rad).
LOG_OFFSETS = tuple(0.0 - v for v in TX40_JOINT_OFFSETS)
#: Per joint: tones (Hz), amplitudes (rad) and phases of its excitation path, in the log convention
#: (joint 2 about the upright arm, as the paper's link-2 experiments).
ALL_JOINTS_TONES = (
    ((0.19, 0.37, 0.71, 1.03), (0.45, 0.3, 0.15, 0.08), (0.7, 2.2, 4.4, 1.1)),
    ((0.23, 0.41, 0.67, 0.97), (0.55, 0.35, 0.2, 0.1), (0.3, 1.9, 4.0, 2.6)),
    ((0.29, 0.47, 0.61, 0.89), (0.5, 0.3, 0.2, 0.1), (1.4, 0.2, 3.1, 5.0)),
    ((0.17, 0.43, 0.79, 1.11), (0.6, 0.4, 0.2, 0.1), (2.9, 4.1, 0.5, 1.7)),
    ((0.21, 0.53, 0.73, 0.93), (0.5, 0.3, 0.2, 0.1), (5.2, 1.3, 2.7, 0.9)),
    ((0.27, 0.39, 0.83, 1.07), (0.7, 0.4, 0.2, 0.1), (3.6, 2.4, 1.0, 4.7)),
)


def wrist_matrices(ratios=TX40_GEAR_RATIOS) -> tuple[np.ndarray, np.ndarray]:
    """(C, D): motor angles = C q_log, joint torques = D v (motor torques v), with the TX40's wrist coupling.

    C = diag(N) + N6 e6 e5^T (motor 6 turns with joint 5); D = diag(N) + N6 e5 e6^T.

    Example:
        >>> from jaxsdp.data._tx40_all_joints import wrist_matrices
        >>> C, D = wrist_matrices()
        >>> float(C[5, 4]), float(D[4, 5])
        (32.0, 32.0)
    """
    N = np.asarray(ratios, dtype=float)
    C, D = np.diag(N), np.diag(N)
    C[5, 4] = N[5]
    D[4, 5] = N[5]
    return C, D


@x64
def tx40_all_joints_data(directory=None, *, seed: int = 0, torque_noise: float = TORQUE_NOISE) -> TX40Builtin:
    """Simulate the all-joints experiment on the nominal six-joint TX40 and write it as real TX40 logs.

    The robot (`tx40_robot`) under joint PD control with gravity feed-forward
    at 5 kHz follows via-point quintics on all six joints (9 s); 2^16-count
    motor encoders; logged torques + N(0, `torque_noise`^2) (N m, joint side).
    Written as `positions.csv` / `torques.csv` in the log convention
    (motor angles C q_log, motor torques D^-1 tau, q_log = q_MDH + offsets
    (0, pi/2, -pi/2, 0, 0, 0), wrist coupling of motor 6 with joint 5) and
    read back with `load_joint_logs` and the TX40 gear ratios (so joints 5
    and 6 come out still wrist-coupled).

    **Arguments:** `directory` (default: a temporary folder, removed after
    reading); `seed` of the torque noise; `torque_noise` (N m).

    **Returns:** a `TX40Builtin`: `truth` holds the robot's nominal parameters
    (`robot`: the `SerialRobot`, `log_offsets`), not link-2 values: the
    one-joint model does not hold here.

    Example:
        >>> from jaxsdp.data import tx40_all_joints_data
        >>> logs, truth, description, files = tx40_all_joints_data()
        >>> logs.q.shape, sorted(truth)
        ((45000, 6), ['log_offsets', 'robot'])
    """
    if not (np.isfinite(torque_noise) and torque_noise >= 0):
        raise ValueError(f"`torque_noise` must be a finite value >= 0 (N m); got {torque_noise!r}")
    robot = tx40_robot()
    N = np.asarray(TX40_GEAR_RATIOS)
    offsets = np.asarray(LOG_OFFSETS)
    qr_log = np.stack(
        [
            np.asarray(via_point_path(SAMPLES, DT, tones=f, amplitudes=a, phases=p, start=0.1, end=8.85).q)
            for f, a, p in ALL_JOINTS_TONES
        ],
        axis=1,
    )
    quantum = 2 * np.pi / (COUNTS_PER_REV * np.abs(N))
    sim = simulate_robot(robot, qr_log - offsets, dt=DT, quantum=quantum)
    keys = jax.random.split(jax.random.key(seed), 6)
    noise = np.stack([np.asarray(white_noise(k, SAMPLES, sigma=torque_noise)) for k in keys], axis=1)
    q_log = np.asarray(sim.q_meas) + offsets
    tau = np.asarray(sim.tau) + noise
    C, D = wrist_matrices()
    pos = q_log @ C.T  # motor angles
    value = np.linalg.solve(D, tau.T).T  # motor torques
    description = {
        "plant": "nominal six-joint TX40 (tx40_robot: MDH Table 3, Newton-Euler, Ia, Fv, Fc, offsets); joint PD "
        "with gravity feed-forward at 5 kHz (10 Hz), one-sample delay",
        "excitation": "quintic moves through via-points of a four-tone path on every joint, 9 s",
        "measurement": f"motor encoders {COUNTS_PER_REV} counts/rev; torque + white noise of {torque_noise:g} N m",
        "log convention": "q_log = q_MDH + (0, pi/2, -pi/2, 0, 0, 0); motor 6 coupled with joint 5",
        "seed": int(seed),
    }

    # joint-side values as the diagonal loader reads them back: still wrist-coupled
    logs, files = written_logs(directory, pos / N, value * N, N, prefix="jaxsdp-tx40-all-")
    truth = {"robot": robot, "log_offsets": tuple(float(v) for v in offsets)}
    return TX40Builtin(logs=logs, truth=truth, description=description, files=files)
