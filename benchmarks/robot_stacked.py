"""Benchmark: the stacked full-model regressor of a six-joint robot on 45,000 states, and its IDIM-LS (issue 31).

Prints the time after compile (median of repeats) of
- jaxsdp's stacked regressor (`RobotModel.regressor`: the rigid-body rows by
  the Newton-Euler recursion written for the regressor, the drive columns,
  the base columns, in one compiled program) of the TX40 (58 base
  parameters) on 45,000 random states, and the LS on its 270,000 rows
  (`idim_ls`);
- pinocchio's `computeJointTorqueRegressor` in a Python loop over the same
  states (the peer; its 60 standard columns, no drive columns, no base
  reduction), measured in the same run; and the same loop keeping its rows in
  one array (`pinocchio-regressor-kept`), as a least squares needs them.
Targets: regressor + LS <= 2 s after compile on 2 cores (issue 31); issue 46: the regressor at most half of
pinocchio's loop, regressor + LS under 0.3 s.

`--keep-freed-memory` re-runs the script with glibc keeping freed memory in
one heap (`_allocator.ONE_ARENA`): the regressor's 125 MB result is then not
page-faulted in again on every call (50,000 faults, ~30 ms here);
`--huge-pages` with glibc's transparent huge pages for its large blocks
(`_allocator.HUGE_PAGES`: 2 MB faults, freed memory still returned). The
JSON records both settings and the page faults per call.

Usage: python benchmarks/robot_stacked.py [--states 45000] [--repeats 3] [--keep-freed-memory] [--huge-pages]
    [--json PATH]

`--json PATH` also writes the rows (key `regressor-ls`, `regressor`,
`pinocchio-regressor`) with the machine and the date (`benchmarks/_record.py`).
"""

import argparse
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _allocator import HUGE_PAGES, ONE_ARENA, rerun_with  # noqa: E402

KEPT = rerun_with(sys.argv[1:], ONE_ARENA)
HUGE = rerun_with(sys.argv[1:], HUGE_PAGES, "--huge-pages")

import jax
import jax.numpy as jnp
import numpy as np
from _record import Recorder, timings

jax.config.update("jax_enable_x64", True)

import jaxsdp  # noqa: E402
from jaxsdp._idim.ls import idim_ls  # noqa: E402
from jaxsdp._runtime import BLAS_ENV  # noqa: E402
from jaxsdp.data import Drives  # noqa: E402
from jaxsdp.plants import tx40_robot  # noqa: E402
from jaxsdp.plants.robot import robot_model  # noqa: E402

TARGET_S = 2.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=45_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    ap.add_argument(
        "--keep-freed-memory",
        action="store_true",
        help="re-run with MALLOC_MMAP_MAX_=0 MALLOC_TRIM_THRESHOLD_=1e11 MALLOC_ARENA_MAX=1 (no page faults)",
    )
    ap.add_argument(
        "--huge-pages", action="store_true", help="re-run with GLIBC_TUNABLES=glibc.malloc.hugetlb=1 (2 MB page faults)"
    )
    ap.add_argument("--ls-only", action="store_true", help=argparse.SUPPRESS)  # the spinning-BLAS run's child
    args = ap.parse_args()
    robot, model, (q, dq, ddq), tau = problem(args.states)

    def regression():  # (X, y) of the least squares, formed after the regressor's own timings (not held during them)
        return jax.block_until_ready(model.regressor(q, dq, ddq).reshape(-1, model.rank)), jnp.asarray(tau.reshape(-1))

    if args.ls_only:
        return print(f"LS_SECONDS {ls_seconds(*regression(), args.repeats)[0]!r}")
    rec = Recorder(
        "benchmarks/robot_stacked.py",
        args.json,
        states=args.states,
        repeats=args.repeats,
        keep_freed_memory=KEPT,
        huge_pages=HUGE,
    )
    print(f"glibc keeps freed memory: {KEPT}; huge pages: {HUGE}; {jaxsdp.fast_loops_status()}")
    # The GPU table (`_results.gpu_table`) reads the file `gpu.py --all` writes by these top-level names too.
    rec.doc["states"] = args.states

    def write():
        if args.json:
            print(f"wrote {args.json}")

    def ours():
        W = model.regressor(q, dq, ddq)
        res = idim_ls(tau.reshape(-1), W.reshape(-1, model.rank), names=model.names)
        return jax.block_until_ready(res.theta)

    t0 = time.perf_counter()
    ours()
    first = time.perf_counter() - t0
    runs = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        ours()
        runs.append(time.perf_counter() - t0)
    t_ours = statistics.median(runs)
    print(f"jaxsdp stacked regressor + IDIM-LS, {args.states} states x {robot.n} joints, rank {model.rank}:")
    print(
        f"  {t_ours:.3f} s after compile (compile {first - t_ours:.1f} s); ratio to the {TARGET_S} s target: "
        f"{t_ours / TARGET_S:.2f}"
    )
    reg = []
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(model.regressor(q, dq, ddq))
        reg.append(time.perf_counter() - t0)
    faults = (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults) / args.repeats
    t_reg = statistics.median(reg)
    print(f"  of which the regressor alone: {t_reg:.3f} s ({faults:,.0f} page faults per call)")
    rec.doc.update(regressor_ls_s=t_ours, regressor_s=t_reg, compile_s=first - t_ours)
    rec.add(
        key="regressor-ls",
        seconds=t_ours,
        compile_s=first - t_ours,
        target_ratio=t_ours / TARGET_S,
        rank=model.rank,
        ls_rows=args.states * robot.n,
    )
    rec.add(key="regressor", seconds=t_reg, ls_s=t_ours - t_reg, page_faults=faults)
    t_ls, t_qr = ls_seconds(*regression(), args.repeats)
    spun = None  # OpenBLAS's spinning threads matter where XLA runs LAPACK on the CPU
    if jax.default_backend() == "cpu":
        env = {**os.environ, BLAS_ENV: "28"}  # OpenBLAS's default: its idle threads spin for 2^28 cycles
        child = subprocess.run(
            [sys.executable, __file__, "--ls-only", "--states", str(args.states), "--repeats", str(args.repeats)],
            env=env,
            capture_output=True,
            text=True,
        )
        found = [float(line.split()[1]) for line in child.stdout.splitlines() if line.startswith("LS_SECONDS")]
        if not found:
            raise RuntimeError(f"the run with {BLAS_ENV}=28 gave no figure:\n{child.stderr[-3000:]}")
        spun = found[0]
    print(
        f"  IDIM-LS alone: {t_ls:.3f} s ({BLAS_ENV}={os.environ.get(BLAS_ENV)})"
        + (f"; {spun:.3f} s with {BLAS_ENV}=28 (OpenBLAS's default)" if spun is not None else "")
    )
    print(f"  LAPACK's Householder QR of [X y] (the fallback): {t_qr:.3f} s")
    rec.add(key="ls", seconds=t_ls, spinning_blas_s=spun, blas_timeout=os.environ.get(BLAS_ENV))
    rec.add(key="householder-qr", seconds=t_qr)
    try:
        import pinocchio as pin
    except ImportError:
        print("pinocchio not installed: no peer figure")
        return write()
    urdf = pathlib.Path(os.environ.get("JAXSDP_SHARED", "../shared")) / "data" / "tx40" / "tx40_mdh_modified.urdf"
    if not urdf.exists():
        print(f"{urdf} not found: no peer figure (set JAXSDP_SHARED)")
        return write()
    pm = pin.buildModelFromUrdf(str(urdf))
    data = pm.createData()
    plain, kept = [], []
    for _ in range(args.repeats):  # the median of each (the loop keeping its rows varies by 2-3x from run to run)
        t0 = time.perf_counter()
        for k in range(args.states):
            pin.computeJointTorqueRegressor(pm, data, q[k], dq[k], ddq[k])
        plain.append(time.perf_counter() - t0)
        t0 = time.perf_counter()  # the same loop keeping its rows in one array, as a least squares needs them
        rows = np.empty((args.states, robot.n, data.jointTorqueRegressor.shape[1]))
        for k in range(args.states):
            rows[k] = pin.computeJointTorqueRegressor(pm, data, q[k], dq[k], ddq[k])
        kept.append(time.perf_counter() - t0)
        del rows
    t_pin, t_pin_kept = statistics.median(plain), statistics.median(kept)
    print(f"pinocchio computeJointTorqueRegressor in a Python loop (regressor only): {t_pin:.3f} s")
    print(
        f"  the same loop keeping its rows in one ({args.states}, {robot.n}, 60) array: {t_pin_kept:.3f} s "
        f"(median; {min(kept):.3f}-{max(kept):.3f} s)"
    )
    print(f"  ratio jaxsdp (regressor + LS) / pinocchio (regressor): {t_ours / t_pin:.2f}")
    print(f"  ratio jaxsdp (regressor) / pinocchio (regressor): {t_reg / t_pin:.2f} (issue 46's target: below 0.5)")
    print(f"  ratio jaxsdp (regressor) / pinocchio (regressor, rows kept): {t_reg / t_pin_kept:.2f}")
    rec.doc.update(pinocchio_loop_s=t_pin)
    rec.add(key="pinocchio-regressor", seconds=t_pin, ratio=t_ours / t_pin, regressor_ratio=t_reg / t_pin)
    rec.add(
        key="pinocchio-regressor-kept",
        seconds=t_pin_kept,
        min_s=min(kept),
        max_s=max(kept),
        regressor_ratio=t_reg / t_pin_kept,
    )
    write()


def problem(states: int):
    """(robot, model, (q, dq, ddq), tau): the TX40 with its coupled drives and `states` seeded random states and
    torques, the same in `main` and in the spinning-BLAS child."""
    robot = tx40_robot()
    model = robot_model(robot, transmission=Drives.builtin("tx40").transmission)
    rng = np.random.default_rng(0)
    q, dq, ddq = rng.uniform(-2, 2, (3, states, robot.n))
    return robot, model, (q, dq, ddq), rng.normal(size=(states, robot.n))


def ls_seconds(X, y, repeats: int) -> tuple[float, float]:
    """(median s of `idim_ls` alone, of LAPACK's Householder QR of [X y]) on the stacked regressor `X`."""
    _, _, runs = timings(lambda: idim_ls(y, X).theta, repeats)
    qr = jax.jit(lambda X, y: jnp.linalg.qr(jnp.concatenate([X, y[:, None]], axis=1), mode="r"))
    _, _, qr_runs = timings(lambda: qr(X, y), repeats)
    return statistics.median(runs), statistics.median(qr_runs)


if __name__ == "__main__":
    main()
