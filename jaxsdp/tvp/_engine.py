"""The kernels the time-variable family shares: a dynamic regression smoothed with the variances of chosen
linear combinations of its states, and maximum-likelihood NVRs that several blocks may share.

The model is `jaxsdp.dlr`'s: y_k = h_k s_k + e_k, e_k ~ N(0, sigma^2), the
state s_k made of random-walk-family blocks (one per regressor), their NVRs a
flat vector. A *component* is a set of blocks (a trend, one harmonic's cosine
and sine pair); its signal at sample k is r_k s_k with r_k = h_k * mask (h_k
restricted to its blocks' states), with variance sigma^2 r_k P_{k|N} r_k^T
from the smoother. *Tied* NVRs: the blocks' NVR vector is nvr_c[index], so
that a harmonic's two amplitudes share one NVR (the toolbox's convention, and
what makes the pair a rotation-invariant, phase-free model).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import as_float_array, check_value, check_values, nonnegative_int
from .._kalman.general import concentrated_loglik, fixed_interval_smoother, kalman_filter, observation_rows
from .._kalman.models import assemble, state_dim
from .._kalman.nvr import dlr_likelihood, optimise_log10_nvr


class Smoothed(eqx.Module):
    """What `smooth_components` returns (internal): the smoothed state, the components' signals and variances."""

    state: jnp.ndarray  # (N, n) s_{k|N}
    state_var: jnp.ndarray  # (N, n) diag P_{k|N} (units of sigma^2)
    signal: jnp.ndarray  # (N, r) r_jk s_{k|N}
    signal_var: jnp.ndarray  # (N, r) r_jk P_{k|N} r_jk^T (units of sigma^2)
    sigma2: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    definite: jnp.ndarray
    innov: jnp.ndarray  # (N,) one-step prediction errors v_k of the filter (NaN where y is missing)
    innov_var: jnp.ndarray  # (N,) their variances f_k (units of sigma^2; NaN where y is missing)


def checked_P0(P0):
    """The diffuse prior's variance: a finite positive scalar."""
    P0 = as_float_array("P0", P0, ndim=0)
    return check_value("P0", P0, lambda a: ~((a > 0) & (a < np.inf)), "must be finite and positive")


def check_observed(y, n_states: int, *, carrier):
    """At least n_states + 2 observed (non-NaN) samples in y; the traced check rides on `carrier`."""
    message = f"has fewer than {n_states + 2} observed samples (NaN are missing): too few for {n_states} states"
    return check_values([("y", y, lambda a: (a == a).sum() < n_states + 2, message)], carrier=carrier)


def checked_burn_in(burn_in, n: int) -> int:
    """The number of first samples the likelihood skips: an integer in [0, n)."""
    b = nonnegative_int("burn_in", burn_in)
    if b >= n:
        raise ValueError(f"`burn_in` ({b}) must be below the number of samples ({n})")
    return b


def bucket_length(n: int) -> int:
    """n rounded up to one of 8 lengths per octave (at most 12.5 % more; 16 and below unchanged).

    Missing samples (NaN) at the end of a series change neither the
    likelihood nor the smoothed estimates before them, so a series padded
    with NaNs to its bucket gives the same results from a program compiled
    once per bucket instead of once per length: series of 466 and 478
    samples share one compilation (seconds each) instead of two.
    """
    if n <= 16:
        return n
    step = 2 ** (int(np.floor(np.log2(n))) - 3)
    return int(-(-n // step) * step)


def head(smoothed: Smoothed, n: int) -> Smoothed:
    """The first n samples of a `Smoothed` (dropping a bucket's padding)."""
    return jax.tree.map(lambda a: a[:n] if a.ndim else a, smoothed)


def block_masks(models, groups) -> np.ndarray:
    """(r, n) 0/1 masks: row j selects the states of the blocks listed in `groups[j]` (block indices)."""
    n = state_dim(models)
    starts = np.cumsum([0] + [m.dim for m in models])
    masks = np.zeros((len(groups), n))
    for j, blocks in enumerate(groups):
        for b in blocks:
            masks[j, starts[b] : starts[b + 1]] = 1.0
    return masks


@eqx.filter_jit
def smooth_components(y, z, nvr, P0, x0, models, masks, burn_in, sigma2_burn_in, method="sequential"):
    """Kalman filter and fixed-interval smoother of the regression, with each component's signal and variance."""
    ss = assemble(models, nvr)
    n = ss.F.shape[0]
    H = observation_rows(z, ss.S)
    return smooth_system(y, H, ss.F, ss.Q, x0, P0 * jnp.eye(n), masks, burn_in, sigma2_burn_in, method)


def smooth_system(y, H, F, Q, x0, P0, masks, burn_in, sigma2_burn_in, method="sequential", obs_var=None):
    """`smooth_components` of a given system: observation rows H (N, n), F, Q, the prior N(x0, P0) (P0 (n, n)),
    the observation variance `obs_var` (units of sigma^2; None: 1). Call it inside a jitted function."""
    filt = kalman_filter(y, H, F, Q, x0, P0, method=method, obs_var=obs_var)
    sm = fixed_interval_smoother(filt, F, Q, rows=(H, jnp.asarray(masks)), method=method)
    lik = concentrated_loglik(filt.innov, filt.innov_var, filt.observed, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in)
    signal = jnp.einsum("kn,rn,kn->kr", H, jnp.asarray(masks), sm.x_smooth)
    definite = (jnp.min(sm.P_smooth_diag) >= 0) & jnp.isfinite(jnp.sum(sm.P_smooth_diag)) & (jnp.min(sm.row_var) >= 0)
    return Smoothed(
        state=sm.x_smooth,
        state_var=sm.P_smooth_diag,
        signal=signal,
        signal_var=sm.row_var,
        sigma2=lik.sigma2,
        loglik=lik.loglik,
        J=lik.J,
        definite=definite,
        innov=jnp.where(filt.observed, filt.innov, jnp.nan),
        innov_var=jnp.where(filt.observed, filt.innov_var, jnp.nan),
    )


@eqx.filter_jit
def fit_tied_nvr(y, z, b0, P0, x0, models, index, burn_in, max_log10, method="sequential"):
    """ML log10 NVRs `b` (one per tied group) of the regression whose blocks' NVRs are 10**b[index]."""
    idx = np.asarray(index, dtype=int)

    def criterion(b):
        return dlr_likelihood(y, z, 10.0 ** b[idx], P0, x0, models, burn_in, method)

    n_obs = jnp.sum(~jnp.isnan(y))
    return optimise_log10_nvr(criterion, b0, scale=n_obs, max_log10=max_log10)


__all__ = [
    "Smoothed",
    "block_masks",
    "bucket_length",
    "checked_P0",
    "head",
    "smooth_components",
    "smooth_system",
    "fit_tied_nvr",
]
