"""Dynamic linear regression with one closed-form block, and its batching rule.

`block_dlr` returns everything `jaxsdp.dlr` reports for a single regressor
whose block has dimension 1 or 2. Under `jax.vmap` it has its own batching
rule for the Monte Carlo case: a batch of series `y` sharing the regressor,
NVRs, x0 and P0. The filter and smoother covariances, gains and innovation
variances do not depend on y, so when no y in the batch has a missing
sample they are computed once (one unbatched pass) and only the mean
recursions run over the batch:

    x_{k|k} = F x_{k-1|k-1} + K_k (y_k - h_k [F x_{k-1|k-1}]_1),
    x_{k|N} = x_{k|k} + G_k (x_{k+1|N} - F x_{k|k}),

with K_k = P_{k|k} h_k e_1 and G_k the smoother gains from the shared pass.
Same numbers as the per-series kernels (tested). Any other batching (a
batched regressor, NVR or initial condition) or a missing sample anywhere
in the batch runs the per-series kernels under `vmap`. Differentiation
goes through the per-series kernels (a `custom_jvp` whose rule is theirs).
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import lax

from .closed_form import (
    BlockSystem,
    block_filter,
    block_filter_smoother,
    block_smoother,
    slogf,
)
from .general import Likelihood, likelihood_from_sums


class BlockDLR(NamedTuple):
    """Per-sample results of one block; standard errors already scaled by sigma2."""

    par: jnp.ndarray  # (N, 1) smoothed first state (the regression parameter)
    parse: jnp.ndarray  # (N, 1) its standard error
    state: tuple  # smoothed states, one (N,) array per state
    state_se: tuple
    state_filt: tuple
    state_filt_se: tuple
    innov: jnp.ndarray  # (N,) NaN where y is missing
    innov_var: jnp.ndarray  # (N,) sigma2 f_k, NaN where y is missing
    lik: Likelihood
    definite: jnp.ndarray  # bool: the covariances stayed positive definite (`closed_form.DEFINITE_RTOL`)


def _se(s2, P):
    return jnp.sqrt(s2 * jnp.clip(P, 0.0))


def _per_series(y, h, svals, x0, P0, *, n, burn_in, sigma2_burn_in, method="sequential", complete=False) -> BlockDLR:
    sys = BlockSystem(n, *svals)
    opts = dict(burn_in=burn_in, sigma2_burn_in=sigma2_burn_in, method=method, complete=complete)
    b = block_filter_smoother(y, h, sys, x0, P0, **opts)
    s2 = b.loglik.sigma2
    cols = lambda a: tuple(a[:, i] for i in range(n))
    observed = y == y
    return BlockDLR(
        b.x_smooth[:, :1],
        _se(s2, b.P_smooth_diag[:, :1]),
        cols(b.x_smooth),
        tuple(_se(s2, P) for P in cols(b.P_smooth_diag)),
        cols(b.x_filt),
        tuple(_se(s2, P) for P in cols(b.P_filt_diag)),
        jnp.where(observed, b.innov, jnp.nan),
        jnp.where(observed, s2 * b.innov_var, jnp.nan),
        b.loglik,
        b.definite,
    )


def _shared_covariance(Y, h, svals, x0, P0, *, n, burn_in, sigma2_burn_in) -> BlockDLR:
    """Batch of complete series Y (B, N) with a shared regressor and system."""
    sys = BlockSystem(n, *svals)
    # the covariance passes (run on y = 0: they do not depend on y)
    cov = block_filter(jnp.zeros_like(h), h, sys, x0, P0, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in)
    _, S, definite, G = block_smoother(cov, sys, gains=True)
    K = (cov.P[0] * h,) if n == 1 else (cov.P[0] * h, cov.P[1] * h)
    f = cov.innov_var
    f11, f12, f22 = sys.f11, sys.f12, sys.f22

    def F_times(x):
        return (f11 * x[0],) if n == 1 else (f11 * x[0] + f12 * x[1], f22 * x[1])

    def mean_filter(carry, inp):
        x, se2, se2_s, k = carry
        yk, hk, Kk, fk = inp
        xp = F_times(x)
        v = yk - hk * xp[0]
        x = tuple(a + Ki * v for a, Ki in zip(xp, Kk))
        e2 = v * v / fk
        se2 = se2 + jnp.where(k >= burn_in, e2, 0.0)
        # (one burn-in for both: the sigma^2 sum is the likelihood's, not carried twice)
        se2_s = se2_s if sigma2_burn_in == burn_in else se2_s + jnp.where(k >= sigma2_burn_in, e2, 0.0)
        return (x, se2, se2_s, k + 1), (x, v)

    def mean_smoother(xs_next, inp):
        xk, Gk = inp
        d = tuple(a - b for a, b in zip(xs_next, F_times(xk)))
        if n == 1:
            xs = (xk[0] + Gk[0] * d[0],)
        else:
            G11, G12, G21, G22 = Gk
            xs = (xk[0] + G11 * d[0] + G12 * d[1], xk[1] + G21 * d[0] + G22 * d[1])
        # (the first state is stored with a trailing unit axis: vmap's transpose then
        # yields the (B, N, 1) `par` in one pass, without a second copy)
        return xs, (xs[0][None], *xs[1:])

    def means(y):
        zero = jnp.zeros((), y.dtype)
        init = (tuple(x0[i] for i in range(n)), zero, zero, 0)
        (_, se2, se2_s, _), (xf, v) = lax.scan(mean_filter, init, (y, h, K, f))
        last = tuple(a[-1] for a in xf)
        _, xs = lax.scan(mean_smoother, F_times(last), (xf, G), reverse=True)
        return xs, xf, v, se2, se2_s

    # (vmap runs the scans time-major over the whole batch: every step is one
    # vector operation across the series)
    xs, xf, v, se2, se2_s = jax.vmap(means)(Y)
    par = xs[0]  # (B, N, 1)
    xs = (par[..., 0], *xs[1:])

    # no missing samples: the counts are those of the covariance pass
    n_lik = cov.sums.n
    if sigma2_burn_in == burn_in:
        s2 = se2 / n_lik  # (B,)
    else:
        s2 = se2_s / cov.sums.n_s
    lik = likelihood_from_sums(slogf(cov.sums), se2, jnp.broadcast_to(n_lik, s2.shape), s2)
    S_diag = (S[0],) if n == 1 else (S[0], S[1])
    Pf_diag = (cov.P[0],) if n == 1 else (cov.P[0], cov.P[2])
    s2c = s2[:, None]
    # (the (B, N, 1) fields are built here, inside the rule's branch, so that XLA-CPU
    # does not copy them once more to reshape the branch's result)
    return BlockDLR(
        par,
        _se(s2[:, None, None], S[0][None, :, None]),
        xs,
        tuple(_se(s2c, P[None, :]) for P in S_diag),
        xf,
        tuple(_se(s2c, P[None, :]) for P in Pf_diag),
        v,
        s2c * f[None, :],
        lik,
        jnp.broadcast_to(definite, s2.shape),
    )


def block_dlr(y, h, sys: BlockSystem, x0, P0, *, burn_in: int, sigma2_burn_in: int, method="sequential") -> BlockDLR:
    """Filter, smoother, likelihood and standard errors for one block (see the module docstring).

    `method` "parallel" runs the associative-scan kernels; its batching rule for
    complete series sharing everything but y is the same kernels told that no
    sample is missing, which leaves all covariance work unbatched under `vmap`.
    """
    n = sys.n
    opts = dict(n=n, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in)
    svals = (sys.f11, sys.f12, sys.f22, sys.q11, sys.q12, sys.q22)

    def core(y, h, svals, x0, P0):
        return _per_series(y, h, svals, x0, P0, method=method, **opts)

    def shared(y, h, svals, x0, P0):
        if method == "parallel":
            one = lambda yy: _per_series(yy, h, svals, x0, P0, method=method, complete=True, **opts)
            return jax.vmap(one)(y)
        return _shared_covariance(y, h, svals, x0, P0, **opts)

    batched = jax.custom_batching.custom_vmap(core)

    @batched.def_vmap
    def _rule(axis_size, in_batched, y, h, svals, x0, P0):
        yb, hb, sb, xb, pb = in_batched
        axes = jax.tree.map(lambda b: 0 if b else None, in_batched)
        per_series = lambda: jax.vmap(core, in_axes=axes)(y, h, svals, x0, P0)
        if yb and not (hb or any(sb) or xb or pb):
            out = lax.cond(jnp.isnan(y).any(), per_series, lambda: shared(y, h, svals, x0, P0))
        else:
            out = per_series()
        return out, jax.tree.map(lambda _: True, out)

    f = jax.custom_jvp(batched)
    f.defjvp(lambda primals, tangents: jax.jvp(core, primals, tangents))
    return f(y, h, svals, x0, P0)
