"""Output helpers shared by the studies: Markdown tables, number formats, JSON-safe summaries."""

import math
import time

import equinox as eqx
import jax
import numpy as np


def finite_or_none(x):
    if isinstance(x, dict):
        return {k: finite_or_none(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [finite_or_none(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def sci(x) -> str:
    """1e-06 -> 1e-6, 3.84e-12 -> 3.8e-12."""
    m, e = f"{x:.1e}".split("e")
    m = m.removesuffix(".0")
    return f"{m}e{int(e)}"


def md_table(header, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def one_line(e) -> str:
    text = " ".join(str(e).split())
    return text if text else type(e).__name__


class StageTimer:
    """Runs a study's stages one by one: announces each (`progress(stage)`), waits for its arrays
    (`block_until_ready`, so that the time is the stage's, not a later one's) and records its wall time
    in `timings[stage]` (s)."""

    def __init__(self, progress=None, timings=None):
        self.note = progress if progress is not None else (lambda stage: None)
        self.timings = {} if timings is None else timings
        self.start = time.perf_counter()

    def __call__(self, stage: str, fn):
        self.note(stage)
        t0 = time.perf_counter()
        out = fn()
        jax.block_until_ready(jax.tree.leaves(eqx.filter(out, eqx.is_array)))
        self.timings[stage] = time.perf_counter() - t0
        return out

    def total(self) -> dict:
        """Records `total`, the time since the timer was made, and returns the timings."""
        self.timings["total"] = time.perf_counter() - self.start
        return self.timings


def percentiles(v) -> dict:
    """mean, std, p05, p95 of the finite values of `v` (None each when there are none)."""
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return dict(mean=None, std=None, p05=None, p95=None)
    p05, p95 = np.percentile(v, [5, 95])
    return dict(mean=float(v.mean()), std=float(v.std()), p05=float(p05), p95=float(p95))
