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
