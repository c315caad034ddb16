"""The EMPS fits on one preprocessed record.

`emps_fits` runs, in order, IDIM-LS with the linear and the asymmetric
friction model (`emps_regression` + least squares: parallel decimation,
the published procedure), the SDP stage (eq. 13) and IDIM-SDP (eq. 17), as
the pure `EMPSPipeline.estimate`, and reads the fit on the host
(`fits_from`, `_diagnosis.py`): the fits that the EMPS study reports and the control study's
friction rests on, computed once, here.
"""

from typing import Literal

from ..._runtime import x64
from ..._sdp.backfit import CONSTANT_NVR
from ..._signal.preprocess import Preprocessed
from ._diagnosis import EMPSFits, fits_from
from ._pipeline import EMPSPipeline
from ._sdp_stage import sdp_backfitting


@x64
def emps_fits(
    inputs: Preprocessed,
    *,
    model="RW",
    nvr_search: Literal["captain", "sdp"] = "sdp",
    max_nvr: float | None = 1.0,
    constant_nvr: float = CONSTANT_NVR,
) -> EMPSFits:
    """IDIM-LS (linear and asymmetric friction), the SDP stage and IDIM-SDP of one preprocessed EMPS record.

    `inputs` from `emps_preprocess`; `model`, `nvr_search`, `max_nvr`,
    `constant_nvr` as `emps_sdp_stage`. The estimation is `EMPSPipeline.estimate`
    (pure; CAPTAIN's NVR search, host-side, runs first and fixes the NVRs), and
    `fits_from` reads its fit on the host.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.plants.emps import emps_fits, emps_preprocess
        >>> fits = emps_fits(emps_preprocess(emps_builtin_data(0)[0]))
        >>> round(fits.idim_asym["M"], 1), fits.sdp.mass_constant  # kg; truth 95.15 kg
        (95.4, True)
    """
    sdp_kw = dict(model=model, nvr=None, nvr_search=nvr_search, max_nvr=max_nvr, constant_nvr=constant_nvr)
    backfitting, search_se = sdp_backfitting(inputs, nvr0=1e-4, **sdp_kw)
    fit = EMPSPipeline(sdp=backfitting).estimate(inputs)
    return fits_from(fit, search_se=search_se, **sdp_kw)
