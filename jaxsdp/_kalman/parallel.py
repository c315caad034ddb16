"""Parallel-in-time Kalman filter and fixed-interval smoother (associative scans), scalar observations.

The model of `jaxsdp._kalman.general` (sigma^2 = 1, concentrated out later),

    s_k = F_k s_{k-1} + eta_k,  eta_k ~ N(0, Q_k),      y_k = h_k . s_k + e_k,  e_k ~ N(0, 1),

with s_0 ~ N(x0, P0), computed with O(log N) depth by parallel prefix scans (`jaxsdp._scan.prefix_scan`;
Särkkä and García-Fernández, "Temporal parallelization of Bayesian
smoothers", IEEE TAC 66(1), 2021).

**Filter.** Sample k contributes the element (A, b, C, eta, J): the Gaussian
p(s_k | s_{k-1}, y_k) = N(A s_{k-1} + b, C) and the information
eta, J of y_k about s_{k-1}. With S = 1 + h.Q h and K = Q h / S:

    A = (I - K h^T) F,   b = K y,   C = (I - K h^T) Q (I - K h^T)^T + K K^T,
    eta = F^T h y / S,   J = F^T h h^T F / S,

and for the first sample (A, b, C) = (0, s_{1|1}, P_{1|1}) from the prior,
eta = J = 0. A missing y_k is h_k = 0. Two elements combine as

    M = I + C_i J_j
    A = A_j M^{-1} A_i,     b = A_j M^{-1} (b_i + C_i eta_j) + b_j,   C = A_j M^{-1} C_i A_j^T + C_j,
    eta = A_i^T M^{-T} (eta_j - J_j b_i) + eta_i,                    J = A_i^T M^{-T} J_j A_i + J_i,

and the prefix combination up to k holds the filtered s_{k|k}, P_{k|k} in (b, C).
No step inverts Q (IRW's is singular) or P0: M = I + C J has determinant
>= 1 (C, J positive semi-definite), and M^{-1} is written out in closed form
for n <= 2, by unrolled Gauss-Jordan elimination with partial pivoting above.

**Likelihood.** The one-step predictions s_{k|k-1} = F_k s_{k-1|k-1}, P_{k|k-1} =
F_k P_{k-1|k-1} F_k^T + Q_k follow elementwise from the filtered moments, and
with them the innovations v_k = y_k - h_k.s_{k|k-1} and f_k = 1 + h_k.P_{k|k-1} h_k:
the exact concentrated likelihood whatever the rank of Q (no element carries
a log-normaliser that would need Q^{-1}).

**Smoother.** Element k: E_k = P_{k|k} F_{k+1}^T P_{k+1|k}^{-1} (a Cholesky solve),
g_k = s_{k|k} - E_k s_{k+1|k}, L_k = (I - E_k F_{k+1}) P_{k|k} (I - E_k F_{k+1})^T +
E_k Q_{k+1} E_k^T (the Joseph form of the sequential smoother); the last is
(0, s_{N|N}, P_{N|N}). Combined from the end, (E_i E_j, E_i g_j + g_i,
E_i L_j E_i^T + L_i), the suffix combination from k holds s_{k|N}, P_{k|N}.

All matrix work is small-block arithmetic written out over the time axis
(elementwise products and sums, unrolled solves): no LAPACK call is batched
over time, so the path cannot stall in jaxlib's batched CPU kernels. The
covariance parts never depend on y, so `jax.vmap` over series with a shared
regressor computes them once (JAX batches only what depends on y).
"""

from typing import NamedTuple

import jax.numpy as jnp

from .._scan import prefix_scan


class ParallelOutput(NamedTuple):
    """Per-sample moments (leading axis = time) of `parallel_filter_smoother`."""

    x_pred: jnp.ndarray  # (N, n)  s_{k|k-1}
    P_pred: jnp.ndarray  # (N, n, n)
    x_filt: jnp.ndarray  # (N, n)  s_{k|k}
    P_filt: jnp.ndarray  # (N, n, n)
    x_smooth: jnp.ndarray  # (N, n)  s_{k|N} (None-like zeros if not smoothed)
    P_smooth: jnp.ndarray  # (N, n, n)
    innov: jnp.ndarray  # (N,) v_k, 0 where y is missing
    innov_var: jnp.ndarray  # (N,) f_k, 1 where y is missing
    observed: jnp.ndarray  # (N,) bool
    P_last_pred: jnp.ndarray  # (n, n) P_{N+1|N}: the prediction one step beyond the data


def _mm(A, B):
    """Batched small matrix product (..., n, m) @ (..., m, p), as elementwise products and a sum."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


def _mv(A, x):
    return jnp.sum(A * x[..., None, :], axis=-1)


def _t(A):
    return jnp.swapaxes(A, -1, -2)


def _sym(A):
    return 0.5 * (A + _t(A))


def _outer(a, b):
    return a[..., :, None] * b[..., None, :]


def _eye_like(A):
    return jnp.broadcast_to(jnp.eye(A.shape[-1], dtype=A.dtype), A.shape)


def _inv_i_plus(C, J):
    """(I + C J)^{-1} for positive semi-definite C, J (..., n, n).

    n = 1, 2 in closed form, with det(I + C J) = 1 + tr(C J) + det C det J >= 1
    summed from non-negative terms (no cancellation); n >= 3 by `gauss_jordan_inverse`.
    """
    n = C.shape[-1]
    CJ = _mm(C, J)
    if n == 1:
        return 1.0 / (1.0 + CJ)
    if n == 2:
        det2 = lambda X: jnp.maximum(X[..., 0, 0] * X[..., 1, 1] - X[..., 0, 1] * X[..., 1, 0], 0.0)
        d = 1.0 + jnp.maximum(CJ[..., 0, 0] + CJ[..., 1, 1], 0.0) + det2(C) * det2(J)
        a, b, c, e = 1.0 + CJ[..., 0, 0], CJ[..., 0, 1], CJ[..., 1, 0], 1.0 + CJ[..., 1, 1]
        row0 = jnp.stack([e, -b], axis=-1)
        row1 = jnp.stack([-c, a], axis=-1)
        return jnp.stack([row0, row1], axis=-2) / d[..., None, None]
    return gauss_jordan_inverse(_eye_like(CJ) + CJ)


def gauss_jordan_inverse(M):
    """M^{-1} of a batch (..., n, n) by Gauss-Jordan elimination with partial pivoting, unrolled over n.

    Rows are kept as a Python list of (..., n) arrays so each step is elementwise
    over the batch (jaxsdp's own small solve: the batched LAPACK kernels are what
    the parallel path must avoid).
    """
    n = M.shape[-1]
    eye = jnp.eye(n, dtype=M.dtype)
    rows = [jnp.concatenate([M[..., i, :], jnp.broadcast_to(eye[i], M.shape[:-1])], axis=-1) for i in range(n)]
    for j in range(n):
        # partial pivoting: the row p >= j with the largest |entry| in column j swaps with row j
        p = jnp.argmax(jnp.stack([jnp.abs(rows[i][..., j]) for i in range(j, n)], axis=-1), axis=-1) + j
        pivot = rows[j]
        for i in range(j + 1, n):
            pivot = jnp.where((p == i)[..., None], rows[i], pivot)
        for i in range(j + 1, n):
            rows[i] = jnp.where((p == i)[..., None], rows[j], rows[i])
        rows[j] = pivot / pivot[..., j : j + 1]
        for i in range(n):
            if i != j:
                rows[i] = rows[i] - rows[i][..., j : j + 1] * rows[j]
    return jnp.stack([r[..., n:] for r in rows], axis=-2)


def unrolled_cholesky(A):
    """Lower Cholesky factor L of symmetric positive-definite A (..., n, n), A = L L^T, unrolled over n.

    Elementwise over any batch: no LAPACK call (batched LAPACK kernels are
    what the parallel path and the vmapped Monte Carlo kernels avoid).
    Returns L as an array (..., n, n).
    """
    n = A.shape[-1]
    L = _cholesky_rows(A)
    zero = jnp.zeros_like(A[..., 0, 0])
    return jnp.stack([jnp.stack([L[i][j] if j <= i else zero for j in range(n)], axis=-1) for i in range(n)], axis=-2)


def _cholesky_rows(A):
    n = A.shape[-1]
    L = [[None] * n for _ in range(n)]
    for j in range(n):
        s = A[..., j, j] - sum(L[j][k] ** 2 for k in range(j))
        L[j][j] = jnp.sqrt(s)
        for i in range(j + 1, n):
            L[i][j] = (A[..., i, j] - sum(L[i][k] * L[j][k] for k in range(j))) / L[j][j]
    return L


def unrolled_cho_solve(A, B):
    """A^{-1} B for symmetric positive-definite A (..., n, n), B (..., n, m), batched or not.

    Cholesky A = L L^T unrolled (elementwise over any batch), forward then back
    substitution row by row; no explicit inverse and no LAPACK call (the
    sequential smoother's small solve too, `jaxsdp._kalman.general`).
    """
    n = A.shape[-1]
    L = _cholesky_rows(A)
    Y = [None] * n
    for i in range(n):
        Y[i] = (B[..., i, :] - sum(L[i][k][..., None] * Y[k] for k in range(i))) / L[i][i][..., None]
    X = [None] * n
    for i in reversed(range(n)):
        X[i] = (Y[i] - sum(L[k][i][..., None] * X[k] for k in range(i + 1, n))) / L[i][i][..., None]
    return jnp.stack(X, axis=-2)


class _FilterElement(NamedTuple):
    A: jnp.ndarray
    b: jnp.ndarray
    C: jnp.ndarray
    eta: jnp.ndarray
    J: jnp.ndarray


def _combine_filter(ei: _FilterElement, ej: _FilterElement) -> _FilterElement:
    """ei (earlier) then ej (later): Särkkä and García-Fernández's filtering operator."""
    Minv = _inv_i_plus(ei.C, ej.J)  # (I + C_i J_j)^{-1}
    AjM = _mm(ej.A, Minv)
    A = _mm(AjM, ei.A)
    b = _mv(AjM, ei.b + _mv(ei.C, ej.eta)) + ej.b
    C = _sym(_mm(_mm(AjM, ei.C), _t(ej.A))) + ej.C
    AiMt = _mm(_t(ei.A), _t(Minv))  # A_i^T (I + J_j C_i)^{-1}
    eta = _mv(AiMt, ej.eta - _mv(ej.J, ei.b)) + ei.eta
    J = _sym(_mm(_mm(AiMt, ej.J), ei.A)) + ei.J
    return _FilterElement(A, b, C, eta, J)


class _SmootherElement(NamedTuple):
    E: jnp.ndarray
    g: jnp.ndarray
    L: jnp.ndarray


def _combine_smoother(ei: _SmootherElement, ej: _SmootherElement) -> _SmootherElement:
    """ei (earlier) applied after ej (later): s_{i|N} = E_i s_{i+1|N} + g_i, and so on."""
    return _SmootherElement(_mm(ei.E, ej.E), _mv(ei.E, ej.g) + ei.g, _sym(_mm(_mm(ei.E, ej.L), _t(ei.E))) + ei.L)


def step_systems(F, Q, advance, N):
    """Per-sample (N, n, n) F_k, Q_k: (I, 0) where `advance` is False (tied SDP states)."""
    Fk = jnp.broadcast_to(F, (N, *F.shape))
    Qk = jnp.broadcast_to(Q, (N, *Q.shape))
    if advance is None:
        return Fk, Qk
    adv = advance[:, None, None]
    return jnp.where(adv, Fk, jnp.eye(F.shape[0], dtype=F.dtype)), jnp.where(adv, Qk, 0.0)


def parallel_filter(y, H, F, Q, x0, P0, *, advance=None, complete: bool = False):
    """Filtered and predicted moments by one associative scan. Returns
    (x_pred, P_pred, x_filt, P_filt, innov, innov_var, observed, Fk, Qk).

    `complete`: the caller knows y has no missing sample; then nothing but the
    means depends on y (under `vmap` over y the covariance work is done once).
    """
    N, n = H.shape
    if complete:
        observed, h, y0 = jnp.ones(N, bool), H, y
    else:
        observed = ~jnp.isnan(y)
        h = jnp.where(observed[:, None], H, 0.0)
        y0 = jnp.where(observed, y, 0.0)
    Fk, Qk = step_systems(F, Q, advance, N)
    eye = jnp.eye(n, dtype=H.dtype)

    # samples 2..N: the conditional of s_k given s_{k-1} and y_k
    Qh = _mv(Qk, h)
    S = 1.0 + jnp.sum(h * Qh, axis=-1)
    K = Qh / S[:, None]
    IKh = eye - _outer(K, h)
    A = _mm(IKh, Fk)
    b = K * y0[:, None]
    C = _sym(_mm(_mm(IKh, Qk), _t(IKh))) + _outer(K, K)
    Fh = _mv(_t(Fk), h)
    eta = Fh * (y0 / S)[:, None]
    J = _outer(Fh, Fh) / S[:, None, None]

    # sample 1: the filtered moments from the prior
    m_pred = Fk[0] @ x0
    P_pred0 = _sym(Fk[0] @ P0 @ Fk[0].T + Qk[0])
    Ph = P_pred0 @ h[0]
    K0 = Ph / (1.0 + h[0] @ Ph)
    I0 = eye - jnp.outer(K0, h[0])
    m1 = m_pred + K0 * (y0[0] - h[0] @ m_pred)
    P1 = _sym(I0 @ P_pred0 @ I0.T + jnp.outer(K0, K0))
    elems = _FilterElement(A.at[0].set(0.0), b.at[0].set(m1), C.at[0].set(P1), eta.at[0].set(0.0), J.at[0].set(0.0))
    out = prefix_scan(_combine_filter, elems)
    x_filt, P_filt = out.b, out.C

    x_prev = jnp.concatenate([x0[None], x_filt[:-1]])
    P_prev = jnp.concatenate([P0[None], P_filt[:-1]])
    x_pred = _mv(Fk, x_prev)
    P_pred = _sym(_mm(_mm(Fk, P_prev), _t(Fk))) + Qk
    v = y0 - jnp.sum(h * x_pred, axis=-1)
    f = 1.0 + jnp.sum(h * _mv(P_pred, h), axis=-1)
    return x_pred, P_pred, x_filt, P_filt, v, f, observed, Fk, Qk


def parallel_smoother(x_filt, P_filt, x_pred, P_pred, Fk, Qk):
    """Smoothed moments s_{k|N}, P_{k|N} by one reverse associative scan (see the module docstring)."""
    n = x_filt.shape[-1]
    eye = jnp.eye(n, dtype=x_filt.dtype)
    Fn, Qn, Pn = Fk[1:], Qk[1:], P_pred[1:]
    Pf, xf = P_filt[:-1], x_filt[:-1]
    E = _t(unrolled_cho_solve(Pn, _mm(Fn, Pf)))  # P_{k|k} F^T P_{k+1|k}^{-1}
    g = xf - _mv(E, x_pred[1:])
    IEF = eye - _mm(E, Fn)
    L = _sym(_mm(_mm(IEF, Pf), _t(IEF))) + _sym(_mm(_mm(E, Qn), _t(E)))
    elems = _SmootherElement(
        jnp.concatenate([E, jnp.zeros_like(E[:1])]),
        jnp.concatenate([g, x_filt[-1:]]),
        jnp.concatenate([L, P_filt[-1:]]),
    )
    out = prefix_scan(_combine_smoother, elems, reverse=True)
    return out.g, out.L


def parallel_filter_smoother(
    y, H, F, Q, x0, P0, *, advance=None, smooth: bool = True, complete: bool = False
) -> ParallelOutput:
    """Filter (and, if `smooth`, fixed-interval smoother) moments by associative scans.

    `y` (N,) with NaN for missing samples, `H` (N, n) observation rows, `F`, `Q`
    (n, n), `x0` (n,), `P0` (n, n); `advance` (N,) bool as in `jaxsdp._kalman.general`.
    """
    x_pred, P_pred, x_filt, P_filt, v, f, observed, Fk, Qk = parallel_filter(
        y, H, F, Q, x0, P0, advance=advance, complete=complete
    )
    P_last = _sym(F @ P_filt[-1] @ F.T + Q)
    if smooth:
        xs, Ps = parallel_smoother(x_filt, P_filt, x_pred, P_pred, Fk, Qk)
    else:
        xs, Ps = jnp.zeros_like(x_filt), jnp.zeros_like(P_filt)
    return ParallelOutput(x_pred, P_pred, x_filt, P_filt, xs, Ps, v, f, observed, P_last)
