"""Monte Carlo robustness studies on the built-in EMPS (issue 18): control robustness of the SDP controllers.

`control_robustness` draws plants around the nominal model, runs the
linear PD, SDP-PD and PIP-SDP step responses designed on that model through
`jaxsdp.monte_carlo`, and summarises them (`ControlRobustness.summary`).
"""

from ._control import CONTROLLERS as CONTROLLERS
from ._control import PARAMETERS as PARAMETERS
from ._control import ControlRobustness as ControlRobustness
from ._control import control_robustness as control_robustness
from ._control import step_statistics as step_statistics

__all__ = ["CONTROLLERS", "PARAMETERS", "ControlRobustness", "control_robustness", "step_statistics"]
