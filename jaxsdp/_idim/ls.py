r"""Inverse dynamic identification model, least squares (IDIM-LS).

The inverse dynamic model is linear in the parameters,
$y = X \theta + e$ ($y$: measured force/torque, $X$: regressors built
from filtered position, velocity and acceleration). IDIM-LS is ordinary
least squares on the (parallel-decimated) samples, with the usual
standard deviations $\sigma_{\theta_i} = \hat\sigma \sqrt{[(X^T X)^{-1}]_{ii}}$,
$\hat\sigma^2 = \|y - X\hat\theta\|^2 / (N - p)$.
"""

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import check_value
from .._runtime import x64
from .._signal.regressors import Regressors, check_names, check_regression


class IDIMResult(eqx.Module):
    r"""Ordinary least-squares estimate of $y = X\theta + e$.

    **Fields:**

    - `theta`: estimate $\hat\theta = \arg\min \|y - X\theta\|$, shape `(p,)`.
    - `std`: standard deviations $\hat\sigma\sqrt{[(X^TX)^{-1}]_{ii}}$.
    - `rel_std`: relative standard deviations $100\,\sigma_i/|\theta_i|$ (%).
    - `sigma`: residual standard deviation $\|e\|/\sqrt{N-p}$.
    - `cov`: covariance $\hat\sigma^2 (X^TX)^{-1}$, shape `(p, p)`.
    - `residuals`: $y - X\hat\theta$; `fit`: $X\hat\theta$.
    - `relative_error`: $100\,\|y - X\hat\theta\| / \|y\|$ (%).
    - `cond`: 2-norm condition number of $X$.
    - `names`: parameter names; `dof`: $N - p$.
    """

    theta: Float[Array, " p"]
    std: Float[Array, " p"]
    rel_std: Float[Array, " p"]
    sigma: Float[Array, ""]
    cov: Float[Array, "p p"]
    residuals: Float[Array, " N"]
    fit: Float[Array, " N"]
    relative_error: Float[Array, ""]
    cond: Float[Array, ""]
    names: tuple[str, ...] = eqx.field(static=True)
    dof: int = eqx.field(static=True)

    def table(self, *, digits: int = 4) -> str:
        """A text table in the style of the paper's Table 1:
        each parameter's value and (relative standard deviation in %)."""
        return idim_table(self, digits=digits)


def idim_table(result: IDIMResult, *, digits: int = 4) -> str:
    """Format an `IDIMResult` as text: `name  value  (rel. std %)` per line,
    then the residual standard deviation and relative error."""
    theta = np.asarray(result.theta)
    rel = np.asarray(result.rel_std)
    width = max([len("parameter")] + [len(n) for n in result.names])
    values = [f"{v:.{digits}f}" for v in theta]
    vwidth = max(len("estimate"), *(len(v) for v in values))
    lines = [f"{'parameter':<{width}}  {'estimate':>{vwidth}}  (rel. std %)"]
    for name, v, r in zip(result.names, values, rel):
        lines.append(f"{name:<{width}}  {v:>{vwidth}}  ({r:.2f} %)")
    lines.append(f"sigma = {float(result.sigma):.{digits}g}, dof = {result.dof}")
    lines.append(f"relative error 100*||y - X theta||/||y|| = {float(result.relative_error):.{digits}f} %")
    lines.append(f"cond(X) = {float(result.cond):.3g}")
    return "\n".join(lines)


@jax.jit
def _ls(y, X):
    n, p = X.shape
    q, r = jnp.linalg.qr(X, mode="reduced")
    theta = jsl.solve_triangular(r, q.T @ y, lower=False)
    fit = X @ theta
    residuals = y - fit
    rss = residuals @ residuals
    sigma2 = rss / (n - p)
    r_inv = jsl.solve_triangular(r, jnp.eye(p, dtype=X.dtype), lower=False)
    std = jnp.sqrt(sigma2) * jnp.linalg.norm(r_inv, axis=1)
    s = jnp.linalg.svd(r, compute_uv=False)  # singular values of X
    return dict(
        theta=theta,
        std=std,
        rel_std=100 * std / jnp.abs(theta),
        sigma=jnp.sqrt(sigma2),
        cov=sigma2 * (r_inv @ r_inv.T),
        residuals=residuals,
        fit=fit,
        relative_error=100 * jnp.sqrt(rss) / jnp.linalg.norm(y),
        cond=s[0] / s[-1],
    )


@x64
def idim_ls(
    y: ArrayLike,
    X: ArrayLike | Regressors,
    *,
    names: Sequence[str] | None = None,
) -> IDIMResult:
    r"""Ordinary least squares $\hat\theta = \arg\min_\theta \|y - X\theta\|_2$.

    Solved through the thin QR factorisation $X = QR$:
    $\hat\theta = R^{-1} Q^T y$ and $(X^TX)^{-1} = R^{-1}R^{-T}$ with
    triangular solves (no normal equations, no explicit inverse of $X^TX$).

    **Arguments:**

    - `y`: measured force/torque, shape `(N,)`.
    - `X`: regressors, shape `(N, p)` with `N > p` and full column rank, or a
      `Regressors` (its names are used unless `names` is given).
    - `names`: parameter names (default `theta1, theta2, ...`).

    **Returns:** an `IDIMResult`.
    """
    if isinstance(X, Regressors):
        if names is None:
            names = X.names
        X = X.X
    y, X = check_regression(y, X)
    n, p = X.shape
    if n <= p:
        raise ValueError(f"`X` needs more rows than columns; got shape {(n, p)}")
    names = check_names(names, p)

    out = _ls(y, X)
    out["cond"] = check_value(
        "X",
        out["cond"],
        lambda c: ~(c < 1 / (max(n, p) * np.finfo(np.float64).eps)),
        f"is rank deficient (shape {(n, p)}); the parameters are not identifiable",
    )
    return IDIMResult(**out, names=names, dof=n - p)
