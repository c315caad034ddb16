"""The "In Python" snippet of the getting-started page (the README's, before the site) runs as written."""

import os
import pathlib
import re

README = pathlib.Path(__file__).resolve().parents[1] / "docs" / "getting-started.md"


def _python_block(title):
    text = README.read_text()
    section = text[text.index(f"## {title}") :]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_in_python_snippet_runs(tmp_path, capsys):
    code = _python_block("In Python")
    cwd = os.getcwd()
    os.chdir(tmp_path)  # the snippet writes emps-study.npz
    try:
        exec(compile(code, str(README) + ":In Python", "exec"), {"__name__": "readme"})
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out
    assert "relative error" in out and (tmp_path / "emps-study.npz").exists()


def _commands(text):
    return [line for line in text.splitlines() if line.startswith("pip install")]


def test_the_set_up_commands_are_the_readmes_and_ci_runs_its_test_command():
    root = README.parents[1]
    readme = _commands((root / "README.md").read_text())
    assert len(readme) == 2, readme  # the quick start: exactly two set-up commands
    assert _commands(README.read_text()) == readme  # the getting-started page shows the same two
    test_command = readme[1].split("  #")[0]
    ci = (root / ".ci" / "run").read_text()
    assert test_command in ci.splitlines(), f"{root / '.ci' / 'run'} does not run the README's test command"
    assert "python -m pytest -q -n 2 --dist loadgroup --durations=10 -m docs tests" in ci  # then the docs step
