"""IDIM-LS vs IDIM-IV (plain and bias-compensated) on the built-in EMPS plant across seeds.

Usage: `python benchmarks/idim_iv.py [n_seeds]` (default 8: seeds 0-7).

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
"""

import sys

import numpy as np

from jaxsdp import idim_ls
from jaxsdp.data import emps_builtin_data
from jaxsdp.data._emps_builtin import EMPS_BUILTIN_TRUTH
from jaxsdp.studies.emps import emps_idim_iv, emps_preprocess, emps_regression

NAMES = ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")


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
    lines.append("mean  " + "  ".join(f"{e:+12.3f} {'':6s}" for e in err.mean(0)))
    lines.append("max|.|" + "  ".join(f"{e:12.3f} {zz:6.2f}" for e, zz in zip(np.abs(err).max(0), np.abs(z).max(0))))
    worst = np.unravel_index(np.argmax(np.abs(err)), err.shape)
    worst_z = np.unravel_index(np.argmax(np.abs(z)), z.shape)
    lines.append(
        f"largest |error| {np.abs(err).max():.3f} % ({NAMES[worst[1]]}, seed {seeds[worst[0]]}); "
        f"largest |z| {np.abs(z).max():.2f} ({NAMES[worst_z[1]]}, seed {seeds[worst_z[0]]})"
    )
    return "\n".join(lines)


def main(n_seeds: int = 8) -> None:
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
                res = emps_idim_iv(data, inputs, compensate=comp, cov=cov)
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


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 8)
