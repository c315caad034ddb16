"""Benchmark: sequential against parallel-in-time kernels, on whatever device JAX picks (GPU or CPU).

Rows (float64, times after compilation, the best of `--repeats` calls with the
outputs blocked on; compile+first call printed beside):

1. `dlr` IRW (NVR 1e-9), one series of N = 25,000;
2. `dlr` IRW under `jax.vmap`, B series of 25,000 sharing the regressor (`--batch`, default 1,000);
3. the concentrated log-likelihood (`dlr_loglik`) and its derivative w.r.t.
   log10 NVR by `jax.jvp`, N = 25,000;
4. `sdp`, two RW terms with ML NVRs, N = 25,000;
5. the EMPS pipeline after compilation (`emps_study` without the decimation
   check; the real DATA_EMPS.mat if found, else the built-in simulated record);
6. the EMPS closed loop (25 s at 1 kHz), one run and a vmap of `--runs` runs
   (the simulators stay sequential: nonlinear, stick-slip);

each for `method="sequential"` and `method="parallel"`, with their ratio
and the largest relative difference between the two results. Then the
parallel-in-time smoothers of the JAX state-space libraries on the same IRW
problem (N = 25,000; prior at time 0, first observation after one
prediction, as jaxsdp): dynamax (`parallel_lgssm_smoother`) and cuthbert
(square-root parallel filter and smoother), where they import: agreement of
their smoothed means and variances with `dlr`, whether their
log-likelihood is finite, and their time.

    python benchmarks/gpu.py [--batch 1000] [--runs 1000] [--repeats 5] [--quick] [--json PATH]
    python benchmarks/gpu.py --all DIR [--limit-scale X] [--only NAME ...]

`--all DIR` is the one command for a GPU machine: every benchmark of `ALL` (these rows with their peers, the Monte
Carlo runner and studies, the robot regressor on a million states, the robot Monte Carlo with IDIM-IV), each in its
own process under a time limit, into DIR (their logs and JSON, `env.txt`), then `all.json` and `all.txt` (one table).

`--json PATH` also writes every row (seconds after compile, compile + first
call, the largest relative difference) with the device, the JAX version and
the date: the performance page's GPU table is read from such a file.

On the CPU this compares the two methods (the sequential kernels are the
faster there; `method="auto"` picks them); on a GPU it is the table of the
README's "GPU" section.
"""

import argparse
import os
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import jax
import jax.numpy as jnp
import numpy as np
from _record import Recorder, timings  # noqa: E402
from _results import MONTECARLO_XLA_FLAGS  # noqa: E402  (the GPU table names the same flag)

import jaxsdp  # noqa: I001  (before JAX's backend starts, see jaxsdp._runtime)

SHARED = pathlib.Path(os.environ.get("JAXSDP_SHARED", ROOT / ".." / "shared")).resolve()
EMPS_MAT = SHARED / "data" / "emps" / "DATA_EMPS.mat"
N = 25_000
NVR = 1e-9
METHODS = ("sequential", "parallel")


def timed(fn, repeats):
    out, first, runs = timings(fn, repeats)
    return out, min(runs, default=np.inf), first


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(b) & np.isfinite(a)
    return float(np.max(np.abs(a[ok] - b[ok])) / max(np.max(np.abs(b[ok])), 1e-300)) if ok.any() else float("nan")


def fmt(t):
    return f"{t * 1e3:9.2f} ms" if t < 1.0 else f"{t:9.3f} s "


def data(n=N, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    return np.sin(6 * t) + 0.1 * rng.normal(size=n), np.ones((n, 1))


def rows(args):
    y, z = data()
    B = args.batch
    Y = np.stack([data(seed=s)[0] for s in range(min(B, 8))])
    Y = jnp.asarray(np.resize(Y, (B, N)))
    rng = np.random.default_rng(1)
    xs = rng.uniform(-2.0, 2.0, (N, 2))
    ys = np.tanh(2 * xs[:, 0]) + 0.3 * np.sign(xs[:, 1]) + 0.05 * rng.normal(size=N)
    zs = np.c_[np.ones(N), 1.0 + 0.3 * np.cos(xs[:, 0])]

    def loglik_jvp(m):
        f = lambda b: jaxsdp.dlr_loglik(y, z, model="IRW", nvr=10.0**b, method=m).loglik
        return jax.jvp(f, (jnp.asarray(-9.0),), (jnp.asarray(1.0),))

    batch = {
        m: jax.jit(jax.vmap(lambda yy, m=m: jaxsdp.dlr(yy, z, model="IRW", nvr=NVR, method=m).par)) for m in METHODS
    }
    out = [
        ("dlr IRW, one series of 25,000", lambda m: jaxsdp.dlr(y, z, model="IRW", nvr=NVR, method=m).par),
        (f"dlr IRW, vmap {B:,} series of 25,000", lambda m: batch[m](Y)),
        ("log-likelihood + jvp, 25,000", loglik_jvp),
        ("sdp, 2 terms, ML NVRs, 25,000", lambda m: jaxsdp.sdp(ys, zs, xs, method=m).par),
    ]
    from jaxsdp.studies.emps import emps_study

    if EMPS_MAT.exists():
        emps = EMPS_MAT
    else:
        from jaxsdp.data import emps_builtin_data

        emps = emps_builtin_data()[0]
    out.append(("EMPS pipeline after compile", lambda m: emps_study(emps, method=m, check_decimation=False).idim.theta))
    return out


REC = None  # a Recorder, set in main()


def record(group, task, **fields):
    REC.add(group=group, task=task, **fields)


def simulation_rows(args):
    from jaxsdp.data import emps_builtin_reference
    from jaxsdp.plants import EMPSPlant, LinearFriction, simulate_emps

    qg = jnp.asarray(emps_builtin_reference(n=25_000).q)
    one = jax.jit(lambda: simulate_emps(qg).force)
    thetas = jnp.asarray([95.1, 203.5, 20.4, -3.2]) * (1 + 0.1 * jax.random.uniform(jax.random.key(0), (args.runs, 4)))
    many = jax.jit(
        jax.vmap(lambda th: simulate_emps(qg, plant=EMPSPlant(th[0], LinearFriction(th[1], th[2], th[3]))).force)
    )
    _, t1, c1 = timed(one, args.repeats)
    _, tn, cn = timed(lambda: many(thetas), max(1, args.repeats // 2))
    print(f"  {'EMPS closed loop 25 s at 1 kHz, one run':44s} {fmt(t1)}   (compile+first {c1:.1f} s)")
    print(f"  {f'EMPS closed loop, vmap {args.runs:,} runs':44s} {fmt(tn)}   (compile+first {cn:.1f} s)")
    record("simulation", "EMPS closed loop 25 s at 1 kHz, one run", seconds=t1, compile_first=c1)
    record("simulation", f"EMPS closed loop, vmap {args.runs:,} runs", seconds=tn, compile_first=cn, runs=args.runs)
    cpu = jax.devices("cpu")[0]
    if jax.default_backend() != "cpu":
        with jax.default_device(cpu):
            one_cpu = jax.jit(lambda: simulate_emps(jax.device_put(qg, cpu)).force)
            _, tc, _ = timed(one_cpu, args.repeats)
        print(f"  {'  the same single run on the CPU device':44s} {fmt(tc)}")
        record("simulation", "EMPS closed loop, one run on the CPU device", seconds=tc)


def peers(args):
    y, z = data()
    ref = jaxsdp.dlr(y, z, model="IRW", nvr=NVR, method="parallel")
    F = jnp.array([[1.0, 1.0], [0.0, 1.0]])
    Q = jnp.array([[0.0, 0.0], [0.0, NVR]])
    P0 = 1e5 * jnp.eye(2)
    s2 = float(ref.sigma2)
    var_ref = np.asarray(ref.parse[:, 0]) ** 2 / s2  # normalised (observation variance 1)
    try:
        from dynamax.linear_gaussian_ssm import (
            ParamsLGSSM,
            ParamsLGSSMDynamics,
            ParamsLGSSMEmissions,
            ParamsLGSSMInitial,
            parallel_lgssm_smoother,
        )

        params = ParamsLGSSM(
            initial=ParamsLGSSMInitial(mean=jnp.zeros(2), cov=F @ P0 @ F.T + Q),
            dynamics=ParamsLGSSMDynamics(weights=F, bias=jnp.zeros(2), input_weights=jnp.zeros((2, 0)), cov=Q),
            emissions=ParamsLGSSMEmissions(
                weights=jnp.array([[1.0, 0.0]]), bias=jnp.zeros(1), input_weights=jnp.zeros((1, 0)), cov=jnp.eye(1)
            ),
        )
        run = jax.jit(lambda yy: parallel_lgssm_smoother(params, yy[:, None]))
        post, t, c = timed(lambda: run(jnp.asarray(y)), args.repeats)
        m = rel(post.smoothed_means[:, 0], ref.par[:, 0])
        v = rel(post.smoothed_covariances[:, 0, 0], var_ref)
        ll = float(post.marginal_loglik)
        print(f"  {'dynamax parallel_lgssm_smoother':44s} {fmt(t)}   means {m:.1e}, variances {v:.1e}, loglik {ll:.6g}")
        record("peers", "dynamax parallel_lgssm_smoother", seconds=t, means=m, variances=v, loglik=ll)
    except Exception as err:  # noqa: BLE001  a peer that fails is reported, not fatal
        print(f"  dynamax: not run ({type(err).__name__}: {err})")
        record("peers", "dynamax parallel_lgssm_smoother", not_run=f"{type(err).__name__}: {err}")
    try:
        import cuthbert
        from cuthbert.gaussian import kalman

        cq = jnp.sqrt(Q)
        filt = kalman.build_filter(
            jnp.zeros(2),
            jnp.sqrt(1e5) * jnp.eye(2),
            lambda mi: (F, jnp.zeros(2), cq),
            lambda mi: (jnp.array([[1.0, 0.0]]), jnp.zeros(1), jnp.eye(1), mi),
        )
        smo = kalman.build_smoother(lambda mi: (F, jnp.zeros(2), cq))

        def run_c(yy):
            fs = cuthbert.filter(filt, yy[:, None], filt.init_prepare(), parallel=True)
            ss = cuthbert.smoother(smo, fs, yy[:, None], parallel=True)
            return ss.mean[1:], ss.chol_cov[1:], fs.log_normalizing_constant[-1]

        run_c = jax.jit(run_c)
        (mean, chol, ll), t, c = timed(lambda: run_c(jnp.asarray(y)), args.repeats)
        var = jnp.einsum("nij,nij->ni", chol, chol)[:, 0]
        print(
            f"  {'cuthbert parallel filter + smoother':44s} {fmt(t)}   means {rel(mean[:, 0], ref.par[:, 0]):.1e}, "
            f"variances {rel(var, var_ref):.1e}, loglik {float(ll):.6g}"
        )
        record(
            "peers",
            "cuthbert parallel filter + smoother",
            seconds=t,
            means=rel(mean[:, 0], ref.par[:, 0]),
            variances=rel(var, var_ref),
            loglik=float(ll),
        )
    except Exception as err:  # noqa: BLE001
        print(f"  cuthbert: not run ({type(err).__name__}: {err})")
        record("peers", "cuthbert parallel filter + smoother", not_run=f"{type(err).__name__}: {err}")
    print(f"  {'jaxsdp dlr, parallel (for reference)':44s} loglik {float(ref.loglik):.6g} (concentrated, finite)")


#: What `--all` runs, in this order, each in its own process under its own time limit (s; `--limit-scale` scales
#: them) and with extra environment variables: the robot regressor on a million states with pinocchio's loop, the
#: kernels and their peers, the Monte Carlo runner and studies (XLA's command buffers off: with them on,
#: instantiating the identification study's CUDA graph ran out of memory on an H200), the robot Monte Carlo with
#: IDIM-IV. Each writes `NAME.txt` and `NAME.json` into the folder; the performance page's GPU table reads them
#: (`benchmarks/_results.py`).
ALL = (
    ("robot_stacked", ["robot_stacked.py", "--states", "1000000", "--repeats", "3"], 120, {}),
    ("gpu", ["gpu.py", "--batch", "2000", "--runs", "10000", "--repeats", "2"], 330, {}),
    (
        "montecarlo",
        ["montecarlo.py", "--runs", "10000", "--vmap-max", "10000", "--ident-runs", "1000", "--control-runs", "10000"],
        170,
        {"XLA_FLAGS": MONTECARLO_XLA_FLAGS},
    ),
    ("robot_montecarlo_iv", ["robot_montecarlo.py", "--runs", "0", "--iv-runs", "500"], 140, {}),
)


def run_all(out: pathlib.Path, *, scale: float = 1.0, only=None) -> int:
    """Every benchmark of `ALL` into `out`: each one's log and JSON, `env.txt` (the device, driver, date, JAX),
    then `all.json` (name -> its JSON, or why it has none) and `all.txt` (one table of every row's figures)."""
    import json
    import subprocess

    out.mkdir(parents=True, exist_ok=True)
    env = [sys.executable, "-c", "import jax, jaxsdp; print('jax', jax.__version__, jax.devices())"]
    smi = (
        subprocess.run(
            ["nvidia-smi", "--query-gpu=name,driver_version,memory.total", "--format=csv"],
            capture_output=True,
            text=True,
        ).stdout
        if _which("nvidia-smi")
        else "name, driver_version, memory.total [MiB]\nno GPU, -, -\n"
    )
    date = time.strftime("%Y-%m-%d", time.gmtime())
    jaxline = subprocess.run(env, capture_output=True, text=True).stdout
    (out / "env.txt").write_text(smi + date + "\n" + jaxline)
    print((out / "env.txt").read_text(), flush=True)
    docs = {}
    for name, argv, limit, extra in ALL:
        if only and name not in only:
            continue
        cmd = [sys.executable, str(ROOT / "benchmarks" / argv[0]), *argv[1:], "--json", str(out / f"{name}.json")]
        t0 = time.perf_counter()
        shown = " ".join([*(f"{k}={v}" for k, v in extra.items()), *argv])
        print(f"== {name}: {shown} (limit {limit * scale:.0f} s)", flush=True)
        with open(out / f"{name}.txt", "w") as log:
            try:
                proc = subprocess.run(
                    cmd,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    timeout=limit * scale,
                    env=dict(os.environ, PYTHONUNBUFFERED="1", **extra),
                )
                status = f"exit {proc.returncode}"
            except subprocess.TimeoutExpired:
                status = f"stopped at its {limit * scale:.0f} s limit"
        wall = time.perf_counter() - t0
        print((out / f"{name}.txt").read_text(), flush=True)
        path = out / f"{name}.json"
        doc = json.loads(path.read_text()) if path.exists() else {"rows": []}
        doc["status"], doc["wall_s"] = status, round(wall, 1)
        docs[name] = doc
        print(f"   {status}, {wall:.0f} s", flush=True)
    (out / "all.json").write_text(json.dumps(docs, indent=1) + "\n")
    (out / "all.txt").write_text(all_table(docs))
    print(all_table(docs))
    return 0


def _which(cmd):
    import shutil

    return shutil.which(cmd) is not None


def all_table(docs: dict) -> str:
    """One table: benchmark, row (its key or task), and every number the row holds."""
    lines = ["| benchmark | row | figures |", "|---|---|---|"]
    for name, doc in docs.items():
        rows = doc.get("rows") or [{}]
        for row in rows:
            label = row.get("key") or row.get("task") or row.get("name") or "-"
            nums = ", ".join(
                f"{k} {v:.4g}" for k, v in row.items() if isinstance(v, (int, float)) and not isinstance(v, bool)
            )
            lines.append(f"| {name} ({doc.get('device', '?')}; {doc['status']}) | {label} | {nums or '-'} |")
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--all",
        type=pathlib.Path,
        default=None,
        metavar="DIR",
        help="run every benchmark of ALL (this file's rows, Monte Carlo, robot regressor, robot IV Monte Carlo) into "
        "DIR, each under its time limit, and write DIR/all.json and DIR/all.txt",
    )
    p.add_argument("--limit-scale", type=float, default=1.0, help="--all: scale every time limit")
    p.add_argument("--only", nargs="*", default=None, help="--all: only these of ALL")
    p.add_argument("--batch", type=int, default=1000)
    p.add_argument("--runs", type=int, default=1000)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--quick", action="store_true", help="batch 100, runs 100, 2 repeats")
    p.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, device and date here")
    p.add_argument("--peers-only", action="store_true", help="only the parallel-in-time peers (dynamax, cuthbert)")
    args = p.parse_args()
    if args.all is not None:
        return run_all(args.all, scale=args.limit_scale, only=args.only)
    if args.quick:
        args.batch, args.runs, args.repeats = 100, 100, 2
    global REC
    REC = Recorder("benchmarks/gpu.py", args.json, batch=args.batch, runs=args.runs, repeats=args.repeats)
    with jax.enable_x64(True):
        print(f"devices: {jax.devices()}; backend {jax.default_backend()}; jax {jax.__version__}")
        print(f"method='auto' resolves to {jaxsdp.resolve_method('auto')!r} here\n")
        print(f"  {'task':44s} {'sequential':>12s} {'parallel':>12s}   seq/par   max rel. difference")
        for name, fn in [] if args.peers_only else rows(args):
            res = {}
            try:
                for m in METHODS:
                    res[m] = timed(lambda m=m: fn(m), args.repeats)
            except Exception as err:  # noqa: BLE001  (out of memory on a small card: say so, go on)
                print(f"  {name:44s} failed: {type(err).__name__}: {str(err)[:200]}")
                record("kernels", name, failed=f"{type(err).__name__}: {str(err)[:200]}")
                continue
            (a, ta, _), (b, tb, cb) = res["sequential"], res["parallel"]
            diff = max(rel(u, v) for u, v in zip(jax.tree.leaves(b), jax.tree.leaves(a)))
            print(
                f"  {name:44s} {fmt(ta)} {fmt(tb)}   {ta / tb:7.2f}   {diff:.1e}   (parallel compile+first {cb:.1f} s)"
            )
            record(
                "kernels",
                name,
                sequential=ta,
                parallel=tb,
                sequential_compile_first=res["sequential"][2],
                parallel_compile_first=cb,
                max_rel_difference=diff,
            )
        if not args.peers_only:
            print("\nclosed-loop simulators (sequential scans; see the README on single runs on a GPU):")
            simulation_rows(args)
        print("\nparallel-in-time peers on the same IRW problem (N = 25,000, float64):")
        peers(args)


if __name__ == "__main__":
    sys.exit(main())
