"""Control: SDP-based control design for the EMPS (paper section 4).

- the SDP control model and the friction forms its controllers use
  (`control_model`, `SDPControlModel`, `sdp_friction`);
- digital controllers on the continuous EMPS plant (`SDPPD`, `LinearPD`,
  the `PIPSDP` cascade; `simulate_control`, `Drive`, `REAL_DRIVE`,
  `true_plant`) and step figures (`step_metrics`, `tracking_cost`);
- continuous-time transfer functions from sampled data (`srivc`) and their
  zero-order-hold discretisation (`c2d`);
- NMSS/PIP-LQ design (`pip_lq`, `nmss`, `solve_dare`) and simulation
  (`pip_init`, `pip_step`, `pip_simulate`).

Transfer-function conventions: continuous `num`, `den` highest power of s
first, `den` monic; discrete `B(z^-1)/A(z^-1)` as coefficients of z^0, z^-1, ...
"""

from ._c2d import c2d
from ._cascade import PIPSDP
from ._closed_loop import REAL_DRIVE, AbstractController, ControlSimulation, Drive, simulate_control, true_plant
from ._dare import solve_dare
from ._metrics import StepMetrics, step_metrics, tracking_cost
from ._model import SDPControlModel, control_model, sdp_friction
from ._pip import NMSS, PIPDesign, PIPSimulation, PIPState, nmss, pip_init, pip_lq, pip_simulate, pip_step
from ._sdp_pd import SDPPD, LinearPD
from ._srivc import SRIVCResult, srivc

__all__ = [
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
