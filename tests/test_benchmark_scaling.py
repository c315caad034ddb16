"""The performance page's "How the cost grows" comes from the saved run of `benchmarks/scaling.py` (issue 46).

Its tables (`{{ bench-table scaling TASK }}`) and figures (drawn by `docs/hooks.py`) are made from
`benchmarks/results/cpu/scaling.json` at build time; these tests check that every table and figure the page shows
is there, and the parts of the script that decide what a row says (slopes, summaries, failed rows), without running
the benchmark.
"""

import importlib.util
import pathlib
import re
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "performance.md"


def _load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


results = _load("bench_results_scaling", ROOT / "benchmarks" / "_results.py")
scaling = _load("bench_scaling", ROOT / "benchmarks" / "scaling.py")


def test_every_table_on_the_page_has_a_row_per_size_run():
    tables = results.TABLE.findall(PAGE.read_text())
    assert {task for _, task in tables} == set(scaling.SERIES), tables
    for name, task in tables:
        doc = results.bench(name)
        table = results.scaling_table(doc, task)
        lines = [ln for ln in table.splitlines() if ln.startswith("| ")]
        sizes = sorted({r["size"] for r in doc["rows"] if r["task"] == task and not r["key"].endswith("-summary")})
        assert len(lines) == 1 + len(sizes), table  # the header and one line per size
        assert all(f"| {n:,} |" in table for n in sizes)
    assert "{{ bench-table" not in results.render_quotes("{{ bench-table scaling dlr }}")


def test_the_figures_the_page_shows_are_drawn_from_the_saved_run():
    hooks = _load("docs_hooks_scaling", ROOT / "docs" / "hooks.py")
    figures = hooks.scaling_figures()
    shown = set(re.findall(r"\(generated/scaling/([\w-]+)\.png\)", PAGE.read_text()))
    assert shown == set(figures) == set(scaling.SERIES)
    for task, fig in figures.items():
        time_axes, memory_axes = fig.axes
        assert len(time_axes.get_lines()) >= len(scaling.SERIES[task]), task  # a line per series (and linear)
        assert time_axes.get_xscale() == time_axes.get_yscale() == memory_axes.get_yscale() == "log"


def test_slopes_summaries_and_failed_rows():
    a = dict(size=1000, seconds=0.01)
    b = dict(size=10_000, seconds=1.0)
    assert scaling.slope(a, b) == pytest.approx(2.0)  # 100x the time for 10x the work
    assert scaling.slope(a, dict(size=10_000, error="killed by signal 9")) is None
    rows = [dict(a, slope=None, peak_rss_gb=0.3), dict(b, slope=2.0, peak_rss_gb=0.5)]
    rows += [dict(size=100_000, error="killed by signal 9", peak_rss_gb=20.0), dict(size=10**6, error="not run: x")]
    s = scaling.summary(rows)
    assert (s["runs"], s["largest"], s["failed_at"], s["max_slope"], s["last_slope"]) == (2, 10_000, 100_000, 2, 2)
    assert scaling.predicted_gb(3_600_000) == pytest.approx(2 * 3.6e6 * 144 * 8 / 1024**3)
    doc = {
        "rows": [
            dict(key="x-1", task="x", series="jaxsdp", label="ours", unit="runs", size=1, seconds=0.5, peak_rss_gb=1),
            dict(key="x-2", task="x", series="jaxsdp", label="ours", unit="runs", size=2, error="a|b", peak_rss_gb=2),
            dict(key="x-summary", task="x", series="jaxsdp", runs=1),
        ],
        "notes": {"x": ["peer: not measured"]},
    }
    table = results.scaling_table(doc, "x")
    assert "| 2 | failed: a\\|b (peak 2.00 GB) |" in table and "Note: peer: not measured." in table
    with pytest.raises(KeyError, match="tasks: x"):
        results.scaling_table(doc, "dlr")


def test_a_row_over_its_time_limit_is_a_row_with_its_error():
    row = scaling.measure("dlr", "jaxsdp", 1000, limit=0.2)
    assert row["error"] == "stopped at the 0.2 s limit" and row["peak_rss_gb"] > 0
    row = scaling.measure("robot-joints", "pinocchio", 2, limit=60, urdf="/nonexistent.urdf")
    assert "seconds" not in row and row["error"] and row["peak_rss_gb"] > 0
