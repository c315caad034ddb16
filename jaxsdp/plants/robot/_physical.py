r"""Physically consistent robot parameters: each link's pseudo-inertia positive definite.

A link's standard parameters $\pi = [I_{xx}, I_{xy}, I_{xz}, I_{yy}, I_{yz}, I_{zz}, h_x, h_y, h_z, m]$
(the inertia $I$ about the link frame's origin, the first moment $h = m c$, the mass) describe a rigid
body, a non-negative mass density, if and only if its pseudo-inertia

$$ P = \begin{bmatrix} \Sigma & h \\ h^T & m \end{bmatrix}, \qquad \Sigma = \tfrac12 \mathrm{tr}(I)\,1 - I $$

($\Sigma = \int r r^T \rho\,dV$) is positive semidefinite (Wensing, Kim and Slotine, 2017): positive mass,
inertia about the centre of mass positive definite, its principal moments satisfying the triangle
inequalities. $P$ is linear in $\pi$ (ten entries for ten parameters), so the physical robots are a convex
set, and every positive definite $P$ is once $P = UU^T$ with (Rucker and Wensing, 2022)

$$ U = e^{\alpha} \begin{bmatrix} e^{d_1} & s_{12} & s_{13} & t_1 \\ 0 & e^{d_2} & s_{23} & t_2 \\
0 & 0 & e^{d_3} & t_3 \\ 0 & 0 & 0 & 1 \end{bmatrix}, $$

ten unconstrained log-Cholesky coordinates $z = (\alpha, d_1, d_2, d_3, s_{12}, s_{23}, s_{13}, t_1, t_2,
t_3)$ ($m = e^{2\alpha}$, $c = t$ in metres; `log_cholesky_to_standard`, `standard_to_log_cholesky`).

**The estimate** (`physical_estimate`): the physical robot nearest to an unconstrained base-parameter
estimate $\hat\beta$ (IDIM-LS or IDIM-IV) in its covariance $C = LL^T$, regularised toward the
description's bodies $P_{0,k}$ by their log-det (Bregman, "entropic") divergence with a stated weight $w$:

$$ \min_\theta \tfrac12 \|L^{-1}(B\theta - \hat\beta)\|^2 + w \Big[\sum_k \big(\mathrm{tr}(P_{0,k}^{-1} P_k)
- \log\det(P_{0,k}^{-1} P_k) - 4\big) + \sum_i \big(\tfrac{x_i}{x_{0,i}} - \log\tfrac{x_i}{x_{0,i}} - 1\big) +
\tfrac12 \sum_j o_j^2 \Big], $$

$B$ the base map ($\beta = B\theta$, `robot_model`), $x$ the motor inertias and friction coefficients
($\geq 0$), $o$ the offsets (N m). The divergence is invariant to the units and the frame, zero at the
description, and infinite on the boundary of the physical set: with $w > 0$ the minimiser is a body with
$P \succ 0$. The problem is convex in $\theta$ (the data term quadratic, $-\log\det$ convex): one minimiser.
With the iid covariance of IDIM-LS the data term is the least squares on the rows themselves.

**Solved** in the log-Cholesky coordinates (the drives by their logarithms), where the boundary is at infinity
and $\log\det P = 8\alpha + 2(d_1 + d_2 + d_3)$ is linear: near the edge of the physical set, where real
estimates end up (thin links), Newton's method in $\theta$ lost its digits (Hessian eigenvalues of $-10^9$ for a
convex cost), the coordinates keep them. The minimiser is optimistix's BFGS along the path of weights $w_0 = 1,
w_0/10, \ldots, w$, each stage from the previous one's minimiser (`PhysicalSolver`, an interior-point path). Measured
(`benchmarks/physical.py`, TX40, 84 parameters, simulated and real estimates): the same cost to 7 digits as a
path-following Newton written for it, as fast or faster; started at the final weight, BFGS gets there too at the
default weight but stopped short at 1e-4 on the real TX40's estimate, which the path reaches. Checked against
the same convex problem in $\theta$ solved by a conic interior point (cvxpy, Clarabel) in the tests.

**Standard errors** by the delta method, the sensitivity of the minimiser to $\hat\beta$ (implicit function
theorem): $\mathrm{cov}\,\theta = J H^{-1} G^T G H^{-1} J^T$, $G = L^{-1} B J$, $J = \partial\theta/\partial z$, $H$
the Hessian in $z$ at the minimiser (eigen-solves, no inverse). Derivatives of the estimate by `jax.grad` go
through the minimiser the same way (optimistix's implicit adjoint).
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
import optimistix as optx
from jaxtyping import Array, Bool, Float, Int

from ..._runtime import x64
from ._stacked import RobotModel, full_parameters, with_full_parameters

__all__ = ["PhysicalEstimate", "PhysicalSolver", "physical_estimate", "pseudo_inertia"]

#: The default weight of the divergence from the description (in units of the data term's chi-square).
PRIOR_WEIGHT = 1e-3
#: Where the unconstrained estimate counts as not physical: a base parameter moved by more standard errors.
SHIFT_LIMIT = 3.0
#: Smallest eigenvalue given to a description's pseudo-inertia that is not positive definite (SI units).
PSD_FLOOR = 1e-6
#: A link whose pseudo-inertia's smallest eigenvalue is below this fraction of its largest sits on the edge
#: of the physical set: a degenerate body (a rod, a plate), which the constraint holds there.
EDGE = 1e-6


@x64
def pseudo_inertia(standard) -> jax.Array:
    r"""The pseudo-inertia $P$ (..., 4, 4) of standard parameters `standard` (..., 10)
    `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` (kg m^2, kg m, kg): physical if and only if $P \succeq 0$.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import link_parameters
        >>> from jaxsdp.plants.robot import pseudo_inertia
        >>> rod = link_parameters(2.0, [0.5, 0.0, 0.0], [1e-3, 0, 0, 0.05, 0, 0.05])
        >>> bool(np.linalg.eigvalsh(pseudo_inertia(rod)).min() > 0)
        True
        >>> bool(np.linalg.eigvalsh(pseudo_inertia(rod * [1, 1, 1, 1, 1, 1, 1, 1, 1, -1])).min() > 0)
        False
    """
    pi = jnp.asarray(standard, dtype=jnp.float64)
    if pi.shape[-1:] != (10,):
        raise ValueError(f"`standard` must have 10 entries on its last axis; got shape {pi.shape}")
    return _pseudo(pi)


def _pseudo(pi):
    xx, xy, xz, yy, yz, zz, hx, hy, hz, m = (pi[..., k] for k in range(10))
    inertia = jnp.stack([jnp.stack([xx, xy, xz], -1), jnp.stack([xy, yy, yz], -1), jnp.stack([xz, yz, zz], -1)], -2)
    tr = xx + yy + zz
    sigma = 0.5 * tr[..., None, None] * jnp.eye(3) - inertia
    h = jnp.stack([hx, hy, hz], -1)
    top = jnp.concatenate([sigma, h[..., :, None]], -1)
    bottom = jnp.concatenate([h, m[..., None]], -1)[..., None, :]
    return jnp.concatenate([top, bottom], -2)


def _standard_of(P):
    """Standard parameters (..., 10) of pseudo-inertias (..., 4, 4)."""
    sigma, h, m = P[..., :3, :3], P[..., :3, 3], P[..., 3, 3]
    inertia = jnp.trace(sigma, axis1=-2, axis2=-1)[..., None, None] * jnp.eye(3) - sigma
    return jnp.stack(
        [inertia[..., 0, 0], inertia[..., 0, 1], inertia[..., 0, 2], inertia[..., 1, 1], inertia[..., 1, 2],
         inertia[..., 2, 2], h[..., 0], h[..., 1], h[..., 2], m],
        -1,
    )  # fmt: skip


@x64
def log_cholesky_to_standard(z) -> jax.Array:
    """Standard parameters (..., 10) of log-Cholesky coordinates `z` (..., 10) (`_physical`'s module docstring):
    every `z` gives a physical body."""
    U = _factor(jnp.asarray(z, dtype=jnp.float64))
    return _standard_of(U @ jnp.swapaxes(U, -1, -2))


def _log_cholesky(P):
    """Log-Cholesky coordinates (..., 10) of positive definite pseudo-inertias (..., 4, 4)."""
    flip = jnp.eye(4)[::-1]
    U = flip @ jnp.linalg.cholesky(flip @ P @ flip) @ flip  # upper triangular, U U^T = P
    u = U / U[..., 3:4, 3:4]
    return jnp.stack(
        [jnp.log(U[..., 3, 3]), jnp.log(u[..., 0, 0]), jnp.log(u[..., 1, 1]), jnp.log(u[..., 2, 2]), u[..., 0, 1],
         u[..., 1, 2], u[..., 0, 2], u[..., 0, 3], u[..., 1, 3], u[..., 2, 3]],
        -1,
    )  # fmt: skip


@x64
def standard_to_log_cholesky(standard) -> jax.Array:
    """Log-Cholesky coordinates (..., 10) of physical standard parameters `standard` (..., 10); NaN where the
    pseudo-inertia is not positive definite."""
    return _log_cholesky(_pseudo(jnp.asarray(standard, dtype=jnp.float64)))


class PhysicalSolver(eqx.Module):
    """How `physical_estimate` minimises: an optimistix minimiser along a path of weights.

    **Fields:** `minimiser` (an `optimistix` minimiser; `optx.BFGS(rtol=1e-10, atol=1e-10)`), `max_steps` (its steps
    per weight; 20,000), `tol` (the estimate has converged when the minimiser met its own tolerances or the cost
    cannot fall by more than `tol` to second order, half the squared Newton decrement at the last point; 1e-5, in
    the data term's chi-square units), `start_weight` (the first weight of the path; 1.0), `factor` (the weight's
    decrease per stage; 10). Each stage starts from the previous one's minimiser: a large weight first keeps the
    estimate near the description, deep inside the physical set, and each smaller one moves it a little (an
    interior-point path); started at the final weight, BFGS stopped short of the minimum at a weight of 1e-4 on
    the real TX40's estimate.
    """

    minimiser: optx.AbstractMinimiser = optx.BFGS(rtol=1e-10, atol=1e-10)
    max_steps: int = eqx.field(static=True, default=20_000)
    tol: float = eqx.field(static=True, default=1e-5)
    start_weight: float = eqx.field(static=True, default=1.0)
    factor: float = eqx.field(static=True, default=10.0)

    def __check_init__(self):
        if not isinstance(self.minimiser, optx.AbstractMinimiser):
            raise ValueError(f"`PhysicalSolver`: `minimiser` must be an optimistix minimiser; got {self.minimiser!r}")
        if not (self.start_weight > 0 and self.factor > 1 and self.tol > 0):
            raise ValueError("`PhysicalSolver`: `start_weight` and `tol` must be > 0 and `factor` > 1")
        if not isinstance(self.max_steps, int) or self.max_steps < 1:
            raise ValueError(f"`PhysicalSolver`: `max_steps` must be an int >= 1; got {self.max_steps!r}")

    @x64
    def weights(self, weight: float) -> tuple:
        """The path of weights from `start_weight` down to `weight`."""
        if weight >= self.start_weight:
            return (float(weight),)
        k = math.ceil(math.log(self.start_weight / weight) / math.log(self.factor) - 1e-9)
        return tuple(max(weight, self.start_weight / self.factor**i) for i in range(k + 1))


class PhysicalEstimate(eqx.Module):
    r"""The physically consistent estimate of a robot (`physical_estimate`).

    **Fields:** `theta` (14 n,) the full parameters in `names` order (`robot_model`'s `full_names`: each link's 10
    standard parameters, then `Ia, Fv, Fc` per motor, then the offsets; SI units), `std` and `cov` their standard
    errors and covariance (the delta method: the spread the data give; a parameter the data do not see has a
    standard error near 0, its value is the description's: see `source`); `base` (rank,) the base parameters
    $B\theta$ (in `base_names` order), `base_std`, `base_cov`; `unconstrained` (rank,) $\hat\beta$ and
    `unconstrained_std`; `shift` (rank,) $(B\theta - \hat\beta) / std(\hat\beta)$, what consistency moved each base
    parameter in its standard errors; `distance` $\|L^{-1}(B\theta - \hat\beta)\|$; `z` (n, 10) each link's
    log-Cholesky coordinates; `edge` (n,) the smallest eigenvalue of each link's pseudo-inertia over its largest
    (near 0: a degenerate body the constraint holds on the edge); `steps` the minimiser's steps (all stages),
    `converged` (the last stage met the minimiser's tolerances or `decrement`, what the cost can still fall by to
    second order, is below the solver's `tol`); `names`, `base_names`; `source` (per full parameter): "data" (a
    combination of the base parameters: identified), "combined" (enters the base parameters only with others: the
    data fix the combination, the divergence splits it) or "prior" (in no base parameter: the description's value);
    `prior_weight`; `lifted` the links whose description is not a body (a singular or indefinite pseudo-inertia),
    replaced in the divergence by the nearest one.
    """

    theta: Float[Array, " p"]
    std: Float[Array, " p"]
    cov: Float[Array, "p p"]
    base: Float[Array, " r"]
    base_std: Float[Array, " r"]
    base_cov: Float[Array, "r r"]
    unconstrained: Float[Array, " r"]
    unconstrained_std: Float[Array, " r"]
    shift: Float[Array, " r"]
    distance: Float[Array, ""]
    z: Float[Array, "n 10"]
    edge: Float[Array, " n"]
    steps: Int[Array, ""]
    converged: Bool[Array, ""]
    decrement: Float[Array, ""]
    names: tuple = eqx.field(static=True)
    base_names: tuple = eqx.field(static=True)
    source: tuple = eqx.field(static=True)
    prior_weight: float = eqx.field(static=True)
    lifted: tuple = eqx.field(static=True, default=())

    @x64
    def links(self) -> np.ndarray:
        """(n, 10) each link's standard parameters `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` about its frame."""
        n = len(self.names) // 14
        return np.asarray(self.theta[: 10 * n]).reshape(n, 10)

    @x64
    def robot(self, robot):
        """`robot` (the model's `SerialRobot`) with these inertial parameters, motor inertias, friction and
        offsets: a robot to simulate."""
        n = robot.n
        if len(self.names) != 14 * n:
            raise ValueError(f"`robot` has {n} joints; this estimate is of {len(self.names) // 14}")
        return with_full_parameters(robot, self.theta)

    @x64
    def relative_error(self, res) -> dict:
        """Each joint's relative error (%) of the physical base parameters on the rows `res` (a `RobotIDIM` of
        the same model) used: $100 \\|y_j - X_j B\\theta\\| / \\|y_j\\|$ over its rows in motion."""
        y, X, moving = np.asarray(res.y), np.asarray(res.X), np.asarray(res.moving)
        if X.shape[-1] != len(self.base_names):
            raise ValueError(f"`res` has {X.shape[-1]} base parameters; this estimate {len(self.base_names)}")
        fit = X @ np.asarray(self.base)
        out = {}
        for i, j in enumerate(res.model.rows):
            k = moving[:, i]
            ny = float(np.linalg.norm(y[k, i]))
            out[j] = 100 * float(np.linalg.norm(y[k, i] - fit[k, i])) / ny if ny > 0 else math.nan
        return out

    @x64
    def warnings(self, limit: float = SHIFT_LIMIT, *, inflation: float = 1.0) -> tuple:
        """One-line messages: the solver did not converge; the unconstrained estimate is not a physical robot (a
        base parameter moved by more than `limit` of its standard errors, those multiplied by `inflation` first:
        the factor a serially correlated residual makes them too small by, `sd_inflation`)."""
        out = []
        if not bool(self.converged):
            out.append(f"the physically consistent estimate did not converge ({int(self.steps)} steps)")
        shift = np.abs(np.asarray(self.shift)) / max(float(inflation), 1.0)
        if shift.size and float(shift.max()) > limit:
            k = int(np.argmax(shift))
            scaled = f", standard errors x{inflation:.2g} for the residual's correlation" if inflation > 1 else ""
            out.append(
                f"the unconstrained estimate is not a physical robot: consistency moves {self.base_names[k]} by "
                f"{shift[k]:.1f} standard errors (distance {float(self.distance):.1f}{scaled}); the model misses "
                "something (friction's shape, a flexible joint, units) or the data do not excite it"
            )
        return tuple(out)

    @x64
    def notes(self) -> tuple:
        """One-line facts to read the estimate by: links held on the edge of the physical set (degenerate bodies),
        links whose description is not a body."""
        out = []
        edge = [k + 1 for k, e in enumerate(np.asarray(self.edge)) if e < EDGE]
        if edge:
            out.append(
                f"The physically consistent estimate holds link(s) {edge} on the edge of the physical set (a "
                "degenerate body: rod, plate, point): the data pull them beyond what a body can be, and their "
                "inertia there is the description's direction, not a measurement."
            )
        if self.lifted:
            out.append(
                f"The description's link(s) {list(self.lifted)} are not physical bodies (pseudo-inertia singular or "
                "indefinite: a massless link, a rod without thickness); the physically consistent estimate's "
                "divergence uses the nearest body."
            )
        return tuple(out)


class _Problem(eqx.Module):
    """The arrays of one robot's problem (`physical_estimate`): the base map, the description's bodies (their
    pseudo-inertias' Cholesky factors), the drives' centres, the start (full parameters)."""

    B: jax.Array
    P0_chol: jax.Array
    x0: jax.Array
    start: jax.Array
    n: int = eqx.field(static=True)

    def theta(self, z):
        """The full parameters of the coordinates z: each link's 10 log-Cholesky ones, the drives' logs, the
        offsets."""
        n = self.n
        U = _factor(z[: 10 * n].reshape(n, 10))
        links = _standard_of(U @ jnp.swapaxes(U, -1, -2))
        return jnp.concatenate([links.reshape(-1), jnp.exp(z[10 * n : 13 * n]), z[13 * n :]])

    def coordinates(self, theta):
        """z of physical full parameters `theta` (the inverse of `theta`)."""
        n = self.n
        links = _log_cholesky(_pseudo(theta[: 10 * n].reshape(n, 10))).reshape(-1)
        return jnp.concatenate([links, jnp.log(theta[10 * n : 13 * n]), theta[13 * n :]])

    def cost(self, z, beta, L, w):
        n = self.n
        theta = self.theta(z)
        r = jsl.solve_triangular(L, self.B @ theta - beta, lower=True)
        zl = z[: 10 * n].reshape(n, 10)
        logdet = jnp.sum(8 * zl[:, 0] + 2 * (zl[:, 1] + zl[:, 2] + zl[:, 3]))  # log det U U^T
        logdet0 = 2 * jnp.sum(jnp.log(jnp.diagonal(self.P0_chol, axis1=-2, axis2=-1)))
        P = _pseudo(theta[: 10 * n].reshape(n, 10))
        M = jsl.solve_triangular(self.P0_chol, P, lower=True)
        M = jsl.solve_triangular(self.P0_chol, jnp.swapaxes(M, -1, -2), lower=True)  # L0^-1 P L0^-T
        links = jnp.sum(jnp.trace(M, axis1=-2, axis2=-1)) - logdet + logdet0 - 4 * n
        v = z[10 * n : 13 * n] - jnp.log(self.x0)  # log(x / x0)
        drives = jnp.sum(jnp.exp(v) - v - 1)
        offsets = 0.5 * jnp.sum(theta[13 * n :] ** 2)
        return 0.5 * r @ r + w * (links + drives + offsets)


def _factor(z):
    """U (..., 4, 4) of log-Cholesky coordinates z (..., 10), P = U U^T."""
    a, d1, d2, d3, s12, s23, s13, t1, t2, t3 = (z[..., k] for k in range(10))
    zero, one = jnp.zeros_like(a), jnp.ones_like(a)
    rows = [
        [jnp.exp(d1), s12, s13, t1],
        [zero, jnp.exp(d2), s23, t2],
        [zero, zero, jnp.exp(d3), t3],
        [zero, zero, zero, one],
    ]
    return jnp.exp(a)[..., None, None] * jnp.stack([jnp.stack(r, -1) for r in rows], -2)


def _metric(H):
    """T with T^T H T = 1 for the Hessian H made positive definite (as `_solve_modified`): the minimiser works in
    u, z = z0 + T u, where the cost's curvature at the stage's start is the same in every direction."""
    H = 0.5 * (H + H.T)
    s = 1.0 / jnp.sqrt(jnp.maximum(jnp.abs(jnp.diag(H)), jnp.finfo(H.dtype).tiny))
    lam, V = jnp.linalg.eigh(H * s[:, None] * s[None, :])
    lam = jnp.maximum(jnp.abs(lam), 1e-10 * jnp.max(jnp.abs(lam)))
    return (s[:, None] * V) / jnp.sqrt(lam)[None, :]


def _solve_modified(H, g):
    """H^-1 g for the Hessian made positive definite as in `_metric` (T T^T = H^-1): the solve with the Hessian at a
    minimiser, safe where rounding leaves it indefinite."""
    T = _metric(H)
    return T @ (T.T @ g)


def _stage(problem: _Problem, solver: PhysicalSolver, z, w, beta, L):
    """One weight's minimisation from `z`: (its minimiser, steps, whether the minimiser met its tolerances). The
    minimiser works in u, z = z0 + T u (`_metric` at the start); derivatives reach `beta` and `L` through it
    (optimistix's implicit function theorem), not `z`."""
    z0 = jax.lax.stop_gradient(z)
    T = jax.lax.stop_gradient(_metric(jax.hessian(problem.cost)(z0, beta, L, w)))
    sol = optx.minimise(
        lambda u, a: problem.cost(z0 + T @ u, a[0], a[1], w), solver.minimiser, jnp.zeros_like(z0), (beta, L),
        max_steps=solver.max_steps, throw=False,
    )  # fmt: skip
    return z0 + T @ sol.value, sol.stats["num_steps"], sol.result == optx.RESULTS.successful


@eqx.filter_jit
def _estimate(problem: _Problem, beta, cov, weights: tuple, solver: PhysicalSolver):
    cov = 0.5 * (cov + cov.T)
    L = jnp.linalg.cholesky(cov)
    z = problem.coordinates(problem.start)
    steps = jnp.asarray(0, dtype=int)
    if len(weights) > 1:  # the path's first stages: one `lax.scan` (the minimiser traced and compiled once)
        fixed = jax.lax.stop_gradient((beta, L))

        def early(carry, w):
            z, k = _stage(problem, solver, carry[0], w, *fixed)[:2]
            return (z, carry[1] + k.astype(carry[1].dtype)), None

        (z, steps), _ = jax.lax.scan(early, (z, steps), jnp.asarray(weights[:-1], dtype=z.dtype))
    w = weights[-1]  # the last stage carries the derivatives
    z, k, converged = _stage(problem, solver, z, w, beta, L)
    steps = steps + k.astype(steps.dtype)
    H = jax.lax.stop_gradient(jax.hessian(problem.cost)(z, beta, L, w))
    g = jax.lax.stop_gradient(jax.grad(problem.cost)(z, beta, L, w))
    decrement = 0.5 * g @ _solve_modified(H, g)  # what the cost can still fall by, to second order
    converged = converged | (decrement <= solver.tol)
    theta = problem.theta(z)
    Jt = jax.lax.stop_gradient(jax.jacfwd(problem.theta)(z))  # (p, p) d theta / d z
    G = jsl.solve_triangular(L, problem.B, lower=True) @ Jt  # L^-1 B J: the data term's Jacobian in z
    V = Jt @ jax.vmap(lambda a: _solve_modified(H, a), in_axes=1, out_axes=1)(G.T)  # J H^-1 G^T
    cov_t = V @ V.T
    BV = problem.B @ V
    cov_b = BV @ BV.T
    base = problem.B @ theta
    std_u = jnp.sqrt(jnp.diag(cov))
    n = problem.n
    eig = jnp.linalg.eigvalsh(_pseudo(theta[: 10 * n].reshape(n, 10)))
    return dict(
        theta=theta,
        std=jnp.sqrt(jnp.diag(cov_t)),
        cov=cov_t,
        base=base,
        base_std=jnp.sqrt(jnp.diag(cov_b)),
        base_cov=cov_b,
        unconstrained=beta,
        unconstrained_std=std_u,
        shift=(base - beta) / std_u,
        distance=jnp.linalg.norm(jsl.solve_triangular(L, base - beta, lower=True)),
        z=z[: 10 * n].reshape(n, 10),
        edge=eig[..., 0] / eig[..., -1],
        steps=steps,
        converged=converged,
        decrement=decrement,
    )


def base_map(model: RobotModel) -> np.ndarray:
    """(rank, 14 n) the matrix $B$ with base parameters $\\beta = B\\theta$ (`BaseParameters.values`)."""
    base = model.base
    B = np.zeros((base.rank, len(model.full_names)))
    B[np.arange(base.rank), np.asarray(base.columns)] = 1.0
    if len(base.dependent_columns):
        B[:, np.asarray(base.dependent_columns)] = base.combination
    return B


def sources(B: np.ndarray, tol: float = 1e-9) -> tuple:
    """Per full parameter: "data" (its unit vector lies in the row space of `B`: a combination of base
    parameters), "prior" (its column of `B` is zero), else "combined"."""
    Q, R = np.linalg.qr(B.T)
    d = np.abs(np.diag(R))
    Q = Q[:, d > tol * max(d.max(initial=0.0), 1.0)]
    out = []
    for i in range(B.shape[1]):
        if not np.any(np.abs(B[:, i]) > tol):
            out.append("prior")
            continue
        e = np.zeros(B.shape[1])
        e[i] = 1.0
        out.append("data" if np.linalg.norm(e - Q @ (Q.T @ e)) < 1e-6 else "combined")
    return tuple(out)


def _problem(model: RobotModel, beta: np.ndarray) -> tuple:
    """The problem's arrays: the description's bodies (one that is not positive definite lifted to eigenvalues
    >= `PSD_FLOOR`), each drive parameter's centre $x_0$ (the description's value where positive, else the
    unconstrained estimate's where that parameter is a base parameter on its own and positive, else 1 in SI
    units) and the start (the description's bodies, the drives at their centres, each offset that is a base
    parameter on its own at its estimate); and which links were lifted."""
    n = model.robot.n
    full = full_parameters(model.robot)
    bodies, lifted = [], []
    for k in range(n):
        P = np.asarray(_pseudo(jnp.asarray(full[10 * k : 10 * k + 10])))
        lam, V = np.linalg.eigh(0.5 * (P + P.T))
        if lam.min() < PSD_FLOOR:
            lifted.append(k + 1)
            P = (V * np.maximum(lam, PSD_FLOOR)) @ V.T
        bodies.append(P)
    pure = {}
    K = model.base.combination
    for i, col in enumerate(np.asarray(model.base.columns)):
        if col >= 10 * n and (K.size == 0 or not np.any(K[i] != 0)):
            pure[int(col)] = float(beta[i])
    x0 = full[10 * n : 13 * n].copy()
    for i in range(3 * n):
        if not x0[i] > 0:
            x0[i] = pure.get(10 * n + i, 1.0) if pure.get(10 * n + i, 0.0) > 0 else 1.0
    offsets = np.array([pure.get(13 * n + j, 0.0) for j in range(n)])
    links = np.stack([np.asarray(_standard_of(jnp.asarray(P))) for P in bodies]).ravel()
    start = np.concatenate([links, x0, offsets])
    chol = np.linalg.cholesky(np.stack(bodies))
    return _Problem(jnp.asarray(base_map(model)), jnp.asarray(chol), jnp.asarray(x0), jnp.asarray(start), n), lifted


@x64
def physical_estimate(
    estimate,
    model: RobotModel,
    *,
    prior_weight: float = PRIOR_WEIGHT,
    solver: PhysicalSolver = PhysicalSolver(),
) -> PhysicalEstimate:
    r"""The physical robot nearest to an unconstrained base-parameter estimate, in its covariance.

    $\min_\theta \|L^{-1}(B\theta - \hat\beta)\|^2 / 2 + w D(\theta \| \theta_0)$ (`_physical`'s module
    docstring): every link a rigid body (pseudo-inertia positive definite), motor inertias and friction
    coefficients positive, offsets free. $\hat\beta$, $C = LL^T$: `estimate.theta`, `estimate.cov` (an
    `IDIMResult` of `model`'s base parameters, a `RobotFit`, or a dict with those two arrays: IDIM-LS, IDIM-IV
    with Newey-West intervals). $\theta_0$: the description (`model.robot`; a link whose description is not a
    physical body is lifted to the nearest one, eigenvalues of $P$ >= 1e-6, and said in `notes`).
    `prior_weight` $w$: the weight of the log-det divergence from the description, which sets the directions
    the data do not see; 1e-3 by default: an identified direction moves by about a tenth of its standard error
    or less (measured on the simulated robots of the gallery, whose estimates are physical), and the minimiser
    converges on every robot tried, where 1e-4 left BFGS crawling along the valleys of the unseen directions
    (`benchmarks/physical.py`). `solver`: a `PhysicalSolver` (optimistix's BFGS along a path of weights).

    Pure in `estimate`'s arrays: it jits, vmaps over estimates of one model, and differentiates (through the
    minimiser by the implicit function theorem, optimistix's `ImplicitAdjoint`). Read the result with its
    methods (`links`, `robot`, `relative_error`, `warnings`, `notes`).

    **Returns:** a `PhysicalEstimate`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import tx40_robot
        >>> from jaxsdp.plants.robot import physical_estimate, pseudo_inertia, robot_model
        >>> m = robot_model(tx40_robot())
        >>> beta = m.nominal.copy()
        >>> beta[m.names.index("Fv1")] = -0.5  # a negative viscous friction: not physical
        >>> est = physical_estimate(dict(theta=beta, cov=np.diag((0.01 * np.abs(m.nominal) + 1e-3) ** 2)), m)
        >>> bool(est.converged), round(float(est.base[m.names.index("Fv1")]), 3)
        (True, 0.0)
        >>> est.warnings()[0][:58]
        'the unconstrained estimate is not a physical robot: consis'
    """
    if not isinstance(model, RobotModel):
        raise ValueError(f"`model` must be a RobotModel (jaxsdp.plants.robot.robot_model); got {model!r}")
    if isinstance(estimate, dict):
        theta, cov = estimate.get("theta"), estimate.get("cov")
    else:
        theta, cov = getattr(estimate, "theta", None), getattr(estimate, "cov", None)
    if theta is None or cov is None:
        raise ValueError("`estimate` must have `theta` and `cov` (an IDIMResult, a RobotFit, or a dict of them)")
    names = getattr(estimate, "names", None)
    if names is not None and tuple(names) != tuple(model.names):
        raise ValueError("`estimate`'s parameters are not `model`'s base parameters (another robot_model?)")
    r = model.rank
    beta, C = jnp.asarray(theta, dtype=jnp.float64), jnp.asarray(cov, dtype=jnp.float64)
    if beta.shape != (r,) or C.shape != (r, r):
        raise ValueError(f"`estimate`: `theta` must be ({r},) and `cov` ({r}, {r}); got {beta.shape}, {C.shape}")
    number = isinstance(prior_weight, (int, float)) and not isinstance(prior_weight, bool)
    if not (number and 0 < prior_weight < math.inf):
        raise ValueError(f"`prior_weight` must be a finite number > 0; got {prior_weight!r}")
    if not isinstance(solver, PhysicalSolver):
        raise ValueError(f"`solver` must be a PhysicalSolver; got {type(solver).__name__}")
    concrete = not isinstance(beta, jax.core.Tracer)
    problem, lifted = _problem(model, np.asarray(beta) if concrete else np.asarray(model.nominal))
    out = _estimate(problem, beta, C, solver.weights(float(prior_weight)), solver)
    return PhysicalEstimate(
        **out,
        names=tuple(model.full_names),
        base_names=tuple(model.names),
        source=sources(np.asarray(problem.B)),
        prior_weight=float(prior_weight),
        lifted=tuple(lifted),
    )
