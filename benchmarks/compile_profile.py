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
    logs = [[json.loads(line) for line in f.read_text().splitlines()] for f in sorted(args.folder.glob("*.jsonl"))]
    records = [r for log in logs for r in log if not r["kind"].startswith("cache-")]
    outcomes(logs, args.top)
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
    sites(records, args.top)


def sites(records, top):
    """The lines of the project's code behind the XLA compilations (the `site` of the compile records: the
    innermost frame in the library, the tests or the benchmarks), by compile seconds: the eager operations on JAX
    arrays (a few ms each, thousands of them) show up as the lines that run them, the candidates for NumPy."""
    by_site = collections.defaultdict(lambda: {"n": 0, "s": 0.0, "funs": collections.Counter()})
    for r in records:
        if r["kind"] == "compile" and "site" in r:
            b = by_site[r["site"]]
            b["n"] += 1
            b["s"] += r["s"]
            b["funs"][r["fun"]] += 1
    if not by_site:
        return
    print(f"\ncall sites (top {top} by compile seconds): line, compilations, seconds, programs")
    for site, b in sorted(by_site.items(), key=lambda kv: -kv[1]["s"])[:top]:
        funs = ", ".join(f"{f} x{n}" for f, n in b["funs"].most_common(3))
        print(f"  {site[:80]:80s} {b['n']:5d} {b['s']:7.1f}  {funs}")


def outcomes(logs, top):
    """The persistent cache's verdict on each XLA compilation (the `cache-*` records the test suite's compile log
    writes after it): compile seconds by verdict, and the programs compiled again in every run because they hold
    host callbacks (`eqx.error_if`)."""
    by_kind = collections.Counter()
    count = collections.Counter()
    callback = collections.defaultdict(lambda: {"n": 0, "s": 0.0, "files": collections.Counter()})
    for log in logs:
        verdict = None  # JAX logs the verdict, then the compile event (its time includes reading the cache)
        for r in log:
            if r["kind"].startswith("cache-"):
                verdict = r
            elif r["kind"] == "compile" and verdict is not None:
                kind = verdict["kind"][len("cache-") :]
                by_kind[kind] += r["s"]
                count[kind] += 1
                if kind == "callback":
                    c = callback[verdict["fun"]]
                    c["n"] += 1
                    c["s"] += r["s"]
                    c["files"][r["test"].split("::")[0].rsplit("/", 1)[-1]] += 1
                verdict = None
    if not count:
        return
    print("persistent cache, compilations (seconds) by verdict: ", end="")
    print(", ".join(f"{k} {count[k]} ({v:.0f} s)" for k, v in sorted(by_kind.items())))
    print(f"\nprograms not cached for their host callbacks (top {top} by compile seconds): name, compilations, s")
    for name, c in sorted(callback.items(), key=lambda kv: -kv[1]["s"])[:top]:
        files = ", ".join(f"{f} x{n}" for f, n in c["files"].most_common(3))
        print(f"  {name[:60]:60s} {c['n']:5d} {c['s']:8.1f}  {files}")
    print()


if __name__ == "__main__":
    main()
