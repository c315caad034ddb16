"""LS and IV estimates without LAPACK, for kernels vmapped over many regressions (Monte Carlo).

`linear_estimate` solves by thin QR (LAPACK `geqrf`). Batched under `vmap`,
several such calls in one XLA-CPU program were seen to wedge the runtime's
thread pool (0 % CPU, never returning; reproduced with two QRs of an
identified EMPS model's regressors in a vmap of 6-16 runs, not with the
unrolled solves below). `unrolled_estimate` computes the same quantities
with small p x p factorisations unrolled over p (elementwise over any batch):

- columns scaled to unit norm (s_j = 1 / ||x_j||, likewise Z), so the Gram
  matrices are well scaled;
- LS (Z = X): Cholesky G = Xs^T Xs = L L^T, theta_s = G^-1 Xs^T y plus one
  step of iterative refinement (semi-normal equations: the accuracy of QR
  for cond(Xs) up to ~1e6);
- IV: B = Zs^T Xs inverted by Gauss-Jordan with partial pivoting, one
  refinement step;
- covariances as in `linear_estimate`: `"iid"` sigma^2 B^-1 Zs^T Zs B^-T
  (sigma^2 G^-1 for LS); `"hac"` N/(N-p) b^-1 S b^-T with the scores
  g_t = q_t e_t in the orthonormal basis q_t = L_z^-1 z_t of Z (the thin-QR
  Q up to column signs, which the Bartlett meat and Andrews' bandwidth do
  not see), b = q^T X.

Agrees with `linear_estimate` to ~1e-10 (relative) on the EMPS regressions
(tested); the condition numbers are not computed.
"""

import jax.numpy as jnp

from .._kalman.parallel import gauss_jordan_inverse, unrolled_cho_solve, unrolled_cholesky
from .ls import estimate_fields, hac_covariance


def _forward(L, B):
    """L^-1 B for lower-triangular L (p, p) and B (p, m), unrolled over p."""
    p = L.shape[-1]
    rows = []
    for i in range(p):
        rows.append((B[i] - sum(L[i, k] * rows[k] for k in range(i))) / L[i, i])
    return jnp.stack(rows)


def unrolled_estimate(y, X, Z, lag, *, cov="iid"):
    """theta = (Z^T X)^-1 Z^T y (Z = X: least squares) and its covariance, no LAPACK (see the module).

    `y` (N,), `X` and `Z` (N, p), `lag` (NaN: Andrews' bandwidth; used with
    `cov="hac"`), `cov` `"iid"` or `"hac"`. Returns a dict with `theta`,
    `std`, `rel_std` (%), `sigma`, `cov`, `residuals`, `fit`,
    `relative_error` (%), `lag` (None for `"iid"`), as `linear_estimate`.
    """
    n, p = X.shape
    ls = Z is X
    sx = 1.0 / jnp.linalg.norm(X, axis=0)
    Xs = X * sx
    Zs = Xs if ls else Z * (1.0 / jnp.linalg.norm(Z, axis=0))
    if ls:
        G = Xs.T @ Xs
        solve = lambda v: unrolled_cho_solve(G, v[:, None])[:, 0]  # noqa: E731
    else:
        B_inv = gauss_jordan_inverse(Zs.T @ Xs)
        solve = lambda v: B_inv @ v  # noqa: E731
    ts = solve(Zs.T @ y)
    ts = ts + solve(Zs.T @ (y - Xs @ ts))  # one step of iterative refinement
    theta = ts * sx
    fit = Xs @ ts
    residuals = y - fit
    sigma2 = residuals @ residuals / (n - p)
    if cov == "iid":
        if ls:
            cov_s = sigma2 * unrolled_cho_solve(G, jnp.eye(p, dtype=X.dtype))
        else:
            cov_s = sigma2 * (B_inv @ (Zs.T @ Zs) @ B_inv.T)
        out_lag = None
    else:
        Lz = unrolled_cholesky(Zs.T @ Zs)
        q = _forward(Lz, Zs.T).T  # (N, p), orthonormal columns spanning Z
        cov_s, out_lag = hac_covariance(q * residuals[:, None], gauss_jordan_inverse(q.T @ Xs), lag, n, p)
    cov_m = cov_s * sx[:, None] * sx[None, :]
    return estimate_fields(y, theta, fit, 0.5 * (cov_m + cov_m.T), sigma2, out_lag)
