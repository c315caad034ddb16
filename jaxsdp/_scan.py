"""Parallel prefix scans with a compile-once loop over levels (Hillis-Steele / Kogge-Stone).

`jax.lax.associative_scan` traces the combining function about 2 log2(N)
times (once per level of its up- and down-sweep): inside `ml_nvr`'s or
`sdp`'s BFGS loops, under `jvp` and nested `jacfwd`, that made XLA-CPU
compile an `sdp` for 200 s (N = 25,000). Here the levels are a
`lax.fori_loop` over ceil(log2 N) steps, each combining every element with
the one 2^d places before it:

    x_i <- x_{i - 2^d} (+) x_i     for i >= 2^d        (d = 0, 1, ...),

so the combining function is traced once. Depth log2 N as before; work
N log2 N combinations instead of ~2N, which a GPU absorbs (each level is
one elementwise pass over the time axis).
"""

import math

import jax
import jax.numpy as jnp
from jax import lax


def _levels(N: int) -> int:
    return max(0, math.ceil(math.log2(N))) if N > 1 else 0


def _shift(a, s, reverse):
    # forward: b_i = a_{i-s} (wrapped values are masked out); reverse: b_i = a_{i+s}
    return jnp.roll(a, -s if reverse else s, axis=0)


def prefix_scan(fn, elems, *, reverse: bool = False):
    """Inclusive scan of a pytree `elems` (leading axis = time) with an associative `fn`.

    `fn(a, b)` combines `a`, the earlier part in time, with `b`, the later one.
    Forward: out_k = e_0 (+) e_1 (+) ... (+) e_k. `reverse`: out_k = e_k (+) ... (+) e_{N-1}.
    """
    N = jax.tree.leaves(elems)[0].shape[0]
    idx = jnp.arange(N)

    def level(d, x):
        s = jnp.left_shift(1, d)
        y = jax.tree.map(lambda a: _shift(a, s, reverse), x)
        comb = fn(x, y) if reverse else fn(y, x)
        keep = idx < N - s if reverse else idx >= s
        return jax.tree.map(lambda c, a: jnp.where(keep.reshape((N,) + (1,) * (a.ndim - 1)), c, a), comb, x)

    return lax.fori_loop(0, _levels(N), level, elems)


def linear_recurrence(A, c):
    """z_k = A z_{k-1} + c_k for k = 0..N-1 with z_{-1} = 0; `A` (m, m) constant, `c` (N, m).

    Prefix scan of the affine maps with the powers A^(2^d) carried along
    (z_k = sum_{j <= k} A^(k-j) c_j): O(N m^2 log N) elementwise work, no
    matrix stored per sample.
    """
    N = c.shape[0]
    idx = jnp.arange(N)

    def level(d, carry):
        z, P = carry
        s = jnp.left_shift(1, d)
        moved = jnp.roll(z, s, axis=0) @ P.T
        z = z + jnp.where((idx >= s)[:, None], moved, 0.0)
        return z, P @ P

    z, _ = lax.fori_loop(0, _levels(N), level, (c, A))
    return z
