"""Independent dense references for the state-space kernels (numpy/scipy only)."""

import numpy as np
import scipy.linalg as sla


def dense_posterior(y, H, F, Q, P0, x0):
    """Joint Gaussian posterior of s_1..s_N for the model of `jaxsdp._kalman`.

    Latent u = (s_0, w_1..w_N) with s_0 ~ N(x0, P0 I), eta_t = C w_t, Q = C C^T,
    w_t ~ N(0, I); s = a + A u is linear in u, so the posterior is computed in
    the well-conditioned precision form of u and mapped back (no inverse of the
    ill-conditioned joint prior covariance). Returns (mean (N,n), cov (N*n, N*n),
    prior mean a (N*n,), prior cov (N*n, N*n)).
    """
    N, n = H.shape
    evals, evecs = np.linalg.eigh(Q)
    keep = evals > 1e-300
    C = evecs[:, keep] * np.sqrt(evals[keep])
    r = C.shape[1]
    m = n + N * r
    A = np.zeros((N * n, m))
    a = np.zeros(N * n)
    Ft = np.eye(n)
    # s_t = F^t s_0 + sum_{j<=t} F^{t-j} C w_j
    blocks = []
    for t in range(N):
        Ft = F @ Ft
        A[t * n:(t + 1) * n, :n] = Ft @ (np.eye(n) * 1.0)
        a[t * n:(t + 1) * n] = Ft @ x0 - Ft @ x0  # mean handled through u's prior mean
    for t in range(N):
        G = np.eye(n)
        for j in range(t, -1, -1):
            if r:
                A[t * n:(t + 1) * n, n + j * r:n + (j + 1) * r] = G @ C
            G = G @ F
    prior_mean_u = np.concatenate([x0, np.zeros(N * r)])
    prior_var_u = np.concatenate([np.full(n, P0), np.ones(N * r)])
    obs = ~np.isnan(y)
    Hs = np.zeros((N, N * n))
    for t in range(N):
        Hs[t, t * n:(t + 1) * n] = H[t]
    Ho = Hs[obs]
    B = Ho @ A
    Lam = np.diag(1.0 / prior_var_u) + B.T @ B
    rhs = prior_mean_u / prior_var_u + B.T @ y[obs]
    cf = sla.cho_factor(Lam)
    mu_u = sla.cho_solve(cf, rhs)
    cov_u = sla.cho_solve(cf, np.eye(m))
    mean = (A @ mu_u).reshape(N, n)
    cov = A @ cov_u @ A.T
    prior_cov = A @ np.diag(prior_var_u) @ A.T
    return mean, cov, A @ prior_mean_u, prior_cov, Hs


def dense_loglik(y, Hs, prior_mean, prior_cov, sigma2):
    """log N(y_obs; H m, sigma2 (H Sigma H^T + I)) via scipy."""
    from scipy.stats import multivariate_normal

    obs = ~np.isnan(y)
    Ho = Hs[obs]
    cov = sigma2 * (Ho @ prior_cov @ Ho.T + np.eye(obs.sum()))
    return multivariate_normal(mean=Ho @ prior_mean, cov=cov).logpdf(y[obs])


def dense_loglik_u(y, H, F, Q, P0, x0, sigma2):
    """log N(y_obs; H a, sigma2 (B D B^T + I)) evaluated in latent space.

    Uses the matrix determinant lemma and Woodbury identity in the latent u of
    `dense_posterior`, so it stays accurate for a diffuse P0 = 1e5.
    """
    N, n = H.shape
    evals, evecs = np.linalg.eigh(Q)
    keep = evals > 1e-300
    C = evecs[:, keep] * np.sqrt(evals[keep])
    r = C.shape[1]
    m = n + N * r
    A = np.zeros((N * n, m))
    Ft = np.eye(n)
    for t in range(N):
        Ft = F @ Ft
        A[t * n:(t + 1) * n, :n] = Ft
        G = np.eye(n)
        for j in range(t, -1, -1):
            if r:
                A[t * n:(t + 1) * n, n + j * r:n + (j + 1) * r] = G @ C
            G = G @ F
    obs = ~np.isnan(y)
    Hs = np.zeros((N, N * n))
    for t in range(N):
        Hs[t, t * n:(t + 1) * n] = H[t]
    B = Hs[obs] @ A
    d = np.concatenate([np.full(n, P0), np.ones(N * r)])
    mu = np.concatenate([x0, np.zeros(N * r)])
    e = y[obs] - B @ mu
    Bs = B * np.sqrt(d)
    M = np.eye(m) + Bs.T @ Bs
    cf = sla.cho_factor(M)
    logdet = 2 * np.sum(np.log(np.diag(cf[0])))
    w = Bs.T @ e
    quad = e @ e - w @ sla.cho_solve(cf, w)
    k = obs.sum()
    return -0.5 * (k * np.log(2 * np.pi * sigma2) + logdet + quad / sigma2)
