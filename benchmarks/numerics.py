"""Hand-written numerics against the library calls they replace or keep beating.

Prints, for the choices stated in the docstrings:

1. `jaxsdp._kalman.general._cho_solve` (unrolled Cholesky below n = 8) against
   `jax.scipy.linalg.cho_solve`, inside the general filter/smoother (`dlr`
   with 2-6 IRW blocks): a scan-free micro-benchmark favours the unrolled
   form at every n, the smoother's scan does not;
2. the ML-NVR curvature: exact Hessian by nested `jax.jacfwd` (what
   `ml_nvr` uses) against central differences of the forward-mode gradient
   (what it used before), IRW, N = 25,000, one and two NVRs: compile and run;
3. `jaxsdp.cutoff_from_nvr` by `scipy.optimize.brentq` against the 200-step
   bisection it replaced;
4. `jnp.gradient` against the hand-written central differences it replaced;
5. jaxsdp's XLA-CPU fast-loop option on and off (`jaxsdp._runtime`);
6. `ml_nvr`'s own BFGS loop against `optimistix.BFGS` on the same likelihood (`dlr_loglik`).

    python benchmarks/numerics.py [--only-fast-loops] [--json PATH]

`--only-fast-loops` runs section 5 alone; `--json PATH` also writes every row
(key `cho-solve-pP`, `curvature-N-nvr`, `cutoff`, `gradient`,
`fast-loops-dlr`, `fast-loops-ml-nvr`, `fast-loops-general`, `bfgs-builtin`,
`bfgs-optimistix`) with the machine and the date (`benchmarks/_record.py`).
"""

import argparse
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import jaxsdp  # noqa: E402  isort: skip  (first: jaxsdp's XLA-CPU option)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _record import Recorder  # noqa: E402

import jaxsdp._kalman.general as general  # noqa: E402
from jaxsdp._kalman.general import _cho_solve, unrolled_cho_solve  # noqa: E402
from jaxsdp._kalman.nvr import _value_and_grad_fwd  # noqa: E402
from jaxsdp._signal.smoothing import nvr_from_cutoff  # noqa: E402

jax.config.update("jax_enable_x64", True)

REC = Recorder("benchmarks/numerics.py", None)  # replaced in main() (with --json, a file)


def best(fn, repeats=7):
    jax.block_until_ready(fn())
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - t0)
    return min(times)


def cho_solve_section(n=25_000):
    print(f"1. Cholesky solves in the general smoother: dlr with p IRW blocks (n = 2p states), N = {n:,}")
    print(f"{'p':>3} {'n':>3} {'unrolled (ms)':>14} {'cho_solve (ms)':>15} {'ratio':>7}")
    rng = np.random.default_rng(0)

    def library(A, B):
        return jax.scipy.linalg.cho_solve((jnp.linalg.cholesky(A), True), B)

    try:
        for p in (2, 3, 4, 5, 6):
            z = rng.standard_normal((n, p))
            y = z.sum(1) + 0.1 * rng.standard_normal(n)
            times = {}
            for name, solve in (("unrolled", unrolled_cho_solve), ("library", library)):
                general._cho_solve = solve
                jax.clear_caches()  # recompile dlr with this solve
                times[name] = best(lambda: jaxsdp.dlr(y, z, model="IRW", nvr=1e-4).par, 5)
            chosen = "cho_solve" if 2 * p >= 8 else "unrolled"
            tu, tl = times["unrolled"], times["library"]
            print(f"{p:>3} {2 * p:>3} {1e3 * tu:14.1f} {1e3 * tl:15.1f} {tl / tu:7.2f}   jaxsdp uses {chosen}")
            REC.add(key=f"cho-solve-p{p}", states=2 * p, unrolled_s=tu, cho_solve_s=tl, ratio=tl / tu, uses=chosen)
    finally:
        general._cho_solve = _cho_solve
        jax.clear_caches()


def curvature_section(n=25_000):
    print(f"\n2. ML-NVR curvature at the optimum, IRW, N = {n:,}: exact nested jacfwd vs central differences")
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, n)
    for p in (1, 2):
        z = np.c_[np.ones(n), np.sin(20 * t)][:, :p]
        y = (z * np.c_[np.sin(6 * t), 1 + t][:, :p]).sum(1) + 0.1 * rng.standard_normal(n)

        def J(b):
            return jaxsdp.dlr_loglik(y, z, model="IRW", nvr=10.0**b).J

        def fd(b, h=1e-3):
            eye = jnp.eye(b.shape[0])
            pts = jnp.concatenate([b + h * eye, b - h * eye])
            g = jax.vmap(lambda bb: _value_and_grad_fwd(J, bb)[1])(pts)
            return (g[:p] - g[p:]) / (2 * h)

        exact = jax.jit(jax.jacfwd(jax.jacfwd(J)))
        fdj = jax.jit(fd)
        b = jnp.full(p, -4.0)
        t0 = time.perf_counter()
        he = jax.block_until_ready(exact(b))
        ce = time.perf_counter() - t0
        t0 = time.perf_counter()
        hf = jax.block_until_ready(fdj(b))
        cf = time.perf_counter() - t0
        te, tf = best(lambda: exact(b)), best(lambda: fdj(b))
        rel = float(jnp.max(jnp.abs(he - hf)) / jnp.max(jnp.abs(he)))
        print(
            f"  {p} NVR(s): exact {1e3 * te:7.2f} ms (compile {ce:5.2f} s), central differences "
            f"{1e3 * tf:7.2f} ms (compile {cf:5.2f} s); run ratio fd/exact {tf / te:4.2f}; |diff| {rel:.1e}"
        )
        REC.add(
            key=f"curvature-{p}-nvr",
            exact_s=te,
            exact_compile_s=ce,
            differences_s=tf,
            differences_compile_s=cf,
            ratio=tf / te,
            rel_difference=rel,
        )


def cutoff_section():
    print("\n3. cutoff_from_nvr: scipy.optimize.brentq vs 200-step bisection (dt = 1 ms)")
    dt = 1e-3

    def bisect(nvr):
        lo, hi = np.zeros(()), np.full((), 0.5 / dt * (1 - 1e-9))
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            big = np.asarray(nvr_from_cutoff(mid, dt)) > nvr
            hi, lo = np.where(big, mid, hi), np.where(big, lo, mid)
        return 0.5 * (lo + hi)

    nvr = float(nvr_from_cutoff(50.0, dt))
    tb = best(lambda: bisect(nvr), 3)
    tr = best(lambda: jaxsdp.cutoff_from_nvr(nvr, dt), 20)
    diff = abs(float(bisect(nvr)) - float(jaxsdp.cutoff_from_nvr(nvr, dt))) / 50.0
    print(f"  bisection {1e3 * tb:.2f} ms, brentq {1e3 * tr:.3f} ms: {tb / tr:.0f}x; relative difference {diff:.1e}")
    REC.add(key="cutoff", bisection_s=tb, brentq_s=tr, ratio=tb / tr, rel_difference=diff)


def gradient_section(n=25_000):
    print(f"\n4. jnp.gradient vs the hand-written central differences, N = {n:,}")
    x = jnp.asarray(np.random.default_rng(1).standard_normal(n))
    dt = 1e-3

    def hand(x):
        inner = (x[2:] - x[:-2]) / (2 * dt)
        return jnp.concatenate([(x[1:2] - x[0:1]) / dt, inner, (x[-1:] - x[-2:-1]) / dt])

    same = bool(jnp.all(jax.jit(hand)(x) == jax.jit(lambda v: jnp.gradient(v, dt))(x)))
    print(f"  bit-identical: {same}")
    REC.add(key="gradient", bit_identical=same)


_FAST_LOOPS_SNIPPET = """
import time, numpy as np, jaxsdp, jax
jax.config.update("jax_enable_x64", True)
rng = np.random.default_rng(0)
n = 25_000
z = np.ones((n, 1)); y = np.cumsum(rng.standard_normal(n)) * 0.01 + rng.standard_normal(n)
def best(f, r=5):
    jax.block_until_ready(f()); ts = []
    for _ in range(r):
        t0 = time.perf_counter(); jax.block_until_ready(f()); ts.append(time.perf_counter() - t0)
    return min(ts)
z3 = rng.standard_normal((n, 3))
print(best(lambda: jaxsdp.dlr(y, z, model="IRW", nvr=1e-4).par), best(lambda: jaxsdp.ml_nvr(y, z, model="IRW").nvr),
      best(lambda: jaxsdp.dlr(y, z3, model="IRW", nvr=1e-4).par))
print(jaxsdp.fast_loops_status())
"""


def fast_loops_section():
    import os
    import subprocess

    from jaxsdp._runtime import OPTION, VALUE

    print("\n5. XLA-CPU fast loops (jaxsdp._runtime) on/off, N = 25,000")
    # XLA_FLAGS as before `import jaxsdp` added the option to it here (the children inherit this environment)
    flags = os.environ.get("XLA_FLAGS", "").replace(f",{OPTION}={VALUE}", "")
    flags = flags.replace(f"--xla_backend_extra_options={OPTION}={VALUE}", "").strip()
    out = {}
    for flag in ("1", "0"):
        env = {**os.environ, "JAXSDP_FAST_LOOPS": flag, "XLA_FLAGS": flags}
        res = subprocess.run([sys.executable, "-c", _FAST_LOOPS_SNIPPET], env=env, capture_output=True, text=True)
        times, status = res.stdout.splitlines()[:2]
        out[flag] = [float(v) for v in times.split()]
        print(f"  JAXSDP_FAST_LOOPS={flag}: {status}")
    (d1, m1, g1), (d0, m0, g0) = out["1"], out["0"]
    print(f"  dlr, one IRW block (closed-form kernels): {1e3 * d1:.2f} ms on, {1e3 * d0:.2f} ms off ({d0 / d1:.1f}x)")
    print(f"  ml_nvr, one IRW block: {1e3 * m1:.1f} ms on, {1e3 * m0:.1f} ms off ({m0 / m1:.1f}x)")
    print(f"  dlr, three IRW blocks (general kernels): {1e3 * g1:.1f} ms on, {1e3 * g0:.1f} ms off ({g0 / g1:.1f}x)")
    for key, on, off in (("dlr", d1, d0), ("ml-nvr", m1, m0), ("general", g1, g0)):
        REC.add(
            key=f"fast-loops-{key}",
            samples=25_000,
            on_s=on,
            off_s=off,
            ratio=off / on,
            off_extra_us_per_sample=1e6 * (off - on) / 25_000,
        )


def optimistix_section(n=25_000):
    import optimistix as optx

    print(f"\n6. ml_nvr's BFGS loop vs optimistix.BFGS on the same likelihood (dlr_loglik), IRW, N = {n:,}")
    rng = np.random.default_rng(0)
    z = np.ones((n, 1))
    y = np.cumsum(rng.standard_normal(n)) * 0.01 + rng.standard_normal(n)
    fit = jaxsdp.ml_nvr(y, z, model="IRW")
    t = best(lambda: jaxsdp.ml_nvr(y, z, model="IRW").nvr, 3)
    steps = int(fit.steps)
    print(f"    built-in: {1e3 * t:8.1f} ms, {steps} steps, NVR {float(fit.nvr[0]):.4g}, J {float(fit.J):.3f}")
    REC.add(key="bfgs-builtin", seconds=t, steps=steps, nvr=float(fit.nvr[0]), J=float(fit.J))

    def J(b, _):
        return jaxsdp.dlr_loglik(y, z, model="IRW", nvr=10.0 ** b[0]).J / n

    b0 = jnp.array([-4.0])

    @jax.jit
    def solve(b0):
        sol = optx.minimise(J, optx.BFGS(rtol=1e-8, atol=1e-5), b0, max_steps=100, throw=False)
        return sol.value, sol.stats["num_steps"], sol.result == optx.RESULTS.successful

    b, steps, ok = solve(b0)
    t = best(lambda: solve(b0)[0], 3)
    Jb = float(jaxsdp.dlr_loglik(y, z, model="IRW", nvr=10.0 ** b[0]).J)
    print(
        f"  optimistix: {1e3 * t:8.1f} ms, {int(steps)} steps, NVR {10 ** float(b[0]):.4g}, J {Jb:.3f}, "
        f"successful {bool(ok)}  (ml_nvr dropped its solver= option: no first-step limit, stops on flat bounds)"
    )
    REC.add(key="bfgs-optimistix", seconds=t, steps=int(steps), nvr=10 ** float(b[0]), J=Jb, successful=bool(ok))


def main():
    global REC
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only-fast-loops", action="store_true", help="section 5 alone")
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args()
    REC = Recorder("benchmarks/numerics.py", args.json, only_fast_loops=args.only_fast_loops)
    if args.only_fast_loops:
        fast_loops_section()
        return
    print(f"jax {jax.__version__}, {jax.devices()[0].platform}; fast loops: {jaxsdp.fast_loops_status()}\n")
    cho_solve_section()
    curvature_section()
    cutoff_section()
    gradient_section()
    fast_loops_section()
    optimistix_section()


if __name__ == "__main__":
    main()
