"""The benchmarks' JSON output: rows written as they are measured, so a run cut by a time limit keeps its figures."""

import datetime
import json
import pathlib
import platform
import statistics
import subprocess
import time

import jax


def timings(fn, repeats: int, ready=lambda out: out):
    """(last output, seconds of the first call, seconds of each of `repeats` further calls): each call's
    `ready(output)` blocked on, the first call (compilation, caches) timed apart. The benchmarks' one timing
    loop; each reads its own figures from it (median, min, first minus median)."""
    t0 = time.perf_counter()
    out = fn()
    jax.block_until_ready(ready(out))
    first = time.perf_counter() - t0
    runs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        jax.block_until_ready(ready(out))
        runs.append(time.perf_counter() - t0)
    return out, first, runs


def timed(fn, repeats: int) -> tuple[float, float]:
    """(median seconds of `repeats` calls, seconds of the first call) (`timings`)."""
    _, first, runs = timings(fn, repeats)
    return statistics.median(runs), first


class Recorder:
    """Collect a benchmark's rows; with a path, rewrite the JSON file after every row.

    The file holds the benchmark's name, the date (UTC), the device (e.g.
    "NVIDIA H200" or "cpu"), the backend, the JAX and Python versions, the
    options and the rows (dicts of seconds and other figures).
    """

    def __init__(self, benchmark: str, path: pathlib.Path | None, **options):
        self.path = path
        dev = jax.devices()[0]
        self.doc = dict(
            benchmark=benchmark,
            date=datetime.datetime.now(datetime.timezone.utc).date().isoformat(),
            device=getattr(dev, "device_kind", str(dev)),
            backend=jax.default_backend(),
            jax=jax.__version__,
            python=platform.python_version(),
            machine=f"{platform.machine()}, {_cores()} cores",
            commit=_commit(),
            options=options,
            rows=[],
        )

    def add(self, **row):
        """One row (keyword fields; give `key=`, a short name without spaces, for the docs to quote it by)."""
        self.doc["rows"].append({k: _plain(v) for k, v in row.items()})
        if self.path is not None:
            self.path.write_text(json.dumps(self.doc, indent=1) + "\n")


def _plain(v):
    try:
        return float(v) if not isinstance(v, (str, bool, int, type(None))) else v
    except (TypeError, ValueError):
        return str(v)


def _cores() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


def _commit() -> str | None:
    """The checkout's commit, `+` when it has uncommitted changes (None outside a git checkout)."""
    root = pathlib.Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True)
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"], cwd=root, capture_output=True, text=True
        )
    except OSError:
        return None
    return head.stdout.strip() + ("+" if dirty.stdout.strip() else "") if head.returncode == 0 else None
