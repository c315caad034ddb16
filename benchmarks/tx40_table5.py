"""Where the multi-SDP's relative error on the real all-joints TX40 logs comes from (issue 30, item 3).

The paper reaches 11.0 % on these logs (6 iterations); the original MATLAB
toolbox's `sdp` back-fitting, run under GNU Octave on inputs processed as the
paper describes, 13.8 % (recorded, not measured here). This script runs the
study's multi-SDP (Butterworth 100 Hz, central differences, decimation 10,
inertia from IDIM-LS at the default rest threshold) with one choice changed
at a time and prints the relative error over the whole record and over the
samples in motion, the iterations and the NVRs:

- the defaults (every sample fitted, RW, ML NVRs at every iteration, tol 1 %);
- the back-fitting on the samples in motion only;
- the NVRs optimised on the first iteration only;
- IRW curves instead of RW;
- tol 0.1 % instead of 1 %;
- the inertia fixed at the paper's Table 5 reference (1.09 kg m^2, CAD);
- the ML NVRs multiplied by 10, 30 and 100 and held fixed (less smoothing).

Usage: python benchmarks/tx40_table5.py [--shared PATH] [--json PATH]

`--json PATH` also writes every row as it is computed (`benchmarks/_record.py`, with the machine, the date and the
commit), keyed for the docs to quote: `defaults`, `fit-on-moving`, `ml-first-only`, `irw`, `tol-0-1-percent`,
`inertia-cad`, `nvr-x10`, `nvr-x30`, `nvr-x100`, each with `record_pct` (None for `fit-on-moving`, whose curves
are fitted and scored on the samples in motion only), `motion_pct`, `iterations`,
`nvr_gravity` and `nvr_friction`. The paper's 11.0 % and the toolbox's 13.8 % are recorded constants (options
`paper_pct`, `toolbox_pct_recorded`), not measured.
"""

import argparse
import os
import pathlib

import jax
import numpy as np
from _record import Recorder

jax.config.update("jax_enable_x64", True)

from jaxsdp._sdp.multi import MultiBackfitting, multi_sdp  # noqa: E402
from jaxsdp.data import load_joint_logs  # noqa: E402
from jaxsdp.studies.tx40 import joint_idim_ls, joint_multi_sdp, joint_preprocess  # noqa: E402

PAPER = 11.0
TOOLBOX = 13.8


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.environ.get("JAXSDP_SHARED", pathlib.Path(__file__).resolve().parents[1] / ".." / "shared")
    ap.add_argument("--shared", default=str(default), help="the shared/ folder (default: ../shared)")
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args()
    folder = pathlib.Path(args.shared) / "data" / "tx40"
    if not (folder / "pos_read_data.csv").exists():
        raise SystemExit(f"real TX40 logs not found in {folder} (pass --shared or set JAXSDP_SHARED)")
    logs = load_joint_logs(
        folder / "pos_read_data.csv", folder / "curr_data.csv", dt=2e-4, ratios=(32, 32, 45, -48, 45, 32)
    )
    recorder = Recorder("benchmarks/tx40_table5.py", args.json, paper_pct=PAPER, toolbox_pct_recorded=TOOLBOX)
    pre = joint_preprocess(logs)
    ls = joint_idim_ls(pre)
    zz = ls.result["ZZ2"]
    mov = np.asarray(ls.moving)
    rows = []

    def record(key, label, rec_pct, motion_pct, iterations, nvr):
        # a fit on the samples in motion has no whole-record error (its curves are not evaluated at rest): None
        rows.append(
            (label, None if rec_pct is None else float(rec_pct), float(motion_pct), int(iterations), np.asarray(nvr))
        )
        recorder.add(
            key=key,
            variant=label,
            record_pct=rows[-1][1],
            motion_pct=rows[-1][2],
            iterations=rows[-1][3],
            nvr_gravity=rows[-1][4][0],
            nvr_friction=rows[-1][4][1],
        )

    def add(key, label, s, *, whole=True):
        rec = s.relative_error if whole else None
        record(key, label, rec, s.relative_error_moving, s.result.iterations, s.result.nvr)

    base = joint_multi_sdp(pre, inertia=zz, moving=mov)
    add("defaults", "defaults (all samples, RW, ML every iteration, tol 1 %)", base)
    add(
        "fit-on-moving",
        "back-fitting on the samples in motion only",
        joint_multi_sdp(pre, inertia=zz, moving=mov, fit_on="moving"),
        whole=False,
    )
    add(
        "ml-first-only",
        "NVRs by ML on the first iteration only",
        joint_multi_sdp(pre, inertia=zz, moving=mov, sdp=MultiBackfitting(optimise_on="first")),
    )
    add("irw", "IRW curves", joint_multi_sdp(pre, inertia=zz, moving=mov, sdp=MultiBackfitting(model="IRW")))
    add("tol-0-1-percent", "tol 0.1 %", joint_multi_sdp(pre, inertia=zz, moving=mov, sdp=MultiBackfitting(tol=0.001)))
    add("inertia-cad", "inertia 1.09 kg m^2 (Table 5 reference)", joint_multi_sdp(pre, inertia=1.09, moving=mov))
    x = np.stack([np.asarray(pre.q), np.asarray(pre.dq)], axis=1)
    y, ddq = np.asarray(pre.y), np.asarray(pre.ddq)
    for factor in (10, 30, 100):
        r = multi_sdp(y, x, w=ddq, a=zz, nvr=factor * np.asarray(base.result.nvr))
        err_mov = 100 * np.linalg.norm(np.asarray(r.resid)[mov]) / np.linalg.norm(y[mov])
        record(f"nvr-x{factor}", f"ML NVRs x {factor}, fixed", r.relative_error, err_mov, r.iterations, r.nvr)
    print(f"Multi-SDP of joint 2 on the real all-joints TX40 logs (paper {PAPER} %, toolbox {TOOLBOX} %)")
    print(f"{'variant':58s} {'record %':>9s} {'motion %':>9s} {'iter':>5s}  NVR gravity, friction")
    for label, rec, motion, it, nvr in rows:
        shown = f"{'-':>9s}" if rec is None else f"{rec:9.2f}"
        print(f"{label:58s} {shown} {motion:9.2f} {it:5d}  {nvr[0]:.3g}, {nvr[1]:.3g}")


if __name__ == "__main__":
    main()
