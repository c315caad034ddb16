"""The built-in simulated TX40 "only link 2 moving" experiment (paper section 3.4.1), with known truth.

**Plant and control.** Link 2 obeys the paper's eq. (20) with the reference
values of its Table 4 (`TX40_LINK2_REFERENCE`: ZZ2 1.60 kg m^2, MX2 2.80 kg m,
MY2 0, Fv2 5.68 N m s/rad, Fc2 7.77 N m, offset 0), friction integrated exactly
through stick-slip, under the discrete PD joint controller of
`jaxsdp.plants.simulate_tx40_link2` (10 Hz critically damped, one-sample
delay) at 5 kHz for 9 s (45,000 samples, the length of the public TX40 logs).

**Excitation.** A chain of fifth-order polynomials (quintic Hermite moves,
`quintic_reference`) through via-points taken on a four-tone smooth path
(0.23-0.97 Hz), from rest to rest, about +-1 rad, up to 2.3 rad/s and
12 rad/s^2. Through via-points rather than rest-to-rest moves, the arm
stops only at the ends: stops are where the friction model (21) is wrong
(static friction).

**Measurement.** The motor encoder has 2^16 counts per revolution (the
joint angle is quantised to 2 pi / (2^16 * 32) = 3.0e-6 rad; the controller
reads the quantised angle). The logged torque is the torque acting on the
link plus white noise of `TORQUE_NOISE` = 5 N m standard deviation
(joint side; 0.16 N m motor side), which gives an IDIM-LS relative error of
about 5 %, as the paper's 5.8 %.

**Files.** The six joints are written in the real logs' layout
(`write_joint_logs`: motor-side angles and motor torques, header
`Joint_1..Joint_6`, TX40 gear ratios); the other joints are held still at
`HELD_POSITIONS` with constant holding torques plus the same noise. The
study then reads them back with `load_joint_logs`, the path of real logs.
"""

import pathlib
import tempfile
from typing import NamedTuple

import jax
import numpy as np

from .._runtime import x64
from ..plants._trajectories import quantise, quintic_reference, white_noise
from ..plants.robot._tx40_link2 import TX40_GEAR_RATIOS, TX40_LINK2_REFERENCE, simulate_tx40_link2
from ._joint_logs import JointLogs, load_joint_logs, write_joint_logs

TX40_BUILTIN_TRUTH = dict(TX40_LINK2_REFERENCE)
SAMPLES = 45_000
DT = 2e-4
COUNTS_PER_REV = 2**16
TORQUE_NOISE = 5.0  # N m, joint side, per 5 kHz sample
#: Joint angles (rad) and holding torques (N m) of the joints kept still.
HELD_POSITIONS = (0.0, None, 1.5708, 0.0, 0.0, 0.0)
HELD_TORQUES = (0.4, None, 12.0, -0.1, 0.8, 0.1)
# The smooth path whose states at the via-points define the excitation.
_TONES_HZ = (0.23, 0.41, 0.67, 0.97)
_AMPLITUDES = (0.55, 0.35, 0.2, 0.1)  # rad
_PHASES = (0.3, 1.9, 4.0, 2.6)
_VIA_STEP = 0.3  # s between via-points
_START, _END = 0.1, 8.85  # s: rest before and after the moves


class TX40Builtin(NamedTuple):
    """The built-in TX40 experiment: `logs` (`JointLogs` read back from the files,
    all six joints, joint side), `truth` (link 2's true parameters, the paper's
    Table 4 reference values), `description` (dict: plant, excitation,
    measurement, seed), `files` (the written positions and torques paths, or
    `None` when they were written to a temporary folder and removed)."""

    logs: JointLogs
    truth: dict
    description: dict
    files: tuple | None


def via_point_path(n: int, dt: float, *, tones, amplitudes, phases, start: float, end: float, step: float = 0.3):
    """Quintic moves through via-points every `step` s of q(t) = sum_i A_i sin(2 pi f_i t + phi_i), rest to rest.

    The via-points carry the path's position, velocity and acceleration; the
    first and last knots (at `start` and `end`, s) are at rest 0.1 rad before
    the first and after the last via-point (`quintic_reference`).
    Returns a `Trajectory` on `n` samples of `dt` s.
    """
    f = 2 * np.pi * np.asarray(tones, dtype=float)
    A, ph = np.asarray(amplitudes, dtype=float), np.asarray(phases, dtype=float)
    kt = np.arange(start + 0.3, end - 0.3 + 1e-9, step)
    arg = f * kt[:, None] + ph
    q = (A * np.sin(arg)).sum(1)
    dq = (A * f * np.cos(arg)).sum(1)
    ddq = -(A * f**2 * np.sin(arg)).sum(1)
    kt = np.r_[start, kt, end]
    q = np.r_[q[0] - 0.1 * np.sign(dq[0]), q, q[-1] + 0.1 * np.sign(dq[-1])]
    t = np.arange(n) * dt
    return quintic_reference(
        t, knot_times=kt, knot_positions=q, knot_velocities=np.r_[0.0, dq, 0.0], knot_accelerations=np.r_[0.0, ddq, 0.0]
    )


@x64
def tx40_builtin_reference(n: int = SAMPLES, dt: float = DT):
    r"""The excitation of link 2: quintic moves through via-points of a smooth four-tone path.

    Via-points every 0.3 s on $q(t) = \sum_i A_i \sin(2 \pi f_i t + \phi_i)$
    (f = 0.23, 0.41, 0.67, 0.97 Hz; A = 0.55, 0.35, 0.2, 0.1 rad) with its
    velocity and acceleration, joined by quintic Hermite polynomials
    (`jaxsdp.plants.quintic_reference`), from rest at 0.1 s to rest at
    8.85 s (0.1 rad before the first and after the last via-point).

    **Returns:** a `Trajectory` (rad, rad/s, rad/s^2) on `n` samples of `dt` s.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.data import tx40_builtin_reference
        >>> ref = tx40_builtin_reference()
        >>> ref.q.shape, round(float(np.max(np.abs(ref.dq))), 2)  # rad/s
        ((45000,), 2.26)
    """
    return via_point_path(n, dt, tones=_TONES_HZ, amplitudes=_AMPLITUDES, phases=_PHASES, start=_START, end=_END)


def written_logs(directory, q, tau, ratios, *, prefix: str) -> tuple[JointLogs, tuple | None]:
    """Write joint-side angles and torques (N, 6) as TX40 logs and read them back with the same loader.

    `positions.csv` and `torques.csv` (motor side, through `ratios`) go into
    `directory` (created if needed), or into a temporary folder named
    `prefix...` that is removed after reading. **Returns:** (`JointLogs`,
    the two paths, or None for the temporary folder).
    """

    def write_and_read(folder):
        folder = pathlib.Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        pos, trq = folder / "positions.csv", folder / "torques.csv"
        write_joint_logs(pos, trq, q, tau, ratios=ratios)
        return load_joint_logs(pos, trq, dt=DT, ratios=ratios), (pos, trq)

    if directory is None:
        with tempfile.TemporaryDirectory(prefix=prefix) as tmp:
            logs, _ = write_and_read(tmp)
        return logs, None
    return write_and_read(directory)


@x64
def tx40_builtin_data(directory=None, *, seed: int = 0, torque_noise: float = TORQUE_NOISE) -> TX40Builtin:
    r"""Simulate the "only link 2 moving" experiment and write it as real TX40 joint logs.

    Link 2: $ZZ_2 \ddot q - g MX_2 \cos q + g MY_2 \sin q + F_{v2} \dot q + F_{c2} sign(\dot q) + offset_2 = \tau$
    (eq. 20, Table 4 reference values, exact stick-slip), PD control at 5 kHz
    along `tx40_builtin_reference()`, motor encoder of $2^{16}$ counts/rev,
    logged torque = tau + N(0, `torque_noise`^2) (N m, joint side). Written
    with `write_joint_logs` as `positions.csv` and `torques.csv` (motor side,
    header `Joint_1..Joint_6`, TX40 gear ratios) and read back with
    `load_joint_logs`; the other five joints are held still at fixed angles
    with constant holding torques plus the same noise.

    **Arguments:** `directory`: where to write the two files (created if
    needed; default: a temporary folder, removed after reading); `seed`: the
    torque-noise seed; `torque_noise` (N m, >= 0).

    **Returns:** a `TX40Builtin` (`logs`, `truth`, `description`, `files`).

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> logs, truth, description, files = tx40_builtin_data()
        >>> logs.q.shape, logs.dt, truth["ZZ2"]  # samples x joints, s, kg m^2
        ((45000, 6), 0.0002, 1.6)
    """
    if not (np.isfinite(torque_noise) and torque_noise >= 0):
        raise ValueError(f"`torque_noise` must be a finite value >= 0 (N m); got {torque_noise!r}")
    ratios = TX40_GEAR_RATIOS
    quantum = 2 * np.pi / (COUNTS_PER_REV * abs(ratios[1]))
    ref = tx40_builtin_reference()
    sim = simulate_tx40_link2(ref.q, dt=DT, quantum=quantum)
    keys = jax.random.split(jax.random.key(seed), 6)
    q = np.empty((SAMPLES, 6))
    tau = np.empty((SAMPLES, 6))
    for j in range(6):
        noise = np.asarray(white_noise(keys[j], SAMPLES, sigma=torque_noise))
        if j == 1:
            q[:, j] = np.asarray(sim.q_meas)
            tau[:, j] = np.asarray(sim.tau) + noise
        else:
            q[:, j] = np.asarray(
                quantise(np.full(SAMPLES, HELD_POSITIONS[j]), 2 * np.pi / (COUNTS_PER_REV * abs(ratios[j])))
            )
            tau[:, j] = HELD_TORQUES[j] + noise
    description = {
        "plant": "TX40 link 2, eq. (20) with the paper's Table 4 reference values, exact stick-slip friction; "
        "PD joint control (10 Hz, one-sample delay) at 5 kHz",
        "excitation": "quintic moves through via-points of a four-tone path (0.23-0.97 Hz), "
        f"{SAMPLES * DT:.0f} s, up to {float(np.max(np.abs(ref.dq))):.2f} rad/s",
        "measurement": f"motor encoder {COUNTS_PER_REV} counts/rev (joint quantum {quantum:.2g} rad); logged torque "
        f"+ white noise of {torque_noise:g} N m (joint side)",
        "other joints": "held still at fixed angles, constant holding torques + the same noise",
        "seed": int(seed),
    }

    logs, files = written_logs(directory, q, tau, ratios, prefix="jaxsdp-tx40-")
    return TX40Builtin(logs=logs, truth=dict(TX40_BUILTIN_TRUTH), description=description, files=files)
