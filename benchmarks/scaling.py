"""Benchmark: how the cost grows with the work (issue 46, item 2), each size in its own process, with the peers.

Tasks and their series (each (series, size) is one row, measured in a fresh process: the best of up to three calls
after the first, the compile + first call, the time of that best call spent compiling again (`recompile_s`, from
`jax.monitoring`: 0 unless the function compiles on every call), the peak resident memory of that process, measured
from outside with `wait4`, so that a row killed for memory still has its figure; GB are 1024^3 bytes):

- `dlr`, N samples (default 1e3, 1e4, 1e5, 1e6, 3.6e6): one IRW regressor with a given NVR, jaxsdp's sequential
  kernel (`dlr`) and its parallel-in-time kernel (`dlr-parallel`); the peer, statsmodels'
  `UnobservedComponents(y, level="smooth trend")` (the same IRW model) with the same fixed variances and the same
  prior, `.smooth(params)` (Kalman filter and smoother, smoothed states and their variances), its largest
  difference to jaxsdp's smoothed parameter; and the memory row `dlr-p6`: six IRW regressors (12 states, the general
  kernel), which keeps the predicted and the filtered covariance of every sample for the smoother, 2 N 12^2 8 bytes
  (`predicted_gb`; 7.7 GB at 3.6e6 samples) beside the measured peak.
- `sdp`, N samples (same sizes): two RW terms with ML NVRs. No peer: CAPTAIN's `sdp` is MATLAB (not
  redistributable; recorded figures on the performance page), and no Python package does SDP back-fitting.
- `robot-joints`, n joints (2, 4, ..., 12): the stacked regressor and IDIM-LS of a chain of n revolute joints (built
  here from a modified DH table, 1 kg links) on 10,000 random states; peer: pinocchio's
  `computeJointTorqueRegressor` in a Python loop (as `robot_stacked.py`), on the same chain written as a URDF by
  `jaxsdp.plants.robot.write_urdf` (its 10 n standard columns: no drive columns, no base reduction, no LS).
- `robot-states`, S states (1e3 ... 1e6): the same for the six-joint TX40, with the same peer.
- `montecarlo`, R runs (10 ... 1e5): the Monte Carlo runner over R EMPS closed loops (25 s at 1 kHz each),
  statistics only; runs per second. No peer: the alternative is one `jax.vmap` over all runs, which
  `montecarlo.py` measures (its memory grows with R, which the runner's chunks avoid).
- `srivc`, N samples (1e3 ... 1e6): the refined IV of a second-order system. No Python peer implements SRIVC
  (`control.py` and `riv.py` compare it with an output-error fit by scipy at one size).

A peer whose package is missing is skipped, with a note in the JSON and the tables. Then per series the log-log
slope of the time between consecutive sizes (1: linear), on each peer row the ratio jaxsdp / peer at that size, and
per series a summary row (`KEY-summary`: the largest size run, the first that failed, the largest and the last
slope). A row that fails (out of memory, killed, over the time limit `--limit`) is a row with its error: where a
kernel stops fitting is a result, and the larger sizes of that series are not tried.

When the sequential `dlr` stops fitting: jaxsdp has no chunked or out-of-core smoother. Its memory grows as
N n^2 (n the state dimension); the ways out are the user's: decimate the record first (`jaxsdp.decimate`, as the
TX40 study does by 10 at 5 kHz), fit fewer or smaller blocks, or use a machine with more memory. The parallel
kernel needs more memory, not less.

    python benchmarks/scaling.py [--quick] [--only TASK ...] [--dlr N ...] [--sdp N ...] [--joints n ...]
        [--states S ...] [--runs R ...] [--riv N ...] [--limit S] [--json PATH] [--figures DIR]

`--json PATH` writes the rows (keys such as `dlr-1000000`, `dlr-statsmodels-1000000`, `robot-joints-6`,
`robot-joints-pinocchio-6`, `dlr-p6-summary`) with the machine and the date (`benchmarks/_record.py`); the
performance page quotes `benchmarks/results/cpu/scaling.json` and draws `figures` from it at build time.
`--quick` is a smoke run on small sizes. The JSON also holds the machine's memory, the peers' versions, the BLAS and
XLA environment variables and the load average at the start and the end: on a loaded machine OpenBLAS's threads
(behind numpy's and jaxlib's CPU LAPACK) wait for cores busy elsewhere, which adds a large fixed cost to every
LAPACK call (the robot rows' least squares); jaxsdp sets `OPENBLAS_THREAD_TIMEOUT=4` on import (idle threads sleep
at once instead of spinning).
"""

import argparse
import json
import math
import os
import pathlib
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]

DEFAULT = dict(
    dlr=[1e3, 1e4, 1e5, 1e6, 3.6e6],
    sdp=[1e3, 1e4, 1e5, 1e6, 3.6e6],
    joints=[2, 4, 6, 8, 10, 12],
    states=[1e3, 1e4, 1e5, 1e6],
    runs=[10, 100, 1e3, 1e4, 1e5],
    riv=[1e3, 1e4, 1e5, 1e6],
)
QUICK = dict(dlr=[1e3, 1e4], sdp=[1e3, 1e4], joints=[2, 4], states=[1e3, 1e4], runs=[10, 100], riv=[1e3, 1e4])
OPTION = {"dlr": "dlr", "sdp": "sdp", "robot-joints": "joints", "robot-states": "states", "montecarlo": "runs"}
OPTION["srivc"] = "riv"
JOINT_STATES = 10_000
NVR = 1e-3  # IRW NVR of the dlr rows (1e-9 over a million samples is too ill-conditioned to compare with a peer)
P_MEMORY = 6  # IRW regressors of the memory row (12 states)

#: task -> (series, row-key prefix, label, the package a peer needs or None); the first series is jaxsdp's main one.
SERIES = {
    "dlr": [
        ("jaxsdp", "dlr", "jaxsdp `dlr`, sequential", None),
        ("parallel", "dlr-parallel", "jaxsdp `dlr`, parallel", None),
        ("statsmodels", "dlr-statsmodels", "statsmodels `UnobservedComponents.smooth`", "statsmodels"),
        ("p6", "dlr-p6", f"jaxsdp `dlr`, {P_MEMORY} IRW regressors", None),
    ],
    "sdp": [("jaxsdp", "sdp", "jaxsdp `sdp`, 2 RW terms, ML NVRs", None)],
    "robot-joints": [
        ("jaxsdp", "robot-joints", "jaxsdp regressor + IDIM-LS", None),
        ("pinocchio", "robot-joints-pinocchio", "pinocchio regressor loop", "pinocchio"),
    ],
    "robot-states": [
        ("jaxsdp", "robot-states", "jaxsdp regressor + IDIM-LS", None),
        ("pinocchio", "robot-states-pinocchio", "pinocchio regressor loop", "pinocchio"),
    ],
    "montecarlo": [("jaxsdp", "montecarlo", "jaxsdp `monte_carlo`, EMPS closed loops", None)],
    "srivc": [("jaxsdp", "srivc", "jaxsdp `srivc`, n = 2, m = 1", None)],
}
UNIT = {"dlr": "samples", "sdp": "samples", "robot-joints": "joints", "robot-states": "states", "montecarlo": "runs"}
UNIT["srivc"] = "samples"


def _gb(kib: float) -> float:
    return kib / 1024**2


#: Seconds JAX has spent tracing, lowering and compiling in this process (a `jax.monitoring` listener adds to it).
COMPILING = [0.0]


def _count_compiling(name: str, secs: float, **_) -> None:
    if name.startswith("/jax/core/compile/"):
        COMPILING[0] += secs


def _best(fn, block=lambda x: x, repeats: int = 3, budget: float = 30.0):
    """(best seconds of up to `repeats` calls after the first, seconds of the first call, seconds of that best call
    spent compiling again: 0 unless the function recompiles on every call); no more repeats once `budget` seconds
    have been spent on them."""
    t0 = time.perf_counter()
    block(fn())
    first = time.perf_counter() - t0
    times = []
    while len(times) < repeats and sum(t for t, _ in times) < budget:
        c0, t0 = COMPILING[0], time.perf_counter()
        block(fn())
        times.append((time.perf_counter() - t0, COMPILING[0] - c0))
    best, recompile = min(times)
    return best, first, recompile


# ---- the data, the same in jaxsdp's process and the peer's ----


def dlr_data(size: int, p: int = 1):
    t = np.linspace(0.0, 1.0, size)
    rng = np.random.default_rng(0)
    if p == 1:
        return np.sin(6 * t) + 0.1 * rng.normal(size=size), np.ones((size, 1))
    k = np.arange(size)
    X = np.column_stack([np.ones(size)] + [np.sin(2 * np.pi * k / (7.0 + 5 * j) + j) for j in range(p - 1)])
    theta = np.column_stack([np.cos((j + 1) * t) for j in range(p)])
    return np.sum(X * theta, axis=1) + 0.1 * rng.normal(size=size), X


def robot_states(states: int, n: int):
    rng = np.random.default_rng(0)
    q, dq, ddq = (rng.uniform(-2, 2, (states, n)) for _ in range(3))
    return q, dq, ddq, rng.normal(size=(states, n))


def chain(n: int):
    """A chain of n revolute joints (modified DH: alternate twists of pi/2, 0.3 m links, 1 kg each)."""
    from jaxsdp.plants import SerialRobot

    table = [[0.0 if j == 0 else (np.pi / 2 if j % 2 else 0.0), 0.0 if j == 0 else 0.3, 0.0, 0.1] for j in range(n)]
    inertias = [(1.0, [0.1, 0.01, 0.02], [0.01, 0.0, 0.0, 0.01, 0.0, 0.01])] * n
    return SerialRobot.from_mdh(table, inertias=inertias, Fv=0.5, Fc=0.2, Ia=0.01)


def robot_for(task: str, size: int):
    from jaxsdp.plants import tx40_robot

    return (chain(size), JOINT_STATES) if task == "robot-joints" else (tx40_robot(), size)


PROBE = 201  # the points of a smoothed series both processes report, to compare them


def _probe(values) -> list:
    values = np.asarray(values)
    return values[np.linspace(0, len(values) - 1, PROBE).astype(int)].tolist()


# ---- one row, measured in this (child) process ----


def child(task: str, series: str, size: int, urdf: str | None = None) -> dict:
    base = _gb(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    if series == "statsmodels":
        return dict(_statsmodels(size), base_rss_gb=base)
    if series == "pinocchio":
        return dict(_pinocchio(task, size, urdf), base_rss_gb=base)
    import jax

    import jaxsdp  # before JAX starts its backend (jaxsdp._runtime)

    jax.config.update("jax_enable_x64", True)
    jax.monitoring.register_event_duration_secs_listener(_count_compiling)
    base = _gb(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    block = jax.block_until_ready
    out = {}
    if task == "dlr":
        p = P_MEMORY if series == "p6" else 1
        y, X = dlr_data(size, p)
        method = "parallel" if series == "parallel" else "sequential"
        res = {}

        def fit():
            res["r"] = jaxsdp.dlr(y, X, model="IRW", nvr=NVR, method=method)
            return res["r"].par

        seconds, first, recompile = _best(fit, block)
        out.update(definite=bool(res["r"].definite), probe=_probe(res["r"].par[:, 0]))
        if p > 1:
            out.update(states=2 * p)
    elif task == "sdp":
        rng = np.random.default_rng(1)
        xs = rng.uniform(-2.0, 2.0, (size, 2))
        ys = np.tanh(2 * xs[:, 0]) + 0.3 * np.sign(xs[:, 1]) + 0.05 * rng.normal(size=size)
        zs = np.c_[np.ones(size), 1.0 + 0.3 * np.cos(xs[:, 0])]
        res = {}

        def fit():
            res["r"] = jaxsdp.sdp(ys, zs, xs)
            return res["r"].par

        seconds, first, recompile = _best(fit, block)
        out.update(sweeps=int(res["r"].sweeps), converged=bool(res["r"].converged))
    elif task in ("robot-joints", "robot-states"):
        from jaxsdp._idim.ls import idim_ls
        from jaxsdp.plants.robot import robot_model

        robot, states = robot_for(task, size)
        model = robot_model(robot)
        q, dq, ddq, tau = robot_states(states, robot.n)

        def fit():
            W = model.regressor(q, dq, ddq)
            return idim_ls(tau.reshape(-1), W.reshape(-1, model.rank), names=model.names).theta

        seconds, first, recompile = _best(fit, block)
        regressor, *_ = _best(lambda: model.regressor(q, dq, ddq), block)
        out.update(rank=model.rank, states=states, joints=robot.n, regressor_s=regressor, ls_rows=states * robot.n)
    elif task == "montecarlo":
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from montecarlo import _draws

        run, scale = _draws(size)
        seconds, first, recompile = _best(
            lambda: jaxsdp.monte_carlo(run, 0, size, params=scale, progress=False).values, block
        )
        out.update(runs_per_s=size / seconds)
    elif task == "srivc":
        import scipy.signal as sig

        from jaxsdp.tfest import srivc

        num, den, dt = [4.0, 20.0], [1.0, 3.0, 20.0], 0.02  # benchmarks/riv.py's system
        rng = np.random.default_rng(2)
        u = np.sign(rng.standard_normal(size))
        sys_d = sig.cont2discrete(sig.tf2ss(num, den), dt, method="zoh")
        y = sig.dlsim((*sys_d[:4], dt), u)[1][:, 0] + 0.1 * rng.standard_normal(size)
        seconds, first, recompile = _best(lambda: srivc(y, u, dt, n=2, m=1).theta, block)
    else:
        raise ValueError(f"no task {task!r}")
    compile_s = max(first - seconds, 0.0)
    return dict(seconds=seconds, first_s=first, compile_s=compile_s, recompile_s=recompile, base_rss_gb=base, **out)


def _statsmodels(size: int) -> dict:
    from statsmodels.tsa.statespace.structural import UnobservedComponents

    y, _ = dlr_data(size)
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    res = {}

    def fit():
        mod = UnobservedComponents(y, level="smooth trend")
        # jaxsdp's prior: x0 = 0, P0 = 1e5 I at time 0, the first sample after one prediction
        mod.ssm.initialize_known(np.zeros(2), F @ (1e5 * np.eye(2)) @ F.T + np.diag([0.0, NVR]))
        mod.ssm.set_smoother_output(smoother_state=True, smoother_state_cov=True, smoother_disturbance=False)
        res["r"] = mod.smooth([1.0, NVR])  # sigma2.irregular, sigma2.trend (NVR x sigma2)
        return res["r"]

    seconds, first, _ = _best(fit)
    return dict(seconds=seconds, first_s=first, probe=_probe(res["r"].smoothed_state[0]))


def _pinocchio(task: str, size: int, urdf: str) -> dict:
    import pinocchio as pin

    pm = pin.buildModelFromUrdf(urdf)
    data = pm.createData()
    states = JOINT_STATES if task == "robot-joints" else size
    q, dq, ddq, _ = robot_states(states, pm.nv)
    neutral = pin.neutral(pm)
    qc = np.array([pin.integrate(pm, neutral, qk) for qk in q])  # continuous joints: (cos, sin) configurations

    def loop():
        for k in range(states):
            pin.computeJointTorqueRegressor(pm, data, qc[k], dq[k], ddq[k])

    seconds, first, _ = _best(loop)
    return dict(seconds=seconds, first_s=first, states=states, joints=pm.nv, columns=10 * pm.nv)


# ---- the parent: one process per row ----


def measure(task: str, series: str, size: int, limit: float, urdf: str | None = None) -> dict:
    """Run one row in a fresh process; its figures, or its error, with the process's peak memory either way."""
    with tempfile.TemporaryDirectory() as tmp:
        out, log = pathlib.Path(tmp) / "row.json", pathlib.Path(tmp) / "log.txt"
        spec = json.dumps(dict(task=task, series=series, size=size, out=str(out), urdf=urdf))
        with open(log, "w") as f:
            proc = subprocess.Popen([sys.executable, __file__, "--child", spec], stdout=f, stderr=subprocess.STDOUT)
            stopped = threading.Event()

            def stop():
                stopped.set()
                proc.send_signal(signal.SIGKILL)

            timer = threading.Timer(limit, stop)
            timer.start()
            _, status, usage = os.wait4(proc.pid, 0)
            timer.cancel()
            proc.returncode = code = os.waitstatus_to_exitcode(status)
        row = json.loads(out.read_text()) if out.exists() and code == 0 else {}
        if stopped.is_set():
            row["error"] = f"stopped at the {limit:g} s limit"
        elif code < 0:
            why = " (the out-of-memory killer, most likely)" if code == -signal.SIGKILL else ""
            row["error"] = f"killed by signal {-code}{why}"
        elif not row:
            lines = [ln for ln in log.read_text().splitlines() if ln.strip() and not ln.startswith(("W0", "I0"))]
            row["error"] = (lines or ["no output"])[-1][:240]
    row["peak_rss_gb"] = _gb(usage.ru_maxrss)
    return row


def slope(a: dict, b: dict) -> float | None:
    """The log-log slope of the time between two rows (1: linear growth), None unless both ran."""
    if a.get("seconds") and b.get("seconds") and a.get("error") is None and b.get("error") is None:
        return math.log(b["seconds"] / a["seconds"]) / math.log(b["size"] / a["size"])
    return None


def summary(rows: list[dict]) -> dict:
    """A series' summary: how far it ran, where it failed, its largest and its last slope."""
    ok = [r for r in rows if r.get("error") is None]
    slopes = [r["slope"] for r in ok if r.get("slope") is not None]
    failed = [r["size"] for r in rows if r.get("error") is not None and not r["error"].startswith("not run")]
    out = dict(
        runs=len(ok),
        largest=ok[-1]["size"] if ok else None,
        failed_at=failed[0] if failed else None,
        max_slope=max(slopes) if slopes else None,
        last_slope=slopes[-1] if slopes else None,
        seconds_largest=ok[-1]["seconds"] if ok else None,
        peak_rss_gb_largest=ok[-1]["peak_rss_gb"] if ok else None,
    )
    for field in ("ratio", "regressor_ratio", "predicted_gb", "max_abs_difference", "runs_per_s", "recompile_s"):
        if ok and field in ok[-1]:
            out[f"{field}_largest"] = ok[-1][field]
    return out


def predicted_gb(size: int, p: int = P_MEMORY) -> float:
    """The bytes (GB) of the covariances the sequential general kernel keeps for its smoother: the predicted and the
    filtered one of every sample, 2 N n^2 8 bytes, n = 2 p states for p IRW regressors."""
    return 2 * size * (2 * p) ** 2 * 8 / 1024**3


def _write_urdf(task: str, size: int, folder: str) -> str:
    from jaxsdp.plants.robot import write_urdf

    robot, _ = robot_for(task, size)
    return str(write_urdf(robot, pathlib.Path(folder) / f"{task}-{size}.urdf")[0])


def run_task(rec, task: str, sizes: list, limit: float) -> None:
    import importlib.util

    series = [s for s in SERIES[task] if s[3] is None or importlib.util.find_spec(s[3]) is not None]
    for name, _, label, package in SERIES[task]:
        if package is not None and importlib.util.find_spec(package) is None:
            note = f"{label}: not measured, `{package}` is not installed"
            rec.doc["notes"].setdefault(task, []).append(note)
            print(f"  note: {note}", flush=True)
    done = {name: [] for name, *_ in series}
    for size in sizes:
        main = None
        for name, prefix, label, package in series:
            prev = done[name]
            if prev and prev[-1].get("error") is not None:
                row = dict(error=f"not run: the size {prev[-1]['size']:,} failed")
            else:
                with tempfile.TemporaryDirectory() as tmp:
                    urdf = _write_urdf(task, size, tmp) if name == "pinocchio" else None
                    row = measure(task, name, size, limit, urdf)
            row = dict(key=f"{prefix}-{size}", task=task, series=name, label=label, unit=UNIT[task], size=size, **row)
            if name == "p6":
                row["predicted_gb"] = predicted_gb(size)
            if prev:
                row["slope"] = slope(prev[-1], row)
            if main is None:
                main = row
            elif package is not None and main.get("seconds") and row.get("seconds") and not row.get("error"):
                row["ratio"] = main["seconds"] / row["seconds"]
                if "regressor_s" in main:
                    row["regressor_ratio"] = main["regressor_s"] / row["seconds"]
                if "probe" in main and "probe" in row:
                    row["max_abs_difference"] = float(np.max(np.abs(np.subtract(main["probe"], row["probe"]))))
            prev.append(row)
            rec.add(**{k: v for k, v in row.items() if k != "probe"})
            _print(row)
    for name, prefix, label, _ in series:
        rec.add(key=f"{prefix}-summary", task=task, series=name, label=label, **summary(done[name]))


def _print(row: dict) -> None:
    what = f"{row['task']:12s} {row['series']:11s} {row['size']:>10,d} {row['unit']:7s}"
    if row.get("error"):
        peak = f"  (peak RSS {row['peak_rss_gb']:.2f} GB)" if "peak_rss_gb" in row else ""
        print(f"  {what}  {row['error']}{peak}", flush=True)
        return
    extra = "".join(
        f", {label} {row[k]:{spec}}"
        for k, label, spec in (
            ("slope", "slope", ".2f"),
            ("ratio", "jaxsdp/peer", ".3g"),
            ("max_abs_difference", "max |diff|", ".1e"),
            ("predicted_gb", "predicted", ".3g"),
            ("recompile_s", "recompiling", ".2f"),
            ("runs_per_s", "runs/s", ",.0f"),
        )
        if row.get(k) is not None and (k != "recompile_s" or row[k] > 0.01)
    )
    print(
        f"  {what}  {row['seconds']:10.4f} s"
        + (f" (first {row['first_s']:.2f} s)" if "first_s" in row else "")
        + f", peak RSS {row['peak_rss_gb']:.2f} GB{extra}",
        flush=True,
    )


def _mem_total_gb() -> float | None:
    try:
        kb = next(ln.split()[1] for ln in open("/proc/meminfo") if ln.startswith("MemTotal:"))
    except (OSError, StopIteration):
        return None
    return float(kb) / 1024**2


# ---- the figures: plotting only, from the saved JSON (`docs/hooks.py` draws the site's from the same function) ----


def _short(size: int) -> str:
    return f"{size / 1e6:g}M" if size >= 1e6 else f"{size / 1e3:g}k" if size >= 1e3 else f"{size:g}"


def figures(doc: dict) -> dict:
    """task -> a matplotlib Figure: the time and the peak memory against the size, log-log, one line per series."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    out = {}
    rows = [r for r in doc["rows"] if not r["key"].endswith("-summary")]
    for task in SERIES:
        mine = [r for r in rows if r.get("task") == task]
        if not mine:
            continue
        fig = Figure(figsize=(9.0, 3.6), layout="constrained")
        ax_t, ax_m = fig.subplots(1, 2)
        for name, _, label, _ in SERIES[task]:
            ser = [r for r in mine if r["series"] == name]
            ok = [r for r in ser if r.get("error") is None and r.get("seconds")]
            if ok:
                size = [r["size"] for r in ok]
                plain = label.replace("`", "")
                (line,) = ax_t.loglog(size, [r["seconds"] for r in ok], "o-", label=plain)
                ax_m.loglog(size, [r["peak_rss_gb"] for r in ok], "o-", color=line.get_color(), label=plain)
            pred = [r for r in ser if "predicted_gb" in r]
            if pred:
                ax_m.loglog([r["size"] for r in pred], [r["predicted_gb"] for r in pred], ":", color="0.3",
                            label="its kept covariances (predicted)")  # fmt: skip
            failed = [r for r in ser if r.get("error") and not r["error"].startswith("not run")]
            for r in failed[:1]:
                for ax in (ax_t, ax_m):
                    ax.axvline(r["size"], ls="--", color="0.5", lw=1)
                ax_t.annotate(f"{name}: failed", (r["size"], 0.5), xycoords=("data", "axes fraction"), rotation=90,
                              fontsize=7, ha="right")  # fmt: skip
        main = [r for r in mine if r["series"] == SERIES[task][0][0] and r.get("error") is None and r.get("seconds")]
        if len(main) > 1:  # the slope-1 line through jaxsdp's first point: growth above it is super-linear
            x = np.array([main[0]["size"], mine[-1]["size"]], dtype=float)
            ax_t.loglog(x, main[0]["seconds"] * x / x[0], color="0.6", lw=1, ls="--", label="linear growth")
        unit = mine[0]["unit"]
        ax_t.set(xlabel=unit, ylabel="seconds after compilation", title=f"{task}: time")
        ax_m.set(xlabel=unit, ylabel="peak resident memory (GB)", title=f"{task}: memory")
        for ax in (ax_t, ax_m):
            ax.grid(True, which="both", alpha=0.3)
            ax.set_xticks(sorted({r["size"] for r in mine}), [_short(r) for r in sorted({r["size"] for r in mine})])
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax_t.legend(fontsize=7)
        if any("predicted_gb" in r for r in mine):
            ax_m.legend(fontsize=7)
        quick = " (--quick: small sizes only)" if doc.get("options", {}).get("quick") else ""
        fig.suptitle(f"benchmarks/scaling.py, {doc.get('machine', '')}, {doc.get('date', '')}{quick}", fontsize=8)
        out[task] = fig
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="small sizes (a smoke run)")
    p.add_argument("--only", nargs="*", choices=list(SERIES), default=None, help="these tasks only")
    for opt, kind in (("dlr", float), ("sdp", float), ("joints", int), ("states", float), ("runs", float)):
        p.add_argument(f"--{opt}", type=kind, nargs="*", default=None)
    p.add_argument("--riv", type=float, nargs="*", default=None)
    p.add_argument("--limit", type=float, default=900.0, help="seconds per row (its process is stopped after)")
    p.add_argument("--json", type=pathlib.Path, default=None)
    p.add_argument("--figures", type=pathlib.Path, default=None, help="write one PNG per task here")
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    if args.child is not None:
        spec = json.loads(args.child)
        row = child(spec["task"], spec["series"], spec["size"], spec["urdf"])
        pathlib.Path(spec["out"]).write_text(json.dumps(row))
        return 0
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import _results
    from _record import Recorder

    preset = QUICK if args.quick else DEFAULT
    sizes = {task: [int(float(s)) for s in (getattr(args, o) or preset[o])] for task, o in OPTION.items()}
    tasks = args.only or list(SERIES)
    rec = Recorder("benchmarks/scaling.py", args.json, quick=args.quick, limit_s=args.limit, tasks=tasks, **sizes)
    peers = {}
    for package in ("statsmodels", "pinocchio"):
        try:
            peers[package] = __import__(package).__version__
        except ImportError:
            peers[package] = None
    env = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "XLA_FLAGS", "JAXSDP_FAST_LOOPS")
    rec.doc.update(
        mem_total_gb=_mem_total_gb(),
        peers=peers,
        notes={},
        environment={k: os.environ.get(k) for k in env},
        load_average_start=os.getloadavg()[0],
    )
    for task in tasks:
        print(f"{task} ({UNIT[task]}):", flush=True)
        run_task(rec, task, sizes[task], args.limit)
    rec.doc["load_average_end"] = os.getloadavg()[0]
    if args.json is not None:  # the end's load too
        args.json.write_text(json.dumps(rec.doc, indent=1) + "\n")
    for task in tasks:
        print(f"\n{task}\n\n{_results.scaling_table(rec.doc, task)}")
    if args.figures is not None:
        args.figures.mkdir(parents=True, exist_ok=True)
        for name, fig in figures(rec.doc).items():
            fig.savefig(args.figures / f"{name}.png", dpi=90)
        print(f"figures in {args.figures}")
    if args.json is not None:
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
