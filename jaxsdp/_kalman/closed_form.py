"""Closed-form Kalman filter and smoother for one parameter block of dimension 1 or 2.

The same model and recursions as `jaxsdp._kalman.general` (which handles any number
of blocks with dense matrix algebra), specialised to a single regressor
whose parameter block is RW/Constant (n = 1) or IRW/SRW/LLT (n = 2):

    s_k = F s_{k-1} + eta_k,   F = [[f11, f12], [0, f22]],   Q = [[q11, q12], [q12, q22]]
    y_k = h_k s_k[0] + e_k,    var(e) = 1

The carry is a tuple of scalars and every 2x2 product, including the
factorised solve in the smoother gain, is written out in closed form: small
`jnp.linalg` calls inside a scan step cost 0.2-1 us each on the CPU. The
scan bodies are also where all the per-sample work happens (missing-sample
handling, burn-in masks, the likelihood sums): on XLA-CPU every elementwise
pass over the data outside a scan costs tens of microseconds, more than the
arithmetic. Results equal the dense kernels to rounding (tested against the
same dense posterior).

Filter (a missing y_k is an observation with h_k = 0, which leaves the
prediction unchanged and contributes v_k = 0, f_k = 1):

    f = 1 + h^2 P11,  P11 <- P11/f,  P12 <- P12/f,  P22 <- P22 - h^2 P12^2/f.

Smoother (RTS, the Joseph-like form of `jaxsdp._kalman.general`), with the gain
from an LDL^T (square-root-free Cholesky) solve of the predicted covariance
A = F P_{k|k} F^T + Q, never its inverse:

    G = P_{k|k} F^T A^{-1},
    P_{k|N} = (I - G F) P_{k|k} (I - G F)^T + G (Q + P_{k+1|N}) G^T.

The backward scan covers all N samples: it starts from the one-step
prediction beyond the last sample (P_{N+1|N} = A, x_{N+1|N} = F x_{N|N}),
for which the step above returns the filtered moments at k = N exactly.
"""

from typing import NamedTuple

import jax.numpy as jnp
from jax import lax

from .general import concentrated_loglik, likelihood_from_sums
from .parallel import parallel_filter_smoother

# Floor on the determinant of A in the 2x2 solve (A is nearly singular
# for an IRW with a tiny NVR once the data pin the slope down). The floor only
# keeps the numbers finite; whether it (or the clip of the filtered P22 at 0)
# was needed is reported, see `DEFINITE_RTOL`.
_TINY = 1e-300

#: A 2x2 covariance counts as numerically positive definite while its
#: determinant exceeds this fraction of the product of its diagonal, i.e.
#: 1 - rho^2 > DEFINITE_RTOL with rho the correlation of the two states
#: (below it the gain has lost all but ~2 of its 16 digits). Checked on the
#: predicted covariance in the smoother (the matrix it solves with) and on the
#: filtered P22 before its clip at 0 (P22 > DEFINITE_RTOL * predicted P22).
#: The kernels carry one boolean for it (`Sums.definite`, `BlockOutput.definite`).
DEFINITE_RTOL = 1e-14


class BlockSystem(NamedTuple):
    """Scalars of F and Q (n = 1 uses f11, q11 only)."""

    n: int
    f11: jnp.ndarray
    f12: jnp.ndarray
    f22: jnp.ndarray
    q11: jnp.ndarray
    q12: jnp.ndarray
    q22: jnp.ndarray


def block_system(F, Q) -> BlockSystem:
    n = F.shape[0]
    if n == 1:
        z = jnp.zeros((), F.dtype)
        return BlockSystem(1, F[0, 0], z, z, Q[0, 0], z, z)
    if n == 2:
        return BlockSystem(2, F[0, 0], F[0, 1], F[1, 1], Q[0, 0], Q[0, 1], Q[1, 1])
    raise ValueError(f"closed-form kernels handle blocks of dimension 1 or 2; got {n}")


def _step_system(sys: BlockSystem, adv):
    """Transition scalars; tied SDP states (adv False) hold the state without noise.

    `adv` None (no ties, e.g. `dlr`): the constant system, with no per-step selects.
    """
    if adv is None:
        return sys.f11, sys.f12, sys.f22, sys.q11, sys.q12, sys.q22
    one, zero = jnp.ones_like(sys.f11), jnp.zeros_like(sys.f11)
    w = lambda a, b: jnp.where(adv, a, b)
    return (w(sys.f11, one), w(sys.f12, zero), w(sys.f22, one), w(sys.q11, zero), w(sys.q12, zero), w(sys.q22, zero))


def _predict(sys: BlockSystem, x, P, adv):
    """One-step prediction (x, P as tuples: (x1,), (P11,) or (x1, x2), (P11, P12, P22))."""
    f11, f12, f22, q11, q12, q22 = _step_system(sys, adv)
    if sys.n == 1:
        return (f11 * x[0],), (f11 * f11 * P[0] + q11,)
    x1, x2 = x
    P11, P12, P22 = P
    # F P F^T + Q with F upper triangular
    a11 = f11 * P11 + f12 * P12
    a12 = f11 * P12 + f12 * P22
    return (f11 * x1 + f12 * x2, f22 * x2), (a11 * f11 + a12 * f12 + q11, a12 * f22 + q12, f22 * f22 * P22 + q22)


class Sums(NamedTuple):
    """Running sums of the filter over the observed samples after the first burn-in ones (`k` counts the observed
    samples so far)."""

    k: jnp.ndarray  # step counter
    logf_m: jnp.ndarray  # prod f_k = logf_m * 2**logf_e (k >= burn_in), logf_m in [1, 2)
    logf_e: jnp.ndarray
    se2: jnp.ndarray  # sum v_k^2 / f_k        (k >= burn_in)
    n: jnp.ndarray  # count                  (k >= burn_in)
    se2_s: jnp.ndarray  # sum v_k^2 / f_k      (k >= sigma2_burn_in)
    n_s: jnp.ndarray  # count                (k >= sigma2_burn_in)
    definite: jnp.ndarray  # bool: the filtered covariance stayed positive definite (`DEFINITE_RTOL`)


def _filter_step(sys, burn_in, sigma2_burn_in):
    def step(carry, inp):
        x, P, s = carry
        yk, hk, adv = inp
        ok = yk == yk  # not NaN
        hk = jnp.where(ok, hk, 0.0)
        (xp, Pp) = _predict(sys, x, P, adv)
        definite = s.definite
        k1 = Pp[0] * hk
        f = 1.0 + hk * k1
        r = 1.0 / f
        v = jnp.where(ok, yk, 0.0) - hk * xp[0]
        vr = v * r
        if sys.n == 1:
            x, P = (xp[0] + k1 * vr,), (Pp[0] * r,)
        else:
            k2 = Pp[1] * hk
            x = (xp[0] + k1 * vr, xp[1] + k2 * vr)
            P22 = Pp[2] - k2 * k2 * r
            definite = s.definite & (P22 > DEFINITE_RTOL * Pp[2])
            P = (Pp[0] * r, Pp[1] * r, jnp.maximum(P22, 0.0))
        e2 = v * vr
        u = ok & (s.k >= burn_in)
        # (with one burn-in for both, the sigma^2 sums are the likelihood's: not carried twice)
        us = u if sigma2_burn_in == burn_in else ok & (s.k >= sigma2_burn_in)
        s = Sums(
            s.k + ok,
            *_times_f(s.logf_m, s.logf_e, jnp.where(u, f, 1.0)),
            s.se2 + jnp.where(u, e2, 0.0),
            s.n + u,
            s.se2_s if us is u else s.se2_s + jnp.where(us, e2, 0.0),
            s.n_s if us is u else s.n_s + us,
            definite,
        )
        return (x, P, s), (x, P, v, f)

    return step


def _times_f(m, e, f):
    """(m, e) with m * 2**e = prod f kept as mantissa m in [1, 2) and integer exponent e.

    Sum log f_k = log m + e log 2: a product and a few integer operations per
    step instead of a logarithm (f_k >= 1, so m stays a positive normal
    number). The exponent is read from the bits of m and carries no tangent;
    the scaling by 2**-e is exact, so derivatives flow through m.
    """
    m = m * f
    info = jnp.finfo(m.dtype)
    itype = jnp.int64 if m.dtype == jnp.float64 else jnp.int32
    bias = info.maxexp - 1
    ex = (lax.bitcast_convert_type(lax.stop_gradient(m), itype) >> info.nmant) - bias
    scale = lax.bitcast_convert_type((bias - ex) << info.nmant, m.dtype)
    return m * scale, e + ex.astype(e.dtype)


def slogf(s: Sums):
    return jnp.log(s.logf_m) + s.logf_e * jnp.log(2.0)


def _init(sys, x0, P0):
    z = jnp.zeros_like(P0)
    if sys.n == 1:
        x, P = (x0[0],), (P0,)
    else:
        x, P = (x0[0], x0[1]), (P0, z, P0)
    zi = jnp.zeros((), jnp.int32)
    return x, P, Sums(zi, jnp.ones_like(P0), zi, z, zi, z, zi, jnp.ones((), bool))


class BlockFilter(NamedTuple):
    x: tuple  # filtered state, one (N,) array per state
    P: tuple  # filtered covariance (P11,) or (P11, P12, P22), each (N,)
    innov: jnp.ndarray  # (N,) v_k (0 where y is missing)
    innov_var: jnp.ndarray  # (N,) f_k (1 where y is missing)
    sums: Sums


def block_filter(y, h, sys: BlockSystem, x0, P0, *, burn_in: int, sigma2_burn_in: int, advance=None) -> BlockFilter:
    """Kalman filter for one block; `h` (N,) the regressor, P0 a scalar (P0 I), NaN y missing.

    `advance` (N,) bool marks steps where the state moves (None: all; scanned as an empty pytree).
    """
    step = _filter_step(sys, burn_in, sigma2_burn_in)
    (_, _, sums), (x, P, v, f) = lax.scan(step, _init(sys, x0, P0), (y, h, advance))
    return BlockFilter(x, P, v, f, sums)


def _solve_gain2(B, A):
    """G^T = A^{-1} B for 2x2 symmetric positive-definite A by LDL^T; B = F P (rows).

    A = L D L^T with L = [[1, 0], [l, 1]], l = A12/A11, D = diag(A11, s) and
    the Schur complement s = A22 - l A12 = det(A)/A11; the two reciprocals are
    independent, so their latencies overlap.
    """
    B11, B12, B21, B22 = B
    A11, A12, A22 = A
    d1 = 1.0 / A11
    a1122 = A11 * A22
    det = a1122 - A12 * A12
    rdet = 1.0 / jnp.maximum(det, _TINY)
    # forward substitution L w = B, then D^{-1}, then back substitution L^T g = D^{-1} w
    G12 = (A11 * B21 - A12 * B11) * rdet
    G22 = (A11 * B22 - A12 * B12) * rdet
    definite = det > DEFINITE_RTOL * a1122
    return ((B11 - A12 * G12) * d1, G12, (B12 - A12 * G22) * d1, G22), definite  # (G11, G12, G21, G22), flag


def _smoother_step(sys):
    def step(carry, inp):
        xs, S, definite = carry
        xf, Pf, adv = inp
        f11, f12, f22, q11, q12, q22 = _step_system(sys, adv)
        if sys.n == 1:
            (P,), (x,) = Pf, xf
            A = f11 * f11 * P + q11
            G = P * f11 / A
            M = 1.0 - G * f11
            x = x + G * (xs[0] - f11 * x)
            S = M * M * P + G * G * (q11 + S[0])
            return ((x,), (S,), definite), (x, S, (G,))
        x1, x2 = xf
        P11, P12, P22 = Pf
        # B = F P_{k|k}; A = B F^T + Q = P_{k+1|k}
        B11 = f11 * P11 + f12 * P12
        B12 = f11 * P12 + f12 * P22
        B21 = f22 * P12
        B22 = f22 * P22
        A = (B11 * f11 + B12 * f12 + q11, B12 * f22 + q12, B22 * f22 + q22)
        (G11, G12, G21, G22), ok = _solve_gain2((B11, B12, B21, B22), A)
        d1 = xs[0] - (f11 * x1 + f12 * x2)
        d2 = xs[1] - f22 * x2
        n1 = x1 + G11 * d1 + G12 * d2
        n2 = x2 + G21 * d1 + G22 * d2
        # M = I - G F
        M11 = 1.0 - G11 * f11
        M12 = -(G11 * f12 + G12 * f22)
        M21 = -G21 * f11
        M22 = 1.0 - (G21 * f12 + G22 * f22)
        t11 = M11 * P11 + M12 * P12
        t12 = M11 * P12 + M12 * P22
        t21 = M21 * P11 + M22 * P12
        t22 = M21 * P12 + M22 * P22
        R11, R12, R22 = q11 + S[0], q12 + S[1], q22 + S[2]
        u11 = G11 * R11 + G12 * R12
        u12 = G11 * R12 + G12 * R22
        u21 = G21 * R11 + G22 * R12
        u22 = G21 * R12 + G22 * R22
        S11 = t11 * M11 + t12 * M12 + u11 * G11 + u12 * G12
        S12 = t11 * M21 + t12 * M22 + u11 * G21 + u12 * G22
        S22 = t21 * M21 + t22 * M22 + u21 * G21 + u22 * G22
        return ((n1, n2), (S11, S12, S22), definite & ok), (n1, n2, S11, S22, (G11, G12, G21, G22))

    return step


def block_smoother(filt: BlockFilter, sys: BlockSystem, *, advance=None, gains: bool = False):
    """Fixed-interval smoother: ((N,) smoothed states, (N,) smoothed variances), one tuple each,
    and whether the predicted covariances it solved with stayed positive definite together
    with the filter's (`DEFINITE_RTOL`); then the smoother gains G_k row by row if `gains`."""
    last_x = tuple(a[-1] for a in filt.x)
    last_P = tuple(a[-1] for a in filt.P)
    # start one step beyond the data (see the module docstring)
    init = (*_predict(sys, last_x, last_P, None), filt.sums.definite)
    adv_next = None if advance is None else jnp.concatenate([advance[1:], jnp.ones(1, bool)])
    (_, _, definite), out = lax.scan(_smoother_step(sys), init, (filt.x, filt.P, adv_next), reverse=True)
    xs, Ps = ((out[0],), (out[1],)) if sys.n == 1 else (out[:2], out[2:4])
    return (xs, Ps, definite, out[-1]) if gains else (xs, Ps, definite)


class BlockOutput(NamedTuple):
    x_smooth: jnp.ndarray  # (N, n)
    P_smooth_diag: jnp.ndarray  # (N, n)
    x_filt: jnp.ndarray  # (N, n)
    P_filt_diag: jnp.ndarray  # (N, n)
    innov: jnp.ndarray  # (N,)  0 where y is missing
    innov_var: jnp.ndarray  # (N,)  1 where y is missing
    loglik: tuple  # `jaxsdp.Likelihood` with CAPTAIN's burn-ins (see `block_filter_smoother`)
    definite: jnp.ndarray  # bool: filter and smoother covariances stayed positive definite


def block_filter_smoother(
    y,
    h,
    sys: BlockSystem,
    x0,
    P0,
    *,
    burn_in: int,
    sigma2_burn_in: int,
    advance=None,
    method: str = "sequential",
    complete: bool = False,
) -> BlockOutput:
    """Filter + fixed-interval smoother for one block, and the concentrated likelihood.

    The likelihood sums run over the observed samples after the first `burn_in` observed ones, sigma^2
    after the first `sigma2_burn_in` (as `jaxsdp._kalman.general.concentrated_loglik`).
    `method` "parallel" computes the same moments by associative scans
    (`jaxsdp._kalman.parallel`); `complete` tells it y has no missing sample.
    """
    if method == "parallel":
        return _parallel_block(
            y, h, sys, x0, P0, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in, advance=advance, complete=complete
        )
    filt = block_filter(y, h, sys, x0, P0, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in, advance=advance)
    xs, Ps, definite = block_smoother(filt, sys, advance=advance)
    col = lambda t: jnp.stack(t, axis=1)
    Pf = (filt.P[0],) if sys.n == 1 else (filt.P[0], filt.P[2])
    lik = _likelihood(filt.sums, shared_burn_in=sigma2_burn_in == burn_in)
    return BlockOutput(col(xs), col(Ps), col(filt.x), col(Pf), filt.innov, filt.innov_var, lik, definite)


def dense_system(sys: BlockSystem):
    """(F, Q) as (n, n) matrices."""
    if sys.n == 1:
        return jnp.reshape(sys.f11, (1, 1)), jnp.reshape(sys.q11, (1, 1))
    z = jnp.zeros_like(sys.f11)
    F = jnp.stack([jnp.stack([sys.f11, sys.f12]), jnp.stack([z, sys.f22])])
    Q = jnp.stack([jnp.stack([sys.q11, sys.q12]), jnp.stack([sys.q12, sys.q22])])
    return F, Q


def _parallel_run(y, h, sys, x0, P0, advance, smooth, complete=False):
    F, Q = dense_system(sys)
    n = sys.n
    H = h[:, None] * jnp.eye(n, dtype=h.dtype)[0]
    P0 = P0 * jnp.eye(n, dtype=h.dtype)
    return parallel_filter_smoother(y, H, F, Q, x0, P0, advance=advance, smooth=smooth, complete=complete)


def _parallel_definite(o, h, n):
    """The sequential kernels' `definite` flag (`DEFINITE_RTOL`) from the parallel moments."""
    if n == 1:
        return jnp.ones((), bool)
    hk = jnp.where(o.observed, h, 0.0)
    Pp = o.P_pred
    k2 = Pp[:, 0, 1] * hk
    filt_ok = jnp.all(Pp[:, 1, 1] - k2 * k2 / o.innov_var > DEFINITE_RTOL * Pp[:, 1, 1])
    A = jnp.concatenate([Pp[1:], o.P_last_pred[None]])
    a1122 = A[:, 0, 0] * A[:, 1, 1]
    smooth_ok = jnp.all(a1122 - A[:, 0, 1] * A[:, 0, 1] > DEFINITE_RTOL * a1122)
    return filt_ok & smooth_ok


def _parallel_block(y, h, sys, x0, P0, *, burn_in, sigma2_burn_in, advance, complete):
    o = _parallel_run(y, h, sys, x0, P0, advance, smooth=True, complete=complete)
    diag = lambda P: jnp.diagonal(P, axis1=1, axis2=2)
    Pf = diag(o.P_filt)
    if sys.n == 2:  # as the sequential filter, which clips P22 at 0
        Pf = Pf.at[:, 1].max(0.0)
    lik = concentrated_loglik(o.innov, o.innov_var, o.observed, burn_in=burn_in, sigma2_burn_in=sigma2_burn_in)
    definite = _parallel_definite(o, h, sys.n)
    return BlockOutput(o.x_smooth, diag(o.P_smooth), o.x_filt, Pf, o.innov, o.innov_var, lik, definite)


def _likelihood(s: Sums, *, shared_burn_in: bool):
    sigma2 = s.se2 / s.n if shared_burn_in else s.se2_s / s.n_s
    return likelihood_from_sums(slogf(s), s.se2, s.n, sigma2)


def block_likelihood(y, h, sys: BlockSystem, x0, P0, *, burn_in: int, advance=None, method: str = "sequential"):
    """`jaxsdp.Likelihood` of one block from the storage-free filter (sigma^2 over k >= burn_in).

    `method` "parallel": from the associative-scan filter (no smoother).
    """
    if method == "parallel":
        o = _parallel_run(y, h, sys, x0, P0, advance, smooth=False)
        return concentrated_loglik(o.innov, o.innov_var, o.observed, burn_in=burn_in, sigma2_burn_in=burn_in)
    step = _filter_step(sys, burn_in, burn_in)
    body = lambda c, inp: (step(c, inp)[0], None)
    (_, _, s), _ = lax.scan(body, _init(sys, x0, P0), (y, h, advance))
    return _likelihood(s, shared_burn_in=True)


def is_small(models) -> bool:
    """Whether the closed-form kernels apply: one regressor, block dimension <= 2."""
    return len(models) == 1 and models[0].dim <= 2
