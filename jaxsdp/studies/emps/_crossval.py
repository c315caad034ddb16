"""Cross-validation of the EMPS identification: fit on one half of a record, predict the force of the other.

On a real record there is no truth to hold the estimates against; what can
be checked is prediction. The record is cut in two at `split`; each half is
processed exactly as the study processes a whole record (`emps_preprocess`,
`emps_regression`: filter, drop, decimation, parallel decimation), each
estimator is fitted on one half, and its parameters predict the
(parallel-decimated) force of the other half from that half's regressors.
"""

import dataclasses
from collections.abc import Sequence
from typing import Literal

import equinox as eqx
import numpy as np

from ..._idim.estimators import IDIMIV
from ..._idim.iv import IDIMIVResult
from ..._idim.ls import IDIMResult, idim_ls
from ..._runtime import x64
from ..._signal.preprocess import Preprocessing
from ...data._loaders import EMPSData, Measurements
from ...plants.emps._checks import check_emps_data
from ...plants.emps._idim_iv import emps_idim_iv
from ...plants.emps._preprocess import emps_preprocess, emps_regression
from .._output import text_table

#: The estimators `emps_cross_validation` knows, as `EMPSStudy.estimator` names them (`emps_study`'s `iv`:
#: None, `IDIMIV()`, `IDIMIV(compensate=False)`).
CV_ESTIMATORS = {
    "ls": "IDIM-LS (iid covariance, the published procedure)",
    "iv": "bias-compensated IDIM-IV (HAC covariance)",
    "iv-plain": "plain IDIM-IV of Janot et al. (2014) (HAC covariance)",
}
#: The two directions, in the order of `EMPSCrossValidation.fits[estimator]`.
DIRECTIONS = ("first -> second", "second -> first")


class CrossValidationFit(eqx.Module):
    """One estimator fitted on one half of the record and scored on the other half.

    **Fields:**

    - `estimate`: the `IDIMResult` of the fit on the training half
      (`theta`, `std`, `cov`, ...; for IDIM-IV that of its last IV step).
    - `fit_error`: 100 ||y_f - X_f theta|| / ||y_f|| (%) on the training half.
    - `holdout_error`: 100 ||y_h - X_h theta|| / ||y_h|| (%) on the held-out
      half: its measured force y_h (N) against the force X_h theta predicted
      from its own regressors, both parallel-decimated.
    - `iterations`, `converged`: the IV iteration (0 and True for IDIM-LS).
    """

    estimate: IDIMResult
    fit_error: float = eqx.field(static=True)
    holdout_error: float = eqx.field(static=True)
    iterations: int = eqx.field(static=True)
    converged: bool = eqx.field(static=True)


class EMPSCrossValidation(eqx.Module):
    r"""Result of `emps_cross_validation`.

    **Fields:**

    - `fits`: estimator -> (fit on the first half, fit on the second half),
      each a `CrossValidationFit` (`DIRECTIONS` names the two).
    - `names`: parameter names; `friction`: the friction model.
    - `split`: the first sample of the second half; `samples`: raw samples
      of the two halves.

    **Methods:** `holdout_errors(est)` the two held-out errors (%),
    `theta(est)` the `(2, p)` estimates, `half_difference_z(est)` the
    difference between the two halves' estimates over its stated standard
    deviation, $(\theta_2 - \theta_1) / \sqrt{std_1^2 + std_2^2}$ (with independent
    halves and honest standard deviations, $|z| < 2$ in about 95 % of records), `table()`.
    """

    fits: dict
    names: tuple = eqx.field(static=True)
    friction: str = eqx.field(static=True)
    split: int = eqx.field(static=True)
    samples: tuple = eqx.field(static=True)

    @property
    @x64
    def estimators(self) -> tuple:
        return tuple(self.fits)

    @x64
    def holdout_errors(self, estimator: str) -> np.ndarray:
        """(2,) held-out relative errors (%), fit on the first half then on the second."""
        return np.array([f.holdout_error for f in self._fits(estimator)])

    @x64
    def theta(self, estimator: str) -> np.ndarray:
        """(2, p) estimates fitted on the first and on the second half."""
        return np.array([np.asarray(f.estimate.theta, dtype=float) for f in self._fits(estimator)])

    @x64
    def half_difference_z(self, estimator: str) -> np.ndarray:
        """(p,) (theta_second - theta_first) / sqrt(std_first^2 + std_second^2), per parameter."""
        a, b = (f.estimate for f in self._fits(estimator))
        sd = np.hypot(np.asarray(a.std, dtype=float), np.asarray(b.std, dtype=float))
        return (np.asarray(b.theta, dtype=float) - np.asarray(a.theta, dtype=float)) / sd

    def _fits(self, estimator):
        if estimator not in self.fits:
            raise KeyError(f"no estimator {estimator!r} in this cross-validation; it has {self.estimators}")
        return self.fits[estimator]

    @x64
    def table(self, *, digits: int = 4) -> str:
        """The estimates and errors as text, one row per estimator and direction."""
        head = ["estimator", "fit -> held out"] + list(self.names) + ["fit error %", "held-out error %"]
        rows = []
        for est, fits in self.fits.items():
            for direction, f in zip(DIRECTIONS, fits):
                th = np.asarray(f.estimate.theta, dtype=float)
                rows.append(
                    [est, direction]
                    + [f"{v:.{digits}g}" for v in th]
                    + [f"{f.fit_error:.{digits}f}", f"{f.holdout_error:.{digits}f}"]
                )
        n1, n2 = self.samples
        intro = (
            f"Cross-validation, {self.friction} friction: halves of {n1} and {n2} samples (split at sample "
            f"{self.split}); each estimator fitted on one half predicts the other half's force"
        )
        return intro + "\n" + text_table(head, rows, align="right")


def _half(data, start: int, stop: int):
    s = slice(start, stop)
    if isinstance(data, EMPSData):
        return EMPSData(
            t=data.t[s], qm=data.qm[s], qg=data.qg[s], vir=data.vir[s], force=data.force[s],
            gtau=data.gtau, kp=data.kp, kv=data.kv, dt=data.dt,
        )  # fmt: skip
    return Measurements(t=data.t[s], q=data.q[s], force=data.force[s], dt=data.dt)


def _relerr(reg, theta) -> float:
    y, X = np.asarray(reg.y, dtype=float), np.asarray(reg.X, dtype=float)
    return float(100.0 * np.linalg.norm(y - X @ theta) / np.linalg.norm(y))


@x64
def emps_cross_validation(
    data,
    *,
    estimators: Sequence[str] = ("ls", "iv"),
    friction: Literal["asymmetric", "linear"] = "asymmetric",
    split: int | None = None,
    preprocessing: Preprocessing | None = None,
    iv: IDIMIV | None = None,
) -> EMPSCrossValidation:
    r"""Two-fold cross-validation of IDIM-LS and IDIM-IV on an EMPS record: fit on one half, predict the other.

    The record (N samples) is cut at `split` into a first half (samples
    0 .. split-1) and a second half (split .. N-1). Each half, as a record of
    its own, goes through the study's processing (`emps_preprocess` with
    `preprocessing`, `emps_regression` with `friction`), giving its
    parallel-decimated force $y$ (N) and regressors $X$. Each estimator is fitted
    on one half, $\theta_f$, and scored on the other, $h$:

    $$ holdout\_error = 100 \|y_h - X_h \theta_f\| / \|y_h\| \quad (\%), $$

    in both directions (first -> second, second -> first).

    **Estimators** (`estimators`, names as `EMPSStudy.estimator`):
    `"ls"` IDIM-LS (`idim_ls`, the paper's iid covariance); `"iv"` the
    bias-compensated IDIM-IV and `"iv-plain"` the plain IDIM-IV of Janot et
    al. (2014) (`emps_idim_iv`, HAC covariance, started from the half's
    IDIM-LS; instruments from the model simulated in the half's closed loop,
    started at rest at its first position reading: they need an `EMPSData`).

    **Arguments:**

    - `data`: an `EMPSData` (`jaxsdp.data.load_emps`, `emps_builtin_data`),
      or a `Measurements` when `estimators` is `("ls",)`.
    - `split`: first sample of the second half; None: N // 2. Both halves
      must pass `check_emps_data` (enough samples, motion both ways).
    - `preprocessing`: a `jaxsdp.Preprocessing` (derivatives, drop, decimation), the same for both halves and
      the IV's simulated records; None: `Preprocessing.emps()`, the benchmark's.
    - `iv`: the IV iteration, a `jaxsdp.IDIMIV`: its `max_iter`, `tol` and `cov` (`NeweyWest(lag)` or `IID()`)
      are used, its `compensate` is set by the estimator's name ("iv" or "iv-plain"); None: `IDIMIV()` (20
      iterations at most, tolerance 1e-4, HAC covariance).

    **Returns:** an `EMPSCrossValidation` (`fits`, `holdout_errors(est)`,
    `theta(est)`, `half_difference_z(est)`, `table()`).

    **Raises:** `ValueError` for an unknown estimator or friction model, a
    split outside the record, a half the study cannot identify, bad option
    objects, or IV on data without the closed loop's reference.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_cross_validation
        >>> data, truth, _ = emps_builtin_data(0)
        >>> cv = emps_cross_validation(data, estimators=("ls",))
        >>> cv.split, cv.samples, cv.names[:2]
        (12420, (12420, 12421), ('M', 'Fv_pos'))
        >>> bool(max(cv.holdout_errors("ls")) < 5.0)  # % of the held-out force
        True
    """
    if isinstance(estimators, str):
        estimators = (estimators,)
    estimators = tuple(estimators)
    unknown = [e for e in estimators if e not in CV_ESTIMATORS]
    if not estimators or unknown or len(set(estimators)) != len(estimators):
        raise ValueError(f"`estimators` must be distinct names among {tuple(CV_ESTIMATORS)}; got {estimators!r}")
    if friction not in ("asymmetric", "linear"):
        raise ValueError(f"`friction` must be 'asymmetric' or 'linear'; got {friction!r}")
    preprocessing = Preprocessing.emps() if preprocessing is None else preprocessing
    if not isinstance(preprocessing, Preprocessing):
        raise ValueError(f"`preprocessing` must be a jaxsdp.Preprocessing or None; got {preprocessing!r}")
    iv = IDIMIV() if iv is None else iv
    if not isinstance(iv, IDIMIV):
        raise ValueError(f"`iv` must be a jaxsdp.IDIMIV or None; got {iv!r}")
    if not isinstance(data, (EMPSData, Measurements)):
        raise ValueError(f"`data` must be an EMPSData or a Measurements; got {type(data).__name__}")
    if any(e != "ls" for e in estimators) and not isinstance(data, EMPSData):
        raise ValueError(
            "IDIM-IV simulates the closed loop to build its instruments: it needs an EMPSData (with the reference "
            f"`qg` and the controller gains), got {type(data).__name__}; use estimators=('ls',)"
        )
    n = int(np.shape(data.force)[0])
    if split is None:
        split = n // 2
    if isinstance(split, bool) or not isinstance(split, (int, np.integer)) or not 0 < split < n:
        raise ValueError(f"`split` must be an integer in (0, {n}) (the first sample of the second half); got {split!r}")
    split = int(split)
    halves = (_half(data, 0, split), _half(data, split, n))
    for label, h in zip(("first", "second"), halves):
        try:
            check_emps_data(h, drop=preprocessing.drop, decimate=preprocessing.decimate)
        except ValueError as e:
            raise ValueError(f"the {label} half (split at sample {split}) cannot be identified: {e}") from None
    options = preprocessing._options()
    inputs = [emps_preprocess(h, **options) for h in halves]
    regs = [emps_regression(i, friction=friction) for i in inputs]
    ls = [idim_ls(r.y, r.X, names=r.names) for r in regs]  # each half's IDIM-LS, also the IV's start
    fits = {}
    for est in estimators:
        per_direction = []
        for k in (0, 1):
            reg, other = regs[k], regs[1 - k]
            res = ls[k]
            iterations, converged = 0, True
            if est != "ls":
                options_k = dataclasses.replace(iv, compensate=est == "iv")
                fitted: IDIMIVResult = emps_idim_iv(
                    halves[k], inputs[k], start=res, friction=friction, preprocessing=preprocessing, iv=options_k
                )
                res, iterations, converged = fitted.result, int(fitted.iterations), bool(fitted.converged)
            theta = np.asarray(res.theta, dtype=float)
            per_direction.append(
                CrossValidationFit(
                    estimate=res,
                    fit_error=_relerr(reg, theta),
                    holdout_error=_relerr(other, theta),
                    iterations=iterations,
                    converged=converged,
                )
            )
        fits[est] = tuple(per_direction)
    return EMPSCrossValidation(
        fits=fits, names=tuple(regs[0].names), friction=friction, split=split, samples=(split, n - split)
    )
