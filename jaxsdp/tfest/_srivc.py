"""Simplified refined instrumental variable estimation of a continuous-time transfer function (SRIVC).

Model, from samples y_k, u_k (k = 0..N-1, interval dt seconds), the input
held constant between samples (zero-order hold, ZOH) and the system at rest
at t = 0:

    y(t_k) = B(s)/A(s) u(t_k - d dt) + e_k,
    A(s) = s^n + a1 s^(n-1) + ... + an,   B(s) = b0 s^m + ... + bm   (m <= n),

with e_k white noise and d a whole number of samples of input delay (u is
shifted by d samples before anything else, u_k = 0 before the record). The
parameters are theta = [a1, ..., an, b0, ..., bm].

Iteration (Young and Jakeman; CONTSID's `srivc`), with the current estimate
Ahat, Bhat:

1. Auxiliary model: xhat = Bhat/Ahat u, simulated exactly at the samples
   for the ZOH input (the continuous state space is discretised with one
   matrix exponential; the time recursion is one `lax.scan`).
2. Prefilters s^i/Ahat(s), i = 0..n: u_f(i) and xhat_f(i) are computed
   exactly for the ZOH input, from the states of 1/Ahat driven by u and of
   the cascade Bhat/Ahat then 1/Ahat (u_f(n) = u - sum_i a_i u_f(n-i)).
3. Filtered output: y is NOT filtered by interpolating its samples (that
   biases even noise-free estimates by O(dt)). Write y = xhat + r with
   r_k = y_k - xhat_k and set y_f(i) = xhat_f(i) + r_f(i), where r_f(i) is r
   filtered by s^i/Ahat with r held constant between samples.
4. Regressor phi_k = [-y_f(n-1), ..., -y_f(0), u_f(m), ..., u_f(0)] and
   instrument zeta_k, the same with xhat_f in place of y_f:
   theta = (sum zeta phi^T)^-1 sum zeta y_f(n).
5. Unstable roots of Ahat are reflected into the left half-plane for the
   prefilter and the auxiliary model.

Why step 3 makes the noise-free estimate exact: xhat_f(n) = phi_x^T theta
holds exactly for the current theta (phi_x: phi built from xhat_f), and
r_f(n) + sum_i a_i r_f(n-i) = r_k at the samples, so the IV equations at a
fixed point reduce to sum_k zeta_k r_k = 0. The instrument zeta_k is exactly
the sensitivity of the sampled model output xhat_k to theta, so this is the
stationary condition of the output-error least-squares criterion
sum_k r_k^2 (the maximum-likelihood estimate under white noise), whatever
the interpolation of r between samples. On noise-free data the true
parameters give r = 0 and satisfy it exactly; near them the iteration is a
Gauss-Newton step with phi in place of zeta (phi = zeta when r = 0), so it
converges fast.

Numerics: each iteration works in scaled time tau = c t, with
c = max_i |a_i|^(1/i) (a bound on the root magnitudes of Ahat), so that the
coefficients of Ahat are at most 1 and the filtered signals have comparable
sizes; the regression columns are normalised as well. All filter states
(1/Ahat driven by u, by xhat and by r) form one linear recursion
s[k+1] = F s[k] + G [u_k, y_k] with F from one matrix exponential (a
degree-18 Taylor polynomial with scaling and squaring, as accurate as
`jax.scipy.linalg.expm` here and much quicker to compile). Every filtered
signal is a linear function of f_k = [s_k, u_k, y_k], so the sums over time
of the IV equations come from the Gram matrix sum_k f_k f_k^T (one matrix
product). The covariance at convergence is sigma2 (sum zeta zeta^T)^-1 (by
Cholesky), sigma2 the residual variance sum r_k^2 / (N - n - m - 1).

Stopping: when the relative change ||theta_new - theta_old|| / ||theta_new||
(theta in scaled time) falls below tol (CONTSID's 1e-4 by default), one
more iteration is made and kept: the iteration converges superlinearly on
low-noise data, so this takes noise-free estimates from about tol^2 to
rounding (1e-10 or better in the tests) at the cost of one pass; on noisy
data it changes the estimate by far less than its standard error.

Initialisation: least squares on data filtered by 1/(s + lam)^n (LSSVF; the
same pass with Bhat = 0 and the instrument equal to the regressor), from
several lam at once (a geometric grid tied to the Nyquist frequency, or the
user's), iterated together. After START_ITERATIONS iterations, only the
start with the smallest output-error sum of squares (stable, finite)
continues, if still running; at the end, the converged stable estimate with
the smallest sum of squares is kept. Dropping the others keeps one start
that wanders (seen from a too-low lam on the benchmark: 45 iterations
before it lands on the same estimate) from holding up the result, or a
whole `vmap` batch.
"""

import math
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
from jax import lax

from .._checks import any_nonfinite, as_float_array, check_values, is_concrete, no_spread, positive_float
from .._runtime import x64
from ._solver import check_solver
from ._tf import MAX_ORDER, tf2ss
from ._zoh import expm_taylor, scale_powers, stabilise, time_scale

#: `SRIVCResult.status` codes (index) and their reasons (`SRIVCResult.reason`).
STATUS_REASONS = (
    "converged",
    "iteration limit reached before the relative change of theta fell below tol",
    "unstable: the estimated A(s) has roots in the right half-plane: either the model structure (orders, delay) "
    "does not fit these data, or the system is open-loop unstable, which SRIVC, an output-error method, cannot "
    "fit (use closed-loop data and an indirect method, or a discrete-time equation-error estimate)",
    "not finite: the iteration produced NaN or inf: the model structure (orders, delay) does not fit these data, "
    "or the data are degenerate or not exciting",
)
CONVERGED, MAX_ITER, UNSTABLE, NONFINITE = range(4)
#: Number of samples per unknown parameter required at least.
SAMPLES_PER_PARAMETER = 10
#: Default prefilter bandwidths lam = (pi/dt) * LAM_FRACTIONS (rad/s) of the LSSVF starts.
LAM_FRACTIONS = (0.3, 0.1, 0.03, 0.01, 0.003)
#: IV iterations run from every LSSVF start before the best one is kept and iterated alone.
START_ITERATIONS = 5
#: `stable` needs every root of A(s) to have a real part below -STABILITY_RTOL c (c: the scale, rad/s).
STABILITY_RTOL = 1e-9


def status_reason(status, reasons=STATUS_REASONS):
    """The reason string(s) of `status` code(s): a str for a scalar, an array of str for a batch."""
    st = np.asarray(status)
    if st.ndim == 0:
        return reasons[int(st)]
    return np.vectorize(lambda c: reasons[int(c)], otypes=[object])(st)


class SRIVCResult(eqx.Module):
    r"""Result of `srivc`: the continuous-time model $B(s)/A(s)$, its uncertainty and the iteration's outcome.

    - `num`: (m + 1,) $B(s)$ coefficients, highest power of $s$ first; `den`:
      (n + 1,) $A(s)$, monic. Units: $G(s)$ maps input units to output units, $s$
      in rad/s (1/s).
    - `theta`: (n + m + 1,) [a1, ..., an, b0, ..., bm]; `cov`: its covariance
      $\sigma^2 (\sum \zeta \zeta^T)^{-1}$ at the estimate; `num_se`, `den_se`:
      standard errors aligned with `num` and `den` (`den_se[0] = 0`, the
      monic coefficient is not estimated).
    - `sigma2`: residual variance $\sum r_k^2 / (N - n - m - 1)$ of the output
      error $r_k = y_k - y_{model,k}$ (output units squared); `y_model`: (N,) the
      model output at the samples for the ZOH input.
    - `iterations`: IV iterations after the LSSVF start (the extra one made
      once `tol` is met included); `rel_change`: the last relative change
      $\|\theta_{new} - \theta_{old}\| / \|\theta_{new}\|$ ($\theta$ in scaled time);
      `converged`: it is below `tol`, with finite values.
    - `stable`: every root of $A(s)$ has a negative real part; `lam`: the
      LSSVF bandwidth (rad/s) of the start that was kept; `status`: int code
      (an array, so that the result stays jit/vmap-able) and `reason` (a
      property, outside `jit`): one of `STATUS_REASONS`.

    Example:
        >>> import numpy as np
        >>> import scipy.signal as sig
        >>> from jaxsdp.tfest import c2d
        >>> from jaxsdp.tfest import srivc
        >>> u = np.repeat(np.random.default_rng(1).choice([-1.0, 1.0], 60), 5)  # 300 samples, dt = 0.05 s
        >>> y = sig.lfilter(*c2d([2.0], [1.0, 3.0, 2.0], 0.05), u)  # exact samples of 2/(s^2 + 3 s + 2)
        >>> y = y + 0.01 * np.random.default_rng(2).standard_normal(300)
        >>> res = srivc(y, u, 0.05, n=2, m=0)
        >>> res.den.shape, res.num.shape, res.cov.shape, res.reason
        ((3,), (1,), (3, 3), 'converged')
        >>> err = np.asarray(res.theta) - np.array([3.0, 2.0, 2.0])  # within 4 standard errors
        >>> bool(np.all(np.abs(err) < 4 * np.r_[res.den_se[1:], res.num_se]))
        True
    """

    num: jnp.ndarray
    den: jnp.ndarray
    theta: jnp.ndarray
    cov: jnp.ndarray
    num_se: jnp.ndarray
    den_se: jnp.ndarray
    sigma2: jnp.ndarray
    y_model: jnp.ndarray
    iterations: jnp.ndarray
    rel_change: jnp.ndarray
    converged: jnp.ndarray
    stable: jnp.ndarray
    lam: jnp.ndarray
    status: jnp.ndarray

    @property
    @x64
    def reason(self):
        """Why the iteration stopped and whether the model is usable, in words (see `STATUS_REASONS`)."""
        return status_reason(self.status)


def _setup(a, b, dt, N, n, m):
    """Per start: scale c, scaled (atilde, btilde), prefilter polynomial and the discretised recursion.

    The state (w, v, z), sampled at t_k, holds w = u_f(0..n-1) (1/A driven by
    u), v = xhat_f(0..n-1) (1/A driven by xhat = B/A u) and z = r_f(0..n-1)
    (1/A driven by r_k = y_k - xhat_k, held): s[k+1] = F s[k] + G [u_k, y_k].
    """
    c = time_scale(a, dt, N)
    p = scale_powers(c, n, m)
    at, bt = a / p[:n], b / p[n:]
    af, maxre = stabilise(at)  # prefilter and auxiliary model (scaled time, stable)
    ac, e, cb, db = tf2ss(bt, jnp.concatenate([jnp.ones((1,)), af]))
    aug = jnp.block([[ac, jnp.zeros((n, n)), e[:, None]], [jnp.outer(e, cb), ac, (e * db)[:, None]]])
    ex = expm_taylor(jnp.concatenate([aug, jnp.zeros((1, 2 * n + 1))], axis=0) * (c * dt))
    phi, gam = ex[: 2 * n, : 2 * n], ex[: 2 * n, 2 * n]
    phw, gw = phi[:n, :n], gam[:n]
    zn, z2 = jnp.zeros((n, n)), jnp.zeros((2 * n,))
    F = jnp.block([[phi, jnp.zeros((2 * n, n))], [-jnp.outer(gw, cb), zn, phw]])
    G = jnp.stack([jnp.concatenate([gam, -gw * db]), jnp.concatenate([z2, gw])], axis=1)
    return c, p, jnp.concatenate([at, bt]), af, cb, db, F, G, maxre


def _maps(n, m):
    """Rows mapping the features f = [w, v, z, u, y] (3n + 2) to the regressor, instrument and target.

    u_f(i) = w_i, xhat_f(i) = v_i, r_f(i) = z_i for i < n; the n-th
    derivatives are x_f(n) = x - sum_i a_i x_f(n - i), with xhat = cb w + db u
    and r = y - xhat; y_f(i) = xhat_f(i) + r_f(i). The rows
    [regressor (p), instrument (p), target (1)] are affine in
    q = [a (n), cb (n), db]: returned as numpy arrays (C0, T) with
    rows = C0 + sum_j q_j T[j], built once at trace time.
    """

    def rows(q):
        arev, cb, db = q[:n][::-1], q[n : 2 * n], q[2 * n]
        eye, zn = np.eye(3 * n + 2), np.zeros(n)
        xhat = np.concatenate([cb, zn, zn, [db, 0.0]])
        uf = np.vstack([eye[:n], np.concatenate([-arev, zn, zn, [1.0, 0.0]])])
        xf = np.vstack([eye[n : 2 * n], xhat - np.concatenate([zn, arev, zn, [0.0, 0.0]])])
        r = eye[3 * n + 1] - xhat
        rf = np.vstack([eye[2 * n : 3 * n], r - np.concatenate([zn, zn, arev, [0.0, 0.0]])])
        yf = xf + rf
        regr = np.vstack([-yf[n - 1 :: -1], uf[m::-1]])
        zeta = np.vstack([-xf[n - 1 :: -1], uf[m::-1]])
        return np.vstack([regr, zeta, yf[n][None]])

    c0 = rows(np.zeros(2 * n + 1))
    return c0, np.stack([rows(e) - c0 for e in np.eye(2 * n + 1)])


def _pass(a, b, ls, y, u, dt, n, m):
    """One SRIVC pass (LSSVF where `ls`) for K starts at once: a (K, n), b (K, m + 1), ls (K,).

    Returns the new (a, b), the relative change, the output error r (N, K)
    at the given (a, b), the information sum zeta zeta^T, the scale c and
    the largest real part of the roots of A(s) in scaled time (> 0: the
    prefilter was stabilised). The time recursion is one
    `lax.scan` over the K starts together (fused elementwise steps); the
    sums over time are read off the Gram matrix of the features
    f_t = [w, v, z, u, y] (one matrix product), every filtered signal being
    a linear function of f_t.
    """
    N, p = y.shape[0], n + m + 1
    c, sc, old, af, cb, db, F, G, maxre = jax.vmap(lambda a, b: _setup(a, b, dt, N, n, m))(a, b)
    cols = [F[:, :, j] for j in range(3 * n)]  # s[k+1] = sum_j F[:, j] s_j[k] + G [u_k, y_k]: fused elementwise
    gu, gy = G[:, :, 0], G[:, :, 1]

    def step(s, uy):
        nxt = gu * uy[0] + gy * uy[1]
        for j, col in enumerate(cols):
            nxt = nxt + col * s[:, j : j + 1]
        return nxt, s

    uy = jnp.stack([u, y], axis=1)
    _, S = lax.scan(step, jnp.zeros((a.shape[0], 3 * n)), uy)
    r = y[:, None] - jnp.einsum("tki,ki->tk", S[..., :n], cb) - db * u[:, None]
    K = a.shape[0]
    feats = jnp.concatenate([S, jnp.broadcast_to(uy[:, None, :], (N, K, 2))], axis=2)
    gram = jnp.einsum("tkd,tke->kde", feats, feats)
    c0, tm = _maps(n, m)
    rz = c0 + jnp.einsum("kj,jrd->krd", jnp.concatenate([af, cb, db[:, None]], axis=1), tm)
    regr, zeta = rz[:, :p], rz[:, p : 2 * p]
    inst = jnp.where(ls[:, None, None], regr, zeta)
    rows = jnp.concatenate([regr, inst, zeta, rz[:, 2 * p :]], axis=1)  # every sum over time at once
    q = jnp.einsum("kpd,kde,kqe->kpq", rows, gram, rows)
    rr, ir, ii = q[:, :p, :p], q[:, p : 2 * p, :p], q[:, p : 2 * p, p : 2 * p]
    it, zz = q[:, p : 2 * p, 3 * p], q[:, 2 * p : 3 * p, 2 * p : 3 * p]
    tiny = jnp.finfo(jnp.float64).tiny
    dr = 1.0 / jnp.sqrt(jnp.maximum(jnp.diagonal(rr, axis1=1, axis2=2), tiny))
    di = 1.0 / jnp.sqrt(jnp.maximum(jnp.diagonal(ii, axis1=1, axis2=2), tiny))
    lhs = ir * di[:, :, None] * dr[:, None, :]
    rhs = it * di
    tt = jnp.linalg.solve(lhs, rhs[..., None])[..., 0] * dr
    rel = jnp.linalg.norm(tt - old, axis=1) / jnp.linalg.norm(tt, axis=1)
    new = tt * sc
    return new[:, :n], new[:, n:], rel, r, zz, c, maxre


def _finite(*xs):
    return jnp.all(jnp.stack([jnp.all(jnp.isfinite(x), axis=-1) for x in xs]), axis=0)


@eqx.filter_jit
def _srivc_core(y, u, dt, lams, n, m, delay, max_iter, tol):
    """The estimation (pure, jit/vmap-able): LSSVF starts, IV iterations, evaluation, choice, covariance.

    One `lax.while_loop` runs the K starts together. Each goes through phase
    0 (the LSSVF pass), 1 (IV iterations until the relative change is below
    `tol`, a value is not finite, or `max_iter`), 2 (once `tol` is met, one
    more IV iteration: near the solution the iteration converges
    superlinearly on low-noise data, so this step takes noise-free estimates
    from about tol^2 to rounding), 3 (one evaluation pass at the estimate:
    output error, information) and 4 (done). After
    START_ITERATIONS IV iterations, the starts still running, except the one
    with the smallest sum of squared output errors (stable, finite), are
    dropped, so that a start wandering far from the data does not hold up
    the others (nor, under `vmap`, the whole batch).
    """
    N, K, p = y.shape[0], lams.shape[0], n + m + 1
    t = jnp.arange(N)
    u = jnp.where(t >= delay, u[jnp.maximum(t - delay, 0)], 0.0)  # input delay: u_k -> u_(k - delay), 0 before
    binom = jnp.asarray([float(math.comb(n, i)) for i in range(1, n + 1)])
    a0 = binom * lams[:, None] ** jnp.arange(1, n + 1, dtype=jnp.float64)
    zk, fk = jnp.zeros((K,), int), jnp.zeros((K,), bool)
    init = dict(it=jnp.array(0), a=a0, b=jnp.zeros((K, m + 1)), phase=zk, k=zk, rel=jnp.full((K,), jnp.inf))
    init.update(
        bad=fk, pruned=fk, r=jnp.zeros((N, K)), info=jnp.zeros((K, p, p)), c=jnp.ones((K,)), maxre=jnp.ones((K,))
    )

    def body(s):
        ph = s["phase"]
        a1, b1, rel1, r, info, c, maxre = _pass(s["a"], s["b"], ph == 0, y, u, dt, n, m)
        finite = _finite(a1, b1) & jnp.isfinite(rel1)
        it = (ph == 1) | (ph == 2)
        k = s["k"] + it
        rel = jnp.where(it, rel1, s["rel"])
        bad = s["bad"] | ((ph < 3) & ~finite)
        after1 = jnp.where(bad, 3, jnp.where(rel < tol, 2, jnp.where(k >= max_iter, 3, 1)))
        nxt = jnp.select([ph == 0, ph == 1, ph == 2], [jnp.where(finite, 1, 3), after1, 3], 4)
        # Keep one running start after START_ITERATIONS: the smallest SSE at its current estimate.
        sse = jnp.sum(r * r, axis=0)
        score = jnp.where(~bad & (maxre <= 0) & jnp.isfinite(sse), sse, jnp.inf)
        drop = (s["it"] == START_ITERATIONS) & (jnp.arange(K) != jnp.argmin(score)) & (nxt < 3)
        upd = (ph < 3) & finite
        ev = ph == 3
        return dict(
            it=s["it"] + 1,
            a=jnp.where(upd[:, None], a1, s["a"]),
            b=jnp.where(upd[:, None], b1, s["b"]),
            phase=jnp.where(drop, 4, nxt),
            k=k,
            rel=rel,
            bad=bad,
            pruned=s["pruned"] | drop,
            r=jnp.where(ev[None, :], r, s["r"]),
            info=jnp.where(ev[:, None, None], info, s["info"]),
            c=jnp.where(ev, c, s["c"]),
            maxre=jnp.where(ev, maxre, s["maxre"]),
        )

    s = lax.while_loop(lambda s: jnp.any(s["phase"] < 4), body, init)
    a, b, r, c = s["a"], s["b"], s["r"], s["c"]
    sse = jnp.sum(r * r, axis=0)
    stable = s["maxre"] < -STABILITY_RTOL  # roots of A(s) at the estimate, in scaled time
    ok = ~s["bad"] & jnp.isfinite(sse)
    converged = (s["rel"] < tol) & ok
    penalty = jnp.where(s["pruned"], 3, jnp.where(converged & stable, 0, jnp.where(stable & ok, 1, 2)))
    i = jnp.argmin(jnp.where(penalty == jnp.min(penalty), jnp.where(ok, sse, jnp.finfo(jnp.float64).max), jnp.inf))
    a, b, r, c, sse, info = a[i], b[i], r[:, i], c[i], sse[i], s["info"][i]
    sigma2 = sse / (N - p)
    d = 1.0 / jnp.sqrt(jnp.maximum(jnp.diag(info), jnp.finfo(jnp.float64).tiny))
    cho = jsl.cho_factor(info * d[:, None] * d[None, :], lower=True)
    scale = scale_powers(c, n, m) * d
    cov = sigma2 * scale[:, None] * jsl.cho_solve(cho, jnp.eye(p)) * scale[None, :]
    se = jnp.sqrt(jnp.diag(cov))
    status = jnp.where(~ok[i], NONFINITE, jnp.where(~stable[i], UNSTABLE, jnp.where(converged[i], CONVERGED, MAX_ITER)))
    return SRIVCResult(
        num=b,
        den=jnp.concatenate([jnp.ones((1,)), a]),
        theta=jnp.concatenate([a, b]),
        cov=cov,
        num_se=se[n:],
        den_se=jnp.concatenate([jnp.zeros((1,)), se[:n]]),
        sigma2=sigma2,
        y_model=y - r,
        iterations=s["k"][i],
        rel_change=s["rel"][i],
        converged=converged[i],
        stable=stable[i],
        lam=lams[i],
        status=status,
    )


def lam_starts(lam, dt):
    """The LSSVF start bandwidths (rad/s): `lam` checked (positive, finite, 1-D), or (pi/dt) LAM_FRACTIONS."""
    if lam is None:
        return (np.pi / dt) * np.asarray(LAM_FRACTIONS)
    lams = np.atleast_1d(np.asarray(lam, dtype=float))
    if lams.ndim != 1 or not np.all(np.isfinite(lams) & (lams > 0)):
        raise ValueError(f"`lam` must be a positive bandwidth (rad/s) or a 1-D sequence of them; got {lam!r}")
    return lams


def check_data_values(y, us, delays, carrier):
    """The value checks of the refined IV family's data, riding on `carrier` (`check_values`).

    `y` (N,), `us` (r, N) inputs, `delays` per input: no NaN/inf in y or any
    input, every input varying over the samples its delay leaves, y varying.
    One input is named `u`, several `u[i]`.
    """
    names = ["u"] if us.shape[0] == 1 else [f"u[{i}]" for i in range(us.shape[0])]
    checks = [("y", y, any_nonfinite, "contains NaN or inf")]
    checks += [(name, us[i], any_nonfinite, "contains NaN or inf") for i, name in enumerate(names)]
    checks += [
        (
            name,
            us[i, : us.shape[1] - delays[i]],
            no_spread,
            "is constant over the samples used: it does not excite the system",
        )
        for i, name in enumerate(names)
    ]
    checks.append(("y", y, no_spread, "is constant: there is no response to fit"))
    return check_values(checks, carrier=carrier)


def int_option(name, v, lo, hi=None):
    """`v` as an int, checked: an integer (not a bool) >= lo (and <= hi)."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo or (hi is not None and v > hi):
        rng = f">= {lo}" if hi is None else f"in {lo}..{hi}"
        raise ValueError(f"`{name}` must be an integer {rng}; got {v!r}")
    return int(v)


@x64
def srivc(y, u, dt, *, n, m, delay=0, lam=None, solver=None):
    r"""Estimate a continuous-time transfer function $B(s)/A(s)$ from sampled data by SRIVC.

    Model: $y(t_k) = B(s)/A(s) u(t_k - delay \cdot \Delta t) + e_k$ at $t_k = k \Delta t$ (s; $\Delta t$ = `dt`), with
    $A(s) = s^n + a_1 s^{n-1} + ... + a_n$, $B(s) = b_0 s^m + ... + b_m$, the input
    held constant between samples (zero-order hold), the system at rest at
    $t = 0$ ($u = 0$ before the record) and $e_k$ white noise. The estimate is the
    fixed point of the simplified refined instrumental variable iteration,
    which is the output-error (maximum-likelihood under white noise) estimate;
    noise-free data give the true parameters to rounding. See the module
    docstring of `jaxsdp.tfest._srivc` for the algorithm.

    Args:
      y: (N,) sampled output.
      u: (N,) sampled input, held constant between samples (not constant over the record).
      dt: sampling interval (s), > 0.
      n: order of A(s), $1 \le n \le 10$; m: order of B(s), $0 \le m \le n$.
      delay: whole samples of input delay (>= 0); u is shifted by `delay` samples, with zeros in front.
      lam: prefilter bandwidth(s) (rad/s) of the LSSVF starts $1/(s + \lambda)^n$;
        default $(\pi/\Delta t)$ (0.3, 0.1, 0.03, 0.01, 0.003). All are iterated
        together; after 5 iterations only the one with the smallest sum of
        squared output errors goes on (if still running), and the converged
        stable estimate with the smallest sum of squares is kept.
      solver: a `jaxsdp.tfest.RIVSolver` (None: its defaults): at most
        `max_iter` IV iterations (50, as CONTSID) plus the extra one below;
        stop when $\|\theta_{new} - \theta_{old}\| / \|\theta_{new}\| <$ `tol`, $\theta$ in
        scaled time (1e-4, as CONTSID), after one more iteration: the
        iteration converges superlinearly on low-noise data, so that step
        takes noise-free estimates from about $tol^2$ to rounding (1e-10
        relative or better in tests/test_srivc.py).

    Returns:
      `SRIVCResult` with `num`, `den`, `theta`, `cov`, `num_se`, `den_se`,
      `sigma2`, `y_model`, `iterations`, `rel_change`, `converged`, `stable`,
      `lam`, `status` and `reason`.

    Raises:
      ValueError: bad shapes or options, non-finite data, too few samples
        (fewer than $10 (n + m + 1)$ after the delay), constant input; and, on
        concrete data, an unstable estimated $A(s)$. A run that did not converge
        is returned with `converged` False and its `reason`, and (on concrete
        data) a `RuntimeWarning` says so.
        Under `jax.vmap`/`jit` the value checks become runtime errors and an
        unstable estimate is flagged by `stable` False and `status`.

    Example:
        >>> import numpy as np
        >>> import scipy.signal as sig
        >>> from jaxsdp.tfest import srivc
        >>> dt = 0.05
        >>> u = np.repeat(np.random.default_rng(0).choice([-1.0, 1.0], 60), 5)  # 300 samples, ZOH
        >>> nd, dd, _ = sig.cont2discrete(([2.0], [1.0, 3.0, 2.0]), dt, method="zoh")
        >>> y = sig.lfilter(nd.ravel(), dd, u)  # exact samples of 2/(s^2 + 3 s + 2)
        >>> res = srivc(y, u, dt, n=2, m=0)
        >>> np.round(np.asarray(res.den), 6).tolist(), np.round(np.asarray(res.num), 6).tolist()
        ([1.0, 3.0, 2.0], [2.0])
        >>> bool(res.converged), res.reason
        (True, 'converged')
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_ORDER:
        raise ValueError(f"`n` (order of A(s)) must be an integer in 1..{MAX_ORDER}; got {n!r}")
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 0:
        raise ValueError(f"`m` (order of B(s)) must be an integer >= 0; got {m!r}")
    if m > n:
        raise ValueError(f"`m` = {m} exceeds `n` = {n}: B(s)/A(s) must be proper (m <= n)")
    n, m = int(n), int(m)
    delay = int_option("delay", delay, 0)
    solver = check_solver(solver, "srivc", pem=False)
    max_iter, tol = solver.max_iter, solver.tol
    dt = positive_float("dt", dt)
    y = as_float_array("y", y, ndim=1)
    u = as_float_array("u", u, ndim=1)
    if y.shape != u.shape:
        raise ValueError(f"`y` and `u` must have the same length; got {y.shape[0]} and {u.shape[0]}")
    N, p = y.shape[0], n + m + 1
    if N - delay < SAMPLES_PER_PARAMETER * p:
        raise ValueError(
            f"too few samples: {N} with a delay of {delay} leaves {N - delay}; n = {n}, m = {m} need at least "
            f"{SAMPLES_PER_PARAMETER * p} ({SAMPLES_PER_PARAMETER} per parameter)"
        )
    lams = lam_starts(lam, dt)
    carrier = check_data_values(y, u[None], (delay,), jnp.asarray(dt))
    res = _srivc_core(
        y, u, carrier, jnp.asarray(lams), n, m, jnp.asarray(delay), jnp.asarray(max_iter), jnp.asarray(tol)
    )
    if not is_concrete(res.status):
        return res
    if int(res.status) == UNSTABLE:
        roots = np.roots(np.asarray(res.den))
        raise ValueError(
            f"the estimated A(s) is unstable (roots {np.round(roots, 4).tolist()}): the data look open-loop "
            "unstable, which SRIVC (an output-error method) cannot fit; identify such a plant from closed-loop "
            "data (indirect approach) or with an equation-error method"
        )
    if not bool(res.converged):
        warnings.warn(f"srivc did not converge: {res.reason} (see `converged`, `rel_change`)", RuntimeWarning, 3)
    return res
