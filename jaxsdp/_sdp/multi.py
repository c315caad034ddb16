"""Multi-SDP disturbance by iterative back-fitting (the paper's section 3.3).

Model, with a known coefficient a on a known signal w (e.g. an inertia
times the acceleration):

    y_k = a w_k + sum_{j=1..m} d_j(x_jk) + e_k .

Each d_j is an SDP on the regressor 1, a random walk in the order of its
own state x_j. With d = y - a w and d_j^0 = 0, iteration k sweeps
j = 1..m: d_j^k = fixed-interval smoothing (sorted by x_j) of
d - sum_{i<j} d_i^k - sum_{i>j} d_i^{k-1}. It stops when

    ||d^k - d^{k-1}|| / ||d^k|| <= tol,      d^k = sum_j d_j^k,

(default tol 1 %; the paper uses 0.5-5 %). NVRs are estimated by maximum
likelihood at every iteration (as the paper's procedure, which calls
CAPTAIN's `sdp` at each step), on the first only, or fixed. A constant can move freely
between the d_j: each SDP absorbs its own offset, reported as its mean
`offsets[j]`; only their sum is identified.

`MultiBackfitting(model, tol, max_iter, max_nvr, optimise_on, nvr0, P0)`
holds these options as one object (the optimistix way):
`MultiBackfitting(...)(y, x, w=w, a=a)` is `multi_sdp(y, x, w=w, a=a, ...)`.
"""

import equinox as eqx
import equinox.internal as eqxi
import jax.numpy as jnp
import numpy as np

from .._checks import as_float_array, check_finite
from .._kalman.models import ParameterModel
from .._runtime import resolve_method, x64
from .backfit import (
    Term,
    backfit_sweep,
    check_sdp_models,
    check_search,
    keep_search,
    loop_kind,
    outcome_text,
    search_options,
    sorted_order,
)
from .options import MLNVR


class MultiSDPResult(eqx.Module):
    r"""Result of `jaxsdp.multi_sdp` for $y_k = a w_k + \sum_j d_j(x_{jk}) + e_k$ (m SDPs, N samples).

    - `d`, `dse`: (N, m) each disturbance $d_j(x_{jk})$ in time order and its standard error (units of y).
    - `x_sorted`, `d_sorted`, `dse_sorted`: (m, N) along each sorted state.
    - `nvr`: (m,); `log10_nvr_se`: (m,) (NaN for fixed NVRs, inf for an NVR on
      a bound or where the curvature is not positive definite);
      `nvr_at_bound`, `nvr_converged`, `nvr_status`, `definite`: (m,) as in
      `jaxsdp.SDPResult`; `offsets`: (m,) mean of each $d_j$.
    - `leverage`: (N, m) diagonal of each smoother's hat matrix, $P_{k|N} / \sigma^2$
      (its smoothed variance in units of the noise variance, in [0, 1]);
      `edf` (property): (m,) their sums, each smoother's effective degrees of
      freedom (about 1 for a constant curve, N for one through every point).
    - `disturbance`: (N,) $\sum_j d_j$; `fit` = $a w + disturbance$; `resid` = $y - fit$.
    - `relative_error`: $100 \|y - fit\| / \|y\|$ (%).
    - `iterations`; `converged`: the change rule was met (see `nvr_converged`
      for the NVR searches); `change_history`: relative change of $d$ per
      iteration (NaN after the last); `reason` (property, outside `jit`): in words.
    """

    @property
    @x64
    def reason(self):
        """Back-fitting and per-SDP NVR outcome in words (a str; an array of str for a vmapped batch)."""
        return outcome_text(
            self.converged, self.iterations, self.nvr_status, self.nvr_at_bound, self.definite, "iterations"
        )

    @property
    @x64
    def edf(self):
        """(m,) effective degrees of freedom of each smoother: the trace of its hat matrix."""
        return jnp.sum(self.leverage, axis=-2)

    d: jnp.ndarray
    dse: jnp.ndarray
    x_sorted: jnp.ndarray
    d_sorted: jnp.ndarray
    dse_sorted: jnp.ndarray
    nvr: jnp.ndarray
    log10_nvr_se: jnp.ndarray
    nvr_at_bound: jnp.ndarray
    nvr_converged: jnp.ndarray
    nvr_status: jnp.ndarray
    definite: jnp.ndarray
    offsets: jnp.ndarray
    leverage: jnp.ndarray
    disturbance: jnp.ndarray
    fit: jnp.ndarray
    resid: jnp.ndarray
    relative_error: jnp.ndarray
    iterations: jnp.ndarray
    converged: jnp.ndarray
    change_history: jnp.ndarray


@eqx.filter_jit
def _multi_sdp(y, known, x, nvr0, opt_mask, models, optimise_on, max_log10, P0, tol, max_iter, method):
    N, m = x.shape
    terms = [Term(models[j], *sorted_order(x[:, j])) for j in range(m)]
    dist = y - known
    ones = jnp.ones((N, m))

    def iterate(D, nvr, optimise_mask):
        D, _, out = backfit_sweep(dist, ones, D, terms, nvr, optimise_mask, max_log10=max_log10, P0=P0, method=method)
        return D, out

    def change(D_new, D_old):
        dn, do = jnp.sum(D_new, axis=1), jnp.sum(D_old, axis=1)
        return jnp.linalg.norm(dn - do) / jnp.linalg.norm(dn)

    D0 = jnp.zeros((N, m))
    D, out = iterate(D0, nvr0, opt_mask)
    hist = jnp.full((max_iter,), jnp.nan).at[0].set(change(D, D0))

    def cond(c):
        i, _, _, _, done = c
        return (i < max_iter) & ~done

    def body(c):
        i, D, out, hist, _ = c
        if optimise_on == "all":
            D_new, new = iterate(D, out.nvr, opt_mask)
        else:
            D_new, new = iterate(D, out.nvr, (False,) * m)
            new = keep_search(new, out)
        ch = change(D_new, D)
        return i + 1, D_new, new, hist.at[i].set(ch), ch <= tol

    init = (jnp.array(1), D, out, hist, hist[0] <= tol)
    iters, D, out, hist, converged = eqxi.while_loop(cond, body, init, max_steps=max_iter, kind=loop_kind(opt_mask))
    se = jnp.sqrt(out.sigma2[None, :] * out.var)
    disturbance = jnp.sum(D, axis=1)
    fit = known + disturbance
    resid = y - fit
    return MultiSDPResult(
        d=D,
        dse=se,
        x_sorted=jnp.stack([x[t.perm, j] for j, t in enumerate(terms)]),
        d_sorted=jnp.stack([D[t.perm, j] for j, t in enumerate(terms)]),
        dse_sorted=jnp.stack([se[t.perm, j] for j, t in enumerate(terms)]),
        nvr=out.nvr,
        log10_nvr_se=out.log10_nvr_se,
        nvr_at_bound=out.at_bound,
        nvr_converged=out.status <= 1,
        nvr_status=out.status,
        definite=out.definite,
        offsets=jnp.mean(D, axis=0),
        leverage=out.var,
        disturbance=disturbance,
        fit=fit,
        resid=resid,
        relative_error=100.0 * jnp.linalg.norm(resid) / jnp.linalg.norm(y),
        iterations=iters,
        converged=converged,
        change_history=hist,
    )


@x64
def multi_sdp(
    y,
    x,
    *,
    w=None,
    a=0.0,
    model="RW",
    nvr=None,
    tol: float = 0.01,
    max_iter: int = 20,
    P0: float = 1e5,
    method: str | None = None,
) -> MultiSDPResult:
    r"""Multi-SDP disturbance $y_k = a w_k + \sum_j d_j(x_{jk}) + e_k$ by iterative back-fitting.

    Each $d_j$ is a state-dependent disturbance (an SDP on the regressor 1): a
    random walk in the order of its own state $x_j$ with noise variance ratio
    $NVR_j$. With $d = y - a w$ and $d_j = 0$ to start, each iteration smooths, for
    $j = 1..m$, the part of $d$ not explained by the other SDPs (sorted by $x_j$);
    it stops when the total disturbance $\sum_j d_j$ changes by at most `tol`
    (relative, in the 2-norm) from one iteration to the next. Only the sum of
    the offsets of the $d_j$ is identified (`offsets`).

    **Arguments**

    - `y`: (N,) measured output (e.g. joint torque, N m; finite, not constant);
      `x`: (N, m) the state of each SDP (e.g. `[q, dq]` for gravity and friction).
    - `w`, `a`: known signal (N,) and its known coefficient (e.g. acceleration and the
      CAD inertia); `w=None` for no known term.
    - `model`, `P0`, `method`: as `jaxsdp.sdp`; `nvr`: as `jaxsdp.sdp` (`MLNVR`, `FixedNVR`, None or fixed
      NVRs; not `CaptainNVR`), except that None means `MLNVR(optimise_on="all")`: ML NVRs at every
      iteration (the paper calls CAPTAIN's `sdp`, which optimises, at every step, so each NVR adapts as the
      other SDPs leave its partial residual).
    - `tol`: relative change of the total disturbance to stop (default 0.01 = 1 %);
      `max_iter`: iteration limit.

    **Returns** a `MultiSDPResult` (`d`, `dse` in units of y, `nvr`,
    `nvr_at_bound`, `nvr_converged`, `converged`, `reason`, ...).

    Example:
        >>> import numpy as np, jaxsdp
        >>> rng = np.random.default_rng(1)
        >>> x = rng.uniform(-1.0, 1.0, (400, 2))
        >>> y = np.sin(3 * x[:, 0]) + np.sign(x[:, 1]) * 0.5 + 0.05 * rng.normal(size=400)
        >>> res = jaxsdp.multi_sdp(y, x)
        >>> bool(res.converged), res.nvr_at_bound.tolist()          # the step d_2 wants NVR > max_nvr
        (True, [False, True])
        >>> print(res.reason)
        back-fitting converged after 4 iterations; term 0 NVR: converged; term 1 NVR: converged on a bound: ...
    """
    y = as_float_array("y", y, ndim=1)
    x = as_float_array("x", x, ndim=2)
    N, m = x.shape
    if y.shape[0] != N:
        raise ValueError(f"`x` must have one row per sample of `y`: y {tuple(y.shape)}, x {tuple(x.shape)}")
    if w is None:
        known = jnp.zeros(N)
    else:
        w = as_float_array("w", w, ndim=1)
        if w.shape != y.shape:
            raise ValueError(f"`w` must have the shape of `y`: y {tuple(y.shape)}, w {tuple(w.shape)}")
        w = check_finite("w", w)
        known = as_float_array("a", a, ndim=0) * w
    models = check_sdp_models(model, m)
    if N < max(md.dim for md in models) + 2 or N < m + 3:
        raise ValueError(f"`y` has {N} samples; too few for {m} SDPs")
    if not (0 < float(tol) < 1):
        raise ValueError(f"`tol` must lie in (0, 1); got {tol}")
    if hasattr(nvr, "_search"):
        raise ValueError("`nvr`: multi_sdp takes MLNVR, FixedNVR, None or fixed NVRs, not CaptainNVR")
    search = search_options(nvr, "all", y, None, x, model=model, P0=P0)
    optimise_on = search["optimise_on"]
    y, x, start, opt_mask, max_log10 = check_search(
        y, x, search["nvr"], search["nvr0"], m, optimise_on=optimise_on, max_nvr=search["max_nvr"],
        count=("max_iter", max_iter),
    )  # fmt: skip
    return _multi_sdp(
        y,
        known,
        x,
        start,
        opt_mask,
        models,
        optimise_on,
        max_log10,
        as_float_array("P0", P0, ndim=0),
        float(tol),
        int(max_iter),
        resolve_method(method),
    )


def _as_model_spec(v):
    return v if isinstance(v, (str, ParameterModel)) else tuple(v)


class MultiBackfitting(eqx.Module):
    r"""Multi-SDP back-fitting options (`jaxsdp.multi_sdp`), as one object.

    $y_k = a w_k + \sum_j d_j(x_{jk}) + e_k$, each $d_j$ a random walk in the
    order of its state $x_j$, back-fitted until the total disturbance changes
    by at most `tol` (relative, 2-norm) between iterations.

    **Fields:** `model` (one of "RW", "IRW", "SRW" or a `ParameterModel`, or
    one per SDP; default "RW" for every SDP), `tol` (in (0, 1); default 0.01 =
    1 %, the paper's), `max_iter` (>= 1, default 20), `max_nvr` (the cap on
    the ML NVRs, None for none; default 1), `optimise_on` ("all": ML NVRs at
    every iteration, the paper's procedure, default; "first": on the first
    only), `nvr0` (the NVR search's start, > 0), `P0` (initial state
    variance, > 0). Checked when made (ValueError naming the field).

    `MultiBackfitting(...)(y, x, w=w, a=a)` is
    `jaxsdp.multi_sdp(y, x, w=w, a=a, ...)`, returning a `MultiSDPResult`.

    Example:
        >>> import numpy as np, jaxsdp
        >>> rng = np.random.default_rng(1)
        >>> x = rng.uniform(-1.0, 1.0, (400, 2))
        >>> y = np.sin(3 * x[:, 0]) + np.sign(x[:, 1]) * 0.5 + 0.05 * rng.normal(size=400)
        >>> fit = jaxsdp.MultiBackfitting(tol=0.01, max_nvr=None)
        >>> res = fit(y, x)
        >>> bool(res.converged), int(res.iterations) <= fit.max_iter
        (True, True)
    """

    model: str | ParameterModel | tuple = eqx.field(static=True, default="RW", converter=_as_model_spec)
    tol: float = eqx.field(static=True, default=0.01)
    max_iter: int = eqx.field(static=True, default=20)
    max_nvr: float | None = eqx.field(static=True, default=1.0)
    optimise_on: str = eqx.field(static=True, default="all")
    nvr0: float = eqx.field(static=True, default=1e-4)
    P0: float = eqx.field(static=True, default=1e5)

    def __check_init__(self):
        single = isinstance(self.model, (str, ParameterModel))
        check_sdp_models(self.model, 1 if single else len(self.model))
        if isinstance(self.tol, bool) or not isinstance(self.tol, (int, float)) or not 0 < self.tol < 1:
            raise ValueError(f"`tol` must lie in (0, 1); got {self.tol!r}")
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, (int, np.integer)) or self.max_iter < 1:
            raise ValueError(f"`max_iter` must be an integer >= 1; got {self.max_iter!r}")
        if self.max_nvr is not None and not (
            isinstance(self.max_nvr, (int, float)) and not isinstance(self.max_nvr, bool) and 0 < self.max_nvr < np.inf
        ):
            raise ValueError(f"`max_nvr` must be None or a finite number > 0; got {self.max_nvr!r}")
        if self.optimise_on not in ("first", "all"):
            raise ValueError(f"`optimise_on` must be 'first' or 'all'; got {self.optimise_on!r}")
        if not (isinstance(self.nvr0, (int, float)) and 0 < self.nvr0 < np.inf):
            raise ValueError(f"`nvr0` must be a finite number > 0; got {self.nvr0!r}")
        if not (isinstance(self.P0, (int, float)) and 0 < self.P0 < np.inf):
            raise ValueError(f"`P0` must be a finite number > 0; got {self.P0!r}")

    def _options(self) -> dict:
        """The keyword arguments of `multi_sdp` these options stand for."""
        return dict(
            model=self.model,
            tol=self.tol,
            max_iter=self.max_iter,
            nvr=MLNVR(self.nvr0, self.max_nvr, self.optimise_on),
            P0=self.P0,
        )

    @x64
    def __call__(self, y, x, *, w=None, a=0.0) -> MultiSDPResult:
        return multi_sdp.__wrapped__(y, x, w=w, a=a, **self._options())
