"""The six-joint TX40 model (modified DH, recursive Newton-Euler) against pinocchio, energy conservation,
eq. (20) for link 2 alone, the regressor by differentiation and the base parameters."""

import jax
import numpy as np
import pytest

from helpers import check_quoted
from jaxsdp.plants import base_parameters, link_parameters, tx40_robot
from jaxsdp.plants.robot._tx40 import TX40_LINKS, TX40_MDH

pin = pytest.importorskip("pinocchio", reason="pinocchio (package `pin`) is a test-only reference")

#: the agreement with pinocchio that docs/paper.md quotes (Table 3)
PINOCCHIO_TOL = 1e-10


def _rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def pinocchio_tx40():
    """The same robot built independently in pinocchio from the MDH table and the centre-of-mass numbers."""
    model = pin.Model()
    parent = 0
    for (alpha, d, theta, r), (m, c, psi, ic) in zip(TX40_MDH, TX40_LINKS):
        # Rot_x(alpha) Trans_x(d) Rot_z(theta + q) Trans_z(r) = [Rot_x(alpha) Rot_z(theta), p] then a z-rotation
        R = _rot("x", alpha) @ _rot("z", theta)
        p = np.array([d, 0.0, 0.0]) + _rot("x", alpha) @ np.array([0.0, 0.0, r])
        jid = model.addJoint(parent, pin.JointModelRZ(), pin.SE3(R, p), f"j{parent + 1}")
        Ic = np.array([[ic[0], ic[1], ic[2]], [ic[1], ic[3], ic[4]], [ic[2], ic[4], ic[5]]])
        Rp = _rot("z", psi)
        model.appendBodyToJoint(jid, pin.Inertia(m, np.asarray(c, float), Rp @ Ic @ Rp.T), pin.SE3.Identity())
        parent = jid
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    model.armature = np.asarray(tx40_robot().Ia)  # reflected actuator inertia
    return model


@pytest.fixture(scope="module")
def robots():
    return tx40_robot(), pinocchio_tx40()


def test_matches_pinocchio_at_random_states(robots):
    robot, model = robots
    data = model.createData()
    rng = np.random.default_rng(0)
    for _ in range(10):
        q, dq, ddq = rng.uniform(-np.pi, np.pi, 6), rng.normal(size=6) * 2, rng.normal(size=6) * 5
        rnea = pin.rnea(model, data, q, dq, ddq) - model.armature * ddq  # rnea adds the armature
        np.testing.assert_allclose(robot.inverse_dynamics(q, dq, ddq), rnea, atol=PINOCCHIO_TOL)
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T - np.diag(model.armature)  # crba adds the armature
        np.testing.assert_allclose(robot.mass_matrix(q), M, atol=PINOCCHIO_TOL)
        g = pin.computeGeneralizedGravity(model, data, q)
        np.testing.assert_allclose(robot.gravity_torques(q), g, atol=PINOCCHIO_TOL)
        tau = rng.normal(size=6) * 10
        np.testing.assert_allclose(robot.forward_dynamics(q, dq, tau), pin.aba(model, data, q, dq, tau), atol=1e-9)
    check_quoted("docs/paper.md", "Newton-Euler dynamics checked against pinocchio to {};", PINOCCHIO_TOL, ".0e")


def test_batched_jit_grad(robots):
    robot, _ = robots
    rng = np.random.default_rng(1)
    q, dq, ddq = (rng.normal(size=(4, 3, 6)) for _ in range(3))
    tau = robot.inverse_dynamics(q, dq, ddq)
    assert tau.shape == (4, 3, 6)
    np.testing.assert_allclose(tau[2, 1], robot.inverse_dynamics(q[2, 1], dq[2, 1], ddq[2, 1]), atol=1e-12)
    f = jax.jit(lambda r, a: r.inverse_dynamics(a, a, a)[1])
    x = rng.normal(size=6)
    g = jax.grad(lambda a: f(robot, a))(x)
    h = 1e-6
    fd = [(f(robot, x + h * e) - f(robot, x - h * e)) / (2 * h) for e in np.eye(6)]
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=1e-7)


def test_energy_is_conserved_without_friction(robots):
    robot, _ = robots
    f = jax.jit(lambda x: jax.numpy.concatenate([x[6:], robot.forward_dynamics(x[:6], x[6:], jax.numpy.zeros(6))]))

    def energy(x):
        q, dq = x[:6], x[6:]
        pot = 0.0
        # potential energy: minus the work of gravity, from the gravity torques integrated along a path
        s, w = np.polynomial.legendre.leggauss(40)  # Gauss-Legendre on [0, 1]: exact to round-off here
        s, w = (s + 1) / 2, w / 2
        gt = np.asarray(robot.gravity_torques(np.outer(s, q)))
        pot = w @ (gt @ q)
        return 0.5 * dq @ (np.asarray(robot.mass_matrix(q)) + np.diag(robot.Ia)) @ dq + pot

    x = np.r_[np.array([0.1, -0.4, 0.7, 0.2, -0.3, 0.5]), np.array([0.5, -0.3, 0.2, 1.0, -0.5, 0.8])]
    e0, h = energy(x), 2.5e-4
    for _ in range(2000):  # RK4, 0.5 s
        k1 = f(x)
        k2 = f(x + h / 2 * k1)
        k3 = f(x + h / 2 * k2)
        k4 = f(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert abs(energy(np.asarray(x)) - e0) < 1e-6 * max(1.0, abs(e0))


def test_link_2_alone_is_eq_20(robots):
    robot, _ = robots
    q = np.array([0.3, 0.0, 0.4, -0.2, 0.6, 0.1])  # joints 1, 3-6 held at these angles
    rng = np.random.default_rng(2)
    rows, tau = [], []
    for _ in range(30):
        q2, dq2, ddq2 = rng.uniform(-2, 2), rng.normal(), rng.normal() * 3
        qq, dq, ddq = q.copy(), np.zeros(6), np.zeros(6)
        qq[1], dq[1], ddq[1] = q2, dq2, ddq2
        tau.append(float(robot.inverse_dynamics(qq, dq, ddq)[1]))
        rows.append([ddq2, -9.81 * np.cos(q2), 9.81 * np.sin(q2)])
    theta, res, *_ = np.linalg.lstsq(np.array(rows), np.array(tau), rcond=None)
    assert res.size == 0 or res[0] < 1e-18  # exact: eq. (20) holds
    assert theta[0] > 0  # ZZ2 of the pose, kg m^2


def test_regressor_and_base_parameters(robots):
    robot, _ = robots
    rng = np.random.default_rng(3)
    q, dq, ddq = (rng.normal(size=(40, 6)) * s for s in (1.5, 1.0, 3.0))
    Y = np.asarray(robot.regressor(q, dq, ddq))
    assert Y.shape == (40, 6, 60)
    np.testing.assert_allclose(Y @ np.asarray(robot.inertial).ravel(), robot.inverse_dynamics(q, dq, ddq), atol=1e-10)
    np.testing.assert_allclose(robot.regressor(q, dq, ddq, joint=2), Y[:, 1, :], atol=1e-12)
    b = base_parameters(Y.reshape(-1, 60), robot.parameter_names())
    assert b.rank == 36  # the 6R robot with a first vertical axis: 36 base inertial parameters
    W = Y.reshape(-1, 60)
    theta = np.asarray(robot.inertial).ravel()
    ind = [robot.parameter_names().index(n) for n in b.independent]
    dep = [robot.parameter_names().index(n) for n in b.dependent]
    base = theta[ind] + b.combination @ theta[dep]
    np.testing.assert_allclose(W[:, ind] @ base, W @ theta, atol=1e-9)
    assert "M1" in b.dependent  # the first link's mass has no effect


def test_link_parameters_parallel_axis():
    p = link_parameters(3.0, [0.1, 0.2, 0.3], [0.01, 0.0, 0.0, 0.02, 0.0, 0.03], psi=0.0)
    c = np.array([0.1, 0.2, 0.3])
    J = np.diag([0.01, 0.02, 0.03]) + 3.0 * (c @ c * np.eye(3) - np.outer(c, c))
    np.testing.assert_allclose(p[:6], [J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2]], atol=1e-15)
    np.testing.assert_allclose(p[6:], [0.3, 0.6, 0.9, 3.0], atol=1e-15)


def test_closed_loop_simulation_is_consistent_with_the_drive_model(robots):
    from jaxsdp.plants import simulate_robot

    robot, _ = robots
    t = np.arange(2500) * 2e-4
    qr = np.outer(1 - np.cos(2 * np.pi * t), np.array([0.2, 0.3, -0.3, 0.5, 0.4, 0.6]))
    sim = simulate_robot(robot, qr, quantum=2 * np.pi / (2**16 * 45))
    assert np.abs(np.asarray(sim.q) - qr).max() < 0.1  # a 10 Hz PD against friction: within 10 % of the motion
    moving = np.all(np.abs(np.asarray(sim.dq)) > 0.05, axis=1)
    assert moving.sum() > 500
    tau = np.asarray(robot.drive_torques(sim.q, sim.dq, sim.ddq))
    np.testing.assert_allclose(tau[moving], np.asarray(sim.tau)[moving], atol=1e-9)
    with pytest.raises(ValueError, match="shape"):
        simulate_robot(robot, qr[:, :5])
