"""The TX40 robot study (paper section 3): one joint's IDIM-LS and multi-SDP from joint logs.

`tx40_study` runs the stages in order; each is also callable alone:
`joint_preprocess` (the EMPS benchmark's processing of one joint) ->
`joint_idim_ls` (eq. 22, residual whiteness) -> `joint_multi_sdp` (section
3.3: gravity and friction SDPs with the inertia fixed, their parametric
projections). `report_markdown` and `text_output` write its report and
tables; `tx40_figures` draws the paper's Figs. 7-11 and the residual
autocorrelation. The back end of `jaxsdp tx40`.

Beyond the paper (`tx40_study(..., full_model=True)`, `jaxsdp tx40 --model
full`): the joint is also identified with the full six-joint rigid-body
model's base parameters (`JointFullModel`), the multi-SDP of its residual
follows, and the study measures how much of the one-joint SDP curves'
departure from eq. (20) the coupling explains (`fig_full_model`).
"""

from ._example import example_study as example_study
from ._figures import FIGURE_NAMES as FIGURE_NAMES
from ._figures import FULL_FIGURE as FULL_FIGURE
from ._figures import fig_autocorrelation as fig_autocorrelation
from ._figures import fig_reconstruction as fig_reconstruction
from ._figures import fig_shapes as fig_shapes
from ._figures import save_tx40_figures as save_tx40_figures
from ._figures import tx40_figures as tx40_figures
from ._figures_full import fig_full_model as fig_full_model
from ._full import JointFullModel as JointFullModel
from ._report import findings as findings
from ._report import recovery as recovery
from ._report import report_markdown as report_markdown
from ._report import study_summary as study_summary
from ._report import text_output as text_output
from ._stages import JointIDIM as JointIDIM
from ._stages import JointSDP as JointSDP
from ._stages import joint_idim_ls as joint_idim_ls
from ._stages import joint_multi_sdp as joint_multi_sdp
from ._stages import joint_preprocess as joint_preprocess
from ._study import FULL_STAGES as FULL_STAGES
from ._study import PAPER as PAPER
from ._study import STAGES as STAGES
from ._study import TX40Study as TX40Study
from ._study import tx40_study as tx40_study

__all__ = [
    "FIGURE_NAMES",
    "FULL_FIGURE",
    "FULL_STAGES",
    "JointFullModel",
    "JointIDIM",
    "JointSDP",
    "PAPER",
    "STAGES",
    "TX40Study",
    "example_study",
    "fig_full_model",
    "fig_autocorrelation",
    "fig_reconstruction",
    "fig_shapes",
    "findings",
    "joint_idim_ls",
    "joint_multi_sdp",
    "joint_preprocess",
    "recovery",
    "report_markdown",
    "save_tx40_figures",
    "study_summary",
    "text_output",
    "tx40_figures",
    "tx40_study",
]
