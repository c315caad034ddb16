"""Exciting trajectories by gradient (issue 31, item 5): the optimiser lowers the condition number, within limits,
and the simulated robot is identified on the optimised trajectory."""

import jax
import jax.numpy as jnp
import numpy as np

from helpers import TX40_URDF, requires_tx40_urdf
from jaxsdp.data import JointLogs
from jaxsdp.plants import SerialRobot
from jaxsdp.plants.robot import optimise_excitation, robot_idim_ls, robot_model

jax.config.update("jax_enable_x64", True)


def _within(res, t):
    q, dq, ddq = (np.asarray(v) for v in res.excitation.states(t))
    lim = np.asarray(res.limits["q"])
    assert np.all(q >= lim[:, 0] - 1e-9) and np.all(q <= lim[:, 1] + 1e-9)
    assert np.all(np.abs(dq) <= np.asarray(res.limits["velocity"]) + 1e-9)
    assert np.all(np.abs(ddq) <= np.asarray(res.limits["acceleration"]) + 1e-9)


@requires_tx40_urdf
def test_tx40_excitation_lowers_the_condition_number_within_the_limits():
    robot = SerialRobot.from_urdf(TX40_URDF)
    res = optimise_excitation(robot_model(robot), harmonics=5, samples=100, max_steps=60)
    # measured: 14953 from the random start, 49.8 optimised
    assert res.cond < 0.05 * res.cond_start
    _within(res, np.linspace(0.0, 10.0, 5001))


def test_identified_on_the_optimised_trajectory():
    arm = SerialRobot.from_mdh(
        [[0, 0, 0, 0], [0, 0.4, 0, 0]],
        inertias=[(3.0, [0.2, 0, 0], np.zeros(6)), (1.5, [0.15, 0.02, 0], [0.01, 0, 0, 0.01, 0, 0.01])],
        Fv=[1.0, 0.6],
        Fc=[0.5, 0.3],
        offset=[0.2, -0.1],
    )
    model = robot_model(arm)
    res = optimise_excitation(model, harmonics=3, samples=60, max_steps=40, q_limits=[[-2, 2], [-2, 2]])
    assert res.cond < res.cond_start
    _within(res, np.linspace(0.0, 10.0, 2001))
    t = np.arange(0.0, 20.0, 1e-3)
    q, dq, ddq = (np.asarray(v) for v in res.excitation.states(t))
    tau = np.asarray(arm.drive_torques(q, dq, ddq))
    logs = JointLogs(
        q=jnp.asarray(q), tau=jnp.asarray(tau), t=jnp.asarray(t), dt=1e-3, joints=(1, 2), source="sim", converted="none"
    )
    ident = robot_idim_ls(logs, model, preprocessing=dict(decimate=5, drop=200))
    np.testing.assert_allclose(np.asarray(ident.result.theta), model.nominal, rtol=2e-3, atol=2e-3)
