"""Identification of the six-joint robot through its closed-loop simulator: the output error's gradient
w.r.t. every inertial, actuator and friction parameter against central finite differences, and bad input."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxsdp.plants import identify_robot_by_simulation, robot_output_error, simulate_robot, tx40_robot

DT = 1e-3
N = 150


@pytest.fixture(scope="module")
def setup():
    robot = tx40_robot()
    t = np.arange(N) * DT
    qr = 0.3 * np.sin(2 * np.pi * np.outer(t, [1.0, 1.3, 1.7, 2.1, 2.5, 2.9]))
    sim = simulate_robot(robot, qr, dt=DT)
    rng = np.random.default_rng(0)
    fields = (robot.inertial, robot.Ia, robot.Fv, robot.Fc)
    moved = tuple(np.asarray(x) * (1 + 0.1 * rng.normal(size=np.shape(x))) for x in fields)
    guess = eqx.tree_at(lambda r: (r.inertial, r.Ia, r.Fv, r.Fc), robot, moved)
    return robot, qr, sim, guess


def test_output_error_gradient_matches_finite_differences(setup, output="torque"):
    robot, qr, sim, guess = setup
    y = sim.tau if output == "torque" else sim.q
    fields = lambda r: (r.inertial, r.Ia, r.Fv, r.Fc)  # noqa: E731

    def loss(theta):
        candidate = eqx.tree_at(fields, guess, theta)
        # eps: a Coulomb law regularised over 0.05 rad/s; at the default 1e-3 rad/s the loss is so steep near
        # velocity reversals that central differences lose their digits (the derivative itself stays exact)
        return robot_output_error(candidate, qr, y, controller_model=robot, output=output, dt=DT, eps=0.05)

    theta = tuple(jnp.asarray(x) for x in fields(guess))
    grad = jax.jit(jax.grad(loss))(theta)
    assert all(bool(jnp.all(jnp.isfinite(g))) for g in grad)
    assert float(loss(theta)) > 0
    rng = np.random.default_rng(1)
    for i, name in enumerate(("inertial", "Ia", "Fv", "Fc")):
        d = [jnp.zeros_like(x) for x in theta]
        d[i] = jnp.asarray(rng.normal(size=theta[i].shape) * np.maximum(np.abs(theta[i]), 1e-3))
        h = 1e-6
        plus = tuple(x + h * dx for x, dx in zip(theta, d))
        minus = tuple(x - h * dx for x, dx in zip(theta, d))
        fd = (float(loss(plus)) - float(loss(minus))) / (2 * h)
        ad = float(jnp.sum(grad[i] * d[i]))
        assert ad == pytest.approx(fd, rel=1e-6, abs=1e-12), name


def test_simulation_under_the_fixed_controller(setup):
    robot, qr, sim, guess = setup
    assert float(robot_output_error(robot, qr, sim.tau, controller_model=robot, dt=DT)) == 0.0
    assert float(robot_output_error(guess, qr, sim.q, controller_model=robot, output="position", dt=DT)) > 0
    other = simulate_robot(guess, qr, dt=DT, controller_model=robot)  # the candidate plant, the real controller
    assert not np.allclose(other.tau, sim.tau)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(output="velocity"), "output"),
        (dict(skip=-1), "skip"),
        (dict(robot0="TX40"), "SerialRobot"),
    ],
)
def test_bad_input(setup, kwargs, message):
    robot, qr, sim, _ = setup
    kw = dict(robot0=robot, dt=DT) | kwargs
    with pytest.raises(ValueError, match=message):
        identify_robot_by_simulation(qr, sim.tau, **kw)
    with pytest.raises(ValueError, match="shape"):
        identify_robot_by_simulation(qr[:, :3], sim.tau, robot0=robot, dt=DT)
