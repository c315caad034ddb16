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

from ._c2d import c2d as c2d
from ._cascade import PIPSDP as PIPSDP
from ._closed_loop import REAL_DRIVE as REAL_DRIVE
from ._closed_loop import AbstractController as AbstractController
from ._closed_loop import ControlSimulation as ControlSimulation
from ._closed_loop import Drive as Drive
from ._closed_loop import simulate_control as simulate_control
from ._closed_loop import true_plant as true_plant
from ._dare import solve_dare as solve_dare
from ._metrics import StepMetrics as StepMetrics
from ._metrics import step_metrics as step_metrics
from ._metrics import tracking_cost as tracking_cost
from ._model import SDPControlModel as SDPControlModel
from ._model import control_model as control_model
from ._model import sdp_friction as sdp_friction
from ._pip import NMSS as NMSS
from ._pip import PIPDesign as PIPDesign
from ._pip import PIPSimulation as PIPSimulation
from ._pip import PIPState as PIPState
from ._pip import nmss as nmss
from ._pip import pip_init as pip_init
from ._pip import pip_lq as pip_lq
from ._pip import pip_simulate as pip_simulate
from ._pip import pip_step as pip_step
from ._sdp_pd import SDPPD as SDPPD
from ._sdp_pd import LinearPD as LinearPD
from ._srivc import SRIVCResult as SRIVCResult
from ._srivc import srivc as srivc

__all__ = [
    "AbstractController",
    "ControlSimulation",
    "Drive",
    "LinearPD",
    "NMSS",
    "PIPDesign",
    "PIPSDP",
    "PIPSimulation",
    "PIPState",
    "REAL_DRIVE",
    "SDPControlModel",
    "SDPPD",
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
