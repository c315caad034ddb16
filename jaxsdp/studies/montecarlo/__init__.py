"""Monte Carlo robustness studies on the built-in EMPS (issue 18): identification and control.

`identification_robustness` repeats the EMPS identification study (IDIM-LS,
IDIM-IV, SDP stage, IDIM-SDP) over noisy closed-loop experiments and
reports bias, spread, the honesty of the stated standard errors (coverage
of the 95 % intervals) and how often the mass is found constant and the
friction asymmetric. `control_robustness` draws plants around the nominal
model and runs the linear PD, SDP-PD and PIP-SDP step responses designed on
that model. Both run through `jaxsdp.monte_carlo` (vectorised, chunked,
sharded over devices); `jaxsdp montecarlo` writes their reports.
"""

from ._control import CONTROLLERS as CONTROLLERS
from ._control import PARAMETERS as PARAMETERS
from ._control import ControlRobustness as ControlRobustness
from ._control import control_robustness as control_robustness
from ._control import step_statistics as step_statistics
from ._figures import control_figures as control_figures
from ._figures import identification_figures as identification_figures
from ._figures import save_figures as save_figures
from ._identification import ESTIMATORS as ESTIMATORS
from ._identification import IdentificationRobustness as IdentificationRobustness
from ._identification import IdentificationSettings as IdentificationSettings
from ._identification import identification_robustness as identification_robustness
from ._report import text_output as text_output

__all__ = [
    "CONTROLLERS",
    "ESTIMATORS",
    "PARAMETERS",
    "ControlRobustness",
    "IdentificationRobustness",
    "IdentificationSettings",
    "control_figures",
    "control_robustness",
    "identification_figures",
    "identification_robustness",
    "save_figures",
    "step_statistics",
    "text_output",
]
