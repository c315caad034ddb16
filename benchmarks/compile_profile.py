"""Where the test suite's compilation goes: `JAXSDP_COMPILE_LOG=DIR pytest ...`, then `python
benchmarks/compile_profile.py DIR [--top N]`.

Prints the seconds of tracing, lowering and XLA compilation in all, by test file, and the programs compiled most
often or longest (name, count, seconds, the files that compiled them). A program compiled by many files is a
candidate for one shape or one session fixture; a file whose compilation is most of its time is a candidate for a
smaller problem of the same shape as another file's.
"""

import argparse
import collections
import json
import pathlib


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=pathlib.Path)
    ap.add_argument("--top", type=int, default=25)
    args = ap.parse_args(argv)
    records = [json.loads(line) for f in sorted(args.folder.glob("*.jsonl")) for line in f.read_text().splitlines()]
    total = collections.Counter()
    by_file = collections.defaultdict(collections.Counter)
    programs = collections.defaultdict(lambda: {"n": 0, "s": 0.0, "files": collections.Counter()})
    for r in records:
        total[r["kind"]] += r["s"]
        file = r["test"].split("::")[0]
        by_file[file][r["kind"]] += r["s"]
        if r["kind"] == "compile":
            p = programs[r["fun"]]
            p["n"] += 1
            p["s"] += r["s"]
            p["files"][file] += 1
    print("seconds in all: " + ", ".join(f"{k} {v:.0f}" for k, v in sorted(total.items())))
    print(f"\nby test file (top {args.top} by compile seconds): file, compile, lower, trace")
    for file, c in sorted(by_file.items(), key=lambda kv: -kv[1]["compile"])[: args.top]:
        print(f"  {file:70s} {c['compile']:8.1f} {c['lower']:7.1f} {c['trace']:7.1f}")
    print(f"\nprograms (top {args.top} by compile seconds): name, compilations, seconds, files")
    for name, p in sorted(programs.items(), key=lambda kv: -kv[1]["s"])[: args.top]:
        files = ", ".join(f"{f.rsplit('/', 1)[-1]} x{n}" for f, n in p["files"].most_common(4))
        more = len(p["files"]) - 4
        print(f"  {name[:60]:60s} {p['n']:5d} {p['s']:8.1f}  {files}{f' +{more} files' if more > 0 else ''}")


if __name__ == "__main__":
    main()
