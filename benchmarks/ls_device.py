"""Benchmark: where `idim_ls` spends its time on one device, for a tall problem like the robot benchmark's.

    python benchmarks/ls_device.py 270000 6000000   # rows (58 columns each)

Times, after compilation (median of 3): the input checks (`check_linear`), the compiled least-squares core
(`ls_estimate`: one R-only QR of [X y], the covariance), the public `idim_ls` on device arrays and on NumPy arrays,
and one device-to-host copy of X (what a check made in NumPy would cost). On a GPU the checks of a device array
run on the device and send one boolean back (`jaxsdp._checks`, 2026-11-28); before, they copied X to the host.
On an H200, 6 million rows: checks 0.76 s before, 0.004 s after; the public `idim_ls` 0.69 s before, 0.052 s after
(the compiled core 0.047 s); `results/gpu/ls_device-before.txt` and `results/gpu/ls_device.txt`.
"""

import sys

import jax
import jax.numpy as jnp
import numpy as np
from _record import timed

import jaxsdp  # noqa: F401  (before JAX's backend starts)
from jaxsdp._idim.ls import check_linear, idim_ls, ls_estimate

jax.config.update("jax_enable_x64", True)


def report(name, f):
    steady, first = timed(f, 3)
    print(f"  {name:28s} {steady:8.4f} s (first {first:.2f} s)", flush=True)


def main(argv):
    print(jax.devices(), jax.__version__, flush=True)
    p = 58
    for n in [int(v) for v in argv] or [270_000]:
        X = jax.random.normal(jax.random.key(0), (n, p), dtype=jnp.float64)
        y = X @ jnp.linspace(1, 2, p) + 0.1 * jax.random.normal(jax.random.key(1), (n,), dtype=jnp.float64)
        print(f"n {n} x {p}", flush=True)
        report("check_linear", lambda: check_linear(y, X, None)[0])
        report("ls_estimate (jitted core)", lambda: ls_estimate(y, X, jnp.asarray(jnp.nan))["theta"])
        report("idim_ls (public)", lambda: idim_ls(y, X).theta)
        Xh, yh = np.asarray(X), np.asarray(y)
        report("idim_ls on numpy inputs", lambda: idim_ls(yh, Xh).theta)
        report("device->host of X", lambda: np.asarray(X + 0.0))


if __name__ == "__main__":
    main(sys.argv[1:])
