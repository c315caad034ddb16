"""The refined instrumental variable iteration for Box-Jenkins models, continuous or discrete, one or several inputs.

Model (r inputs u_i, each delayed by d_i whole samples, zeros before the record):

    y_k = sum_i G_i u_i(k - d_i) + xi_k,      xi_k = C(z^-1)/D(z^-1) e_k,

with G_i = B_i(s)/A_i(s) (continuous, `continuous=True`: the input held
between samples, the responses exact at the samples) or
G_i = B_i(z^-1)/A_i(z^-1) (discrete), and either one common denominator A
for every input (`common=True`) or one per input. C, D: the discrete ARMA
noise model (`jaxsdp.tfest._arma`); nc = nd = 0 is white noise (SRIVC/SRIV).

One pass at the current estimate (Ahat_i, Bhat_i, Chat, Dhat):

1. Auxiliary model xhat_i = Bhat_i/Ahat_i u_i and the model residual
   xi = y - sum_i xhat_i.
2. Prefilters: 1/Ahat_i (continuous: s^j/Ahat_i(s), j = 0..n_i, exact for the
   held input; the residual xi is filtered held, as in SRIVC, so that y's
   filtered derivatives are xhat_f + xi_f and noise-free data give exact
   estimates), then Dhat/Chat in discrete time on every filtered signal.
3. IV: for a common denominator one regression
   y_f^(n) = -sum a_j y_f^(n-j) + sum_i sum_j b_ij u_if^(m_i - j), the
   instrument built from xhat_f in place of y_f; for separate denominators
   one regression per input on y_i = y - sum_(l != i) xhat_l (Jacobi
   back-fitting: every input's step uses the previous pass's others).
4. Noise: a Gauss-Newton step of eta = [c, d] on the prediction errors
   eps = (Dhat/Chat) xi (`jaxsdp.tfest._arma.arma_step`).

At a fixed point the IV equations read sum_k zeta_k eps_k = 0 with zeta_k
the sensitivity d xhat_k / d theta filtered by D/C, i.e. -d eps_k / d theta,
and the noise step's equations sum_k psi_k eps_k = 0: together, the
stationary point of the Box-Jenkins prediction-error criterion sum eps_k^2
(conditional on zero initial conditions), which is the Gaussian maximum
likelihood estimate for large N and statistically efficient. The filtered
signals are linear in a few features f_k (filter states, inputs, output),
so every sum over time is read off the Gram matrix sum g_k g_k^T of the
noise-filtered features g = (D/C) f.

Stages (`riv_core`): (A) START_ITERATIONS white-noise passes from several
starts at once (continuous: the LSSVF prefilters 1/(s + lam)^n; discrete:
ARX least squares), the start with the smallest residual sum of squares kept;
(B) white-noise IV iterations to convergence (the SRIVC/SRIV estimate);
(C) with a noise model, the Hannan-Rissanen ARMA start on the residual of (B)
and Box-Jenkins passes to convergence; each stage's iteration stops after
one more pass once the relative change of theta is below `tol`.
"""

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
from jax import lax

from ._arma import arma_step, hannan_rissanen, lags, noise_filter, normalised_solve, reflect_inside
from ._srivc import START_ITERATIONS  # the same pruning of starts as SRIVC
from ._tf import tf2ss
from ._zoh import expm_taylor, scale_powers, stabilise, time_scale

#: The noise model is not updated when the model residual's sum of squares is below this fraction of
#: y's (noise-free data: an ARMA fit of rounding errors would be meaningless).
NOISE_FLOOR = 1e-24
#: `stable` needs continuous roots with real part < -STABILITY_RTOL c, discrete |root| < 1 - STABILITY_RTOL.
STABILITY_RTOL = 1e-9
CONVERGED, MAX_ITER, UNSTABLE, NONFINITE = range(4)


class Structure(NamedTuple):
    """The model's static structure: orders per input, common or separate denominators, noise orders."""

    continuous: bool
    n: tuple  # order of A_i per input (all equal when common)
    m: tuple  # order of B_i per input
    common: bool
    nc: int
    nd: int

    @property
    def r(self):
        return len(self.m)

    def slices(self):
        """[(slice of a_i, slice of b_i)] into theta per input, and the number of system parameters p."""
        out, pos = [], 0
        if self.common:
            n, pos = self.n[0], self.n[0]
            for mi in self.m:
                out.append((slice(0, n), slice(pos, pos + mi + 1)))
                pos += mi + 1
        else:
            for ni, mi in zip(self.n, self.m):
                out.append((slice(pos, pos + ni), slice(pos + ni, pos + ni + mi + 1)))
                pos += ni + mi + 1
        return out, pos


def powers(c, st):
    """(p,) scalings theta = theta_scaled * powers for time scaled by c (ones in discrete time)."""
    if not st.continuous:
        return jnp.ones((st.slices()[1],))
    if st.common:
        pa = c ** jnp.arange(1, st.n[0] + 1, dtype=jnp.float64)
        return jnp.concatenate([pa] + [scale_powers(c, st.n[0], mi)[st.n[0] :] for mi in st.m])
    return jnp.concatenate([scale_powers(c, ni, mi) for ni, mi in zip(st.n, st.m)])


def _ct_rows(tt, c, dt, st):
    """Continuous time: the linear recursion of the filter states and the rows mapping features to signals.

    State per input i: (w_i, v_i): 1/Af_i driven by u_i, and 1/Af_i driven by
    xhat_i = Bhat_i/Af_i u_i (= cb_i . w_i + db_i u_i); per prefilter group:
    z, 1/Af driven by the held residual xi = y - sum_i xhat_i. All in scaled
    time, discretised exactly (one matrix exponential per input). Features
    f = [states, u_1..u_r, y]; returns (A, B) of s[k+1] = A s[k] + B [u_k, y_k],
    the rows, and the largest real part of the Ahat roots (scaled time).
    """
    sl, _ = st.slices()
    groups = [0] if st.common else list(range(st.r))
    chans, maxre = [], []
    for a_sl, b_sl in sl:
        at, bt = tt[a_sl], tt[b_sl]
        n = at.shape[0]
        af, mr = stabilise(at)
        ac, e, cb, db = tf2ss(bt, jnp.concatenate([jnp.ones((1,)), af]))
        aug = jnp.block([[ac, jnp.zeros((n, n)), e[:, None]], [jnp.outer(e, cb), ac, (e * db)[:, None]]])
        ex = expm_taylor(jnp.concatenate([aug, jnp.zeros((1, 2 * n + 1))], axis=0) * (c * dt))
        chans.append((n, af, cb, db, ex[: 2 * n, : 2 * n], ex[: 2 * n, 2 * n]))
        maxre.append(mr)
    offs, o = [], 0
    for n, *_ in chans:
        offs.append(o)
        o += 2 * n
    zoffs = []
    for j in groups:
        zoffs.append(o)
        o += chans[j][0]
    S, r = o, st.r
    U, Y = S, S + r
    F = S + r + 1
    E = jnp.eye(F)
    # recursion: s[k+1] = blockdiag(phi_i, phiw_j) s + gam_i u_i + gw_j xi_k, xi_k = y_k - sum_i xhat_i(k)
    A = jnp.zeros((S, S))
    B = jnp.zeros((S, r + 1))
    xh_rows = []
    for i, (n, af, cb, db, phi, gam) in enumerate(chans):
        A = A.at[offs[i] : offs[i] + 2 * n, offs[i] : offs[i] + 2 * n].set(phi)
        B = B.at[offs[i] : offs[i] + 2 * n, i].set(gam)
        xh_rows.append(cb @ E[offs[i] : offs[i] + n] + db * E[U + i])
    xi_row = E[Y] - sum(xh_rows)
    for g, j in enumerate(groups):
        n, phi, gam = chans[j][0], chans[j][4], chans[j][5]
        q = zoffs[g]
        A = A.at[q : q + n, q : q + n].set(phi[:n, :n])
        gw = gam[:n]
        # + gw xi_k with xi_k = xi_row . [s, u, y]
        A = A.at[q : q + n, :S].add(jnp.outer(gw, xi_row[:S]))
        B = B.at[q : q + n, :].add(jnp.outer(gw, xi_row[S:]))

    def deriv(base, top, af, n, k):  # x_f(k) for k < n: state; x_f(n) = x - sum_j af_j x_f(n - j)
        if k < n:
            return E[base + k]
        return top - sum(af[j - 1] * E[base + n - j] for j in range(1, n + 1))

    def uf(i, k):
        n, af = chans[i][0], chans[i][1]
        return deriv(offs[i], E[U + i], af, n, k)

    def xf(i, k):
        n, af = chans[i][0], chans[i][1]
        return deriv(offs[i] + n, xh_rows[i], af, n, k)

    def xif(g, k):
        j = groups[g]
        n, af = chans[j][0], chans[j][1]
        return deriv(zoffs[g], xi_row, af, n, k)

    blocks = _block_rows(st, uf, xf, xif, lambda n: range(n - 1, -1, -1), lambda n: n)
    return (A, B), blocks, xi_row, jnp.max(jnp.stack(maxre))


def _block_rows(st, uf, xf, xif, a_lags, target_lag):
    """(regressor, instrument, target) rows per solved block.

    `a_lags(n)`: the filtered-output entries multiplying a_1..a_n (continuous:
    derivatives n-1..0; discrete: lags 1..n); `target_lag(n)`: the target's
    (continuous: derivative n; discrete: lag 0). The B entries run over
    u_f's derivatives m..0 (continuous) or lags 0..m (discrete).
    """
    blocks = []
    if st.common:
        n = st.n[0]

        def xsum(lv):
            return sum(xf(i, lv) for i in range(st.r))

        ys = [xsum(lv) + xif(0, lv) for lv in a_lags(n)]
        xs = [xsum(lv) for lv in a_lags(n)]
        us = [uf(i, lv) for i in range(st.r) for lv in _b_lags(st, st.m[i])]
        regr = jnp.stack([-v for v in ys] + us)
        inst = jnp.stack([-v for v in xs] + us)
        tn = target_lag(n)
        blocks.append((regr, inst, xsum(tn) + xif(0, tn)))
    else:
        for i, (n, mi) in enumerate(zip(st.n, st.m)):
            ys = [xf(i, lv) + xif(i, lv) for lv in a_lags(n)]
            xs = [xf(i, lv) for lv in a_lags(n)]
            us = [uf(i, lv) for lv in _b_lags(st, mi)]
            tn = target_lag(n)
            blocks.append((jnp.stack([-v for v in ys] + us), jnp.stack([-v for v in xs] + us), xf(i, tn) + xif(i, tn)))
    return blocks


def _b_lags(st, m):
    return range(m, -1, -1) if st.continuous else range(0, m + 1)


def _dt_features(theta, y, us, st):
    """Discrete time: filter signals by one scan, then lagged features and their rows.

    Per input: w_i = (1/Af_i) u_i, xhat_i = Bhat_i w_i, v_i = (1/Af_i) xhat_i;
    per prefilter group z = (1/Af) xi, xi = y - sum xhat_i. Features: lags
    0..m_i of w_i, 0..n_i of v_i, 0..n of z, and y.
    """
    sl, _ = st.slices()
    groups = [0] if st.common else list(range(st.r))
    chans, maxmod = [], []
    for a_sl, b_sl in sl:
        af, mod = reflect_inside(theta[a_sl], 1.0)
        chans.append((af, theta[b_sl]))
        maxmod.append(mod)

    def step(state, x):
        ws, vs, zs = state
        uk, yk = x[: st.r], x[st.r]
        nw, nv, outs_w, outs_v, xh = [], [], [], [], 0.0
        for i, (af, b) in enumerate(chans):
            n, m = af.shape[0], b.shape[0] - 1
            wk = uk[i] - af @ ws[i][:n]
            wl = jnp.concatenate([wk[None], ws[i]])
            xk = b @ wl[: m + 1]
            vk = xk - af @ vs[i]
            xh = xh + xk
            nw.append(wl[:-1])
            nv.append(jnp.concatenate([vk[None], vs[i][:-1]]) if n else vs[i])
            outs_w.append(wk)
            outs_v.append(vk)
        xik = yk - xh
        nz, outs_z = [], []
        for g, j in enumerate(groups):
            af = chans[j][0]
            zk = xik - af @ zs[g]
            nz.append(jnp.concatenate([zk[None], zs[g][:-1]]))
            outs_z.append(zk)
        return (nw, nv, nz), jnp.stack(outs_w + outs_v + outs_z)

    init = (
        [jnp.zeros((max(af.shape[0], b.shape[0] - 1, 1),)) for af, b in chans],
        [jnp.zeros((af.shape[0],)) for af, _ in chans],
        [jnp.zeros((chans[j][0].shape[0],)) for j in groups],
    )
    x = jnp.concatenate([us.T, y[:, None]], axis=1)
    _, out = lax.scan(step, init, x, unroll=4)
    r = st.r
    cols, offs_w, offs_v, offs_z, o = [], [], [], [], 0
    for i, (af, b) in enumerate(chans):
        offs_w.append(o)
        cols.append(lags(out[:, i], 0, b.shape[0] - 1))
        o += b.shape[0]
    for i, (af, _) in enumerate(chans):
        offs_v.append(o)
        cols.append(lags(out[:, r + i], 0, af.shape[0]))
        o += af.shape[0] + 1
    for g, j in enumerate(groups):
        offs_z.append(o)
        cols.append(lags(out[:, 2 * r + g], 0, chans[j][0].shape[0]))
        o += chans[j][0].shape[0] + 1
    f = jnp.concatenate(cols + [y[:, None]], axis=1)
    E = jnp.eye(o + 1)
    xh_rows = [chans[i][1] @ E[offs_w[i] : offs_w[i] + chans[i][1].shape[0]] for i in range(r)]
    xi_row = E[o] - sum(xh_rows)
    blocks = _block_rows(
        st,
        lambda i, lv: E[offs_w[i] + lv],
        lambda i, lv: E[offs_v[i] + lv],
        lambda g, lv: E[offs_z[g] + lv],
        lambda n: range(1, n + 1),
        lambda n: 0,
    )
    return f, blocks, xi_row, jnp.max(jnp.stack(maxmod))


def delayed(us, delays):
    """u_i(k - d_i), zeros before the record; `delays` may be traced (vmap over delays)."""
    N = us.shape[1]
    t = jnp.arange(N)
    idx = t[None, :] - delays[:, None]
    return jnp.where(idx >= 0, jnp.take_along_axis(us, jnp.maximum(idx, 0), axis=1), 0.0)


def riv_pass(theta, eta, ls, y, us, dt, st, noise):
    """One refined IV pass at (theta, eta); `ls`: instrument = regressor (the least-squares start).

    Returns (new theta, new eta, relative change, diagnostics at the given
    theta, eta: residual xi, prediction errors eps, information matrices).
    """
    N = y.shape[0]
    _, p = st.slices()
    if st.continuous:
        sl, _ = st.slices()
        c = jnp.max(jnp.stack([time_scale(theta[a], dt, N) for a, _ in sl]))
        pw = powers(c, st)
        tt = theta / pw
        (A, B), blocks, xi_row, maxre = _ct_rows(tt, c, dt, st)
        x = jnp.concatenate([us.T, y[:, None]], axis=1)

        def step(s, xk):
            return A @ s + B @ xk, s

        _, states = lax.scan(step, jnp.zeros((A.shape[0],)), x, unroll=4)
        f = jnp.concatenate([states, x], axis=1)
        stable = maxre < -STABILITY_RTOL
    else:
        c, pw, tt = jnp.array(1.0), jnp.ones((p,)), theta
        f, blocks, xi_row, maxmod = _dt_features(theta, y, us, st)
        stable = maxmod < 1.0 - STABILITY_RTOL
    nc, q = st.nc, st.nc + st.nd
    xi = f @ xi_row
    if q:  # `noise` (traced) False: C = D = 1, the same scan, no noise-model update
        used = jnp.where(noise, eta, 0.0)
        g, eps, a, b = noise_filter(f, xi, xi_row, used[:nc], used[nc:])
    else:
        g, eps = f, xi
    gram = g.T @ g
    new = []
    for regr, inst, tgt in blocks:
        use = jnp.where(ls, regr, inst)
        lhs = use @ gram @ regr.T
        rhs = use @ gram @ tgt
        dr = 1.0 / jnp.sqrt(jnp.maximum(jnp.diagonal(regr @ gram @ regr.T), jnp.finfo(jnp.float64).tiny))
        di = 1.0 / jnp.sqrt(jnp.maximum(jnp.diagonal(use @ gram @ use.T), jnp.finfo(jnp.float64).tiny))
        new.append(jnp.linalg.solve(lhs * di[:, None] * dr[None, :], rhs * di) * dr)
    new_t = jnp.concatenate(new)
    zall = jnp.concatenate([inst for _, inst, _ in blocks])
    info = zall @ gram @ zall.T
    sse_xi, sse_eps = xi @ xi, eps @ eps
    if q:
        stepped, ninfo = arma_step(eta, eps, a, b, nc, st.nd)
        eta_new = jnp.where(noise & (sse_xi > NOISE_FLOOR * (y @ y)), stepped, eta)
    else:
        eta_new, ninfo = eta, jnp.zeros((0, 0))
    # convergence is judged on the system parameters: an over-parameterised noise model (e.g. ARMA(1,1) on
    # white noise, c1 ~ d1) drifts along its ridge without changing D/C or theta
    rel = jnp.linalg.norm(new_t - tt) / jnp.linalg.norm(new_t)
    diag = dict(xi=xi, eps=eps, sse_xi=sse_xi, sse_eps=sse_eps, info=info, ninfo=ninfo, pw=pw, stable=stable)
    return new_t * pw, eta_new, rel, diag


def _finite(*xs):
    return jnp.all(jnp.stack([jnp.all(jnp.isfinite(x)) for x in xs]))


def starts(st, dt, lams):
    """(K, p) start values: continuous (s + lam)^n for each lam (B = 0); discrete A = 1, B = 0 (one start)."""
    sl, p = st.slices()
    if not st.continuous:
        return jnp.zeros((1, p))
    th = jnp.zeros((lams.shape[0], p))
    for a_sl, _ in sl:
        n = a_sl.stop - a_sl.start
        binom = jnp.asarray([float(math.comb(n, i)) for i in range(1, n + 1)])
        th = th.at[:, a_sl].set(binom * lams[:, None] ** jnp.arange(1, n + 1, dtype=jnp.float64))
    return th


# Phases of each start in `riv_core`'s loop.
LS, OE, OE_LAST, BJ, BJ_LAST, EVAL, DONE = range(7)


def riv_core(y, us, dt, delays, lams, st, max_iter, tol):
    """Stages A-C (module docstring) and the evaluation at the estimate, in one `lax.while_loop`.

    All K starts run together (one compiled pass, `vmap`ped over them); each
    goes through the phases LS (least-squares start), OE (white-noise IV
    until the relative change < tol), OE_LAST (one more), then with a noise
    model BJ (Hannan-Rissanen start on the OE residual, Box-Jenkins passes
    until < tol) and BJ_LAST, then EVAL (a pass at the estimate whose
    statistics are kept) and DONE. After START_ITERATIONS passes only the
    start with the smallest residual sum of squares (stable, finite) goes
    on. Returns the dict of `evaluate`.
    """
    N = y.shape[0]
    _, p = st.slices()
    q = st.nc + st.nd
    ud = delayed(us, delays)
    th0 = starts(st, dt, lams)
    K = th0.shape[0]
    zk, fk = jnp.zeros((K,), int), jnp.zeros((K,), bool)
    init = dict(it=jnp.array(0), theta=th0, eta=jnp.zeros((K, q)), phase=zk, k=zk, rel=jnp.full((K,), jnp.inf))
    init.update(met=fk, bad=fk, pruned=fk, xi=jnp.zeros((K, N)), eps=jnp.zeros((K, N)))
    init.update(info=jnp.zeros((K, p, p)), ninfo=jnp.zeros((K, q, q)), pw=jnp.ones((K, p)), stable=fk)
    init.update(sse=jnp.zeros((K,)), kst=zk)

    def body(s):
        ph = s["phase"]
        noise = (ph == BJ) | (ph == BJ_LAST) | (ph == EVAL) if q else fk
        th, et, rel, d = jax.vmap(lambda t, e, ls, nz: riv_pass(t, e, ls, y, ud, dt, st, nz))(
            s["theta"], s["eta"], ph == LS, noise
        )
        ok = jax.vmap(_finite)(th, et, rel)
        iterating = (ph == OE) | (ph == BJ)
        kst = jnp.where(iterating, s["kst"] + 1, s["kst"])
        k = s["k"] + (iterating | (ph == OE_LAST) | (ph == BJ_LAST))
        small = ok & (rel < tol)
        after_oe = BJ if q else EVAL
        limit = jnp.where(ph == OE, after_oe, EVAL)
        after_it = jnp.where(~ok, EVAL, jnp.where(small, ph + 1, jnp.where(kst >= max_iter, limit, ph)))
        nxt = jnp.select(
            [ph == LS, iterating, ph == OE_LAST, ph == BJ_LAST, ph == EVAL],
            [jnp.where(ok, OE, EVAL), after_it, after_oe, EVAL, DONE],
            DONE,
        )
        kst = jnp.where((nxt == BJ) & (ph != BJ), 0, kst) if q else kst
        met = jnp.where(iterating, small, jnp.where(ph == LS, False, s["met"]))
        upd = (ph < EVAL) & ok
        theta = jnp.where(upd[:, None], th, s["theta"])
        eta = jnp.where(upd[:, None], et, s["eta"])
        if q:  # entering BJ: the Hannan-Rissanen start from the OE residual (noise-free: none)
            enter = (nxt == BJ) & (ph != BJ)  # from OE_LAST, or from OE at its iteration limit
            hr = lax.cond(
                jnp.any(enter), lambda: jax.vmap(lambda x: hannan_rissanen(x, st.nc, st.nd))(d["xi"]), lambda: eta
            )
            noisy = d["sse_xi"] > NOISE_FLOOR * (y @ y)
            eta = jnp.where((enter & noisy)[:, None], hr, eta)
        sse = d["sse_xi"]
        score = jnp.where(ok & d["stable"] & jnp.isfinite(sse), sse, jnp.inf)
        drop = (s["it"] == START_ITERATIONS) & (jnp.arange(K) != jnp.argmin(score)) & (nxt < EVAL)
        ev = ph == EVAL
        keep = lambda new, old: jnp.where(ev.reshape((K,) + (1,) * (old.ndim - 1)), new, old)  # noqa: E731
        return dict(
            it=s["it"] + 1,
            theta=theta,
            eta=eta,
            phase=jnp.where(drop, DONE, nxt),
            k=k,
            kst=kst,
            rel=jnp.where(iterating | (ph == OE_LAST) | (ph == BJ_LAST), jnp.where(ok, rel, s["rel"]), s["rel"]),
            met=met,
            bad=s["bad"] | ((ph < EVAL) & ~ok),
            pruned=s["pruned"] | drop,
            xi=keep(d["xi"], s["xi"]),
            eps=keep(d["eps"], s["eps"]),
            info=keep(d["info"], s["info"]),
            ninfo=keep(d["ninfo"], s["ninfo"]),
            pw=keep(d["pw"], s["pw"]),
            stable=keep(d["stable"], s["stable"]),
            sse=keep(d["sse_eps"], s["sse"]),
        )

    s = lax.while_loop(lambda s: jnp.any(s["phase"] < DONE), body, init)
    sse_xi = jnp.sum(s["xi"] * s["xi"], axis=1)
    ok = ~s["bad"] & jnp.isfinite(s["sse"])
    penalty = jnp.where(s["pruned"], 3, jnp.where(s["met"] & s["stable"] & ok, 0, jnp.where(s["stable"] & ok, 1, 2)))
    big = jnp.finfo(jnp.float64).max
    i = jnp.argmin(jnp.where(penalty == jnp.min(penalty), jnp.where(ok, sse_xi, big), jnp.inf))
    pick = {key: v[i] for key, v in s.items() if key not in ("it",)}
    return evaluate(pick, y, st)


def evaluate_at(theta, eta, y, ud, dt, st, iterations, met):
    """`evaluate` at a given (theta, eta) (e.g. the prediction-error estimate), after one pass there."""
    q = st.nc + st.nd
    _, _, rel, d = riv_pass(theta, eta, False, y, ud, dt, st, jnp.array(q > 0))
    ok = _finite(d["sse_eps"])
    s = dict(theta=theta, eta=eta, sse=d["sse_eps"], info=d["info"], ninfo=d["ninfo"], pw=d["pw"])
    s.update(xi=d["xi"], eps=d["eps"], stable=d["stable"], bad=~ok, met=met, k=iterations, rel=rel)
    return evaluate(s, y, st)


def evaluate(s, y, st):
    """Covariances and fit statistics from the statistics of the pass at the estimate (`s`: one start)."""
    N = y.shape[0]
    _, p = st.slices()
    q = st.nc + st.nd
    theta, eta = s["theta"], s["eta"]
    sigma2 = s["sse"] / (N - p - q)
    info, pw = s["info"], s["pw"]
    sc = 1.0 / jnp.sqrt(jnp.maximum(jnp.diag(info), jnp.finfo(jnp.float64).tiny))
    cho = jsl.cho_factor(info * sc[:, None] * sc[None, :], lower=True)
    sc = pw * sc
    cov = sigma2 * sc[:, None] * jsl.cho_solve(cho, jnp.eye(p)) * sc[None, :]
    if q:
        ncov = sigma2 * normalised_solve(s["ninfo"], jnp.eye(q))
        ncov = 0.5 * (ncov + ncov.T)
    else:
        ncov = jnp.zeros((0, 0))
    xi, eps, sse_eps, stable = s["xi"], s["eps"], s["sse"], s["stable"]
    bad, met, iterations, rel = s["bad"], s["met"], s["k"], s["rel"]
    var_y = jnp.var(y)
    var_xi = jnp.var(xi)
    rt2 = 1.0 - var_xi / var_y
    nevn = jnp.mean(jnp.diag(cov) / jnp.maximum(theta**2, jnp.finfo(jnp.float64).tiny))
    yic = jnp.log(var_xi / var_y) + jnp.log(nevn)
    s2ml = sse_eps / N
    aic = N * jnp.log(s2ml) + 2.0 * (p + q)
    bic = N * jnp.log(s2ml) + (p + q) * jnp.log(N)
    ok = ~bad & jnp.isfinite(sse_eps) & _finite(theta, eta)
    converged = met & ok
    status = jnp.where(~ok, NONFINITE, jnp.where(~stable, UNSTABLE, jnp.where(converged, CONVERGED, MAX_ITER)))
    return dict(
        theta=theta,
        eta=eta,
        cov=cov,
        noise_cov=ncov,
        sigma2=sigma2,
        xi=xi,
        eps=eps,
        iterations=iterations,
        rel=rel,
        converged=converged,
        stable=stable,
        status=status,
        rt2=rt2,
        yic=yic,
        aic=aic,
        bic=bic,
    )
