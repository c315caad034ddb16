r"""Factorisations that stay safe under `jax.vmap` on the CPU: LAPACK unbatched, plain `lax` batched.

jaxlib 0.10's CPU LAPACK kernels split a *batched* call over XLA-CPU's intra-op
thread pool and block their own pool thread until the pieces are done; XLA runs
independent kernels on the same pool at the same time, so two batched
factorisations in flight (two QRs of 2,500 x 5 in a batch of 64, on a 2-thread
pool) wait for each other forever: the process hangs at 0 % CPU. It is every
batched LAPACK kernel (QR, Cholesky, triangular solve, SVD, ...), not only QR,
and no XLA flag turns it off (issue 44's analysis, gdb stacks).

Each function here is therefore two implementations behind one name:

- called on one problem (also under `jit`), the LAPACK kernel: the numbers of
  `jnp.linalg.qr` / `jax.scipy.linalg.solve_triangular`, bit for bit;
- under `jax.vmap` (a `custom_vmap` rule), the same factorisation written in
  `lax` (Householder reflections, back substitution), with no LAPACK call;
- differentiated (`custom_jvp`), the tangent of the `lax` version, so that
  `grad`, `vmap(grad)` and `grad(vmap)` need no batched LAPACK either.

`tall_lstsq` is the exception: unbatched it takes another algorithm (the
semi-normal equations with a refinement step, LAPACK's Householder QR only
as its fallback), so its unbatched and batched results agree to rounding,
not bit for bit.

Householder QR is backward stable: the `lax` version agrees with LAPACK to
rounding (relative 1e-14 on well-conditioned problems, the error growing
with the condition number as LAPACK's does). Its loop over the columns is
unrolled, so compile time grows with the column count (used up to about a
hundred columns).
"""

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
from jax.custom_batching import custom_vmap

__all__ = [
    "qr_r",
    "qr_thin",
    "solve_upper",
    "lstsq",
    "householder_r",
    "householder_qr",
    "householder_lstsq",
    "back_substitute",
    "batch_safe",
    "spd_solve",
    "cholesky_solve",
    "tall_lstsq",
    "SEMINORMAL_COND",
]


def batch_safe(lapack_fn, lax_fn):
    """`f` = `lapack_fn` on one problem; `vmap(f)` = `vmap(lax_fn)`; the derivatives of `f` are `lax_fn`'s.

    Both functions take and return arrays (the same shapes); `lax_fn` must be
    differentiable and free of LAPACK calls."""

    @custom_vmap
    def primal(*args):
        return lapack_fn(*args)

    @primal.def_vmap
    def _rule(axis_size, in_batched, *args):
        args = [a if b else jnp.broadcast_to(a, (axis_size, *jnp.shape(a))) for a, b in zip(args, in_batched)]
        out = jax.vmap(lax_fn)(*args)
        return out, jax.tree.map(lambda _: True, out)

    @jax.custom_jvp
    def f(*args):
        return primal(*args)

    @f.defjvp
    def _jvp(primals, tangents):
        return f(*primals), jax.jvp(lax_fn, primals, tangents)[1]

    return f


def _reflect(a):
    """The reflected matrix and the reflectors (v_k, beta_k) of a Householder QR of `a`."""
    n, p = a.shape
    rows = jnp.arange(n)
    reflectors = []
    for k in range(p):
        x = jnp.where(rows >= k, a[:, k], 0.0)
        alpha = -jnp.where(a[k, k] >= 0, 1.0, -1.0) * jnp.sqrt(jnp.sum(x * x))
        v = x.at[k].add(-alpha)
        vv = jnp.sum(v * v)
        beta = jnp.where(vv > 0, 2.0 / jnp.where(vv > 0, vv, 1.0), 0.0)
        a = a - beta * jnp.outer(v, v @ a)
        a = a.at[k, k].set(alpha)
        reflectors.append((v, beta))
    return a, reflectors


def householder_r(a):
    r"""The $p \times p$ triangle $R$ of a tall $A$ ($N \times p$, $N \ge p$) by Householder reflections in `lax`.

    Column $k$: $v = x - \alpha e_k$ with $x$ the column below row $k$ and
    $\alpha = -\mathrm{sign}(x_k) \|x\|$; $A \leftarrow (I - \beta v v^T) A$,
    $\beta = 2 / v^T v$. The signs of $R$'s rows are LAPACK's (diagonal
    $\alpha$, negative for a positive pivot)."""
    p = a.shape[1]
    return jnp.triu(_reflect(a)[0][:p, :p])


def householder_qr(a):
    r"""The thin $Q$ ($N \times p$) and $R$ ($p \times p$) of a tall $A$ in `lax`: $Q = H_1 \cdots H_p I_{N,p}$, the
    reflectors of `householder_r` applied to the first $p$ columns of the identity (LAPACK's signs)."""
    n, p = a.shape
    reflected, reflectors = _reflect(a)
    q = jnp.eye(n, p, dtype=a.dtype)
    for v, beta in reversed(reflectors):
        q = q - beta * jnp.outer(v, v @ q)
    return q, jnp.triu(reflected[:p, :p])


def back_substitute(r, b):
    r"""$R^{-1} B$ for an upper-triangular $R$ ($p \times p$) and $B$ ($p$ or $p \times k$), in `lax`: row $i$ from
    the last, $x_i = (b_i - \sum_{j > i} r_{ij} x_j) / r_{ii}$, one `fori_loop` over the rows (a loop unrolled
    into $p^2/2$ scalar steps compiled for 46 s and ran for 8 s on a batch of eight 58 x 58 inverses)."""
    p = r.shape[-1]
    B = b[:, None] if b.ndim == 1 else b
    cols = jnp.arange(p)

    def row(k, x):
        i = p - 1 - k
        above = jnp.where(cols > i, r[i], 0.0)  # the strictly upper part of row i
        return x.at[i].set((B[i] - above @ x) / r[i, i])

    x = jax.lax.fori_loop(0, p, row, jnp.zeros(B.shape, jnp.result_type(r, B)))
    return x[:, 0] if b.ndim == 1 else x


def householder_lstsq(a, b):
    r"""Least squares $\arg\min_x \|A x - b\|^2 + \lambda^2 \|x\|^2$ of a tall $A$ ($N \times p$) in `lax`,
    with $\lambda = \sqrt{\epsilon}\,\|A\|_F$: $R$ and $Q^T b$ from a Householder QR of
    $\begin{bmatrix} A & b \\ \lambda I & 0 \end{bmatrix}$, then back substitution. With a column that adds
    nothing (zero, or a copy of others) the tiny ridge gives a finite solution with LAPACK's fit (its split along
    the null direction may differ from LAPACK's minimum-norm one), where a plain QR would divide by a zero
    pivot; on a full-rank
    $A$ it moves the solution by about $(\lambda / \sigma_{min})^2$ relative ($10^{-12}$ at a condition number
    of $10^2$: a starting value, as the SDP's, needs no more)."""
    n, p = a.shape
    lam = jnp.sqrt(jnp.finfo(a.dtype).eps * jnp.sum(a * a))
    top = jnp.concatenate([a, b[:, None]], axis=1)
    bottom = jnp.concatenate([lam * jnp.eye(p, dtype=a.dtype), jnp.zeros((p, 1), a.dtype)], axis=1)
    r_aug = householder_r(jnp.concatenate([top, bottom], axis=0))
    return back_substitute(r_aug[:p, :p], r_aug[:p, p])


def _lapack_lstsq(a, b):
    return jnp.linalg.lstsq(a, b)[0]


def _lapack_r(a):
    return jnp.linalg.qr(a, mode="r")


def _lapack_qr(a):
    q, r = jnp.linalg.qr(a, mode="reduced")
    return q, r


def _lapack_solve(r, b):
    return jsl.solve_triangular(r, b, lower=False)


#: $R$ of a tall matrix ($N \times p$ -> $p \times p$): `jnp.linalg.qr(a, mode="r")` unbatched, Householder in
#: `lax` under `vmap`.
qr_r = batch_safe(_lapack_r, householder_r)
#: Thin $Q$ and $R$ of a tall matrix: `jnp.linalg.qr(a, mode="reduced")` unbatched, Householder in `lax` under
#: `vmap`.
qr_thin = batch_safe(_lapack_qr, householder_qr)
#: Least squares $\arg\min_x \|A x - b\|$: `jnp.linalg.lstsq(a, b)[0]` unbatched, Householder in `lax` under `vmap`.
lstsq = batch_safe(_lapack_lstsq, householder_lstsq)
#: $R^{-1} B$ for an upper-triangular $R$: `solve_triangular(r, b, lower=False)` unbatched, back substitution in
#: `lax` under `vmap`.
solve_upper = batch_safe(_lapack_solve, back_substitute)


def cholesky_solve(a, b):
    r"""$A^{-1} B$ for a small symmetric positive-definite $A$ ($p \times p$) and $B$ ($p$ or $p \times k$) in `lax`:
    the Cholesky factor $A = L L^T$ unrolled over $p$, then forward and back substitution (no explicit inverse)."""
    p = a.shape[-1]
    L = [[None] * p for _ in range(p)]
    for j in range(p):
        L[j][j] = jnp.sqrt(a[j, j] - sum(L[j][k] ** 2 for k in range(j)))
        for i in range(j + 1, p):
            L[i][j] = (a[i, j] - sum(L[i][k] * L[j][k] for k in range(j))) / L[j][j]
    y = [None] * p
    for i in range(p):
        y[i] = (b[i] - sum(L[i][k] * y[k] for k in range(i))) / L[i][i]
    x = [None] * p
    for i in reversed(range(p)):
        x[i] = (y[i] - sum(L[k][i] * x[k] for k in range(i + 1, p))) / L[i][i]
    return jnp.stack(x)


def _lapack_spd_solve(a, b):
    return jsl.cho_solve(jsl.cho_factor(a), b)


#: $A^{-1} B$ for a symmetric positive-definite $A$: `cho_solve(cho_factor(a), b)` unbatched, the unrolled Cholesky
#: solve in `lax` under `vmap` (for small $A$: a robot's mass matrix, a state covariance).
spd_solve = batch_safe(_lapack_spd_solve, cholesky_solve)


#: The largest condition number of the column-scaled $A$ at which `tall_lstsq` takes the corrected semi-normal
#: equations; above it (or when the Cholesky factorisation fails) a Householder QR.
SEMINORMAL_COND = 1e4


def _positive_rows(r, c):
    """R and Q^T b with the signs that make R's diagonal positive (R is unique so, whichever factorisation)."""
    s = jnp.where(jnp.diag(r) < 0, -1.0, 1.0).astype(r.dtype)
    return r * s[:, None], c * s


def _augmented_lstsq_r(a, b, r_of, solve):
    """(x, R) from the R-only QR `r_of` of [A | b] (R_aug = [[R, Q^T b], [0, ||e||]]) and the triangular `solve`."""
    p = a.shape[1]
    r_aug = r_of(jnp.concatenate([a, b[:, None]], axis=1))
    r, c = _positive_rows(r_aug[:p, :p], r_aug[:p, p])
    return solve(r, c), r


def _householder_lstsq_r(a, b):
    return _augmented_lstsq_r(a, b, householder_r, back_substitute)


def _lapack_lstsq_r(a, b):
    return _augmented_lstsq_r(a, b, _lapack_r, _lapack_solve)


def _seminormal_lstsq_r(a, b):
    r"""Least squares by the semi-normal equations with one refinement step: $R = R_s D$, $R_s$ the Cholesky
    factor of $D^{-1} A^T A D^{-1}$ ($D$ the column norms, so $R^T R = A^T A$), $x_0 = R^{-1} R^{-T} A^T b$ and
    $x_1 = x_0 + R^{-1} R^{-T} A^T (b - A x_0)$: four passes over $A$ ($A^T A$, $b^T A$, $A x_0$, $r^T A$). Björck's
    (1987) corrected semi-normal equations take $R$ from a QR factorisation; with $R$ from Cholesky the accuracy is
    an empirical fact, checked in `tests/test_linalg.py` against known solutions: the error stays within the
    first-order bound of a backward-stable solver, $\epsilon (\kappa + \kappa^2 \|r\| / (\|A\| \|x\|))$ on the
    column-scaled problem (measured at most 0.37 of it, $N$ = 3,000 and 300,000, $\kappa$ up to $9 \times 10^3$;
    a second step did not lower it). Falls back to `_lapack_lstsq_r` when the scaled condition number $\kappa$
    exceeds `SEMINORMAL_COND`, when the Cholesky factorisation fails, or when a column is so small that its
    squared norm is not a normal float (the Gram matrix would then be inexact)."""
    # b @ a, not a.T @ b: XLA-CPU transposes `a` for the latter, which costs more than the product
    g, atb = a.T @ a, b @ a
    d = jnp.sqrt(jnp.diag(g))
    finfo = jnp.finfo(g.dtype)
    normal = jnp.min(jnp.diag(g)) > a.shape[0] * finfo.tiny / finfo.eps
    d = jnp.where(d > 0, d, 1.0)
    rs = jnp.linalg.cholesky(g / d[:, None] / d[None, :]).T  # R of A D^-1, upper, positive diagonal
    sv = jnp.linalg.svd(jnp.where(jnp.isfinite(rs), rs, 0.0), compute_uv=False)
    usable = normal & jnp.all(jnp.isfinite(rs)) & (sv[-1] * SEMINORMAL_COND > sv[0])

    def seminormal(a, b):
        r = rs * d[None, :]

        def solve(v):  # (A^T A)^-1 v = R^-1 R^-T v
            return _lapack_solve(r, jsl.solve_triangular(r, v, trans=1, lower=False))

        x = solve(atb)
        return x + solve((b - a @ x) @ a), r

    return jax.lax.cond(usable, seminormal, _lapack_lstsq_r, a, b)


#: Least squares of a tall $A$ ($N \times p$) and $b$ ($N$): $(x, R)$ with $x = \arg\min \|A x - b\|$ and $R$ the
#: triangle of $A = Q R$ with a positive diagonal ($R^T R = A^T A$). Unbatched, the semi-normal equations with one
#: refinement step (`_seminormal_lstsq_r`) when the column-scaled $A$ is well conditioned (LAPACK's Householder
#: QR of a tall matrix is bound by its level-2 panel; `benchmarks/robot_stacked.py` measures both), else a
#: LAPACK Householder QR of $[A\,|\,b]$; Householder in `lax` under `vmap` and for derivatives.
tall_lstsq = batch_safe(_seminormal_lstsq_r, _householder_lstsq_r)
