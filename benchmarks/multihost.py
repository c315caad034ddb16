"""Benchmark: the Monte Carlo runner (`jaxsdp.monte_carlo`) on 1, 2 and 4 local `jax.distributed` processes.

The workload of `benchmarks/montecarlo.py` (its `make_run`): per draw, the
built-in EMPS plant with M, Fv, Fc, offset drawn +-20 % uniform, in closed
loop along the built-in 25 s reference at 1 kHz (25,000 samples), one
encoder count of position noise; four statistics per run come back.

For each process count P (`--processes`), the script starts P processes of
itself on this machine, as on a cluster: process i calls
`jax.distributed.initialize(coordinator_address="127.0.0.1:<free port>",
num_processes=P, process_id=i)` (P = 1: no `jax.distributed` at all, the
plain single-process run) with the CPU (gloo) collectives, then
`monte_carlo` with the same arguments; each process has `--cpu-devices`
CPU devices (JAX_NUM_CPU_DEVICES). Printed per P, the fastest of
`--repeats` launches (the machine may be shared): the run's wall time
(`MonteCarloOutput.seconds` of the slowest process: compilation and the
per-chunk gathers included), runs/s, the speed-up over one process, the
whole launch (process start-up, `initialize`, run, exit), and how the
results compare: every process's copy must be the same; runs on 2 devices
or more must be bit-identical to each other, whatever the split over
processes; against the one-device run the relative difference is printed
(a one-device program is compiled without XLA's SPMD partitioner and, for
this closed loop, differs in the last bits).

    python benchmarks/multihost.py [--processes 1 2 4] [--runs 4096] [--chunk 1024] [--cpu-devices 1] [--repeats 3]

On a machine with fewer cores than processes the processes share the cores
(oversubscribed): the figures then measure the runner's overhead, not a
cluster's scaling.
"""

import argparse
import json
import os
import pathlib
import socket
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import jaxsdp  # noqa: I001  (before JAX's backend starts)
import jax
import numpy as np

from montecarlo import make_run  # the workload of benchmarks/montecarlo.py

HEARTBEAT_S = 30
SHUTDOWN_S = 60


def worker(args):
    if args.num_processes > 1:
        jax.distributed.initialize(
            coordinator_address=args.coordinator,
            coordinator_bind_address=args.coordinator,  # this machine only (default: [::]:port)
            num_processes=args.num_processes,
            process_id=args.process_id,
            heartbeat_timeout_seconds=HEARTBEAT_S,
            shutdown_timeout_seconds=SHUTDOWN_S,
        )
    from jaxsdp.data import emps_builtin_reference

    with jax.enable_x64(True):
        qg = jax.numpy.asarray(emps_builtin_reference(n=25_000).q)
        scale = 1.0 + 0.4 * (np.random.default_rng(0).random((args.runs, 4)) - 0.5)
        out = jaxsdp.monte_carlo(make_run(qg), 0, args.runs, params=scale, chunk_size=args.chunk, progress=False)
    np.save(pathlib.Path(args.out) / f"values{args.process_id}.npy", out.values)
    info = dict(seconds=out.seconds, devices=out.devices, chunk=out.chunk_size, processes=jax.process_count())
    (pathlib.Path(args.out) / f"info{args.process_id}.json").write_text(json.dumps(info))


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def launch(P, args, out):
    """Start P processes of this script, wait (at most `--timeout` s); returns the launch's wall time."""
    coordinator = f"127.0.0.1:{_free_port()}"
    env = dict(os.environ, JAX_PLATFORMS="cpu", JAX_NUM_CPU_DEVICES=str(args.cpu_devices))
    common = ["--runs", str(args.runs), "--chunk", str(args.chunk), "--out", str(out)]
    t0 = time.perf_counter()
    procs = [
        subprocess.Popen(
            [sys.executable, __file__, "--worker", coordinator, str(P), str(i)] + common,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for i in range(P)
    ]
    try:
        logs = [p.communicate(timeout=args.timeout)[0] for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    wall = time.perf_counter() - t0
    bad = [(i, p.returncode) for i, p in enumerate(procs) if p.returncode != 0]
    if bad:
        raise RuntimeError(f"{P} processes: exit codes {bad}\n" + "\n".join(log[-2000:] for log in logs))
    return wall


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--processes", type=int, nargs="+", default=[1, 2, 4])
    p.add_argument("--runs", type=int, default=4096)
    p.add_argument("--chunk", type=int, default=1024)
    p.add_argument("--cpu-devices", type=int, default=1, help="CPU devices per process (JAX_NUM_CPU_DEVICES)")
    p.add_argument("--repeats", type=int, default=3, help="launches per process count; the fastest is printed")
    p.add_argument("--timeout", type=float, default=600, help="seconds, per process count")
    p.add_argument("--worker", nargs=3, metavar=("COORDINATOR", "NUM_PROCESSES", "PROCESS_ID"), help=argparse.SUPPRESS)
    p.add_argument("--out", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.worker:
        args.coordinator, args.num_processes, args.process_id = args.worker[0], *map(int, args.worker[1:])
        return worker(args)

    print(
        f"EMPS closed loop (25 s at 1 kHz), {args.runs:,} runs, chunk {args.chunk}, {args.cpu_devices} CPU "
        f"device(s) per process, {os.cpu_count()} cores on this machine"
    )
    print(f"{'processes':>9} {'devices':>7} {'run (s)':>8} {'runs/s':>7} {'vs 1':>5} {'launch (s)':>10}  results")
    base_rate, ref, multi = None, None, None
    for P in args.processes:
        seconds, wall = float("inf"), float("inf")
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory() as tmp:
                wall = min(wall, launch(P, args, tmp))
                infos = [json.loads((pathlib.Path(tmp) / f"info{i}.json").read_text()) for i in range(P)]
                values = [np.load(pathlib.Path(tmp) / f"values{i}.npy") for i in range(P)]
            assert all(info["processes"] == P for info in infos), infos
            seconds = min(seconds, max(info["seconds"] for info in infos))
        rate = args.runs / seconds
        base_rate = base_rate or (rate if P == 1 else None)
        ratio = f"{rate / base_rate:5.2f}" if base_rate else "    -"
        notes = []
        if not all(np.array_equal(v, values[0]) for v in values):
            notes.append("processes DIFFER")
        if infos[0]["devices"] == 1:
            ref = ref if ref is not None else values[0]
        elif multi is None:
            multi = (P, values[0])
        else:
            notes.append(
                f"bit-identical to {multi[0]} processes"
                if np.array_equal(values[0], multi[1])
                else f"DIFFERS from {multi[0]} processes"
            )
        if ref is not None and infos[0]["devices"] > 1:
            rel = np.max(np.abs(values[0] - ref) / np.maximum(np.abs(ref), 1e-300))
            notes.append("bit-identical to 1 device" if rel == 0 else f"max rel. diff. to 1 device {rel:.1e}")
        print(f"{P:9d} {infos[0]['devices']:7d} {seconds:8.2f} {rate:7.0f} {ratio} {wall:10.1f}  {'; '.join(notes)}")


if __name__ == "__main__":
    main()
