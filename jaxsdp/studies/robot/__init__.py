"""The robot study: every joint of a serial robot identified at once from its description and joint logs.

`robot_study` (the back end of `jaxsdp robot`): the logs brought to the
model's convention by the robot's `Drives`, the stacked full model and its
base parameters, one IDIM-LS on every joint's rows, and the multi-SDP of
each joint's residual; `excitation_study` (`jaxsdp robot --excite`): an
exciting trajectory optimised by gradient and checked by identifying the
simulated robot on it. The study contract's `summary`, `report`, `text` and
`figures` present either.
"""

from .._contract import figures, report, summary, text
from ._example import example_study
from ._excite import EXCITE_STAGES, ExcitationDesign, ExcitationStudy, excitation_study
from ._excite_report import write_trajectory
from ._study import STAGES, RobotStudy, robot_study

__all__ = [
    "EXCITE_STAGES",
    "STAGES",
    "ExcitationDesign",
    "ExcitationStudy",
    "RobotStudy",
    "example_study",
    "excitation_study",
    "figures",
    "report",
    "robot_study",
    "summary",
    "text",
    "write_trajectory",
]
