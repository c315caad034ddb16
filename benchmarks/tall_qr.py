"""Benchmark: R of a tall matrix [X y] (N x 59, float64) by Householder QR against CholeskyQR2, on one device.

    python benchmarks/tall_qr.py 270000 1000000 6000000

Householder: `jnp.linalg.qr(a, mode="r")` (LAPACK on the CPU, cuSOLVER on a GPU; jaxsdp's least squares today).
CholeskyQR2: $R_1 = \\mathrm{chol}(A^T A)$, $A_1 = A R_1^{-1}$ (by one matrix product with the small inverse),
$R_2 = \\mathrm{chol}(A_1^T A_1)$, $R = R_2 R_1$: matrix products only, as accurate as Householder while the
condition number of A stays well below $u^{-1/2} \\approx 10^8$ (a fallback to Householder would be needed
beyond). Also one Gram matrix and its Cholesky factor alone (the normal equations: the condition number squared).
Prints the times (median of 5 after compilation) and how far the two R and the two least-squares solutions differ.
Measured 2026-11-28 (`results/gpu/tall_qr.txt`, H200): 6 million rows 43 ms against 8.4 ms; the 2-core CPU, 270,000
rows: 0.34 s against 0.20 s. Not used by the library yet (every least squares would change at rounding level).
"""

import sys

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
from _record import timed

jax.config.update("jax_enable_x64", True)


@jax.jit
def householder(a):
    return jnp.linalg.qr(a, mode="r")


@jax.jit
def cholqr2(a):
    r1 = jnp.linalg.cholesky(a.T @ a).T
    a1 = a @ jsl.solve_triangular(r1, jnp.eye(r1.shape[0], dtype=a.dtype), lower=False)
    r2 = jnp.linalg.cholesky(a1.T @ a1).T
    return r2 @ r1


@jax.jit
def gram(a):
    return jnp.linalg.cholesky(a.T @ a).T


def main(argv):
    print(jax.devices(), jax.__version__, flush=True)
    p = 59
    for n in [int(v) for v in argv] or [270_000]:
        a = jax.random.normal(jax.random.key(0), (n, p), dtype=jnp.float64) * jnp.logspace(0, 2, p)
        th, tc, tg = (timed(f, 5)[0] for f in (lambda: householder(a), lambda: cholqr2(a), lambda: gram(a)))
        r0, r1 = np.asarray(householder(a)), np.asarray(cholqr2(a))
        r0, r1 = r0 * np.sign(np.diag(r0))[:, None], r1 * np.sign(np.diag(r1))[:, None]
        x0 = np.linalg.solve(r0[:-1, :-1], r0[:-1, -1])
        x1 = np.linalg.solve(r1[:-1, :-1], r1[:-1, -1])
        print(
            f"n {n:>9d} p {p}: householder {th:.4f} s, cholqr2 {tc:.4f} s, gram+chol {tg:.4f} s, "
            f"ratio {tc / th:.3f}; R rel diff {np.abs(r0 - r1).max() / np.abs(r0).max():.1e}, "
            f"solution rel diff {np.abs(x0 - x1).max() / np.abs(x0).max():.1e}",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1:])
