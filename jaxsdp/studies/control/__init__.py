"""The SDP control study of the EMPS (paper section 4): SDP-PD, SRIVC, PIP-LQ, PIP-SDP cascade, gradients.

`control_study` runs the stages in order (`STAGES`); `ControlSettings`
holds its options (the paper's by default). The designs it stands on live in
the control layer and are re-exported here: `identify_friction` (the EMPS
fits for the friction the controllers use) and `nominal_design` (the designs
without the study's simulations; the Monte Carlo control study designs on
it); `control_summary`,
`report_markdown` and `text_output` turn a `ControlStudy` into summary.json,
report.md and the console tables; the `fig_*` functions draw Fig. 13,
Fig. 14, the cascade and the SRIVC fit (`save_control_figures` writes them).
"""

from ...control._nominal import (
    ASYM,
    ControlSettings,
    FrictionEstimate,
    NominalDesign,
    identify_friction,
    nominal_design,
)
from .._contract import figures, report, summary, text
from ._figures import (
    CONTROL_FIGURE_NAMES,
    control_figures,
    fig_cascade,
    fig_friction_forms,
    fig_srivc,
    fig_step_responses,
    save_control_figures,
)
from ._report import control_summary, report_markdown, text_output
from ._settings import ControlStudy
from ._shared import PAPER_MODEL
from ._study import STAGES, control_study

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
    "figures",
    "identify_friction",
    "nominal_design",
    "report",
    "report_markdown",
    "save_control_figures",
    "summary",
    "text",
    "text_output",
]
