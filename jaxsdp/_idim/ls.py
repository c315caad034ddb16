"""Inverse dynamic identification model, least squares (IDIM-LS), and the shared linear-estimate core.

The inverse dynamic model is linear in the parameters, y = X theta + e
(y: measured force/torque, X: regressors built from filtered position,
velocity and acceleration). IDIM-LS is ordinary least squares on the
(parallel-decimated) samples, with the usual standard deviations

    sigma_i = sigma_hat * sqrt([(X^T X)^-1]_ii),   sigma_hat^2 = ||y - X theta_hat||^2 / (N - p),

or, with `cov="hac"`, a Newey-West (Bartlett kernel) heteroskedasticity and
autocorrelation consistent covariance for serially correlated residuals.
The same core (`linear_estimate`) serves IDIM-IV (`jaxsdp._idim.iv`).
"""

from collections.abc import Sequence
from typing import Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import check_value
from .._linalg import qr_r, qr_thin, solve_upper, tall_lstsq
from .._runtime import x64
from .._signal.regressors import Regressors, check_names, check_regression

COV_TYPES = ("iid", "hac")


class ParamEstimate(NamedTuple):
    """One parameter of an `IDIMResult`: `value`, `std` (standard deviation,
    units of the value) and `rel_std` ($100 std / |value|$, %)."""

    value: float
    std: float
    rel_std: float


class IDIMResult(eqx.Module):
    r"""Linear estimate of $y = X \theta + e$ (IDIM-LS, or IDIM-IV from `jaxsdp._idim.iv`).

    **Fields:**

    - `theta`: the estimate, shape `(p,)`.
    - `std`: standard deviations $\sqrt{diag(cov)}$, shape `(p,)`.
    - `rel_std`: relative standard deviations $100 std_i / |\theta_i|$ (%).
    - `sigma`: residual standard deviation $\|y - X \theta\| / \sqrt{N - p}$.
    - `cov`: covariance of `theta`, shape `(p, p)`: for LS with `cov_type="iid"`
      $\sigma^2 (X^T X)^{-1}$; see `idim_ls` / `idim_iv` for the others.
    - `residuals`: $y - X \theta$; `fit`: $X \theta$.
    - `relative_error`: $100 \|y - X \theta\| / \|y\|$ (%).
    - `cond`: 2-norm condition number of $X$.
    - `lag`: the Newey-West lag (Bartlett bandwidth - 1, samples) of a `"hac"`
      covariance; None for `"iid"`.
    - `names`: parameter names; `dof`: $N - p$; `cov_type`: `"iid"` or `"hac"`.

    **Lookup by name:** `res["M"]` is the estimate of `M` (a float; an array
    when the result is batched or traced), `res.param("M")` a `ParamEstimate`
    `(value, std, rel_std)`, `res.as_dict()` `{name: value}`. An unknown name
    raises `KeyError` listing the valid ones.
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
    lag: Float[Array, ""] | None = None
    cov_type: str = eqx.field(static=True, default="iid")

    @x64
    def table(self, *, digits: int = 4) -> str:
        """A text table in the style of the paper's Table 1:
        each parameter's value and (relative standard deviation in %)."""
        return idim_table(self, digits=digits)

    def _index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no parameter {name!r}; the parameters are {', '.join(map(repr, self.names))}") from None

    def __getitem__(self, name: str):
        """The estimate of parameter `name` (float for an unbatched concrete result)."""
        return _scalar(self.theta[..., self._index(name)])

    @x64
    def param(self, name: str) -> ParamEstimate:
        """`ParamEstimate(value, std, rel_std)` of parameter `name`.

        Example:
            >>> import numpy as np
            >>> from jaxsdp import idim_ls
            >>> X = np.c_[np.arange(10.0), np.ones(10)]
            >>> res = idim_ls(2 * X[:, 0] + 1 + 0.01 * np.cos(np.arange(10.0)), X, names=("a", "b"))
            >>> round(res["a"], 2), res.param("a").std > 0
            (2.0, True)
        """
        i = self._index(name)
        return ParamEstimate(*(_scalar(a[..., i]) for a in (self.theta, self.std, self.rel_std)))

    @x64
    def as_dict(self) -> dict:
        """`{name: estimate}` in parameter order."""
        return {n: self[n] for n in self.names}


def _scalar(a):
    if isinstance(a, jax.core.Tracer) or jnp.ndim(a) != 0:
        return a
    return float(a)


@x64
def idim_table(result: IDIMResult, *, digits: int = 4) -> str:
    r"""Format an `IDIMResult` as text, in the layout of the paper's Table 1.

    One line per parameter, `name  value  (rel. std %)`, with the relative
    standard deviation $100 std_i / |\theta_i|$ in %; then the residual
    standard deviation $\sigma$ (units of $y$) and degrees of freedom $N - p$, the
    relative error $100 \|y - X \theta\| / \|y\|$ (%), the condition number of
    $X$, and for a `"hac"` covariance its Newey-West lag. `digits`: decimals
    of the estimates. Same as `result.table(digits=...)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import idim_ls, idim_table
        >>> t = np.linspace(0.0, 1.0, 50)
        >>> res = idim_ls(3.0 * t + 0.5 + 0.01 * np.sin(40 * t), np.c_[t, np.ones(50)], names=("k", "c"))
        >>> print(idim_table(res, digits=3))  # doctest: +ELLIPSIS
        parameter  estimate  (rel. std %)
        k             3.000  (0.1... %)
        c             0.500  (0.4... %)
        sigma = 0.007..., dof = 48
        relative error 100*||y - X theta||/||y|| = 0.3... %
        cond(X) = 4.31
    """
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
    if result.cov_type == "hac":
        lines.append(f"covariance: Newey-West (Bartlett), lag {float(result.lag):.1f} samples")
    return "\n".join(lines)


def bartlett_meat(g, bandwidth):
    """Sum over |l| < N of w(l) * sum_t g_t g_{t-l}^T with w(l) = max(0, 1 - |l| / bandwidth).

    `g`: scores, shape `(N, p)`. All lag products through one FFT (linear, not
    circular: zero padding to 2N), so `bandwidth` may be a traced value.
    """
    n = g.shape[0]
    f = jnp.fft.rfft(g, n=2 * n, axis=0)
    cross = jnp.fft.irfft(f[:, :, None] * jnp.conj(f[:, None, :]), n=2 * n, axis=0)  # index l: sum g_t g_{t-l}
    lags = jnp.abs(jnp.fft.fftfreq(2 * n, 1.0 / (2 * n)))
    w = jnp.clip(1.0 - lags / bandwidth, 0.0, None)
    return jnp.einsum("l,lab->ab", w, cross)


def andrews_bandwidth(g):
    """Andrews (1991) automatic Bartlett bandwidth from AR(1) fits of each score column.

    alpha = sum_a 4 rho_a^2 s_a^4 / ((1 - rho_a)^6 (1 + rho_a)^2) / sum_a s_a^4 / (1 - rho_a)^4,
    bandwidth = 1.1447 (alpha N)^(1/3), clipped to [1, N] (rho_a clipped to +-0.99).
    """
    n = g.shape[0]
    rho = jnp.sum(g[1:] * g[:-1], axis=0) / jnp.sum(g[:-1] ** 2, axis=0)
    rho = jnp.clip(rho, -0.99, 0.99)
    s2 = jnp.mean((g[1:] - rho * g[:-1]) ** 2, axis=0)
    num = jnp.sum(4 * rho**2 * s2**2 / ((1 - rho) ** 6 * (1 + rho) ** 2))
    den = jnp.sum(s2**2 / (1 - rho) ** 4)
    return jnp.clip(1.1447 * (num / den * n) ** (1 / 3), 1.0, n)


def hac_covariance(g, b_inv, lag, n: int, p: int, groups: int = 1):
    """The Newey-West sandwich N/(N-p) b^-1 S b^-T (symmetrised), S the Bartlett-weighted lag products of the
    scores g (N, p) (`bartlett_meat`) with bandwidth `lag + 1`, or Andrews' automatic one when `lag` is NaN;
    returns (covariance, the lag used).

    `groups` > 1: the rows are `groups` equations at each instant, stacked instant by instant (row
    t * groups + j); the scores are summed over each instant's equations before the lag products, so that the
    lags count instants and every equation's correlation with the others at the same and nearby instants enters
    S (statsmodels' "hac-groupsum" with the instant as the time index)."""
    if groups > 1:
        g = g.reshape(-1, groups, g.shape[-1]).sum(axis=1)
    bw = jnp.where(jnp.isnan(lag), andrews_bandwidth(g), lag + 1.0)
    cov_m = n / (n - p) * (b_inv @ bartlett_meat(g, bw) @ b_inv.T)
    return 0.5 * (cov_m + cov_m.T), bw - 1.0


def estimate_fields(y, theta, fit, cov_m, sigma2, lag) -> dict:
    """The `IDIMResult` array fields of an estimate `theta` with fit X theta and covariance `cov_m` (the
    condition numbers are the caller's)."""
    residuals = y - fit
    std = jnp.sqrt(jnp.diag(cov_m))
    return dict(
        theta=theta,
        std=std,
        rel_std=100 * std / jnp.abs(theta),
        sigma=jnp.sqrt(sigma2),
        cov=cov_m,
        residuals=residuals,
        fit=fit,
        relative_error=100 * jnp.linalg.norm(residuals) / jnp.linalg.norm(y),
        lag=lag,
    )


@jax.custom_batching.sequential_vmap
def _cond_one(r):
    s = jnp.linalg.svd(r, compute_uv=False)
    return s[0] / s[-1]


def _cond(r):
    """cond of a matrix from its p x p triangle R (the SVD of a tall X made XLA allocate an N x N workspace:
    583 GB for 270,000 stacked robot rows). A diagnostic, not differentiated; under `vmap` one unbatched SVD per
    problem (a batched LAPACK call can deadlock XLA-CPU: `jaxsdp._linalg`)."""
    return _cond_one(jax.lax.stop_gradient(r))


@jax.jit(static_argnames=("cov", "groups"))
def linear_estimate(y, X, Z, lag, *, cov="iid", groups=1):
    """theta = (Z^T X)^-1 Z^T y with its covariance, by QR factorisations (for least squares, Z = X,
    `ls_estimate` is quicker).

    Z = Q R (thin QR), B = Q^T X = Q_B R_B; then theta = R_B^-1 Q_B^T Q^T y,
    (Z^T X)^-1 z_t = B^-1 q_t, and

    - `"iid"`: cov = sigma^2 B^-1 B^-T = sigma^2 R_B^-1 R_B^-T
      (= sigma^2 (Z^T X)^-1 Z^T Z (X^T Z)^-1; sigma^2 (X^T X)^-1 when Z = X);
    - `"hac"`: cov = N/(N-p) B^-1 S B^-T, S the Bartlett-weighted sum of the
      lag products of g_t = q_t e_t (`hac_covariance`); bandwidth `lag + 1`,
      or Andrews' automatic bandwidth when `lag` is NaN; `groups` equations per instant
      (`hac_covariance`: a stacked robot's joints).

    Returns a dict of the `IDIMResult` array fields (and `cond_b`, `cond_z`,
    the condition numbers of B and Z, for the identifiability checks).
    """
    n, p = X.shape
    q, rz = qr_thin(Z)  # LAPACK, or Householder in lax under vmap (jaxsdp._linalg)
    qb, rb = qr_thin(q.T @ X)
    theta = solve_upper(rb, qb.T @ (q.T @ y))
    fit = X @ theta
    rss = jnp.sum((y - fit) ** 2)
    sigma2 = rss / (n - p)
    rb_inv = solve_upper(rb, jnp.eye(p, dtype=X.dtype))
    if cov == "iid":
        cov_m, out_lag = sigma2 * (rb_inv @ rb_inv.T), None
    else:
        cov_m, out_lag = hac_covariance(q * (y - fit)[:, None], rb_inv @ qb.T, lag, n, p, groups)
    out = estimate_fields(y, theta, fit, cov_m, sigma2, out_lag)
    return out | dict(cond=_cond(qr_r(X)), cond_b=_cond(rb), cond_z=_cond(rz))


@jax.jit(static_argnames=("cov", "groups"))
def ls_estimate(y, X, lag, *, cov="iid", groups=1):
    """`linear_estimate` for Z = X (least squares) without forming Q: theta and the triangle R of X = QR from
    `jaxsdp._linalg.tall_lstsq` (the semi-normal equations with a refinement step when the column-scaled X is well
    conditioned, else a Householder QR of [X | y]; Householder in lax under `vmap`), cov = sigma^2 R^-1 R^-T; for
    the HAC covariance Q = X R^-1. On the stacked robot regressor (270,000 x 58) a fraction of the Householder QR's
    time (`benchmarks/robot_stacked.py`), the same estimate to 2e-13 relative there."""
    n, p = X.shape
    theta, r = tall_lstsq(X, y)
    fit = X @ theta
    sigma2 = jnp.sum((y - fit) ** 2) / (n - p)
    r_inv = solve_upper(r, jnp.eye(p, dtype=X.dtype))
    if cov == "iid":
        cov_m, out_lag = sigma2 * (r_inv @ r_inv.T), None
    else:
        cov_m, out_lag = hac_covariance((X @ r_inv) * (y - fit)[:, None], r_inv, lag, n, p, groups)
    return estimate_fields(y, theta, fit, cov_m, sigma2, out_lag) | dict(cond=_cond(r))


def check_linear(y, X, names):
    """`(y, X, names)` of a regression checked (`X` may be a `Regressors`): finite, more rows than columns."""
    if isinstance(X, Regressors):
        if names is None:
            names = X.names
        X = X.X
    y, X = check_regression(y, X)
    n, p = X.shape
    if n <= p:
        raise ValueError(f"`X` needs more rows than columns; got shape {(n, p)}")
    return y, X, check_names(names, p)


def check_cov(cov, lag):
    """Validate the covariance options; returns the `lag` argument of `linear_estimate` (NaN: automatic)."""
    if cov not in COV_TYPES:
        raise ValueError(f"`cov` must be one of {COV_TYPES}; got {cov!r}")
    if lag is None:
        return jnp.asarray(jnp.nan, dtype=jnp.float64)
    if cov != "hac":
        raise ValueError("`lag` is only used with cov='hac'")
    if isinstance(lag, bool) or not isinstance(lag, (int, float, np.integer, np.floating)) or not 0 <= lag < np.inf:
        raise ValueError(f"`lag` must be a finite number >= 0 (samples); got {lag!r}")
    return jnp.asarray(float(lag), dtype=jnp.float64)


def rank_checked(name, c, n, p, message="is rank deficient"):
    """Raise ValueError if the condition number `c` shows a numerically rank-deficient matrix."""
    return check_value(
        name,
        c,
        lambda c: ~(c < 1 / (max(n, p) * np.finfo(np.float64).eps)),
        f"{message} (shape {(n, p)}); the parameters are not identifiable",
    )


@x64
def idim_ls(
    y: ArrayLike,
    X: ArrayLike | Regressors,
    *,
    names: Sequence[str] | None = None,
    cov: Literal["iid", "hac"] = "iid",
    lag: float | None = None,
) -> IDIMResult:
    r"""Ordinary least squares $\hat\theta = \arg\min \|y - X \theta\|_2$.

    Solved through the triangle $R$ of $X = QR$ ($R^T R = X^T X$): when the
    column-scaled $X$ is well conditioned (condition number below $10^4$), by the
    semi-normal equations with one refinement step: $R = R_s D$ with $R_s$ the
    Cholesky factor of $D^{-1} X^T X D^{-1}$ ($D$ the column norms),
    $\hat\theta_0 = R^{-1} R^{-T} X^T y$ and
    $\hat\theta = \hat\theta_0 + R^{-1} R^{-T} X^T (y - X \hat\theta_0)$, four passes
    over $X$ (as Björck's corrected semi-normal equations, with $R$ from Cholesky
    instead of QR: within the error bound of a backward-stable solver there, as
    `tests/test_linalg.py` checks); otherwise by a Householder QR of $[X | y]$. Then
    $(X^T X)^{-1} = R^{-1} R^{-T}$ by triangular solves (no explicit inverse of $X^T X$).

    **Covariance** (`cov`):

    - `"iid"` (default, the paper's eq. 12): $\hat\sigma^2 (X^T X)^{-1}$, valid
      for white residuals.
    - `"hac"`: Newey-West sandwich $N/(N-p) (X^T X)^{-1} S (X^T X)^{-1}$ with
      $S = \sum_l w(l) \sum_t x_t e_t e_{t-l} x_{t-l}^T$, Bartlett weights
      $w(l) = 1 - |l|/(lag + 1)$; `lag` in samples, or None for Andrews' (1991)
      automatic AR(1) bandwidth. For serially correlated residuals (closed
      loop, filtered and decimated data).

    **Arguments:**

    - `y`: measured force/torque, shape `(N,)`.
    - `X`: regressors, shape `(N, p)` with `N > p` and full column rank, or a
      `Regressors` (its names are used unless `names` is given).
    - `names`: parameter names (default `theta1, theta2, ...`).
    - `cov`, `lag`: see above.

    **Returns:** an `IDIMResult`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import idim_ls
        >>> t = np.linspace(0.0, 1.0, 50)
        >>> res = idim_ls(3.0 * t + 0.5 + 0.01 * np.sin(40 * t), np.c_[t, np.ones(50)], names=("k", "c"))
        >>> round(res["k"], 2), round(res["c"], 2)
        (3.0, 0.5)
    """
    y, X, names = check_linear(y, X, names)
    n, p = X.shape
    lag_arg = check_cov(cov, lag)

    out = ls_estimate(y, X, lag_arg, cov=cov)
    out["cond"] = rank_checked("X", out["cond"], n, p)
    return IDIMResult(**out, names=names, dof=n - p, cov_type=cov)
