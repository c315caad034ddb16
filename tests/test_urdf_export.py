"""The identified robot written back as a URDF (issue 45, item 2): pinocchio loads it and its dynamics are the
robot's; the drives file beside it; the rpy of any rotation; what cannot be written is refused."""

import json

import jax
import numpy as np
import pytest

from helpers import EXAMPLE_ROBOTS, requires_example_robots
from jaxsdp.plants import SerialRobot, tx40_robot
from jaxsdp.plants.robot import physical_estimate, robot_model, write_urdf
from jaxsdp.plants.robot._urdf import rpy_matrix
from jaxsdp.plants.robot._urdf_export import matrix_rpy

jax.config.update("jax_enable_x64", True)
pin = pytest.importorskip("pinocchio")


def _same_dynamics_as_pinocchio(robot, path, tol=1e-10):
    model = pin.buildModelFromUrdf(str(path))
    assert tuple(model.names[1:]) == robot.names
    data = model.createData()
    rng = np.random.default_rng(0)
    for _ in range(5):
        q, v, a = rng.uniform(-1.5, 1.5, (3, robot.n))
        qp = np.concatenate([[np.cos(x), np.sin(x)] if model.joints[i + 1].nq == 2 else [x] for i, x in enumerate(q)])
        tau = pin.rnea(model, data, qp, v, a)
        np.testing.assert_allclose(np.asarray(robot.inverse_dynamics(q, v, a)), tau, atol=tol * max(1, abs(tau).max()))


def test_rpy_of_any_rotation():
    rng = np.random.default_rng(0)
    for rpy in [*rng.uniform(-3, 3, (20, 3)), (0.3, np.pi / 2, -0.2), (0.1, -np.pi / 2, 0.4)]:
        R = rpy_matrix(rpy)
        np.testing.assert_allclose(rpy_matrix(matrix_rpy(R)), R, atol=1e-12)


def test_identified_tx40_written_loads_in_pinocchio(tmp_path):
    """The physically consistent estimate of a perturbed TX40 (from a modified DH table: no URDF behind it)
    written as a URDF: pinocchio's inverse dynamics of the file equals the identified robot's, and the drives
    file holds the identified motor inertias and friction."""
    robot = tx40_robot()
    model = robot_model(robot)
    beta = model.nominal * (1 + 0.05 * np.random.default_rng(2).normal(size=model.rank))
    est = physical_estimate(dict(theta=beta, cov=np.diag((0.02 * np.abs(model.nominal) + 1e-3) ** 2)), model)
    identified = est.robot(robot)
    urdf, drives = write_urdf(identified, tmp_path / "tx40_identified.urdf")
    assert drives.name == "tx40_identified.drives.json"
    _same_dynamics_as_pinocchio(identified, urdf)
    table = json.loads(drives.read_text())
    full = dict(zip(est.names, np.asarray(est.theta)))
    assert [j["Fv"] for j in table["joints"]] == pytest.approx([full[f"Fv{k}"] for k in range(1, 7)], rel=1e-15)
    assert table["coordinate"] == "joint" and table["gravity"] == pytest.approx(9.81)
    # and jaxsdp reads its own file back to the same robot
    back = SerialRobot.from_urdf(urdf)
    q = np.random.default_rng(3).uniform(-2, 2, (10, 6))
    np.testing.assert_allclose(back.mass_matrix(q), identified.mass_matrix(q), atol=1e-12)


@requires_example_robots
def test_identified_ur5_written_loads_in_pinocchio(tmp_path):
    """A robot from a real description (UR5, fixed joints merged): its physical estimate, written and loaded."""
    robot = SerialRobot.from_urdf(EXAMPLE_ROBOTS / "ur_description/urdf/ur5_robot.urdf")
    model = robot_model(robot)
    beta = model.nominal + 0.01 * np.random.default_rng(4).normal(size=model.rank)
    est = physical_estimate(dict(theta=beta, cov=1e-4 * np.eye(model.rank)), model)
    identified = est.robot(robot)
    urdf, _ = write_urdf(identified, tmp_path / "ur5.urdf", name="ur5_identified")
    _same_dynamics_as_pinocchio(identified, urdf)


def test_what_cannot_be_written_is_refused(tmp_path):
    massless = SerialRobot.from_mdh([[0, 0, 0, 0]], inertias=np.zeros((1, 10)))
    with pytest.raises(ValueError, match="no positive mass"):
        write_urdf(massless, tmp_path / "a.urdf")
    with pytest.raises(ValueError, match=r"\.urdf"):
        write_urdf(tx40_robot(), tmp_path / "a.xml")
    with pytest.raises(ValueError, match="does not exist"):
        write_urdf(tx40_robot(), tmp_path / "missing" / "a.urdf")
