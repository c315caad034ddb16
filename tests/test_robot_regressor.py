"""The robot regressor by the Newton-Euler recursion written for it (issue 46, item 1), against the derivative of
the Newton-Euler torques (the reference it replaced), under jit, vmap and grad; pinocchio's is in test_urdf.py."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import two_link_arm
from jaxsdp.data import Drives
from jaxsdp.plants import SerialRobot, tx40_robot
from jaxsdp.plants.robot import robot_model
from jaxsdp.plants.robot._joint import drive_matrix, stacked_rows
from jaxsdp.plants.robot._regressor import regressor_rows

jax.config.update("jax_enable_x64", True)


def differentiated(robot, q, dq, ddq):
    """(N, n, 10 n): d tau / d theta by forward-mode differentiation of `SerialRobot._rnea` (the reference)."""
    n = robot.n

    def one(a, b, c):
        return jax.jacfwd(lambda th: robot._rnea(th.reshape(n, 10), a, b, c, robot.g))(robot.inertial.ravel())

    return jax.jit(jax.vmap(one))(*(jnp.asarray(x) for x in (q, dq, ddq)))


def chain(n: int, *, seed: int, prismatic=()):
    """A random n-joint chain (modified DH; the joints in `prismatic` slide), random links and drives."""
    rng = np.random.default_rng(seed)
    table = np.column_stack(
        [
            rng.choice([0, np.pi / 2, -np.pi / 2], n),
            rng.uniform(0, 0.4, n),
            rng.uniform(-1, 1, n),
            rng.uniform(0, 0.3, n),
        ]
    )
    links = [(rng.uniform(0.5, 5), rng.uniform(-0.2, 0.2, 3), np.diag(rng.uniform(0.01, 0.1, 3))) for _ in range(n)]
    return SerialRobot.from_mdh(
        table, inertias=links, Ia=0.1, Fv=0.5, Fc=0.3, offset=0.1, prismatic=[j in prismatic for j in range(n)]
    )


def states(n, N, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2, 2, (N, n)), rng.normal(size=(N, n)), rng.normal(size=(N, n)) * 3


@pytest.mark.parametrize(
    "robot",
    [tx40_robot(), two_link_arm(), chain(12, seed=0), chain(5, seed=1, prismatic=(0, 3))],
    ids=["tx40", "two-link", "12-joint", "prismatic"],
)
def test_equals_the_derivative_of_the_torques(robot):
    q, dq, ddq = states(robot.n, 64, 0)
    ref = np.asarray(differentiated(robot, q, dq, ddq))
    Y = np.asarray(robot.regressor(q, dq, ddq))
    assert Y.dtype == np.float64 and Y.shape == ref.shape
    np.testing.assert_allclose(Y, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    if robot.n <= 6:  # one joint's row, the batch axes kept (another program: its compile is left to small robots)
        j = robot.n // 2 + 1
        three = [x[:8].reshape(2, 4, -1) for x in (q, dq, ddq)]
        row = robot.regressor(*three, joint=j)
        np.testing.assert_allclose(row, ref[:8, j - 1].reshape(2, 4, -1), rtol=0, atol=1e-12 * np.abs(ref).max())
    # torques of the robot's own parameters
    np.testing.assert_allclose(Y @ np.asarray(robot.inertial).ravel(), robot.inverse_dynamics(q, dq, ddq), atol=1e-9)


def test_stacked_rows_with_coupled_drives_and_chosen_columns():
    """The TX40's coupled wrist (motor 6 turns with q5 + q6): every column of the stacked model as the derivative
    plus the drive columns G_jk [ddu_k, du_k, sign du_k] and the offsets; and a choice of rows and columns."""
    robot = tx40_robot()
    C = Drives.builtin("tx40").transmission
    Cinv, G = drive_matrix(6, C)
    q, dq, ddq = states(6, 50, 1)
    W = np.asarray(stacked_rows(robot, q, dq, ddq, Cinv, G, tuple(range(6))))
    du, ddu = dq @ Cinv.T, ddq @ Cinv.T
    motor = np.stack([ddu, du, np.sign(du)], axis=-1).reshape(50, 18)
    drive = np.repeat(G, 3, axis=1)[None] * motor[:, None, :]
    ref = np.concatenate([differentiated(robot, q, dq, ddq), drive, np.broadcast_to(np.eye(6), (50, 6, 6))], -1)
    np.testing.assert_allclose(W, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    rows, cols = (1, 4, 5), (3, 17, 40, 59, 61, 70, 75, 80, 83)
    sub = np.asarray(stacked_rows(robot, q, dq, ddq, Cinv, G, rows, cols))
    np.testing.assert_array_equal(sub, W[:, rows][:, :, cols])
    # G given as a JAX array: no structure known, the same result
    np.testing.assert_allclose(
        stacked_rows(robot, q, dq, ddq, jnp.asarray(Cinv), jnp.asarray(G), rows, cols), sub, rtol=0, atol=1e-14
    )


def test_gradient_in_the_states_matches_finite_differences():
    """Reverse mode through the regressor (the excitation optimiser's cost) against central differences, jitted,
    and forward mode against reverse."""
    model = robot_model(tx40_robot(), transmission=Drives.builtin("tx40").transmission)
    q, dq, ddq = states(6, 20, 2)
    w = np.random.default_rng(3).normal(size=(20, 6, model.rank))

    def f(x):
        return jnp.sum(jnp.sin(model.regressor(x, dq, ddq)) * w)

    g = np.asarray(jax.jit(jax.grad(f))(jnp.asarray(q)))
    # forward mode gives the same directional derivative as reverse mode
    direction = np.random.default_rng(4).normal(size=q.shape)
    forward = jax.jit(lambda x, d: jax.jvp(f, (x,), (d,))[1])(jnp.asarray(q), jnp.asarray(direction))
    assert abs(float(forward) - float(np.sum(g * direction))) < 1e-9 * max(1.0, abs(float(forward)))
    h = 1e-6
    for i, j in [(0, 0), (3, 2), (7, 4), (19, 5)]:
        e = np.zeros_like(q)
        e[i, j] = h
        fd = (float(f(q + e)) - float(f(q - e))) / (2 * h)
        assert abs(g[i, j] - fd) < 1e-6 * max(1.0, abs(fd))

    # in the kinematics too (a link length), against the derivative of the differentiated reference
    def by_length(d, fn):
        r = eqx.tree_at(lambda r: r.translation, model.robot, model.robot.translation.at[2, 0].set(d))
        return jnp.sum(jnp.sin(fn(r)) * w[:, :, :1])

    fast = lambda r: regressor_rows(r, q, dq, ddq, np.eye(6), np.eye(6), tuple(range(6)), (25,), ((True,) * 6,) * 6)
    ref = jax.jit(lambda r: differentiated(r, q, dq, ddq)[:, :, 25:26])
    d0 = float(model.robot.translation[2, 0])
    ga = float(jax.jit(jax.grad(lambda d: by_length(d, fast)))(d0))
    fd = (float(by_length(d0 + h, ref)) - float(by_length(d0 - h, ref))) / (2 * h)
    assert abs(ga - fd) < 1e-6 * max(1.0, abs(fd))


def test_vmapped_over_robots_and_not_finite_states():
    """A batch of robots (drawn link lengths, as the Monte Carlo studies draw them) row by row, and a state that is
    not finite gives its own rows not finite, the others unchanged."""
    base = two_link_arm()
    lengths = jnp.asarray([0.3, 0.4, 0.55])
    robots = jax.vmap(lambda d: eqx.tree_at(lambda r: r.translation, base, base.translation.at[1, 0].set(d)))(lengths)
    q, dq, ddq = states(2, 10, 4)
    eye = np.eye(2)
    felt = ((True, False), (False, True))

    def rows(r):
        return regressor_rows(r, q, dq, ddq, eye, eye, (0, 1), tuple(range(20)), felt)

    Y = np.asarray(jax.vmap(rows)(robots))
    for k, d in enumerate(np.asarray(lengths)):
        r = eqx.tree_at(lambda r: r.translation, base, base.translation.at[1, 0].set(d))
        np.testing.assert_allclose(Y[k], differentiated(r, q, dq, ddq), rtol=0, atol=1e-12)
    q[3, 1] = np.nan
    Z = np.asarray(base.regressor(q, dq, ddq))
    assert np.isnan(Z[3]).any() and not np.isinf(Z).any()
    kept = np.asarray(base.regressor(*(np.delete(x, 3, axis=0) for x in (q, dq, ddq))))
    np.testing.assert_array_equal(np.delete(Z, 3, axis=0), kept)
