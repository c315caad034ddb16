"""Vectorised Monte Carlo runner: vmap within a chunk, chunks in sequence, sharded over devices.

`monte_carlo(fn, key, n)` evaluates fn(key_i) (or fn(key_i, params_i)) for
the draws i = 0..n-1 with key_i = `jax.random.fold_in(key, i)`: a draw's
randomness depends on its index alone, never on how the draws are grouped,
so the results are the same for any chunk size and device count. Each chunk
of C draws is one compiled call whose draw axis is sharded over the
devices (`jax.shard_map` on a one-axis mesh; on each device a loop over
groups of `width` draws under `vmap`);
the chunks run one after another, so memory is bounded by a chunk whatever
n is, and a chunk's results come back to the host (numpy) while the next one
runs. Across hosts, under `jax.distributed.initialize()`, the mesh spans
every process's devices and every process gets all the results (one
`process_allgather` per chunk); `monte_carlo`'s docstring says how to launch it.
"""

import sys
import time
from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from ._checks import positive_int, raise_flagged, with_flags
from ._runtime import x64

#: Draws per chunk when `chunk_size` is None (rounded up to a multiple of width x devices).
DEFAULT_CHUNK = 1024


class MonteCarloOutput(NamedTuple):
    """Result of `jaxsdp.monte_carlo`.

    - `values`: fn's outputs for every draw, a pytree of numpy arrays with a
      leading axis of length `runs` (draw i at index i).
    - `runs`, `chunk_size`, `devices` (how many), `seconds` (wall time, compilation
      included), `runs_per_second`.
    """

    values: Any
    runs: int
    chunk_size: int
    devices: int
    seconds: float

    @property
    @x64
    def runs_per_second(self) -> float:
        return self.runs / self.seconds if self.seconds > 0 else float("inf")


def _as_key(key):
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        return jax.random.key(int(key))
    try:
        arr = jnp.asarray(key) if not isinstance(key, jax.Array) else key
    except TypeError:
        arr = None
    if arr is None:
        pass
    elif jnp.issubdtype(arr.dtype, jax.dtypes.prng_key) and arr.shape == ():
        return arr
    elif arr.dtype == jnp.uint32 and arr.shape == (2,):
        return jax.random.wrap_key_data(arr)
    raise ValueError(
        f"`key` must be a PRNG key (jax.random.key(seed)), a raw uint32[2] key or an int seed; got {key!r}"
    )


def _devices(devices):
    if devices is None:
        devs = list(jax.devices())
    elif isinstance(devices, (int, np.integer)) and not isinstance(devices, bool):
        avail = jax.devices()
        if not 1 <= devices <= len(avail):
            raise ValueError(f"`devices` = {devices}: between 1 and the {len(avail)} available devices")
        devs = list(avail[:devices])
    else:
        devs = list(devices)
        if not devs:
            raise ValueError("`devices` must not be empty")
    if jax.process_count() > 1:
        _check_multiprocess(devs)
    return devs


def _check_multiprocess(devs):
    # every process gets the results through a collective over the mesh: each must own one of its devices
    missing = sorted(set(range(jax.process_count())) - {d.process_index for d in devs})
    if missing:
        raise ValueError(
            f"under jax.distributed every process must own at least one of `devices`: processes {missing} own "
            f"none of {devs} (jax.devices() lists process 0's devices first; pass None for all of them)"
        )
    if jax.default_backend() == "cpu" and jax.config.jax_cpu_collectives_implementation is None:
        raise ValueError(
            "several CPU processes need cross-process collectives: set "
            'jax.config.update("jax_cpu_collectives_implementation", "gloo") before jax.distributed.initialize()'
        )


def _progress_bar(n, desc, progress):
    enabled = bool(progress) and sys.stderr.isatty()
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=n, desc=desc or "Monte Carlo", unit="run", file=sys.stderr, dynamic_ncols=True)


def _to_host(tree):
    if jax.process_count() > 1:
        from jax.experimental import multihost_utils

        return jax.tree.map(np.asarray, multihost_utils.process_allgather(tree, tiled=True))
    return jax.tree.map(np.asarray, tree)


@x64
def monte_carlo(
    fn: Callable,
    key,
    n: int,
    *,
    params=None,
    chunk_size: int | None = None,
    devices=None,
    progress: bool = True,
    desc: str | None = None,
    width: int | None = None,
) -> MonteCarloOutput:
    """Run `fn` over $n$ Monte Carlo draws: vmapped in chunks, sharded over devices, gathered as numpy.

    Draw $i$ gets the key $k_i$ = `jax.random.fold_in(key, i)` and, with `params`,
    its own slice $params_i$ = `params[i]` (a pytree of arrays with leading axis
    $n$, e.g. plant parameters sampled beforehand):

        values[i] = fn(k_i)   or   fn(k_i, params_i),     i = 0..n-1.

    `fn` must be a pure JAX function (it is `vmap`ped and `jit`ted) returning
    a pytree of arrays; return per-draw statistics rather than whole
    trajectories to keep memory small (only `chunk_size` draws are on the
    devices at a time). Results do not depend on `chunk_size`, on the
    number of devices or on how the devices are split over processes: each
    draw's key depends on its index only (tested bit for bit on 1, 2 and 4
    devices, 2 and 4 processes and several chunk sizes). One caveat: a
    one-device program is compiled without XLA's SPMD partitioner, and for
    some functions it differs from the (mutually identical) runs on 2 or
    more devices in the last bits (the EMPS closed loop: relative 4e-12).

    **Arguments**

    - `fn`: `fn(key)` or `fn(key, params_i)`.
    - `key`: a PRNG key (`jax.random.key(seed)`), a raw uint32[2] key or an int seed.
    - `n`: number of draws (>= 1).
    - `params`: optional pytree of arrays with leading axis n.
    - `chunk_size`: draws per compiled call (default min(n, 1024)), rounded
      up to a multiple of `width` times the device count; the last chunk is
      padded (the padding is computed and dropped).
    - `devices`: None (all devices: `jax.devices()`, every process's under
      `jax.distributed`), a number of them, or a list of devices.
    - `progress`: a progress bar per chunk with the throughput (tqdm), shown
      only when stderr is a terminal; `desc` its label.
    - `width`: draws vectorised together: each device runs its share of a
      chunk as a loop over groups of `width` draws under `vmap`, so every
      draw is computed by the same compiled code whatever the chunk size and
      device count (XLA orders a reduction by the batch width it sees:
      without the fixed width, sums differ in the last bit). Default 16 on
      CPU devices; on GPUs and TPUs 2048, or n rounded up to a multiple of
      16 when smaller (a GPU runs one group of draws in about the time of
      one draw: 16 at a time, 10,000 EMPS closed loops took over 140 s on
      an H200; measured in `benchmarks/montecarlo.py`). Results of two
      widths differ in the last bits only.

    **Multi-host.** Run the same script once per host, P processes in all,
    each calling `jax.distributed.initialize` before any other JAX work and
    then `monte_carlo` with the same arguments (`fn`, `key`, `n`, `params`,
    `chunk_size`, `width`, `devices`): the mesh spans every process's
    devices, each process computes its devices' share of every chunk, the
    chunk is gathered (`process_allgather`; on CPU over gloo, the default
    `jax_cpu_collectives_implementation` of jax 0.10), and every process
    returns all n results.

        # run.py
        import os
        import jaxsdp  # first: jaxsdp's XLA-CPU option must precede JAX's backend
        import jax

        jax.distributed.initialize(  # under srun / mpirun: leave out the first three (detected)
            coordinator_address=os.environ["JAX_COORDINATOR_ADDRESS"],  # host:port of process 0's service
            num_processes=int(os.environ["NUM_PROCESSES"]),  # P (NUM_PROCESSES, PROCESS_ID: the script's own)
            process_id=int(os.environ["PROCESS_ID"]),  # 0..P-1
            heartbeat_timeout_seconds=30,  # a dead process is detected after this (jax's default 100 s)
            shutdown_timeout_seconds=60,  # the longest a process waits for the others at exit (300 s)
        )
        out = jaxsdp.monte_carlo(fn, key, n, params=params)

        # by hand, on hosts h = 0..3 (host0 runs process 0 and serves the coordinator on any free port):
        JAX_COORDINATOR_ADDRESS=host0:12345 NUM_PROCESSES=4 PROCESS_ID=$h python run.py
        # SLURM: the coordinator is the step's first node, its port derived from SLURM_JOB_ID (or
        # JAX_COORDINATOR_PORT), P = SLURM_NTASKS, process id = SLURM_PROCID
        srun --nodes=4 --ntasks-per-node=1 python run.py
        # Open MPI (detected by OMPI_MCA_orte_hnp_uri, OMPI_COMM_WORLD_SIZE and _RANK; another MPI:
        # initialize(cluster_detection_method="mpi4py", ...) with mpi4py installed)
        mpirun -n 4 --map-by node python run.py

    `JAX_NUM_CPU_DEVICES` sets a CPU process's device count. With `devices`
    a number or a list, every process must own at least one of them
    (`jax.devices()` lists process 0's devices first), else `ValueError`.
    A failing process does not hang the others: jax's distributed service
    aborts every process (SIGABRT, "Terminating process because the JAX
    distributed service detected fatal errors") within about
    `heartbeat_timeout_seconds` of a process's death, or
    `shutdown_timeout_seconds` of a Python exception (the failing process
    waits that long for the others at exit). Tested with 2 and 4 local
    processes (results bit-identical to the one-process run) and with
    heartbeat 5 s, shutdown 10 s: a process raising in the run, a worker
    or the coordinator killed; the others exit with an error 0.2-11 s
    after the failure.

    **Returns** a `MonteCarloOutput` (`values`, `runs`, `chunk_size`,
    `devices`, `seconds`, `runs_per_second`).

    Example:
        >>> import jax, jaxsdp
        >>> def draw(k):
        ...     return jax.random.normal(k, (3,)).mean()
        >>> out = jaxsdp.monte_carlo(draw, jax.random.key(0), 100, progress=False)
        >>> out.values.shape, out.runs
        ((100,), 100)
    """
    n = positive_int("n", n)
    key = _as_key(key)
    devs = _devices(devices)
    D = len(devs)
    width = _default_width(devs, n) if width is None else positive_int("width", width)
    C = min(n, DEFAULT_CHUNK) if chunk_size is None else positive_int("chunk_size", chunk_size)
    C = -(-C // (D * width)) * D * width
    if params is not None:
        leaves = jax.tree.leaves(params)
        bad = [np.shape(a) for a in leaves if np.ndim(a) == 0 or np.shape(a)[0] != n]
        if bad or not leaves:
            raise ValueError(f"`params` must be a pytree of arrays with leading axis n = {n}; got shapes {bad}")
        params = jax.tree.map(np.asarray, params)

    mesh = Mesh(np.asarray(devs), ("runs",))
    shard = NamedSharding(mesh, PartitionSpec("runs"))

    messages = []  # the checks each draw's program returns as flags (`with_flags`), filled when it is traced

    def one(k, i, p):
        ki = jax.random.fold_in(k, i)
        out, flags, found = with_flags(fn, ki) if p is None else with_flags(fn, ki, p)
        messages[:] = found
        return out, flags

    def local(k, idx, p):
        # this device's draws, in groups of `width`: every group is the same compiled vmap
        g = idx.shape[0] // width
        grp = lambda a: a.reshape((g, width) + a.shape[1:])
        body = lambda xs: jax.vmap(one, in_axes=(None, 0, 0 if p is not None else None))(k, xs[0], xs[1])
        out = jax.lax.map(body, (grp(idx), None if p is None else jax.tree.map(grp, p)))
        return jax.tree.map(lambda a: a.reshape((g * width,) + a.shape[2:]), out)

    # (check_vma off: a user's scan starts from constants that the check would
    # require to be marked device-varying; every device's work is independent)
    spec = PartitionSpec("runs")
    run = jax.jit(
        jax.shard_map(local, mesh=mesh, in_specs=(PartitionSpec(), spec, spec), out_specs=spec, check_vma=False)
    )

    def put(a):
        return jax.make_array_from_callback(a.shape, shard, lambda index: a[index])

    bar = _progress_bar(n, desc, progress)
    t0 = time.perf_counter()
    parts, pending = [], None
    try:
        for start in range(0, n, C):
            idx = np.minimum(np.arange(start, start + C), n - 1)
            stop = min(start + C, n)
            p = None if params is None else jax.tree.map(lambda a: put(a[idx]), params)
            out = run(key, put(idx.astype(np.int32)), p)  # dispatched: runs while the previous chunk is fetched
            if pending is not None:
                parts.append(_checked(_fetch(*pending[:2], bar), pending[2], n, messages))
            pending = (out, stop - start, start)
        parts.append(_checked(_fetch(*pending[:2], bar), pending[2], n, messages))
    finally:
        if bar is not None:
            bar.close()
    values = jax.tree.map(lambda *a: np.concatenate(a, axis=0), *parts)
    return MonteCarloOutput(values, n, C, D, time.perf_counter() - t0)


CPU_WIDTH, ACCELERATOR_WIDTH = 16, 2048


def _default_width(devs, n: int) -> int:
    """16 draws per vmapped group on CPUs; up to 2048 on accelerators, whose lanes would idle at 16."""
    if all(d.platform == "cpu" for d in devs):
        return CPU_WIDTH
    return min(ACCELERATOR_WIDTH, -(-n // CPU_WIDTH) * CPU_WIDTH)


def _checked(part, start: int, n: int, messages) -> object:
    """A chunk's values, once its draws' value checks (`with_flags`) have passed: the first failed one raises
    ValueError naming the draw (the checks are outputs, not `eqx.error_if`s, so that the runner's program holds
    no host callback and JAX's persistent compilation cache keeps it)."""
    values, flags = part
    raise_flagged(flags, messages, element=lambda run: f"Monte Carlo draw {start + run} of {n}")
    return values


def _fetch(out, keep, bar):
    host = jax.tree.map(lambda a: a[:keep], _to_host(out))
    if bar is not None:
        bar.update(keep)
    return host
