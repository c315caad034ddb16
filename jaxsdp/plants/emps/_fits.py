"""The EMPS fits on one preprocessed record, and what they say about themselves.

`emps_fits` runs, in order, IDIM-LS with the linear and the asymmetric
friction model (`emps_regression` + `jaxsdp.idim_ls`: parallel decimation,
the published procedure), the SDP stage (`emps_sdp_stage`, eq. 13) and
IDIM-SDP (`emps_idim_sdp`, eq. 17): the fits that the EMPS study reports and
the control study's friction rests on, computed once, here.
`EMPSFits.checks` (`physical_warnings`, `fit_warnings`) are their checks: signs (mass > 0,
friction >= 0), conditioning and precision, NVRs on a bound, convergence; `EMPSFits.scales`
checks the scales against physics (units, time scale).
"""

from collections.abc import Callable
from typing import Literal, NamedTuple

from ..._idim.ls import IDIMResult, idim_ls
from ..._idim.trust import bound_advice, conditioning_warnings, sign_warnings
from ..._runtime import x64
from ..._sdp.backfit import CONSTANT_NVR
from ..._signal.preprocess import Preprocessed
from .._plausibility import linear_axis_checks, linear_axis_warnings
from ._idim_sdp import EMPSIDIMSDP, emps_idim_sdp
from ._model import emps_regression
from ._sdp_stage import EMPSSDPStage, emps_sdp_stage

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
    def checks(self, extra: dict | None = None) -> tuple[list[str], list[str]]:
        """(physical, fit) warnings of these fits (`physical_warnings`, `fit_warnings`).

        `extra`: label -> result of further asymmetric-friction fits solved on
        the same regression (e.g. IDIM-IV), checked with the IDIM-LS fits.
        """
        fits = {LS_LABELS["linear"]: (self.idim, "linear"), LS_LABELS["asymmetric"]: (self.idim_asym, "asymmetric")}
        regressions = dict(self.regressions)
        for label, res in (extra or {}).items():
            fits[label] = (res, "asymmetric")
            regressions[label] = self.regressions[LS_LABELS["asymmetric"]]
        return physical_warnings(fits, self.sdp, self.idim_sdp), fit_warnings(fits, regressions, self.sdp)

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
def emps_fits(
    inputs: Preprocessed,
    *,
    model="RW",
    nvr_search: Literal["captain", "sdp"] = "sdp",
    max_nvr: float | None = 1.0,
    constant_nvr: float = CONSTANT_NVR,
    timed: Callable | None = None,
) -> EMPSFits:
    """IDIM-LS (linear and asymmetric friction), the SDP stage and IDIM-SDP of one preprocessed EMPS record.

    `inputs` from `emps_preprocess`; `model`, `nvr_search`, `max_nvr`,
    `constant_nvr` as `emps_sdp_stage`; `timed(name, thunk)`, if given, runs
    each stage (`idim_ls`, `idim_ls_asym`, `sdp`, `idim_sdp`) and may time it.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.plants.emps import emps_fits, emps_preprocess
        >>> fits = emps_fits(emps_preprocess(emps_builtin_data(0)[0]))
        >>> round(fits.idim_asym["M"], 1), fits.sdp.mass_constant  # kg; truth 95.15 kg
        (95.4, True)
    """
    timed = (lambda name, thunk: thunk()) if timed is None else timed
    regressions = {}

    def ls(friction):
        reg = regressions[LS_LABELS[friction]] = emps_regression(inputs, friction=friction)
        return idim_ls(reg.y, reg.X, names=reg.names)

    idim = timed("idim_ls", lambda: ls("linear"))
    idim_asym = timed("idim_ls_asym", lambda: ls("asymmetric"))
    sdp_kw = dict(model=model, nvr_search=nvr_search, max_nvr=max_nvr, constant_nvr=constant_nvr)
    stage = timed("sdp", lambda: emps_sdp_stage(inputs, **sdp_kw))
    idim_sdp = timed("idim_sdp", lambda: emps_idim_sdp(stage, inputs, asym=idim_asym))
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


def fit_warnings(fits: dict, regressions: dict, stage: EMPSSDPStage) -> list[str]:
    """Conditioning and precision of the IDIM-LS fits; NVR bounds and convergence of the SDP stage."""
    out = []
    for label, (res, friction) in fits.items():
        out += conditioning_warnings(res, regressions[label].X, label=label, check=("M",) + _FRICTION[friction])
    for term, bound in zip(("M(ddq)", "d_fric(dq)"), stage.nvr_bound):
        if bound is not None:
            out.append("SDP stage: " + bound_advice(term, bound))
    if not bool(stage.result.converged):
        out.append(
            f"SDP stage: back-fitting stopped after {int(stage.result.sweeps)} sweeps without meeting its R^2 "
            "convergence test; the curves may still move (raise max_sweeps)"
        )
    return out
