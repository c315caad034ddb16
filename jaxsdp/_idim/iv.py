"""Inverse dynamic identification model, instrumental variables (IDIM-IV; Janot, Vandanjon & Gautier, 2014).

In closed loop the regressors X, built from the measured (noisy, filtered)
motion, are correlated with the error e of y = X theta + e, which biases
least squares. IDIM-IV replaces X^T by the transpose of an instrument
matrix Z of the same shape, correlated with X but not with e; in the
generic IDIM-IV, Z is the same inverse dynamic model evaluated on the motion
of the identified model simulated in the same closed loop (noise free):

    theta_IV = (Z^T X)^-1 Z^T y,

computed by QR factorisations (never an explicit inverse of a covariance).
Since Z depends on the current estimate, the estimate is iterated
(`idim_iv_iterate`) from an IDIM-LS start until the parameters and the
relative error stop changing.
"""

from collections.abc import Callable, Sequence
from typing import Literal, NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float_array, check_finite, positive_int
from .._runtime import x64
from .._signal.regressors import Regressors, check_names, check_regression
from .ls import IDIMResult, ParamEstimate, check_cov, check_linear, linear_estimate, rank_checked


@x64
def idim_iv(
    y: ArrayLike,
    X: ArrayLike | Regressors,
    Z: ArrayLike | Regressors,
    *,
    names: Sequence[str] | None = None,
    cov: Literal["iid", "hac"] = "iid",
    lag: float | None = None,
) -> IDIMResult:
    r"""Instrumental-variable estimate $\theta = (Z^T X)^{-1} Z^T y$ (one IDIM-IV step).

    With $Z = Q R$ (thin QR) and $Q^T X = Q_B R_B$, $\theta = R_B^{-1} Q_B^T Q^T y$.
    Residuals $e = y - X \theta$ use the measured regressors $X$, and
    $\sigma^2 = \|e\|^2 / (N - p)$.

    **Covariance** (`cov`):

    - `"iid"` (Janot, Vandanjon & Gautier 2014, eq. of the IV covariance):
      $\sigma^2 (Z^T X)^{-1} (Z^T Z) (X^T Z)^{-1}$, valid for white residuals;
    - `"hac"`: Newey-West sandwich $N/(N-p) (Z^T X)^{-1} S (X^T Z)^{-1}$ with
      $S = \sum_l w(l) \sum_t z_t e_t e_{t-l} z_{t-l}^T$, Bartlett weights
      $w(l) = 1 - |l|/(lag + 1)$; `lag` in samples, None for Andrews' (1991)
      automatic bandwidth.

    `rel_std` is $100 std / |\theta|$ (%), `relative_error` $100 \|e\| / \|y\|$ (%),
    `cond` the condition number of $X$. With $Z = X$ it is `idim_ls`.

    **Arguments:**

    - `y`: measured output, `(N,)`; `X`: measured regressors `(N, p)`, `N > p`
      (or a `Regressors`, whose names are used).
    - `Z`: instruments, same shape as `X` (or a `Regressors`); `Z^T X` must be
      invertible.
    - `names`, `cov`, `lag`: as in `idim_ls`.

    **Returns:** an `IDIMResult`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import idim_iv
        >>> rng = np.random.default_rng(0)
        >>> x = rng.standard_normal(400)
        >>> y = 2.0 * x + 0.1 * rng.standard_normal(400)
        >>> X = np.c_[x + 0.3 * rng.standard_normal(400), np.ones(400)]  # noisy regressor
        >>> res = idim_iv(y, X, np.c_[x, np.ones(400)], names=("k", "c"))
        >>> abs(res["k"] - 2.0) < 0.05
        True
    """
    y, X, names = check_linear(y, X, names)
    if isinstance(Z, Regressors):
        Z = Z.X
    Z = as_float_array("Z", Z)
    if Z.shape != X.shape:
        raise ValueError(
            f"`Z` must have the shape of `X` (one instrument per regressor); got {tuple(Z.shape)} and {tuple(X.shape)}"
        )
    Z = check_finite("Z", Z)
    n, p = X.shape
    lag_arg = check_cov(cov, lag)
    out = linear_estimate(y, X, Z, lag_arg, cov=cov)
    rank_checked("Z", out.pop("cond_z"), n, p, "is rank deficient")
    rank_checked("Z^T X", out.pop("cond_b"), n, p, "is singular")
    out["cond"] = rank_checked("X", out["cond"], n, p)
    return IDIMResult(**out, names=names, dof=n - p, cov_type=cov)


class Instruments(NamedTuple):
    """What an `instruments(theta)` callable of `idim_iv_iterate` may return.

    `Z`: instruments `(N, p)` (or a `Regressors`); `y_offset`: optional `(N,)`
    subtracted from `y` for this step (e.g. the simulated model's own
    residual, for a bias-compensated IV), None for the plain IV.
    """

    Z: ArrayLike
    y_offset: ArrayLike | None = None


class IDIMIVResult(eqx.Module):
    r"""Iterated IDIM-IV (`idim_iv_iterate`).

    **Fields:**

    - `result`: the `IDIMResult` of the last IV step (estimate, covariance, ...);
      its `residuals`, `sigma` and `relative_error` are those of the regression
      solved, $y - o - X \theta$ ($o$ the last `y_offset`; $o = 0$ for the plain IV).
    - `theta_history`: start and every iterate, shape `(iterations + 1, p)`.
    - `relative_error_history`: $100 \|y - X \theta\| / \|y\|$ (%) for each row
      of `theta_history`, with the measured y (no offset); the last one is
      `measured_relative_error`.
    - `iterations`: IV steps done; `converged`: whether the convergence test
      passed; `tol`: its tolerance; `failed`: the loop stopped because the
      next step's instruments were not finite (the model simulated for them
      diverged): the result is then step `iterations`' (0: the start's
      regression, least squares).

    `res["M"]`, `res.param("M")`, `res.as_dict()`, `res.table()`, `res.names`,
    `res.theta`, `res.std`, `res.rel_std`, `res.relative_error` forward to `result`.
    """

    result: IDIMResult
    theta_history: Float[Array, "k p"]
    relative_error_history: Float[Array, " k"]
    iterations: int = eqx.field(static=True)
    converged: bool = eqx.field(static=True)
    tol: float = eqx.field(static=True)
    failed: bool = eqx.field(static=True, default=False)

    names = property(x64(lambda self: self.result.names))
    theta = property(x64(lambda self: self.result.theta))
    std = property(x64(lambda self: self.result.std))
    rel_std = property(x64(lambda self: self.result.rel_std))
    relative_error = property(x64(lambda self: self.result.relative_error))

    @property
    @x64
    def measured_relative_error(self) -> float:
        """100 ||y - X theta|| / ||y|| (%) of the final estimate on the measured y."""
        return float(self.relative_error_history[-1])

    def __getitem__(self, name: str):
        return self.result[name]

    @x64
    def param(self, name: str) -> ParamEstimate:
        return self.result.param(name)

    @x64
    def as_dict(self) -> dict:
        return self.result.as_dict()

    @x64
    def table(self, *, digits: int = 4) -> str:
        state = "converged" if self.converged else "NOT converged"
        if self.failed:
            state = f"NOT converged: step {self.iterations + 1}'s instruments were not finite, its simulation diverged"
        return (
            self.result.table(digits=digits)
            + f"\nrelative error on the measured y = {self.measured_relative_error:.{digits}f} %"
            + f"\nIV iterations: {self.iterations} ({state}, tol {self.tol:g})"
        )


def relative_error(y, X, theta):
    """The regression's relative error 100 ||y - X theta|| / ||y|| (%), in JAX (jit, vmap, grad).

    Example:
        >>> import numpy as np
        >>> round(float(relative_error(np.array([3.0, 4.0]), np.eye(2), np.array([3.0, 0.0]))), 6)  # %
        80.0
    """
    return 100 * jnp.linalg.norm(y - X @ theta) / jnp.linalg.norm(y)


def iv_converged(theta, new, rho, rho_new, tol, scale=None):
    """The iterated IDIM-IV's convergence test (Janot et al. 2014), in JAX: both the largest relative
    parameter change max_i |new_i - theta_i| / |theta_i| and the relative change of the relative error
    |rho_new - rho| / rho below `tol`. Used by `idim_iv_iterate` and by the Monte Carlo run's IV loop.
    `scale` (p,): each change is measured against max(|theta_i|, scale_i) instead (`iv_iterate` passes the
    standard errors: a parameter whose value is zero, an offset, converges when it moves by far less than its
    standard error, not by less than tol times nothing).

    Example:
        >>> import numpy as np
        >>> bool(iv_converged(np.array([1.0, 2.0]), np.array([1.00001, 2.0]), 5.0, 5.00001, 1e-4))
        True
    """
    tiny = jnp.finfo(jnp.float64).tiny
    ref = jnp.abs(theta) if scale is None else jnp.maximum(jnp.abs(theta), scale)
    dtheta = jnp.max(jnp.abs(new - theta) / jnp.maximum(ref, tiny))
    drho = jnp.abs(rho_new - rho) / jnp.maximum(rho, tiny)
    return (dtheta < tol) & (drho < tol)


def _relerr(y, X, theta):
    return float(relative_error(y, X, theta))


@x64
def idim_iv_iterate(
    y: ArrayLike,
    X: ArrayLike | Regressors,
    instruments: Callable[[np.ndarray], ArrayLike | Instruments],
    theta0: ArrayLike,
    *,
    names: Sequence[str] | None = None,
    max_iter: int = 20,
    tol: float = 1e-4,
    cov: Literal["iid", "hac"] = "iid",
    lag: float | None = None,
) -> IDIMIVResult:
    r"""Iterated IDIM-IV: $\theta_{k+1} = (Z_k^T X)^{-1} Z_k^T (y - o_k)$, $Z_k$ = `instruments(theta_k)`.

    `instruments(theta)` (a Python callable, typically a closed-loop
    simulation of the model with parameters `theta`) returns the instrument
    matrix `Z` (same shape as `X`), or an `Instruments(Z, y_offset)` whose
    `y_offset` $o_k$ is subtracted from `y` for that step (None: 0).

    **Convergence test** (Janot et al. 2014): stop when both the relative
    change of every parameter, $\max_i |\theta_{k+1,i} - \theta_{k,i}| / |\theta_{k,i}|$,
    and the relative change of the relative error
    $|\rho_{k+1} - \rho_k| / \rho_k$ ($\rho = \|y - X \theta\| / \|y\|$) are below
    `tol`; at most `max_iter` steps (`converged=False` then).

    The last step's covariance (`cov`, `lag`: see `idim_iv`) treats Z as
    fixed. `theta0`: the start (e.g. the IDIM-LS estimate), shape `(p,)`.

    **Returns:** an `IDIMIVResult`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import idim_iv_iterate
        >>> rng = np.random.default_rng(1)
        >>> x = np.sin(np.linspace(0, 20, 300))
        >>> y = 1.5 * x + 0.05 * rng.standard_normal(300)
        >>> X = np.c_[x + 0.05 * rng.standard_normal(300), np.ones(300)]
        >>> res = idim_iv_iterate(y, X, lambda th: np.c_[x, np.ones(300)], np.array([1.0, 0.0]))
        >>> res.converged, abs(res["theta1"] - 1.5) < 0.05
        (True, True)
    """
    if isinstance(X, Regressors):
        names = X.names if names is None else names
        X = X.X
    y, X = check_regression(y, X)
    n, p = X.shape
    names = check_names(names, p)
    max_iter = positive_int("max_iter", max_iter)
    if not (isinstance(tol, (int, float, np.floating)) and 0 < tol < np.inf):
        raise ValueError(f"`tol` must be a finite number > 0; got {tol!r}")
    if not callable(instruments):
        raise ValueError(f"`instruments` must be a callable theta -> Z; got {type(instruments).__name__}")
    theta = np.asarray(check_finite("theta0", as_float_array("theta0", theta0, ndim=1)), dtype=float)
    if theta.shape != (p,):
        raise ValueError(f"`theta0` must have shape ({p},) (one value per column of `X`); got {theta.shape}")
    yn, Xn = np.asarray(y), np.asarray(X)
    thetas, rhos = [theta], [_relerr(yn, Xn, theta)]
    converged, res = False, None
    for _ in range(int(max_iter)):
        inst = instruments(theta)
        if not isinstance(inst, Instruments):
            inst = Instruments(inst)
        yk = y
        if inst.y_offset is not None:
            off = as_float_array("y_offset", inst.y_offset, ndim=1)
            if off.shape != y.shape:
                raise ValueError(f"`y_offset` must have the shape of `y` {tuple(y.shape)}; got {tuple(off.shape)}")
            yk = y - off
        res = idim_iv(yk, X, inst.Z, names=names, cov=cov, lag=lag)
        new = np.asarray(res.theta, dtype=float)
        rho = _relerr(yn, Xn, new)
        done = bool(iv_converged(theta, new, rhos[-1], rho, tol))
        theta = new
        thetas.append(theta)
        rhos.append(rho)
        if done:
            converged = True
            break
    return IDIMIVResult(
        result=res,
        theta_history=jnp.asarray(np.array(thetas)),
        relative_error_history=jnp.asarray(np.array(rhos)),
        iterations=len(thetas) - 1,
        converged=converged,
        tol=float(tol),
    )
