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
import numpy as np
from jax import lax

from .._checks import as_float_array, check_values, no_spread, positive_float
from .._runtime import resolve_method, x64
from .closed_form import block_likelihood, block_system, is_small
from .general import Likelihood, filter_criterion, observation_rows
from .models import as_models, assemble, n_hyper, state_dim
from .validate import validate_dlr_args, validate_nvr, validate_regression

#: Bounds on log10 NVR during the search; NVR = 1e-30 is a constant parameter.
LOG10_NVR_BOUNDS = (-30.0, 6.0)

#: An estimate within this many decades of a search bound counts as on it (`NVRFit.at_bound`).
BOUND_TOL = 1e-3

#: `NVRFit.status` codes (index) and their reasons (`NVRFit.reason`). 0 and 1 are `converged`.
STATUS_REASONS = (
    "converged",
    "converged on a bound: the NVR is at a search bound (LOG10_NVR_BOUNDS; at the lower one, 1e-30, the data "
    "cannot tell the parameter from a constant) or at the max_nvr cap; it has no standard error",
    "not a minimum: the likelihood's curvature is not positive definite there (flat or saddle); no standard error",
    "stalled: the line search found no decrease along the search direction",
    "iteration limit reached before the tolerances were met",
    "likelihood not finite (degenerate data?)",
)
CONVERGED, AT_BOUND, NOT_MINIMUM, STALLED, MAX_STEPS, NONFINITE = range(6)
#: Status of an NVR that was given, not estimated (`jaxsdp.sdp` with fixed NVRs).
FIXED = -1


def _reason(code) -> str:
    return "fixed: given, not estimated" if int(code) == FIXED else STATUS_REASONS[int(code)]


def status_reason(status):
    """The reason string(s) of `status` code(s): a str for a scalar, an array of str for a batch."""
    st = np.asarray(status)
    if st.ndim == 0:
        return _reason(st)
    return np.vectorize(_reason, otypes=[object])(st)


class NVRFit(eqx.Module):
    r"""Maximum-likelihood NVR estimate (the result of `jaxsdp.ml_nvr`).

    - `nvr`: (k,) the estimate (after the optional cap `max_nvr`); `log10_nvr`: $\log_{10}$ of it.
    - `log10_nvr_se`: (k,) approximate standard error of $\log_{10} NVR$ from the
      curvature of the log-likelihood, $se = \sqrt{diag((J''/2)^{-1})}$. It is
      **inf** where there is no standard error: for an NVR on a bound
      (`at_bound`), or for all where the curvature is not positive definite.
    - `loglik`, `J`: concentrated log-likelihood and criterion at the estimate.
    - `steps`: optimiser iterations.
    - `converged`: bool, the search met its tolerances at a minimum (inside
      the bounds, or on one: see `at_bound`). False when it stalled, ran out
      of iterations, found a non-finite likelihood or stopped where the
      curvature is not positive definite.
    - `at_bound`: (k,) bool, the NVR is at (within 1e-3 decades of) a bound of
      the search, `LOG10_NVR_BOUNDS` = (1e-30, 1e6), or at the `max_nvr` cap.
    - `status`: int code (an array, so that the fit stays jit/vmap-able);
      `reason` (a property, outside `jit`): its explanation, one of
      `STATUS_REASONS`: "converged", "converged on a bound: ...",
      "not a minimum: ...", "stalled: ...", "iteration limit reached ...",
      "likelihood not finite ...".
    """

    nvr: jnp.ndarray
    log10_nvr: jnp.ndarray
    log10_nvr_se: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    steps: jnp.ndarray
    converged: jnp.ndarray
    at_bound: jnp.ndarray
    status: jnp.ndarray

    @property
    @x64
    def reason(self):
        """Why the search stopped, in words (see `STATUS_REASONS`)."""
        return status_reason(self.status)


def _value_and_grad_fwd(f, b):
    """f(b) and its gradient by forward mode: one filter pass per hyperparameter."""
    eye = jnp.eye(b.shape[0], dtype=b.dtype)
    vals, grads = jax.vmap(lambda e: jax.jvp(f, (b,), (e,)))(eye)
    return vals[0], grads


#: Relative curvature guard of the BFGS update: s.y must exceed this times |s| |y|.
CURVATURE_RTOL = 1e-8


def bfgs_minimise(f, b0, *, atol=1e-5, gtol=1e-9, max_steps=100, max_step=3.0):
    """Minimise a smooth f: R^k -> R by BFGS with Armijo backtracking, in one `lax.while_loop`.

    Gradients by forward mode. Steps are limited to `max_step` in the
    infinity norm (decades of NVR). Stops when the step is below `atol` or the
    gradient below `gtol` (infinity norms). Returns (b, f(b), steps, status)
    with `status` one of CONVERGED, STALLED (the line search found no
    decrease while the quasi-Newton step was still longer than `atol`) or
    MAX_STEPS (see `STATUS_REASONS`).

    Kept (rather than `optimistix.BFGS`) for its first step of at most one
    decade and its restart on negative curvature, which the EMPS mass NVR needs
    (see `jaxsdp.plants.emps._sdp_stage`); per step it costs the same as
    optimistix's (2.0 ms at N = 25,000, `benchmarks/numerics.py`, section 6).
    The BFGS update is skipped (restart from a scaled identity) unless the
    curvature along the step is positive relative to the problem's scale:
    s.y > CURVATURE_RTOL |s| |y|.
    """
    k = b0.shape[0]
    eye = jnp.eye(k, dtype=b0.dtype)
    f0, g0 = _value_and_grad_fwd(f, b0)
    # first step: one decade (at most) down the gradient
    H0 = eye / jnp.maximum(jnp.max(jnp.abs(g0)), 1e-300)

    def cond(c):
        i, _, _, _, _, status = c
        return (i < max_steps) & (status == MAX_STEPS)

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
        curved = sy > CURVATURE_RTOL * jnp.sqrt((s @ s) * (yv @ yv))
        # first step: rescale the initial inverse Hessian (Shanno-Phua)
        Hinv = jnp.where((i == 0) & curved, eye * sy / (yv @ yv), Hinv)
        rho = 1.0 / jnp.where(curved, sy, 1.0)
        V = eye - rho * jnp.outer(s, yv)
        Hnew = V @ Hinv @ V.T + rho * jnp.outer(s, s)
        # no positive curvature along s (J is not convex far from its minimum in
        # log10 NVR): restart from a scaled identity that doubles the step length
        Hrestart = eye * 2.0 * jnp.max(jnp.abs(s)) / jnp.maximum(jnp.max(jnp.abs(gn)), 1e-300)
        Hinv = jnp.where(curved, 0.5 * (Hnew + Hnew.T), Hrestart)
        b_new = jnp.where(ok, b + s, b)
        f_new = jnp.where(ok, fn, fb)
        g_new = jnp.where(ok, gn, g)
        small = (jnp.max(jnp.abs(s)) < atol) | (jnp.max(jnp.abs(g_new)) < gtol)
        # a failed line search is a stall, unless the step it tried was already within tolerance
        stalled = ~ok & ~(jnp.max(jnp.abs(p)) < atol)
        status = jnp.where(stalled, STALLED, jnp.where(small | ~ok, CONVERGED, MAX_STEPS))
        return i + 1, b_new, f_new, g_new, Hinv, status

    init_status = jnp.where(jnp.max(jnp.abs(g0)) < gtol, CONVERGED, MAX_STEPS)
    init = (jnp.array(0), b0, f0, g0, H0, init_status)
    steps, b, fb, g, _, status = lax.while_loop(cond, body, init)
    return b, fb, steps, status


#: `_resolve_flat_zeros`: an NVR whose move to the lower bound changes the normalised criterion J / scale by less
#: than this is indistinguishable from zero (J / scale: the negative log-likelihood per sample).
FLAT_DJ = 1e-10
#: ... and the search counts as converged when, with those NVRs at zero, the remaining gradient of J / scale (per
#: decade of NVR) is below this.
FLAT_GTOL = 1e-6


def _resolve_flat_zeros(J, b, status, lo):
    """A search that stopped short (stalled, iteration limit, not a minimum) because some NVRs head to zero.

    Where the likelihood cannot tell an NVR from zero (moving it to the lower bound `lo` changes J by less than
    `FLAT_DJ`), it has no minimum in log10 NVR: J is flat down to -inf, so BFGS stalls in rounding noise there.
    Each such NVR is set to the bound (it is then `at_bound`: zero, reported as such); if the gradient in the
    other NVRs is then below `FLAT_GTOL`, the search had converged and its status becomes CONVERGED (then
    AT_BOUND in the caller). A converged search is returned unchanged. Returns (b, status, zeroed).
    """
    k = b.shape[0]
    lo = jnp.broadcast_to(lo, b.shape)  # one bound, or one per NVR
    J0 = J(b)
    moved = jax.vmap(lambda i: J(jnp.where(jnp.arange(k) == i, lo, b)))(jnp.arange(k))
    # only NVRs (whose lower bound is LOG10_NVR_BOUNDS' zero), not other hyperparameters searched beside them
    flat = (moved - J0 < FLAT_DJ) & (b > lo) & (lo <= LOG10_NVR_BOUNDS[0])
    b_z = jnp.where(flat, lo, b)
    g = jax.jacfwd(J)(b_z)
    settled = jnp.all(jnp.where(flat, True, jnp.abs(g) < FLAT_GTOL)) & jnp.isfinite(J(b_z))
    use = (status != CONVERGED) & jnp.any(flat) & settled
    return jnp.where(use, b_z, b), jnp.where(use, CONVERGED, status), use & flat


def optimise_log10_nvr(criterion, b0, *, scale, max_log10=None, atol=1e-5, max_steps=100, bounds=LOG10_NVR_BOUNDS):
    """Minimise `criterion(b) -> Likelihood` over b = log10 NVR (vector) with `bfgs_minimise`.

    `b` is clipped to `bounds` inside the criterion (zero gradient outside, so
    the search stops at a bound); the result is capped at `max_log10`.
    `scale` (e.g. the number of samples) normalises J to order one for the tolerances.
    Returns an `NVRFit` whose `status` also reports a bound, a non-finite
    likelihood and a curvature that is not positive definite at the estimate.
    """
    lo, hi = bounds

    def J(b):
        return criterion(jnp.clip(b, lo, hi)).J / scale

    b, _, steps, status = bfgs_minimise(J, b0, atol=atol, max_steps=max_steps)
    b = jnp.clip(b, lo, hi)
    b, status, zeroed = _resolve_flat_zeros(J, b, status, lo)
    at_bound = (b <= lo + BOUND_TOL) | (b >= hi - BOUND_TOL)
    if max_log10 is not None:
        at_bound = at_bound | (b >= max_log10 - BOUND_TOL)
        b = jnp.minimum(b, max_log10)
    lik = criterion(b)
    hess = jax.jacfwd(jax.jacfwd(lambda bb: criterion(bb).J))(b)  # exact, forward over forward
    eye = jnp.eye(b.shape[0])
    # an NVR set to zero by `_resolve_flat_zeros` has no curvature: the others' errors from their own block
    free = ~zeroed
    info = jnp.where(free[:, None] & free[None, :], 0.5 * (hess + hess.T) / 2.0, eye)
    chol = jnp.linalg.cholesky(info)
    cov = jsl.cho_solve((chol, True), eye)
    se = jnp.sqrt(jnp.diag(cov))
    definite = jnp.all(jnp.isfinite(chol)) & jnp.all(jnp.isfinite(se))
    se = jnp.where(definite & ~at_bound, se, jnp.inf)
    finite = jnp.isfinite(lik.J) & jnp.all(jnp.isfinite(b))
    ok = status == CONVERGED
    status = jnp.where(
        ~finite,
        NONFINITE,
        jnp.where(~ok, status, jnp.where(jnp.any(at_bound), AT_BOUND, jnp.where(definite, CONVERGED, NOT_MINIMUM))),
    )
    return NVRFit(
        nvr=10.0**b,
        log10_nvr=b,
        log10_nvr_se=se,
        loglik=lik.loglik,
        J=lik.J,
        steps=steps,
        converged=status <= AT_BOUND,
        at_bound=at_bound,
        status=status,
    )


def dlr_likelihood(y, z, nvr, P0, x0, models, burn_in, method="sequential"):
    """Concentrated `Likelihood` of `dlr`'s model from a filter that stores nothing per sample."""
    ss = assemble(models, nvr)
    if is_small(models):
        return block_likelihood(y, z[:, 0], block_system(ss.F, ss.Q), x0, P0, burn_in=burn_in, method=method)
    n = state_dim(models)
    H = observation_rows(z, ss.S)
    return filter_criterion(y, H, ss.F, ss.Q, x0, P0 * jnp.eye(n), burn_in=burn_in, method=method)


@eqx.filter_jit
def fit_ml_nvr(y, z, b0, P0, x0, models, burn_in, max_log10, method="sequential"):
    def criterion(b):
        return dlr_likelihood(y, z, 10.0**b, P0, x0, models, burn_in, method)

    return optimise_log10_nvr(criterion, b0, scale=y.shape[0], max_log10=max_log10)


def check_nvr0(nvr0, name="nvr0"):
    """Start NVR(s) of a search: finite, positive and inside `LOG10_NVR_BOUNDS` (ValueError)."""
    lo, hi = LOG10_NVR_BOUNDS
    return check_values(
        [(name, nvr0, lambda a: ~((a >= 10.0**lo) & (a <= 10.0**hi)).all(), "must be finite and in [1e-30, 1e6]")],
        carrier=nvr0,
    )


def max_log10_nvr(max_nvr):
    """log10 of the `max_nvr` cap (None: no cap); ValueError unless finite and positive."""
    cap = positive_float("max_nvr", max_nvr, allow_none=True)
    return None if cap is None else float(np.log10(cap))


def prepare_ml(y, z, model, nvr0, P0, max_nvr):
    """Checked arguments of `ml_nvr` (shared with `dlr(..., nvr="ml")`)."""
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    models = as_models(model, z.shape[1])
    if n_hyper(models) == 0:
        raise ValueError("`model`: every block is Constant, there is no NVR to estimate")
    nvr0 = check_nvr0(validate_nvr(nvr0, models, name="nvr0"))
    P0 = as_float_array("P0", P0, ndim=0)
    P0 = check_values([("P0", P0, lambda a: ~((a > 0) & (a < np.inf)), "must be finite and positive")], carrier=P0)
    max_log10 = max_log10_nvr(max_nvr)
    y, z, nvr0 = validate_regression(y, z, min_samples=state_dim(models) + 2, carrier=nvr0)
    nvr0 = check_values([("y", y, no_spread, "has zero variance (all observed values equal)")], carrier=nvr0)
    return y, z, jnp.log10(nvr0), P0, models, max_log10


@x64
def ml_nvr(
    y, z, *, model="RW", nvr0=1e-4, P0: float = 1e5, max_nvr: float | None = None, method: str | None = None
) -> NVRFit:
    r"""Maximum-likelihood NVRs of a dynamic linear regression (the model of `jaxsdp.dlr`).

    Model: $y_k = \sum_i z_{ik} \theta_{ik} + e_k$, $e_k \sim N(0, \sigma^2)$, each $\theta_i$
    the first state of a random-walk-family block (`RW`, `IRW`, `SRW`, `LLT`;
    see `jaxsdp.dlr`) whose state noise has variance $NVR \cdot \sigma^2$. The NVR
    (noise variance ratio, dimensionless) sets how fast the parameter may
    vary; $\sigma^2$ is concentrated out.

    The estimate minimises the concentrated criterion

    $$ J(b) = \sum_k \log f_k + n \log( \sum_k v_k^2 / f_k / n ) $$

    ($v_k$ the one-step prediction errors, $f_k$ their normalised variances,
    over the $n$ samples after the burn-in) over $b = \log_{10} NVR$, with jaxsdp's
    BFGS loop and exact forward-mode derivatives through the Kalman filter,
    starting from `nvr0` (CAPTAIN's default 1e-4; its first step is at most
    one decade). The search stays within 1e-30 $\le NVR \le$ 1e6
    (`LOG10_NVR_BOUNDS`); `max_nvr` then caps the result (CAPTAIN caps SDP
    NVRs at 1). `Constant` blocks take no NVR.

    **Arguments**: `y` (N,) (NaN = missing), `z` (N, p), `model` as `jaxsdp.dlr`;
    `nvr0` scalar or one per NVR, finite, in [1e-30, 1e6]; `P0` > 0;
    `max_nvr` finite > 0 or None; `method` the kernels' "sequential",
    "parallel", "auto" or None (the current setting; see `jaxsdp.dlr`).
    Non-finite or non-positive values, an all-NaN or constant `y` raise `ValueError`.

    **Returns** an `NVRFit`: `nvr`, `log10_nvr`, `log10_nvr_se` (inf on a
    bound), `loglik`, `J`, `converged`, `at_bound`, `status` and `reason`.
    Check `converged` and `at_bound` before using `log10_nvr_se`.

    There is no choice of optimiser: an earlier `solver=` option passed the
    criterion to `optimistix` minimisers, which lack this loop's first-step
    scaling and stop where the clipped criterion is flat beyond a bound; they
    reported "converged" at the 1e6 bound or at a point far from the optimum
    (EMPS mass NVR 8.8e-5 instead of 3.8e-12; an RW series with NVR ~ 1 sent
    to 1e6 with J worse by 3,456). The built-in loop is also the faster one
    on the CPU.

    Example:
        >>> import numpy as np, jaxsdp
        >>> rng = np.random.default_rng(0)
        >>> theta = np.cumsum(rng.normal(size=400)) * 0.1        # RW parameter, NVR = 1
        >>> y = theta + 0.1 * rng.normal(size=400)
        >>> fit = jaxsdp.ml_nvr(y, np.ones((400, 1)), model="RW")
        >>> bool(fit.converged), bool(fit.at_bound[0]), fit.reason
        (True, False, 'converged')
        >>> print(np.round(fit.log10_nvr, 1), np.round(fit.log10_nvr_se, 2))
        [-0.1] [0.12]
    """
    y, z, b0, P0, models, max_log10 = prepare_ml(y, z, model, nvr0, P0, max_nvr)
    x0 = jnp.zeros(state_dim(models))
    return fit_ml_nvr(y, z, b0, P0, x0, models, state_dim(models) + 1, max_log10, resolve_method(method))


_dlr_loglik = eqx.filter_jit(dlr_likelihood)


@x64
def dlr_loglik(
    y, z, *, model="RW", nvr=None, P0: float = 1e5, x0=None, burn_in: int | None = None, method: str | None = None
) -> Likelihood:
    r"""Concentrated log-likelihood of `jaxsdp.dlr`'s model, without the smoother.

    Model: $y_k = \sum_i z_{ik} \theta_{ik} + e_k$ with random-walk-family parameters
    (see `jaxsdp.dlr`). Returns the same `loglik` and `J` as `dlr(...)`:
    the prediction-error decomposition with $\sigma^2$ concentrated out,

    $$ J = \sum_k \log f_k + n \log( \sum_k v_k^2 / f_k / n ), $$

    $$ loglik = -J/2 - (n/2)(\log 2\pi + 1), $$

    over the observed samples after the first $dim(s)+1$ (`burn_in`), from one
    filter pass that stores nothing per sample: the function to
    differentiate for gradient-based NVR estimation (`jax.jvp` suits a few
    NVRs, `jax.grad` works too). `sigma2` is the concentrated-out estimate
    over the same innovations as the likelihood (`dlr.sigma2` starts one
    sample earlier, CAPTAIN's convention).

    Arguments as `jaxsdp.dlr` (`method` included); `nvr` (finite, >= 0) is required (it is not
    estimated here: see `jaxsdp.ml_nvr`). Returns a `Likelihood` (`loglik`,
    `J`, `sigma2`, `n_used`).

    Example:
        >>> import numpy as np, jaxsdp
        >>> y = np.sin(np.linspace(0.0, 6.0, 200))
        >>> lik = jaxsdp.dlr_loglik(y, np.ones((200, 1)), model="IRW", nvr=1e-4)
        >>> int(lik.n_used), bool(np.isfinite(lik.loglik))
        (197, True)
    """
    if isinstance(nvr, str):
        raise ValueError(f"`nvr` must be numbers here (use `jaxsdp.ml_nvr` to estimate them); got {nvr!r}")
    y, z, nvr, P0, x0, models, burn_in = validate_dlr_args(y, z, model, nvr, P0, x0, burn_in)
    m = resolve_method(method)
    return _dlr_loglik(y, z, nvr, P0, x0, models, burn_in, m)
