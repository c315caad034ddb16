"""The GPU table of the performance page is read from the saved benchmark logs: every row is found there."""

import importlib.util
import json
import pathlib

import pytest

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


def _row(table, start):
    found = [ln for ln in table.splitlines() if ln.startswith(start)]
    assert len(found) == 1, (start, table)
    return found[0]


def test_gpu_table_reads_the_one_run_of_gpu_py_all():
    """The EMPS row, the closed loops and the peers from `gpu.txt`/`gpu.json`, the identification Monte Carlo from
    `montecarlo.txt` with command buffers off, and pinocchio's loop beside the robot regressor."""
    results = _results()
    folder = results.GPU
    table = results.gpu_table(folder)
    kernels = results.kernel_rows(folder, "gpu.txt")
    run = json.loads((folder / "gpu.json").read_text())
    rows = {r["task"]: r for r in run["rows"]}
    # the EMPS pipeline row of the same run (DATA_EMPS.mat), its compile + first call from gpu.json
    emps = kernels["EMPS pipeline after compile"]
    line = _row(table, "| EMPS pipeline on DATA_EMPS.mat")
    assert results.fmt(emps["parallel"]) in line and results.fmt(emps["sequential"]) in line
    assert f"{rows['EMPS pipeline after compile']['parallel_compile_first']:.3g} s" in line
    # the closed loops of the same run, not the first run's
    one = kernels["EMPS closed loop 25 s at 1 kHz, one run"]
    cpu = kernels["the same single run on the CPU device"]
    line = _row(table, "| EMPS closed loop 25 s at 1 kHz, one run")
    assert results.fmt(one["seconds"]) in line and results.fmt(cpu["seconds"]) in line
    # the 10,000-series batch is still the first run's out-of-memory
    assert "out of memory" in _row(table, "| `dlr` IRW, vmap 10,000 series")
    # the peers: gpu.json's rows of the group "peers", in the same process as the kernels
    peers = [r for r in run["rows"] if r.get("group") == "peers"]
    assert {r["task"].split()[0] for r in peers} == {"dynamax", "cuthbert"}
    assert "in the same `benchmarks/gpu.py` process" in table
    for r in peers:
        assert results.fmt(r["seconds"]) in _row(table, f"| {r['task']} |")
    assert not (folder / "peers.json").exists()  # superseded by gpu.json's peers
    # the identification Monte Carlo of the same run, with XLA's command buffers off
    mc = results.montecarlo_rows(folder)
    ident = [n for (task, n) in mc if task == "identification"]
    assert ident, "montecarlo.txt has no identification row"
    line = _row(
        table, f"| `identification_robustness`, {ident[0]:,} runs, compilation included (XLA command buffers off"
    )
    assert results.fmt(mc[("identification", ident[0])]) in line
    assert results.MONTECARLO_XLA_FLAGS in line and "CUDA graph" in line
    # pinocchio's loop on the same machine's CPU, with both ratios
    robot = json.loads((folder / "robot_stacked.json").read_text())
    pin = next(r for r in robot["rows"] if r["key"] == "pinocchio-regressor")
    line = _row(table, "| pinocchio's `computeJointTorqueRegressor`")
    assert results.fmt(pin["seconds"]) in line
    assert f"regressor {pin['regressor_ratio']:.2g} (issue 46's target: below 0.5, met)" in line
    assert f"regressor + IDIM-LS {pin['ratio']:.2g}" in line
    assert pin["regressor_ratio"] == pytest.approx(robot["regressor_s"] / pin["seconds"])


def test_gpu_table_falls_back_to_the_first_runs_closed_loops(tmp_path):
    """Without closed-loop rows in `gpu.txt` they come from `gpu-batch10000.txt`; without pinocchio, peers or the
    other sessions' files, their rows are left out."""
    results = _results()
    (tmp_path / "env.txt").write_text(
        "name, driver_version, memory.total [MiB]\nNVIDIA X, 1.0, 1000 MiB\n2026-01-02\njax 0.0.1 [CudaDevice(id=0)]\n"
    )
    head = "  task                                           sequential     parallel   seq/par   max rel. difference\n"
    (tmp_path / "gpu.txt").write_text(
        head + "  dlr IRW, one series of 25,000                   500.00 ms      4.00 ms    125.00   9.8e-14   (x)\n"
        "  dlr IRW, vmap 2,000 series of 25,000            900.00 ms     90.00 ms     10.00   1.9e-12   (x)\n"
        "  log-likelihood + jvp, 25,000                    300.00 ms     10.00 ms     30.00   1.1e-14   (x)\n"
        "  sdp, 2 terms, ML NVRs, 25,000                    6.000 s      16.00 ms    375.00   1.1e-14   (x)\n"
        "  EMPS pipeline after compile                     20.000 s     700.00 ms     28.57   8.4e-10   (x)\n"
    )
    (tmp_path / "gpu-batch10000.txt").write_text(
        head + "  dlr IRW, vmap 10,000 series of 25,000        failed: JaxRuntimeError: RESOURCE_EXHAUSTED: "
        "Out of memory while trying to allocate 96.86GiB with allocator GPU_0_bfc\n"
        "  EMPS closed loop 25 s at 1 kHz, one run         329.57 ms   (compile+first 1.1 s)\n"
        "  EMPS closed loop, vmap 10,000 runs              327.09 ms   (compile+first 1.4 s)\n"
        "    the same single run on the CPU device           3.08 ms\n"
    )
    (tmp_path / "robot_stacked.json").write_text(
        json.dumps(dict(states=1000, regressor_ls_s=2.0, regressor_s=0.05, compile_s=6.0, rows=[]))
    )
    table = results.gpu_table(tmp_path)
    assert "330 ms" in _row(table, "| EMPS closed loop 25 s at 1 kHz, one run")
    assert "3.08 ms" in table and "327 ms" in table
    assert "one 96.86GiB buffer" in table
    assert "700 ms" in _row(table, "| EMPS pipeline on DATA_EMPS.mat")
    assert "pinocchio" not in table and "smoother" not in table and "EMPSPipeline" not in table


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
