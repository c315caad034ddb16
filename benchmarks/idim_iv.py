"""IDIM-LS vs IDIM-IV (plain and bias-compensated) on the built-in EMPS plant across seeds.

Usage: `python benchmarks/idim_iv.py [n_seeds] [--json PATH]` (default 8: seeds 0-7).

Prints, for the default estimator of `--estimator iv` (bias-compensated
IDIM-IV, Newey-West covariance), one row per seed with, per parameter, the
error against the truth (% of the truth) and z = (estimate - truth) / stated
std; then the largest |error| (%) and |z| per parameter over the seeds, the
mean error, and the overall largest |error| and |z| (the figures the README
states and `tests/test_idim_iv.py` checks).

Then, per estimator and covariance ("iid", "hac"), the mean bias over the
seeds (% of the truth), the spread of the estimates over the seeds (%), the
mean stated standard deviation (%), the largest |z| and the fraction of seeds
with the truth within 2 stated standard deviations.

`--json PATH` also writes every row as it is computed (`benchmarks/_record.py`, with the machine, the date and the
commit), keyed for the docs to quote: `seed-0` .. `seed-7` (`error_pct_M`, `z_M`, ... per parameter), `mean`
(`error_pct_*`), `max` (`abs_error_pct_*`, `abs_z_*`, and the overall `largest_abs_error_pct`, `largest_abs_z`
with their parameter and seed), then one row per estimator and covariance, `ls-iid`, `ls-hac`, `iv-iid`,
`iv-hac`, `ivc-iid`, `ivc-hac` (`bias_pct_*`, `spread_pct_*`, `stated_pct_*`, `max_abs_z_*`, `within_2sd_*`).
"""

import argparse
import pathlib

import numpy as np
from _record import Recorder

from jaxsdp import IDIMIV, IID, NeweyWest, idim_ls
from jaxsdp.data import emps_builtin_data
from jaxsdp.data._emps_builtin import EMPS_BUILTIN_TRUTH
from jaxsdp.studies.emps import emps_idim_iv, emps_preprocess, emps_regression

NAMES = ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")
REC = None  # a Recorder, set in main()


def per(prefix, values) -> dict:
    """`{prefix_M: ..., prefix_Fv_pos: ...}`: one field per parameter."""
    return {f"{prefix}_{n}": float(v) for n, v in zip(NAMES, values)}


def per_seed_table(results, truth, seeds) -> str:
    """Per-seed errors (% of the truth) and z, then the max |error| and max |z| per parameter."""
    th = np.array([np.asarray(r.theta) for r in results])
    sd = np.array([np.asarray(r.std) for r in results])
    err = 100 * (th / truth - 1)
    z = (th - truth) / sd
    head = "seed  " + "  ".join(f"{n + ' err%':>12s} {'z':>6s}" for n in NAMES)
    lines = [head]
    for s, e_row, z_row in zip(seeds, err, z):
        lines.append(f"{s:4d}  " + "  ".join(f"{e:+12.3f} {zz:+6.2f}" for e, zz in zip(e_row, z_row)))
        REC.add(key=f"seed-{s}", seed=s, **per("error_pct", e_row), **per("z", z_row))
    lines.append("mean  " + "  ".join(f"{e:+12.3f} {'':6s}" for e in err.mean(0)))
    REC.add(key="mean", **per("error_pct", err.mean(0)))
    lines.append("max|.|" + "  ".join(f"{e:12.3f} {zz:6.2f}" for e, zz in zip(np.abs(err).max(0), np.abs(z).max(0))))
    worst = np.unravel_index(np.argmax(np.abs(err)), err.shape)
    worst_z = np.unravel_index(np.argmax(np.abs(z)), z.shape)
    REC.add(
        key="max",
        **per("abs_error_pct", np.abs(err).max(0)),
        **per("abs_z", np.abs(z).max(0)),
        largest_abs_error_pct=np.abs(err).max(),
        largest_abs_error_param=NAMES[worst[1]],
        largest_abs_error_seed=seeds[worst[0]],
        largest_abs_z=np.abs(z).max(),
        largest_abs_z_param=NAMES[worst_z[1]],
        largest_abs_z_seed=seeds[worst_z[0]],
    )
    lines.append(
        f"largest |error| {np.abs(err).max():.3f} % ({NAMES[worst[1]]}, seed {seeds[worst[0]]}); "
        f"largest |z| {np.abs(z).max():.2f} ({NAMES[worst_z[1]]}, seed {seeds[worst_z[0]]})"
    )
    return "\n".join(lines)


def main(n_seeds: int = 8, json_path: pathlib.Path | None = None) -> None:
    global REC
    REC = Recorder("benchmarks/idim_iv.py", json_path, n_seeds=n_seeds, estimator_table="IVc-hac")
    truth = np.array([EMPS_BUILTIN_TRUTH[n] for n in NAMES])
    seeds = list(range(n_seeds))
    rows = {}
    for seed in seeds:
        data, _, _ = emps_builtin_data(seed)
        inputs = emps_preprocess(data)
        reg = emps_regression(inputs, friction="asymmetric")
        for cov in ("iid", "hac"):
            rows.setdefault(f"LS-{cov}", []).append(idim_ls(reg.y, reg.X, names=reg.names, cov=cov))
            for comp, label in ((False, "IV"), (True, "IVc")):
                options = IDIMIV(compensate=comp, cov=IID() if cov == "iid" else NeweyWest())
                res = emps_idim_iv(data, inputs, iv=options)
                if not res.converged:
                    print(f"seed {seed}: {label}-{cov} did not converge in {res.iterations} iterations")
                rows.setdefault(f"{label}-{cov}", []).append(res.result)
    print(f"Bias-compensated IDIM-IV (Newey-West), seeds {seeds[0]}-{seeds[-1]}: error % of the truth and z")
    print(per_seed_table(rows["IVc-hac"], truth, seeds))
    print()
    print(f"{n_seeds} seeds; columns {NAMES}")
    for key, results in rows.items():
        th = np.array([np.asarray(r.theta) for r in results])
        sd = np.array([np.asarray(r.std) for r in results])
        z = np.abs(th - truth) / sd
        print(
            f"{key:8s} bias% {np.round(100 * (th.mean(0) / truth - 1), 3)} "
            f"spread% {np.round(100 * th.std(0, ddof=1) / truth, 3)} stated% {np.round(100 * sd.mean(0) / truth, 3)} "
            f"max|z| {np.round(z.max(0), 2)} within2sd {np.round((z < 2).mean(0), 2)}"
        )
        REC.add(
            key=key.lower(),
            estimator=key,
            **per("bias_pct", 100 * (th.mean(0) / truth - 1)),
            **per("spread_pct", 100 * th.std(0, ddof=1) / truth),
            **per("stated_pct", 100 * sd.mean(0) / truth),
            **per("max_abs_z", z.max(0)),
            **per("within_2sd", (z < 2).mean(0)),
        )


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n_seeds", type=int, nargs="?", default=8, help="seeds 0 .. n_seeds - 1 (default 8)")
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args()
    main(args.n_seeds, args.json)
