"""Maximum-likelihood noise variance ratios by gradient-based optimisation.

The NVRs b = log10(NVR) minimise the concentrated criterion (see
`jaxsdp._kalman.concentrated_loglik`)

    J(b) = sum_k log f_k + n log( sum_k v_k^2 / f_k / n ),

differentiated exactly through the Kalman filter (forward mode: one or a few
hyperparameters). The standard error of log10 NVR comes from the curvature
of the log-likelihood -J/2: se(b) = sqrt(diag((J''/2)^{-1})).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import optimistix as optx

from ._checks import as_float_array, check_value
from ._dlr import validate_nvr, validate_regression
from ._kalman import filter_criterion, observation_rows
from ._models import as_models, assemble, n_hyper, state_dim
from ._x64 import x64

#: Bounds on log10 NVR during the search; NVR = 1e-30 is a constant parameter.
LOG10_NVR_BOUNDS = (-30.0, 6.0)


class NVRFit(eqx.Module):
    """Maximum-likelihood NVR estimate.

    - `nvr`: the estimate (after the optional cap `max_nvr`); `log10_nvr`: log10 of it.
    - `log10_nvr_se`: approximate standard error of log10 NVR from the curvature
      of the log-likelihood (inf where the likelihood is flat, e.g. at a bound).
    - `loglik`, `J`: concentrated log-likelihood and criterion at the estimate.
    - `steps`: optimiser iterations; `converged`: whether the optimiser met its tolerance.
    """

    nvr: jnp.ndarray
    log10_nvr: jnp.ndarray
    log10_nvr_se: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    steps: jnp.ndarray
    converged: jnp.ndarray


def optimise_log10_nvr(criterion, b0, *, max_log10=None, rtol=1e-8, atol=1e-5, max_steps=100, bounds=LOG10_NVR_BOUNDS):
    """Minimise `criterion(b) -> Likelihood` over b = log10 NVR (vector) with BFGS.

    `b` is clipped to `bounds` inside the criterion (zero gradient outside, so
    the search stops at a bound); the result is capped at `max_log10`.
    """
    lo, hi = bounds
    scale = jax.lax.stop_gradient(criterion(b0).n_used)

    def fn(b, _):
        return criterion(jnp.clip(b, lo, hi)).J / scale

    sol = optx.minimise(
        fn,
        optx.BFGS(rtol=rtol, atol=atol),
        b0,
        options={"autodiff_mode": "fwd"},
        max_steps=max_steps,
        throw=False,
    )
    b = jnp.clip(sol.value, lo, hi)
    if max_log10 is not None:
        b = jnp.minimum(b, max_log10)
    lik = criterion(b)
    hess = jax.jacfwd(jax.jacfwd(lambda bb: criterion(bb).J))(b)
    info = 0.5 * (hess + hess.T) / 2.0
    eye = jnp.eye(b.shape[0])
    chol = jnp.linalg.cholesky(info)
    cov = jsl.cho_solve((chol, True), eye)
    se = jnp.sqrt(jnp.diag(cov))
    se = jnp.where(jnp.all(jnp.isfinite(chol)) & jnp.all(jnp.isfinite(se)), se, jnp.inf)
    return NVRFit(
        nvr=10.0**b,
        log10_nvr=b,
        log10_nvr_se=se,
        loglik=lik.loglik,
        J=lik.J,
        steps=sol.stats["num_steps"],
        converged=sol.result == optx.RESULTS.successful,
    )


@eqx.filter_jit
def _ml_nvr(y, z, b0, P0, models, burn_in, max_log10):
    n = state_dim(models)
    x0 = jnp.zeros(n)
    P0m = P0 * jnp.eye(n)

    def criterion(b):
        ss = assemble(models, 10.0**b)
        return filter_criterion(y, observation_rows(z, ss.S), ss.F, ss.Q, x0, P0m, burn_in=burn_in)

    return optimise_log10_nvr(criterion, b0, max_log10=max_log10)


@x64
def ml_nvr(y, z, *, model="RW", nvr0=1e-4, P0: float = 1e5, max_nvr: float | None = None) -> NVRFit:
    r"""Maximum-likelihood NVRs of a dynamic linear regression (see `jaxsdp.dlr`).

    Minimises the concentrated criterion $J(b)$ over $b = \log_{10}\mathrm{NVR}$
    with BFGS and exact forward-mode derivatives through the Kalman filter,
    starting from `nvr0` (CAPTAIN's default 1e-4). `max_nvr` caps the result
    (CAPTAIN caps SDP NVRs at 1). `Constant` blocks take no NVR.
    """
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    models = as_models(model, z.shape[1])
    if n_hyper(models) == 0:
        raise ValueError("`model`: every block is Constant, there is no NVR to estimate")
    y, z = validate_regression(y, z, min_samples=state_dim(models) + 2)
    nvr0 = validate_nvr(nvr0, models)
    nvr0 = check_value("nvr0", nvr0, lambda a: ~(a > 0).all(), "initial NVRs must be positive")
    max_log10 = None if max_nvr is None else float(jnp.log10(max_nvr))
    return _ml_nvr(y, z, jnp.log10(nvr0), as_float_array("P0", P0, ndim=0), models, state_dim(models) + 1, max_log10)
