"""Kalman filter and fixed-interval smoother kernels for scalar observations.

Model (observation variance sigma^2 = 1; it is concentrated out later):

    s_k = F s_{k-1} + eta_k,   eta_k ~ N(0, Q)
    y_k = h_k . s_k + e_k,      e_k ~ N(0, 1),         k = 1..N

with s_0 ~ N(x0, P0). Each pass is one `lax.scan` (the smoother with `reverse=True`):

    predict:  s_{k|k-1} = F s_{k-1|k-1},  P_{k|k-1} = F P_{k-1|k-1} F^T + Q
    update:   v_k = y_k - h_k.s_{k|k-1},  f_k = 1 + h_k.P_{k|k-1} h_k,
              K_k = P_{k|k-1} h_k / f_k,  s_{k|k} = s_{k|k-1} + K_k v_k,
              P_{k|k} = (I - K_k h_k^T) P_{k|k-1} (I - K_k h_k^T)^T + K_k K_k^T

Missing observations (NaN) skip the update and are interpolated by the
smoother (Rauch-Tung-Striebel form, see `fixed_interval_smoother`).
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import lax

from .parallel import parallel_filter, parallel_smoother, step_systems, unrolled_cho_solve


class FilterOutput(NamedTuple):
    """Per-sample filter quantities (leading axis = time)."""

    x_pred: jnp.ndarray  # (N, n)  s_{k|k-1}
    P_pred: jnp.ndarray  # (N, n, n)
    x_filt: jnp.ndarray  # (N, n)  s_{k|k}
    P_filt: jnp.ndarray  # (N, n, n)
    innov: jnp.ndarray  # (N,)  v_k (0 where missing)
    innov_var: jnp.ndarray  # (N,)  f_k (1 where missing), in units of sigma^2
    gain: jnp.ndarray  # (N, n)  K_k = P_{k|k-1} h_k / f_k
    observed: jnp.ndarray  # (N,) bool


class SmootherOutput(NamedTuple):
    x_smooth: jnp.ndarray  # (N, n)
    P_smooth_diag: jnp.ndarray  # (N, n)
    P_smooth: jnp.ndarray | None  # (N, n, n) if requested
    row_var: jnp.ndarray | None = None  # (N, r) r_jk P_{k|N} r_jk^T, r_jk = h_k * masks_j, if `rows` given


def _symmetrise(P):
    return 0.5 * (P + P.T)


def _predict(x, P, F, Q):
    return F @ x, _symmetrise(F @ P @ F.T + Q)


def _update(x_pred, P_pred, h, y, observed, r=1.0):
    """Measurement update with observation variance r (1, sigma^2's unit, unless a model says otherwise)."""
    Ph = P_pred @ h
    f = r + h @ Ph
    K = Ph / f
    v = y - h @ x_pred
    # Joseph form keeps P symmetric positive semi-definite.
    IKh = jnp.eye(x_pred.shape[0]) - jnp.outer(K, h)
    P_upd = _symmetrise(IKh @ P_pred @ IKh.T + r * jnp.outer(K, K))
    x_upd = x_pred + K * v
    x = jnp.where(observed, x_upd, x_pred)
    P = jnp.where(observed, P_upd, P_pred)
    v = jnp.where(observed, v, 0.0)
    f = jnp.where(observed, f, 1.0)
    K = jnp.where(observed, K, 0.0)
    return x, P, v, f, K


def _transition(F, Q, adv):
    """(F, Q) when the state advances, (I, 0) when it holds (tied SDP states)."""
    n = F.shape[0]
    return jnp.where(adv, F, jnp.eye(n)), jnp.where(adv, Q, 0.0)


def _advance(advance, N):
    return jnp.ones(N, bool) if advance is None else advance


def kalman_filter(
    y, H, F, Q, x0, P0, *, advance=None, unroll: int = 1, method: str = "sequential", obs_var=None
) -> FilterOutput:
    """Run the filter over y (N,) with observation rows H (N, n).

    NaN entries of y are treated as missing. `advance` (N,) bool, default all
    True: where False, the transition into sample k is the identity with no
    noise (used for tied state values in SDP estimation). `method`
    "parallel": the same moments by an associative scan (`jaxsdp._kalman.parallel`).
    `obs_var`: the observation noise variance r >= 0 in units of sigma^2
    (None: 1, the model above; 0: an exact observation, whose f_k = h_k P_{k|k-1} h_k
    must stay positive: the state noise must reach every observation). Sequential only.
    """
    r = _obs_var(obs_var, method)
    if method == "parallel":
        xp, Pp, xf, Pf, v, f, observed, _, _ = parallel_filter(y, H, F, Q, x0, P0, advance=advance)
        h = jnp.where(observed[:, None], H, 0.0)
        K = jnp.sum(Pp * h[:, None, :], axis=-1) / f[:, None]
        return FilterOutput(xp, Pp, xf, Pf, v, f, K, observed)
    observed = ~jnp.isnan(y)
    y0 = jnp.where(observed, y, 0.0)

    def step(carry, inp):
        x, P = carry
        yk, hk, ok, adv = inp
        x_pred, P_pred = _predict(x, P, *_transition(F, Q, adv))
        x_new, P_new, v, f, K = _update(x_pred, P_pred, hk, yk, ok, r)
        return (x_new, P_new), (x_pred, P_pred, x_new, P_new, v, f, K)

    inputs = (y0, H, observed, _advance(advance, y.shape[0]))
    _, (xp, Pp, xf, Pfd, v, f, K) = lax.scan(step, (x0, P0), inputs, unroll=unroll)
    return FilterOutput(xp, Pp, xf, Pfd, v, f, K, observed)


def _obs_var(obs_var, method):
    """The observation variance of the update: 1.0 (the default model) or the given one (sequential kernels)."""
    if obs_var is None:
        return 1.0
    if method == "parallel":
        raise ValueError("`obs_var`: the parallel kernels have the unit observation variance only")
    return obs_var


def _cho_solve(A, B):
    """Solve A X = B for SPD A (n, n) by Cholesky; no explicit inverse.

    Unrolled below n = 8, where the smoother with it runs 3.5-7x faster than with
    `jax.scipy.linalg.cho_solve`; the library call from n = 8, where it is 6-20 %
    faster (`benchmarks/numerics.py`, section 1).
    """
    if A.shape[0] >= 8:
        return jax.scipy.linalg.cho_solve((jnp.linalg.cholesky(A), True), B)
    return unrolled_cho_solve(A, B)


def fixed_interval_smoother(
    filt: FilterOutput,
    F,
    Q,
    *,
    advance=None,
    full_cov: bool = False,
    rows=None,
    unroll: int = 1,
    method: str = "sequential",
) -> SmootherOutput:
    """Rauch-Tung-Striebel fixed-interval smoother (reverse `lax.scan`).

    With G_k = P_{k|k} F^T P_{k+1|k}^{-1} (a Cholesky solve, never an inverse):

        s_{k|N} = s_{k|k} + G_k (s_{k+1|N} - s_{k+1|k})
        P_{k|N} = (I - G_k F) P_{k|k} (I - G_k F)^T + G_k Q G_k^T + G_k P_{k+1|N} G_k^T

    The covariance recursion is the algebraically equivalent "Joseph" form:
    a sum of positive semi-definite terms, so it does not lose precision by
    cancellation when the diffuse start makes P_{k+1|k} huge (P0 = 1e5).
    `advance` must be the one given to the filter. `method` "parallel": the
    same moments by a reverse associative scan (`jaxsdp._kalman.parallel`).
    `rows = (H, masks)`, H (N, n) and masks (r, n): the variances
    r_jk P_{k|N} r_jk^T of the linear combinations r_jk = H_k * masks_j
    (a signal and its components), computed in the sequential scan without
    storing P_{k|N} (the parallel path has them all anyway).
    """
    H, masks = rows if rows is not None else (None, None)

    def quad(Hk, P):
        R = Hk[None, :] * masks
        return jnp.einsum("rn,nm,rm->r", R, P, R)

    if method == "parallel":
        Fk, Qk = step_systems(F, Q, advance, filt.x_filt.shape[0])
        xs, Ps = parallel_smoother(filt.x_filt, filt.P_filt, filt.x_pred, filt.P_pred, Fk, Qk)
        rv = None if rows is None else jax.vmap(quad)(H, Ps)
        return SmootherOutput(xs, jnp.diagonal(Ps, axis1=1, axis2=2), Ps if full_cov else None, rv)
    n = F.shape[0]
    eye = jnp.eye(n)

    def step(carry, inp):
        xs_next, Ps_next = carry
        xf, Pf, xp_next, Pp_next, adv_next, Hk = inp
        Fk, Qk = _transition(F, Q, adv_next)
        G = _cho_solve(Pp_next, Fk @ Pf).T
        IGF = eye - G @ Fk
        xs = xf + G @ (xs_next - xp_next)
        Ps = _symmetrise(IGF @ Pf @ IGF.T + G @ (Qk + Ps_next) @ G.T)
        out = (xs, jnp.diag(Ps), Ps if full_cov else None, None if rows is None else quad(Hk, Ps))
        return (xs, Ps), out

    xN, PN = filt.x_filt[-1], filt.P_filt[-1]
    adv = _advance(advance, filt.x_filt.shape[0])
    Hin = None if rows is None else H[:-1]
    inputs = (filt.x_filt[:-1], filt.P_filt[:-1], filt.x_pred[1:], filt.P_pred[1:], adv[1:], Hin)
    _, out = lax.scan(step, (xN, PN), inputs, reverse=True, unroll=unroll)
    xs = jnp.concatenate([out[0], xN[None]])
    Pd = jnp.concatenate([out[1], jnp.diag(PN)[None]])
    Pfull = jnp.concatenate([out[2], PN[None]]) if full_cov else None
    rv = None if rows is None else jnp.concatenate([out[3], quad(H[-1], PN)[None]])
    return SmootherOutput(xs, Pd, Pfull, rv)


class Likelihood(NamedTuple):
    r"""Concentrated likelihood of a dynamic linear regression (see `concentrated_loglik`).

    - `loglik`: $-J/2 - (n/2)(\log 2\pi + 1)$; `J`: $\sum \log f_k + n \log(\sum v_k^2/f_k / n)$.
    - `sigma2`: the $\sigma^2$ estimate; `n_used`: the number $n$ of innovations in the sums.
    """

    loglik: jnp.ndarray  # concentrated log-likelihood
    J: jnp.ndarray  # the criterion minimised over NVRs
    sigma2: jnp.ndarray  # sigma^2 estimate
    n_used: jnp.ndarray  # number of innovations in the likelihood


def likelihood_from_sums(slogf, se2, n, sigma2) -> Likelihood:
    """`Likelihood` from the sums over the n innovations used: sum log f_k and sum v_k^2/f_k.

    J = slogf + n log(se2 / n),  loglik = -J/2 - (n/2)(log 2 pi + 1).
    """
    J = slogf + n * jnp.log(se2 / n)
    return Likelihood(-0.5 * J - 0.5 * n * (jnp.log(2 * jnp.pi) + 1.0), J, sigma2, n)


def concentrated_loglik(innov, innov_var, observed, *, burn_in: int, sigma2_burn_in: int) -> Likelihood:
    """Prediction-error decomposition with sigma^2 concentrated out.

    With the innovations v_k and their normalised variances f_k of the
    observed samples after the first `burn_in` observed ones (missing samples do not count: a series that
    starts with gaps still skips its first `burn_in` observations, whose innovations carry the diffuse prior):

        J = sum log f_k + n log( sum v_k^2 / f_k / n ),
        loglik = -J/2 - (n/2)(log 2 pi + 1),

    n the number of terms. `sigma2` = mean(v_k^2/f_k) over the observed
    samples after the first `sigma2_burn_in` observed ones (CAPTAIN's
    convention: burn_in = dim(s) + 1, sigma2_burn_in = dim(s)).
    """
    e2 = innov**2 / innov_var
    rank = jnp.cumsum(observed) - 1  # 0-based rank of each sample among the observed ones
    use = observed & (rank >= burn_in)
    n = jnp.sum(use)
    s = jnp.sum(jnp.where(use, e2, 0.0))
    use2 = observed & (rank >= sigma2_burn_in)
    sigma2 = jnp.sum(jnp.where(use2, e2, 0.0)) / jnp.sum(use2)
    return likelihood_from_sums(jnp.sum(jnp.where(use, jnp.log(innov_var), 0.0)), s, n, sigma2)


def filter_criterion(
    y, H, F, Q, x0, P0, *, burn_in: int, advance=None, method: str = "sequential", obs_var=None
) -> Likelihood:
    """Concentrated likelihood from a filter pass that stores nothing per sample.

    Same quantities as `concentrated_loglik(kalman_filter(...))` (with
    `sigma2_burn_in = burn_in`), but the scan only carries running sums, so it
    is the cheap pass to differentiate when optimising NVRs. `method`
    "parallel": from the associative-scan filter's innovations. `obs_var` as
    `kalman_filter`.
    """
    r = _obs_var(obs_var, method)
    if method == "parallel":
        filt = kalman_filter(y, H, F, Q, x0, P0, advance=advance, method="parallel")
        return concentrated_loglik(filt.innov, filt.innov_var, filt.observed, burn_in=burn_in, sigma2_burn_in=burn_in)
    observed = ~jnp.isnan(y)
    y0 = jnp.where(observed, y, 0.0)
    use = observed & (jnp.cumsum(observed) > burn_in)  # after the first `burn_in` observed samples

    def step(carry, inp):
        x, P, slogf, se2, n = carry
        yk, hk, ok, uk, adv = inp
        x_pred, P_pred = _predict(x, P, *_transition(F, Q, adv))
        x_new, P_new, v, f, _ = _update(x_pred, P_pred, hk, yk, ok, r)
        slogf = slogf + jnp.where(uk, jnp.log(f), 0.0)
        se2 = se2 + jnp.where(uk, v * v / f, 0.0)
        return (x_new, P_new, slogf, se2, n + uk), None

    zero = jnp.zeros((), y.dtype)
    inputs = (y0, H, observed, use, _advance(advance, y.shape[0]))
    (_, _, slogf, se2, n), _ = lax.scan(step, (x0, P0, zero, zero, zero), inputs)
    return likelihood_from_sums(slogf, se2, n, se2 / n)


def gaussian_loglik(innov, innov_var, observed, sigma2, *, burn_in: int = 0):
    """Exact Gaussian log-likelihood for a given sigma^2 (prediction-error decomposition)."""
    use = observed & (jnp.cumsum(observed) > burn_in)  # after the first `burn_in` observed samples
    terms = -0.5 * (jnp.log(2 * jnp.pi * sigma2 * innov_var) + innov**2 / (sigma2 * innov_var))
    return jnp.sum(jnp.where(use, terms, 0.0))


def observation_rows(z, S):
    """h_k = z_k @ S for all k."""
    return z @ S


__all__ = [
    "FilterOutput",
    "SmootherOutput",
    "Likelihood",
    "kalman_filter",
    "fixed_interval_smoother",
    "concentrated_loglik",
    "likelihood_from_sums",
    "filter_criterion",
    "gaussian_loglik",
    "observation_rows",
]
