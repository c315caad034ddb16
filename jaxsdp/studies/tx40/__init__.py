"""The TX40 robot study (paper section 3): one joint's IDIM-LS and multi-SDP from joint logs.

`tx40_study` runs the stages in order; each is also callable alone:
`joint_preprocess` (the EMPS benchmark's processing of one joint) ->
`joint_idim_ls` (eq. 22, residual whiteness) -> `joint_multi_sdp` (section
3.3: gravity and friction SDPs with the inertia fixed, their parametric
projections). `report_markdown` and `text_output` write its report and
tables; `tx40_figures` draws the paper's Figs. 7-11 and the residual
autocorrelation. The back end of `jaxsdp tx40`. The stages live in the
serial-robot family (`jaxsdp.plants.robot`), for every robot study to share;
they are re-exported here.

Options are objects, checked when made: the data (`JointLogs`, or a
built-in experiment `TX40Builtin`), the processing (`jaxsdp.Preprocessing`;
default Butterworth order 4 at 100 Hz, 100 samples dropped, decimation by
10), the multi-SDP (`jaxsdp.MultiBackfitting`) and the full model
(`FullModel`).

Beyond the paper (`tx40_study(..., full_model=FullModel())`, `jaxsdp tx40 --model
full`): the joint is also identified with the full six-joint rigid-body
model's base parameters (`JointFullModel`), the multi-SDP of its residual
follows, and the study measures how much of the one-joint SDP curves'
departure from eq. (20) the coupling explains (`fig_full_model`).

The study recognises the experiment (which joints move, `joint_motion`)
and compares the logs with the paper's matching table
(`choose_reference`, `paper_comparison`: each difference in the paper's
standard deviations); its shape verdict (`ShapeTest`) is re-checked at
neighbouring processing settings.
"""

from ...plants.robot._joint_full import JointFullModel
from ...plants.robot._joint_stages import JointIDIM, JointSDP, joint_idim_ls, joint_multi_sdp, joint_preprocess
from .._contract import figures, report, summary, text
from ._example import example_study
from ._figures import (
    FIGURE_NAMES,
    FULL_FIGURE,
    fig_autocorrelation,
    fig_reconstruction,
    fig_shapes,
    save_tx40_figures,
    tx40_figures,
)
from ._figures_full import fig_full_model
from ._options import CASES, FullModel, TX40Builtin
from ._paper import PAPER, choose_reference, paper_comparison
from ._report import findings, recovery, report_markdown, study_summary, text_output
from ._study import FULL_STAGES, STAGES, TX40Study, tx40_study

__all__ = [
    "CASES",
    "FIGURE_NAMES",
    "FULL_FIGURE",
    "FULL_STAGES",
    "PAPER",
    "STAGES",
    "FullModel",
    "JointFullModel",
    "JointIDIM",
    "JointSDP",
    "TX40Builtin",
    "TX40Study",
    "choose_reference",
    "example_study",
    "fig_autocorrelation",
    "fig_full_model",
    "fig_reconstruction",
    "fig_shapes",
    "figures",
    "findings",
    "joint_idim_ls",
    "joint_multi_sdp",
    "joint_preprocess",
    "paper_comparison",
    "recovery",
    "report",
    "report_markdown",
    "save_tx40_figures",
    "study_summary",
    "summary",
    "text",
    "text_output",
    "tx40_figures",
    "tx40_study",
]
