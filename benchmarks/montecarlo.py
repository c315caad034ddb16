"""Benchmark: the Monte Carlo runner (`jaxsdp.monte_carlo`) on EMPS closed-loop runs.

Each draw: the built-in EMPS plant with M, Fv, Fc, offset drawn +-20 %
uniform around the IDIM-LS values, in closed loop with the benchmark's
controller along the built-in 25 s reference at 1 kHz (25,000 samples),
with one encoder count of position noise from the draw's key; only per-run
statistics come back (peak tracking error, RMS error, peak force, peak
speed), the trajectories stay on the device and are dropped.

For n = 1,000 and 10,000 (`--runs`): runs per second and the peak resident
memory (each row runs in its own process, so its peak is its own), for the runner (chunks of `--chunk`) and, as the
peer, a single `jax.jit(jax.vmap(...))` over all n draws (the memory of a
whole batch at once; skipped above `--vmap-max` draws). Targets: 10,000
runs within 2 GB (the runner), and the control study's 10,000 runs <= 60 s
on 2 cores.

Then both studies end to end (`--studies`, compilation included, as a user
runs them): `identification_robustness` (closed loop + derivatives + IDIM-LS
x 3 + IDIM-IV + SDP + IDIM-SDP per run; target 1,000 runs <= 60 s on 2
cores) for `--ident-runs`, and `control_robustness` (three step responses
per drawn plant; target 10,000 runs <= 60 s on 2 cores, <= 2 s on an H100)
for `--control-runs`.

    python benchmarks/montecarlo.py [--runs 1000 10000] [--chunk N] [--vmap-max 2000]
        [--ident-runs 1000 10000] [--control-runs 1000 10000] [--no-runner] [--json PATH]

`--json PATH` also writes every row with the device, the JAX version and the date.
"""

import argparse
import json
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import jax
import jax.numpy as jnp
import numpy as np
from _record import Recorder  # noqa: E402

import jaxsdp  # noqa: I001  (before JAX's backend starts)
from jaxsdp.data import emps_builtin_reference
from jaxsdp.plants import EMPSPlant, LinearFriction, simulate_emps

REC = None  # a Recorder, set in main()
THETA = np.array([95.1089, 203.5034, 20.3935, -3.1648])


def peak_rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2


def device_peak_gb():
    """Peak bytes on the accelerator (None on the CPU, whose figure is the process's RSS)."""
    stats = jax.devices()[0].memory_stats() if jax.default_backend() != "cpu" else None
    return stats["peak_bytes_in_use"] / 1024**3 if stats and "peak_bytes_in_use" in stats else None


def make_run(qg):
    def run(key, scale):
        th = jnp.asarray(THETA) * scale
        noise = 5e-8 * jax.random.normal(key, qg.shape)
        sim = simulate_emps(qg, plant=EMPSPlant(th[0], LinearFriction(th[1], th[2], th[3])), measurement_noise=noise)
        e = sim.q - qg
        return jnp.stack(
            [jnp.max(jnp.abs(e)), jnp.sqrt(jnp.mean(e * e)), jnp.max(jnp.abs(sim.force)), jnp.max(jnp.abs(sim.dq))]
        )

    return run


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, nargs="+", default=[1000, 10000])
    p.add_argument("--chunk", type=int, default=None, help="draws per chunk (default: the runner's)")
    p.add_argument("--vmap-max", type=int, default=2000)
    p.add_argument("--ident-runs", type=int, nargs="*", default=[1000, 10000])
    p.add_argument("--control-runs", type=int, nargs="*", default=[1000, 10000])
    p.add_argument("--no-runner", action="store_true", help="only the two studies")
    p.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, device and date here")
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)  # TASK:N, one row in this process
    args = p.parse_args()
    global REC
    options = {k: v for k, v in vars(args).items() if k not in ("json", "child")}
    if args.child is not None:
        task, n = args.child.split(":")
        REC = Recorder("benchmarks/montecarlo.py", args.json, **options)
        {"runner": runner_row, "vmap": vmap_row, "control": control_row, "identification": identification_row}[task](
            args, int(n)
        )
        return
    REC = Recorder("benchmarks/montecarlo.py", args.json, **options)
    tasks = (
        []
        if args.no_runner
        else [("runner", n) for n in args.runs] + [("vmap", n) for n in args.runs if n <= args.vmap_max]
    )
    tasks += [("control", n) for n in args.control_runs] + [("identification", n) for n in args.ident_runs]
    print(f"devices: {jax.devices()}; each row in its own process (its peak memory is its own)")
    for task, n in tasks:  # a fresh process per row: the peak resident memory is a process's highest so far
        with tempfile.TemporaryDirectory() as tmp:
            out = pathlib.Path(tmp) / "row.json"
            argv = [sys.executable, __file__, "--child", f"{task}:{n}", "--json", str(out)]
            argv += [] if args.chunk is None else ["--chunk", str(args.chunk)]
            subprocess.run(argv, check=True)
            for row in json.loads(out.read_text())["rows"]:
                REC.add(**row)


def control_row(args, n):
    from jaxsdp.studies.montecarlo import control_robustness

    res = control_robustness(n, progress=False)
    print(
        f"  control, n = {n:6,d}: {res.seconds:7.2f} s ({res.runs_per_second:8.0f} runs/s; target 10,000 "
        f"<= 60 s on 2 cores), peak RSS {peak_rss_gb():.2f} GB; PIP-SDP within the velocity limit in "
        f"{res.statistics['pip_sdp']['within_velocity_limit']:.0%}"
    )
    REC.add(
        key=f"control-{n}",
        task="control_robustness",
        runs=n,
        seconds=float(res.seconds),
        peak_rss_gb=peak_rss_gb(),
        device_peak_gb=device_peak_gb(),
    )


def identification_row(args, n):
    from jaxsdp.studies.montecarlo import identification_robustness

    res = identification_robustness(n, progress=False)
    iv = res.statistics["estimators"]["idim_iv"]["parameters"]
    ls = res.statistics["estimators"]["idim_ls_asym"]["parameters"]
    print(
        f"  identification, n = {n:6,d}: {res.seconds:7.2f} s ({res.runs_per_second:6.1f} runs/s; target "
        f"1,000 <= 60 s on 2 cores), peak RSS {peak_rss_gb():.2f} GB; coverage 95 % of Fv_pos: "
        f"LS {ls['Fv_pos']['coverage_95']:.0%}, IV {iv['Fv_pos']['coverage_95']:.0%}; "
        f"min IV coverage {min(e['coverage_95'] for e in iv.values()):.0%}"
    )
    REC.add(
        key=f"identification-{n}",
        task="identification_robustness",
        runs=n,
        seconds=float(res.seconds),
        peak_rss_gb=peak_rss_gb(),
        device_peak_gb=device_peak_gb(),
    )


def _draws(n):
    qg = jnp.asarray(emps_builtin_reference(n=25_000).q)
    return make_run(qg), 1.0 + 0.4 * (np.random.default_rng(0).random((n, 4)) - 0.5)


def runner_row(args, n):
    with jax.enable_x64(True):
        run, scale = _draws(n)
        jaxsdp.monte_carlo(run, 0, n, params=scale, chunk_size=args.chunk, progress=True)
        t0 = time.perf_counter()
        out = jaxsdp.monte_carlo(run, 0, n, params=scale, chunk_size=args.chunk, progress=False)
        t = time.perf_counter() - t0
        print(
            f"  runner, n = {n:6,d}: {t:7.2f} s after compile ({n / t:7.0f} runs/s), chunk {out.chunk_size}, "
            f"devices {out.devices}, peak RSS {peak_rss_gb():.2f} GB; "
            f"median peak error {np.median(out.values[:, 0]) * 1e3:.3f} mm"
        )
        REC.add(
            key=f"runner-{n}",
            task="runner",
            runs=n,
            seconds=t,
            chunk=int(out.chunk_size),
            peak_rss_gb=peak_rss_gb(),
            device_peak_gb=device_peak_gb(),
        )


def vmap_row(args, n):
    """The peer: one `jax.jit(jax.vmap(...))` over all n draws (the same keys as the runner's), checked equal."""
    with jax.enable_x64(True):
        run, scale = _draws(n)
        keys = jax.vmap(lambda i: jax.random.fold_in(jax.random.key(0), i))(jnp.arange(n))
        whole = jax.jit(jax.vmap(run))
        jax.block_until_ready(whole(keys, jnp.asarray(scale)))
        t0 = time.perf_counter()
        v = jax.block_until_ready(whole(keys, jnp.asarray(scale)))
        t = time.perf_counter() - t0
        rss = peak_rss_gb()
        out = jaxsdp.monte_carlo(run, 0, n, params=scale, chunk_size=args.chunk, progress=False)
        same = float(np.max(np.abs(np.asarray(v) - out.values)))
        print(
            f"  peer: one vmap over all {n:,}: {t:7.2f} s ({n / t:7.0f} runs/s), peak RSS {rss:.2f} GB, "
            f"max |difference| to the runner {same:.1e}"
        )
        REC.add(
            key=f"vmap-{n}",
            task="one vmap (peer)",
            runs=n,
            seconds=t,
            peak_rss_gb=rss,
            device_peak_gb=device_peak_gb(),
            max_difference=same,
        )


if __name__ == "__main__":
    main()
