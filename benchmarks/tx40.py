"""Benchmark: the TX40 multi-SDP (gravity + friction, ML NVRs at every iteration) at the full 5 kHz rate (issue 15).

On the built-in "only link 2 moving" experiment (45,000 samples at 5 kHz;
Butterworth 100 Hz + central differences, first 100 samples dropped), prints
for RW and IRW curves, at the full rate (no decimation, about 45,000 samples
in motion) and decimated by 10 (the study's default):
the multi-SDP time after compile (median of repeats), the compile time
(first call minus steady state), the iterations, and the ratio to the target.
Target: <= 1 s after compile at the full rate on 2 cores.
For scale, recorded figures (from the issue that set the target, not measured
by this script; printed as "Octave (recorded)"): the original MATLAB
toolbox's `sdp`, looped as the paper does and run under GNU Octave on real
TX40 data, took 6 s decimated and 81 s (RW) / 311 s (IRW) at the full rate.

Usage: python benchmarks/tx40.py [--repeats 3] [--json PATH]

`--json PATH` also writes every row (key `full-rw`, `full-irw`,
`decimated-rw`, `decimated-irw`) with the machine and the date
(`benchmarks/_record.py`); the Octave figures stay out of it (recorded, not
measured here).
"""

import argparse
import pathlib
import statistics

import jax

jax.config.update("jax_enable_x64", True)

from _record import Recorder, timings  # noqa: E402

from jaxsdp import MultiBackfitting  # noqa: E402
from jaxsdp.data import tx40_builtin_data  # noqa: E402
from jaxsdp.studies.tx40 import joint_idim_ls, joint_multi_sdp, joint_preprocess  # noqa: E402

TARGET_S = 1.0
OCTAVE_S = {("full", "RW"): 81.0, ("full", "IRW"): 311.0, ("decimated", "RW"): 6.0}


def timed(fn, repeats):
    out, first, runs = timings(fn, repeats, ready=lambda out: out.result.d)
    steady = statistics.median(runs)
    return out, steady, first - steady


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args()
    rec = Recorder("benchmarks/tx40.py", args.json, repeats=args.repeats)
    logs = tx40_builtin_data().logs
    print(f"devices: {jax.devices()}")
    print(
        f"{'rate':<10} {'model':<6} {'samples':>8} {'after compile':>14} {'compile':>9} {'iters':>6} "
        f"{'/ target':>9} {'Octave (recorded)':>18}"
    )
    for rate, r in (("full", 1), ("decimated", 10)):
        inputs = joint_preprocess(logs, decimate=r)
        ls = joint_idim_ls(inputs)
        zz = ls.result["ZZ2"]
        for model in ("RW", "IRW"):
            out, steady, compile_s = timed(
                lambda: joint_multi_sdp(inputs, inertia=zz, moving=ls.moving, sdp=MultiBackfitting(model=(model,) * 2)),
                args.repeats,
            )
            n = int(out.y.shape[0])
            octave = OCTAVE_S.get((rate, model))
            octave = f"{octave:.0f} s ({octave / steady:.0f}x)" if octave else "-"
            print(
                f"{rate:<10} {model:<6} {n:>8} {steady:>12.3f} s {compile_s:>7.2f} s {int(out.result.iterations):>6} "
                f"{steady / TARGET_S:>9.2f} {octave:>18}"
            )
            rec.add(
                key=f"{rate}-{model.lower()}",
                decimation=r,
                samples=n,
                seconds=steady,
                compile_s=compile_s,
                iterations=int(out.result.iterations),
                target_ratio=steady / TARGET_S,
            )


if __name__ == "__main__":
    main()
