"""Identification of a serial robot through its closed-loop simulator (output error, DIDIM with the torques).

Given the joint references `qr` that drove the experiment, the controller's
model (its gains and gravity feed-forward, fixed) and measured torques or
joint angles `y` (N, n), find the plant parameters theta (link inertial
parameters, actuator inertias, friction) minimising

    J(theta) = sum_{k >= skip} |y_sim(k; theta) - y(k)|^2 / sum_{k >= skip} |y(k)|^2,

`y_sim` from `simulate_robot(robot(theta), qr, controller_model=...)`. The
simulator is differentiable (semi-implicit steps, Coulomb friction
regularised by tanh(dq / eps)), so the gradient of J w.r.t. every parameter
comes exactly from reverse mode (`robot_output_error` under `jax.grad`), and
Levenberg-Marquardt (optimistix) uses the residual's Jacobian by forward mode.
"""

from collections.abc import Callable
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from ..._runtime import x64
from .._output_error import OutputError, check_output_error, solve_output_error
from ._serial import SerialRobot
from ._sim import simulate_robot

_OUTPUTS = ("torque", "position")


def default_robot_parameters(robot: SerialRobot) -> tuple:
    """The parameters estimated by default: every link's inertial parameters, actuator inertias, Fv and Fc.

    Example:
        >>> from jaxsdp.plants import tx40_robot
        >>> from jaxsdp.plants.robot._sim_ident import default_robot_parameters
        >>> [p.shape for p in default_robot_parameters(tx40_robot())]
        [(6, 10), (6,), (6,), (6,)]
    """
    return (robot.inertial, robot.Ia, robot.Fv, robot.Fc)


def _check(qr, y, n, *, finite: bool = True):
    qr = jnp.asarray(qr, dtype=jnp.float64)
    y = jnp.asarray(y, dtype=jnp.float64)
    if qr.ndim != 2 or qr.shape[1] != n or y.shape != qr.shape:
        raise ValueError(f"`qr` and `y` must both have shape (N, {n}); got {tuple(qr.shape)}, {tuple(y.shape)}")
    if finite and not (bool(jnp.all(jnp.isfinite(qr))) and bool(jnp.all(jnp.isfinite(y)))):
        raise ValueError("`qr` and `y` must be finite")
    return qr, y


def _output(sim, output):
    return sim.tau if output == "torque" else sim.q


@x64
def robot_output_error(
    robot: SerialRobot,
    qr,
    y,
    *,
    controller_model: SerialRobot,
    output: str = "torque",
    dt: float = 2e-4,
    skip: int = 0,
    **simulation,
) -> jax.Array:
    r"""Relative output error $J = \sum_k |y_{sim} - y|^2 / \sum_k |y|^2$ ($k \ge skip$) of a closed-loop simulation.

    Differentiable w.r.t. every field of `robot` (`eqx.filter_grad`, or
    `jax.grad` with the robot as the argument). `output`: "torque" (the
    drive torques, N m: DIDIM) or "position" (the joint angles, rad);
    `simulation`: further options of `simulate_robot` (`bandwidth_hz`,
    `substeps`, `eps`, `delay`, ...).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import simulate_robot, tx40_robot
        >>> from jaxsdp.plants import robot_output_error
        >>> robot = tx40_robot()
        >>> qr = np.outer(1 - np.cos(np.linspace(0, np.pi, 100)), np.full(6, 0.05))
        >>> tau = simulate_robot(robot, qr, dt=1e-3).tau
        >>> float(robot_output_error(robot, qr, tau, controller_model=robot, dt=1e-3))
        0.0
    """
    if output not in _OUTPUTS:
        raise ValueError(f"`output` must be one of {_OUTPUTS}; got {output!r}")
    qr, y = _check(qr, y, robot.n, finite=False)  # traceable: used under jit and grad
    w = (jnp.arange(y.shape[0]) >= skip)[:, None]
    sim = simulate_robot(robot, qr, dt=dt, controller_model=controller_model, **simulation)
    e = jnp.where(w, _output(sim, output) - y, 0.0)
    return jnp.sum(e**2) / jnp.sum(jnp.where(w, y, 0.0) ** 2)


class RobotSimIdentResult(NamedTuple):
    r"""Result of `identify_robot_by_simulation`.

    **Fields:** `robot` (the estimated `SerialRobot`), `estimates` (the
    estimated parameters, structured as `where` returns them; SI units),
    `relative_error` and `initial_relative_error` ($100 \sqrt{J}$, %, at the
    estimate and at the initial guess), `num_steps`, `result` (optimistix code).
    """

    robot: SerialRobot
    estimates: Any
    relative_error: jax.Array
    initial_relative_error: jax.Array
    num_steps: jax.Array
    result: Any


class _Residual(eqx.Module):
    where: Callable = eqx.field(static=True)
    unravel: Callable = eqx.field(static=True)
    output: str = eqx.field(static=True)
    options: tuple = eqx.field(static=True)

    def robot(self, z, args):
        return eqx.tree_at(self.where, args["robot0"], self.unravel(z * args["scale"]))

    def __call__(self, z, args):
        sim = simulate_robot(self.robot(z, args), args["qr"], controller_model=args["ctrl"], **dict(self.options))
        return (args["weight"] * (_output(sim, self.output) - args["y"]) / args["norm"]).ravel()


@x64
def identify_robot_by_simulation(
    qr,
    y,
    *,
    robot0: SerialRobot,
    controller_model: SerialRobot | None = None,
    output: str = "torque",
    where: Callable | None = None,
    dt: float = 2e-4,
    skip: int = 0,
    fit: OutputError = OutputError(),
    **simulation,
) -> RobotSimIdentResult:
    r"""Estimate a serial robot's parameters by fitting its closed-loop simulation to data (output error).

    $\hat\theta = \arg\min \sum_{k \ge skip} |y_{sim}(k; \theta) - y(k)|^2 / \sum |y(k)|^2$, `y_sim` simulated by
    `simulate_robot` driven by `qr` under the fixed controller of
    `controller_model` (default `robot0`); Levenberg-Marquardt on the
    parameters scaled by their initial magnitudes (1 where 0), the Jacobian
    by forward mode through the simulator. Parameters the data do not excite
    (the non-base combinations) are held near their initial values by the
    damping: compare base parameters, not raw ones.

    **Arguments:** `qr` (N, n) references (rad); `y` (N, n) measured drive
    torques (N m, `output="torque"`) or joint angles (rad, "position");
    `robot0` the initial guess; `where` selects the estimated fields
    (default `default_robot_parameters`: inertial, Ia, Fv, Fc); `dt`,
    `simulation` as `simulate_robot`; `skip` initial samples left out;
    `fit`: the solver, its step limit (default 50) and whether a failure raises (`OutputError`; default
    `optimistix.LevenbergMarquardt(rtol=1e-8, atol=1e-8)`, no raise).

    **Returns:** a `RobotSimIdentResult`.

    Example:
        >>> import numpy as np, equinox as eqx
        >>> from jaxsdp.plants import identify_robot_by_simulation, simulate_robot, tx40_robot
        >>> robot = tx40_robot()
        >>> qr = np.outer(np.sin(np.linspace(0, 2 * np.pi, 200)), np.full(6, 0.3))
        >>> tau = simulate_robot(robot, qr, dt=1e-3).tau
        >>> guess = eqx.tree_at(lambda r: r.Fv, robot, np.asarray(robot.Fv) * 1.3)
        >>> res = identify_robot_by_simulation(qr, tau, robot0=guess, controller_model=robot, dt=1e-3,
        ...                                    where=lambda r: r.Fv)
        >>> bool(np.allclose(res.estimates, robot.Fv, rtol=1e-6))
        True
    """
    fit = check_output_error(fit)
    if output not in _OUTPUTS:
        raise ValueError(f"`output` must be one of {_OUTPUTS}; got {output!r}")
    if not isinstance(robot0, SerialRobot):
        raise ValueError(f"`robot0` must be a SerialRobot; got {type(robot0).__name__}")
    qr, y = _check(qr, y, robot0.n)
    n = qr.shape[0]
    if not (isinstance(skip, int) and 0 <= skip < n):
        raise ValueError(f"`skip` must be an int in [0, {n}); got {skip!r}")
    ctrl = robot0 if controller_model is None else controller_model
    where = default_robot_parameters if where is None else where
    theta0, unravel = ravel_pytree(jax.tree_util.tree_map(lambda x: jnp.asarray(x, jnp.float64), where(robot0)))
    scale = jnp.where(jnp.abs(theta0) > 0, jnp.abs(theta0), 1.0)
    residual = _Residual(where, unravel, output, tuple(sorted((simulation | {"dt": float(dt)}).items())))
    weight = (jnp.arange(n) >= skip).astype(jnp.float64)[:, None]
    args = dict(robot0=robot0, ctrl=ctrl, qr=qr, y=y, scale=scale, weight=weight, norm=jnp.linalg.norm(weight * y))
    z0 = theta0 / scale
    sol, args, rel, rel0 = solve_output_error(
        residual, z0, args, solver=fit.solver, max_steps=fit.max_steps or 50, throw=fit.throw
    )
    return RobotSimIdentResult(
        robot=residual.robot(sol.value, args),
        estimates=unravel(sol.value * scale),
        relative_error=rel,
        initial_relative_error=rel0,
        num_steps=sol.stats["num_steps"],
        result=sol.result,
    )
