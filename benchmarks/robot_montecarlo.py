"""Benchmark: the robot Monte Carlo (issue 44) on the built-in six-joint TX40, runs per second and coverage.

`robot_robustness(runs)`: robots drawn within +-10 % of the TX40 description, each simulated for one period
(10 s at 1 kHz) of an optimised exciting trajectory under joint PD control, 1 % torque noise, and identified by
the robot pipeline (IDIM-LS of the 6 joints at once). Prints the wall time (compilation included), runs per
second, the time 1,000 runs would take at that rate, and the coverage of the stated 95 % intervals over the
base parameters (median, minimum, the worst ones).

With `--iv-runs N` (issue 45): N runs of a two-link arm in the closed-loop case, a white torque disturbance on
the plant (50 % of each joint's torque spread) that the log does not show, identified by IDIM-LS and by the
iterated IDIM-IV (instruments from the identified robot simulated in the same loop, Newey-West intervals): the
coverage of both estimators' 95 % intervals.

    python benchmarks/robot_montecarlo.py [--runs 32] [--plain-runs 0] [--iv-runs 0] [--json PATH]
"""

import argparse
import os
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import jax  # noqa: E402
from _record import Recorder  # noqa: E402

from jaxsdp.studies.montecarlo import RobotSettings, robot_robustness  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, nargs="+", default=[32])
    ap.add_argument(
        "--plain-runs",
        type=int,
        default=0,
        help="also run this many with the plain settings (held torque, one pooled variance, rest 1 %%, 200 samples "
        "dropped): what the study did before issue 44's fixes",
    )
    ap.add_argument(
        "--iv-runs", type=int, default=0, help="also this many runs of the two-link arm with IDIM-IV (0: none)"
    )
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args(argv)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"jax {jax.__version__}, backend {jax.default_backend()}, {cores} CPU core(s)")
    rec = Recorder("benchmarks/robot_montecarlo.py", args.json, runs=args.runs)
    plain = RobotSettings(rest_fraction=0.01, joint_weights=False, centred_torque=False, drop=200)
    cases = [(n, f"tx40-{n}", RobotSettings()) for n in args.runs if n > 0]  # --runs 0: none
    cases += [(args.plain_runs, f"tx40-plain-{args.plain_runs}", plain)] if args.plain_runs else []
    cases += [(args.iv_runs, f"arm-iv-{args.iv_runs}", IV_SETTINGS)] if args.iv_runs else []
    for n, key, settings in cases:
        t0 = time.perf_counter()
        iv = settings is IV_SETTINGS
        res = robot_robustness(n, robot=two_link_arm() if iv else None, settings=settings, progress=False)
        wall = time.perf_counter() - t0
        label = " (plain settings)" if settings == plain else ""
        label = " two-link arm, torque disturbance, IDIM-LS" if iv else label
        cover = res.statistics["coverage_95"]
        worst = sorted(res.statistics["parameters"].items(), key=lambda kv: kv[1]["coverage_95"])[:3]
        print(
            f"{'' if iv else 'TX40'}{label}, {n} runs: {wall:.1f} s with the set-up and compilation, "
            f"{res.seconds:.1f} s in monte_carlo "
            f"({n / res.seconds:.2f} runs/s: 1,000 runs in {1000 / (n / res.seconds) / 60:.1f} min); rank "
            f"{res.statistics['rank']}, trajectory cond {res.cond:.3g}"
        )
        print(
            f"  coverage of the 95 % intervals: median {cover['median']:.2f}, min {cover['min']:.2f}; worst "
            + ", ".join(f"{k} {v['coverage_95']:.2f} (bias {v['bias_in_se']:+.1f} se)" for k, v in worst)
        )
        rec.add(
            key=key,
            runs=n,
            wall_s=wall,
            seconds=res.seconds,
            runs_per_s=n / res.seconds,
            minutes_per_1000=1000 / (n / res.seconds) / 60,
            coverage_median=cover["median"],
            coverage_min=cover["min"],
            below_90=len(res.statistics["below_min_coverage"]),
            rank=res.statistics["rank"],
            rest_fraction=settings.rest_fraction,
            joint_weights=settings.joint_weights,
            centred_torque=settings.centred_torque,
            **{f"processing_{k}": v for k, v in res.statistics["processing"].items()},
            **(_iv_row(res) if iv else {}),
        )
        if iv:
            st = res.statistics["iv"]
            c = st["coverage_95"]
            worst = sorted(st["parameters"].items(), key=lambda kv: kv[1]["coverage_95"])[:3]
            print(
                f"  IDIM-IV: coverage median {c['median']:.3f}, min {c['min']:.3f}, max {c['max']:.3f}; worst "
                + ", ".join(f"{k} {v['coverage_95']:.3f} (bias {v['bias_in_se']:+.2f} se)" for k, v in worst)
                + f"; iterations median {st['iterations']['median']:g}, {st['not_converged']} not converged"
            )
    return 0


#: The closed-loop case of `--iv-runs`: a 15 s record at 1 kHz (three periods at 0.2 Hz), the disturbance, the
#: processing that keeps 0-40 Hz at 100 Hz, rows below 15 % of a joint's peak speed left out (the disturbance
#: dithers the motion at each reversal).
IV_SETTINGS = RobotSettings(
    f0=0.2, periods=3, excite_steps=30, torque_noise=0.02, disturbance=0.5, cutoff_hz=40.0, decimate=10,
    rest_fraction=0.15, iv=True,
)  # fmt: skip


def two_link_arm():
    """The two-link arm of the tests (`tests/test_robot_pipeline.py`) without armature (the study adds it)."""
    import numpy as np

    from jaxsdp.plants import SerialRobot

    inertias = [(3.0, [0.2, 0, 0], np.zeros(6)), (1.5, [0.15, 0.02, 0], [0.01, 0, 0, 0.01, 0, 0.01])]
    return SerialRobot.from_mdh([[0, 0, 0, 0], [0, 0.4, 0, 0]], inertias=inertias, Fv=1.0, Fc=0.5)


def _iv_row(res) -> dict:
    st = res.statistics["iv"]
    params = {k: round(v["coverage_95"], 4) for k, v in st["parameters"].items()}
    ls = {k: round(v["coverage_95"], 4) for k, v in res.statistics["parameters"].items()}
    return dict(
        iv_coverage_median=st["coverage_95"]["median"],
        iv_coverage_min=st["coverage_95"]["min"],
        iv_coverage_max=st["coverage_95"]["max"],
        iv_below_90=len(st["below_min_coverage"]),
        iv_iterations_median=st["iterations"]["median"],
        iv_not_converged=st["not_converged"],
        iv_coverage=params,
        ls_coverage=ls,
        disturbance=res.settings.disturbance,
    )


if __name__ == "__main__":
    raise SystemExit(main())
