"""Monte Carlo robustness studies on the built-in EMPS (issue 18): identification and control.

`identification_robustness` repeats the EMPS identification study (IDIM-LS,
IDIM-IV, SDP stage, IDIM-SDP) over noisy closed-loop experiments and
reports bias, spread, the honesty of the stated standard errors (coverage
of the 95 % intervals) and how often the mass is found constant and the
friction asymmetric. `control_robustness` draws plants around the nominal
model and runs the linear PD, SDP-PD and PIP-SDP step responses designed on
that model (`step_statistics`: settling time, overshoot, peaks, stability
of each response). `robot_robustness` draws robots around a description,
simulates each on one exciting trajectory and identifies it with the robot
pipeline: bias, spread and coverage of every base parameter. All run through `jaxsdp.monte_carlo` (vectorised,
chunked, sharded over devices and hosts). Each result is a study result (`jaxsdp.studies._contract.Study`)
that presents itself (`summary()`, `report()`, `text()`, `figures()`; the
functions `summary`, `report`, `text`, `figures` call them): that is what
`jaxsdp montecarlo` prints and writes.
"""

from .._contract import figures, report, summary, text
from ._control import ControlRobustness, control_robustness, step_statistics
from ._figures import control_figures, identification_figures, save_figures
from ._identification import IdentificationRobustness, IdentificationSettings, identification_robustness
from ._report import text_output
from ._robot import RobotRobustness, RobotSettings, robot_robustness
from ._shared import CONTROLLERS, ESTIMATORS, PARAMETERS

__all__ = [
    "CONTROLLERS",
    "ESTIMATORS",
    "PARAMETERS",
    "ControlRobustness",
    "IdentificationRobustness",
    "IdentificationSettings",
    "RobotRobustness",
    "RobotSettings",
    "control_figures",
    "control_robustness",
    "figures",
    "identification_figures",
    "identification_robustness",
    "report",
    "robot_robustness",
    "save_figures",
    "step_statistics",
    "summary",
    "text",
    "text_output",
]
