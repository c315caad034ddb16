"""Continuous-time helpers shared by the refined instrumental variable estimators (SRIVC, RIVCBJ).

- `time_scale` and `scale_powers`: the iterations work in scaled time
  tau = c t, c = max_i |a_i|^(1/i) (a bound on the root magnitudes of A(s)),
  so that the coefficients are at most 1 and filtered derivatives have
  comparable sizes; a_i = atilde_i c^i, b_j = btilde_j c^(n - m + j).
- `stabilise`: reflect right-half-plane roots of A(s) into the left
  half-plane (the prefilters 1/A(s) must be stable).
- `expm_taylor`: the matrix exponential of the small augmented matrices that
  discretise the filters exactly for a zero-order-hold input.
"""

import jax.numpy as jnp
from jax import lax

#: Degree of the Taylor polynomial and most squarings of the matrix exponential (`expm_taylor`).
TAYLOR_DEGREE, MAX_SQUARINGS = 18, 40


def scale_powers(c, n, m):
    """Scalings of theta: a_i = atilde_i c^i, b_j = btilde_j c^(n + j - m) (time scaled by c)."""
    pa = c ** jnp.arange(1, n + 1, dtype=jnp.float64)
    pb = c ** (n - m + jnp.arange(m + 1, dtype=jnp.float64))
    return jnp.concatenate([pa, pb])


def time_scale(a, dt, N):
    """c = max_i |a_i|^(1/i), a bound on the root magnitudes, kept within [1/(N dt), 10/dt]."""
    i = jnp.arange(1, a.shape[0] + 1, dtype=jnp.float64)
    nz = a != 0
    c = jnp.exp(jnp.max(jnp.where(nz, jnp.log(jnp.abs(jnp.where(nz, a, 1.0))) / i, -jnp.inf)))
    c = jnp.where(jnp.isfinite(c) & (c > 0), c, 1.0 / dt)
    return jnp.clip(c, 1.0 / (N * dt), 10.0 / dt)


def ct_roots(a):
    """Roots of s^n + a1 s^(n-1) + ... + an (eigenvalues of the companion matrix)."""
    n = a.shape[0]
    comp = jnp.zeros((n, n), dtype=a.dtype).at[1:, :-1].set(jnp.eye(n - 1, dtype=a.dtype)).at[0, :].set(-a)
    return jnp.linalg.eigvals(comp)


def stabilise(a):
    """(`a` with the right-half-plane roots of s^n + a1 s^(n-1) + ... reflected into the left half-plane,
    the largest real part of the roots)."""
    roots = ct_roots(a)
    reflected = jnp.where(roots.real > 0, -roots.real + 1j * roots.imag, roots)
    poly0 = jnp.zeros((a.shape[0] + 1,), reflected.dtype).at[0].set(1.0)
    # prod (s - root): multiply by one factor at a time, c_j <- c_j - root c_(j-1)
    poly = lax.fori_loop(0, a.shape[0], lambda k, c: c - reflected[k] * jnp.roll(c, 1).at[0].set(0.0), poly0)
    maxre = jnp.max(roots.real)
    return jnp.where(maxre > 0, jnp.real(poly[1:]), a), maxre


def expm_taylor(A):
    """Matrix exponential by scaling and squaring with a degree-18 Taylor polynomial (small A, float64).

    Scaled to a 1-norm <= 1, the truncation error is below e/19! (2e-17
    relative). Two fixed-length loops instead of `jax.scipy.linalg.expm`'s
    branches over Pade orders: the same accuracy here (tests/test_srivc.py
    compares them) and a compile several times shorter (0.35 s against 2 s
    measured), which matters as compiling dominates a single `srivc` call.
    """
    nrm = jnp.max(jnp.sum(jnp.abs(A), axis=0))
    s = jnp.clip(jnp.ceil(jnp.log2(jnp.maximum(nrm, 1e-300))), 0, MAX_SQUARINGS)
    X = A * 2.0 ** (-s)
    eye = jnp.eye(A.shape[0], dtype=A.dtype)
    R = lax.fori_loop(0, TAYLOR_DEGREE, lambda i, R: eye + (X @ R) / (TAYLOR_DEGREE - i), eye)
    return lax.fori_loop(0, MAX_SQUARINGS, lambda i, R: jnp.where(i < s, R @ R, R), R)
