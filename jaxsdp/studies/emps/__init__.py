"""The EMPS identification study (paper section 2): IDIM-LS, IDIM-IV, SDP stage, IDIM-SDP, figures, report.

`emps_study` runs the stages in order; each stage is also callable alone:
`emps_preprocess` -> `emps_regression` + `jaxsdp.idim_ls` (Table 1) ->
`emps_sdp_stage` (eq. 13) -> `emps_idim_sdp` (Table 2); `emps_idim_iv` is
the instrumental-variable IDIM with instruments from the closed-loop
simulation of the model. `simulation_check` simulates the identified model
in closed loop against the data, `emps_cross_validation` fits IDIM-LS and
IDIM-IV on one half of a record and scores them on the other. `emps_figures` draws the paper's
Figs. 3-5; `report_markdown`, `text_output`, `findings` and `recovery`
(simulated data: estimates against the truth) write the report.

The study contract (`jaxsdp.studies._contract`): `emps_study(data=None, ...)`
returns an `EMPSStudy` holding everything (the simulation check, the
recovery of the built-in plant's truth, warnings, findings, timings,
versions), and `summary`, `report`, `text` and `figures` of it give
`summary.json`, `report.md`, the printed text and the figures of `jaxsdp emps`.

The stages live in the EMPS family (`jaxsdp.plants.emps`), shared with the
control study's friction and the Monte Carlo run; they are re-exported here.
"""

from ...plants.emps._idim_iv import emps_idim_iv
from ...plants.emps._idim_sdp import EMPSIDIMSDP, emps_idim_sdp
from ...plants.emps._preprocess import emps_preprocess, emps_regression
from ...plants.emps._sdp_stage import EMPSSDPStage, emps_sdp_stage
from .._contract import figures, report, summary, text
from ._crossval import EMPSCrossValidation, emps_cross_validation
from ._figures import (
    FIGURE_NAMES,
    emps_figures,
    fig_force_reconstruction,
    fig_friction_asym,
    fig_friction_linear,
    fig_sdp_mass,
    save_emps_figures,
)
from ._report import RECOVERY_TOL, findings, recovery, report_markdown, text_output
from ._simulation_check import simulation_check
from ._study import EMPSStudy, emps_study

__all__ = [
    "EMPSIDIMSDP",
    "FIGURE_NAMES",
    "RECOVERY_TOL",
    "EMPSCrossValidation",
    "EMPSSDPStage",
    "EMPSStudy",
    "emps_cross_validation",
    "emps_figures",
    "emps_idim_iv",
    "emps_idim_sdp",
    "emps_preprocess",
    "emps_regression",
    "emps_sdp_stage",
    "emps_study",
    "fig_force_reconstruction",
    "fig_friction_asym",
    "fig_friction_linear",
    "fig_sdp_mass",
    "figures",
    "findings",
    "recovery",
    "report",
    "report_markdown",
    "save_emps_figures",
    "simulation_check",
    "summary",
    "text",
    "text_output",
]
