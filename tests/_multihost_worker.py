"""One process of a multi-host `jaxsdp.monte_carlo` run, started by tests/test_montecarlo_multihost.py.

    python tests/_multihost_worker.py COORDINATOR NUM_PROCESSES PROCESS_ID OUT.npz [--fail none|raise|kill] [--devices]

Joins the `jax.distributed` group served by process 0 at COORDINATOR
(host:port), runs `jaxsdp.monte_carlo(walk, key(3), N, params=PARAMS)` and
saves its copy of the results to OUT.npz. `--fail raise` makes this process
raise inside the run, in the middle of the third chunk's computation (the
others then wait for it in the chunk's gather); `--fail kill` kills it
there (SIGKILL), after writing the time to OUT.npz.failed; `--fail none` runs the same program without failing (the
others). `--devices` also runs with `devices` a list spanning the
processes and checks that a number of devices owned by process 0 alone is
refused (start the processes with JAX_NUM_CPU_DEVICES=2). The reference,
one process, is `run()` imported from this module.
"""

import argparse
import os
import signal
import time

import jaxsdp  # isort: skip  (first: before JAX's backend starts)
import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

N = 301
PARAMS = {"a": np.linspace(0.5, 1.5, N)}
CHUNK = 64  # five chunks
#: seconds: a process that stops answering is declared dead after this (jax's default is 100 s)
HEARTBEAT_S = 5
#: seconds: the longest a process waits for the others at exit (jax's default is 300 s)
SHUTDOWN_S = 10
#: draws with a > FAIL_FROM fail (the third chunk on)
FAIL_FROM = 1.0


def walk(k, p):
    # reductions over a long axis: their order would depend on the batch width unless the runner fixed it
    x = jax.random.normal(k, (400,))
    y = jnp.cumsum(x * p["a"])
    return {"mean": jnp.mean(y), "std": jnp.std(y), "peak": jnp.max(jnp.abs(y)), "head": y[:3]}


def run(fn=walk, **kwargs):
    return jaxsdp.monte_carlo(fn, jax.random.key(3), N, params=PARAMS, chunk_size=CHUNK, progress=False, **kwargs)


def failing(how: str | None, mark: str = ""):
    """`walk` with a host callback that fails on this process (raise or SIGKILL) once a > FAIL_FROM.

    The time of the failure (`time.time()`) is written to the file `mark` first.
    """

    def check(a):
        if how is not None and np.any(np.asarray(a) > FAIL_FROM):
            with open(mark, "w") as f:
                f.write(repr(time.time()))
            if how == "kill":
                os.kill(os.getpid(), signal.SIGKILL)
            raise RuntimeError(f"process {jax.process_index()}: deliberate failure within the run")
        return np.zeros(np.shape(a), np.float64)

    def fn(k, p):
        zero = jax.pure_callback(check, jax.ShapeDtypeStruct((), jnp.float64), p["a"], vmap_method="broadcast_all")
        out = walk(k, p)
        return dict(out, mean=out["mean"] + zero)

    return fn


def main():
    cli = argparse.ArgumentParser()
    cli.add_argument("coordinator")
    cli.add_argument("num_processes", type=int)
    cli.add_argument("process_id", type=int)
    cli.add_argument("out")
    cli.add_argument("--fail", choices=("none", "raise", "kill"))
    cli.add_argument("--devices", action="store_true")
    args = cli.parse_args()
    jax.distributed.initialize(
        coordinator_address=args.coordinator,
        coordinator_bind_address=args.coordinator,  # this machine only (default: [::]:port)
        num_processes=args.num_processes,
        process_id=args.process_id,
        initialization_timeout=60,
        heartbeat_timeout_seconds=HEARTBEAT_S,
        shutdown_timeout_seconds=SHUTDOWN_S,
    )
    assert jax.process_count() == args.num_processes
    res = {}
    out = run() if args.fail is None else run(failing(None if args.fail == "none" else args.fail, args.out + ".failed"))
    res.update(devices=out.devices, chunk_size=out.chunk_size, **out.values)
    if args.devices:
        devs = jax.devices()
        span = [devs[1], devs[2]]  # process 0's second device, process 1's first
        sub = run(devices=span)
        res.update(span_devices=sub.devices, **{f"span_{k}": v for k, v in sub.values.items()})
        try:
            run(devices=len(jax.local_devices()))  # process 0's devices only
        except ValueError as e:
            res["refused"] = str(e)
    np.savez(args.out, **res)
    print(f"process {args.process_id}: done, {out.devices} devices, {out.seconds:.2f} s", flush=True)


if __name__ == "__main__":
    main()
