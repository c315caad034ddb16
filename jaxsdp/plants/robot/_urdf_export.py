"""A `SerialRobot` written as a URDF, with its drives in a JSON file beside it: the identified robot for simulators.

The URDF holds the robot's dynamics: a chain `base_link` -> one link per
joint, each joint's fixed origin (xyz, and rpy with URDF's R = Rz(yaw)
Ry(pitch) Rx(roll)), axis, type and limits, each link's inertial (mass, the
centre of mass as the inertial origin, the inertia about it in the link's
axes). Geometry (visual, collision meshes) is not the robot's dynamics and
is not written; a description read from a URDF with fixed joints comes back
as its merged chain (`SerialRobot.from_urdf`). What a URDF has no element
for goes to `<file>.drives.json`: each joint's actuator inertia, viscous and
Coulomb friction and torque offset (joint side, or in the motors'
coordinates with the coupling `transmission`), gear ratio, and gravity.
pinocchio (`buildModelFromUrdf`) loads the file; its inverse dynamics
equals `SerialRobot.inverse_dynamics` (tested to 1e-10).
"""

import json
import math
import pathlib
import xml.etree.ElementTree as ET

import numpy as np

from ..._runtime import x64
from ._inertia import link_body
from ._serial import SerialRobot


def matrix_rpy(R) -> tuple:
    """URDF's roll, pitch, yaw (rad) of a rotation matrix R = Rz(yaw) Ry(pitch) Rx(roll)."""
    R = np.asarray(R, dtype=float)
    pitch = math.asin(float(np.clip(-R[2, 0], -1.0, 1.0)))
    if abs(math.cos(pitch)) > 1e-9:
        return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])
    return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])  # gimbal lock: the roll folded into the yaw


def _num(v) -> str:
    return repr(float(v))


def _inertial(link, pi) -> None:
    m, c, J = link_body(pi)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz=" ".join(map(_num, c)), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=_num(m))
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    ET.SubElement(
        inertial, "inertia", **dict(zip(keys, map(_num, (J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2]))))
    )


@x64
def write_urdf(robot: SerialRobot, path, *, name: str = "identified", transmission=None) -> tuple:
    """Write `robot` as the URDF `path` and its drives as `<path without .urdf>.drives.json`.

    `name`: the URDF's robot name; `transmission`: the drives' coupling C
    (n, n) when the drive parameters are in the motors' coordinates (du =
    C^-1 dq), written to the JSON file (None: joint side). Returns the two
    paths. Links with a non-positive mass are refused (not a body a
    simulator can load): make the robot physical first
    (`PhysicalEstimate.robot`).

    Example:
        >>> import pathlib, tempfile
        >>> from jaxsdp.plants import SerialRobot, tx40_robot
        >>> from jaxsdp.plants.robot import write_urdf
        >>> urdf, drives = write_urdf(tx40_robot(), pathlib.Path(tempfile.mkdtemp()) / "tx40.urdf")
        >>> back = SerialRobot.from_urdf(urdf)
        >>> q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
        >>> bool(abs(back.gravity_torques(q) - tx40_robot().gravity_torques(q)).max() < 1e-12)
        True
    """
    if not isinstance(robot, SerialRobot):
        raise ValueError(f"`robot` must be a SerialRobot; got {type(robot).__name__}")
    path = pathlib.Path(path)
    if path.suffix != ".urdf":
        raise ValueError(f"`path` must end in .urdf; got {path.name!r}")
    if not path.parent.is_dir():
        raise ValueError(f"`path`: the folder {path.parent} does not exist")
    n = robot.n
    inertial = np.asarray(robot.inertial, dtype=float)
    light = [k + 1 for k in range(n) if not inertial[k, 9] > 0]
    if light:
        raise ValueError(f"link(s) {light} have no positive mass: not a body a simulator loads (make it physical)")
    C = None if transmission is None else np.asarray(transmission, dtype=float)
    if C is not None and C.shape != (n, n):
        raise ValueError(f"`transmission` must be ({n}, {n}); got {C.shape}")
    names = list(robot.names or tuple(f"joint{j}" for j in range(1, n + 1)))
    root = ET.Element("robot", name=name)
    ET.SubElement(root, "link", name="base_link")
    parent = "base_link"
    rotation, translation, axis = (np.asarray(a, dtype=float) for a in (robot.rotation, robot.translation, robot.axis))
    for k in range(n):
        child = f"{names[k]}_link"
        link = ET.SubElement(root, "link", name=child)
        _inertial(link, inertial[k])
        prismatic = robot._is_prismatic(k)
        limit = robot.limits.get(names[k])
        kind = "prismatic" if prismatic else ("revolute" if limit is not None else "continuous")
        joint = ET.SubElement(root, "joint", name=names[k], type=kind)
        ET.SubElement(joint, "parent", link=parent)
        ET.SubElement(joint, "child", link=child)
        rpy = matrix_rpy(rotation[k])
        ET.SubElement(joint, "origin", xyz=" ".join(map(_num, translation[k])), rpy=" ".join(map(_num, rpy)))
        ET.SubElement(joint, "axis", xyz=" ".join(map(_num, axis[k])))
        if kind != "continuous":
            lower, upper, velocity, effort = limit if limit is not None else (-1e3, 1e3, 1e3, 1e6)
            values = dict(lower=lower, upper=upper, velocity=velocity, effort=effort)
            ET.SubElement(joint, "limit", **{key: _num(v) for key, v in values.items() if v is not None})
        parent = child
    ET.indent(root)
    header = "<?xml version='1.0' encoding='utf-8'?>\n<!-- written by jaxsdp (write_urdf): dynamics only -->\n"
    path.write_text(header + ET.tostring(root, encoding="unicode") + "\n")
    drives = path.with_suffix(".drives.json")
    drives.write_text(json.dumps(drive_table(robot, names, C), indent=2) + "\n")
    return path, drives


def drive_table(robot: SerialRobot, names, transmission) -> dict:
    """The drives file's content: gravity, the coordinate, the coupling, each joint's drive parameters."""
    ratios = robot.ratios or (1.0,) * robot.n
    return {
        "gravity": float(robot.g),
        "coordinate": "joint" if transmission is None else "motor (du = C^-1 dq, C = transmission)",
        "transmission": None if transmission is None else np.asarray(transmission).tolist(),
        "units": {"Ia": "kg m^2 (kg)", "Fv": "N m s/rad (N s/m)", "Fc": "N m (N)", "offset": "N m (N)"},
        "joints": [
            {
                "name": names[k],
                "type": "prismatic" if robot._is_prismatic(k) else "revolute",
                "Ia": float(robot.Ia[k]),
                "Fv": float(robot.Fv[k]),
                "Fc": float(robot.Fc[k]),
                "offset": float(robot.offset[k]),
                "ratio": float(ratios[k]),
            }
            for k in range(robot.n)
        ],
    }
