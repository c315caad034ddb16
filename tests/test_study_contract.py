"""The study contract (issue 28, item 1): every study is a function returning a result plus the same four
functions `summary`, `report`, `text`, `figures`; the command line only maps options to the study's
arguments and writes what those return, so Python and the command give the same numbers and text."""

import ast
import contextlib
import importlib
import inspect
import io
import json
import pathlib

import pytest

import jaxsdp.studies
from jaxsdp._cli import main
from jaxsdp.studies._contract import CONTRACT, save_figures

STUDIES = ("emps", "tx40", "robot", "control", "montecarlo", "forecast")
CLI = pathlib.Path(jaxsdp.__file__).parent / "_cli"
# keys that differ between two runs of the same study (seconds, versions)
VOLATILE = {"timings", "versions", "fast_loops", "seconds", "total_seconds", "runs_per_second"}


def _strip(tree):
    if isinstance(tree, dict):
        return {k: _strip(v) for k, v in tree.items() if k not in VOLATILE}
    if isinstance(tree, list):
        return [_strip(v) for v in tree]
    return tree


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("name", STUDIES)
def test_every_study_exports_the_four_functions(name):
    module = importlib.import_module(f"jaxsdp.studies.{name}")
    for fn in CONTRACT:
        assert fn in module.__all__, (name, fn)
        f = getattr(module, fn)
        assert callable(f) and f.__doc__, (name, fn)
        params = list(inspect.signature(f).parameters.values())
        assert params[0].name == "result", (name, fn)
        keyword = [p.name for p in params[1:]]
        assert keyword == (["figures"] if fn == "report" else []), (name, fn, keyword)
        assert all(p.kind is p.KEYWORD_ONLY for p in params[1:]), (name, fn)


@pytest.mark.parametrize("name", STUDIES)
def test_the_four_functions_refuse_another_result(name):
    module = importlib.import_module(f"jaxsdp.studies.{name}")
    for fn in CONTRACT:
        with pytest.raises(ValueError, match="`result` must be"):
            getattr(module, fn)(object())


# what only a study may do: compose results, check them against a truth, stamp versions, write outputs
STUDY_WORK = {
    "OutputFolder",
    "WarningLines",
    "Progress",
    "save_figures",
    "simulation_check",
    "recovery",
    "tx40_builtin_data",
    "tx40_all_joints_data",
    "emps_builtin_data",
    "__version__",
    "fast_loops_status",
    "finite_or_none",
    "json",
}


@pytest.mark.parametrize("command", STUDIES)
def test_commands_only_map_options_to_the_study(command):
    """A command module declares its options, maps them to the study's arguments and calls `run_study`."""
    tree = ast.parse((CLI / f"{command}.py").read_text())
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    imports = [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))]
    names |= {a.name.split(".")[-1] for n in imports for a in n.names}
    names |= {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    assert "run_study" in names, command
    assert not names & STUDY_WORK, (command, sorted(names & STUDY_WORK))


def test_save_figures_writes_and_clears(tmp_path):
    from jaxsdp.studies._figure_style import new_figure

    fig = new_figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    paths = save_figures({"line": fig}, tmp_path, fmt="svg")
    assert paths["line"] == tmp_path / "line.svg" and paths["line"].stat().st_size > 1000
    assert not fig.axes  # cleared once written
    with pytest.raises(ValueError, match="fmt"):
        save_figures({}, tmp_path, fmt="jpg")


# --------------------------------------------------------------------------- #
# Python and the command give the same results
# --------------------------------------------------------------------------- #


def _as_the_command(tree, command):
    """A Python result's texts as command `command` writes them: the arguments its messages name in
    backquotes become the command's options (`jaxsdp._cli.common.cli_tree`), the only difference allowed."""
    from jaxsdp._cli import flags_of
    from jaxsdp._cli.common import cli_tree

    return cli_tree(tree, flags_of(command))


def _same_as_the_command(module, result, argv, tmp_path):
    out = tmp_path / "out"
    code, stdout, _ = _run([*argv, "--out", str(out), "--quiet"])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    python = json.loads(json.dumps(module.summary(result), allow_nan=False))
    assert _strip(summary) == _strip(_as_the_command(python, argv[0]))
    printed = stdout.split("\n\nWrote ")[0]
    assert printed == _as_the_command(module.text(result), argv[0])
    figures = module.figures(result)
    assert sorted(f"{n}.png" for n in figures) == sorted(p.name for p in out.glob("*.png"))
    report = _as_the_command(module.report(result, figures={n: f"{n}.png" for n in figures}), argv[0])
    body = (out / "report.md").read_text()
    cut = "## Timings"
    assert report.split(cut)[0] == body.split(cut)[0]  # everything but the seconds
    return summary


def test_emps_study_is_the_command(tmp_path):
    from jaxsdp.studies import emps

    result = emps.emps_study(check_decimation=False)
    summary = _same_as_the_command(emps, result, ["emps", "--no-decimation-check"], tmp_path)
    # what the command used to add itself now comes from the study
    assert summary["simulation"]["position"] < 0.01  # %
    assert summary["truth"]["M"] == 95.15  # kg, the built-in plant
    assert set(summary["recovery"]) >= {"idim_ls_asym", "idim_sdp", "warnings"}
    assert summary["data"]["seed"] == 0 and "plant" in summary["data"]
    assert result.findings and result.versions["jaxsdp"] == jaxsdp.__version__
    assert set(result.recovery["warnings"]) <= set(result.warnings)
    assert (tmp_path / "out" / "study.npz").exists()


def test_emps_study_options_of_the_builtin_plant(tmp_path):
    from jaxsdp.data import emps_builtin_data
    from jaxsdp.studies.emps import emps_study

    data = emps_builtin_data(0)[0]
    with pytest.raises(ValueError, match="seed"):
        emps_study(data, seed=1)
    with pytest.raises(ValueError, match="seed"):
        emps_study(seed=-1)
    study = emps_study(data, check_decimation=False, check_simulation=False)
    assert study.simulation is None and study.truth is None and study.recovery is None
    assert "recovery" not in study.summary() and study.summary()["simulation"] is None


def test_tx40_study_is_the_command(tmp_path):
    from jaxsdp.studies import tx40

    logs_dir = tmp_path / "logs"
    logs_dir.mkdir()
    result = tx40.tx40_study(tx40.TX40Builtin(case="link2", seed=0, logs_dir=logs_dir))
    assert result.data_files == ("positions.csv", "torques.csv")
    assert sorted(p.name for p in logs_dir.iterdir()) == ["positions.csv", "torques.csv"]
    assert "Table 4" in result.reference_label and result.truth is not None
    summary = _same_as_the_command(tx40, result, ["tx40"], tmp_path)
    assert summary["data"]["files"] == ["positions.csv", "torques.csv"]
    assert sorted(p.name for p in (tmp_path / "out").glob("*.csv")) == ["positions.csv", "torques.csv"]
    with pytest.raises(ValueError, match="JointLogs.*TX40Builtin"):
        tx40.tx40_study(result.inputs)
    with pytest.raises(ValueError, match="`case`"):
        tx40.TX40Builtin(case="link3")
    with pytest.raises(ValueError, match="`seed`"):
        tx40.TX40Builtin(seed=-1)
    with pytest.raises(ValueError, match="come with the built-in experiment"):
        tx40.tx40_study(tx40.TX40Builtin(case="all"), truth={"ZZ2": 1.0})


def test_forecast_study_is_the_command(tmp_path):
    import numpy as np

    from helpers import seasonal_series, write_series_csv
    from jaxsdp.studies import forecast

    y = seasonal_series(132)
    path = write_series_csv(tmp_path / "series.csv", y)
    dates = np.arange(np.datetime64("2000-01"), np.datetime64("2000-01") + len(y)).astype("datetime64[s]")
    options = dict(periods=[12, 6], horizon=12, holdout=12, nvr=(1e-6, 1e-4, 1e-4))
    result = forecast.forecast_study(
        y, **options, time=dates, name="y", source="series.csv, column 'y', time column 'time'"
    )
    argv = ["forecast", "--data", path, "--periods", "12", "6", "--horizon", "12", "--holdout", "12"]
    summary = _same_as_the_command(forecast, result, [*argv, "--nvr", "1e-6", "1e-4", "1e-4"], tmp_path)
    assert summary["forecast"]["rows"][0]["time"] == "2011-01-01" and summary["holdout"]["observed"] == 12
    assert (tmp_path / "out" / "forecast.csv").read_text() == result.csv()


def test_montecarlo_study_is_the_command(tmp_path):
    from jaxsdp.studies import montecarlo

    result = montecarlo.control_robustness(32, seed=3, progress=False)
    out = tmp_path / "out"
    code, stdout, _ = _run(["montecarlo", "--study", "control", "--runs", "32", "--seed", "3", "--out", str(out)])
    assert code == 0
    python = _as_the_command(montecarlo.summary(result), "montecarlo")
    assert _strip(json.loads((out / "summary.json").read_text())) == _strip(python)
    assert sorted(montecarlo.figures(result)) == ["mc_envelope", "mc_settling"]
    assert montecarlo.summary(result)["versions"]["jaxsdp"] == jaxsdp.__version__


@pytest.mark.parametrize(
    "argv",
    [
        ["emps", "--no-decimation-check"],
        ["tx40"],
        ["montecarlo", "--study", "identification", "--runs", "16", "--no-sdp"],
    ],
)
def test_each_warning_is_printed_once_on_stderr(tmp_path, argv):
    """One convention for every command (issue 29): stdout holds the results, each warning is printed
    once, on stderr, as `jaxsdp <command>: warning: ...`, and heads report.md."""
    out = tmp_path / "out"
    code, stdout, stderr = _run([*argv, "--out", str(out), "--quiet"])
    assert code == 0
    warnings = json.loads((out / "summary.json").read_text())["warnings"]
    assert warnings, "these runs are chosen for their warnings"
    lines = stderr.strip().splitlines()
    assert lines == [f"jaxsdp {argv[0]}: warning: {w}" for w in warnings]
    for w in warnings:
        assert w not in stdout
        assert w in (out / "report.md").read_text()
