"""Timings that README.md quotes, checked against the saved run that measured them (issue 43).

README.md is read raw on GitHub, so it cannot hold a placeholder: it types the run time of its first command, with
the machine and the date, and this test fails, naming the README, the quoted and the saved value, when
`benchmarks/results/cpu/commands.json` (written by `benchmarks/commands.py`) says otherwise.
"""

import json
import pathlib
import re

from helpers import check_quoted

ROOT = pathlib.Path(__file__).resolve().parents[1]
COMMANDS = ROOT / "benchmarks" / "results" / "cpu" / "commands.json"


def test_readme_quotes_the_main_commands_run_time():
    saved = json.loads(COMMANDS.read_text())
    (row,) = [r for r in saved["rows"] if r["key"] == "emps-builtin"]
    assert row["command"] == "jaxsdp emps", row  # the README's first command, on the built-in data
    cores = int(re.search(r"(\d+) cores", saved["machine"])[1])
    year, month, day = (int(x) for x in saved["date"].split("-"))
    check_quoted(
        "README.md",
        "`study.npz` ({} s on the project's {}-core machine, {}-{}-{}, compilation included:",
        (format(row["seconds"], ".0f"), cores, year, format(month, "02d"), format(day, "02d")),
        "",
    )
