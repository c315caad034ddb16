"""Plants: friction laws, references and measurement noise, closed-loop simulators, identification models.

- friction laws (`LinearFriction`, `AsymmetricFriction`, `TabulatedFriction`),
  integrated exactly through stick-slip by the simulators;
- references and measurement (`bang_bang_reference`, `quintic_reference`,
  `step_reference`, `white_noise`, `quantise`, `measure`);
- the EMPS linear axis with its benchmark controller (`simulate_emps`), its
  inverse dynamic model (`emps_regressors`, `emps_asym_regressors`) and
  identification through the simulator (`identify_emps_by_simulation`);
- the TX40 robot's link 2 under PD control (`simulate_tx40_link2`) and the
  one-joint identification model (`joint_regressors`, `gravity_basis`,
  `friction_basis`);
- serial robots from a modified DH table with recursive Newton-Euler
  dynamics (`SerialRobot`, `tx40_robot`, `link_parameters`), their
  identification regressor and base parameters (`base_parameters`), one
  joint's full-model regressor (`joint_model`).
"""

from ._emps import (
    EMPS_IDIM_LS as EMPS_IDIM_LS,
)
from ._emps import (
    EMPSController as EMPSController,
)
from ._emps import (
    EMPSPlant as EMPSPlant,
)
from ._emps import (
    EMPSSimulation as EMPSSimulation,
)
from ._emps import (
    simulate_emps as simulate_emps,
)
from ._emps_model import (
    asym_friction as asym_friction,
)
from ._emps_model import (
    asym_friction_basis as asym_friction_basis,
)
from ._emps_model import (
    emps_asym_regressors as emps_asym_regressors,
)
from ._emps_model import (
    emps_regressors as emps_regressors,
)
from ._friction import (
    AbstractFriction as AbstractFriction,
)
from ._friction import (
    AsymmetricFriction as AsymmetricFriction,
)
from ._friction import (
    LinearFriction as LinearFriction,
)
from ._friction import (
    TabulatedFriction as TabulatedFriction,
)
from ._robot import (
    BaseParameters as BaseParameters,
)
from ._robot import (
    SerialRobot as SerialRobot,
)
from ._robot import (
    base_parameters as base_parameters,
)
from ._robot import (
    link_parameters as link_parameters,
)
from ._robot_joint import (
    JointModel as JointModel,
)
from ._robot_joint import (
    joint_model as joint_model,
)
from ._robot_sim import (
    RobotSimulation as RobotSimulation,
)
from ._robot_sim import (
    simulate_robot as simulate_robot,
)
from ._robot_sim_ident import (
    RobotSimIdentResult as RobotSimIdentResult,
)
from ._robot_sim_ident import (
    identify_robot_by_simulation as identify_robot_by_simulation,
)
from ._robot_sim_ident import (
    robot_output_error as robot_output_error,
)
from ._sim_ident import (
    SimIdentResult as SimIdentResult,
)
from ._sim_ident import (
    default_parameters as default_parameters,
)
from ._sim_ident import (
    identify_emps_by_simulation as identify_emps_by_simulation,
)
from ._trajectories import (
    Trajectory as Trajectory,
)
from ._trajectories import (
    bang_bang_reference as bang_bang_reference,
)
from ._trajectories import (
    encoder_quantum as encoder_quantum,
)
from ._trajectories import (
    measure as measure,
)
from ._trajectories import (
    quantise as quantise,
)
from ._trajectories import (
    quintic_reference as quintic_reference,
)
from ._trajectories import (
    step_reference as step_reference,
)
from ._trajectories import (
    white_noise as white_noise,
)
from ._tx40 import (
    TX40_GEAR_RATIOS as TX40_GEAR_RATIOS,
)
from ._tx40 import (
    TX40_LINK2_REFERENCE as TX40_LINK2_REFERENCE,
)
from ._tx40 import (
    PDController as PDController,
)
from ._tx40 import (
    TX40Link2 as TX40Link2,
)
from ._tx40 import (
    TX40Simulation as TX40Simulation,
)
from ._tx40 import (
    friction_basis as friction_basis,
)
from ._tx40 import (
    gravity_basis as gravity_basis,
)
from ._tx40 import (
    joint_regressors as joint_regressors,
)
from ._tx40 import (
    simulate_tx40_link2 as simulate_tx40_link2,
)
from ._tx40_robot import (
    tx40_robot as tx40_robot,
)

__all__ = [
    "AbstractFriction",
    "AsymmetricFriction",
    "BaseParameters",
    "EMPSController",
    "EMPSPlant",
    "EMPSSimulation",
    "EMPS_IDIM_LS",
    "LinearFriction",
    "PDController",
    "JointModel",
    "RobotSimIdentResult",
    "RobotSimulation",
    "SerialRobot",
    "SimIdentResult",
    "TX40Link2",
    "TX40Simulation",
    "TX40_GEAR_RATIOS",
    "TX40_LINK2_REFERENCE",
    "TabulatedFriction",
    "Trajectory",
    "asym_friction",
    "asym_friction_basis",
    "bang_bang_reference",
    "base_parameters",
    "default_parameters",
    "emps_asym_regressors",
    "emps_regressors",
    "encoder_quantum",
    "friction_basis",
    "gravity_basis",
    "identify_emps_by_simulation",
    "joint_regressors",
    "identify_robot_by_simulation",
    "joint_model",
    "link_parameters",
    "measure",
    "quantise",
    "quintic_reference",
    "simulate_emps",
    "robot_output_error",
    "simulate_robot",
    "simulate_tx40_link2",
    "step_reference",
    "tx40_robot",
    "white_noise",
]
