"""IDIM-LS vs IDIM-IV (plain and bias-compensated) on the built-in EMPS plant across seeds.

Usage: `python benchmarks/idim_iv.py [n_seeds]` (default 8). Prints, per
estimator and covariance ("iid", "hac"), the mean bias over the seeds (% of
the truth), the spread of the estimates over the seeds (%), the mean stated
standard deviation (%), the largest |estimate - truth| / stated std, and the
fraction of seeds with the truth within 2 stated standard deviations.
"""

import sys

import numpy as np

from jaxsdp import idim_ls
from jaxsdp.data import emps_builtin_data
from jaxsdp.data._emps_builtin import EMPS_BUILTIN_TRUTH
from jaxsdp.studies.emps import emps_preprocess, emps_regression
from jaxsdp.studies.emps._idim_iv import emps_idim_iv

NAMES = ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")


def main(n_seeds: int = 8) -> None:
    truth = np.array([EMPS_BUILTIN_TRUTH[n] for n in NAMES])
    rows = {}
    for seed in range(n_seeds):
        data, _, _ = emps_builtin_data(seed)
        inputs = emps_preprocess(data)
        reg = emps_regression(inputs, friction="asymmetric")
        for cov in ("iid", "hac"):
            rows.setdefault(f"LS-{cov}", []).append(idim_ls(reg.y, reg.X, names=reg.names, cov=cov))
            for comp, label in ((False, "IV"), (True, "IVc")):
                rows.setdefault(f"{label}-{cov}", []).append(
                    emps_idim_iv(data, inputs, compensate=comp, cov=cov).result
                )
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
