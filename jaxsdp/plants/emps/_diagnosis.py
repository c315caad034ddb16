"""The host-side reading of an EMPS fit: what the fits say about themselves (the EMPS pipeline's diagnosis).

`fits_from` reads an `EMPSFit` (`EMPSPipeline`) on the host: the `IDIMResult`s rank-checked, the SDP stage's
NVR bounds and standard errors, IDIM-SDP; `EMPSFits.checks` (`physical_warnings`, `fit_warnings`) are their
checks: signs (mass > 0, friction >= 0), conditioning and precision, NVRs on a bound, convergence, a record that
ends in motion; `EMPSFits.scales` checks the scales against physics (units, time scale).
`EMPSPipeline.diagnose` is this module on the pipeline's own options.
"""

from typing import NamedTuple

import numpy as np

from ..._idim.ls import IDIMResult, rank_checked
from ..._idim.trust import bound_advice, conditioning_warnings, sign_warnings
from ..._runtime import x64
from ..._sdp.backfit import CONSTANT_NVR
from ..._signal.preprocess import Preprocessed
from .._plausibility import linear_axis_checks, linear_axis_warnings
from ._idim_sdp import EMPSIDIMSDP, fv_ratio
from ._model import emps_regression
from ._sdp_stage import EMPSSDPStage, sdp_stage_from

#: The labels of the two IDIM-LS fits, by friction model (in warnings, reports and `EMPSFits.regressions`).
LS_LABELS = {"linear": "IDIM-LS (linear friction)", "asymmetric": "IDIM-LS (asymmetric friction)"}
_UNITS = {"M": "kg", "Fv": "N/(m/s)", "Fc": "N", "Fv_pos": "N/(m/s)", "Fc_pos": "N", "Fv_neg": "N/(m/s)"}
_UNITS["Fc_neg"] = "N"
_FRICTION = {"linear": ("Fv", "Fc"), "asymmetric": ("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")}


class EMPSFits(NamedTuple):
    """What `emps_fits` returns.

    `idim`: IDIM-LS, linear friction (M, Fv, Fc, offset); `idim_asym`:
    IDIM-LS, asymmetric friction (eq. 18); `sdp`: the `EMPSSDPStage`;
    `idim_sdp`: the `EMPSIDIMSDP`; `regressions`: label (`LS_LABELS`) -> the
    `Regression` each IDIM-LS fit was solved on.
    """

    idim: IDIMResult
    idim_asym: IDIMResult
    sdp: EMPSSDPStage
    idim_sdp: EMPSIDIMSDP
    regressions: dict

    @x64
    def checks(self, extra: dict | None = None, *, cap: str = "`max_nvr`") -> tuple[list[str], list[str]]:
        """(physical, fit) warnings of these fits (`physical_warnings`, `fit_warnings`).

        `extra`: label -> result of further asymmetric-friction fits solved on
        the same regression (e.g. IDIM-IV), checked with the IDIM-LS fits;
        `cap`: where the caller's user sets the NVR cap an NVR-on-its-cap
        warning tells them to raise (an argument in backquotes).
        """
        fits = {LS_LABELS["linear"]: (self.idim, "linear"), LS_LABELS["asymmetric"]: (self.idim_asym, "asymmetric")}
        regressions = dict(self.regressions)
        for label, res in (extra or {}).items():
            fits[label] = (res, "asymmetric")
            regressions[label] = self.regressions[LS_LABELS["asymmetric"]]
        return physical_warnings(fits, self.sdp, self.idim_sdp), fit_warnings(fits, regressions, self.sdp, cap=cap)

    @x64
    def scales(self, inputs: Preprocessed) -> tuple[list[dict], list[str]]:
        """The scale checks of a linear axis (`jaxsdp.plants._plausibility.linear_axis_checks`: travel, speed,
        acceleration, the mass against the force, Coulomb friction against the weight M g) of these fits on their
        record `inputs`, and their warning (none when every check passes)."""
        a = self.idim_asym
        fits = {
            LS_LABELS["linear"]: (self.idim["M"], self.idim["Fc"]),
            LS_LABELS["asymmetric"]: (a["M"], max(a["Fc_pos"], a["Fc_neg"])),
        }
        checks = linear_axis_checks(inputs, fits)
        return checks, linear_axis_warnings(checks, fits)


@x64
def fits_from(
    fit, *, model="RW", nvr=None, nvr_search="sdp", max_nvr=1.0, constant_nvr=CONSTANT_NVR, search_se=None
) -> EMPSFits:
    """The host-side reading of an `EMPSFit` (with its SDP stage): the `IDIMResult`s rank-checked (a rank-deficient
    regression raises `ValueError`, as `idim_ls`), the `EMPSSDPStage` (NVR bounds, standard errors, the
    mass-constancy flag) and the `EMPSIDIMSDP`; the options are those the fit was made with (`emps_sdp_stage`'s).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.plants.emps import EMPSPipeline, fits_from
        >>> fits = fits_from(EMPSPipeline()(emps_builtin_data(0)[0]))
        >>> fits.sdp.nvr_bound, round(fits.idim_sdp.fv_ratio, 2)  # the friction NVR at its cap; Fv_neg / Fv_pos
        ((None, 'upper'), 1.45)
    """
    if fit.sdp is None:
        raise ValueError("the fit has no SDP stage: make it with EMPSPipeline(sdp=Backfitting(...))")
    inputs = fit.inputs
    regressions = {LS_LABELS[f]: emps_regression(inputs, friction=f) for f in ("linear", "asymmetric")}

    def checked(res, label):
        n, p = regressions[label].X.shape
        rank_checked("X", res.cond, n, p)
        return res

    idim = checked(fit.idim, LS_LABELS["linear"])
    idim_asym = checked(fit.idim_asym, LS_LABELS["asymmetric"])
    stage = sdp_stage_from(
        fit.sdp, inputs, model=model, nvr=nvr, nvr_search=nvr_search, max_nvr=max_nvr, constant_nvr=constant_nvr,
        search_se=search_se,
    )  # fmt: skip
    curve = checked(fit.idim_sdp, LS_LABELS["asymmetric"])
    idim_sdp = EMPSIDIMSDP(
        friction=curve,
        mass=stage.mass,
        fv_ratio=fv_ratio(curve),
        relative_error=float(fit.idim_sdp_relative_error),
        asym=idim_asym,
        basis="parallel",
    )
    return EMPSFits(idim, idim_asym, stage, idim_sdp, regressions)


def physical_warnings(fits: dict, stage: EMPSSDPStage, idim_sdp: EMPSIDIMSDP) -> list[str]:
    """Sign checks (mass > 0, friction >= 0) of every identified model (label -> (result, friction)), and the SDP
    mass."""
    out = []
    for label, (res, friction) in fits.items():
        out += sign_warnings(res, label=label, positive=("M",), nonnegative=_FRICTION[friction], units=_UNITS)
    out += sign_warnings(
        idim_sdp.friction, label="IDIM-SDP curve fit", nonnegative=_FRICTION["asymmetric"], units=_UNITS
    )
    if not stage.mass > 0:
        out.append(
            f"SDP stage: the acceleration-weighted SDP mass {stage.mass:.4g} kg is not positive: physically impossible"
        )
    return out


#: A residual at either end of the record beyond this many residual standard deviations is the derivative
#: filter's end transient (Gaussian noise puts a sample there with probability 6e-7)...
END_SIGMAS = 5.0
#: ...and it is reported when removing those end samples moves an estimate by more than this many of its
#: standard errors (a fragile estimate; below it, one corrupted sample among thousands is harmless).
END_SHIFT = 1.0


def end_warnings(res: IDIMResult, regression, label: str) -> list[str]:
    r"""A warning when the residuals at the record's start or end exceed `END_SIGMAS` standard deviations and
    leaving those samples out moves an estimate by more than `END_SHIFT` standard errors.

    The zero-phase derivative filter starts and stops on a record in motion with a transient: the first or last
    decimated samples carry derivative errors of tens of sigmas. The check refits $\hat\theta$ by least squares
    without the runs of such samples at each end (NumPy, on the host) and compares $|\Delta\hat\theta_i| /
    se_i$.
    """
    r = np.asarray(res.residuals, dtype=float)
    sigma = float(np.std(r))
    if r.size < 10 or not sigma > 0:
        return []
    big = np.abs(r) > END_SIGMAS * sigma
    head = int(np.argmin(big)) if not big.all() else r.size
    tail = int(np.argmin(big[::-1])) if not big.all() else r.size
    if head + tail == 0 or head + tail > r.size // 10:
        return []
    keep = slice(head, r.size - tail)
    X, y = np.asarray(regression.X, dtype=float), np.asarray(regression.y, dtype=float)
    theta = np.linalg.lstsq(X[keep], y[keep], rcond=None)[0]
    shift = np.abs(theta - np.asarray(res.theta, dtype=float)) / np.asarray(res.std, dtype=float)
    i = int(np.argmax(shift))
    if not shift[i] > END_SHIFT:
        return []
    ends = " and ".join(f"{w} {n}" for n, w in ((head, "first"), (tail, "last")) if n)
    worst = r[0] if abs(r[0]) >= abs(r[-1]) else r[-1]
    return [
        f"{label}: the residuals of the record's {ends} decimated sample(s) exceed {END_SIGMAS:g} times their "
        f"standard deviation {sigma:.3g} N (up to {worst:.3g} N): the axis is in motion there and the zero-phase "
        f"derivative filter's transient corrupts those samples; without them {res.names[i]} moves by "
        f"{shift[i]:.2g} standard errors (the estimate depends on them); cut the record where the axis is at rest "
        "(the processing drops samples at the start only)"
    ]


def fit_warnings(fits: dict, regressions: dict, stage: EMPSSDPStage, *, cap: str = "`max_nvr`") -> list[str]:
    """Conditioning and precision of the IDIM-LS fits, residuals at the record's ends; NVR bounds and convergence
    of the SDP stage."""
    asym = LS_LABELS["asymmetric"]
    out = end_warnings(fits[asym][0], regressions[asym], asym)
    for label, (res, friction) in fits.items():
        out += conditioning_warnings(res, regressions[label].X, label=label, check=("M",) + _FRICTION[friction])
    for term, bound in zip(("M(ddq)", "d_fric(dq)"), stage.nvr_bound):
        if bound is not None:
            out.append("SDP stage: " + bound_advice(term, bound, option=cap))
    if not bool(stage.result.converged):
        out.append(
            f"SDP stage: back-fitting stopped after {int(stage.result.sweeps)} sweeps without meeting its R^2 "
            "convergence test; the curves may still move (raise max_sweeps)"
        )
    return out
