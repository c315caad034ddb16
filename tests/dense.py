"""Independent dense references for the state-space kernels (numpy/scipy only).

The model of `jaxsdp._kalman.general` is written in terms of the latent vector
u = (s_0, w_1..w_N), s_0 ~ N(x0, P0 I), eta_t = C w_t with Q = C C^T and
w_t ~ N(0, I), so that the stacked states are s = A u (linear in u). All
posterior quantities are computed in the well-conditioned precision form of
u, never by inverting the (ill-conditioned, diffuse) joint prior covariance.
"""

import numpy as np
import scipy.linalg as sla


def _latent_map(F, Q, N):
    """A (N n, m) with s = A u, and the latent prior variances d (m,)."""
    n = F.shape[0]
    evals, evecs = np.linalg.eigh(Q)
    keep = evals > 1e-300
    C = evecs[:, keep] * np.sqrt(evals[keep])
    r = C.shape[1]
    A = np.zeros((N * n, n + N * r))
    Ft = np.eye(n)
    for t in range(N):  # s_t = F^t s_0 + sum_{j<=t} F^{t-j} C w_j
        Ft = F @ Ft
        A[t * n : (t + 1) * n, :n] = Ft
        G = np.eye(n)
        for j in range(t, -1, -1):
            if r:
                A[t * n : (t + 1) * n, n + j * r : n + (j + 1) * r] = G @ C
            G = G @ F
    return A, r


def _stacked_rows(H):
    N, n = H.shape
    Hs = np.zeros((N, N * n))
    for t in range(N):
        Hs[t, t * n : (t + 1) * n] = H[t]
    return Hs


def dense_posterior(y, H, F, Q, P0, x0):
    """Joint Gaussian posterior of s_1..s_N (observation variance 1).

    Returns (mean (N, n), cov (N n, N n), prior mean (N n,), prior cov, stacked H (N, N n)).
    """
    N, n = H.shape
    A, r = _latent_map(F, Q, N)
    prior_mean_u = np.concatenate([x0, np.zeros(N * r)])
    prior_var_u = np.concatenate([np.full(n, P0), np.ones(N * r)])
    obs = ~np.isnan(y)
    Hs = _stacked_rows(H)
    B = Hs[obs] @ A
    Lam = np.diag(1.0 / prior_var_u) + B.T @ B
    cf = sla.cho_factor(Lam)
    mu_u = sla.cho_solve(cf, prior_mean_u / prior_var_u + B.T @ y[obs])
    cov_u = sla.cho_solve(cf, np.eye(A.shape[1]))
    return (A @ mu_u).reshape(N, n), A @ cov_u @ A.T, A @ prior_mean_u, (A * prior_var_u) @ A.T, Hs


def dense_loglik_u(y, H, F, Q, P0, x0, sigma2):
    """log N(y_obs; H s_prior, sigma2 (B D B^T + I)) by the determinant lemma and Woodbury in u.

    Accurate for a diffuse P0 = 1e5, where a dense multivariate normal of y is too ill-conditioned.
    """
    N, n = H.shape
    A, r = _latent_map(F, Q, N)
    obs = ~np.isnan(y)
    B = _stacked_rows(H)[obs] @ A
    d = np.concatenate([np.full(n, P0), np.ones(N * r)])
    e = y[obs] - B @ np.concatenate([x0, np.zeros(N * r)])
    Bs = B * np.sqrt(d)
    cf = sla.cho_factor(np.eye(A.shape[1]) + Bs.T @ Bs)
    logdet = 2 * np.sum(np.log(np.diag(cf[0])))
    w = Bs.T @ e
    quad = e @ e - w @ sla.cho_solve(cf, w)
    return -0.5 * (obs.sum() * np.log(2 * np.pi * sigma2) + logdet + quad / sigma2)
