"""A gallery of robots for `jaxsdp robot` (issue 42, item 7): the arms of `example-robot-data` and one robot with a
prismatic joint, simulated as their logs would come from the robot.

`gallery_robot(name)`: the description file, the `SerialRobot` with its true drives (motor inertia Ia, viscous
Fv and Coulomb Fc friction, a torque offset, joint side) and the tip link that makes the arm a serial chain.

`write_gallery_logs(folder, robot, ...)`: an exciting motion (a sum of sines per joint, 0.1-1.5 Hz, within the
description's position and velocity limits), sampled at jittered stamps t_k = T0 + (k + U(-0.1, 0.1)) / rate
(T0 = 2 s; the motion evaluated at the true stamp), the drive torques `robot.drive_torques(q, dq, ddq)` with 1 %
white noise (of each channel's RMS), positions quantised (1e-5 rad, 1e-6 m), one dead torque channel (exact zeros
on 97 % of the samples, about 94 % once resampled onto a uniform grid: the drive reports nothing), written as
positions.csv and torques.csv headed `time,<URDF joint names>` in a shuffled order with one extra column
(`temperature`) to be ignored. Returns the paths and the truth: the base parameters of the live joints
(`robot_model(robot, joints=live)`) with their values.

Chosen descriptions (example-robot-data): UR5 `ur_description/urdf/ur5_robot.urdf` (6 joints, default tip
`wrist_3_link`); Panda `panda_description/urdf/panda.urdf`, tip `panda_link8` (the flange: the fingers are two
prismatic branches, held and merged); Z1 `z1_description/urdf/z1.urdf`, tip `link06` (the gripper's revolute joint
is held and merged); Kinova Jaco 2 `kinova_description/robots/kinova.urdf` (6 joints, default tip).
"""

import pathlib

import equinox as eqx
import numpy as np

from helpers import EXAMPLE_ROBOTS

#: name -> (description file under example-robot-data's robots folder, tip link or None, the dead joint)
ARMS = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", None, "wrist_1_joint"),
    "panda": ("panda_description/urdf/panda.urdf", "panda_link8", "panda_joint3"),
    "z1": ("z1_description/urdf/z1.urdf", "link06", "joint5"),
    "kinova": ("kinova_description/robots/kinova.urdf", None, "j2s6s200_joint_4"),
}
#: The robot the gallery writes itself: a vertical lift (prismatic along gravity), then three revolute joints.
PRISMATIC_DEAD = "wrist"
GALLERY = (*ARMS, "prismatic")

PRISMATIC_URDF = """<?xml version="1.0"?>
<robot name="lift_arm">
  <link name="base_link"/>
  <link name="carriage">
    <inertial><origin xyz="0 0 0.05"/><mass value="8.0"/>
      <inertia ixx="0.06" ixy="0" ixz="0" iyy="0.06" iyz="0" izz="0.08"/></inertial></link>
  <link name="upper_arm">
    <inertial><origin xyz="0.2 0.0 0.02"/><mass value="4.0"/>
      <inertia ixx="0.006" ixy="0" ixz="0" iyy="0.055" iyz="0" izz="0.055"/></inertial></link>
  <link name="forearm">
    <inertial><origin xyz="0.15 0.01 0.0"/><mass value="2.5"/>
      <inertia ixx="0.003" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
  <link name="hand">
    <inertial><origin xyz="0.04 0.02 0.03" rpy="0 0.3 0"/><mass value="0.8"/>
      <inertia ixx="0.0012" ixy="0.0001" ixz="0" iyy="0.0009" iyz="0" izz="0.001"/></inertial></link>
  <link name="tool0">
    <inertial><origin xyz="0.02 0 0"/><mass value="0.2"/>
      <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/></inertial></link>
  <joint name="lift" type="prismatic"><parent link="base_link"/><child link="carriage"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="0.0" upper="0.5" velocity="0.4" effort="600"/></joint>
  <joint name="shoulder" type="revolute"><parent link="carriage"/><child link="upper_arm"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-2.6" upper="2.6" velocity="1.5" effort="80"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper_arm"/><child link="forearm"/>
    <origin xyz="0.4 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-2.0" upper="2.0" velocity="2.0" effort="40"/></joint>
  <joint name="wrist" type="revolute"><parent link="forearm"/><child link="hand"/>
    <origin xyz="0.3 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-2.5" upper="2.5" velocity="3.0" effort="10"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="hand"/><child link="tool0"/>
    <origin xyz="0.08 0 0"/></joint>
</robot>
"""

#: Drives on the joint side, in proportion to each joint's effort limit E (N m or N): Ia = 2e-3 E (kg m^2 or kg),
#: Fv = 2e-2 E (N m s/rad or N s/m), Fc = 4e-2 E (N m or N), each times a seeded factor in [0.7, 1.3]; an
#: offset of up to 1e-2 E either way (N m or N).
DRIVES_PER_EFFORT = {"Ia": 2e-3, "Fv": 2e-2, "Fc": 4e-2}
OFFSET_PER_EFFORT = 1e-2
#: Positions quantised to these steps (rad, m).
QUANTUM_REVOLUTE, QUANTUM_PRISMATIC = 1e-5, 1e-6
#: Torque noise: this share of each channel's RMS.
NOISE = 0.01
#: The dead torque channel reports a value on this share of the samples (exact 0 otherwise).
DEAD_REPORTS = 0.03
#: The logs' first stamp (s): a clock that does not start at 0.
T0 = 2.0
#: The sines' frequencies (Hz) and how many per joint.
BAND, SINES = (0.1, 1.5), 4


def gallery_robot(name: str, *, folder=None, seed: int = 0):
    """(urdf path, `SerialRobot` with true drives, tip link or None) of gallery robot `name` (`GALLERY`).

    The prismatic robot's description is written to `folder` (required for it). The dead joint of each robot
    is `dead_joint(name)`.
    """
    from jaxsdp.plants import SerialRobot

    if name == "prismatic":
        if folder is None:
            raise ValueError("the prismatic robot's URDF is written to `folder`; give one")
        urdf, tip = pathlib.Path(folder) / "lift_arm.urdf", None
        urdf.write_text(PRISMATIC_URDF)
    elif name in ARMS:
        if EXAMPLE_ROBOTS is None:
            raise ValueError("example-robot-data is not installed (pip install example-robot-data)")
        rel, tip, _ = ARMS[name]
        urdf = EXAMPLE_ROBOTS / rel
    else:
        raise ValueError(f"`name` must be one of {GALLERY}; got {name!r}")
    robot = SerialRobot.from_urdf(urdf, tip_link=tip)
    effort = np.array([robot.limits[k][3] for k in robot.names])
    rng = np.random.default_rng(seed)
    drives = [k * effort * rng.uniform(0.7, 1.3, robot.n) for k in DRIVES_PER_EFFORT.values()]
    drives.append(OFFSET_PER_EFFORT * effort * rng.uniform(-1.0, 1.0, robot.n))
    robot = eqx.tree_at(lambda r: (r.Ia, r.Fv, r.Fc, r.offset), robot, tuple(drives))  # float64 NumPy
    return urdf, robot, tip


def dead_joint(name: str) -> str:
    """The joint whose torque channel is dead in gallery robot `name`'s logs."""
    return PRISMATIC_DEAD if name == "prismatic" else ARMS[name][2]


def _motion(robot, seconds: float, rng):
    """Per joint: centre c, scale s, and sines (f Hz, amplitude, phase) with q = c + s sum a sin(2 pi f t + phi),
    within 85 % of the half range of the position limits (at most 1.5 rad or 0.2 m) and 80 % of the velocity
    limit, on every joint."""
    out = []
    t = np.linspace(0.0, seconds, 20001)
    for name, prism in zip(robot.names, robot.prismatic):
        lo, hi, vmax, _ = robot.limits.get(name, (np.nan,) * 4)
        cap = 0.2 if prism else 1.5
        lo, hi = (-cap, cap) if not (np.isfinite(lo) and np.isfinite(hi)) else (lo, hi)
        centre, half = 0.5 * (lo + hi), min(0.85 * 0.5 * (hi - lo), cap)
        vmax = 0.8 * vmax if np.isfinite(vmax) and vmax > 0 else (0.3 if prism else 1.5)
        f = np.sort(rng.uniform(*BAND, SINES))
        a = rng.uniform(0.5, 1.0, SINES) / f  # equal share of the speed at every frequency, roughly
        phi = rng.uniform(0.0, 2.0 * np.pi, SINES)
        w = 2.0 * np.pi * f
        q = np.sin(np.outer(t, w) + phi) @ a
        dq = np.cos(np.outer(t, w) + phi) @ (a * w)
        scale = min(half / np.max(np.abs(q)), vmax / np.max(np.abs(dq)))
        out.append((centre, scale * a, w, phi))
    return out


def _evaluate(motion, t):
    q, dq, ddq = (np.empty((t.size, len(motion))) for _ in range(3))
    for j, (c, a, w, phi) in enumerate(motion):
        arg = np.outer(t, w) + phi
        q[:, j] = c + np.sin(arg) @ a
        dq[:, j] = np.cos(arg) @ (a * w)
        ddq[:, j] = -np.sin(arg) @ (a * w * w)
    return q, dq, ddq


def _write_csv(path, t, values, names, order, extra, rng):
    """`time,<names in order>` with the extra column inserted at a random place among the joints."""
    cols = [names[k] for k in order]
    data = [values[:, k] for k in order]
    if extra is not None:
        at = int(rng.integers(0, len(cols) + 1))
        cols.insert(at, extra[0])
        data.insert(at, extra[1])
    table = np.column_stack([t, *data])
    fmt = ["%.7f"] + ["%.8g"] * len(cols)
    np.savetxt(path, table, delimiter=",", header=",".join(["time", *cols]), comments="", fmt=fmt)


def true_base(robot, joints):
    """{combination: (name, value)} of the base parameters of `robot_model(robot, joints=joints)` (1-based)."""
    from jaxsdp.plants.robot import robot_model

    model = robot_model(robot, joints=joints)
    nominal = np.asarray(model.nominal, dtype=float)
    return {c: (k, float(v)) for c, k, v in zip(model.base.names, model.names, nominal)}


def write_gallery_logs(
    folder,
    robot,
    *,
    rate_hz: float,
    seconds: float,
    dead_joint: str,
    seed: int = 0,
    header: str = "urdf",
    jitter: float = 0.1,
) -> dict:
    """Simulate `robot` (with its true drives) on an exciting motion and write positions.csv and torques.csv.

    `header="urdf"` (the logs as robots write them: URDF joint names, shuffled, an extra `temperature`
    column) or `"joint_k"` (`Joint_<k>` in the description's order, no extra column: what today's loader reads);
    `jitter`: the stamps' jitter, a share of the sampling period (uniform either way; 0: a uniform clock).

    **Returns:** `positions`, `torques` (paths), `names` (joint names), `live` (the live joints' names), `dead`,
    `rate_hz`, `seconds`, `samples`, `truth` ({combination: (base parameter name, true value)} of the live joints'
    stacked model, `true_base`), `peak_speed` (per joint, rad/s or m/s).
    """
    if dead_joint not in robot.names:
        raise ValueError(f"`dead_joint` {dead_joint!r} is not one of {robot.names}")
    if header not in ("urdf", "joint_k"):
        raise ValueError(f"`header` must be 'urdf' or 'joint_k'; got {header!r}")
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    n, N = robot.n, int(round(rate_hz * seconds))
    motion = _motion(robot, seconds, rng)
    t = T0 + (np.arange(N) + rng.uniform(-jitter, jitter, N)) / rate_hz
    q, dq, ddq = _evaluate(motion, t)
    tau = np.asarray(robot.drive_torques(q, dq, ddq))
    rms = np.sqrt(np.mean(tau**2, axis=0))
    tau = tau + NOISE * rms * rng.standard_normal(tau.shape)
    quantum = np.where(np.asarray(robot.prismatic, dtype=bool), QUANTUM_PRISMATIC, QUANTUM_REVOLUTE)
    q_logged = np.round(q / quantum) * quantum
    d = robot.names.index(dead_joint)
    tau[rng.random(N) >= DEAD_REPORTS, d] = 0.0
    if header == "urdf":
        names, order = robot.names, rng.permutation(n)
        temp = 35.0 + 0.01 * np.cumsum(rng.standard_normal(N))
        extras = (("temperature", np.round(temp, 2)), ("temperature", np.round(temp + 5.0, 2)))
    else:
        names, order, extras = tuple(f"Joint_{k}" for k in range(1, n + 1)), np.arange(n), (None, None)
    paths = {"positions": folder / "positions.csv", "torques": folder / "torques.csv"}
    _write_csv(paths["positions"], t, q_logged, names, order, extras[0], rng)
    _write_csv(paths["torques"], t, tau, names, order, extras[1], rng)
    live = [k for k in robot.names if k != dead_joint]
    return {
        **paths,
        "names": robot.names,
        "live": live,
        "dead": dead_joint,
        "rate_hz": rate_hz,
        "seconds": seconds,
        "samples": N,
        "truth": true_base(robot, [robot.names.index(k) + 1 for k in live]),
        "peak_speed": np.max(np.abs(dq), axis=0),
    }
