"""Dynamic linear regression: time-variable parameters by Kalman filtering and smoothing."""

import equinox as eqx
import jax.numpy as jnp

from .._runtime import resolve_method, x64
from .closed_form import block_system, is_small
from .dlr_block import block_dlr
from .general import concentrated_loglik, fixed_interval_smoother, kalman_filter, observation_rows
from .models import assemble, first_state_index, n_hyper, state_dim
from .nvr import fit_ml_nvr, prepare_ml
from .validate import validate_dlr_args


class DLRResult(eqx.Module):
    r"""Result of `jaxsdp.dlr`.

    All standard errors are $\sqrt{\sigma^2 P}$ with $P$ the normalised covariance
    (filters run with $\sigma^2 = 1$).

    - `par`, `parse`: (N, p) smoothed parameters $\theta_{k|N}$ and standard errors.
    - `par_filt`, `parse_filt`: (N, p) filtered $\theta_{k|k}$ and standard errors.
    - `state`, `state_se`: (N, n) full smoothed state (e.g. [theta, slope]).
    - `fit`: (N,) $\sum_i z_{ik} \theta_{ik|N}$; `resid` = $y - fit$ (NaN where y is missing).
    - `innov`, `innov_var`: (N,) one-step-ahead prediction errors $v_k$ and their
      variances $\sigma^2 f_k$ (NaN where y is missing).
    - `sigma2`: estimated observation noise variance.
    - `loglik`: concentrated log-likelihood; `J`: the criterion $-2 \cdot loglik - n (\log 2\pi + 1)$.
    - `nvr`: the NVRs used (flat vector, one per NVR of each block).
    - `nvr_estimated`: bool, whether `nvr` was estimated (`dlr(..., nvr="ml")`)
      rather than given; `nvr_fit`: the `NVRFit` of that estimate (check its
      `converged`, `at_bound`, `reason`), None when the NVRs were given.
    - `definite`: bool, the filter and smoother covariances stayed
      numerically positive definite. False means the standard errors (and
      possibly the estimates) are not to be trusted: with one 2-state block
      (IRW/SRW/LLT), the correlation of its two states reached
      $1 - \rho^2$ < 1e-14 somewhere (e.g. an IRW with a tiny NVR over many
      samples); with several blocks, a variance became negative or not finite.
    """

    par: jnp.ndarray
    parse: jnp.ndarray
    par_filt: jnp.ndarray
    parse_filt: jnp.ndarray
    state: jnp.ndarray
    state_se: jnp.ndarray
    fit: jnp.ndarray
    resid: jnp.ndarray
    innov: jnp.ndarray
    innov_var: jnp.ndarray
    sigma2: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    nvr: jnp.ndarray
    definite: jnp.ndarray
    nvr_estimated: jnp.ndarray
    nvr_fit: eqx.Module | None = None


@eqx.filter_jit
def _dlr(y, z, nvr, P0, x0, models, burn_in, sigma2_burn_in, method="sequential"):
    ss = assemble(models, nvr)
    idx = first_state_index(models)
    if is_small(models):
        sys = block_system(ss.F, ss.Q)
        b = block_dlr(y, z[:, 0], sys, x0, P0, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in, method=method)
        col = lambda t: jnp.stack(t, axis=-1)
        lik = b.lik
        fit = z[:, 0] * b.state[0]
        return DLRResult(
            par=b.par,
            parse=b.parse,
            par_filt=b.state_filt[0][:, None],
            parse_filt=b.state_filt_se[0][:, None],
            state=col(b.state),
            state_se=col(b.state_se),
            fit=fit,
            resid=y - fit,
            innov=b.innov,
            innov_var=b.innov_var,
            sigma2=lik.sigma2,
            loglik=lik.loglik,
            J=lik.J,
            nvr=nvr,
            definite=b.definite,
            nvr_estimated=jnp.asarray(False),
        )
    n = ss.F.shape[0]
    H = observation_rows(z, ss.S)
    filt = kalman_filter(y, H, ss.F, ss.Q, x0, P0 * jnp.eye(n), method=method)
    sm = fixed_interval_smoother(filt, ss.F, ss.Q, method=method)
    x_s, P_s = sm.x_smooth, sm.P_smooth_diag
    x_f, P_f = filt.x_filt, jnp.diagonal(filt.P_filt, axis1=1, axis2=2)
    innov, innov_var, observed = filt.innov, filt.innov_var, filt.observed
    lik = concentrated_loglik(innov, innov_var, observed, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in)
    s2 = lik.sigma2
    definite = (jnp.min(P_s) >= 0) & (jnp.min(P_f) >= 0) & jnp.isfinite(jnp.sum(P_s))
    se = lambda P: jnp.sqrt(s2 * jnp.clip(P, 0.0))
    par = x_s[:, idx]
    fit = jnp.sum(z * par, axis=1)
    return DLRResult(
        par=par,
        parse=se(P_s[:, idx]),
        par_filt=x_f[:, idx],
        parse_filt=se(P_f[:, idx]),
        state=x_s,
        state_se=se(P_s),
        fit=fit,
        resid=y - fit,
        innov=jnp.where(observed, innov, jnp.nan),
        innov_var=jnp.where(observed, s2 * innov_var, jnp.nan),
        sigma2=s2,
        loglik=lik.loglik,
        J=lik.J,
        nvr=nvr,
        definite=definite,
        nvr_estimated=jnp.asarray(False),
    )


@x64
def dlr(
    y, z, *, model="RW", nvr=None, P0: float = 1e5, x0=None, burn_in: int | None = None, method: str | None = None
) -> DLRResult:
    r"""Dynamic linear regression with random-walk-family parameters (Kalman filter + smoother).

    Model, for samples $k = 1..N$ and $p$ regressors:

    $$ y_k = \sum_i z_{ik} \theta_{ik} + e_k, \quad e_k \sim N(0, \sigma^2), $$

    each $\theta_i$ the first state of its own block (`RW`, `IRW`, `SRW`, `LLT`,
    `Constant`; see `jaxsdp.RW`), e.g. for an RW $\theta_{ik} = \theta_{i,k-1} + w_{ik}$
    with $var(w_{ik}) = NVR_i \cdot \sigma^2$. The NVR (noise variance ratio,
    dimensionless) sets how fast a parameter may vary: 0 keeps it constant
    (recursive least squares). The Kalman filter and the fixed-interval
    smoother run with $\sigma^2 = 1$; $\sigma^2$ is then estimated as the mean
    squared normalised innovation after the first $dim(s)$ observed samples, and the
    concentrated log-likelihood skips the first $dim(s)+1$ (CAPTAIN's
    conventions; `burn_in` overrides the latter), $dim(s)$ the state dimension.
    Missing samples (NaN) do not count in either: a series that starts with
    gaps skips its first observations, whose innovations carry the diffuse prior.

    **Arguments**

    - `y`: (N,) observations; NaN marks a missing sample (skipped by the
      filter, interpolated by the smoother).
    - `z`: (N, p) regressors (finite).
    - `model`: one model for all regressors, or a sequence of p models (names or instances).
    - `nvr` (**required**): a scalar or flat vector of NVRs (finite, >= 0),
      one per block (two for `LLT`, none for `Constant`: it may be left out
      when every block is `Constant`); or the string `"ml"` to estimate them
      first by maximum likelihood (`jaxsdp.ml_nvr` from its default start
      1e-4, no cap). There is no default NVR, so that a result never rests
      on a value the user did not choose; with `"ml"` the result says so
      (`nvr_estimated`, `nvr_fit`).
    - `P0`: diffuse initial covariance $P_0 I$ (default 1e5); `x0`: initial state (default 0).
    - `method`: "sequential" (one `lax.scan` per pass), "parallel"
      (associative scans, $O(\log N)$ depth: Särkkä and García-Fernández 2021,
      see `jaxsdp._kalman.parallel`), "auto" (parallel on GPU/TPU, sequential
      on CPU) or None (the current setting, see `jaxsdp.set_kernel_method`;
      "auto" by default). Same results to rounding.

    **Returns** a `DLRResult` (`par` $\theta_{k|N}$ in the units of y/z, `parse`,
    `fit`, `loglik`, `sigma2` in units of $y^2$, `nvr`, `nvr_estimated`,
    `definite`, ...). Works under `jax.jit`, `jax.vmap` and `jax.grad`
    (w.r.t. `nvr` and the data).

    Example:
        >>> import numpy as np, jaxsdp
        >>> t = np.linspace(0.0, 1.0, 200)
        >>> y = (1.0 + t) * 2.0                                  # y = theta_k z_k, z = 2
        >>> res = jaxsdp.dlr(y, np.full((200, 1), 2.0), model="IRW", nvr=1e-6)
        >>> print(np.round(res.par[[0, 100, 199], 0], 3), bool(res.definite))
        [1.    1.503 2.   ] True
        >>> est = jaxsdp.dlr(y + 0.01 * np.sin(40 * t), np.full((200, 1), 2.0), nvr="ml")
        >>> bool(est.nvr_estimated), bool(est.nvr_fit.converged)
        (True, True)
    """
    m = resolve_method(method)
    if isinstance(nvr, str):
        if nvr != "ml":
            raise ValueError(f'`nvr` must be NVR values or "ml" (estimate them); got {nvr!r}')
        y, z, b0, P0c, models, max_log10 = prepare_ml(y, z, model, 1e-4, P0, None)
        _, _, _, P0c, x0c, _, bi = validate_dlr_args(y, z, model, jnp.zeros(n_hyper(models)), P0, x0, burn_in)
        fit = fit_ml_nvr(y, z, b0, P0c, x0c, models, bi, max_log10, m)
        res = _dlr(y, z, fit.nvr, P0c, x0c, models, bi, state_dim(models), m)
        return eqx.tree_at(
            lambda r: (r.nvr_estimated, r.nvr_fit), res, (jnp.asarray(True), fit), is_leaf=lambda v: v is None
        )
    y, z, nvr, P0, x0, models, burn_in = validate_dlr_args(y, z, model, nvr, P0, x0, burn_in)
    return _dlr(y, z, nvr, P0, x0, models, burn_in, state_dim(models), m)
