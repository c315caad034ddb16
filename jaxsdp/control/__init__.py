"""Control: SDP-based control design for the EMPS (paper section 4).

- the SDP control model and the friction forms its controllers use
  (`control_model`, `SDPControlModel`, `sdp_friction`);
- digital controllers on the continuous EMPS plant (`SDPPD`, `LinearPD`,
  the `PIPSDP` cascade; `simulate_control`, `Drive`, `REAL_DRIVE`,
  `true_plant`) and step figures (`step_metrics`, `tracking_cost`);
- `srivc`, `SRIVCResult` and `c2d`, re-exported from `jaxsdp.tfest` (the
  transfer-function estimators' family, their home);
- the designs on the nominal model that the control and Monte Carlo
  studies share (`identify_friction`, `nominal_design`, `ControlSettings`);
- NMSS/PIP-LQ design (`pip_lq`, `nmss`, `solve_dare`) and simulation
  (`pip_init`, `pip_step`, `pip_simulate`).

Transfer-function conventions: continuous `num`, `den` highest power of s
first, `den` monic; discrete `B(z^-1)/A(z^-1)` as coefficients of z^0, z^-1, ...
"""

from ..tfest import SRIVCResult, c2d, srivc
from ._cascade import PIPSDP
from ._closed_loop import REAL_DRIVE, AbstractController, ControlSimulation, Drive, simulate_control, true_plant
from ._dare import solve_dare
from ._metrics import StepMetrics, step_metrics, tracking_cost
from ._model import SDPControlModel, control_model, sdp_friction
from ._nominal import ControlSettings, FrictionEstimate, NominalDesign, identify_friction, nominal_design
from ._pip import NMSS, PIPDesign, PIPSimulation, PIPState, nmss, pip_init, pip_lq, pip_simulate, pip_step
from ._sdp_pd import SDPPD, LinearPD

__all__ = [
    "ControlSettings",
    "FrictionEstimate",
    "NominalDesign",
    "identify_friction",
    "nominal_design",
    "NMSS",
    "PIPSDP",
    "REAL_DRIVE",
    "SDPPD",
    "AbstractController",
    "ControlSimulation",
    "Drive",
    "LinearPD",
    "PIPDesign",
    "PIPSimulation",
    "PIPState",
    "SDPControlModel",
    "SRIVCResult",
    "StepMetrics",
    "c2d",
    "control_model",
    "nmss",
    "pip_init",
    "pip_lq",
    "pip_simulate",
    "pip_step",
    "sdp_friction",
    "simulate_control",
    "solve_dare",
    "srivc",
    "step_metrics",
    "tracking_cost",
    "true_plant",
]
