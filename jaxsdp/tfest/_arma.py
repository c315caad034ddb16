"""The discrete ARMA noise model of the refined IV family: prefiltering by D/C, its Gauss-Newton step, a start.

Noise model (Box-Jenkins): xi_k = C(z^-1)/D(z^-1) e_k with e_k white,
C = 1 + c1 z^-1 + ... + c_nc z^-nc (moving average) and
D = 1 + d1 z^-1 + ... + d_nd z^-nd (autoregressive); eta = [c1..c_nc, d1..d_nd].
The prediction error of the noise is eps = (D/C) xi, so that

    d eps_k / d d_j = (1/C) xi_(k-j),      d eps_k / d c_j = -(1/C) eps_(k-j),

and a Gauss-Newton step on sum_k eps_k^2 is
eta <- eta - (Psi^T Psi)^-1 Psi^T eps with Psi the rows of these
derivatives. Interleaved with the system's IV steps, its fixed point is the
stationary point of the (conditional, zero initial conditions) Box-Jenkins
prediction-error criterion in eta: Young's RIVBJ/RIVCBJ estimate the noise
by IVARMA, which has the same fixed point; the Gauss-Newton step is the
quicker of the two to write as one scan.

The start is Hannan and Rissanen's: a long autoregression of xi gives
innovations ehat, then xi_k = -sum d_j xi_(k-j) + sum c_j ehat_(k-j) + e_k
is solved by least squares. C is kept minimum phase (its roots are
reflected into the unit circle, |z| <= MA_MAX_RADIUS), so that the
prefilter 1/C is stable.
"""

import jax.numpy as jnp
from jax import lax

#: Order of the long autoregression of the Hannan-Rissanen start (at most N / 10).
LONG_AR_ORDER = 30
#: Levenberg damping of the noise model's Gauss-Newton step (relative to the diagonal of Psi^T Psi).
ARMA_DAMPING = 0.05
#: Roots of C(z) are kept within this radius (1/C is the prefilter; a root on the circle would not decay).
MA_MAX_RADIUS = 0.999


def shift(x, j):
    """x delayed by j samples along axis 0, zeros in front (x_(k-j))."""
    if j == 0:
        return x
    pad = jnp.zeros((j,) + x.shape[1:], x.dtype)
    return jnp.concatenate([pad, x[: x.shape[0] - j]], axis=0)


def lags(x, first, last):
    """(N, last - first + 1) columns x_(k-first), ..., x_(k-last) of a 1-D signal."""
    return jnp.stack([shift(x, j) for j in range(first, last + 1)], axis=1)


def poly_from_roots(roots):
    """Real coefficients [1, p1, ..., pn] of prod_i (z - root_i) (conjugate pairs give real values)."""
    n = roots.shape[0]
    p0 = jnp.zeros((n + 1,), roots.dtype).at[0].set(1.0)
    p = lax.fori_loop(0, n, lambda k, p: p - roots[k] * jnp.roll(p, 1).at[0].set(0.0), p0)
    return jnp.real(p[1:])


def dt_roots(a):
    """Roots of z^n + a1 z^(n-1) + ... + an, i.e. of 1 + a1 z^-1 + ... + an z^-n."""
    n = a.shape[0]
    comp = jnp.zeros((n, n), dtype=a.dtype).at[1:, :-1].set(jnp.eye(n - 1, dtype=a.dtype)).at[0, :].set(-a)
    return jnp.linalg.eigvals(comp)


def reflect_inside(a, radius):
    """(`a` with the roots of 1 + a1 z^-1 + ... outside |z| = radius moved inside, the largest root modulus).

    A root z outside the unit circle is replaced by 1/conj(z) (same spectrum
    shape), then any modulus above `radius` is cut to `radius`.
    """
    if a.shape[0] == 0:
        return a, jnp.array(0.0)
    roots = dt_roots(a)
    mod = jnp.abs(roots)
    inside = jnp.where(mod > 1.0, 1.0 / jnp.conj(roots), roots)
    m2 = jnp.abs(inside)
    inside = jnp.where(m2 > radius, inside * (radius / jnp.maximum(m2, 1e-300)), inside)
    return jnp.where(jnp.max(mod) > radius, poly_from_roots(inside), a), jnp.max(mod)


def noise_filter(f, xi, row_xi, c, d):
    """Filter the feature columns by D/C and run the noise model's derivative chain, in one scan.

    `f`: (N, F) features, `row_xi` (F,) the row giving the model residual
    xi_k = row_xi . f_k, and `xi` (N,) that residual (the caller has it).
    Returns g = (D/C) f (N, F), the prediction errors eps = row_xi . g (N,),
    a = (1/C) xi and b = (1/C) eps (N,), the sources of the Gauss-Newton rows
    (`arma_step`). With nc = 0 there is no scan.
    """
    nc = c.shape[0]
    dpoly = jnp.concatenate([jnp.ones((1,)), d])
    h = f
    for j in range(1, d.shape[0] + 1):
        h = h + dpoly[j] * shift(f, j)
    if nc == 0:
        eps = h @ row_xi
        return h, eps, xi, eps
    F = f.shape[1]
    x = jnp.concatenate([h, xi[:, None]], axis=1)

    def step(state, xk):
        gs, bs = state  # (nc, F + 1) past outputs g and a (newest first); (nc,) past b
        gk = xk - c @ gs
        ek = gk[:F] @ row_xi
        bk = ek - c @ bs
        return (jnp.concatenate([gk[None], gs[:-1]]), jnp.concatenate([bk[None], bs[:-1]])), (gk, ek, bk)

    init = (jnp.zeros((nc, F + 1)), jnp.zeros((nc,)))
    _, (g, eps, b) = lax.scan(step, init, x, unroll=4)
    return g[:, :F], eps, g[:, F], b


def arma_rows(a, b, nc, nd):
    """Psi (N, nc + nd): d eps / d eta = [-(1/C) eps lags 1..nc, (1/C) xi lags 1..nd]."""
    cols = [-shift(b, j) for j in range(1, nc + 1)] + [shift(a, j) for j in range(1, nd + 1)]
    return jnp.stack(cols, axis=1)


def normalised_solve(lhs, rhs):
    """Solve lhs x = rhs with the columns and rows of the (nearly symmetric) lhs scaled to unit diagonal."""
    s = 1.0 / jnp.sqrt(jnp.maximum(jnp.abs(jnp.diagonal(lhs)), jnp.finfo(jnp.float64).tiny))
    return s * jnp.linalg.solve(lhs * s[:, None] * s[None, :], rhs * s)


def arma_step(eta, eps, a, b, nc, nd):
    """One damped Gauss-Newton step of eta = [c, d] on sum eps^2; returns (new eta, Psi^T Psi).

    The step solves (Psi^T Psi + mu diag(Psi^T Psi)) delta = -Psi^T eps with
    mu = ARMA_DAMPING: a well-determined noise model converges as before (the
    damping slows each step by about mu), while along a near-flat ridge (a
    zero and a pole that nearly cancel: white noise fitted by ARMA(1,1)) the
    step is held back instead of swinging along the ridge, which would keep
    moving the prefilter D/C and the system estimate with it. C is reflected
    to be minimum phase after the step."""
    psi = arma_rows(a, b, nc, nd)
    info = psi.T @ psi
    damped = info + ARMA_DAMPING * jnp.diag(jnp.diag(info))
    new = eta - normalised_solve(damped, psi.T @ eps)
    cnew, _ = reflect_inside(new[:nc], MA_MAX_RADIUS)
    return jnp.concatenate([cnew, new[nc:]]), info


def hannan_rissanen(xi, nc, nd):
    """Start values eta = [c, d] of ARMA(nd, nc) for the series xi (Hannan-Rissanen, two least squares)."""
    N = xi.shape[0]
    if nc == 0:
        x = -lags(xi, 1, nd)
        return normalised_solve(x.T @ x, x.T @ xi)
    p = max(min(LONG_AR_ORDER, N // 10), nc + nd)
    x = -lags(xi, 1, p)
    alpha = normalised_solve(x.T @ x, x.T @ xi)
    ehat = xi - x @ alpha
    z = jnp.concatenate([lags(ehat, 1, nc), -lags(xi, 1, nd)], axis=1) if nd else lags(ehat, 1, nc)
    z, target = z[p:], xi[p:]
    eta = normalised_solve(z.T @ z, z.T @ target)
    cnew, _ = reflect_inside(eta[:nc], MA_MAX_RADIUS)
    return jnp.concatenate([cnew, eta[nc:]])
