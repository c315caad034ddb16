"""CAPTAIN-style NVR estimation for SDP models: Nelder-Mead on the first back-fitting sweep.

The CAPTAIN toolbox's `sdp` estimates each term's NVR by minimising, with
MATLAB's `fminsearch` simplex on log10 NVR, the concentrated
likelihood of the term's sorted partial residual during the first
back-fitting sweep. `captain_nvrs` does exactly that with the criterion
`jaxsdp.sdp` uses (`term_criterion`); pass its NVRs to `jaxsdp.sdp(..., nvr=...)`
for the back-fitting. scipy's Nelder-Mead is used (with MATLAB's initial
simplex) because the result must match the toolbox's local search, not the
global optimum a gradient method may reach.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import scipy.optimize

from .._checks import as_float_array, check_finite
from .._kalman.models import LLT, Constant, as_models
from .._kalman.nvr import BOUND_TOL, LOG10_NVR_BOUNDS, check_nvr0, max_log10_nvr
from .._runtime import x64
from .backfit import Term, check_spread, sorted_order, term_criterion, term_update, validate_states


@eqx.filter_jit
def _term_criterion(b, r, zj, prev, term, P0):
    # The criterion `jaxsdp.sdp` optimises for one term, on the search bounds.
    lo, hi = LOG10_NVR_BOUNDS
    return term_criterion(r, zj, prev, term, P0)(jnp.clip(b, lo, hi)[None]).J


@eqx.filter_jit
def _term_smooth(r, zj, prev, term, nvr, P0):
    return term_update(r, zj, prev, term, nvr, optimise=False, max_log10=None, P0=P0).par


def _fminsearch_1d(f, b0: float, *, xatol: float, fatol: float, maxiter: int) -> float:
    # MATLAB fminsearch's initial simplex: x0 and x0 * 1.05 (0.00025 if x0 = 0).
    b1 = b0 * 1.05 if b0 != 0 else 0.00025
    res = scipy.optimize.minimize(
        lambda v: float(f(float(v[0]))),
        np.array([b0]),
        method="Nelder-Mead",
        options=dict(initial_simplex=np.array([[b0], [b1]]), xatol=xatol, fatol=fatol, maxiter=maxiter),
    )
    return float(res.x[0])


def _log10_se(f, b: float, h: float = 0.05) -> float:
    # Curvature standard error of log10 NVR: info = J''/2 (J = -2 loglik + const).
    d2 = (float(f(b + h)) - 2.0 * float(f(b)) + float(f(b - h))) / (h * h)
    return float(np.sqrt(2.0 / d2)) if d2 > 0 else float("inf")


@x64
def captain_nvrs(y, z, x, *, model="RW", nvr=None, nvr0=1e-4, max_nvr=1.0, P0=1e5, xatol=0.01):
    r"""ML NVRs of an SDP model on the first back-fitting sweep, CAPTAIN style.

    Model (as `jaxsdp.sdp`): $y_k = \sum_j c_j(x_{jk}) z_{jk} + e_k$, each $c_j$ a
    random walk in the order of its state $x_j$ with noise variance ratio $NVR_j$.
    Starting from the constant least-squares parameters, for each term $j$ in
    order: the partial residual $r = y - \sum_{i \ne j} c_i z_i$ is sorted by
    $x_j$, the concentrated criterion $J(\log_{10} NVR_j)$ that `jaxsdp.sdp` uses is
    minimised by Nelder-Mead from $\log_{10}$ `nvr0` (MATLAB `fminsearch` initial
    simplex, tolerance `xatol` on $\log_{10} NVR$), the result is clipped to the
    search bounds (1e-30, 1e6) and capped at `max_nvr`, and $c_j$ is smoothed
    with it before the next term.

    `nvr`: None (all estimated) or (p,) with NaN for the entries to estimate
    (the others finite, >= 0). `nvr0` finite in [1e-30, 1e6]; `max_nvr`
    finite > 0 or None; a constant `y` is a ValueError.
    Returns `(nvr, log10_nvr_se)` as numpy arrays: `log10_nvr_se` is NaN for
    a given NVR and inf for one on a bound (search bound or `max_nvr` cap) or
    where the criterion's curvature is not positive. Pass `nvr` to
    `jaxsdp.sdp(y, z, x, nvr=nvr)` for the back-fitting.

    Example:
        >>> import numpy as np, jaxsdp
        >>> rng = np.random.default_rng(0)
        >>> x = rng.uniform(-2, 2, (300, 1))
        >>> y = 1.0 + 0.5 * x[:, 0] ** 2 + 0.05 * rng.normal(size=300)   # c(x) = 1 + x^2 / 2, z = 1
        >>> nvr, se = jaxsdp.captain_nvrs(y, np.ones((300, 1)), x)
        >>> nvr.shape, bool(nvr[0] > 1e-6)
        ((1,), True)
    """
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    x = as_float_array("x", x, ndim=2)
    p = z.shape[1]
    models = as_models(model, p)
    for m in models:
        if isinstance(m, (LLT, Constant)):
            raise ValueError(f"`model`: SDP terms must be RW, IRW or SRW (one NVR each); got {m.name}")
    if z.shape[0] != y.shape[0] or x.shape != z.shape:
        raise ValueError(f"`y` (N,), `z` and `x` (N, p) must agree; got {y.shape}, {z.shape}, {x.shape}")
    y = check_finite("y", y)
    z = check_finite("z", z)
    x = validate_states(x)
    check_spread("y", y, y)
    if nvr is None:
        fixed = np.full(p, np.nan)
    else:
        try:
            fixed = np.broadcast_to(np.asarray(nvr, dtype=float), (p,)).copy()
        except ValueError:
            raise ValueError(f"`nvr` must be None, a scalar or shape ({p},); got {nvr!r}") from None
        if np.any(fixed[~np.isnan(fixed)] < 0) or not np.all(np.isfinite(fixed[~np.isnan(fixed)])):
            raise ValueError(f"`nvr`: fixed NVRs must be finite and non-negative; got {fixed}")
    check_nvr0(as_float_array("nvr0", nvr0, ndim=0))
    max_log10 = max_log10_nvr(max_nvr)
    P0 = jnp.asarray(P0, dtype=jnp.float64)
    lo, hi = LOG10_NVR_BOUNDS
    cap = hi if max_log10 is None else min(hi, max_log10)
    c0 = jnp.linalg.lstsq(z, y)[0]
    par = jnp.broadcast_to(c0, z.shape)
    fit = jnp.sum(par * z, axis=1)
    out_nvr = np.empty(p)
    out_se = np.full(p, np.nan)
    for j in range(p):
        perm, adv = sorted_order(x[:, j])
        term = Term(models[j], perm, adv)
        zj = z[:, j]
        r = y - fit + par[:, j] * zj
        prev = par[:, j]
        if np.isnan(fixed[j]):

            def J(b, r=r, zj=zj, prev=prev, term=term):
                v = float(_term_criterion(jnp.asarray(b), r, zj, prev, term, P0))
                return v if np.isfinite(v) else np.inf

            b = _fminsearch_1d(J, float(np.log10(nvr0)), xatol=xatol, fatol=1e-4, maxiter=200)
            on_bound = b <= lo + BOUND_TOL or b >= cap - BOUND_TOL
            b = min(max(b, lo), hi, cap)
            out_se[j] = np.inf if on_bound else _log10_se(J, b)
            out_nvr[j] = 10.0**b
        else:
            out_nvr[j] = fixed[j]
        cj = _term_smooth(r, zj, prev, term, jnp.asarray(out_nvr[j]), P0)
        fit = fit - par[:, j] * zj + cj * zj
        par = par.at[:, j].set(cj)
    return out_nvr, out_se
