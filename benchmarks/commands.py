"""Benchmark: the wall-clock time of the documented commands, each in a fresh process as a user types it.

Each row is one `jaxsdp ...` command of the docs (the study snapshot's cases,
`benchmarks/study_snapshot.py`, plus the 1,000-run identification Monte Carlo)
run in a new Python process: interpreter and JAX start-up, compilation and the
study, figures and report included. `seconds` is that wall-clock time;
`study_seconds` the study's own `timings.total` from its summary.json (what
the study reports). Cases that need the shared data folder are skipped
without it. The load average at the start and the end says whether other
work shared the cores.

    python benchmarks/commands.py --json benchmarks/results/cpu/commands.json [--only emps-builtin,...]

The pages quote the rows as `{{ bench commands /rows/@CASE/seconds .0f }}`, with the row's machine and date.
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _record import Recorder  # noqa: E402
from study_snapshot import CASES, unshare  # noqa: E402

EXTRA = {
    "montecarlo-identification-1000": (["montecarlo", "--study", "identification", "--runs", "1000"], ()),
}
DEFAULT = [
    "emps-builtin",
    "emps-real",
    "tx40-real",
    "robot-tx40-real",
    "control-default",
    "montecarlo-control-1000",
    "montecarlo-identification-1000",
]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=pathlib.Path, default=None)
    parser.add_argument("--only", default=None, help="comma-separated cases (default: the documented ones)")
    args = parser.parse_args(argv)
    cases = {**CASES, **EXTRA}
    names = args.only.split(",") if args.only else DEFAULT
    rec = Recorder("benchmarks/commands.py", args.json, cases=names, load_start=os.getloadavg()[0])
    for name in names:
        argv_case, needs = cases[name]
        if any(not pathlib.Path(p).exists() for p in needs):
            print(f"{name:34s} skipped (needs the shared data folder)")
            continue
        with tempfile.TemporaryDirectory() as out:
            cmd = [sys.executable, "-m", "jaxsdp", *argv_case, "--out", out, "--quiet"]
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True)
            seconds = time.perf_counter() - t0
            if proc.returncode != 0:
                print(f"{name:34s} failed ({proc.returncode}): {proc.stderr.strip()[-300:]}")
                rec.add(key=name, failed=proc.returncode)
                continue
            summary = json.loads((pathlib.Path(out) / "summary.json").read_text())
        study = summary.get("timings", {}).get("total")
        command = unshare(" ".join(["jaxsdp", *map(str, argv_case)]))
        rec.add(key=name, seconds=seconds, study_seconds=study, command=command)
        print(f"{name:34s} {seconds:7.1f} s   (study {study if study is None else f'{study:.1f}'} s)")
    rec.add(key="summary", load_end=os.getloadavg()[0])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
