"""Output-error least squares through a simulator: forward-mode Jacobians, scaled Levenberg-Marquardt.

Shared by the plant families' identification by simulation
(`identify_emps_by_simulation`, `identify_robot_by_simulation`).
"""

import functools
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx


@functools.partial(jax.custom_jvp, nondiff_argnums=(0,))
def forward_jacobian_residual(residual, z, args):
    return residual(z, args)


@forward_jacobian_residual.defjvp
def _forward_jacobian_residual_jvp(residual, primals, tangents):
    # The JVP materialises the (N, p) Jacobian by forward mode in one pass
    # (p = a handful of parameters), instead of letting `jax.linearize` store
    # every intermediate of the 25,000-step scan. Tangents w.r.t. `args` (the
    # data) are ignored: the estimate is not differentiable w.r.t. the data.
    z, args = primals
    dz, _ = tangents
    f = lambda zz: (residual(zz, args),) * 2  # noqa: E731
    jac, r = jax.jacfwd(f, has_aux=True)(z)
    return r, jac @ dz


class _Objective(eqx.Module):
    residual: Callable = eqx.field(static=True)

    def __call__(self, z, args):
        return forward_jacobian_residual(self.residual, z, args)


class OutputError(eqx.Module):
    r"""How identification by simulation solves its output-error least squares (`identify_emps_by_simulation`,
    `identify_robot_by_simulation`): `solver` an optimistix least-squares solver (None:
    `optimistix.LevenbergMarquardt(rtol=1e-8, atol=1e-8)` on the parameters scaled by their start, with the
    Jacobian by forward mode through the simulator), `max_steps` and `throw` as `optimistix.least_squares`
    (None: the family's default, 100 steps for the EMPS, 50 for a robot; `throw=False`: a solve that did not
    converge is reported in the result, not raised).

    Example:
        >>> import optimistix as optx
        >>> from jaxsdp.plants import OutputError
        >>> OutputError(optx.LevenbergMarquardt(rtol=1e-6, atol=1e-6), max_steps=200).max_steps
        200
    """

    solver: optx.AbstractLeastSquaresSolver | None = None
    max_steps: int | None = eqx.field(static=True, default=None)
    throw: bool = eqx.field(static=True, default=False)

    def __check_init__(self):
        if self.solver is not None and not isinstance(self.solver, optx.AbstractLeastSquaresSolver):
            raise ValueError(f"`solver` must be an optimistix least-squares solver or None; got {self.solver!r}")
        steps = self.max_steps
        if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int) or steps < 1):
            raise ValueError(f"`max_steps` must be None or an integer >= 1; got {steps!r}")
        if not isinstance(self.throw, bool):
            raise ValueError(f"`throw` must be True or False; got {self.throw!r}")


def check_output_error(fit) -> "OutputError":
    """`fit` checked: an `OutputError` (ValueError naming `fit` otherwise)."""
    if not isinstance(fit, OutputError):
        raise ValueError(f"`fit` must be a jaxsdp.plants.OutputError; got {fit!r}")
    return fit


def solve_output_error(residual: Callable, z0, args: dict, *, solver, max_steps: int, throw: bool):
    """Levenberg-Marquardt on a scaled output-error residual `residual(z, args)`, normalised to cost 1 at `z0`.

    On entry `args["norm"]` holds ||y|| over the fitted samples (the residual
    divides by it); it is multiplied by the initial residual's norm so that
    the solver's tolerances are relative whatever the output's units. The
    Jacobian comes by forward mode (`forward_jacobian_residual`).

    **Returns:** (optimistix solution, the args used, relative error
    100 ||y_sim - y|| / ||y|| (%) at the solution, the same at `z0`).
    """
    ynorm = args["norm"]
    e0 = jnp.linalg.norm(residual(z0, args))
    args = dict(args, norm=ynorm * jnp.where(e0 > 0, e0, 1.0))
    solver = optx.LevenbergMarquardt(rtol=1e-8, atol=1e-8) if solver is None else solver
    sol = optx.least_squares(_Objective(residual), solver, z0, args, max_steps=max_steps, throw=throw)
    r0 = args["norm"] / ynorm  # relative error at z0, as a fraction
    rel = lambda z: 100 * r0 * jnp.linalg.norm(residual(z, args))  # noqa: E731
    return sol, args, rel(sol.value), rel(z0)
