"""State-dependent parameter (SDP) estimation by sorted-TVP back-fitting.

Model (CAPTAIN's `sdp`):

    y_k = sum_{j=1..p} c_j(x_jk) z_jk + e_k,

each c_j an unknown function of its own state x_j. Each c_j is
estimated non-parametrically as a random walk (RW/IRW/SRW) *in the order of
ascending x_j*, where it varies slowly, by the Kalman filter and
fixed-interval smoother (`jaxsdp._kalman.closed_form`). Back-fitting (Gauss-Seidel):

1. start from constant least squares c_j = (Z^+ y)_j;
2. sweep j = 1..p: partial residual r = y - sum_{i != j} c_i z_i; sort by
   x_j (stable: ties keep time order); on the sweeps where NVRs are
   optimised, maximise the concentrated likelihood of the sorted partial
   residual over log10 NVR_j (BFGS, exact derivatives) and cap it;
   filter and smooth in sorted order starting from the previous estimate;
   un-sort;
3. after sweep i, R^2_i = 1 - var(y - fit)/var(y);
   stop when i > 3 and |R^2_i - R^2_{i-1}| or |R^2_i - R^2_{i-2}| is
   below `tol`, or after `max_sweeps`.

Tied state values do not advance the random walk (transition I, no noise),
so tied samples share one estimate and long runs of equal states stay finite.
"""

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._checks import as_float_array, check_finite, check_value, check_values, no_spread
from .._kalman.closed_form import block_filter_smoother, block_likelihood, block_system
from .._kalman.models import LLT, Constant, as_models
from .._kalman.nvr import FIXED, check_nvr0, max_log10_nvr, optimise_log10_nvr, status_reason
from .._linalg import lstsq
from .._runtime import resolve_method, x64

#: NVRs below this are reported as constant parameters (`SDPResult.constant`).
CONSTANT_NVR = 1e-6


class SDPResult(eqx.Module):
    r"""Result of `jaxsdp.sdp` for $y_k = \sum_j c_j(x_{jk}) z_{jk} + e_k$ (p terms, N samples).

    - `par`, `parse`: (N, p) SDP estimates $c_j(x_{jk})$ in time order and their
      standard errors (units of $y / z_j$).
    - `x_sorted`, `par_sorted`, `parse_sorted`: (p, N) the same along each
      term's sorted state (for plotting $c_j$ against $x_j$).
    - `nvr`: (p,) NVRs (dimensionless). `log10_nvr_se`: (p,) curvature
      standard errors of $\log_{10} NVR$: **NaN** for a fixed (given) NVR, **inf**
      where there is none: the NVR is on a bound (`nvr_at_bound`) or the
      likelihood's curvature is not positive definite there.
    - `nvr_at_bound`: (p,) bool, the estimated NVR is at the `max_nvr` cap or
      at a search bound (`LOG10_NVR_BOUNDS`: 1e-30, 1e6); report it as
      "NVR on its bound", never with a standard error.
    - `nvr_converged`: (p,) bool, the NVR search met its tolerances (True for
      a fixed NVR); `nvr_status`: (p,) its `NVRFit.status` code (-1 for a
      fixed NVR). With `optimise_on="first"` these describe the first sweep's
      search (the one that set the NVRs).
    - `definite`: (p,) bool, each term's last smoothing pass kept its
      covariances numerically positive definite (see `jaxsdp.DLRResult.definite`).
    - `term_loglik`: (p,) concentrated log-likelihood of each term's last smoothing pass.
    - `constant`: (p,) bool, NVR below `constant_nvr`: the parameter does not
      depend on its state.
    - `fit`, `resid`: (N,); `r2`: $1 - var(resid)/var(y)$;
      `relative_error`: $100 \|y - fit\| / \|y\|$ (%); `sigma2`: residual variance (units of $y^2$).
    - `sweeps`: back-fitting sweeps used; `converged`: the back-fitting $R^2$
      rule was met (it says nothing about the NVR searches: see
      `nvr_converged`, `nvr_at_bound`); `r2_history`: (max_sweeps,) $R^2$ after
      each sweep (NaN after the last).
    - `reason` (a property, outside `jit`): all of this in words.
    """

    @property
    @x64
    def reason(self):
        """Back-fitting and per-term NVR outcome in words (a str; an array of str for a vmapped batch)."""
        return outcome_text(self.converged, self.sweeps, self.nvr_status, self.nvr_at_bound, self.definite, "sweeps")

    par: jnp.ndarray
    parse: jnp.ndarray
    x_sorted: jnp.ndarray
    par_sorted: jnp.ndarray
    parse_sorted: jnp.ndarray
    nvr: jnp.ndarray
    log10_nvr_se: jnp.ndarray
    nvr_at_bound: jnp.ndarray
    nvr_converged: jnp.ndarray
    nvr_status: jnp.ndarray
    definite: jnp.ndarray
    term_loglik: jnp.ndarray
    constant: jnp.ndarray
    fit: jnp.ndarray
    resid: jnp.ndarray
    r2: jnp.ndarray
    relative_error: jnp.ndarray
    sigma2: jnp.ndarray
    sweeps: jnp.ndarray
    converged: jnp.ndarray
    r2_history: jnp.ndarray


def outcome_text(converged, count, status, at_bound, definite, what):
    """Summary of a back-fitting result in words; vectorised over leading (vmap) axes."""
    conv, cnt = np.asarray(converged), np.asarray(count)
    st, ab, df = np.asarray(status), np.asarray(at_bound), np.asarray(definite)

    def one(idx):
        head = "converged" if conv[idx] else "not converged"
        parts = [f"back-fitting {head} after {int(cnt[idx])} {what}"]
        for j, (c, b, d) in enumerate(zip(st[idx], ab[idx], df[idx])):
            text = status_reason(c)
            if b and "bound" not in text:
                text += "; NVR on a bound"
            if not d:
                text += "; covariance lost positive definiteness (standard errors unreliable)"
            parts.append(f"term {j} NVR: {text}")
        return "; ".join(parts)

    if conv.ndim == 0:
        return one(())
    out = np.empty(conv.shape, dtype=object)
    for idx in np.ndindex(conv.shape):
        out[idx] = one(idx)
    return out


class Term(eqx.Module):
    """Static description of one SDP term and its sorted order."""

    model: eqx.Module = eqx.field(static=True)
    perm: jnp.ndarray  # (N,) argsort of the state (stable)
    advance: jnp.ndarray  # (N,) bool: sorted state differs from the previous one


class _TermOut(eqx.Module):
    par: jnp.ndarray
    var: jnp.ndarray  # normalised smoothed variance (times sigma2 = se^2)
    sigma2: jnp.ndarray
    nvr: jnp.ndarray
    log10_nvr_se: jnp.ndarray
    loglik: jnp.ndarray
    at_bound: jnp.ndarray  # bool: the ML NVR is on a search bound or the cap
    status: jnp.ndarray  # `NVRFit.status` of the ML search, FIXED for a given NVR
    definite: jnp.ndarray  # bool: the smoothing pass's covariances stayed positive definite


def keep_search(new, old):
    """`new` with the NVR search outcome (se, bound, status) of `old` (NVRs optimised on the first sweep only)."""
    return eqx.tree_at(
        lambda o: (o.log10_nvr_se, o.at_bound, o.status), new, (old.log10_nvr_se, old.at_bound, old.status)
    )


def sorted_order(xj):
    perm = jnp.argsort(xj, stable=True)
    xs = xj[perm]
    advance = jnp.concatenate([jnp.ones(1, bool), xs[1:] != xs[:-1]])
    return perm, advance


def _system(model, nvr):
    return model.transition(), model.noise(jnp.reshape(nvr, (1,)))


def term_criterion(r, zj, prev, term: "Term", P0, method: str = "sequential"):
    """b = [log10 NVR] -> concentrated `Likelihood` of a term's sorted partial residual.

    The criterion the first back-fitting sweep optimises (CAPTAIN's): the
    partial residual `r` and regressor `zj` in the order of the term's state,
    filtered from the previous estimate `prev` at the first sorted sample.
    """
    model = term.model
    d = model.dim
    rs, h = r[term.perm], zj[term.perm]
    x0 = jnp.zeros(d).at[0].set(prev[term.perm[0]])

    def criterion(b):
        F, Q = _system(model, 10.0 ** b[0])
        sys = block_system(F, Q)
        return block_likelihood(rs, h, sys, x0, P0, burn_in=d + 1, advance=term.advance, method=method)

    return criterion


def term_update(r, zj, prev, term: Term, nvr, *, optimise: bool, max_log10, P0, method: str = "sequential"):
    """One back-fitting step for a term: smooth the partial residual `r` in sorted order.

    `prev` is the term's previous estimate (time order) used as initial state.
    Returns a `_TermOut` in time order.
    """
    model = term.model
    d = model.dim
    perm = term.perm
    rs = r[perm]
    h = zj[perm]
    x0 = jnp.zeros(d).at[0].set(prev[perm[0]])
    burn_in = d + 1

    if optimise:
        b0 = jnp.log10(jnp.clip(nvr, 1e-30))[None]
        criterion = term_criterion(r, zj, prev, term, P0, method)
        fit = optimise_log10_nvr(criterion, b0, scale=r.shape[0], max_log10=max_log10)
        nvr = fit.nvr[0]
        se, at_bound, status = fit.log10_nvr_se[0], fit.at_bound[0], fit.status
    else:
        se, at_bound, status = jnp.nan, jnp.asarray(False), jnp.asarray(FIXED)
    F, Q = _system(model, nvr)
    out = block_filter_smoother(
        rs, h, block_system(F, Q), x0, P0, burn_in=burn_in, sigma2_burn_in=d, advance=term.advance, method=method
    )
    lik = out.loglik
    inv = jnp.zeros_like(r)
    par = inv.at[perm].set(out.x_smooth[:, 0])
    var = inv.at[perm].set(jnp.clip(out.P_smooth_diag[:, 0], 0.0))
    return _TermOut(par, var, lik.sigma2, nvr, se, lik.loglik, at_bound, status, out.definite)


def loop_kind(opt_mask):
    """`lax.while_loop` when NVRs are estimated (the ML search is not reverse-differentiable
    anyway); with all NVRs fixed a "bounded" loop, which reverse-mode AD can differentiate."""
    return "lax" if any(opt_mask) else "bounded"


def _r2(y, fit):
    return 1.0 - jnp.var(y - fit) / jnp.var(y)


def backfit_sweep(y, z, par, terms, nvr, optimise_mask, *, max_log10, P0, method: str = "sequential"):
    """One Gauss-Seidel sweep over the terms: returns (par, fit, stacked `_TermOut`).

    When every term has the same model and ML setting, the sweep is one
    `lax.scan` over the terms (traced and compiled once, whatever p is);
    otherwise a Python loop over the terms.
    """
    p = z.shape[1]
    fit = jnp.sum(par * z, axis=1)
    same = len({(t.model, bool(m)) for t, m in zip(terms, optimise_mask)}) == 1
    if same and p > 1:
        model, optimise = terms[0].model, bool(optimise_mask[0])

        def step(carry, inp):
            (fit,) = carry
            zj, prev, perm, adv, nv = inp
            r = y - fit + prev * zj
            term = Term(model, perm, adv)
            out = term_update(r, zj, prev, term, nv, optimise=optimise, max_log10=max_log10, P0=P0, method=method)
            return (fit - prev * zj + out.par * zj,), out

        # Gauss-Seidel needs the newest estimates: `prev` of term j is untouched by terms < j
        xs = (z.T, par.T, jnp.stack([t.perm for t in terms]), jnp.stack([t.advance for t in terms]), nvr)
        (fit,), outs = lax.scan(step, (fit,), xs)
        outs = jax.tree.map(lambda a: jnp.moveaxis(a, 0, -1), outs)
        return outs.par, fit, outs
    outs = []
    for j in range(p):
        zj = z[:, j]
        r = y - fit + par[:, j] * zj
        out = term_update(
            r,
            zj,
            par[:, j],
            terms[j],
            nvr[j],
            optimise=bool(optimise_mask[j]),
            max_log10=max_log10,
            P0=P0,
            method=method,
        )
        fit = fit - par[:, j] * zj + out.par * zj
        par = par.at[:, j].set(out.par)
        outs.append(out)
    return par, fit, jax.tree.map(lambda *a: jnp.stack(a, axis=-1), *outs)


@eqx.filter_jit
def _sdp(y, z, x, nvr0, opt_mask, models, optimise_on, max_log10, P0, tol, max_sweeps, constant_nvr, method):
    N, p = z.shape
    terms = []
    for j in range(p):
        perm, adv = sorted_order(x[:, j])
        terms.append(Term(models[j], perm, adv))
    c0 = lstsq(z, y)  # LAPACK, or Householder in lax under vmap (jaxsdp._linalg)
    par = jnp.broadcast_to(c0, (N, p))

    def sweep(par, nvr, optimise_mask):
        return backfit_sweep(y, z, par, terms, nvr, optimise_mask, max_log10=max_log10, P0=P0, method=method)

    # first sweep: optimise the NVRs marked for ML
    par, fit, out = sweep(par, nvr0, opt_mask)
    r2_hist = jnp.full((max_sweeps,), jnp.nan).at[0].set(_r2(y, fit))
    later_mask = opt_mask if optimise_on == "all" else (False,) * p

    def cond(c):
        i, _, _, _, _, done = c
        return (i < max_sweeps) & ~done

    def body(c):
        i, par, fit, out, r2_hist, _ = c
        par, fit, new = sweep(par, out.nvr, later_mask)
        if optimise_on != "all":
            new = keep_search(new, out)
        r2 = _r2(y, fit)
        r2_hist = r2_hist.at[i].set(r2)
        # i sweeps done before this one, so this is sweep i + 1 (1-based)
        prev1 = r2_hist[i - 1]
        prev2 = jnp.where(i >= 2, r2_hist[jnp.maximum(i - 2, 0)], jnp.inf)
        done = (i + 1 > 3) & ((jnp.abs(r2 - prev1) < tol) | (jnp.abs(r2 - prev2) < tol))
        return i + 1, par, fit, new, r2_hist, done

    init = (jnp.array(1), par, fit, out, r2_hist, jnp.array(False))
    sweeps, par, fit, out, r2_hist, converged = eqxi.while_loop(
        cond, body, init, max_steps=max_sweeps, kind=loop_kind(opt_mask)
    )

    resid = y - fit
    sigma2 = jnp.sum(resid**2) / (N - 1)
    se = jnp.sqrt(out.sigma2[None, :] * out.var)
    xs = jnp.stack([x[t.perm, j] for j, t in enumerate(terms)])
    par_sorted = jnp.stack([par[t.perm, j] for j, t in enumerate(terms)])
    se_sorted = jnp.stack([se[t.perm, j] for j, t in enumerate(terms)])
    return SDPResult(
        par=par,
        parse=se,
        x_sorted=xs,
        par_sorted=par_sorted,
        parse_sorted=se_sorted,
        nvr=out.nvr,
        log10_nvr_se=out.log10_nvr_se,
        nvr_at_bound=out.at_bound,
        nvr_converged=out.status <= 1,
        nvr_status=out.status,
        definite=out.definite,
        term_loglik=out.loglik,
        constant=out.nvr < constant_nvr,
        fit=fit,
        resid=resid,
        r2=_r2(y, fit),
        relative_error=100.0 * jnp.linalg.norm(resid) / jnp.linalg.norm(y),
        sigma2=sigma2,
        sweeps=sweeps,
        converged=converged,
        r2_history=r2_hist,
    )


def validate_states(x, name="x"):
    """Each state column must be finite and have a real spread (>= 3 distinct values)."""
    x = check_finite(name, x)

    def no_spread(a):
        xp = np if isinstance(a, np.ndarray) else jnp
        srt = xp.sort(a, axis=0)
        distinct = 1 + xp.sum(srt[1:] != srt[:-1], axis=0)
        scale = xp.maximum(1.0, xp.max(xp.abs(a), axis=0))
        return xp.any((srt[-1] - srt[0] <= 1e-12 * scale) | (distinct < 3))

    return check_value(name, x, no_spread, "a state column has (almost) no spread (fewer than 3 distinct values)")


def nvr_spec(nvr, nvr0, p):
    """Starting NVRs (p,) and the static mask of terms whose NVR is estimated by ML.

    `nvr=None`: all estimated from `nvr0`; otherwise fixed values (finite,
    >= 0), NaN entries estimated. A traced `nvr` (under jit/vmap/grad) is all
    fixed, and a NaN in it is an error. `nvr0` must be finite and in [1e-30, 1e6].
    """
    nvr0 = check_nvr0(as_float_array("nvr0", nvr0, ndim=0))
    if nvr is None:
        return jnp.full((p,), nvr0), (True,) * p
    nvr = as_float_array("nvr", nvr)
    if nvr.ndim == 0:
        nvr = jnp.full((p,), nvr)
    if nvr.shape != (p,):
        raise ValueError(f"`nvr` must be None, a scalar or shape ({p},); got shape {tuple(nvr.shape)}")
    if isinstance(nvr, jax.core.Tracer):
        opt_mask = (False,) * p
    else:
        nv = np.asarray(nvr)
        opt_mask = tuple(bool(v) for v in np.isnan(nv))
        fixed = nv[~np.isnan(nv)]
        if np.any(fixed < 0) or not np.all(np.isfinite(fixed)):
            raise ValueError(f"`nvr`: fixed NVRs must be non-negative and finite (NaN: estimate it); got {nv}")
    start = jnp.where(jnp.isnan(nvr), nvr0, nvr) if any(opt_mask) else nvr
    bad = lambda a: ~((a >= 0) & (a < np.inf)).all()
    return check_value("nvr", start, bad, "fixed NVRs must be non-negative and finite"), opt_mask


def check_spread(name, y, carrier):
    """`y` with zero variance leaves nothing to estimate (R^2 undefined): ValueError; guard rides on `carrier`."""
    return check_values([(name, y, no_spread, "has zero variance (all values equal)")], carrier=carrier)


def check_search(y, x, nvr, nvr0, p, *, optimise_on, max_nvr, count):
    """The checks `sdp` and `multi_sdp` share: search options, finite `y`, states, NVRs.

    `count` is (name, value) of the iteration limit. Returns
    `(y, x, nvr_start, opt_mask, max_log10)`.
    """
    if optimise_on not in ("first", "all"):
        raise ValueError(f"`optimise_on` must be 'first' or 'all'; got {optimise_on!r}")
    name, value = count
    if int(value) < 1:
        raise ValueError(f"`{name}` must be >= 1; got {value}")
    y = check_finite("y", y)
    x = validate_states(x)
    nvr_start, opt_mask = nvr_spec(nvr, nvr0, p)
    nvr_start = check_spread("y", y, nvr_start)
    return y, x, nvr_start, opt_mask, max_log10_nvr(max_nvr)


def search_options(nvr, optimise_on: str, y, z, x, *, model, P0) -> dict:
    """The `nvr`, `nvr0`, `max_nvr`, `optimise_on` of an NVR search: an object with `_sdp_options` (`MLNVR`,
    `FixedNVR`, `CaptainNVR`, whose host search runs here), or None / fixed NVRs (maximum likelihood from 1e-4,
    capped at 1, on `optimise_on`)."""
    options = dict(nvr=None, nvr0=1e-4, max_nvr=1.0, optimise_on=optimise_on)
    if nvr is not None and hasattr(nvr, "_sdp_options"):
        return options | nvr._sdp_options(y, z, x, model=model, P0=P0)
    return options | dict(nvr=nvr)


def check_sdp_models(model, p):
    models = as_models(model, p)
    for m in models:
        if isinstance(m, (LLT, Constant)):
            raise ValueError(f"`model`: SDP terms must be RW, IRW or SRW (one NVR each); got {m.name}")
    return models


@x64
def sdp(
    y,
    z,
    x,
    *,
    model="RW",
    nvr=None,
    max_sweeps: int = 10,
    tol: float = 1e-3,
    P0: float = 1e5,
    constant_nvr: float = CONSTANT_NVR,
    method: str | None = None,
) -> SDPResult:
    r"""State-dependent parameter (SDP) estimation by back-fitting (CAPTAIN's `sdp`).

    Model, for samples $k = 1..N$ and $p$ terms:

    $$ y_k = \sum_j c_j(x_{jk}) z_{jk} + e_k, \quad e_k \sim N(0, \sigma^2), $$

    each $c_j$ an unknown function of its own state $x_j$, estimated without a
    parametric form: as a random walk (RW, IRW or SRW) in the order of
    ascending $x_j$, whose noise variance ratio $NVR_j$ (dimensionless) sets how
    fast $c_j$ may vary with $x_j$.

    Algorithm (Gauss-Seidel back-fitting):

    1. start from the constant least-squares parameters;
    2. sweep $j = 1..p$: form the partial residual $r = y - \sum_{i \ne j} c_i z_i$,
       sort it by $x_j$ (ties share one estimate), estimate $NVR_j$ by maximum
       likelihood of the sorted residual (BFGS over $\log_{10} NVR$, exact
       derivatives; on the first sweep only, or on all with
       `optimise_on="all"`), cap it at `max_nvr`, then Kalman filter and
       smooth in sorted order and un-sort;
    3. after sweep $i$, $R^2_i = 1 - var(y - fit) / var(y)$; stop when $i > 3$ and
       $R^2$ changed by less than `tol` over one or two sweeps, or after `max_sweeps`.

    **Arguments**

    - `y`: (N,) output (finite, not constant); `z`: (N, p) regressors; `x`: (N, p) the
      state each parameter depends on (column j for term j; may equal z).
    - `model`: `"RW"` (default, as the paper's EMPS results imply), `"IRW"`,
      `jaxsdp.SRW(alpha)`, or one per term.
    - `nvr`: the NVR search, an object: `jaxsdp.MLNVR(nvr0, max_nvr, optimise_on, fixed)` (maximum
      likelihood from `nvr0`, CAPTAIN's 1e-4; capped at `max_nvr`, 1 by default, None for none; on the
      `"first"` sweep only, the default, or on `"all"`), `jaxsdp.FixedNVR(nvr)` (no search) or
      `jaxsdp.CaptainNVR(nvr0, max_nvr)` (the toolbox's simplex search, on the host first); or None
      (`MLNVR()`), or (p,) fixed NVRs (finite, >= 0; 0 = constant parameter) where NaN entries are
      estimated as `MLNVR()` does.
    - `max_sweeps` (10) and `tol` (1e-3): back-fitting stopping rule on $R^2$.
    - `constant_nvr`: NVRs below it flag a term as constant (default 1e-6).
    - `method`: the Kalman kernels, "sequential", "parallel", "auto" or None
      (the current setting; see `jaxsdp.dlr`). The sort stays `jnp.argsort`.

    Non-finite or negative values of these raise `ValueError` at call time.

    **Returns** an `SDPResult`: `par` $c_j(x_{jk})$ (units of $y / z_j$) and
    `parse`, `nvr`, `log10_nvr_se` (NaN: fixed; inf: on a bound),
    `nvr_at_bound`, `nvr_converged`, `definite`, `converged` ($R^2$ rule),
    `r2`, `reason`, ... Works under `jax.vmap` over data sets of equal length
    (with fixed or ML NVRs) and `jax.grad` with fixed NVRs.

    Example:
        >>> import numpy as np, jaxsdp
        >>> rng = np.random.default_rng(0)
        >>> x = rng.uniform(-2.0, 2.0, 500)
        >>> y = np.tanh(2 * x) + 0.05 * rng.normal(size=500)     # one term c(x), z = 1
        >>> res = jaxsdp.sdp(y, np.ones((500, 1)), x[:, None])
        >>> bool(res.converged), bool(res.nvr_converged[0]), bool(res.nvr_at_bound[0])
        (True, True, False)
        >>> i = np.argsort(x)[[50, 250, 450]]                    # c(x) at three states
        >>> print(np.round(res.par[i, 0] - np.tanh(2 * x[i]), 1) + 0.0)
        [0. 0. 0.]
    """
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    x = as_float_array("x", x, ndim=2)
    N = y.shape[0]
    if z.shape[0] != N or x.shape[0] != N:
        raise ValueError(
            f"`y`, `z` and `x` must have the same number of samples; got y {tuple(y.shape)}, "
            f"z {tuple(z.shape)}, x {tuple(x.shape)}"
        )
    if x.shape != z.shape:
        raise ValueError(f"`x` must have one state column per regressor: z {tuple(z.shape)}, x {tuple(x.shape)}")
    p = z.shape[1]
    models = check_sdp_models(model, p)
    dmax = max(m.dim for m in models)
    if N < dmax + 2 or N < p + 3:
        raise ValueError(f"`y` has {N} samples; at least {max(dmax + 2, p + 3)} are needed for {p} terms")
    z = check_finite("z", z)
    search = search_options(nvr, "first", y, z, x, model=model, P0=P0)
    optimise_on = search["optimise_on"]
    y, x, nvr_start, opt_mask, max_log10 = check_search(
        y, x, search["nvr"], search["nvr0"], p, optimise_on=optimise_on, max_nvr=search["max_nvr"],
        count=("max_sweeps", max_sweeps),
    )  # fmt: skip
    return _sdp(
        y,
        z,
        x,
        nvr_start,
        opt_mask,
        models,
        optimise_on,
        max_log10,
        as_float_array("P0", P0, ndim=0),
        float(tol),
        int(max_sweeps),
        float(constant_nvr),
        resolve_method(method),
    )
