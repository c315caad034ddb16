"""Benchmark: the six-joint TX40 model (issue 16) against pinocchio.

Prints, on this machine:
- inverse dynamics for 45,000 random states (`SerialRobot.inverse_dynamics`, vectorised, jit) against
  pinocchio's C++ `rnea` called in a Python loop;
- the joint-2 identification regressor for 45,000 states (`SerialRobot.regressor(..., joint=2)`, by the
  Newton-Euler recursion written for the regressor) against pinocchio's `computeJointTorqueRegressor` in a Python loop;
- one 9 s all-joints closed-loop simulation at 5 kHz (`simulate_robot`, 4 sub-steps).
Every entry, the pinocchio peers included, is called once to warm up (compile, caches) and then timed
`--repeats` times (the simulation half as often): median, min, and the warm-up call's excess over the median.
Target: the joint-2 regressor for 45,000 states <= 0.2 s after compile on 2 cores.

Usage: python benchmarks/robot.py [--repeats 3] [--json PATH]   (pinocchio: pip install pin)

`--json PATH` also writes every row (key `inverse-dynamics`, `regressor-joint2`,
`pinocchio-rnea`, `pinocchio-regressor`, `closed-loop`) with the machine and the
date (`benchmarks/_record.py`).
"""

import argparse
import pathlib
import statistics

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _record import Recorder, timings  # noqa: E402

from jaxsdp.plants import simulate_robot, tx40_robot  # noqa: E402

N = 45_000
TARGET_REGRESSOR_S = 0.2


def timed(fn, repeats):
    """One warm-up call (compile, caches), then `repeats` timed calls: (median s, min s, warm-up minus median s)."""
    _, first, runs = timings(fn, repeats)
    steady = statistics.median(runs)
    return steady, min(runs), first - steady


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args()
    rec = Recorder("benchmarks/robot.py", args.json, repeats=args.repeats, states=N)
    robot = tx40_robot()
    rng = np.random.default_rng(0)
    q, dq, ddq = (rng.uniform(-2, 2, (N, 6)) for _ in range(3))
    print(f"devices: {jax.devices()}; {N} states")
    idm = jax.jit(lambda a, b, c: robot.inverse_dynamics(a, b, c))
    s, m, c = timed(lambda: idm(q, dq, ddq), args.repeats)
    print(f"inverse dynamics, jaxsdp:               {s:8.3f} s  (min {m:.3f} s; compile {c:.1f} s)")
    rec.add(key="inverse-dynamics", seconds=s, min_s=m, compile_s=c)
    reg = jax.jit(lambda a, b, c: robot.regressor(a, b, c, joint=2))
    s_reg, m, c = timed(lambda: reg(q, dq, ddq), args.repeats)
    print(
        f"joint-2 regressor, jaxsdp:              {s_reg:8.3f} s  (min {m:.3f} s; compile {c:.1f} s; target "
        f"{TARGET_REGRESSOR_S} s: ratio {s_reg / TARGET_REGRESSOR_S:.2f})"
    )
    rec.add(key="regressor-joint2", seconds=s_reg, min_s=m, compile_s=c, target_ratio=s_reg / TARGET_REGRESSOR_S)
    try:
        import pinocchio as pin

        from tests.test_robot import pinocchio_tx40  # the same robot, built independently

        model = pinocchio_tx40()
        data = model.createData()

        def loop(fn):
            def run():
                for k in range(N):
                    fn(model, data, q[k], dq[k], ddq[k])

            return run

        s, m, w = timed(loop(pin.rnea), args.repeats)
        print(f"inverse dynamics, pinocchio rnea loop:  {s:8.3f} s  (min {m:.3f} s; warm-up {w:+.2f} s)")
        rec.add(key="pinocchio-rnea", seconds=s, min_s=m, warmup_s=w)
        s, m, w = timed(loop(pin.computeJointTorqueRegressor), args.repeats)
        print(
            f"full regressor, pinocchio loop:         {s:8.3f} s  (min {m:.3f} s; warm-up {w:+.2f} s; all joints, "
            "Python loop over C++)"
        )
        rec.add(key="pinocchio-regressor", seconds=s, min_s=m, warmup_s=w)
    except ImportError as e:
        print(f"pinocchio not available ({e}); peers skipped")
    qr = np.outer(1 - np.cos(2 * np.pi * 0.5 * np.arange(N) * 2e-4), np.full(6, 0.3))
    s, m, c = timed(lambda: simulate_robot(robot, qr).q, max(1, args.repeats // 2))
    print(f"9 s all-joints closed loop at 5 kHz:    {s:8.3f} s  (min {m:.3f} s; compile {c:.1f} s)")
    rec.add(key="closed-loop", seconds=s, min_s=m, compile_s=c)


if __name__ == "__main__":
    main()
