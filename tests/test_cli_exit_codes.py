"""One exit-code rule for every `jaxsdp` command (issue 41): 0 done, 1 a data error, 2 a usage mistake, 130 interrupted.

Each usage mistake of each command must exit with 2 before any work, with one line on stderr that names the
option as the command line spells it. `main([...])` runs in-process, with every study (and the EMPS loaders)
replaced by a function that fails the test: a case that got past its check would start the study. The joint-log
loader is left in place, since some mistakes (`--ratios` not one per log column, a `--joint` the logs do not
hold, `--dt` missing) show only once the files' headers are read; the files here are a few rows. The data
errors exit with 1 before the study starts. The whole file runs in seconds.
"""

import pathlib

import numpy as np
import pytest

import jaxsdp._cli as cli
import jaxsdp._cli.control as cli_control
import jaxsdp._cli.emps as cli_emps
import jaxsdp.studies.montecarlo as montecarlo
import jaxsdp.studies.robot._excite as robot_excite
import jaxsdp.studies.robot._study as robot_study
import jaxsdp.studies.tx40._study as tx40_study
from helpers import (
    ARM_URDF,
    EMPS_MAT,
    TX40_CURRENTS,
    TX40_POSITIONS,
    TX40_URDF,
    requires_emps,
    requires_tx40,
    requires_tx40_urdf,
)
from jaxsdp._cli import main

STUDIES = [
    (cli_emps, "emps_study"),
    (cli_control, "control_study"),
    (tx40_study, "tx40_study"),
    (robot_study, "robot_study"),
    (robot_excite, "excitation_study"),
    (montecarlo, "identification_robustness"),
    (montecarlo, "control_robustness"),
]
EMPS_LOADERS = [(cli_emps, "load_emps"), (cli_emps, "load_measurements"), (cli_control, "load_emps")]


def _forbid(monkeypatch, targets):
    def started(*args, **kwargs):
        pytest.fail("the work started: the usage check should have come first")

    for module, name in targets:
        monkeypatch.setattr(module, name, started)


def _logs(path, n_joints, *, time=None, rows=20, cell=None):
    """A joint log of `rows` rows (header Joint_1..Joint_n, a `time` column when `time` is a step in s)."""
    values = 0.01 * np.arange(rows)[:, None] * np.ones(n_joints)
    header = ",".join(f"Joint_{k}" for k in range(1, n_joints + 1))
    if time is not None:
        values = np.column_stack([np.arange(rows) * time, values])
        header = "time," + header
    lines = [header] + [",".join(f"{v:.6g}" for v in row) for row in values]
    if cell is not None:
        lines[3] = lines[3].rsplit(",", 1)[0] + f",{cell}"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@pytest.fixture
def files(tmp_path):
    """Paths the cases name: `{out}` a fresh --out, `{afile}` a file, `{full}` a non-empty folder, small logs."""
    (tmp_path / "afile").write_text("x")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "report.md").write_text("an earlier report\n")
    (tmp_path / "arm.urdf").write_text(ARM_URDF)
    (tmp_path / "bad.urdf").write_text("<notarobot/>")
    (tmp_path / "bad.csv").write_text("t,q,force\n0,0,1\n0.001,abc,2\n")
    t = np.arange(200) * 1e-3
    t[100:] += 0.5  # a 0.5 s gap
    q = 0.01 * np.sin(2 * np.pi * t)
    np.savetxt(tmp_path / "gap.csv", np.column_stack([t, q, np.cos(t)]), delimiter=",", header="t,q,force", comments="")
    jitter = np.arange(20) * 1e-3
    jitter[10:] += 1e-3  # a missing sample: a gap (steps within 0.5-1.5 x the median are jitter, resampled)
    (tmp_path / "jitter.csv").write_text(
        "time,Joint_1,Joint_2\n" + "".join(f"{s:.6g},{0.01 * k:.6g},{0.02 * k:.6g}\n" for k, s in enumerate(jitter))
    )
    return {
        "out": str(tmp_path / "out"),
        "tmp": str(tmp_path),
        "afile": str(tmp_path / "afile"),
        "full": str(tmp_path / "full"),
        "missing": str(tmp_path / "no" / "such"),
        "mat": str(tmp_path / "record.mat"),  # never read: the usage checks come first
        "csv": str(tmp_path / "record.csv"),  # likewise
        "bad_csv": str(tmp_path / "bad.csv"),
        "gap_csv": str(tmp_path / "gap.csv"),
        "urdf": str(tmp_path / "arm.urdf"),
        "bad_urdf": str(tmp_path / "bad.urdf"),
        "pos6": _logs(tmp_path / "pos6.csv", 6),
        "trq6": _logs(tmp_path / "trq6.csv", 6),
        "pos6_ms": _logs(tmp_path / "pos6_ms.csv", 6, time=1e-3),  # a time column at 1 kHz
        "pos6_bad": _logs(tmp_path / "pos6_bad.csv", 6, cell="abc"),
        "pos2": _logs(tmp_path / "pos2.csv", 2),
        "trq2": _logs(tmp_path / "trq2.csv", 2),
        "pos2_ms": _logs(tmp_path / "pos2_ms.csv", 2, time=1e-3),
        "jitter": str(tmp_path / "jitter.csv"),
        "tx40_pos": str(TX40_POSITIONS),
        "tx40_trq": str(TX40_CURRENTS),
        "tx40_urdf": str(TX40_URDF),
        "emps_mat": str(EMPS_MAT),
    }


def run(argv, paths, capsys):
    """`main` on `argv` with the paths filled in (and `--out {out}` unless the case names one); (code, stderr)."""
    args = [a.format(**paths) for a in argv]
    if args and "--out" not in args and args[0] in cli.COMMANDS:
        args += ["--out", paths["out"]]
    code = main(args)
    captured = capsys.readouterr()
    return code, captured.err


def check_error_line(argv, err, fragment):
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    command = argv[0] if argv and argv[0] in cli.COMMANDS else None
    prefix = f"jaxsdp {command}: error: " if command else "jaxsdp: error: "
    assert lines[0].startswith(prefix), lines[0]
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in err


def check_nothing_written(paths):
    out = pathlib.Path(paths["out"])
    assert not out.exists() or not any(out.iterdir())
    assert not list(pathlib.Path(paths["tmp"]).glob(".jaxsdp-*"))  # no staging folder left


P6 = ["--positions", "{pos6}", "--torques", "{trq6}"]  # six-joint logs, 20 rows, no time column
P2 = ["--positions", "{pos2}", "--torques", "{trq2}"]  # two-joint logs for the two-link arm
ROBOT = ["robot", "--urdf", "{urdf}"]
FULL = ["tx40", "--case", "all", "--model", "full"]

#: (argv, fragment of the one-line message): each a usage mistake, exit 2 before any work.
USAGE = {
    # the command line as a whole
    "no command": ([], "COMMAND"),
    "unknown command": (["nope"], "invalid choice"),
    "unknown option": (["emps", "--frobnicate"], "unrecognized arguments: --frobnicate"),
    "bad --format": (["emps", "--format", "gif"], "--format"),
    "bad --dpi": (["tx40", "--dpi", "0"], "--dpi"),
    # --out, every command
    "emps --out a file": (["emps", "--out", "{afile}"], "--out {afile}: exists and is not a directory"),
    "emps --out missing parent": (["emps", "--out", "{missing}/out"], "does not exist"),
    "emps --out empty path": (["emps", "--out", ""], "--out: an empty path"),
    "emps --out not empty": (["emps", "--out", "{full}"], "--overwrite"),
    "tx40 --out a file": (["tx40", "--out", "{afile}"], "--out {afile}: exists and is not a directory"),
    "tx40 --out missing parent": (["tx40", "--out", "{missing}/out"], "--out {missing}/out: parent directory"),
    "control --out a file": (["control", "--out", "{afile}"], "--out {afile}: exists and is not a directory"),
    "montecarlo --out missing parent": (
        ["montecarlo", "--study", "control", "--out", "{missing}/out"],
        "does not exist",
    ),
    "robot --out a file": ([*ROBOT, "--excite", "--out", "{afile}"], "--out {afile}: exists and is not a directory"),
    "robot --out missing parent": ([*ROBOT, "--excite", "--out", "{missing}/out"], "does not exist"),
    # emps
    "emps --seed with --data": (["emps", "--data", "{mat}", "--seed", "3"], "--seed"),
    "emps --resample without --data": (["emps", "--resample"], "--resample"),
    "emps --columns without --data": (["emps", "--columns", "t,q,force"], "--columns names what a --data file"),
    "emps --variables with a CSV": (["emps", "--data", "{csv}", "--variables", "t=time"], "--variables"),
    "emps --estimator iv with a CSV": (["emps", "--data", "{csv}", "--estimator", "iv"], "--estimator iv"),
    "emps --columns and --variables": (
        ["emps", "--data", "{mat}", "--columns", "t,q,f", "--variables", "t=time"],
        "exclude each other",
    ),
    "emps --columns count": (["emps", "--columns", "t,q"], "--columns"),
    "emps --decimate 0": (["emps", "--decimate", "0"], "--decimate"),
    "emps --decimate too large": (["emps", "--decimate", "100000"], "--decimate"),
    "emps --cutoff above Nyquist": (["emps", "--cutoff", "600"], "--cutoff 600 Hz must be below the Nyquist"),
    # tx40
    "tx40 --positions alone": (["tx40", "--positions", "{pos6}"], "--torques missing"),
    "tx40 --torques alone": (["tx40", "--torques", "{trq6}"], "--positions missing"),
    "tx40 --joint 7": (["tx40", "--joint", "7"], "--joint 7: the TX40 has joints 1..6"),
    "tx40 --joint 0": (["tx40", "--joint", "0"], "--joint"),
    "tx40 --joint not in the logs": (["tx40", *P6, "--joint", "7"], "--joint 7: the logs hold joints 1, 2, 3"),
    "tx40 --ratios count": (["tx40", *P6, "--ratios", "32,32"], "--ratios has 2 entries"),
    "tx40 --torque-constants count": (["tx40", *P6, "--torque-constants", "1,1"], "--torque-constants has 2"),
    "tx40 --ratios zero": (["tx40", *P6, "--ratios", "32,0,45,-48,45,32"], "--ratios: a gear ratio of 0"),
    "tx40 --torque-constants negative": (
        ["tx40", *P6, "--torque-constants", "1,1,1,1,1,-1"],
        "--torque-constants must be positive",
    ),
    "tx40 --ratios with built-in data": (["tx40", "--ratios", "32,32,45,-48,45,32"], "--ratios describes real logs"),
    "tx40 --dt with built-in data": (["tx40", "--dt", "1e-3"], "--dt describes real logs"),
    "tx40 --dt against the time column": (
        ["tx40", "--positions", "{pos6_ms}", "--torques", "{trq6}"],
        "--dt = 0.0002 s but the time column",
    ),
    "tx40 --seed with real logs": (["tx40", *P6, "--seed", "1"], "--seed chooses the built-in data"),
    "tx40 --case with real logs": (["tx40", *P6, "--case", "all"], "--case chooses the built-in data"),
    "tx40 --joint-offsets without --model full": (
        ["tx40", "--joint-offsets", "0,0,0,0,0,0"],
        "--joint-offsets applies to --model full only",
    ),
    "tx40 --wrist-coupling without --model full": (["tx40", "--wrist-coupling", "none"], "--wrist-coupling"),
    "tx40 --model full without --case all": (["tx40", "--model", "full"], "--case all"),
    "tx40 --model full on fewer joints": (["tx40", *P6, "--ratios", "32,32", "--model", "full"], "all 6 joints"),
    "tx40 --joint-offsets count": ([*FULL, "--joint-offsets", "0,0"], "--joint-offsets has 2 values"),
    "tx40 --wrist-coupling out of range": ([*FULL, "--wrist-coupling", "5,7"], "--wrist-coupling 5,7"),
    "tx40 --wrist-coupling count": ([*FULL, "--wrist-coupling", "5"], "--wrist-coupling"),
    "tx40 --sdp-model": (["tx40", "--sdp-model", "ARX"], "--sdp-model"),
    "tx40 --tol": (["tx40", "--tol", "1.5"], "--tol"),
    # robot
    "robot without --urdf": (["robot", *P2], "--urdf"),
    "robot --positions alone": ([*ROBOT, "--positions", "{pos2}"], "--torques required"),
    "robot --dt missing": ([*ROBOT, *P2], "give the sampling period --dt"),
    "robot --dt against the time column": (
        [*ROBOT, "--positions", "{pos2_ms}", "--torques", "{trq2}", "--dt", "2e-4"],
        "--dt = 0.0002 s but the time column",
    ),
    "robot --joints out of range": ([*ROBOT, "--excite", "--joints", "3"], "--joints 3: the robot of --urdf"),
    "robot --joints twice": ([*ROBOT, *P2, "--dt", "1e-3", "--joints", "1,1"], "--joints"),
    "robot --tip-link unknown": ([*ROBOT, "--excite", "--tip-link", "nope"], "--tip-link 'nope' is not a link"),
    "robot --base-link unknown": ([*ROBOT, "--excite", "--base-link", "nope"], "--base-link 'nope' is not a link"),
    "robot --excite with logs": ([*ROBOT, "--excite", "--positions", "{pos2}"], "drop --positions"),
    "robot --excite with --decimate": ([*ROBOT, "--excite", "--decimate", "5"], "drop --decimate"),
    "robot --harmonics without --excite": ([*ROBOT, *P2, "--harmonics", "3"], "--harmonics only apply with"),
    # control
    "control --data not .mat": (["control", "--data", "{csv}"], "--data {csv}: the control study reads"),
    "control --noise-orders without rivcbj": (["control", "--noise-orders", "1", "1"], "--noise-orders"),
    "control --noise-orders count": (["control", "--estimator", "rivcbj", "--noise-orders", "1"], "--noise-orders"),
    "control --noise-orders range": (["control", "--estimator", "rivcbj", "--noise-orders", "11", "1"], "0..10"),
    "control --ident-noise-ar range": (["control", "--ident-noise-ar", "1"], "--ident-noise-ar"),
    # montecarlo
    "montecarlo without --study": (["montecarlo", "--runs", "10"], "--study"),
    "montecarlo --no-iv with control": (["montecarlo", "--study", "control", "--no-iv"], "--no-iv"),
    "montecarlo --draws with identification": (
        ["montecarlo", "--study", "identification", "--draws", "covariance"],
        "--draws",
    ),
    "montecarlo --spread 0 with control": (["montecarlo", "--study", "control", "--spread", "0"], "--spread"),
    "montecarlo --runs 0": (["montecarlo", "--study", "control", "--runs", "0"], "--runs"),
}

#: Usage mistakes on the real data sets (skipped without ../shared/): still refused before any computation.
USAGE_REAL = {
    "tx40 real logs --ratios count": (
        ["tx40", "--positions", "{tx40_pos}", "--torques", "{tx40_trq}", "--ratios", "32,32"],
        "--ratios has 2 entries",
        requires_tx40,
    ),
    "tx40 real logs --joint 7": (
        ["tx40", "--positions", "{tx40_pos}", "--torques", "{tx40_trq}", "--joint", "7"],
        "--joint 7",
        requires_tx40,
    ),
    "robot TX40 --joints 7": (
        ["robot", "--urdf", "{tx40_urdf}", "--excite", "--joints", "7"],
        "--joints 7: the robot of --urdf has joints 1..6",
        requires_tx40_urdf,
    ),
    "emps real file --seed": (["emps", "--data", "{emps_mat}", "--seed", "1"], "--seed", requires_emps),
}

#: (argv, fragment): data errors, exit 1 before the study starts.
DATA = {
    "emps CSV that does not parse": (["emps", "--data", "{bad_csv}"], "is not a number: 'abc'"),
    "emps irregular time stamps": (["emps", "--data", "{gap_csv}"], "pass --resample"),
    "emps missing file": (["emps", "--data", "{tmp}/nope.csv"], "no such file"),
    "tx40 log that does not parse": (["tx40", "--positions", "{pos6_bad}", "--torques", "{trq6}"], "pos6_bad.csv"),
    "tx40 missing log": (["tx40", "--positions", "{tmp}/nope.csv", "--torques", "{trq6}"], "no such file"),
    "robot irregular time stamps": ([*ROBOT, "--positions", "{jitter}", "--torques", "{trq2}"], "pass --resample"),
    "robot not a URDF": (["robot", "--urdf", "{bad_urdf}", "--excite"], "--urdf"),
    "control missing file": (["control", "--data", "{tmp}/nope.mat"], "no such file"),
}


@pytest.mark.parametrize("case", list(USAGE))
def test_usage_mistakes_exit_2_before_any_work(case, files, capsys, monkeypatch):
    _forbid(monkeypatch, STUDIES + EMPS_LOADERS)
    argv, fragment = USAGE[case]
    code, err = run(argv, files, capsys)
    assert code == 2, err
    check_error_line(argv, err, fragment.format(**files))
    check_nothing_written(files)


@pytest.mark.parametrize(
    "case", [pytest.param(name, marks=mark) for name, (_, _, mark) in USAGE_REAL.items()], ids=list(USAGE_REAL)
)
def test_usage_mistakes_on_real_data_exit_2(case, files, capsys, monkeypatch):
    _forbid(monkeypatch, STUDIES + EMPS_LOADERS)
    argv, fragment, _ = USAGE_REAL[case]
    code, err = run(argv, files, capsys)
    assert code == 2, err
    check_error_line(argv, err, fragment)
    check_nothing_written(files)


@pytest.mark.parametrize("case", list(DATA))
def test_data_errors_exit_1(case, files, capsys, monkeypatch):
    _forbid(monkeypatch, STUDIES)  # the data are read (and refused) before the study
    argv, fragment = DATA[case]
    code, err = run(argv, files, capsys)
    assert code == 1, err
    check_error_line(argv, err, fragment)
    check_nothing_written(files)


def test_help_and_version_exit_0(capsys):
    for command in cli.COMMANDS:
        assert main([command, "--help"]) == 0
        assert "--out" in capsys.readouterr().out
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("jaxsdp ")


def test_ctrl_c_exits_130(files, capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tx40_study, "tx40_study", interrupted)
    try:
        code, err = run(["tx40"], files, capsys)
    finally:
        cli._HANDLING.clear()  # what main() sets for the interrupt watchdog (not running in-process)
    assert code == cli.INTERRUPTED == 130
    assert err.strip().splitlines()[-1] == "jaxsdp: interrupted"
    check_nothing_written(files)
