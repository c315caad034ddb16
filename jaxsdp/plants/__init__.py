"""Plants: friction laws, references and measurement noise, closed-loop simulators, identification models.

- friction laws (`LinearFriction`, `AsymmetricFriction`, `TabulatedFriction`),
  integrated exactly through stick-slip by the simulators;
- references and measurement (`bang_bang_reference`, `quintic_reference`,
  `step_reference`, `white_noise`, `quantise`, `measure`);
- the EMPS linear axis with its benchmark controller (`simulate_emps`), its
  inverse dynamic model (`emps_regressors`, `emps_asym_regressors`) and
  identification through the simulator (`identify_emps_by_simulation`);
- the TX40 robot's link 2 under PD control (`simulate_tx40_link2`).
"""

from ._emps import (
    EMPS_IDIM_LS as EMPS_IDIM_LS,
    EMPSController as EMPSController,
    EMPSPlant as EMPSPlant,
    EMPSSimulation as EMPSSimulation,
    simulate_emps as simulate_emps,
)
from ._emps_model import (
    asym_friction as asym_friction,
    asym_friction_basis as asym_friction_basis,
    emps_asym_regressors as emps_asym_regressors,
    emps_regressors as emps_regressors,
)
from ._friction import (
    AbstractFriction as AbstractFriction,
    AsymmetricFriction as AsymmetricFriction,
    LinearFriction as LinearFriction,
    TabulatedFriction as TabulatedFriction,
)
from ._sim_ident import (
    SimIdentResult as SimIdentResult,
    default_parameters as default_parameters,
    identify_emps_by_simulation as identify_emps_by_simulation,
)
from ._trajectories import (
    Trajectory as Trajectory,
    bang_bang_reference as bang_bang_reference,
    encoder_quantum as encoder_quantum,
    measure as measure,
    quantise as quantise,
    quintic_reference as quintic_reference,
    step_reference as step_reference,
    white_noise as white_noise,
)
from ._tx40 import (
    TX40_LINK2_REFERENCE as TX40_LINK2_REFERENCE,
    PDController as PDController,
    TX40Link2 as TX40Link2,
    TX40Simulation as TX40Simulation,
    simulate_tx40_link2 as simulate_tx40_link2,
)
