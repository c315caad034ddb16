"""The `jaxsdp emps` command end to end (issue 6).

`main([...])` runs in-process so that every run shares JAX's compilations: the
built-in plant has the real file's length (24,841 samples), so the real-file
and CSV runs reuse its compiled kernels. The built-in plant runs with its
default settings (full 24.8 s record).
"""

import contextlib
import io
import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import scipy.io

from helpers import EMPS_MAT, requires_emps
from jaxsdp._cli import main
from jaxsdp._cli.common import Progress
from jaxsdp.data import EMPS_BUILTIN_TRUTH, emps_builtin_data
from jaxsdp.data._emps_builtin import BUILTIN_SAMPLES
from jaxsdp.studies.emps import FIGURE_NAMES

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SUMMARY_KEYS = {
    "idim_ls": {"M", "Fv", "Fc", "offset", "relative_error"},
    "idim_ls_asym": {"M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg", "relative_error"},
    "sdp": {"nvr_mass", "nvr_friction", "mass_constant", "relative_error"},
    "simulation": {"position", "velocity", "acceleration", "force"},
    "data": {"source", "samples", "sample_time"},
}
STAGES = {"derivatives", "identification", "simulation", "figures", "total"}


def run(args):
    """`main(args)` with stdout and stderr captured; returns (code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return code, out.getvalue(), err.getvalue()


def summary_warnings(out_dir):
    return json.loads((out_dir / "summary.json").read_text())["warnings"]


def check_outputs(out_dir):
    summary = json.loads((out_dir / "summary.json").read_text())
    for key, fields in SUMMARY_KEYS.items():
        assert fields <= set(summary[key]), (key, set(summary[key]))
    assert STAGES <= set(summary["timings"])
    assert all(v >= 0 for v in summary["timings"].values())
    report = (out_dir / "report.md").read_text()
    for name in FIGURE_NAMES:
        png = out_dir / f"{name}.png"
        assert png.stat().st_size > 10_000
        assert png.read_bytes()[:8] == PNG_MAGIC
        assert f"]({name}.png)" in report  # embedded with a relative link
    for needle in ("Table 1", "Table 2", "SDP stage", "Findings", "Mass constancy at neighbouring decimation factors"):
        assert needle in report
    # the mass finding is stated with its evidence, or called fragile when the decimation check disagrees
    assert "Mass is acceleration-independent" in report or "Mass constancy is NOT established robustly" in report
    return summary, report


@pytest.fixture(scope="module")
def builtin(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("cli") / "emps-out"  # does not exist yet; its parent does
    code, stdout, stderr = run(["emps", "--out", str(out_dir)])
    return code, stdout, stderr, out_dir


# --------------------------------------------------------------------------- #
# Built-in plant
# --------------------------------------------------------------------------- #


def test_builtin_run_writes_everything(builtin):
    code, stdout, stderr, out_dir = builtin
    assert code == 0, stderr
    assert "[1/" not in stderr and "error:" not in stderr  # no progress display: not a terminal
    # the study's warnings, one line each (the friction NVR on its cap, the fragile mass flag, the LS bias)
    lines = [ln for ln in stderr.splitlines() if ln]
    assert lines and all(ln.startswith("jaxsdp emps: warning: ") for ln in lines), stderr
    assert summary_warnings(out_dir) == [ln.removeprefix("jaxsdp emps: warning: ") for ln in lines]
    assert not list(out_dir.parent.glob(".jaxsdp-*"))  # the staging folder is gone
    summary, report = check_outputs(out_dir)
    for needle in ("Table 1. IDIM-LS", "Table 2. IDIM-SDP", "recovered vs true", "Closed-loop simulation"):
        assert needle in stdout
    assert summary["data"]["samples"] == BUILTIN_SAMPLES
    assert summary["data"]["sample_time"] == pytest.approx(1e-3)
    assert summary["data"]["seed"] == 0
    assert summary["truth"] == pytest.approx({**EMPS_BUILTIN_TRUTH, "fv_ratio": 240.4 / 166.7})
    assert "truth" in report and "Recovery" in report


def test_builtin_recovers_true_parameters(builtin):
    # Issue item 3: M within 1 %, each asymmetric friction coefficient within 5 %,
    # Fv-/Fv+ within 5 %, mass flagged constant.
    summary = json.loads((builtin[3] / "summary.json").read_text())
    truth = summary["truth"]
    assert summary["sdp"]["mass_constant"] is True
    assert summary["sdp"]["nvr_mass"] < 1e-6
    for key in ("idim_ls_asym", "idim_sdp"):
        est = summary[key]
        assert est["M"] == pytest.approx(truth["M"], rel=0.01), key
        for name in ("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"):
            assert est[name] == pytest.approx(truth[name], rel=0.05), (key, name)
        assert est["Fv_neg"] / est["Fv_pos"] == pytest.approx(truth["fv_ratio"], rel=0.05), key
    assert summary["recovery"]["within_tolerances"] is True
    # the asymmetry is detected: the linear model fits worse than the asymmetric one
    assert summary["idim_ls_asym"]["relative_error"] < 0.8 * summary["idim_ls"]["relative_error"]


def test_builtin_simulation_check(builtin):
    sim = json.loads((builtin[3] / "summary.json").read_text())["simulation"]
    # the linear-friction model simulated against the asymmetric plant: close, not exact
    assert 0 < sim["position"] < 0.02
    assert 0 < sim["velocity"] < 0.3
    assert 0 < sim["acceleration"] < 10
    assert 0 < sim["force"] < 6


def test_builtin_seed_changes_the_noise_only():
    a, truth, _ = emps_builtin_data(0)
    b, _, desc = emps_builtin_data(1)
    assert desc["seed"] == 1 and truth["M"] == EMPS_BUILTIN_TRUTH["M"]
    np.testing.assert_array_equal(a.qg, b.qg)
    assert not np.array_equal(np.asarray(a.qm), np.asarray(b.qm))
    q = 5e-8  # encoder count: quantised measured position, noise at the count level
    np.testing.assert_allclose(np.asarray(a.qm) / q, np.round(np.asarray(a.qm) / q), atol=1e-6)
    assert np.abs(np.asarray(a.qm) - np.asarray(b.qm)).max() < 20 * q


# --------------------------------------------------------------------------- #
# Real data and CSV
# --------------------------------------------------------------------------- #


@requires_emps
def test_real_file_matches_published_idim_ls(tmp_path):
    out_dir = tmp_path / "real"
    code, stdout, stderr = run(["emps", "--data", str(EMPS_MAT), "--out", str(out_dir), "--quiet"])
    assert code == 0, stderr
    summary, _ = check_outputs(out_dir)
    ls = summary["idim_ls"]
    for name, ref in dict(M=95.1089, Fv=203.5034, Fc=20.3935, offset=-3.1648).items():
        assert ls[name] == pytest.approx(ref, rel=1e-4), name
    assert ls["relative_error"] == pytest.approx(4.083, abs=0.005)
    asym = summary["idim_ls_asym"]
    for name, ref in dict(M=95.1540, Fv_pos=166.7061, Fc_pos=20.1440, Fv_neg=240.4236, Fc_neg=20.6277).items():
        assert asym[name] == pytest.approx(ref, rel=1e-4), name
    assert summary["sdp"]["mass_constant"] is True
    assert summary["truth"] is None
    assert summary["data"]["source"] == "DATA_EMPS.mat"
    # closed-loop simulation check (published Simulink: 0.0138 / 0.229 / 8.60 / 5.85 %)
    sim = summary["simulation"]
    assert sim["position"] <= 0.02 and sim["velocity"] <= 0.3
    assert sim["acceleration"] <= 10.0 and sim["force"] <= 6.0
    assert "95.1089" in stdout and "4.0834 %" in stdout


def test_csv_file_runs_without_simulation_check(tmp_path):
    data, _, _ = emps_builtin_data(0)
    path = tmp_path / "meas.csv"
    cols = np.column_stack([np.asarray(data.t), np.asarray(data.qm), np.asarray(data.force)])
    np.savetxt(path, cols, delimiter=",", header="t,q,force", comments="", fmt="%.12g")
    code, stdout, stderr = run(["emps", "--data", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    assert code == 0, stderr
    summary, _ = check_outputs(tmp_path / "out")
    assert all(summary["simulation"][k] is None for k in SUMMARY_KEYS["simulation"])
    assert "skipped" in summary["simulation"] and "skipped" in stdout
    assert summary["idim_ls_asym"]["M"] == pytest.approx(EMPS_BUILTIN_TRUTH["M"], rel=0.01)
    # IDIM-IV simulates the closed loop: a t, q, force record cannot carry it (a usage error, before any work)
    code, _, stderr = run(["emps", "--data", str(path), "--estimator", "iv", "--out", str(tmp_path / "iv")])
    assert code == 2 and "--estimator ls only" in stderr and not (tmp_path / "iv").exists()


# --------------------------------------------------------------------------- #
# Errors: non-zero exit, one line on stderr, no traceback
# --------------------------------------------------------------------------- #


def _emps_mat(path, n=3000):
    t = np.arange(n) * 1e-3
    qg = 0.01 * np.sin(2 * np.pi * t)
    scipy.io.savemat(
        path,
        dict(t=t[:, None], qm=qg[:, None], qg=qg[:, None], vir=np.cos(t)[:, None], gtau=35.15, kp=160.18, kv=243.45),
    )
    return path


def _bad_inputs(tmp_path):
    truncated = tmp_path / "truncated.mat"
    raw = _emps_mat(tmp_path / "full.mat").read_bytes()
    truncated.write_bytes(raw[: len(raw) // 2])
    other = tmp_path / "other.mat"
    scipy.io.savemat(other, dict(x=np.arange(10.0), y=np.ones((3, 3))))
    text = tmp_path / "text.mat"
    text.write_text("this is not a MATLAB file\n")
    nan = tmp_path / "nan.mat"
    d = scipy.io.loadmat(_emps_mat(tmp_path / "tmp.mat"))
    d["qm"][5] = np.nan
    scipy.io.savemat(nan, {k: v for k, v in d.items() if not k.startswith("__")})
    short = _emps_mat(tmp_path / "short.mat", n=60)
    csv = tmp_path / "bad.csv"
    csv.write_text("t,q,force\n0,0,1\n0.001,abc,2\n")
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    return {
        "missing file": ["--data", str(tmp_path / "nope.mat")],
        "directory as data": ["--data", str(tmp_path)],
        "truncated .mat": ["--data", str(truncated)],
        "non-EMPS .mat": ["--data", str(other)],
        "not a .mat": ["--data", str(text)],
        "NaN in .mat": ["--data", str(nan)],
        "too short": ["--data", str(short)],
        "malformed CSV": ["--data", str(csv)],
        "empty CSV": ["--data", str(empty)],
        "missing out parent": ["--out", str(tmp_path / "no" / "such" / "dir")],
        "out is a file": ["--out", str(a_file)],
        "negative decimate": ["--decimate", "-3"],
        "zero decimate": ["--decimate", "0"],
        "non-integer decimate": ["--decimate", "2.5"],
        "huge decimate": ["--decimate", "100000"],
        "cutoff above Nyquist": ["--cutoff", "600"],
        "cutoff at Nyquist": ["--cutoff", "500"],
        "negative cutoff": ["--cutoff", "-5"],
        "nan cutoff": ["--cutoff", "nan"],
        "negative seed": ["--seed", "-1"],
        "unknown option": ["--frobnicate"],
    }


BAD_CASES = [
    "missing file",
    "directory as data",
    "truncated .mat",
    "non-EMPS .mat",
    "not a .mat",
    "NaN in .mat",
    "too short",
    "malformed CSV",
    "empty CSV",
    "missing out parent",
    "out is a file",
    "negative decimate",
    "zero decimate",
    "non-integer decimate",
    "huge decimate",
    "cutoff above Nyquist",
    "cutoff at Nyquist",
    "negative cutoff",
    "nan cutoff",
    "negative seed",
    "unknown option",
]


@pytest.mark.parametrize("case", BAD_CASES)
def test_errors_are_one_line_without_traceback(case, tmp_path, capsys):
    args = _bad_inputs(tmp_path)[case]
    out_dir = [] if "--out" in args else ["--out", str(tmp_path / "out")]
    code = main(["emps", *args, *out_dir, "--quiet"])
    captured = capsys.readouterr()
    assert code != 0
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("jaxsdp emps: error: "), lines[0]
    assert "Traceback" not in captured.err + captured.out
    assert not (tmp_path / "out" / "summary.json").exists()


def test_error_messages_name_the_problem(tmp_path, capsys):
    cases = _bad_inputs(tmp_path)
    expect = {
        "missing file": "no such file",
        "truncated .mat": "could not read",
        "non-EMPS .mat": "not an EMPS data set",
        "missing out parent": "does not exist",
        "negative decimate": "--decimate",
        "cutoff above Nyquist": "Nyquist",
    }
    for case, needle in expect.items():
        main(["emps", *cases[case], "--quiet"] + ([] if "--out" in cases[case] else ["--out", str(tmp_path / "o")]))
        assert needle in capsys.readouterr().err, case


def test_usage_errors_without_subcommand(capsys):
    assert main([]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jaxsdp: error:")
    assert main(["emps", "--help"]) == 0
    assert "--decimate" in capsys.readouterr().out


def test_progress_display():
    stream = io.StringIO()
    p = Progress(["a", "b"], enabled=True, stream=stream)
    p.start("a")
    p.start("b")
    p.done()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2 and lines[0].startswith("[1/2]") and lines[1].endswith(" s")
    quiet = io.StringIO()
    p = Progress(["a"], enabled=False, stream=quiet)
    p.start("a")
    p.done()
    assert quiet.getvalue() == ""


def test_python_dash_m():
    res = subprocess.run(
        [sys.executable, "-m", "jaxsdp", "emps", "--help"], capture_output=True, text=True, timeout=120, check=False
    )
    assert res.returncode == 0, res.stderr
    assert "usage: jaxsdp emps" in res.stdout


@pytest.mark.parametrize(
    "command,delay",
    [
        (["emps"], 1.0),
        (["emps"], 3.0),
        (["control"], 3.0),
        (["montecarlo", "--study", "identification", "--runs", "4096"], 5.0),
        (["montecarlo", "--study", "identification", "--runs", "4096"], 20.0),
    ],
)
def test_ctrl_c_exits_130_and_leaves_nothing(tmp_path, command, delay):
    """SIGINT during a run: "interrupted", exit 130 (never a crash), no output folder, no staging left (issue 29).

    The console command ends the process with `os._exit(130)` after cleaning up (`jaxsdp._cli.run`), so
    the interpreter's teardown never runs under XLA's worker threads; when the main thread is inside a
    compiled computation (a Monte Carlo chunk of 1024 runs), a watchdog thread does it within 2 s."""
    import signal

    out = tmp_path / "out"
    # the child as a terminal's foreground job gets it: Python's own SIGINT handler. A test process started in
    # the background (`nohup ... &`, a CI runner) ignores SIGINT, its children inherit that, and Python keeps an
    # inherited SIG_IGN, so the signal below would be discarded and the run would go on to its end
    launcher = (
        "import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
        "runpy.run_module('jaxsdp', run_name='__main__', alter_sys=True)"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", launcher, *command, "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONFAULTHANDLER="1"),  # SIGABRT then prints every thread's stack (see below)
    )
    try:
        # the run has started once its staging folder exists (Ctrl-C during the imports before it is
        # Python's own: killed by SIGINT, which a shell also reports as 130)
        started = time.monotonic()
        while not list(tmp_path.glob(".jaxsdp-*")) and proc.poll() is None and time.monotonic() - started < 120:
            time.sleep(0.05)
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        sent = time.monotonic()
        try:
            _, stderr = proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            # no exit 2 min after Ctrl-C (seen under a loaded machine, 2026-11-27): every thread's stack, for the log
            proc.send_signal(signal.SIGABRT)
            _, stacks = proc.communicate(timeout=60)
            pytest.fail(f"no exit 120 s after SIGINT; the threads' stacks at SIGABRT:\n{stacks[-8000:]}")
        waited = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    if proc.returncode == 0:  # finished before the signal (a fast machine): nothing to test at this delay
        pytest.skip(f"the run ended within {delay} s")
    assert proc.returncode == 130, stderr[-2000:]
    assert stderr.count("jaxsdp: interrupted") == 1, stderr[-2000:]
    assert not out.exists() and not list(tmp_path.glob(".jaxsdp-*"))
    # inside a compiled Monte Carlo chunk the watchdog ends the run after INTERRUPT_GRACE (2 s), not the chunk
    assert waited < 30.0, waited


def test_mis_scaled_record_does_not_reproduce_and_warns(tmp_path):
    """A logger's own units (position in micrometres, drive signal x 100): the closed-loop simulation of the
    identified model cannot reproduce the data, and the study says so (issue 29): a warning, and the finding
    reads "does NOT reproduce" with its test's limits, never "reproduces"."""
    from jaxsdp.data import emps_builtin_data

    data = emps_builtin_data(0)[0]
    mat = tmp_path / "scaled.mat"
    columns = dict(t=data.t, qm=1e6 * np.asarray(data.qm), qg=1e6 * np.asarray(data.qg), vir=100 * np.asarray(data.vir))
    scipy.io.savemat(
        mat, {k: np.asarray(v)[:, None] for k, v in columns.items()} | dict(gtau=data.gtau, kp=data.kp, kv=data.kv)
    )
    out = tmp_path / "out"
    code, stdout, stderr = run(["emps", "--data", str(mat), "--out", str(out), "--quiet", "--no-decimation-check"])
    assert code == 0, stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["simulation"]["reproduces"] is False and "position" in summary["simulation"]["failed"]
    assert any(
        w.startswith("closed-loop simulation: the identified IDIM-LS model does not reproduce")
        for w in summary["warnings"]
    )
    assert "does NOT reproduce the data" in stdout and "reproduces the data" not in stdout
    assert "jaxsdp emps: warning: closed-loop simulation" in stderr


# --------------------------------------------------------------------------- #
# Files a user exports every day (issue 29)
# --------------------------------------------------------------------------- #


def _builtin_columns():
    from jaxsdp.data import emps_builtin_data

    data = emps_builtin_data(0)[0]
    return data, np.asarray(data.t), np.asarray(data.qm), np.asarray(data.force)


def test_loader_accepts_bom_semicolons_and_float32_time(tmp_path):
    from jaxsdp.data import load_emps, load_measurements

    data, t, q, f = _builtin_columns()
    rows = "".join(f"{a:.6f};{b:.9e};{c:.6f}\n" for a, b, c in zip(t[:2000], q[:2000], f[:2000]))
    csv_file = tmp_path / "export.csv"
    csv_file.write_bytes(("\ufeffT;Q;Force\n" + rows).encode("utf-8"))  # spreadsheet export: BOM, semicolons
    m = load_measurements(csv_file, time="T", position="Q", force="Force")
    assert m.q.shape == (2000,) and m.dt == pytest.approx(1e-3) and m.resampled is None
    # time written to the millisecond (its resolution is the step itself): a missing sample is still refused
    coarse = tmp_path / "coarse.csv"
    keep = np.r_[0:700, 701:2000]
    coarse.write_text(
        "t,q,force\n" + "".join(f"{a:.3f},{b:.9e},{c:.6f}\n" for a, b, c in zip(t[keep], q[keep], f[keep]))
    )
    with pytest.raises(ValueError, match="not uniformly sampled: sample 700"):
        load_measurements(coarse)
    # float32 time: 2,546 of 24,840 steps "deviate" by its rounding (1.9e-6 s near 25 s), not by jitter
    mat = tmp_path / "single.mat"
    record = dict(
        time=t.astype(np.float32), qm=data.qm, qg=data.qg, vir=data.vir, gtau=data.gtau, kp=data.kp, kv=data.kv
    )
    scipy.io.savemat(mat, {k: np.asarray(v) for k, v in record.items()})
    e = load_emps(mat, variables={"t": "time"})
    assert e.resampled is None and e.dt == pytest.approx(1e-3, rel=1e-6)
    # a real gap is still refused, and the message names the resolution it allowed for
    gap = dict(record, time=np.delete(t, 5000).astype(np.float32), qm=np.delete(data.qm, 5000))
    gap.update(qg=np.delete(data.qg, 5000), vir=np.delete(data.vir, 5000))
    scipy.io.savemat(mat, {k: np.asarray(v) for k, v in gap.items()})
    with pytest.raises(ValueError, match="resolution of the stored time values"):
        load_emps(mat, variables={"t": "time"})


def test_cli_maps_columns_and_variables(tmp_path):
    data, t, q, f = _builtin_columns()
    csv_file = tmp_path / "export.csv"
    rows = "".join(f"{a:.4f};{b:.9e};{c:.6f}\n" for a, b, c in zip(t, q, f))
    csv_file.write_bytes(("\ufeffT;Q;Force\n" + rows).encode("utf-8"))
    out = tmp_path / "csv"
    code, stdout, stderr = run(
        ["emps", "--data", str(csv_file), "--columns", "T,Q,Force", "--out", str(out), "--quiet"]
    )
    assert code == 0, stderr
    assert json.loads((out / "summary.json").read_text())["idim_ls_asym"]["M"] == pytest.approx(95.4, abs=0.2)
    mat = tmp_path / "renamed.mat"
    names = dict(
        time=t.astype(np.float32), pos=data.qm, ref=data.qg, u=data.vir, gtau=data.gtau, kp=data.kp, kv=data.kv
    )
    scipy.io.savemat(mat, {k: np.asarray(v) for k, v in names.items()})
    out = tmp_path / "mat"
    mapping = "t=time,qm=pos,qg=ref,vir=u"
    code, stdout, stderr = run(["emps", "--data", str(mat), "--variables", mapping, "--out", str(out), "--quiet"])
    assert code == 0, stderr
    assert json.loads((out / "summary.json").read_text())["simulation"]["reproduces"] is True
    code, _, stderr = run(["emps", "--data", str(mat), "--out", str(tmp_path / "x"), "--quiet"])
    assert code == 1 and "--variables (t=time, qm=pos" in stderr  # the error says how to map


def test_time_in_milliseconds_gets_a_hint(tmp_path):
    data, t, q, f = _builtin_columns()
    csv_file = tmp_path / "ms.csv"
    np.savetxt(csv_file, np.c_[1e3 * t, q, f], delimiter=",", header="t,q,force", comments="")
    code, _, stderr = run(["emps", "--data", str(csv_file), "--out", str(tmp_path / "o"), "--quiet"])
    assert code == 2 and "if the time column is in milliseconds, give it in seconds (--scale time=1e-3)" in stderr
    # the same file read with the factors: ms -> s, and a force column in kN -> N
    np.savetxt(csv_file, np.c_[1e3 * t, q, 1e-3 * f], delimiter=",", header="t,q,force", comments="")
    out = tmp_path / "scaled"
    argv = ["emps", "--data", str(csv_file), "--scale", "time=1e-3,force=1e3", "--out", str(out), "--quiet"]
    code, _, stderr = run(argv + ["--no-decimation-check"])
    assert code == 0, stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["idim_ls_asym"]["M"] == pytest.approx(95.4, abs=0.2)
    code, _, stderr = run(["emps", "--data", str(csv_file), "--scale", "time=-1", "--out", str(tmp_path / "b")])
    assert code == 2 and "positive for time" in stderr
