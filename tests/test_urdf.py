"""Robots from their description (issue 31, item 1): `SerialRobot.from_urdf` and `from_mdh` against pinocchio.

Inverse dynamics, mass matrix and gravity of robots loaded from real description files (the TX40's, and UR5,
Panda, Unitree Z1 and Kinova Jaco from `example-robot-data`) against pinocchio's `rnea`, `crba` and
`computeGeneralizedGravity` on the same file, to 1e-10; the TX40 file against `tx40_robot()`; prismatic
joints; the errors for what a serial-chain model cannot hold.
"""

import pathlib

import jax
import numpy as np
import pytest

from helpers import EXAMPLE_ROBOTS, TX40_URDF, check_quoted, requires_example_robots, requires_tx40_urdf
from jaxsdp.plants import SerialRobot, tx40_robot
from jaxsdp.plants.robot._tx40 import TX40_MDH

jax.config.update("jax_enable_x64", True)
pin = pytest.importorskip("pinocchio")

ROBOTS = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", None),
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand"),  # the fingers held: a branch off the chain
    "z1": ("z1_description/urdf/z1.urdf", None),
    "kinova": ("kinova_description/robots/kinova.urdf", None),  # continuous joints
}


#: pinocchio's regressor column of each of ours, within a link (`SerialRobot.parameter_names`' order)
PIN_COLUMNS = [4, 5, 7, 6, 8, 9, 1, 2, 3, 0]


def pinocchio_model(path, robot):
    """pinocchio's model of the same file, with the joints jaxsdp holds (or leaves out) locked at 0."""
    model = pin.buildModelFromUrdf(str(path))
    lock = [model.getJointId(n) for n in model.names[1:] if n not in robot.names]
    if lock:
        model = pin.buildReducedModel(model, lock, pin.neutral(model))
    assert tuple(model.names[1:]) == robot.names
    return model


def assert_same_dynamics(robot, model, *, seed=0, tol=1e-10):
    data = model.createData()
    rng = np.random.default_rng(seed)
    for _ in range(6):
        q, v, a = rng.uniform(-1.5, 1.5, (3, robot.n))
        # pinocchio's continuous joints take (cos q, sin q)
        qp = np.concatenate([[np.cos(x), np.sin(x)] if model.joints[i + 1].nq == 2 else [x] for i, x in enumerate(q)])
        tau = pin.rnea(model, data, qp, v, a)
        M = pin.crba(model, data, qp)
        M = np.triu(M) + np.triu(M, 1).T
        g = pin.computeGeneralizedGravity(model, data, qp)
        np.testing.assert_allclose(np.asarray(robot.inverse_dynamics(q, v, a)), tau, atol=tol * max(1, abs(tau).max()))
        np.testing.assert_allclose(np.asarray(robot.mass_matrix(q)), M, atol=tol * max(1, abs(M).max()))
        np.testing.assert_allclose(np.asarray(robot.gravity_torques(q)), g, atol=tol * max(1, abs(g).max()))
        # the regressor, by the recursion written for it, against pinocchio's: its columns per joint are
        # [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz], ours [XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]
        Yp = pin.computeJointTorqueRegressor(model, data, qp, v, a)
        Yp = Yp.reshape(robot.n, robot.n, 10)[:, :, PIN_COLUMNS].reshape(robot.n, -1)
        np.testing.assert_allclose(np.asarray(robot.regressor(q, v, a)), Yp, atol=tol * max(1, abs(Yp).max()))


@requires_tx40_urdf
def test_tx40_file_against_pinocchio_and_tx40_robot():
    robot = SerialRobot.from_urdf(TX40_URDF)
    assert robot.n == 6 and robot.names == tuple(f"joint_{j}" for j in range(1, 7))
    assert robot.limits["joint_2"] == (-2.18, 2.18, 5.009, 131.84)
    assert_same_dynamics(robot, pinocchio_model(TX40_URDF, robot))
    # the same dynamics as the Table 3 model: the file's pi/2 has 11 digits
    ref = tx40_robot()
    q, v, a = np.random.default_rng(1).uniform(-2, 2, (3, 50, 6))
    tau = np.asarray(robot.inverse_dynamics(q, v, a))
    np.testing.assert_allclose(tau, ref.inverse_dynamics(q, v, a), atol=1e-10)
    np.testing.assert_allclose(robot.mass_matrix(q), ref.mass_matrix(q), atol=1e-10)
    largest = float(np.max(np.abs(tau - np.asarray(ref.inverse_dynamics(q, v, a)))))
    check_quoted("docs/paper.md", "the public URDF gives the same dynamics to {} N m", largest, ".1e")


@requires_example_robots
@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_example_robots_against_pinocchio(name):
    rel, tip = ROBOTS[name]
    path = EXAMPLE_ROBOTS / rel
    robot = SerialRobot.from_urdf(path, tip_link=tip)
    assert robot.n >= 6
    if name == "panda":
        assert set(robot.locked) == {"panda_finger_joint1", "panda_finger_joint2"}
    assert_same_dynamics(robot, pinocchio_model(path, robot))


def test_from_mdh_is_tx40_robot():
    ref = tx40_robot()
    r = SerialRobot.from_mdh(TX40_MDH, inertias=ref.inertial, ratios=ref.ratios, Ia=ref.Ia, Fv=ref.Fv)
    q, v, a = np.random.default_rng(2).uniform(-2, 2, (3, 20, 6))
    np.testing.assert_allclose(r.inverse_dynamics(q, v, a), ref.inverse_dynamics(q, v, a), atol=1e-12)
    np.testing.assert_allclose(r.regressor(q[0], v[0], a[0]), ref.regressor(q[0], v[0], a[0]), atol=1e-12)
    with pytest.raises(ValueError, match="table"):
        SerialRobot.from_mdh(np.zeros((6, 3)), inertias=ref.inertial)
    with pytest.raises(ValueError, match="inertias"):
        SerialRobot.from_mdh(TX40_MDH, inertias=ref.inertial[:5])


PRISMATIC = """<robot name="gantry">
  <link name="world"/>
  <link name="carriage"><inertial><mass value="3"/><origin xyz="0.1 0 0.05" rpy="0.2 0 0"/>
    <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0" izz="0.01"/></inertial></link>
  <link name="arm"><inertial><mass value="1.5"/><origin xyz="0.3 0.02 0" rpy="0 0.1 0.3"/>
    <inertia ixx="0.01" ixy="0" ixz="0.001" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
  <link name="tool"><inertial><mass value="0.5"/><origin xyz="0 0 0.1"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>
  <joint name="slide" type="prismatic"><parent link="world"/><child link="carriage"/>
    <origin xyz="0 0 1" rpy="0 0.3 0"/><axis xyz="1 0 0.5"/>
    <limit lower="0" upper="1" velocity="1" effort="100"/></joint>
  <joint name="turn" type="revolute"><parent link="carriage"/><child link="arm"/>
    <origin xyz="0.2 0 0" rpy="1.0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" velocity="2" effort="40"/></joint>
  <joint name="flange" type="fixed"><parent link="arm"/><child link="tool"/><origin xyz="0.6 0 0" rpy="0 0 1"/></joint>
</robot>"""


def test_prismatic_and_fixed_joints_against_pinocchio(tmp_path):
    path = tmp_path / "gantry.urdf"
    path.write_text(PRISMATIC)
    robot = SerialRobot.from_urdf(path)
    assert robot.prismatic == (True, False) and robot.names == ("slide", "turn")
    assert_same_dynamics(robot, pinocchio_model(path, robot))


def _write(tmp_path, text) -> pathlib.Path:
    path = tmp_path / "r.urdf"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "text,kwargs,match",
    [
        ("<robot><link name='a'/><link name='b'/></robot>", {}, "2 root links"),
        ("<notarobot/>", {}, "not a URDF"),
        ("<robot", {}, "cannot read it as XML"),
        (
            "<robot><link name='w'/><link name='b'/><joint name='free' type='floating'><parent link='w'/>"
            "<child link='b'/></joint><link name='c'/><joint name='j' type='revolute'><parent link='b'/>"
            "<child link='c'/><axis xyz='0 0 1'/></joint></robot>",
            {},
            "joint 'free' is floating",
        ),
        (
            "<robot><link name='w'/><link name='b'/><link name='c'/><joint name='j1' type='revolute'><parent "
            "link='w'/><child link='b'/></joint><joint name='j2' type='revolute'><parent link='w'/><child "
            "link='c'/></joint></robot>",
            {},
            "not a serial chain",
        ),
        (
            "<robot><link name='w'/><link name='b'/><joint name='j1' type='revolute'><parent link='w'/><child "
            "link='b'/><mimic joint='x'/></joint></robot>",
            {},
            "mimic joint",
        ),
        (
            "<robot><link name='w'/><link name='b'/><joint name='j' type='revolute'><parent link='w'/><child "
            "link='b'/></joint></robot>",
            {"base_link": "nope"},
            "base_link 'nope'",
        ),
        (
            "<robot><link name='w'/><link name='b'/><joint name='j' type='revolute'><parent link='w'/><child "
            "link='x'/></joint></robot>",
            {},
            "link 'x' is not defined",
        ),
        (
            "<robot><link name='w'/><link name='b'/><joint name='j' type='revolute'><parent link='w'/><child "
            "link='b'/></joint></robot>",
            {"joints": ["k"]},
            "joints \\['k'\\] are not on the chain",
        ),
    ],
)
def test_unsupported_descriptions_are_named(tmp_path, text, kwargs, match):
    with pytest.raises(ValueError, match=match):
        SerialRobot.from_urdf(_write(tmp_path, text), **kwargs)


@requires_example_robots
def test_panda_without_tip_is_not_a_serial_chain():
    with pytest.raises(ValueError, match="not a serial chain.*tip_link"):
        SerialRobot.from_urdf(EXAMPLE_ROBOTS / ROBOTS["panda"][0])
