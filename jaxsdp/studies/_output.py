"""Output helpers shared by the studies: Markdown tables, number formats, JSON-safe summaries."""

import math

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
