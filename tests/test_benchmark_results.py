"""The GPU table of the performance page is read from the saved benchmark logs: every row is found there."""

import importlib.util
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _results():
    spec = importlib.util.spec_from_file_location("bench_results", ROOT / "benchmarks" / "_results.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_gpu_table_reads_every_row_from_the_logs():
    results = _results()
    folder = results.GPU
    table = results.gpu_table(folder)
    rows = [ln for ln in table.splitlines() if ln.startswith("| ") and not ln.startswith("| task")]
    assert len(rows) >= 12, table
    kernels = results.kernel_rows(folder, "gpu.txt")
    one = kernels["dlr IRW, one series of 25,000"]
    assert one["parallel"] < one["sequential"]  # the parallel kernel is the GPU's
    assert results.fmt(one["parallel"]) in table
    env = results.environment(folder)
    assert env["device"] in table and env["jax"] in table
    mc = results.montecarlo_rows(folder)
    assert ("runner", 10_000) in mc and ("control", 10_000) in mc


def test_performance_page_takes_the_gpu_table_from_the_logs():
    page = (ROOT / "docs" / "performance.md").read_text()
    assert "{{ gpu_table }}" in page
    assert "not measured" not in page


def test_parsers_read_the_formats_the_benchmarks_print(tmp_path):
    results = _results()
    (tmp_path / "gpu.txt").write_text(
        "  task                                           sequential     parallel   seq/par   max rel. difference\n"
        "  dlr IRW, one series of 25,000                     2.37 ms    109.23 ms      0.02   6.3e-14   (x)\n"
        "  sdp, 2 terms, ML NVRs, 25,000                    5.781 s      16.15 ms    357.88   1.1e-14   (x)\n"
        "  EMPS pipeline after compile                  failed: ValueError: bad\n"
        "  EMPS closed loop 25 s at 1 kHz, one run           2.00 ms   (compile+first 0.2 s)\n"
    )
    rows = results.kernel_rows(tmp_path, "gpu.txt")
    assert abs(rows["dlr IRW, one series of 25,000"]["parallel"] - 109.23e-3) < 1e-15
    assert rows["sdp, 2 terms, ML NVRs, 25,000"]["sequential"] == 5.781
    assert rows["EMPS pipeline after compile"] == {"failed": "ValueError: bad"}
    assert abs(rows["EMPS closed loop 25 s at 1 kHz, one run"]["seconds"] - 2.0e-3) < 1e-15
