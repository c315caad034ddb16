"""Output helpers shared by the studies: Markdown tables, number formats, JSON-safe summaries."""

import math
import pathlib
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
    """A markdown table; a `|` inside a cell (e.g. `|dq|`) is escaped so that it does not split the cell."""

    def cell(c):
        return str(c).replace("|", "\\|")

    lines = ["| " + " | ".join(cell(c) for c in header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def text_table(header, rows, *, align: str = "left") -> str:
    """A console table: `header` and `rows` (sequences of the same length) in columns two spaces apart.

    `align`: "left" (trailing spaces stripped) or "right" (numbers line up on their last digit).
    """
    if align not in ("left", "right"):
        raise ValueError(f"`align` must be 'left' or 'right'; got {align!r}")
    widths = [max(len(str(r[c])) for r in [header, *rows]) for c in range(len(header))]
    pad = str.ljust if align == "left" else str.rjust
    fmt = lambda r: "  ".join(pad(str(v), w) for v, w in zip(r, widths)).rstrip()
    return "\n".join([fmt(header)] + [fmt(r) for r in rows])


#: Most decimals `fraction_pct` adds to keep a fraction off 0 % and 100 %.
MAX_DECIMALS = 6


def fraction_pct(v, *, digits: int = 0) -> str:
    """A fraction (0-1) as a percentage with `digits` decimals, never rounded onto 0 % or 100 % unless exact.

    100 v is printed with `digits` decimals; when 0 < v < 1 and that would
    print 0 or 100, decimals are added (up to `digits + MAX_DECIMALS`) until
    it does not: 995 successes in 1,000 runs print "99.5 %", 9,999 in 10,000
    "99.99 %", 1 failure in 10,000 "0.01 %", where the plain format prints
    "100 %" and "0 %". Only v == 1 prints "100 %" and only v == 0 "0 %".
    None prints "n/a"; NaN "nan %".

    Example:
        >>> from jaxsdp.studies._output import fraction_pct
        >>> fraction_pct(0.995), fraction_pct(1.0), fraction_pct(1 / 10_000, digits=1), fraction_pct(0.5)
        ('99.5 %', '100 %', '0.01 %', '50 %')
    """
    if v is None:
        return "n/a"
    v = float(v)
    if not math.isfinite(v):
        return "nan %"
    if isinstance(digits, bool) or not isinstance(digits, int) or digits < 0:
        raise ValueError(f"`digits` must be an integer >= 0; got {digits!r}")
    pct = 100.0 * v
    d = digits
    if 0.0 < v < 1.0:
        while d < digits + MAX_DECIMALS and float(f"{pct:.{d}f}") in (0.0, 100.0):
            d += 1
    return f"{pct:.{d}f} %"


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
        self.timings[stage] = self.timings.get(stage, 0.0) + time.perf_counter() - t0  # a repeated stage adds up
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


def figure_markdown(path, label: str | None = None) -> str:
    """A figure file in a markdown report: an image (PNG, SVG), or a link for a PDF, which markdown viewers do not
    display as an image; `label` defaults to the file's stem.

    Example:
        >>> from jaxsdp.studies._output import figure_markdown
        >>> figure_markdown("out/fig3.png"), figure_markdown("fig3.pdf")
        ('![fig3](fig3.png)', '[fig3 (PDF)](fig3.pdf)')
    """
    p = pathlib.Path(path)
    label = p.stem if label is None else label
    return f"[{label} (PDF)]({p.name})" if p.suffix.lower() == ".pdf" else f"![{label}]({p.name})"
