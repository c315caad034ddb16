"""The EMPS identification study (paper section 2): IDIM-LS, SDP stage, IDIM-SDP, figures, report.

`emps_study` runs the stages in order; each stage is also callable alone:
`emps_preprocess` -> `emps_regression` + `jaxsdp.idim_ls` (Table 1) ->
`emps_sdp_stage` (eq. 13) -> `emps_idim_sdp` (Table 2); `emps_idim_iv` the
instrumental-variable IDIM with instruments from the closed-loop simulation of
the model; `emps_figures` draws
the paper's Figs. 3-5, `simulation_check` simulates the identified model in
closed loop against the data, `report_markdown` writes the report.
"""

from ._crossval import EMPSCrossValidation as EMPSCrossValidation
from ._crossval import emps_cross_validation as emps_cross_validation
from ._figures import (
    FIGURE_NAMES as FIGURE_NAMES,
)
from ._figures import (
    emps_figures as emps_figures,
)
from ._figures import (
    fig_force_reconstruction as fig_force_reconstruction,
)
from ._figures import (
    fig_friction_asym as fig_friction_asym,
)
from ._figures import (
    fig_friction_linear as fig_friction_linear,
)
from ._figures import (
    fig_sdp_mass as fig_sdp_mass,
)
from ._figures import (
    save_emps_figures as save_emps_figures,
)
from ._idim_iv import emps_idim_iv as emps_idim_iv
from ._idim_sdp import EMPSIDIMSDP as EMPSIDIMSDP
from ._idim_sdp import emps_idim_sdp as emps_idim_sdp
from ._preprocess import emps_preprocess as emps_preprocess
from ._preprocess import emps_regression as emps_regression
from ._report import (
    RECOVERY_TOL as RECOVERY_TOL,
)
from ._report import (
    findings as findings,
)
from ._report import (
    recovery as recovery,
)
from ._report import (
    report_markdown as report_markdown,
)
from ._report import (
    text_output as text_output,
)
from ._sdp_stage import EMPSSDPStage as EMPSSDPStage
from ._sdp_stage import emps_sdp_stage as emps_sdp_stage
from ._simulation_check import simulation_check as simulation_check
from ._study import EMPSStudy as EMPSStudy
from ._study import emps_study as emps_study

__all__ = [
    "EMPSCrossValidation",
    "EMPSIDIMSDP",
    "EMPSSDPStage",
    "EMPSStudy",
    "FIGURE_NAMES",
    "RECOVERY_TOL",
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
    "findings",
    "recovery",
    "report_markdown",
    "save_emps_figures",
    "simulation_check",
    "text_output",
]
