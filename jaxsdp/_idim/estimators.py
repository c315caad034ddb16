r"""IDIM estimators as small Modules: pure `__call__`s that jit, vmap and differentiate.

The option objects of the identification pipelines (`jaxsdp.plants.emps.EMPSPipeline`),
in the manner of optimistix's solvers: the covariance and the iteration are
fields, not strings at call sites.

- `IID()`, `NeweyWest(lag)`: the covariance of a linear estimate (`idim_ls`'s
  `cov="iid"` and `cov="hac"`).
- `IDIMLS(cov)`: least squares $\hat\theta = \arg\min \|y - X\theta\|_2$ by QR
  (`ls_estimate`), returning an `IDIMResult`.
- `IDIMIV(max_iter, tol, cov, compensate, floor)`: the iterated instrumental
  variable $\theta_{k+1} = (Z_k^T X)^{-1} Z_k^T (y - o_k)$ with
  $Z_k, o_k$ = `instruments(theta_k)`, in one `while_loop` (`iv_iterate`).

Nothing here raises on values or prints: the checks that need concrete
numbers (rank, signs, convergence) are the studies' diagnosis step.
"""

from collections.abc import Callable

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, Int

from .._runtime import x64
from .iv import Instruments, iv_converged, relative_error
from .ls import IDIMResult, linear_estimate, ls_estimate

__all__ = ["IID", "NeweyWest", "IDIMLS", "IDIMIV", "IVFit", "iv_iterate"]


class IID(eqx.Module):
    r"""White-residual covariance $\hat\sigma^2 (X^T X)^{-1}$ (IV: $\hat\sigma^2 B^{-1} B^{-T}$), the paper's
    eq. (12)."""

    name = "iid"

    def _lag(self):
        return jnp.asarray(jnp.nan, dtype=jnp.float64)


class NeweyWest(eqx.Module):
    r"""Newey-West (Bartlett) covariance $N/(N-p) (X^T X)^{-1} S (X^T X)^{-1}$ for serially correlated
    residuals; `lag` in samples (bandwidth `lag + 1`), or None for Andrews' (1991) automatic bandwidth."""

    lag: float | None = eqx.field(static=True, default=None)
    name = "hac"

    def __check_init__(self):
        v = self.lag
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v < float("inf")):
            raise ValueError(f"`lag` must be None or a finite number >= 0 (samples); got {v!r}")

    def _lag(self):
        return jnp.asarray(jnp.nan if self.lag is None else float(self.lag), dtype=jnp.float64)


Covariance = IID | NeweyWest


def _check_cov(cov):
    if not isinstance(cov, (IID, NeweyWest)):
        raise ValueError(f"`cov` must be jaxsdp.IID() or jaxsdp.NeweyWest(...); got {cov!r}")
    return cov


def as_result(out: dict, names, cov: Covariance) -> IDIMResult:
    """An `IDIMResult` from the dict of `ls_estimate` / `linear_estimate` (extra keys dropped)."""
    keys = ("theta", "std", "rel_std", "sigma", "cov", "residuals", "fit", "relative_error", "cond", "lag")
    n, p = out["fit"].shape[-1], out["theta"].shape[-1]
    return IDIMResult(**{k: out[k] for k in keys}, names=tuple(names), dof=n - p, cov_type=cov.name)


class IDIMLS(eqx.Module):
    r"""IDIM-LS: $\hat\theta = \arg\min_\theta \|y - X\theta\|_2$ through the QR factorisation of $[X | y]$
    (no normal equations), with the covariance `cov` (`IID()` default, or `NeweyWest()`).

    `IDIMLS(cov)(y, X, names)` returns an `IDIMResult`; pure: under `jit`, `vmap`
    (LAPACK on one problem, Householder in `lax` on a batch: `jaxsdp._linalg`) and `grad`.
    Its condition number is a diagnostic: a rank-deficient `X` is reported by the
    study's diagnosis, not raised here (`idim_ls` raises).
    """

    cov: Covariance = IID()

    def __check_init__(self):
        _check_cov(self.cov)

    @x64
    def __call__(self, y: Float[Array, " N"], X: Float[Array, "N p"], names) -> IDIMResult:
        return self._solve(y, X, names)

    def _solve(self, y, X, names, groups: int = 1) -> IDIMResult:
        """`__call__` without the float64 entry wrapper, for pipelines (already inside it); `groups` equations
        per instant, stacked instant by instant (the Newey-West lags count instants: `hac_covariance`)."""
        return as_result(ls_estimate(y, X, self.cov._lag(), cov=self.cov.name, groups=groups), names, self.cov)


class IVFit(eqx.Module):
    """An iterated IDIM-IV in JAX (`iv_iterate`): `result` the last step's `IDIMResult` (its residuals those of
    $y - o - X\\theta$), `iterations` the steps done, `converged` the convergence test's verdict, `start` the
    start $\\theta_0$, `relative_error` $100 \\|y - X\\theta\\| / \\|y\\|$ (%) on the measured $y$;
    `theta_history` (max_iter + 1, p) the start and each iterate, NaN after the last, and
    `relative_error_history` (max_iter + 1,) their relative errors (%); `failed` True when a step's instruments
    were not finite (the model simulated for them diverged): the loop stopped there, not converged, and `result`
    is the previous step's (the least-squares estimate if it was the first)."""

    result: IDIMResult
    iterations: Int[Array, ""]
    converged: Bool[Array, ""]
    start: Float[Array, " p"]
    relative_error: Float[Array, ""]
    theta_history: Float[Array, "k p"]
    relative_error_history: Float[Array, " k"]
    failed: Bool[Array, ""]


class IDIMIV(eqx.Module):
    r"""Iterated (bias-compensated) IDIM-IV options.

    **Fields:** `max_iter` (steps), `tol` (the convergence test of Janot et al.,
    `iv_converged`: parameters and relative error both change by less than
    `tol`), `cov` (`NeweyWest()` default: the closed loop colours the
    residual), `compensate` (subtract the simulated model's own residual $o_k$,
    the bias-compensated IV; False: the plain IV of Janot et al.), `floor` (each
    parameter whose start is positive is handed to the simulator at least
    `floor` times its start, so that a wild step still simulates a physical
    plant; parameters that start at zero or below, an offset, are free).
    """

    max_iter: int = eqx.field(static=True, default=20)
    tol: float = eqx.field(static=True, default=1e-4)
    cov: Covariance = NeweyWest()
    compensate: bool = eqx.field(static=True, default=True)
    floor: float = eqx.field(static=True, default=0.05)

    def __check_init__(self):
        _check_cov(self.cov)
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, int) or self.max_iter < 1:
            raise ValueError(f"`max_iter` must be an integer >= 1; got {self.max_iter!r}")
        if not (isinstance(self.tol, (int, float)) and 0.0 < self.tol < 1.0):
            raise ValueError(f"`tol` must lie in (0, 1); got {self.tol!r}")
        if not (isinstance(self.floor, (int, float)) and 0.0 <= self.floor < 1.0):
            raise ValueError(f"`floor` must lie in [0, 1); got {self.floor!r}")


def iv_iterate(
    y: Float[Array, " N"],
    X: Float[Array, "N p"],
    instruments: Callable[[Array], Instruments],
    theta0: Float[Array, " p"],
    names,
    options: IDIMIV,
    *,
    groups: int = 1,
) -> IVFit:
    r"""The iterated IDIM-IV $\theta_{k+1} = (Z_k^T X)^{-1} Z_k^T (y - o_k)$ in one `while_loop`.

    `instruments(theta)` (pure JAX, e.g. the closed-loop simulation of the
    model `theta` processed like the measurement) returns an `Instruments(Z, y_offset)`;
    with `options.compensate=False` the offset is ignored. It is called on
    $\max(\theta_k, f \theta_0)$ for the parameters whose start $\theta_0$ is
    positive ($f$ = `options.floor`; the others as they are), so that the
    simulated plant stays physical. The loop stops when
    `iv_converged` passes, after `options.max_iter` steps, or at a step whose instruments are not finite (NaN
    from a diverged simulation: `failed`, the previous step kept); it is a checkpointed
    `equinox.internal.while_loop`, so reverse-mode derivatives pass through it. `groups`: equations per
    instant, the rows stacked instant by instant (a robot's joints; the Newey-West lags then count instants).
    """
    lag = options.cov._lag()
    floor = options.floor * theta0
    positive = theta0 > 0  # the parameters that start positive (masses, friction) stay so; others are free

    def step(theta):
        inst = instruments(jnp.where(positive, jnp.maximum(theta, floor), theta))
        yk = y if (inst.y_offset is None or not options.compensate) else y - inst.y_offset
        return linear_estimate(yk, X, inst.Z, lag, cov=options.cov.name, groups=groups)

    def body(carry):
        k, theta, rho, _, previous, thetas, rhos, _ = carry
        est = step(theta)
        failed = ~jnp.all(jnp.isfinite(est["theta"]))
        est = jax.tree.map(lambda a, b: jnp.where(failed, a, b), previous, est)
        new = jnp.where(failed, theta, est["theta"])
        rho_new = jnp.where(failed, rho, relative_error(y, X, new))
        done = ~failed & iv_converged(theta, new, rho, rho_new, options.tol, est["std"])
        thetas = jnp.where(failed, thetas, thetas.at[k + 1].set(new))
        rhos = jnp.where(failed, rhos, rhos.at[k + 1].set(rho_new))
        return k + 1 - failed, new, rho_new, done, est, thetas, rhos, failed

    first = linear_estimate(y, X, X, lag, cov=options.cov.name, groups=groups)  # the loop's carry shape: an LS estimate
    rho0 = relative_error(y, X, theta0)
    thetas = jnp.full((options.max_iter + 1, theta0.shape[0]), jnp.nan).at[0].set(theta0)
    rhos = jnp.full((options.max_iter + 1,), jnp.nan).at[0].set(rho0)
    init = (jnp.asarray(0), theta0, rho0, jnp.asarray(False), first, thetas, rhos, jnp.asarray(False))
    k, theta, rho, done, est, thetas, rhos, failed = eqxi.while_loop(
        lambda c: (c[0] < options.max_iter) & ~c[3] & ~c[7],
        body,
        init,
        max_steps=options.max_iter,
        kind="checkpointed",
    )
    return IVFit(
        result=as_result(est, names, options.cov),
        iterations=k,
        converged=done,
        start=theta0,
        relative_error=rho,
        theta_history=thetas,
        relative_error_history=rhos,
        failed=failed,
    )
