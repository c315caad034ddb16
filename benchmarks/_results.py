"""What the docs quote from runs, read from the saved results (`benchmarks/results/`), never typed.

- `gpu_table(folder)` turns the logs that `python benchmarks/gpu.py --all` writes on
  a GPU machine into the performance page's GPU table
  (`tests/test_benchmark_results.py` checks that every row is found);
- `render_quotes(markdown)` fills a page's `{{ run CASE /json/path FORMAT }}`
  and `{{ stdout CASE }}` from the snapshot of the study runs in
  `benchmarks/results/studies/` (`tests/test_docs_numbers.py` checks them
  against fresh runs), `{{ bench NAME /path FORMAT }}` from the saved
  benchmark results, and `{{ calc FORMAT : EXPR }}` from arithmetic on such
  values (a z against a published value, a ratio, a difference);
  `{{ bench-table scaling TASK }}` becomes the table of one task of
  `benchmarks/scaling.py`'s saved run (`scaling_table`).

The docs hook (`docs/hooks.py`) calls both at build time.
"""

import ast
import json
import math
import operator
import pathlib
import re

GPU = pathlib.Path(__file__).resolve().parent / "results" / "gpu"

_TIME = r"([\d.]+) (ms|s)"
_KERNEL = re.compile(rf"^  (?P<task>\S.*?)\s{{2,}}{_TIME}\s+{_TIME}\s+[\d.]+\s+(?P<diff>\S+)")
_FAILED = re.compile(r"^  (?P<task>\S.*?)\s{2,}failed: (?P<why>.*)$")
_SIM = re.compile(rf"^  (?P<task>(?:\s\s)?\S.*?)\s{{2,}}{_TIME}\s+\(compile\+first ([\d.]+) s\)")
_CPU_SIM = re.compile(rf"^    the same single run on the CPU device\s+{_TIME}")
_EMPS = re.compile(r"^EMPS pipeline (\w+) first ([\d.]+) best ([\d.]+)")


def _s(value, unit):
    return float(value) * (1e-3 if unit == "ms" else 1.0)


def fmt(t: float) -> str:
    """Seconds as the tables print them: ms below 1 s."""
    return f"{t * 1e3:.3g} ms" if t < 1.0 else f"{t:.3g} s"


def _lines(folder, name):
    path = folder / name
    return [ln for ln in path.read_text().splitlines() if not ln.startswith("W1")] if path.exists() else []


def kernel_rows(folder: pathlib.Path, name: str) -> dict:
    """task -> {'sequential': s, 'parallel': s, 'diff': str} or {'failed': why}, from a `gpu.py` log."""
    rows = {}
    for ln in _lines(folder, name):
        if m := _KERNEL.match(ln):
            rows[m["task"]] = dict(sequential=_s(m[2], m[3]), parallel=_s(m[4], m[5]), diff=m["diff"])
        elif m := _FAILED.match(ln):
            rows[m["task"]] = dict(failed=m["why"])
        elif m := _SIM.match(ln):
            rows[m["task"].strip()] = dict(seconds=_s(m[2], m[3]), compile=float(m[4]))
        elif m := _CPU_SIM.match(ln):
            rows["the same single run on the CPU device"] = dict(seconds=_s(m[1], m[2]))
    return rows


def montecarlo_rows(folder: pathlib.Path, name: str = "montecarlo.txt") -> dict:
    """(task, runs) -> seconds, from a `montecarlo.py` log (runner after compile; studies with compilation)."""
    rows = {}
    for ln in _lines(folder, name):
        m = re.match(r"^  (runner|control|identification), n =\s*([\d,]+):\s+([\d.]+) s", ln)
        if m:
            rows[(m[1], int(m[2].replace(",", "")))] = float(m[3])
        m = re.match(r"^  peer: one vmap over all ([\d,]+):\s+([\d.]+) s", ln)
        if m:
            rows[("one vmap", int(m[1].replace(",", "")))] = float(m[2])
    return rows


def environment(folder: pathlib.Path, name: str = "env.txt") -> dict:
    """The device, driver, date and JAX version that `gpu.py --all` printed first."""
    lines = _lines(folder, name)
    device, driver, memory = (x.strip() for x in lines[1].split(","))
    jax_version = next(ln.split()[1] for ln in lines if ln.startswith("jax "))
    date = next(ln for ln in lines[2:] if re.search(r"\b20\d\d\b", ln))
    return dict(device=device, driver=driver, memory=memory, date=date, jax=jax_version)


def _verdict(seconds, target):
    if target is None:
        return ""
    if math.isinf(seconds):
        return f"<= {fmt(target)}: missed (out of memory)"
    return f"<= {fmt(target)}: {'met' if seconds <= target else f'missed ({seconds / target:.1f}x)'}"


#: How `gpu.py --all` runs `montecarlo.py` (its `ALL` reads this; README.md): XLA's command buffers
#: off, because with them on, instantiating the identification study's CUDA graph ran out of memory in an earlier run.
MONTECARLO_XLA_FLAGS = "--xla_gpu_enable_command_buffer="


def _json(folder: pathlib.Path, name: str) -> dict | None:
    path = folder / name
    return json.loads(path.read_text()) if path.exists() else None


def _when(doc: dict, env: dict) -> str:
    """`, DATE` when a saved run is not from the day of `env.txt`'s run, else nothing."""
    return f", {doc['date']}" if doc.get("date") and doc["date"] != env["date"] else ""


def gpu_table(folder: pathlib.Path = GPU) -> str:
    """The performance page's GPU table, from the logs in `folder` (see its README.md for each file's command):
    `gpu.txt`/`gpu.json` (kernels, closed loops, peers), `montecarlo.*`, `robot_stacked.json` (with pinocchio's loop
    on the same machine's CPU) from one `gpu.py --all`; the out-of-memory batch of 10,000 series and the earlier
    sequential times from `gpu-batch10000.txt` and `emps_pipeline.txt`; the other files' rows name their run."""
    env = environment(folder)
    main, big = kernel_rows(folder, "gpu.txt"), kernel_rows(folder, "gpu-batch10000.txt")
    compiled = {r["task"]: r for r in (_json(folder, "gpu.json") or {"rows": []})["rows"]}
    earlier = {t: r["sequential"] for t, r in big.items() if "sequential" in r}
    earlier.update(
        {
            "EMPS pipeline after compile": float(m[3])
            for ln in _lines(folder, "emps_pipeline.txt")
            if (m := _EMPS.match(ln)) and m[1] == "sequential"
        }
    )
    mc = montecarlo_rows(folder)
    robot = json.loads((folder / "robot_stacked.json").read_text())
    out = [
        f"Measured on one {env['device']} ({env['memory']}, driver {env['driver']}), jax {env['jax']}, float64, "
        f"{env['date']}, by one `python benchmarks/gpu.py --all` (each benchmark in its own process); rows from other "
        "runs name their date. Times after compilation unless the row says otherwise.",
        "",
        "| task | sequential kernels | parallel kernels (`auto` on a GPU) | target on one GPU |",
        "|---|---|---|---|",
    ]

    def kernel(task, rows, target, label=None):
        r = rows[task]
        if "failed" in r:
            why = "out of memory" if "RESOURCE_EXHAUSTED" in r["failed"] else r["failed"]
            size = re.search(r"allocate ([\d.]+GiB)", r["failed"])
            out.append(
                f"| {label or task} | not run | {why}{f' (one {size[1]} buffer)' if size else ''} | "
                f"{_verdict(float('inf'), target) if target else ''} |"
            )
            return
        before = f" (an earlier run: {fmt(earlier[task])})" if rows is main and task in earlier else ""
        out.append(
            f"| {label or task} | {fmt(r['sequential'])}{before} | {fmt(r['parallel'])} (same to {r['diff']}) | "
            f"{_verdict(r['parallel'], target)} |"
        )

    kernel("dlr IRW, one series of 25,000", main, 5e-3, "`dlr` IRW, one series of 25,000")
    batch = next(t for t in main if t.startswith("dlr IRW, vmap"))
    kernel(batch, main, None, f"`{batch[:3]}`{batch[3:]} (shared regressor)")
    kernel(
        "dlr IRW, vmap 10,000 series of 25,000",
        big,
        0.3,
        f"`dlr` IRW, vmap 10,000 series of 25,000 (the first run, `gpu.py --batch 10000`{_first_date(folder)})",
    )
    kernel("log-likelihood + jvp, 25,000", main, 5e-3, "log-likelihood + derivative (jvp), 25,000")
    kernel("sdp, 2 terms, ML NVRs, 25,000", main, 0.3, "`sdp`, 2 terms, ML NVRs, 25,000")
    emps = "EMPS pipeline after compile"
    c = compiled.get(emps, {})
    first = (
        f", compile + first call {c['sequential_compile_first']:.3g} s / {c['parallel_compile_first']:.3g} s"
        if "parallel_compile_first" in c
        else ""
    )
    kernel(emps, main, 0.5, f"EMPS pipeline on DATA_EMPS.mat (`emps_study`, eager){first}")
    sources = [f"the first run, `gpu-batch10000.txt`{_first_date(folder)}"] if big else []
    sources += ["the EMPS row run alone, `emps_pipeline.txt`"] if emps in earlier else []
    if any(task in earlier for task in main):
        out += [
            "",
            "An earlier run: the same row's sequential kernels on an H200 in an earlier session "
            f"({'; '.join(sources)}).",
        ]

    def sim(task):
        return main.get(task) or big[task]

    one = sim("EMPS closed loop 25 s at 1 kHz, one run")
    cpu = sim("the same single run on the CPU device")
    many = next((t, r) for t, r in {**big, **main}.items() if t.startswith("EMPS closed loop, vmap"))
    off = "XLA command buffers off"
    out += [
        "",
        "| closed loops and Monte Carlo (sequential scans over time) | on the GPU | note |",
        "|---|---|---|",
        f"| EMPS closed loop 25 s at 1 kHz, one run | {fmt(one['seconds'])} | {fmt(cpu['seconds'])} on the same "
        "machine's CPU device: run single simulations there |",
        f"| {many[0]} (one `jax.vmap`) | {fmt(many[1]['seconds'])} | about one run's time |",
    ]
    for n in sorted({n for (task, n) in mc if task == "runner"}):
        out.append(
            f"| `monte_carlo` runner, {n:,} closed loops (statistics only; {off}) | {fmt(mc[('runner', n)])} "
            f"({n / mc[('runner', n)]:,.0f} runs/s) | default width 2048 draws per group"
            + (f"; one `vmap` over all {n:,}: {fmt(mc[('one vmap', n)])}" if ("one vmap", n) in mc else "")
            + " |"
        )
    for n in sorted({n for (task, n) in mc if task == "control"}):
        target = "target 10,000 <= 2 s: " + ("met" if mc[("control", n)] <= 2 else "missed") if n == 10_000 else ""
        out.append(
            f"| `control_robustness`, {n:,} runs, compilation included ({off}) | {fmt(mc[('control', n)])} | {target} |"
        )
    for n in sorted(n for (task, n) in mc if task == "identification"):
        t = mc[("identification", n)]
        out.append(
            f"| `identification_robustness`, {n:,} runs, compilation included ({off}: `XLA_FLAGS="
            f"{MONTECARLO_XLA_FLAGS}`) | {fmt(t)} ({n / t:,.0f} runs/s) | each run the EMPS study's pipeline after "
            "one experiment; with command buffers on, instantiating a CUDA graph ran out of memory in an earlier run |"
        )
    ident, ident_doc = pipeline_mc(folder), _json(folder, "montecarlo_ident.json") or {}
    for n in sorted(ident):
        out.append(
            f"| `identification_robustness`, {n:,} runs, compilation included (command buffers on, XLA's default; "
            f"issue 44's session{_when(ident_doc, env)}) | {fmt(ident[n])} ({n / ident[n]:,.0f} runs/s) | the same "
            "study on issue 44's working tree (`montecarlo_ident.*`) |"
        )
    robot_mc = _json(folder, "robot_montecarlo.json")
    for r in robot_mc["rows"] if robot_mc else []:
        out.append(
            f"| `robot_robustness`, six-joint TX40, {r['runs']:,} runs (simulation + robot pipeline; "
            f"`robot_montecarlo.py`{_when(robot_mc, env)}) | {fmt(r['seconds'])} ({r['runs_per_s']:.2f} runs/s; "
            f"{fmt(r['wall_s'])} with the set-up and compilation) | coverage of the 95 % intervals: median "
            f"{r['coverage_median']:.0%}, min {r['coverage_min']:.0%} |"
        )
    robot_iv = _json(folder, "robot_montecarlo_iv.json")
    for r in robot_iv["rows"] if robot_iv else []:
        out.append(
            f"| `robot_robustness` with IDIM-IV, two-link arm in closed loop, {r['runs']:,} runs "
            f"(`robot_montecarlo.py --iv-runs`{_when(robot_iv, env)}) | {fmt(r['seconds'])} ({r['runs_per_s']:.2f} "
            f"runs/s; {fmt(r['wall_s'])} with the set-up and compilation) | coverage of the 95 % intervals: IDIM-IV "
            f"median {r['iv_coverage_median']:.1%}, min {r['iv_coverage_min']:.1%}; IDIM-LS median "
            f"{r['coverage_median']:.0%}, min {r['coverage_min']:.0%} (the CPU run's figures to the last digit) |"
        )
    keyed = {r.get("key"): r for r in robot.get("rows", [])}
    ls = f", IDIM-LS {fmt(keyed['regressor']['ls_s'])}" if "ls_s" in keyed.get("regressor", {}) else ""
    pin = keyed.get("pinocchio-regressor")
    out.append(
        f"| six-joint TX40 stacked regressor + IDIM-LS, {robot['states']:,} states (`robot_stacked.py`) | "
        f"{fmt(robot['regressor_ls_s'])} (regressor alone {fmt(robot['regressor_s'])}{ls}) | "
        f"compile {robot['compile_s']:.2g} s |"
    )
    if pin:
        met = "met" if pin["regressor_ratio"] < 0.5 else "missed"
        # a row kept from an earlier run (no pinocchio on the later machine) says when it was measured
        where = "the same machine's CPU"
        if "measured" in pin:
            where = f"the CPU of a machine of the same kind, {pin['measured']}"
        out.append(
            f"| pinocchio's `computeJointTorqueRegressor` in a Python loop over the same {robot['states']:,} states, "
            f"on {where} (regressor only) | {fmt(pin['seconds'])} | jaxsdp on the GPU / pinocchio: "
            f"regressor {pin['regressor_ratio']:.2g} (issue 46's target: below 0.5, {met}), regressor + IDIM-LS "
            f"{pin['ratio']:.2g} |"
        )
    out += peers_table(folder, main)
    out += pipeline_table(folder)
    return "\n".join(out)


def _first_date(folder: pathlib.Path) -> str:
    """The date of the first run (`env-batch10000.txt`, as `date` printed it) as `, YYYY-MM-DD`, else nothing."""
    import datetime

    for ln in _lines(folder, "env-batch10000.txt"):
        try:
            return ", " + datetime.datetime.strptime(ln.strip(), "%a %b %d %I:%M:%S %p UTC %Y").date().isoformat()
        except ValueError:
            continue
    return ""


def peers_table(folder: pathlib.Path, kernels: dict) -> list[str]:
    """The parallel-in-time smoothers of the JAX state-space libraries on the GPU (`gpu.json`'s rows of the group
    "peers", from the same process as the kernels) beside jaxsdp's parallel `dlr` on the same problem."""
    run = _json(folder, "gpu.json")
    rows = [r for r in run["rows"] if r.get("group") == "peers" and "seconds" in r] if run else []
    if not rows:
        return []
    ours = kernels["dlr IRW, one series of 25,000"]["parallel"]
    out = [
        "",
        f"The parallel-in-time smoothers of the JAX state-space libraries on the same IRW problem (one series of "
        f"25,000, float64), in the same `benchmarks/gpu.py` process as the kernels above ({run['device']}, jax "
        f"{run['jax']}, {run['date']}):",
        "",
        "| smoother | on the GPU, after compilation | against jaxsdp's parallel `dlr` | largest difference to `dlr` "
        "(means, variances) |",
        "|---|---|---|---|",
        f"| jaxsdp `dlr`, parallel | {fmt(ours)} | 1 | - |",
    ]
    for r in rows:
        out.append(
            f"| {r['task']} | {fmt(r['seconds'])} | {r['seconds'] / ours:.2g}x | {r['means']:.1e}, "
            f"{r['variances']:.1e} |"
        )
    return out


def pipeline_mc(folder: pathlib.Path) -> dict:
    """runs -> seconds of the identification Monte Carlo in `montecarlo_ident.json` (the pipeline's, issue 44)."""
    path = folder / "montecarlo_ident.json"
    if not path.exists():
        return {}
    rows = json.loads(path.read_text())["rows"]
    return {r["runs"]: r["seconds"] for r in rows if r.get("task") == "identification_robustness"}


def pipeline_table(folder: pathlib.Path) -> list[str]:
    """The EMPS pipeline as one jitted Module on the GPU (`pipeline.json`, `emps_pipeline.py --data builtin`)."""
    path = folder / "pipeline.json"
    if not path.exists():
        return []
    run = json.loads(path.read_text())
    rows = {r["key"]: r for r in run["rows"]}
    one, iv = rows["pipeline-jit"], rows["pipeline-jit-iv"]
    out = [
        "",
        f"The EMPS estimation as one pure Module (`EMPSPipeline`, `benchmarks/emps_pipeline.py --data builtin`, "
        f"{run['device']}, jax {run['jax']}, {run['date']}), on the built-in record (24,841 samples):",
        "",
        "| task | on the GPU, after compilation | compile + first call | target |",
        "|---|---|---|---|",
        f"| `jax.jit(EMPSPipeline())`: IDIM-LS, SDP stage (ML NVRs), IDIM-SDP | {fmt(one['seconds'])} | "
        f"{fmt(one['first_s'])} | {_verdict(one['seconds'], 0.5)} (EMPS pipeline <= 0.5 s) |",
        f"| the same with IDIM-IV (bias-compensated, closed-loop instruments) | {fmt(iv['seconds'])} | "
        f"{fmt(iv['first_s'])} | |",
        f"| `emps_study` end to end, eager (the stages one by one, plus the checks) | "
        f"{fmt(rows['emps-study']['seconds'])} | | |",
    ]
    for key in sorted((k for k in rows if k.startswith("pipeline-vmap-")), key=lambda k: rows[k]["batch"]):
        r = rows[key]
        out.append(
            f"| `jax.vmap` over {r['batch']:,} records | {fmt(r['seconds'])} ({r['records_per_s']:,.0f} records/s) | "
            f"{fmt(r['first_s'])} | |"
        )
    return out


# ---- numbers quoted from the study runs (issue 43): `{{ run CASE /json/path FORMAT }}` in a page ----

#: The snapshot of the fixed set of study runs the pages quote (`python benchmarks/study_snapshot.py run
#: benchmarks/results/studies`): `<case>.json` (summary.json without its run-to-run keys), `<case>.stdout.txt`.
STUDIES = pathlib.Path(__file__).resolve().parent / "results" / "studies"
#: A number quoted from a run: `{{ run emps-real /idim_ls/M .4f }}`; FORMAT is a Python format spec (one ending
#: in `%` prints a fraction as a percentage without the sign; an exponent comes without padding, `1.6e-6`), by
#: default the value as JSON prints it; `yesno` for a boolean; `time` for seconds (`fmt`); `len`, and `min:`,
#: `max:`, `range:` before a spec over a `*` path, e.g.
#: `{{ run montecarlo-identification-256 /estimators/idim_iv/parameters/*/coverage_95 range:.0% }}`.
#: `{{ stdout CASE }}` is the whole printed output of a case, `{{ stderr CASE }}` its warnings.
QUOTE = re.compile(r"\{\{ run (?P<case>[\w.-]+) (?P<path>/[^\s}]*)(?: (?P<fmt>[^\s}]+))? \}\}")
STDOUT = re.compile(r"\{\{ (?P<stream>stdout|stderr) (?P<case>[\w.-]+) \}\}")
#: The saved JSON of the benchmark scripts run on the project's CPU machine (`python benchmarks/NAME.py --json
#: benchmarks/results/cpu/NAME.json`): a page quotes `{{ bench NAME /rows/@KEY/FIELD FORMAT }}` (a row chosen by
#: its `key`), and `{{ bench NAME /date }}`, `/device`, `/commit` for where and when it ran.
CPU = pathlib.Path(__file__).resolve().parent / "results" / "cpu"
BENCH = re.compile(r"\{\{ bench (?P<case>[\w.-]+) (?P<path>/[^\s}]*)(?: (?P<fmt>[^\s}]+))? \}\}")
#: A table generated from a scaling run's rows: `{{ bench-table scaling TASK }}` (`scaling_table`), so that the page
#: shows whatever sizes the saved run measured.
TABLE = re.compile(r"\{\{ bench-table (?P<case>[\w.-]+) (?P<task>[\w.-]+) \}\}")


#: A number worked out from quoted values: `{{ calc +.1f : ([emps-real /idim_ls/Fc] - 20.53) / (0.0064 * 20.53) }}`.
#: `[CASE /path]` is a snapshot value, `[bench:NAME /path]` a benchmark result's; EXPR is Python arithmetic
#: (+ - * / ** and parentheses, numbers, abs, min, max, sqrt, log, log10, len, sum over a `*` path's list).
CALC = re.compile(r"\{\{ calc (?P<fmt>[^\s:}]+) : (?P<expr>.+?) \}\}")
REF = re.compile(r"\[(?P<case>(?:bench:)?[\w.-]+) (?P<path>/[^\]\s]*)\]")
_OPS = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
}
_FUNCS = {
    "abs": abs,
    "min": lambda *a: min(a[0]) if len(a) == 1 else min(a),
    "max": lambda *a: max(a[0]) if len(a) == 1 else max(a),
    "sqrt": math.sqrt,
    "log": math.log,
    "log10": math.log10,
    "len": len,
    "sum": sum,
}


def calc_refs(expr: str) -> list[tuple[str, str]]:
    """The (case, path) pairs an expression reads; a benchmark's case is `bench:NAME`."""
    return [(m["case"], m["path"]) for m in REF.finditer(expr)]


def evaluate(expr: str, value) -> float:
    """The arithmetic `expr` with each `[CASE /path]` replaced by `value(case, path)` (ValueError naming what is
    not arithmetic: no names, calls other than `_FUNCS`, attributes or subscripts)."""
    values = []

    def ref(m):
        values.append(value(m["case"], m["path"]))
        return f"_v{len(values) - 1}"

    tree = ast.parse(REF.sub(ref, expr), mode="eval")

    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return node.value
        if isinstance(node, ast.Name) and node.id.startswith("_v"):
            return values[int(node.id[2:])]
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.operand))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCS:
            return _FUNCS[node.func.id](*(ev(a) for a in node.args))
        raise ValueError(f"{expr}: only arithmetic on quoted values is allowed, not {ast.dump(node)[:60]}")

    return ev(tree)


def lookup(tree, path: str):
    """The value at a JSON path such as `/recovery/MX3/z` or `/warnings/0` (KeyError naming the path); a `*`
    segment takes every child (a list of the values below it, for `min:`/`max:`/`range:` formats)."""
    parts = [p for p in path.split("/") if p]
    node = tree
    for i, part in enumerate(parts):
        if part == "*":
            children = node.values() if isinstance(node, dict) else node
            rest = "/" + "/".join(parts[i + 1 :])
            return [lookup(child, rest) for child in children]
        if isinstance(node, list) and part.startswith("@"):  # the row whose "key" is this (benchmark rows)
            found = [row for row in node if isinstance(row, dict) and row.get("key") == part[1:]]
            if len(found) != 1:
                keys = ", ".join(str(row.get("key")) for row in node if isinstance(row, dict))
                raise KeyError(f"{path}: {len(found)} rows with key {part[1:]!r} (keys: {keys})")
            node = found[0]
        elif isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise KeyError(f"{path}: no item {part!r} in a list of {len(node)}")
            node = node[int(part)]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            keys = ", ".join(sorted(node)) if isinstance(node, dict) else type(node).__name__
            raise KeyError(f"{path}: no {part!r} (there: {keys})")
    return node


_EXPONENT = re.compile(r"([eE])([+-])0*(\d)")


def _spec(value, spec: str) -> str:
    """`format(value, spec)`, except that a spec ending in `%` prints the percentage without its sign (0.955 with
    `.1%` gives `95.5`: the pages write ` %` after it, with a space), an exponent is printed without its padding
    and plus sign (`.1e` of 1.6e-06 gives `1.6e-6`, of 2.98e+05 `3.0e5`, as the pages write `1e-9`), and `yesno`
    prints a boolean as `yes` or `no`; `time` prints seconds as the tables do (`fmt`: ms below 1 s)."""
    if spec == "time":
        return fmt(value)
    if spec == "yesno":
        if not isinstance(value, bool):
            raise TypeError(f"yesno formats a boolean, not {value!r}")
        return "yes" if value else "no"
    if spec.endswith("%"):
        return format(100 * value, spec[:-1] + "f")
    return _EXPONENT.sub(lambda m: m[1] + ("-" if m[2] == "-" else "") + m[3], format(value, spec))


def formatted(value, fmt: str | None) -> str:
    """`value` as the page prints it: through the format spec (`len`: the length of a list; `min:SPEC`, `max:SPEC`,
    `range:SPEC`: of the values a `*` path collected, a range printed `low-high`), or as JSON prints it."""
    if fmt is None:
        return value if isinstance(value, str) else json.dumps(value)
    if fmt == "len":
        return str(len(value))
    for how in ("min:", "max:", "range:"):
        if fmt.startswith(how):
            values = [v for v in value if v is not None]
            spec = fmt[len(how) :]
            if how == "range:":
                low, high = _spec(min(values), spec), _spec(max(values), spec)
                return low if low == high else f"{low}-{high}"
            return _spec(min(values) if how == "min:" else max(values), spec)
    return _spec(value, fmt)


def bench(name: str, folder: pathlib.Path = CPU) -> dict:
    """The saved JSON of benchmark `name` (KeyError naming the command that writes it)."""
    path = folder / f"{name}.json"
    if not path.exists():
        raise KeyError(f"no {path.name} in results/{folder.name}/ (python benchmarks/{name}.py --json {path.name})")
    return json.loads(path.read_text())


def summaries(folder: pathlib.Path = STUDIES) -> dict:
    """case -> its summary (without the run-to-run keys), for every case in the snapshot folder."""
    return {p.stem: json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))}


def scaling_table(doc: dict, task: str) -> str:
    """The markdown table of one task of a `benchmarks/scaling.py` run: a line per size, a column per series (time
    after compilation, compile time, peak memory of its process, log-log slope from the size before; on a peer's
    column the ratio jaxsdp / peer and the largest difference of the results), a failed row's error; its notes
    below (KeyError naming the tasks when the run has none of `task`)."""
    rows = [r for r in doc["rows"] if r.get("task") == task and not r["key"].endswith("-summary")]
    if not rows:
        tasks = ", ".join(dict.fromkeys(str(r.get("task")) for r in doc["rows"]))
        raise KeyError(f"no rows of the task {task!r} in the scaling run (tasks: {tasks})")
    series = list(dict.fromkeys(r["series"] for r in rows))
    labels = {r["series"]: r["label"] for r in rows}
    by = {(r["series"], r["size"]): r for r in rows}
    out = [f"| {rows[0]['unit']} | " + " | ".join(labels[s] for s in series) + " |", "|---" * (len(series) + 1) + "|"]
    for size in sorted({r["size"] for r in rows}):
        out.append(f"| {size:,} | " + " | ".join(_scaling_cell(by.get((s, size))) for s in series) + " |")
    notes = doc.get("notes", {}).get(task, [])
    return "\n".join(out + ([""] + [f"Note: {n}." for n in notes] if notes else []))


#: The optional parts of a scaling cell, in order: a row's field and how it is written.
_CELL_PARTS = (
    ("predicted_gb", "covariances kept {:.3g} GB"),
    ("sweeps", "{} sweeps"),
    ("runs_per_s", "{:,.0f} runs/s"),
    ("slope", "slope {:.2f}"),
    ("ratio", "jaxsdp / this {:.3g}"),
    ("regressor_ratio", "(regressor alone {:.3g})"),
)


def _scaling_cell(r: dict | None) -> str:
    if r is None:
        return ""
    if r.get("error"):
        peak = r.get("peak_rss_gb")
        ran = peak is not None and not r["error"].startswith("not run")
        return ("failed: " + r["error"] + (f" (peak {peak:.2f} GB)" if ran else "")).replace("|", "\\|")
    parts = [fmt(r["seconds"])]
    if r.get("compile_s") is not None:
        parts.append(f"compile {r['compile_s']:.1f} s")
    if (r.get("recompile_s") or 0.0) > 0.01:
        parts.append(f"of which compiling again {fmt(r['recompile_s'])}")
    parts.append(f"{r['peak_rss_gb']:.2f} GB")
    parts += [text.format(r[key]) for key, text in _CELL_PARTS if r.get(key) is not None]
    if r.get("max_abs_difference") is not None:
        parts.append(f"same to {_spec(r['max_abs_difference'], '.0e')}")
    return ", ".join(parts)


def render_quotes(markdown: str, folder: pathlib.Path = STUDIES) -> str:
    """The page with every `{{ run ... }}`, `{{ stdout ... }}` and `{{ stderr ... }}` replaced by the snapshot's
    value, every `{{ bench ... }}` by the saved benchmark result's, every `{{ bench-table ... }}` by its table."""
    cache = {}

    def summary(case):
        if case not in cache:
            path = folder / f"{case}.json"
            if not path.exists():
                raise KeyError(f"no snapshot of the case {case!r} in {folder.name}/ (run benchmarks/study_snapshot.py)")
            cache[case] = json.loads(path.read_text())
        return cache[case]

    def value(case, path):
        return lookup(bench(case[6:]) if case.startswith("bench:") else summary(case), path)

    markdown = QUOTE.sub(lambda m: formatted(lookup(summary(m["case"]), m["path"]), m["fmt"]), markdown)
    markdown = BENCH.sub(lambda m: formatted(lookup(bench(m["case"]), m["path"]), m["fmt"]), markdown)
    markdown = TABLE.sub(lambda m: scaling_table(bench(m["case"]), m["task"]), markdown)
    markdown = CALC.sub(lambda m: formatted(evaluate(m["expr"], value), m["fmt"]), markdown)
    return STDOUT.sub(lambda m: (folder / f"{m['case']}.{m['stream']}.txt").read_text().rstrip("\n"), markdown)
