"""The EMPS identification study (paper section 2): IDIM-LS, SDP stage, IDIM-SDP, figures, report.

`emps_study` runs the stages in order; each stage is also callable alone:
`emps_preprocess` -> `emps_regression` + `jaxsdp.idim_ls` (Table 1) ->
`emps_sdp_stage` (eq. 13) -> `emps_idim_sdp` (Table 2); `emps_figures` draws
the paper's Figs. 3-5, `simulation_check` simulates the identified model in
closed loop against the data, `report_markdown` writes the report.
"""

from ._figures import (
    FIGURE_NAMES as FIGURE_NAMES,
    emps_figures as emps_figures,
    fig_force_reconstruction as fig_force_reconstruction,
    fig_friction_asym as fig_friction_asym,
    fig_friction_linear as fig_friction_linear,
    fig_sdp_mass as fig_sdp_mass,
    save_emps_figures as save_emps_figures,
)
from ._idim_sdp import EMPSIDIMSDP as EMPSIDIMSDP, emps_idim_sdp as emps_idim_sdp
from ._preprocess import emps_preprocess as emps_preprocess, emps_regression as emps_regression
from ._report import (
    RECOVERY_TOL as RECOVERY_TOL,
    findings as findings,
    recovery as recovery,
    report_markdown as report_markdown,
    text_output as text_output,
)
from ._sdp_stage import EMPSSDPStage as EMPSSDPStage, emps_sdp_stage as emps_sdp_stage
from ._simulation_check import simulation_check as simulation_check
from ._study import EMPSStudy as EMPSStudy, emps_study as emps_study
