"""Identification of the EMPS through its closed-loop simulator (output/input error).

Given the reference `qg` that drove the experiment and a measured signal `y`
(the drive force `gtau * vir` or the position `qm`), find the plant parameters
`theta` (mass and friction coefficients) minimising

    sum_k ( y_sim(k; theta) - y(k) )^2 / sum_k y(k)^2,     k >= skip,

where `y_sim` is produced by `jaxsdp.plants.simulate_emps` driven by
`qg` with the benchmark controller. With the force as output this is the
DIDIM approach of Gautier, Janot & Vandanjon (direct and inverse dynamic
identification). The residual is differentiated exactly through the
simulator (forward-mode Jacobian through the `lax.scan`), and minimised with
an optimistix least-squares solver (Levenberg-Marquardt by default) on the
parameters scaled by their initial values.
"""

from collections.abc import Callable
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from ..._checks import FINITE_ARRAY
from ..._runtime import x64
from .._friction import AsymmetricFriction, LinearFriction, TabulatedFriction
from .._output_error import OutputError, check_output_error, solve_output_error
from .._parameters import check_parameters, to64
from .._sampling import sampled_signal, time_grid
from ._plant import EMPSController, EMPSInitial, EMPSPlant, check_initial, simulate_closed_loop


class SimIdentResult(NamedTuple):
    """Result of `identify_emps_by_simulation`.

    **Fields:**

    - `plant`: the estimated `EMPSPlant`;
    - `estimates`: the estimated parameters as a tuple (order of `where`; SI
      units: M kg, Fv N/(m/s), Fc and offset N);
    - `relative_error`: `100 ||y - y_sim|| / ||y||` (%) at the estimate;
    - `initial_relative_error`: the same at the initial guess;
    - `num_steps`: solver steps; `result`: `optimistix.RESULTS` code.
    """

    plant: EMPSPlant
    estimates: tuple
    relative_error: jax.Array
    initial_relative_error: jax.Array
    num_steps: jax.Array
    result: Any


def _linear_params(p):
    return (p.M, p.friction.Fv, p.friction.Fc, p.friction.offset)


def _asymmetric_params(p):
    return (p.M, p.friction.Fv_pos, p.friction.Fc_pos, p.friction.Fv_neg, p.friction.Fc_neg)


def _tabulated_params(p):
    return (p.M, p.friction.f_grid)


@x64
def default_parameters(plant: EMPSPlant) -> Callable:
    """The parameters estimated by default, as an `eqx.tree_at`-style `where`.

    Linear friction: `(M, Fv, Fc, offset)`. Asymmetric friction:
    `(M, Fv_pos, Fc_pos, Fv_neg, Fc_neg)` (no offset, which is collinear with
    `Fc_pos` and `Fc_neg`). Tabulated friction: `(M, f_grid)`. Units: kg,
    N/(m/s), N.

    **Returns:** a function `plant -> tuple of parameter arrays`.

    Example:
        >>> from jaxsdp.plants import EMPSPlant, default_parameters
        >>> where = default_parameters(EMPSPlant())
        >>> tuple(round(float(v), 4) for v in where(EMPSPlant()))  # M, Fv, Fc, offset
        (95.1089, 203.5034, 20.3935, -3.1648)
    """
    fr = plant.friction
    if isinstance(fr, LinearFriction):
        return _linear_params
    if isinstance(fr, AsymmetricFriction):
        return _asymmetric_params
    if isinstance(fr, TabulatedFriction):
        return _tabulated_params
    raise ValueError(f"no default parameter set for {type(fr).__name__}; pass `where`")


class _Residual(eqx.Module):
    """Scaled output error `(y_sim - y) / norm`, as a function of scaled parameters."""

    where: Callable = eqx.field(static=True)
    unravel: Callable = eqx.field(static=True)

    def plant(self, z, args):
        theta = self.unravel(z * args["scale"])
        return eqx.tree_at(self.where, args["plant0"], theta)

    def __call__(self, z, args):
        a = args
        sim = simulate_closed_loop(
            a["qg"],
            a["t"],
            a["dt"],
            self.plant(z, a),
            a["controller"],
            a["q0"],
            a["dq0"],
            a["vir0"],
            jnp.zeros_like(a["qg"]),
            jnp.zeros(()),
            1,
        )
        # Traced selector: force and position fits share one compilation.
        y_sim = jnp.where(a["use_force"], sim.force, sim.q)
        # Samples before `skip` are weighted out (a traced mask: no recompilation).
        return a["weight"] * (y_sim - a["y"]) / a["norm"]


@x64
def identify_emps_by_simulation(
    qg,
    y,
    *,
    plant0: EMPSPlant,
    controller: EMPSController | None = None,
    output: str = "force",
    where: Callable | None = None,
    dt=1e-3,
    t=None,
    initial: EMPSInitial | None = None,
    skip: int = 49,
    fit: OutputError = OutputError(),
) -> SimIdentResult:
    r"""Estimate EMPS plant parameters by fitting the closed-loop simulation to data.

    Output-error (DIDIM with the force) least squares:

    $$ \hat\theta = \arg\min_\theta \sum_{k \ge skip} (y_{sim}(k; \theta) - y(k))^2 / \sum_{k \ge skip} y(k)^2, $$

    `y_sim` simulated by `simulate_emps` driven by `qg` with `controller`;
    Levenberg-Marquardt on the parameters scaled by their initial values,
    with the Jacobian by forward mode through the simulator.

    **Arguments:**

    - `qg`: reference position (m) `(N,)` that drove the experiment.
    - `y`: measured output `(N,)`: the force `gtau * vir` (N) if
      `output="force"`, the position `qm` (m) if `output="position"`.
    - `plant0`: initial guess (`EMPSPlant`); its friction type selects the model.
    - `controller`: the benchmark controller (default gains).
    - `where`: selects the estimated parameters (default `default_parameters`);
      the others stay at their `plant0` values.
    - `dt`, `t`, `initial`: as in `simulate_emps` (`EMPSInitial`).
    - `skip`: number of initial samples left out of the cost.
    - `fit`: the solver, its step limit (default 100) and whether a failure raises (`OutputError`; default
      `LevenbergMarquardt(rtol=1e-8, atol=1e-8)`, no raise).

    **Returns:** a `SimIdentResult`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import (EMPSPlant, LinearFriction, bang_bang_reference,
        ...     identify_emps_by_simulation, simulate_emps)
        >>> t = np.arange(400) * 1e-3
        >>> ref = bang_bang_reference(t, velocities=[0.1, -0.1], switch_times=[0.02, 0.2], accel=2.0)
        >>> force = simulate_emps(ref.q).force  # data from the default plant, N
        >>> guess = EMPSPlant(90.0, LinearFriction(180.0, 15.0, 0.0))
        >>> res = identify_emps_by_simulation(ref.q, force, plant0=guess, skip=10)
        >>> [round(float(v), 2) for v in res.estimates]  # M, Fv, Fc, offset
        [95.11, 203.5, 20.39, -3.16]
    """
    fit = check_output_error(fit)
    if output not in ("force", "position"):
        raise ValueError(f"`output` must be 'force' or 'position'; got {output!r}")
    if not isinstance(plant0, EMPSPlant):
        raise ValueError(f"`plant0` must be an EMPSPlant; got {type(plant0).__name__}")
    controller = EMPSController() if controller is None else controller
    qg = sampled_signal("qg", qg)
    n = qg.shape[0]
    y = sampled_signal("y", y, n)
    if not (isinstance(skip, int) and 0 <= skip < n):
        raise ValueError(f"`skip` must be an int in [0, {n}); got {skip!r}")
    t, dt, cons = time_grid("qg", n, t, dt)
    cons += plant0.constraints() + controller.constraints() + [("qg", qg, FINITE_ARRAY), ("y", y, FINITE_ARRAY)]
    qg = check_parameters(qg, cons)
    plant0, controller = to64(plant0), to64(controller)
    where = default_parameters(plant0) if where is None else where
    theta0 = tuple(jnp.asarray(x, dtype=jnp.float64) for x in where(plant0))
    theta0_flat, unravel = ravel_pytree(theta0)
    scale = jnp.where(jnp.abs(theta0_flat) > 0, jnp.abs(theta0_flat), 1.0)
    residual = _Residual(where, unravel)
    q0, dq0, vir0 = check_initial(initial)._values(qg)
    args = dict(
        qg=qg,
        t=t,
        dt=jnp.asarray(dt, dtype=jnp.float64),
        plant0=plant0,
        controller=controller,
        q0=q0,
        dq0=dq0,
        vir0=vir0,
        y=y,
        use_force=jnp.asarray(output == "force"),
        scale=scale,
        norm=jnp.linalg.norm(y[skip:]),
        weight=(jnp.arange(n) >= skip).astype(jnp.float64),
    )
    z0 = theta0_flat / scale  # the guess itself (+-1 per parameter; a negative one stays negative)
    sol, args, rel, rel0 = solve_output_error(
        residual, z0, args, solver=fit.solver, max_steps=fit.max_steps or 100, throw=fit.throw
    )
    return SimIdentResult(
        plant=residual.plant(sol.value, args),
        estimates=unravel(sol.value * scale),
        relative_error=rel,
        initial_relative_error=rel0,
        num_steps=sol.stats["num_steps"],
        result=sol.result,
    )
