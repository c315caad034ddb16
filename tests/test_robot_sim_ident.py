"""Identification of a serial robot through its closed-loop simulator, on the TX40's first two joints (the
base turning about the vertical and the shoulder lifting the arm against gravity: a small robot that compiles
quickly): Levenberg-Marquardt run end to end from a perturbed guess recovers the base parameters of noise-free
data, the output error's gradient w.r.t. every inertial, actuator and friction parameter matches central
finite differences, and bad input."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

from jaxsdp.plants import (
    SerialRobot,
    identify_robot_by_simulation,
    joint_model,
    robot_output_error,
    simulate_robot,
    tx40_robot,
)

DT = 1e-3
N = 500
# Coulomb law regularised over 0.05 rad/s (the joints reach 6-8 rad/s): at the default 1e-3 rad/s the loss is
# so steep near velocity reversals that central differences lose their digits (the derivative itself stays
# exact); one value for the data and every candidate, so the simulator compiles once for both
EPS = 0.05
FIELDS = lambda r: (r.inertial, r.Ia, r.Fv, r.Fc)  # noqa: E731  the parameters estimated by default


def two_joint_tx40() -> SerialRobot:
    """The TX40's first two links and drives (MDH rows 1-2), without the links beyond the shoulder."""
    tx40 = tx40_robot()
    fields = ("rotation", "translation", "axis", "inertial", "Ia", "Fv", "Fc", "offset")
    rows = {k: getattr(tx40, k)[:2] for k in fields}
    return SerialRobot(g=tx40.g, ratios=tx40.ratios[:2], **rows)


@pytest.fixture(scope="module")
def setup():
    robot = two_joint_tx40()
    t = np.arange(N) * DT
    # both joints reverse (Fc), the shoulder sweeps -1.4..0.2 rad (its gravity torque's cos and sin parts)
    qr = np.stack([0.5 * np.sin(2 * np.pi * 2.0 * t), -0.6 + 0.8 * np.sin(2 * np.pi * 1.5 * t)], axis=1)
    sim = simulate_robot(robot, qr, dt=DT, eps=EPS)
    rng = np.random.default_rng(0)
    # every parameter moved by 10-20 %, up or down at random
    moved = tuple(
        np.asarray(x) * (1 + rng.choice([-1.0, 1.0], np.shape(x)) * rng.uniform(0.1, 0.2, np.shape(x)))
        for x in FIELDS(robot)
    )
    guess = eqx.tree_at(FIELDS, robot, moved)
    return robot, qr, sim, guess


def _theta(robot: SerialRobot, joint: int) -> np.ndarray:
    """The full parameter vector of `joint_model`: the link parameters, then the joint's Ia, Fv, Fc, offset."""
    drive = [float(getattr(robot, k)[joint - 1]) for k in ("Ia", "Fv", "Fc", "offset")]
    return np.concatenate([np.asarray(robot.inertial).ravel(), drive])


def test_identification_recovers_the_base_parameters(setup):
    robot, qr, sim, guess = setup
    res = identify_robot_by_simulation(qr, sim.tau, robot0=guess, controller_model=robot, dt=DT, eps=EPS)
    assert res.result == optx.RESULTS.successful
    assert int(res.num_steps) < 50  # converged before max_steps
    # the reported errors are 100 sqrt(J), J the relative output error of `robot_output_error`
    j0 = robot_output_error(guess, qr, sim.tau, controller_model=robot, dt=DT, eps=EPS)
    assert float(res.initial_relative_error) == pytest.approx(100 * float(jnp.sqrt(j0)), rel=1e-10)
    assert float(res.initial_relative_error) > 5.0  # % (9.6 %: the guess is far off)
    # noise-free data from the same simulator: the truth has zero residual, and the fit must reach it to the
    # solver's 1e-8 tolerances, i.e. below 1e-6 % (measured 2e-12 %)
    assert float(res.relative_error) < 1e-6
    # only base parameters are identifiable (ZZ1 + Ia1 + XX2, ZZ2 + Ia2, ...): compare them joint by joint,
    # each to 1e-6 relative (measured <= 2e-11, the smallest base parameter XY2 = 8e-4 kg m^2 included)
    for joint in (1, 2):
        base = joint_model(robot, joint=joint).base
        truth, start, est = (base.values(_theta(r, joint)) for r in (robot, guess, res.robot))
        moved = np.array([not k.startswith("offset") for k in base.names])  # the offset is not estimated
        assert np.all(np.abs(start - truth)[moved] > 0.05 * np.abs(truth[moved])), base.names  # all started off
        np.testing.assert_allclose(est, truth, rtol=1e-6, atol=0, err_msg=str(base.names))
    np.testing.assert_allclose(res.estimates[2], robot.Fv, rtol=1e-6)  # base parameters themselves
    np.testing.assert_allclose(res.estimates[3], robot.Fc, rtol=1e-6)


def test_output_error_gradient_matches_finite_differences(setup, output="torque"):
    robot, qr, sim, guess = setup
    y = sim.tau if output == "torque" else sim.q

    def loss(theta):
        candidate = eqx.tree_at(FIELDS, guess, theta)
        return robot_output_error(candidate, qr, y, controller_model=robot, output=output, dt=DT, eps=EPS)

    theta = tuple(jnp.asarray(x) for x in FIELDS(guess))
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
    assert float(robot_output_error(robot, qr, sim.tau, controller_model=robot, dt=DT, eps=EPS)) == 0.0
    assert float(robot_output_error(guess, qr, sim.q, controller_model=robot, output="position", dt=DT, eps=EPS)) > 0
    other = simulate_robot(guess, qr, dt=DT, controller_model=robot, eps=EPS)  # the candidate, the real controller
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
        identify_robot_by_simulation(qr[:, :1], sim.tau, robot0=robot, dt=DT)
