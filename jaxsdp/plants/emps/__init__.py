"""The EMPS family: the linear axis, its benchmark controller, its inverse dynamic model and identification stages.

- the plant and its closed loop (`EMPSPlant`, `EMPSController`, `EMPSInitial`,
  `simulate_emps`) and identification through that simulator
  (`identify_emps_by_simulation`);
- the inverse dynamic model (`emps_regression`, `emps_regressors`,
  `emps_asym_regressors`, eqs. 17-18) and its names and constants
  (`EMPS_ASYM_NAMES`, `EMPS_LINEAR_NAMES`, `EMPS_DROP`);
- the identification stages shared by every study that identifies an EMPS
  (`jaxsdp.studies.emps`, the control study's friction, the Monte Carlo
  run): `emps_preprocess` -> IDIM-LS (`jaxsdp.idim_ls` on `emps_regression`)
  -> `emps_idim_iv` -> `emps_sdp_stage` -> `emps_idim_sdp`, with the
  record checks (`check_emps_data`) and the fits' warnings; the friction law
  read off the SDP curve (`emps_friction`, `EMPSFriction`);
- the same estimation as one pure Module, `EMPSPipeline(...)(data) -> EMPSFit`
  (jit, vmap over records, grad), and the noisy closed-loop experiment that
  makes records, `EMPSExperiment(reference, dt=...)(key, theta) -> EMPSData`.
"""

from ._checks import check_emps_data
from ._diagnosis import EMPSFits, fits_from
from ._fits import emps_fits
from ._friction_stage import EMPSFriction, emps_friction
from ._idim_iv import emps_idim_iv
from ._idim_sdp import EMPSIDIMSDP, emps_idim_sdp
from ._model import (
    EMPS_ASYM_NAMES,
    EMPS_DROP,
    EMPS_LINEAR_NAMES,
    asym_friction,
    asym_friction_basis,
    emps_asym_regressors,
    emps_regression,
    emps_regressors,
)
from ._pipeline import EMPSExperiment, EMPSFit, EMPSPipeline, asymmetric_plant
from ._plant import EMPS_IDIM_LS, EMPSController, EMPSInitial, EMPSPlant, EMPSSimulation, simulate_emps
from ._preprocess import emps_preprocess
from ._sdp_stage import EMPSSDPStage, emps_sdp_stage
from ._sim_ident import SimIdentResult, default_parameters, identify_emps_by_simulation

__all__ = [
    "EMPSIDIMSDP",
    "EMPS_ASYM_NAMES",
    "EMPS_DROP",
    "EMPS_IDIM_LS",
    "EMPS_LINEAR_NAMES",
    "EMPSController",
    "EMPSInitial",
    "EMPSExperiment",
    "EMPSFit",
    "EMPSPipeline",
    "EMPSFits",
    "EMPSFriction",
    "EMPSPlant",
    "EMPSSDPStage",
    "EMPSSimulation",
    "SimIdentResult",
    "asym_friction",
    "asymmetric_plant",
    "asym_friction_basis",
    "check_emps_data",
    "default_parameters",
    "emps_asym_regressors",
    "emps_fits",
    "emps_friction",
    "emps_idim_iv",
    "emps_idim_sdp",
    "emps_preprocess",
    "emps_regression",
    "emps_regressors",
    "emps_sdp_stage",
    "fits_from",
    "identify_emps_by_simulation",
    "simulate_emps",
]
