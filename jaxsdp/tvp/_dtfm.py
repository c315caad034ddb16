"""Time-variable transfer functions: coefficients as random walks, estimated by refined instrumental variables.

Model (the toolbox's `dtfm`), sample k, the system at rest before the record:

    y_k = x_k + xi_k,   x_k = sum_i phi_ik x_(k-i) + sum_j beta_jk u_(k-d-j),

i.e. A(z^-1, k) x_k = B(z^-1, k) u_(k-d) with a_ik = -phi_ik, b_jk = beta_jk,
each coefficient a random-walk-family block (`jaxsdp.dlr`'s models), and
xi_k white or AR: D(z^-1) xi_k = e_k (order `nd`, time-invariant).

Least squares on the ARX form (`darx`) is biased: its equation error
A(z^-1) xi_k is correlated with the lagged outputs. One refined IV pass at the
current estimate theta_k:

1. auxiliary model: x^_k simulated from u with the current coefficients
   (their denominator stabilised at each sample, `stabilised`);
2. noise model: D by least squares on the model residual y - x^ (nd > 0);
3. prefilter D(z^-1) / A(z^-1, k) on y, u and x^: for the true A and D the
   prefiltered equation y_f,k = z_f,k . theta_k + e_k has a white error;
4. NVRs by maximum likelihood on that regression (`nvr="ml"`), each search
   from `nvr0`;
5. the IV fixed-interval smoother: the estimate solving
   (Zh^T Z + Omega) Theta = Zh^T y_f, Omega the random walks' precision,
   Zh the instruments (x^_f in place of y_f): a Kalman-type forward pass with
   the non-symmetric gain K = P zh / (1 + z.P zh) and the Rauch-Tung-Striebel
   backward pass, exact for this block-tridiagonal system.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._checks import as_float_array, check_finite, nonnegative_int, positive_int
from .._kalman.general import observation_rows
from .._kalman.models import as_model, assemble, state_dim
from .._kalman.nvr import NVRFit, check_nvr0, dlr_likelihood, max_log10_nvr
from .._kalman.parallel import unrolled_cho_solve
from .._kalman.validate import estimate_name, nvr_vector, validate_regression
from .._runtime import x64
from ..tfest._arma import lags, shift
from ..tfest._rivcore import NOISE_FLOOR
from ._engine import (
    bucket_length,
    check_observed,
    checked_burn_in,
    checked_P0,
    fit_tied_nvr,
)
from ._forecast import Forecast

#: Reflection coefficients of the auxiliary model's denominators (and of D) are kept within this bound, so that
#: the simulation and the prefilter stay stable where an estimate is not (`stabilised`).
STABILITY_RADIUS = 0.999


class DTFMResult(eqx.Module):
    r"""Result of `jaxsdp.tvp.dtfm` (the fields shared with `DARResult` mean the same).

    Model: $y_k = x_k + \xi_k$, $x_k = \sum_i \phi_{ik} x_{k-i} + \sum_j \beta_{jk} u_{k-d-j}$
    ($a_{ik} = -\phi_{ik}$ in $A(z^{-1}, k)$), $D(z^{-1}) \xi_k = e_k$.

    - `coef`, `coef_se`: (N, n_a + n_b) the smoothed coefficients $\phi_1..\phi_{n_a}$ then
      $\beta_0..\beta_{n_b-1}$, and their standard errors; `na`, `start` (the first sample with all its lags).
    - `x_hat`: (N,) the noise-free output simulated from u with `coef` (the auxiliary model);
      `resid`: y - x_hat (the model residual, $\xi$'s estimate; NaN where y is missing).
    - `d`: (nd + 1,) the noise model $[1, d_1, ..., d_{nd}]$ ([1.0] for white noise).
    - `nvr`, `nvr_estimated`, `nvr_fit`: the NVRs (by maximum likelihood on the prefiltered regression, or
      given); `sigma2`, `loglik`, `J`: $\sigma^2$ of $e_k$ and the concentrated likelihood of the last
      pass's prefiltered regression (not comparable with `darx`'s: the data are prefiltered);
      `definite`: the covariances came out positive.
    - `iterations`: the IV passes run after the `darx` start; `change`: the last pass's relative change of
      the coefficients, $\max_k |\theta_k^{new} - \theta_k| / \max_k |\theta_k^{new}|$; `converged`:
      `change` < `tol`.
    - `forecast`: the `Forecast`: the one-step prediction of y over the data, then (`dtfm(..., u_future=...)`)
      the forecast h samples beyond it with the last coefficients (see `dtfm`).
    """

    coef: jnp.ndarray
    coef_se: jnp.ndarray
    na: int = eqx.field(static=True)
    start: int = eqx.field(static=True)
    x_hat: jnp.ndarray
    resid: jnp.ndarray
    d: jnp.ndarray
    nvr: jnp.ndarray
    sigma2: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    definite: jnp.ndarray
    nvr_estimated: jnp.ndarray
    iterations: jnp.ndarray
    change: jnp.ndarray
    converged: jnp.ndarray
    nvr_fit: NVRFit | None = None
    forecast: Forecast | None = None


def stabilised(a, radius: float = STABILITY_RADIUS):
    """(..., n) coefficients of 1 + a_1 z^-1 + ... + a_n z^-n, made stable where they are not.

    The reflection coefficients (Schur-Cohn step-down) are clipped to
    [-radius, radius] and the polynomial rebuilt (step-up): a stable
    polynomial within the radius is returned unchanged, any other one is
    mapped to a stable one. Arithmetic only (no eigenvalues), so it runs
    elementwise over a batch of samples and differentiates.
    """
    n = a.shape[-1]
    cur, ks = [a[..., i] for i in range(n)], []
    for m in range(n, 0, -1):
        k = jnp.clip(cur[m - 1], -radius, radius)
        ks.append(k)
        cur = [(cur[i] - k * cur[m - 2 - i]) / (1.0 - k * k) for i in range(m - 1)]
    inside = jnp.all(jnp.abs(jnp.stack(ks, axis=-1)) < radius, axis=-1) if n else True
    b = []
    for m, k in enumerate(ks[::-1], start=1):
        b = [b[i] + k * b[m - 2 - i] for i in range(m - 1)] + [k]
    return jnp.where(inside[..., None], a, jnp.stack(b, axis=-1)) if n else a


def _solve(A, B):
    """A^{-1} B for a small square A (n, n) by Gaussian elimination, unrolled (no pivoting, no LAPACK call).

    For the IV smoother's predicted matrices F P F^T + Q, whose symmetric
    part is positive definite when the instruments are correlated with the
    regressors (the pivots stay positive); from n = 8 the library solve.
    """
    n = A.shape[0]
    if n >= 8:
        return jnp.linalg.solve(A, B)
    M = [[A[i, j] for j in range(n)] for i in range(n)]
    R = [B[i] for i in range(n)]
    for c in range(n):
        for r in range(c + 1, n):
            f = M[r][c] / M[c][c]
            M[r] = [M[r][j] - f * M[c][j] for j in range(n)]
            R[r] = R[r] - f * R[c]
    X = [None] * n
    for i in reversed(range(n)):
        X[i] = (R[i] - sum(M[i][j] * X[j] for j in range(i + 1, n))) / M[i][i]
    return jnp.stack(X)


def iv_smoother(y, H, Hh, F, Q, P0):
    """The IV fixed-interval smoother: regressor rows H, instrument rows Hh (N, n), NaN in y skipped.

    Forward, with the state's RW-family transition (F, Q) and s_0 ~ (0, P0 I):

        P = F P F^T + Q,  K = P hh / (1 + h.P hh),  s += K (y - h.s),  P = P - K h^T P,

    backward s_(k|N) = s_(k|k) + G (s_(k+1|N) - F s_(k|k)), G = P_(k|k) F^T P_(k+1|k)^-1.
    Returns (s_(k|N) (N, n), diag of the covariance (N, n) of the symmetric smoother on the instruments, in
    units of sigma^2: the IV estimate's covariance for instruments close to the noise-free regressors).
    """
    n = F.shape[0]
    obs = ~jnp.isnan(y)
    y0 = jnp.where(obs, y, 0.0)
    eye = jnp.eye(n)

    def forward(carry, inp):
        x, P, S = carry
        yk, h, hh, ok = inp
        xp, Pp, Sp = F @ x, F @ P @ F.T + Q, F @ S @ F.T + Q
        Sp = 0.5 * (Sp + Sp.T)
        Phh = Pp @ hh
        K = Phh / (1.0 + h @ Phh)
        Shh = Sp @ hh
        Ks = Shh / (1.0 + hh @ Shh)
        IKh = eye - jnp.outer(Ks, hh)  # Joseph form, as jaxsdp._kalman.general
        Sn = IKh @ Sp @ IKh.T + jnp.outer(Ks, Ks)
        x = jnp.where(ok, xp + K * (yk - h @ xp), xp)
        P = jnp.where(ok, Pp - jnp.outer(K, h @ Pp), Pp)
        S = jnp.where(ok, 0.5 * (Sn + Sn.T), Sp)
        return (x, P, S), (xp, Pp, Sp, x, P, S)

    init = (jnp.zeros(n), P0 * eye, P0 * eye)
    _, (xp, Pp, Sp, xf, Pf, Sf) = lax.scan(forward, init, (y0, H, Hh, obs))

    def backward(carry, inp):
        xs, Ss = carry
        xf_, Pf_, xp_, Pp_, Sf_, Sp_ = inp
        G = _solve(Pp_.T, F @ Pf_.T).T
        xs = xf_ + G @ (xs - xp_)
        Gs = unrolled_cho_solve(Sp_, F @ Sf_).T if n < 8 else jnp.linalg.solve(Sp_, F @ Sf_).T
        IGF = eye - Gs @ F
        Ss = IGF @ Sf_ @ IGF.T + Gs @ (Q + Ss) @ Gs.T
        Ss = 0.5 * (Ss + Ss.T)
        return (xs, Ss), (xs, jnp.diag(Ss))

    inputs = (xf[:-1], Pf[:-1], xp[1:], Pp[1:], Sf[:-1], Sp[1:])
    _, (xs, sd) = lax.scan(backward, (xf[-1], Sf[-1]), inputs, reverse=True)
    return jnp.concatenate([xs, xf[-1:]]), jnp.concatenate([sd, jnp.diag(Sf[-1])[None]])


def simulate(phi, beta, u, delay: int):
    """x_k = sum_i phi_ik x_(k-i) + sum_j beta_jk u_(k-delay-j), zeros before the record; one scan."""
    na, nb = phi.shape[1], beta.shape[1]
    bu = jnp.sum(beta * lags(u, delay, delay + nb - 1), axis=1)

    def step(past, inp):
        ph, b = inp
        x = ph @ past + b
        return jnp.concatenate([x[None], past[:-1]]), x

    _, x = lax.scan(step, jnp.zeros((na,)), (phi, bu))
    return x


def prefilter(phi, d, v):
    """D(z^-1) / A(z^-1, k) applied to each column of v (N, m): FIR D, then w_k = v_k + sum_i phi_ik w_(k-i)."""
    v = v + sum(d[i] * shift(v, i + 1) for i in range(d.shape[0]))

    def step(past, inp):
        ph, vk = inp
        w = vk + ph @ past
        return jnp.concatenate([w[None], past[:-1]]), w

    _, w = lax.scan(step, jnp.zeros((phi.shape[1], v.shape[1])), (phi, v))
    return w


def noise_model(xi, y, nd: int, start: int):
    """[d_1..d_nd] of D(z^-1) xi_k = e_k by least squares on the observed rows (stabilised); zeros when xi is
    negligible (noise-free data: an AR fit of rounding errors would be meaningless)."""
    X = lags(xi, 1, nd)
    ok = ~jnp.isnan(xi) & ~jnp.any(jnp.isnan(X), axis=1) & (jnp.arange(xi.shape[0]) >= start + nd)
    X = jnp.where(ok[:, None], X, 0.0)
    t = jnp.where(ok, xi, 0.0)
    gram = X.T @ X
    gram = gram + (1e-12 * jnp.trace(gram) + jnp.finfo(jnp.float64).tiny) * jnp.eye(nd)
    c = unrolled_cho_solve(gram, (X.T @ t)[:, None])[:, 0]
    floor = jnp.sum(t * t) <= NOISE_FLOOR * jnp.nansum(y * y)
    return jnp.where(floor, 0.0, stabilised(-c))


class _Pass(eqx.Module):
    """One pass's estimate and what the result reports from it."""

    state: jnp.ndarray  # (L, n) smoothed states
    var: jnp.ndarray  # (L, n) their variances, units of sigma^2
    nvr: jnp.ndarray  # the NVRs (one per tied group)
    d: jnp.ndarray  # (nd,)
    sigma2: jnp.ndarray
    loglik: jnp.ndarray
    J: jnp.ndarray
    fit: NVRFit | None


def _no_fit(nvr):
    """A placeholder `NVRFit` (the loop's carry before the first pass)."""
    z = jnp.zeros_like(nvr)
    f, i = jnp.zeros(()), jnp.zeros((), int)
    return NVRFit(nvr, z, z, f, f, i, jnp.array(False), jnp.zeros(nvr.shape, bool), i)


@eqx.filter_jit
def _dtfm_core(y, u, nvr0, P0, models, index, na, nb, delay, nd, start, n_data, burn_in, ml, iterations, tol):
    """`darx` (a pass with no prefilter and the regressors as instruments), then up to `iterations` IV passes,
    in one loop: one compiled pass."""
    L = y.shape[0]
    n = state_dim(models)
    first = np.cumsum([0] + [m.dim for m in models])[:-1]
    idx = np.asarray(index, dtype=int)
    obs = ~jnp.isnan(y)
    k = jnp.arange(L)
    row_ok = (k >= start) & obs
    for i in range(1, na + 1):
        row_ok = row_ok & (shift(obs, i) if i < L else False)
    valid = (k >= start) & (k < n_data)
    x0 = jnp.zeros(n)
    max_log10 = max_log10_nvr(None)

    def auxiliary(coef):
        phi = -stabilised(-coef[:, :na])
        return phi, simulate(phi, coef[:, na:], u, delay)

    def one_pass(prev, ls):
        """An IV pass at `prev`'s coefficients; `ls`: darx's least squares (no prefilter, no instruments)."""
        phi, xh = auxiliary(prev.state[:, first])
        d = noise_model(jnp.where(obs, y - xh, jnp.nan), y, nd, start) if nd else jnp.zeros((0,))
        phi, d = jnp.where(ls, 0.0, phi), jnp.where(ls, 0.0, d)  # D / A = 1: the raw data
        yf, uf, xf = prefilter(phi, d, jnp.stack([jnp.where(obs, y, xh), u, xh], axis=1)).T
        ul = lags(uf, delay, delay + nb - 1)
        Z = jnp.concatenate([lags(yf, 1, na), ul], axis=1)
        Zh = jnp.where(ls, Z, jnp.concatenate([lags(xf, 1, na), ul], axis=1))
        target = jnp.where(row_ok, yf, jnp.nan)
        # every search from nvr0: from a previous NVR in the likelihood's flat region (a constant coefficient,
        # which darx's bias may suggest) the search would not move
        fit = fit_tied_nvr(target, Z, jnp.log10(nvr0), P0, x0, models, index, burn_in, max_log10) if ml else None
        nvr = fit.nvr if ml else prev.nvr
        nvr_b = nvr[idx] if idx.size else jnp.zeros((0,))
        ss = assemble(models, nvr_b)
        state, var = iv_smoother(target, observation_rows(Z, ss.S), observation_rows(Zh, ss.S), ss.F, ss.Q, P0)
        lik = dlr_likelihood(target, Z, nvr_b, P0, x0, models, burn_in)
        # sigma^2 from the rows after the first dim(s) observed ones, darx's (CAPTAIN's) convention (rows without their
        # lags are missing samples, which the burn-ins do not count)
        s2 = dlr_likelihood(target, Z, nvr_b, P0, x0, models, n).sigma2
        return _Pass(state, var, nvr, d, s2, lik.loglik, lik.J, fit)

    def body(j, carry):
        prev, passes, change, done = carry

        def step(_):
            new = one_pass(prev, j == 0)
            a, b = new.state[:, first], prev.state[:, first]
            num = jnp.max(jnp.where(valid[:, None], jnp.abs(a - b), 0.0))
            den = jnp.max(jnp.where(valid[:, None], jnp.abs(a), 0.0))
            rel = num / jnp.maximum(den, jnp.finfo(jnp.float64).tiny)
            return new, passes + 1, rel, (j > 0) & (rel < tol)

        return lax.cond(done, lambda _: carry, step, None)

    f0 = jnp.zeros(())
    init = _Pass(
        jnp.zeros((L, n)), jnp.zeros((L, n)), nvr0, jnp.zeros((nd,)), f0, f0, f0, _no_fit(nvr0) if ml else None
    )
    carry = (init, jnp.array(0), jnp.array(jnp.inf), jnp.array(False))
    last, passes, change, done = lax.fori_loop(0, iterations + 1, body, carry)
    coef = last.state[:, first]
    _, xh = auxiliary(coef)
    var = last.var[:, first]
    return dict(
        coef=coef,
        coef_se=jnp.sqrt(last.sigma2 * jnp.clip(var, 0.0)),
        x_hat=xh,
        d=jnp.concatenate([jnp.ones((1,)), last.d]),
        nvr=last.nvr,
        sigma2=last.sigma2,
        loglik=last.loglik,
        J=last.J,
        definite=(jnp.min(last.var) >= 0) & jnp.isfinite(jnp.sum(last.var)),
        fit=last.fit,
        change=jnp.where(iterations > 0, change, jnp.inf),
        converged=done,
        iterations=passes - 1,
    )


def _tf_forecast(y, u, u_future, coef, x_hat, d, s2, na: int, nb: int, delay: int) -> Forecast:
    """y's one-step prediction over the data, then its forecast over h = len(u_future) samples (None: h = 0).

    x continues x_hat with the last coefficients (the denominator stabilised as in x_hat) and the known inputs
    (u_{N+j-d-i} from u or u_future). The noise xi = y - x_hat, D(z^-1) xi_k = e_k, goes through the Kalman filter of
    its companion form (A, sigma^2 e_1 e_1^T, at rest before the record), xi_k observed exactly where y is: the
    prediction xi_(k|k-1) and its variance V_k (sigma^2 after observed lags, the AR(nd) k-step variance over a gap
    and beyond the data). mean = x + xi_(k|k-1), obs_se = sqrt(V_k), se = sqrt(V_k - sigma^2).
    """
    N = y.shape[0]
    h = 0 if u_future is None else int(u_future.shape[0])
    x = x_hat
    if h:
        phi = -stabilised(-coef[-1, :na])
        idx = N + np.arange(h)[:, None] - delay - np.arange(nb)[None, :]
        bu = jnp.concatenate([u, u_future])[idx] @ coef[-1, na:]

        def simulate_step(past, b):
            xk = phi @ past + b
            return jnp.concatenate([xk[None], past[:-1]]), xk

        x = jnp.concatenate([x_hat, lax.scan(simulate_step, x_hat[::-1][:na], bu)[1]])
    m = max(d.shape[0] - 1, 1)  # nd = 0: one state whose coefficient is 0 (white noise)
    A = jnp.zeros((m, m)).at[0].set(jnp.zeros(m).at[: d.shape[0] - 1].set(-d[1:])).at[1:, :-1].set(jnp.eye(m - 1))
    Q = jnp.zeros((m, m)).at[0, 0].set(s2)

    def filter_step(carry, xi):
        s, P = carry
        s, P = A @ s, A @ P @ A.T + Q
        ok = ~jnp.isnan(xi)
        g = P[:, 0] / jnp.maximum(P[0, 0], jnp.finfo(jnp.float64).tiny)
        s_new, P_new = s + g * (jnp.where(ok, xi, 0.0) - s[0]), P - jnp.outer(g, P[0])
        return (jnp.where(ok, s_new, s), jnp.where(ok, P_new, P)), (s[0], P[0, 0])

    xi = jnp.concatenate([y - x_hat, jnp.full((h,), jnp.nan)])
    _, (pred, V) = lax.scan(filter_step, (jnp.zeros(m), jnp.zeros((m, m))), xi)
    V = jnp.clip(V, 0.0)
    return Forecast(y=y, mean=x + pred, se=jnp.sqrt(jnp.clip(V - s2, 0.0)), obs_se=jnp.sqrt(V), sigma2=s2)


@x64
def dtfm(
    y,
    u,
    *,
    na: int,
    nb: int,
    delay: int = 1,
    nd: int = 0,
    model="RW",
    nvr="ml",
    nvr0=1e-4,
    tied: bool = False,
    iterations: int = 20,
    tol: float = 1e-4,
    P0: float = 1e5,
    burn_in: int | None = None,
    u_future=None,
) -> DTFMResult:
    r"""Time-variable transfer function: coefficients as random walks, estimated by refined instrumental variables.

    Model, the system at rest before the record ($a_{ik} = -\phi_{ik}$):

    $$ y_k = x_k + \xi_k, \quad x_k = \sum_{i=1}^{n_a} \phi_{ik} x_{k-i} + \sum_{j=0}^{n_b-1} \beta_{jk} u_{k-d-j}, $$

    $$ D(z^{-1}) \xi_k = e_k, \quad e_k \sim N(0, \sigma^2), $$

    each coefficient a `model` block (random walk by default) with its NVR, $d$ the `delay`, $D$ of order
    `nd` constant (`nd=0`: white measurement noise). Least squares on the ARX form (`darx`) is biased here:
    its error $A(z^{-1}) \xi_k$ is correlated with the lagged outputs (with white $\xi$ the poles are pulled
    towards zero). Starting from `darx`, each pass:

    1. simulates the noise-free output $\hat x_k$ with the current coefficients (the auxiliary model);
    2. fits $D$ by least squares on $y - \hat x$ (`nd` > 0);
    3. prefilters y, u and $\hat x$ by $D(z^{-1}) / \hat A(z^{-1}, k)$: the prefiltered equation
       $y_{f,k} = z_{f,k} \cdot \theta_k + e_k$ then has a white error;
    4. estimates the NVRs by maximum likelihood on it (`nvr="ml"`);
    5. smooths by instrumental variables: $\hat z_{f,k}$ (with $\hat x_f$ in place of $y_f$) as instrument,
       the forward gain $K_k = P_{k|k-1} \hat z_{f,k} / (1 + z_{f,k} \cdot P_{k|k-1} \hat z_{f,k})$, the update
       $\theta_{k|k} = \theta_{k|k-1} + K_k (y_{f,k} - z_{f,k} \cdot \theta_{k|k-1})$ and the
       Rauch-Tung-Striebel backward pass: the exact solution of $(\hat Z^\top Z + \Omega) \Theta = \hat Z^\top y_f$
       over all samples at once, $\Omega$ the random walks' precision.

    Passes repeat until the coefficients change by less than `tol` (relative) or `iterations` passes.
    Standard errors: $\sigma^2$ times the variances of the (symmetric) smoother on the instruments, as
    refined IV's $\sigma^2 (\sum \hat z_f \hat z_f^\top)^{-1}$. With constant coefficients (`nvr=0`) the
    fixed point is the discrete refined IV estimate of `jaxsdp.tfest.rivbj` with an AR noise model.

    **Arguments**: `y` (N,), NaN where missing (its row and the `na` after it leave the estimate; the
    prefilter and the noise model run over a gap on $\hat x$ in place of y); `u` (N,) finite; `na` >= 1,
    `nb` >= 1, `delay` >= 0, `nd` >= 0; `nvr` values (one per coefficient, or one with `tied`) or `"ml"`
    from `nvr0`; `iterations` >= 0 (0: the `darx` estimate); `tol` >= 0 (0: every pass); `P0`, `burn_in`
    as `darx`. Remove offsets from y and u first (no mean is removed: the model has none).

    `u_future` (h,) finite, the input over the h samples beyond the data, or None (no horizon): `forecast`
    holds y's forecast $\hat x_{N+j} + \hat\xi_{N+j|N}$, j = 1..h: $\hat x$ continued by the TF with the last
    coefficients and the known inputs ($u_{N+j-d-i}$ from `u` inside the data, from `u_future` beyond; with
    $d \geq h$ `u_future` sets only the horizon), plus the AR(`nd`) noise model's forecast from the last
    residuals $y - \hat x$ (0 for `nd=0`). Its variance is the noise's j-step forecast variance (companion form,
    $P_j = A P_{j-1} A^\top + \sigma^2 e_1 e_1^\top$ from $P_0 = 0$; $\sigma^2$ at every step for `nd=0`): the
    input adds none, and the coefficients' own uncertainty is not included (`se` excludes the new $e_k$,
    `obs_se` includes it). Over the data `forecast.mean` is y's one-step prediction $\hat x_k + \hat\xi_{k|k-1}$
    ($\hat x_k$ for `nd=0`; over gaps the noise is predicted from the observed past, the noise at rest before
    the record), `obs_se` $\sigma$ there and `se` 0 (both larger over a gap; no coefficient uncertainty).
    Missing last samples of y are not refused: the noise forecast is then from the last observed residuals,
    with the wider variance the filter gives (nothing changes for `nd=0`).

    **Returns** a `DTFMResult`. Check `converged`: with coloured noise and `nd=0` the prefiltered error is
    not white, the likelihood's NVRs grow to follow the noise and the iteration diverges; give `nd` (an
    AR(1) noise model suffices for AR(1) noise, `tests/test_tvp_dtfm.py`). `jit`, `vmap` and, with given
    NVRs, `jax.grad` apply.

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(0)
        >>> n = 1000
        >>> u = rng.normal(size=n)
        >>> pole = np.linspace(0.5, 0.9, n)                    # a drifting pole
        >>> gain = np.where(np.arange(n) < 500, 1.0, 2.0)         # a gain that jumps
        >>> x = np.zeros(n)
        >>> for k in range(1, n):
        ...     x[k] = pole[k] * x[k - 1] + gain[k] * u[k - 1]
        >>> y = x + 0.5 * x.std() * rng.normal(size=n)            # white measurement noise
        >>> ls = tvp.darx(y, u, na=1, nb=1, delay=1, demean=False)
        >>> iv = tvp.dtfm(y, u, na=1, nb=1, u_future=np.ones(3))      # and 3 samples ahead, u = 1
        >>> bool(iv.converged)
        True
        >>> print(np.round(pole[[250, 750]], 2), np.round(np.asarray(ls.coef)[[250, 750], 0], 2),
        ...       np.round(np.asarray(iv.coef)[[250, 750], 0], 2))   # truth, darx (biased), dtfm
        [0.6 0.8] [0.31 0.69] [0.63 0.8 ]
        >>> fc = iv.forecast
        >>> print(fc.horizon, np.round(np.asarray(fc.mean)[-3:], 2), np.round(np.asarray(fc.obs_se)[-3:], 2))
        3 [-3.12 -0.97  0.97] [1.4 1.4 1.4]
    """
    na = positive_int("na", na)
    nb = positive_int("nb", nb)
    delay = nonnegative_int("delay", delay)
    nd = nonnegative_int("nd", nd)
    iterations = nonnegative_int("iterations", iterations)
    tol = float(tol)
    if not (tol >= 0.0 and np.isfinite(tol)):
        raise ValueError(f"`tol` must be finite and >= 0; got {tol}")
    y = as_float_array("y", y, ndim=1)
    u = check_finite("u", as_float_array("u", u, ndim=1))
    if u.shape != y.shape:
        raise ValueError(f"`u` must have the shape of `y` {tuple(y.shape)}; got {tuple(u.shape)}")
    if u_future is not None:
        u_future = check_finite("u_future", as_float_array("u_future", u_future, ndim=1))
    N, p = int(y.shape[0]), na + nb
    if N < 2 * (p + delay + nd) + 4:
        raise ValueError(f"`y` has {N} samples; the model needs at least {2 * (p + delay + nd) + 4}")
    _, _, P0 = validate_regression(y, jnp.zeros((N, 1)), min_samples=1, carrier=checked_P0(P0))
    models = (as_model(model),) * p
    k = models[0].n_nvr
    n_nvr = k if tied else k * p
    index = tuple(list(range(k)) * p) if tied else tuple(range(k * p))
    n = state_dim(models)
    P0 = check_observed(y, n + na, carrier=P0)
    start = max(na, delay + nb - 1)
    bi = n + 1 if burn_in is None else checked_burn_in(burn_in, N)
    what = "one NVR per coefficient, or one with tied=True"
    ml = estimate_name(nvr, k, unit="coefficient") is not None
    if ml:
        nvr = check_nvr0(nvr_vector("nvr0", nvr0, n_nvr, what))
    else:
        nvr = nvr_vector("nvr", nvr, n_nvr, what)
    L = bucket_length(N)  # NaN padding: one compilation per bucket of lengths
    yy = jnp.concatenate([y, jnp.full((L - N,), jnp.nan)])
    uu = jnp.concatenate([u, jnp.zeros((L - N,))])
    out = _dtfm_core(yy, uu, nvr, P0, models, index, na, nb, delay, nd, start, N, bi, ml, iterations, tol)
    x_hat, coef = out["x_hat"][:N], out["coef"][:N]
    return DTFMResult(
        coef=coef,
        coef_se=out["coef_se"][:N],
        na=na,
        start=start,
        x_hat=x_hat,
        resid=y - x_hat,
        d=out["d"],
        nvr=out["nvr"],
        sigma2=out["sigma2"],
        loglik=out["loglik"],
        J=out["J"],
        definite=out["definite"],
        nvr_estimated=jnp.asarray(ml),
        iterations=out["iterations"],
        change=out["change"],
        converged=out["converged"],
        nvr_fit=out["fit"],
        forecast=_tf_forecast(y, u, u_future, coef, x_hat, out["d"], out["sigma2"], na, nb, delay),
    )


__all__ = ["DTFMResult", "dtfm", "iv_smoother", "stabilised"]
