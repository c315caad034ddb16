"""Snapshot every study's summary.json and compare two snapshots: "nothing changes for users' numbers" (issue 28).

Runs each study through the `jaxsdp` command (in this process, so that the
runs share their compilations) on the built-in data and, when `../shared/`
(or `$JAXSDP_SHARED`) is there, on the real EMPS file and the real TX40 logs,
and keeps each `summary.json` as `<case>.json` in the snapshot folder, with the
keys that change from run to run removed (timings, versions, the fast-loop
status, Monte Carlo seconds and throughput), and the report.md and printed
text a user reads (`<case>.report.md`, `<case>.stdout.txt`, `<case>.stderr.txt`:
wall-clock seconds and versions masked; compared line by line). Take one snapshot before a
refactoring and one after, then compare:

    python benchmarks/study_snapshot.py run before/          # on the old code
    python benchmarks/study_snapshot.py run after/           # on the new code
    python benchmarks/study_snapshot.py compare before/ after/ [--rtol 0]

`compare` prints every path whose value differs (numbers beyond `rtol`,
default 0: bit for bit as JSON prints them; strings, lists and keys exactly)
and exits 1 when any does. `run --only emps-builtin,tx40-builtin` runs a
subset; `list` names the cases. The whole set takes about 1.5 min on 2
cores (measured: 84 s, compilation included). Runs of the same code give
identical snapshots (checked on the built-in EMPS, TX40 and Monte Carlo
control cases).
"""

import argparse
import contextlib
import difflib
import io
import json
import math
import os
import pathlib
import re
import shutil
import sys
import tempfile
import time

import jax

jax.config.update("jax_enable_x64", True)

from jaxsdp._cli import main as jaxsdp_main  # noqa: E402

SHARED = pathlib.Path(
    os.environ.get("JAXSDP_SHARED", pathlib.Path(__file__).resolve().parents[1] / ".." / "shared")
).resolve()
EMPS_MAT = SHARED / "data" / "emps" / "DATA_EMPS.mat"
TX40_POS = SHARED / "data" / "tx40" / "pos_read_data.csv"
TX40_CURR = SHARED / "data" / "tx40" / "curr_data.csv"
TX40_URDF = SHARED / "data" / "tx40" / "tx40_mdh_modified.urdf"

# keys whose values change from run to run, dropped wherever they appear
VOLATILE = {"timings", "versions", "fast_loops", "seconds", "total_seconds", "runs_per_second"}

# case -> (command line without --out, files it needs)
CASES = {
    "emps-builtin": (["emps"], ()),
    "emps-builtin-iv": (["emps", "--estimator", "iv", "--no-decimation-check"], ()),
    "emps-real": (["emps", "--data", str(EMPS_MAT)], (EMPS_MAT,)),
    "emps-real-captain": (["emps", "--data", str(EMPS_MAT), "--nvr-search", "captain"], (EMPS_MAT,)),
    "tx40-builtin": (["tx40"], ()),
    "tx40-builtin-full": (["tx40", "--case", "all", "--model", "full"], ()),
    "tx40-real": (["tx40", "--positions", str(TX40_POS), "--torques", str(TX40_CURR)], (TX40_POS, TX40_CURR)),
    "tx40-real-full": (
        ["tx40", "--positions", str(TX40_POS), "--torques", str(TX40_CURR), "--model", "full"],
        (TX40_POS, TX40_CURR),
    ),
    "robot-tx40-real": (
        ["robot", "--urdf", str(TX40_URDF), "--drives", "tx40", "--positions", str(TX40_POS), "--torques"]
        + [str(TX40_CURR), "--dt", "2e-4"],
        (TX40_URDF, TX40_POS, TX40_CURR),
    ),
    "robot-tx40-excite": (["robot", "--urdf", str(TX40_URDF), "--excite"], (TX40_URDF,)),
    "control-builtin": (["control", "--tune-iterations", "3"], ()),
    "control-default": (["control"], ()),
    "montecarlo-identification": (["montecarlo", "--study", "identification", "--runs", "32", "--no-sdp"], ()),
    "montecarlo-control": (["montecarlo", "--study", "control", "--runs", "256"], ()),
    # the Monte Carlo guide's runs
    "montecarlo-identification-256": (["montecarlo", "--study", "identification", "--runs", "256"], ()),
    "montecarlo-control-1000": (["montecarlo", "--study", "control", "--runs", "1000"], ()),
    # the paper page's and the concepts page's coverage over 1,000 runs, and over plants drawn within +-20 %
    "montecarlo-identification-1000": (["montecarlo", "--study", "identification", "--runs", "1000"], ()),
    "montecarlo-identification-1000-spread": (
        ["montecarlo", "--study", "identification", "--runs", "1000", "--spread", "0.2", "--force-noise", "2"],
        (),
    ),
    # the Monte Carlo hosts page's control runs with the real drive and with draws from the covariance
    "montecarlo-control-real-2000": (["montecarlo", "--study", "control", "--runs", "2000", "--drive", "real"], ()),
    "montecarlo-control-covariance-1000": (
        ["montecarlo", "--study", "control", "--runs", "1000", "--draws", "covariance"],
        (),
    ),
    # the control guide's run on the real record and its coloured-noise rivcbj run
    "control-real": (["control", "--data", str(EMPS_MAT)], (EMPS_MAT,)),
    "control-rivcbj-ar095": (["control", "--estimator", "rivcbj", "--ident-noise-ar", "0.95"], ()),
    # the TX40 guide's wrist joints with the full model
    **{
        f"tx40-real-full-joint{j}": (
            ["tx40", "--positions", str(TX40_POS), "--torques", str(TX40_CURR), "--joint", str(j), "--model", "full"]
            + ["--no-settings-check"],
            (TX40_POS, TX40_CURR),
        )
        for j in (5, 6)
    },
}


# timings in the printed text and report.md ("12.3 s", "(0.8 s)"), masked before comparing them
# (only wall-clock times: "(12.3 s)", "in 4.1 s", "took 2 s"; a sample time "dt = 0.001 s", a settling time or
# "log10 s.e." are results and stay)
_SECONDS = re.compile(
    r"(?:(?<=\()|(?<=\bin )|(?<=\btook ))\d+(?:\.\d+)?(?:e[-+]?\d+)? ?(?:s|ms|min)\b(?!\.)"
    r"|\d+(?:\.\d+)? ?s(?= \(<n> runs/s)"  # "chunks of 32, 8.8 s (12 runs/s"
)
_VERSIONS = re.compile(r"(jaxsdp|jax|JAX) \d+\.\d+[^\s,;)]*")


def mask(text: str) -> str:
    """`text` with its run-to-run parts (seconds, throughput, versions, the temporary output folder, the
    numbers of a timings table) masked."""
    text = re.sub(r"/\S*snapshot-[^/\s]*/out", "<out>", text)
    text = re.sub(r"\d+(?:\.\d+)? runs/s", "<n> runs/s", text)
    lines, timings = [], False
    for line in text.splitlines():
        # the Timings section: its table, or its one line of stages, up to the next heading
        timings = "Timings" in line or (timings and not line.startswith("#"))
        lines.append(re.sub(r"\d+(?:\.\d+)?", "<t>", line) if timings else line)
    return _VERSIONS.sub(r"\1 <version>", _SECONDS.sub("<t>", "\n".join(lines) + "\n"))


def unshare(text: str) -> str:
    """`text` with the shared data folder's absolute path written `<shared>` (snapshots are committed and
    compared across machines)."""
    return text.replace(json.dumps(str(SHARED))[1:-1], "<shared>").replace(str(SHARED), "<shared>")


def strip(tree):
    """The summary without its run-to-run keys (`VOLATILE`), at any depth."""
    if isinstance(tree, dict):
        return {k: strip(v) for k, v in tree.items() if k not in VOLATILE}
    if isinstance(tree, list):
        return [strip(v) for v in tree]
    return tree


def differences(a, b, *, rtol: float = 0.0, path: str = ""):
    """Paths where two JSON trees differ: numbers beyond `rtol` (relative), anything else when not equal."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                yield f"{path}/{k}: {'missing before' if k not in a else 'missing after'}"
            else:
                yield from differences(a[k], b[k], rtol=rtol, path=f"{path}/{k}")
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            yield f"{path}: length {len(a)} -> {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            yield from differences(x, y, rtol=rtol, path=f"{path}[{i}]")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        both_nan = isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)
        if not both_nan and abs(a - b) > rtol * max(abs(a), abs(b)):
            yield f"{path}: {a!r} -> {b!r}"
    elif a != b:
        yield f"{path}: {a!r} -> {b!r}"


def run(out: pathlib.Path, only: list[str] | None) -> int:
    out.mkdir(parents=True, exist_ok=True)
    names = only or list(CASES)
    unknown = sorted(set(names) - set(CASES))
    if unknown:
        raise SystemExit(f"unknown cases {unknown}; known: {', '.join(CASES)}")
    failed = 0
    for name in names:
        argv, needs = CASES[name]
        missing = [str(p) for p in needs if not p.exists()]
        if missing:
            print(f"{name:28s} skipped: {', '.join(missing)} not found (set JAXSDP_SHARED)")
            continue
        work = pathlib.Path(tempfile.mkdtemp(prefix=f"snapshot-{name}-"))
        t0 = time.perf_counter()
        printed, warned = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(warned):
            code = jaxsdp_main([*argv, "--out", str(work / "out"), "--quiet"])
        seconds = time.perf_counter() - t0
        if code != 0:
            print(f"{name:28s} FAILED (exit {code})")
            failed += 1
        else:
            summary = json.loads(unshare((work / "out" / "summary.json").read_text()))
            summary = strip(summary)
            (out / f"{name}.json").write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n")
            (out / f"{name}.report.md").write_text(mask(unshare((work / "out" / "report.md").read_text())))
            (out / f"{name}.stdout.txt").write_text(mask(unshare(printed.getvalue())))
            (out / f"{name}.stderr.txt").write_text(mask(unshare(warned.getvalue())))
            print(f"{name:28s} {seconds:6.1f} s -> {out / (name + '.json')}")
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failed else 0


def compare(before: pathlib.Path, after: pathlib.Path, rtol: float) -> int:
    a_names = {p.stem for p in before.glob("*.json")}
    b_names = {p.stem for p in after.glob("*.json")}
    diff = 0
    for name in sorted(a_names ^ b_names):
        print(f"{name}: only in {'before' if name in a_names else 'after'}")
        diff += 1
    for name in sorted(a_names & b_names):
        a = json.loads((before / f"{name}.json").read_text())
        b = json.loads((after / f"{name}.json").read_text())
        lines = list(differences(a, b, rtol=rtol))
        verdict = "identical" if not lines else f"{len(lines)} differences"
        print(f"{name}: {verdict}" + (f" (rtol {rtol:g})" if rtol > 0 else ""))
        for line in lines[:50]:
            print(f"  {line}")
        if len(lines) > 50:
            print(f"  ... and {len(lines) - 50} more")
        diff += bool(lines)
        for kind in ("report.md", "stdout.txt", "stderr.txt"):  # the texts a user reads, timings and versions masked
            fa, fb = before / f"{name}.{kind}", after / f"{name}.{kind}"
            if fa.exists() and fb.exists():
                text = list(difflib.unified_diff(fa.read_text().splitlines(), fb.read_text().splitlines(), lineterm=""))
                print(f"{name} {kind}: {'identical' if not text else f'{len(text)} diff lines'}")
                for line in text[:40]:
                    print(f"  {line}")
                diff += bool(text)
    return 1 if diff else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run every study and keep its summary.json")
    r.add_argument("out", type=pathlib.Path)
    r.add_argument("--only", type=lambda s: s.split(","), default=None, help="comma-separated case names")
    sub.add_parser("list", help="name the cases")
    c = sub.add_parser("compare", help="compare two snapshots; exit 1 on any difference")
    c.add_argument("before", type=pathlib.Path)
    c.add_argument("after", type=pathlib.Path)
    c.add_argument("--rtol", type=float, default=0.0)
    args = ap.parse_args(argv)
    if args.command == "list":
        for name, (cmd, _) in CASES.items():
            print(f"{name:28s} jaxsdp {' '.join(cmd)}")
        return 0
    if args.command == "run":
        return run(args.out, args.only)
    return compare(args.before, args.after, args.rtol)


if __name__ == "__main__":
    sys.exit(main())
