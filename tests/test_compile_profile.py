"""`benchmarks/compile_profile.py` sums what `JAXSDP_COMPILE_LOG` records (tests/conftest.py)."""

import json
import subprocess
import sys

from helpers import ROOT


def test_compile_profile_sums_the_log(tmp_path):
    records = [
        {"kind": "compile", "fun": "jit(f)", "s": 1.5, "test": "tests/test_a.py::test_1"},
        {"kind": "compile", "fun": "jit(f)", "s": 0.5, "test": "tests/test_b.py::test_2"},
        {"kind": "trace", "fun": "f", "s": 0.25, "test": "tests/test_a.py::test_1"},
    ]
    (tmp_path / "gw0.jsonl").write_text("\n".join(json.dumps(r) for r in records) + "\n")
    out = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "compile_profile.py"), str(tmp_path)],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    assert "seconds in all: compile 2, trace 0" in out
    line = next(x for x in out.splitlines() if x.strip().startswith("jit(f)"))
    assert line.split()[1:3] == ["2", "2.0"] and "test_a.py x1" in line and "test_b.py x1" in line
