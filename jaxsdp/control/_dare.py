"""The discrete algebraic Riccati equation (DARE): structure-preserving doubling, implicit derivatives, pure JAX.

The equation, for A (N, N), B (N, M), Q (N, N) symmetric and R (M, M)
symmetric positive definite:

    P = A' P A - A' P B (R + B' P B)^-1 B' P A + Q.

With G = B R^-1 B' it reads P = A' P (I + G P)^-1 A + Q, which the
structure-preserving doubling algorithm (SDA; Chu, Fan & Lin 2005) solves by

    W_k     = I + G_k H_k
    A_{k+1} = A_k W_k^-1 A_k
    G_{k+1} = G_k + A_k W_k^-1 G_k A_k'
    H_{k+1} = H_k + A_k' H_k W_k^-1 A_k

from A_0 = A, G_0 = G, H_0 = Q; H_k tends to the stabilising solution P
quadratically (the error falls like rho^(2^k), rho the spectral radius of
the closed loop A - B K). Nothing inverts A, so a singular A (the NMSS
transition matrix of a PIP design often is) is fine; every step is one
linear solve with W_k (never an explicit inverse), and G_k, H_k are
symmetrised after each step.

The doublings stop when H changes by less than 1e-13 of its largest entry
(then its error is of the order of that change squared) or after
`max_doublings` (default 60: enough for any rho below 1 - 1e-15; a typical
PIP design converges in 5 to 8). The loop is a `lax.while_loop`, so it is
not differentiated through; the derivatives come from the equation itself
(implicit differentiation, a `jax.custom_jvp`): with
K = (R + B'PB)^-1 B'PA and Acl = A - B K, the tangent dP solves the Stein
equation

    dP = Acl' dP Acl + E,
    E  = dQ + K' dR K + dAcl' P Acl + Acl' P dAcl,   dAcl = dA - dB K,

solved directly as one N^2 x N^2 linear system (I - Acl' kron Acl') vec(dP)
= vec(E) (small N: the NMSS models here have N <= 20 or so). Reverse mode
(`jax.grad`) is JAX's transpose of this linear map, so `jvp`, `grad`,
`jit` and `vmap` all work, and the derivatives are those of the exact
solution (checked against finite differences and scipy in
`tests/test_pip.py`). The solution exists when (A, B) is stabilisable and
(A, Q) detectable; otherwise the iterates grow without bound and the result
holds inf or NaN.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import as_float_array, is_concrete
from .._runtime import x64

DOUBLINGS = 60
TOL = 1e-13  # stop doubling when max|H_{k+1} - H_k| <= TOL max|H_{k+1}|


def _sym(x):
    return 0.5 * (x + x.T)


def check_dare(a, b, q, r):
    """Shapes of a DARE's matrices as float64 arrays: `b` 1-D means one input, `r` a scalar means (1, 1)."""
    a = as_float_array("a", a, ndim=2)
    b = as_float_array("b", b)
    q = as_float_array("q", q, ndim=2)
    r = as_float_array("r", r)
    n = a.shape[0]
    if a.shape != (n, n) or n < 1:
        raise ValueError(f"`a` must be a non-empty square matrix; got shape {tuple(a.shape)}")
    if b.ndim == 1:
        b = b[:, None]
    if b.ndim != 2 or b.shape[0] != n or b.shape[1] < 1:
        raise ValueError(f"`b` must have shape ({n}, M) (or ({n},) for one input); got {tuple(b.shape)}")
    if q.shape != (n, n):
        raise ValueError(f"`q` must have the shape of `a`, ({n}, {n}); got {tuple(q.shape)}")
    m = b.shape[1]
    if r.ndim == 0:
        r = r.reshape(1, 1)
    if r.shape != (m, m):
        raise ValueError(f"`r` must have shape ({m}, {m}) (a scalar for one input); got {tuple(r.shape)}")
    for name, x in (("a", a), ("b", b), ("q", q), ("r", r)):
        if is_concrete(x) and not np.all(np.isfinite(np.asarray(x))):
            raise ValueError(f"`{name}` contains NaN or inf")
    return a, b, q, r


def sda(a, b, q, r, max_doublings: int = DOUBLINGS):
    """The SDA iteration (traceable, no checks, not differentiable): (P, number of doublings done)."""
    n = a.shape[-1]
    eye = jnp.eye(n, dtype=a.dtype)
    if r.shape[-1] == 1:  # one input: G = b b' / r, no solve to compile
        g = _sym(b @ b.T / r[0, 0])
    else:
        g = _sym(b @ jnp.linalg.solve(r, b.T))

    def going(carry):
        k, _, _, hk, change = carry
        return (k < max_doublings) & (change > TOL * jnp.max(jnp.abs(hk)))

    def doubling(carry):
        k, ak, gk, hk, _ = carry
        sol = jnp.linalg.solve(eye + gk @ hk, jnp.concatenate([ak, gk], axis=-1))
        wa, wg = sol[..., :n], sol[..., n:]
        h_next = _sym(hk + ak.T @ hk @ wa)
        return k + 1, ak @ wa, _sym(gk + ak @ wg @ ak.T), h_next, jnp.max(jnp.abs(h_next - hk))

    k, _, _, p, _ = jax.lax.while_loop(going, doubling, (0, a, g, _sym(q), jnp.asarray(jnp.inf, a.dtype)))
    return p, k


@functools.partial(jax.custom_jvp, nondiff_argnums=(4,))
def dare(a, b, q, r, max_doublings: int = DOUBLINGS):
    """The stabilising DARE solution (traceable, no checks), differentiable by the implicit function theorem."""
    return sda(a, b, q, r, max_doublings)[0]


@dare.defjvp
def _dare_jvp(max_doublings, primals, tangents):
    a, b, q, r = primals
    da, db, dq, dr = tangents
    p = dare(a, b, q, r, max_doublings)
    n = a.shape[-1]
    k = jnp.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)
    acl = a - b @ k
    dacl = da - db @ k
    pacl = p @ acl
    e = _sym(dq + k.T @ dr @ k + dacl.T @ pacl + pacl.T @ dacl)
    stein = jnp.eye(n * n, dtype=a.dtype) - jnp.kron(acl.T, acl.T)  # row-major vec(Acl' X Acl) = kron vec(X)
    dp = jnp.linalg.solve(stein, e.reshape(-1)).reshape(n, n)
    return p, _sym(dp)


_dare_jit = jax.jit(dare, static_argnums=4)


def residual(a, b, q, r, p):
    """A' P A - A' P B (R + B' P B)^-1 B' P A + Q - P (traceable, no checks)."""
    pa = p @ a
    bpa = b.T @ pa
    return a.T @ pa - bpa.T @ jnp.linalg.solve(r + b.T @ p @ b, bpa) + q - p


@x64
def solve_dare(a, b, q, r, *, max_doublings: int = DOUBLINGS):
    r"""Stabilising solution $P$ of the discrete algebraic Riccati equation, by structure-preserving doubling.

    Solves

    $$ P = A' P A - A' P B (R + B' P B)^{-1} B' P A + Q $$

    for `a` (N, N), `b` (N, M) (or (N,) for one input), `q` (N, N) symmetric
    positive semi-definite and `r` (M, M) symmetric positive definite (or a
    scalar for one input); returns $P$ (N, N), symmetric. The optimal LQ gain
    of $u_k = -K x_k$ is then $K = (R + B' P B)^{-1} B' P A$.

    Pure JAX: doublings (one linear solve each, no inverse of A: a singular
    A is fine) until P changes by less than 1e-13 relative, at most
    `max_doublings` (static, default 60; the error falls like $\rho^{2^k}$, $\rho$
    the closed-loop spectral radius). Works under `jax.jit`, `jax.vmap` and
    `jax.grad`/`jax.jvp`: the derivatives are those of the exact solution
    (implicit differentiation: a Stein equation, solved as an $N^2 \times N^2$
    linear system, so meant for small $N$). Shapes are checked at trace
    time; NaN or inf in concrete inputs is a ValueError. Without a
    stabilising solution ((A, B) not stabilisable or (A, Q) not detectable)
    the result holds inf or NaN. `dare_residual` measures how well P solves
    the equation.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.control._dare import solve_dare, dare_residual
        >>> a = np.array([[1.0, 0.1], [0.0, 1.0]]); b = np.array([0.005, 0.1])
        >>> p = solve_dare(a, b, np.eye(2), 1.0)
        >>> print(np.round(np.asarray(p), 3))
        [[17.835 10.012]
         [10.012 17.857]]
        >>> bool(dare_residual(a, b, np.eye(2), 1.0, p) < 1e-12)
        True
    """
    if int(max_doublings) != max_doublings or max_doublings < 1:
        raise ValueError(f"`max_doublings` must be a positive integer; got {max_doublings!r}")
    a, b, q, r = check_dare(a, b, q, r)
    return _dare_jit(a, b, q, r, int(max_doublings))


@x64
def dare_residual(a, b, q, r, p):
    """Relative residual of a DARE solution: max |A'PA - A'PB(R + B'PB)^-1 B'PA + Q - P| / max(1, max |P|).

    Same shapes as `solve_dare`, plus `p` (N, N); returns a scalar (0 for an
    exact solution, about 1e-16 for `solve_dare`'s on a well-conditioned problem).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.control._dare import solve_dare, dare_residual
        >>> p = solve_dare(np.array([[0.5]]), np.array([1.0]), np.array([[1.0]]), 1.0)
        >>> float(np.round(p[0, 0], 6)), bool(dare_residual([[0.5]], [1.0], [[1.0]], 1.0, p) < 1e-14)
        (1.132782, True)
    """
    a, b, q, r = check_dare(a, b, q, r)
    p = as_float_array("p", p, ndim=2)
    if p.shape != a.shape:
        raise ValueError(f"`p` must have the shape of `a`, {tuple(a.shape)}; got {tuple(p.shape)}")
    return jnp.max(jnp.abs(residual(a, b, q, r, p))) / jnp.maximum(1.0, jnp.max(jnp.abs(p)))
