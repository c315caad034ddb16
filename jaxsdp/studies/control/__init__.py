"""The SDP control study of the EMPS (paper section 4): SDP-PD, SRIVC, PIP-LQ, PIP-SDP cascade, gradients.

`control_study` runs the stages in order (`STAGES`); `ControlSettings`
holds its options (the paper's by default); `control_summary`,
`report_markdown` and `text_output` turn a `ControlStudy` into summary.json,
report.md and the console tables; the `fig_*` functions draw Fig. 13,
Fig. 14, the cascade and the SRIVC fit (`save_control_figures` writes them).
"""

from ._figures import CONTROL_FIGURE_NAMES as CONTROL_FIGURE_NAMES
from ._figures import control_figures as control_figures
from ._figures import fig_cascade as fig_cascade
from ._figures import fig_friction_forms as fig_friction_forms
from ._figures import fig_srivc as fig_srivc
from ._figures import fig_step_responses as fig_step_responses
from ._figures import save_control_figures as save_control_figures
from ._report import control_summary as control_summary
from ._report import report_markdown as report_markdown
from ._report import text_output as text_output
from ._settings import ControlSettings as ControlSettings
from ._settings import ControlStudy as ControlStudy
from ._study import ASYM as ASYM
from ._study import PAPER_MODEL as PAPER_MODEL
from ._study import STAGES as STAGES
from ._study import FrictionEstimate as FrictionEstimate
from ._study import NominalDesign as NominalDesign
from ._study import control_study as control_study
from ._study import identify_friction as identify_friction
from ._study import nominal_design as nominal_design

__all__ = [
    "ASYM",
    "CONTROL_FIGURE_NAMES",
    "PAPER_MODEL",
    "STAGES",
    "ControlSettings",
    "ControlStudy",
    "FrictionEstimate",
    "NominalDesign",
    "control_figures",
    "control_study",
    "control_summary",
    "fig_cascade",
    "fig_friction_forms",
    "fig_srivc",
    "fig_step_responses",
    "identify_friction",
    "nominal_design",
    "report_markdown",
    "save_control_figures",
    "text_output",
]
