"""Results a user can trust: `jaxsdp emps` refuses irregular sampling and degenerate data up front,
checks the output folder before any work, never leaves half-written outputs, and prints library
warnings as one line each.

The bad-input cases fail before the study runs (the study and the plant simulation are replaced by
functions that fail the test if called); one case runs the full built-in study and fails while
writing the figures.
"""

import contextlib
import io
import os
import pathlib
import tempfile
import time
import warnings

import numpy as np
import pytest

import jaxsdp._cli.common as cli_common
import jaxsdp._cli.emps as cli_emps
from helpers import EMPS_MAT, requires_emps
from jaxsdp._cli import main
from jaxsdp._cli.common import CLIError, OutputFolder
from jaxsdp.data import Measurements, emps_builtin_data, load_emps
from jaxsdp.plants.emps._checks import MIN_MOVING, check_emps_data

PREFIX = "jaxsdp emps: error: "


def run(args):
    """`main(args)` with stdout and stderr captured; returns (code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return code, out.getvalue(), err.getvalue()


def one_line_error(code, stdout, stderr, prefix=PREFIX):
    assert code != 0
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith(prefix), lines[0]
    assert "Traceback" not in stderr + stdout and ".py" not in stderr and "warning" not in stderr.lower()
    return lines[0]


def assert_nothing_left(out_dir: pathlib.Path):
    """--out absent or empty, and no staging folder left beside it."""
    assert not out_dir.exists() or not any(out_dir.iterdir()), sorted(out_dir.iterdir())
    assert not list(out_dir.parent.glob(".jaxsdp-*"))


@pytest.fixture
def no_study(monkeypatch):
    """Fail the test if the plant simulation or the study starts."""

    def forbidden(*args, **kwargs):
        pytest.fail("the study started: the check should have come first")

    monkeypatch.setattr(cli_emps, "emps_study", forbidden)  # it simulates the built-in plant too


@pytest.fixture(scope="module")
def builtin():
    data, _, _ = emps_builtin_data(0)
    return np.asarray(data.t), np.asarray(data.qm), np.asarray(data.force)


def write_csv(path, t, q, force):
    np.savetxt(path, np.column_stack([t, q, force]), delimiter=",", header="t,q,force", comments="", fmt="%.12g")
    return path


# --------------------------------------------------------------------------- #
# Irregular sampling
# --------------------------------------------------------------------------- #


def test_gap_is_refused_naming_the_first_bad_sample(builtin, tmp_path, no_study):
    t, q, f = builtin
    t = t.copy()
    t[10001:] += 1.0  # a 1 s gap after sample 10,000 (0-based indices)
    path = write_csv(tmp_path / "gap.csv", t, q, f)
    out_dir = tmp_path / "out"
    line = one_line_error(*run(["emps", "--data", str(path), "--out", str(out_dir)]))
    assert "gap.csv" in line and "not uniformly sampled" in line
    assert "sample 10001 (0-based, t = 11.001 s)" in line and "1.001 s after sample 10000" in line
    assert "median step is 0.001 s" in line and "--resample" in line
    assert_nothing_left(out_dir)


def test_resample_flag_hands_uniform_data_to_the_study(builtin, tmp_path, monkeypatch):
    t, q, f = builtin
    n = 12_000
    t = t[:n].copy()
    t[6001:] += 0.02  # a 20 ms gap, bridged by interpolation
    seen = {}

    def fake_study(data, **kwargs):
        seen["data"] = data
        raise ValueError("stop here")

    monkeypatch.setattr(cli_emps, "emps_study", fake_study)
    path = write_csv(tmp_path / "gap.csv", t, q[:n], f[:n])
    code, stdout, stderr = run(["emps", "--data", str(path), "--out", str(tmp_path / "out"), "--resample"])
    assert code == 1 and stderr.strip().splitlines()[-1] == f"{PREFIX}stop here"
    assert "note: resampled 12000 irregular samples" in stderr
    data = seen["data"]
    assert isinstance(data, Measurements) and data.dt == pytest.approx(1e-3)
    assert data.t.shape == (n + 20,) and data.resampled.startswith("resampled 12000")
    assert_nothing_left(tmp_path / "out")


# --------------------------------------------------------------------------- #
# Degenerate data: one line, before any work
# --------------------------------------------------------------------------- #


def _degenerate(builtin, case):
    t, q, f = builtin
    if case == "all-zero force":
        return t, q, np.zeros_like(f), "the force is zero in all 24792 samples kept"
    if case == "constant force":
        return t, q, np.full_like(f, 3.5), "the force is constant (3.5)"
    if case == "constant position":
        return t, np.full_like(q, 0.1), f, "the position is constant (0.1)"
    if case == "one direction only":  # a single 0.1 s move forward, at rest otherwise
        p = np.full_like(q, q[0])
        p[5000:5100] = np.linspace(q[0], q[0] + 0.01, 100)
        p[5100:] = q[0] + 0.01
        return t, p, f, "too few moving samples: 108 move forward and 0 backward"
    if case == "few moving samples":  # short back-and-forth moves: 50 samples each way
        p = np.full_like(q, q[0])
        p[5000:5050] = q[0] + np.linspace(0, 0.01, 50)
        p[5050:5100] = q[0] + np.linspace(0.01, 0, 50)
        return t, p, f, "too few moving samples"
    raise AssertionError(case)


DEGENERATE = ["all-zero force", "constant force", "constant position", "one direction only", "few moving samples"]


@pytest.mark.parametrize("case", DEGENERATE)
def test_degenerate_data_fails_up_front(builtin, case, tmp_path, no_study):
    t, q, f, needle = _degenerate(builtin, case)
    path = write_csv(tmp_path / "bad.csv", t, q, f)
    out_dir = tmp_path / "out"
    line = one_line_error(*run(["emps", "--data", str(path), "--out", str(out_dir), "--quiet"]))
    assert line.startswith(f"{PREFIX}--data {path}: ") and needle in line, line
    assert_nothing_left(out_dir)


@pytest.mark.parametrize("case", DEGENERATE)
def test_check_emps_data_messages(builtin, case):
    t, q, f, needle = _degenerate(builtin, case)
    with pytest.raises(ValueError, match=needle.replace("(", r"\(").replace(")", r"\)")) as info:
        check_emps_data(Measurements(t=t, q=q, force=f, dt=1e-3))
    assert "\n" not in str(info.value)


def test_check_emps_data_other_failures(builtin):
    t, q, f = builtin
    good = Measurements(t=t, q=q, force=f, dt=1e-3)
    check_emps_data(good)
    check_emps_data(emps_builtin_data(0)[0], decimate=1)
    with pytest.raises(ValueError, match=r"24841 samples leave 49 after dropping 49 and decimating by 500; need at"):
        check_emps_data(good, decimate=500)
    with pytest.raises(ValueError, match=r"100 samples leave 5 after dropping 0 and decimating by 20"):
        check_emps_data(Measurements(t=t[:100], q=q[:100], force=f[:100], dt=1e-3), drop=0, decimate=20)
    bad = q.copy()
    bad[[7, 9]] = np.nan
    with pytest.raises(ValueError, match=r"`data.q` contains 2 NaN/inf value\(s\), the first at sample 7"):
        check_emps_data(Measurements(t=t, q=bad, force=f, dt=1e-3))
    with pytest.raises(ValueError, match="`data.dt` must be a positive finite"):
        check_emps_data(Measurements(t=t, q=q, force=f, dt=float("nan")))
    with pytest.raises(ValueError, match="differ in length"):
        check_emps_data(Measurements(t=t, q=q, force=f[:-1], dt=1e-3))
    with pytest.raises(ValueError, match="must be an EMPSData or Measurements"):
        check_emps_data(object())
    with pytest.raises(ValueError, match="`decimate` must be an integer >= 1"):
        check_emps_data(good, decimate=0)
    # one move forward and one back, 200 samples each: twice the MIN_MOVING x decimate needed
    p = np.full_like(q, q[0])
    p[5000:5200] = q[0] + np.linspace(0, 0.01, 200)
    p[5200:5400] = q[0] + np.linspace(0.01, 0, 200)
    check_emps_data(Measurements(t=t, q=p, force=f, dt=1e-3))
    with pytest.raises(ValueError, match="at least 400 .* in each direction"):
        check_emps_data(Measurements(t=t, q=p, force=f, dt=1e-3), decimate=40)
    assert MIN_MOVING == 10


@requires_emps
def test_real_file_passes_the_checks():
    check_emps_data(load_emps(EMPS_MAT))


# --------------------------------------------------------------------------- #
# The output folder: checked before any work
# --------------------------------------------------------------------------- #


def _fails_fast(args, needle):
    t0 = time.perf_counter()
    line = one_line_error(*run(["emps", *args, "--quiet"]))
    assert time.perf_counter() - t0 < 1.0
    assert needle in line, line
    return line


@pytest.mark.skipif(not pathlib.Path("/proc").is_dir(), reason="no /proc on this system")
def test_out_in_proc(no_study):
    _fails_fast(["--out", "/proc/x"], "--out /proc/x: cannot create the directory")
    assert not pathlib.Path("/proc/x").exists()


def test_out_is_a_file(tmp_path, no_study):
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    _fails_fast(["--out", str(a_file)], "exists and is not a directory")
    assert a_file.read_text() == "x"


def test_out_parent_missing(tmp_path, no_study):
    _fails_fast(["--out", str(tmp_path / "no" / "dir")], "does not exist")


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root ignores directory permissions")
def test_out_read_only(tmp_path, no_study):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        _fails_fast(["--out", str(ro)], "not writable")
        _fails_fast(["--out", str(ro / "sub")], "cannot create the directory")
    finally:
        ro.chmod(0o755)


def test_out_probe_failure(tmp_path, monkeypatch, no_study):
    # What a read-only folder does for a non-root user, simulated (root ignores permissions).
    def refuse(self):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(OutputFolder, "_probe", refuse)
    out_dir = tmp_path / "new"
    _fails_fast(["--out", str(out_dir), "--data", str(tmp_path / "missing.csv")], "not writable")
    assert not out_dir.exists()  # the folder it had created is removed again
    existing = tmp_path / "existing"
    existing.mkdir()
    _fails_fast(["--out", str(existing)], "--out")
    assert existing.is_dir()


def test_output_folder_staging(tmp_path, monkeypatch):
    out = OutputFolder(str(tmp_path / "out"))
    assert out.created and out.staging.parent == tmp_path and out.staging.name.startswith(".jaxsdp-")
    (out.staging / "a.txt").write_text("a")
    assert out.commit() == ["a.txt"]
    out.close()
    assert (tmp_path / "out" / "a.txt").read_text() == "a" and not list(tmp_path.glob(".jaxsdp-*"))
    # parent not writable: staged inside --out, still moved into place
    real = tempfile.mkdtemp

    def mkdtemp(dir=None, prefix=None):
        if pathlib.Path(dir) == tmp_path:
            raise PermissionError(13, "Permission denied")
        return real(dir=dir, prefix=prefix)

    monkeypatch.setattr("tempfile.mkdtemp", mkdtemp)
    with OutputFolder(str(tmp_path / "out"), overwrite=True) as out:  # a.txt, the earlier run's, is replaced
        assert out.staging.parent == tmp_path / "out"
        (out.staging / "b.txt").write_text("b")
        out.commit()
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [OutputFolder.MANIFEST, "b.txt"]
    with pytest.raises(CLIError, match="exists and is not a directory"):
        OutputFolder(str(tmp_path / "out" / "b.txt"))


# --------------------------------------------------------------------------- #
# Warnings: one line each, no source paths
# --------------------------------------------------------------------------- #


def test_library_warnings_are_one_line_each(tmp_path, monkeypatch):
    def noisy_study(data, **kwargs):
        for _ in range(3):
            np.float64(1.0) / np.float64(0.0)  # numpy RuntimeWarning, three times
        warnings.warn("something odd\nover two lines", UserWarning, stacklevel=1)
        warnings.warn("old API", DeprecationWarning, stacklevel=1)  # for developers: dropped
        raise ValueError("stop here")

    monkeypatch.setattr(cli_emps, "emps_study", noisy_study)
    code, stdout, stderr = run(["emps", "--out", str(tmp_path / "out"), "--quiet"])
    assert code == 1
    assert stderr.strip().splitlines() == [
        "jaxsdp emps: warning: divide by zero encountered in scalar divide (RuntimeWarning)",
        "jaxsdp emps: warning: something odd over two lines (UserWarning)",
        f"{PREFIX}stop here",
    ]
    assert_nothing_left(tmp_path / "out")


# --------------------------------------------------------------------------- #
# A failure late in the run leaves --out as it was (one full run of the study)
# --------------------------------------------------------------------------- #


def test_failure_while_writing_figures_leaves_out_untouched(tmp_path, monkeypatch):
    out_dir = tmp_path / "emps-out"
    out_dir.mkdir()
    earlier = {"report.md": "earlier report\n", "summary.json": "{}\n", "fig3_sdp_mass.png": "earlier png"}
    for name, text in earlier.items():
        (out_dir / name).write_text(text)
    seen = {}

    def failing_figures(figures, out, **kwargs):
        seen["out"] = pathlib.Path(out)
        (pathlib.Path(out) / "fig3_sdp_mass.png").write_bytes(b"half-written")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(cli_common, "save_figures", failing_figures)  # the one runner writes every figure
    code, stdout, stderr = run(["emps", "--out", str(out_dir), "--quiet", "--overwrite"])
    line = one_line_error(code, stdout, stderr, prefix="jaxsdp: error: OSError: ")
    assert "No space left on device" in line
    assert seen["out"].parent == tmp_path and seen["out"].name.startswith(".jaxsdp-")  # staged beside --out
    assert {p.name: p.read_text() for p in out_dir.iterdir()} == earlier
    assert not seen["out"].exists() and not list(tmp_path.glob(".jaxsdp-*"))


# --------------------------------------------------------------------------- #
# Output folders (issue 29): never mixed with an earlier run's files
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize("command", [["emps"], ["tx40"], ["control"], ["montecarlo", "--study", "control"]])
def test_non_empty_out_is_refused_before_any_work(tmp_path, command, no_study):
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    (out_dir / "report.md").write_text("an earlier report\n")
    code, stdout, stderr = run([*command, "--out", str(out_dir), "--quiet"])
    line = one_line_error(code, stdout, stderr, prefix=f"jaxsdp {command[0]}: error: --out ")
    assert code == 2 and "not empty (report.md)" in line and "--overwrite" in line
    assert (out_dir / "report.md").read_text() == "an earlier report\n"


def test_empty_out_path_is_refused(tmp_path, no_study):
    code, stdout, stderr = run(["emps", "--out", "", "--quiet"])
    assert code == 2 and "--out: an empty path" in one_line_error(code, stdout, stderr, prefix="jaxsdp emps: error: ")


def test_overwrite_replaces_the_earlier_run_and_keeps_other_files(tmp_path):
    out_dir = tmp_path / "out"
    first = ["montecarlo", "--study", "control", "--runs", "16", "--out", str(out_dir), "--quiet"]
    assert run(first)[0] == 0
    assert (out_dir / "mc_envelope.png").exists()
    (out_dir / "notes.txt").write_text("mine\n")
    assert run([*first, "--format", "svg"])[0] == 2  # not empty: refused
    code, _, stderr = run([*first, "--format", "svg", "--overwrite"])
    assert code == 0, stderr
    names = sorted(p.name for p in out_dir.iterdir() if not p.name.startswith("."))
    assert names == ["mc_envelope.svg", "mc_settling.svg", "notes.txt", "report.md", "summary.json"]
    assert (out_dir / "notes.txt").read_text() == "mine\n"
