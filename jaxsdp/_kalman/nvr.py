"""Maximum-likelihood noise variance ratios by gradient-based optimisation.

The NVRs b = log10(NVR) minimise the concentrated criterion (see
`jaxsdp._kalman.general.concentrated_loglik`)

    J(b) = sum_k log f_k + n log( sum_k v_k^2 / f_k / n ),

differentiated exactly through the Kalman filter (forward mode: one or a few
hyperparameters). The standard error of log10 NVR comes from the curvature
of the log-likelihood -J/2: se(b) = sqrt(diag((J''/2)^{-1})), with the exact
Hessian J'' (nested forward-mode differentiation).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import optimistix as optx
from jax import lax

from .._checks import as_float_array, check_value
from .._runtime import x64
from .closed_form import block_likelihood, block_system, is_small
from .dlr import validate_dlr_args, validate_nvr, validate_regression
from .general import Likelihood, filter_criterion, observation_rows
from .models import as_models, assemble, n_hyper, state_dim

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


def _value_and_grad_fwd(f, b):
    """f(b) and its gradient by forward mode: one filter pass per hyperparameter."""
    eye = jnp.eye(b.shape[0], dtype=b.dtype)
    vals, grads = jax.vmap(lambda e: jax.jvp(f, (b,), (e,)))(eye)
    return vals[0], grads


def _fwd_objective(f):
    """Wrap f so that any differentiation of it uses forward mode (few hyperparameters).

    The JVP rule computes the full gradient from the primal alone, so
    `jax.linearize`/`jax.grad` never store per-sample residuals of the filter scan.
    """

    @jax.custom_jvp
    def wrapped(b):
        return f(b)

    @wrapped.defjvp
    def _jvp(primals, tangents):
        (b,), (t,) = primals, tangents
        val, g = _value_and_grad_fwd(f, b)
        return val, g @ t

    return wrapped


def bfgs_minimise(f, b0, *, atol=1e-5, gtol=1e-9, max_steps=100, max_step=3.0):
    """Minimise a smooth f: R^k -> R by BFGS with Armijo backtracking, in one `lax.while_loop`.

    Gradients by forward mode. Steps are limited to `max_step` in the
    infinity norm (decades of NVR). Stops when the step is below `atol` or the
    gradient below `gtol` (infinity norms). Returns (b, f(b), steps, converged).

    Kept (rather than `optimistix.BFGS`) for its first step of at most one
    decade and its restart on negative curvature, which the EMPS mass NVR needs
    (see `jaxsdp.studies.emps._sdp_stage`); per step it costs the same as
    optimistix's (2.0 ms at N = 25,000, `benchmarks/numerics.py`, section 6).
    """
    k = b0.shape[0]
    eye = jnp.eye(k, dtype=b0.dtype)
    f0, g0 = _value_and_grad_fwd(f, b0)
    # first step: one decade (at most) down the gradient
    H0 = eye / jnp.maximum(jnp.max(jnp.abs(g0)), 1e-300)

    def cond(c):
        i, _, _, _, _, done = c
        return (i < max_steps) & ~done

    def body(c):
        i, b, fb, g, Hinv, _ = c
        p = -Hinv @ g
        p = p * jnp.minimum(1.0, max_step / jnp.maximum(jnp.max(jnp.abs(p)), 1e-300))
        slope = g @ p
        # if p is not a descent direction, fall back to steepest descent
        bad = ~(slope < 0)
        p = jnp.where(bad, -g * jnp.minimum(1.0, max_step / jnp.maximum(jnp.max(jnp.abs(g)), 1e-300)), p)
        slope = g @ p

        # Armijo backtracking from t = 1 (one call site of f keeps compile time down)
        def ls_cond(lc):
            t, fn, _, j = lc
            return (~(fn <= fb + 1e-4 * t * slope)) & (j < 20)

        def ls_body(lc):
            t, _, _, j = lc
            t = jnp.where(j == 0, 1.0, 0.5 * t)
            fn, gn = _value_and_grad_fwd(f, b + t * p)
            return t, fn, gn, j + 1

        t, fn, gn, _ = lax.while_loop(ls_cond, ls_body, (jnp.ones(()), jnp.inf, g, 0))
        ok = fn <= fb + 1e-4 * t * slope
        s = jnp.where(ok, t * p, 0.0)
        yv = gn - g
        sy = s @ yv
        # first step: rescale the initial inverse Hessian (Shanno-Phua)
        Hinv = jnp.where((i == 0) & (sy > 0), eye * sy / (yv @ yv), Hinv)
        rho = 1.0 / jnp.where(sy > 1e-300, sy, 1.0)
        V = eye - rho * jnp.outer(s, yv)
        Hnew = V @ Hinv @ V.T + rho * jnp.outer(s, s)
        # no positive curvature along s (J is not convex far from its minimum in
        # log10 NVR): restart from a scaled identity that doubles the step length
        Hrestart = eye * 2.0 * jnp.max(jnp.abs(s)) / jnp.maximum(jnp.max(jnp.abs(gn)), 1e-300)
        Hinv = jnp.where(sy > 1e-300, 0.5 * (Hnew + Hnew.T), Hrestart)
        b_new = jnp.where(ok, b + s, b)
        f_new = jnp.where(ok, fn, fb)
        g_new = jnp.where(ok, gn, g)
        done = (~ok) | (jnp.max(jnp.abs(s)) < atol) | (jnp.max(jnp.abs(g_new)) < gtol)
        return i + 1, b_new, f_new, g_new, Hinv, done

    init = (jnp.array(0), b0, f0, g0, H0, jnp.max(jnp.abs(g0)) < gtol)
    steps, b, fb, g, _, done = lax.while_loop(cond, body, init)
    return b, fb, steps, done


def optimise_log10_nvr(
    criterion, b0, *, scale, max_log10=None, atol=1e-5, max_steps=100, bounds=LOG10_NVR_BOUNDS, solver=None
):
    """Minimise `criterion(b) -> Likelihood` over b = log10 NVR (vector).

    `b` is clipped to `bounds` inside the criterion (zero gradient outside, so
    the search stops at a bound); the result is capped at `max_log10`.
    `solver`: None for the built-in forward-mode BFGS loop (`bfgs_minimise`),
    or any `optimistix` minimiser (e.g. `optx.BFGS(rtol=1e-8, atol=1e-5)`).
    `scale` (e.g. the number of samples) normalises J to order one for the tolerances.
    """
    lo, hi = bounds

    def J(b):
        return criterion(jnp.clip(b, lo, hi)).J / scale

    if solver is None:
        b, _, steps, converged = bfgs_minimise(J, b0, atol=atol, max_steps=max_steps)
    else:
        Jf = _fwd_objective(J)
        sol = optx.minimise(
            lambda b, _: Jf(b), solver, b0, options={"autodiff_mode": "fwd"}, max_steps=max_steps, throw=False
        )
        b, steps, converged = sol.value, sol.stats["num_steps"], sol.result == optx.RESULTS.successful
    b = jnp.clip(b, lo, hi)
    if max_log10 is not None:
        b = jnp.minimum(b, max_log10)
    lik = criterion(b)
    hess = jax.jacfwd(jax.jacfwd(lambda bb: criterion(bb).J))(b)  # exact, forward over forward
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
        steps=steps,
        converged=converged,
    )


def _likelihood(y, z, nvr, P0, x0, models, burn_in):
    """Concentrated `Likelihood` of `dlr`'s model from a filter that stores nothing per sample."""
    ss = assemble(models, nvr)
    if is_small(models):
        return block_likelihood(y, z[:, 0], block_system(ss.F, ss.Q), x0, P0, burn_in=burn_in)
    n = state_dim(models)
    return filter_criterion(y, observation_rows(z, ss.S), ss.F, ss.Q, x0, P0 * jnp.eye(n), burn_in=burn_in)


@eqx.filter_jit
def _ml_nvr(y, z, b0, P0, models, burn_in, max_log10, solver):
    x0 = jnp.zeros(state_dim(models))

    def criterion(b):
        return _likelihood(y, z, 10.0**b, P0, x0, models, burn_in)

    return optimise_log10_nvr(criterion, b0, scale=y.shape[0], max_log10=max_log10, solver=solver)


@x64
def ml_nvr(y, z, *, model="RW", nvr0=1e-4, P0: float = 1e5, max_nvr: float | None = None, solver=None) -> NVRFit:
    r"""Maximum-likelihood NVRs of a dynamic linear regression (see `jaxsdp.dlr`).

    Minimises the concentrated criterion $J(b)$ over $b = \log_{10}\mathrm{NVR}$
    with BFGS and exact forward-mode derivatives through the Kalman filter,
    starting from `nvr0` (CAPTAIN's default 1e-4). `max_nvr` caps the result
    (CAPTAIN caps SDP NVRs at 1). `Constant` blocks take no NVR.
    `solver`: None for jaxsdp's own forward-mode BFGS loop (`bfgs_minimise`,
    the fast default), or an `optimistix` minimiser such as
    `optx.BFGS(rtol=1e-8, atol=1e-5)` (same optimum, slower on the CPU).
    """
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    models = as_models(model, z.shape[1])
    if n_hyper(models) == 0:
        raise ValueError("`model`: every block is Constant, there is no NVR to estimate")
    nvr0 = validate_nvr(nvr0, models)
    nvr0 = check_value("nvr0", nvr0, lambda a: ~(a > 0).all(), "initial NVRs must be positive")
    y, z, nvr0 = validate_regression(y, z, min_samples=state_dim(models) + 2, carrier=nvr0)
    max_log10 = None if max_nvr is None else float(jnp.log10(max_nvr))
    return _ml_nvr(
        y, z, jnp.log10(nvr0), as_float_array("P0", P0, ndim=0), models, state_dim(models) + 1, max_log10, solver
    )


_dlr_loglik = eqx.filter_jit(_likelihood)


@x64
def dlr_loglik(y, z, *, model="RW", nvr=1e-3, P0: float = 1e5, x0=None, burn_in: int | None = None) -> Likelihood:
    r"""Concentrated log-likelihood of `jaxsdp.dlr`'s model, without the smoother.

    The same `loglik` and `J` as `dlr(...)` (prediction-error decomposition
    with $\sigma^2$ concentrated out, the first $\dim(s)+1$ samples skipped),
    from one filter pass that stores nothing per sample: the function to
    differentiate for gradient-based NVR estimation (`jax.jvp` suits a few
    NVRs, `jax.grad` works too). `sigma2` is the concentrated-out estimate
    over the same innovations as the likelihood (`dlr.sigma2` starts one
    sample earlier, CAPTAIN's convention).

    Arguments as `jaxsdp.dlr`. Returns a `Likelihood` (`loglik`, `J`,
    `sigma2`, `n_used`).
    """
    y, z, nvr, P0, x0, models, burn_in = validate_dlr_args(y, z, model, nvr, P0, x0, burn_in)
    return _dlr_loglik(y, z, nvr, P0, x0, models, burn_in)
