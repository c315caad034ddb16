"""Plants: friction laws, references and measurement noise, closed-loop simulators, identification models.

- friction laws (`LinearFriction`, `AsymmetricFriction`, `TabulatedFriction`),
  integrated exactly through stick-slip by the simulators; and the laws a
  joint's friction curve is read by (`ViscousCoulomb`, `AsymmetricCoulomb`,
  `SmoothCoulomb`, `Stribeck`), estimated jointly with the linear parameters
  (`fit_friction`), chosen by BIC (`select_friction`) and cross-validated
  (`cross_validate_friction`);
- references and measurement (`bang_bang_reference`, `quintic_reference`,
  `step_reference`, `white_noise`, `quantise`, `measure`);
- `plants.emps`, the EMPS family: the linear axis with its benchmark controller (`simulate_emps`), its
  inverse dynamic model (`emps_regressors`, `emps_asym_regressors`) and
  identification through the simulator (`identify_emps_by_simulation`, its solver options `OutputError`);
- `plants.robot`, the serial-robot family: the TX40 robot's link 2 under PD control (`simulate_tx40_link2`) and the
  one-joint identification model (`joint_regressors`, `gravity_basis`,
  `friction_basis`);
- serial robots from a modified DH table with recursive Newton-Euler
  dynamics (`SerialRobot`, `tx40_robot`, `link_parameters`), their
  identification regressor and base parameters (`base_parameters`), one
  joint's full-model regressor (`joint_model`).
"""

from . import emps, robot
from ._friction import AbstractFriction, AsymmetricFriction, LinearFriction, TabulatedFriction
from ._friction_laws import (
    AsymmetricCoulomb,
    FrictionFit,
    FrictionLaw,
    SmoothCoulomb,
    Stribeck,
    ViscousCoulomb,
    cross_validate_friction,
    fit_friction,
    select_friction,
)
from ._output_error import OutputError
from ._trajectories import (
    Trajectory,
    bang_bang_reference,
    encoder_quantum,
    measure,
    quantise,
    quintic_reference,
    step_reference,
    white_noise,
)
from .emps import (
    EMPS_ASYM_NAMES,
    EMPS_DROP,
    EMPS_IDIM_LS,
    EMPS_LINEAR_NAMES,
    EMPSController,
    EMPSInitial,
    EMPSPlant,
    EMPSSimulation,
    SimIdentResult,
    asym_friction,
    asym_friction_basis,
    default_parameters,
    emps_asym_regressors,
    emps_regression,
    emps_regressors,
    identify_emps_by_simulation,
    simulate_emps,
)
from .robot import (
    TX40_GEAR_RATIOS,
    TX40_LINK2_REFERENCE,
    BaseParameters,
    JointModel,
    PDController,
    RobotSimIdentResult,
    RobotSimulation,
    SerialRobot,
    TX40Link2,
    TX40Simulation,
    base_parameters,
    friction_basis,
    gravity_basis,
    identify_robot_by_simulation,
    joint_model,
    joint_regressors,
    link_parameters,
    robot_output_error,
    simulate_robot,
    simulate_tx40_link2,
    tx40_robot,
)

__all__ = [
    "EMPS_ASYM_NAMES",
    "EMPS_DROP",
    "EMPS_IDIM_LS",
    "EMPS_LINEAR_NAMES",
    "TX40_GEAR_RATIOS",
    "TX40_LINK2_REFERENCE",
    "AbstractFriction",
    "AsymmetricCoulomb",
    "AsymmetricFriction",
    "BaseParameters",
    "EMPSController",
    "EMPSInitial",
    "EMPSPlant",
    "EMPSSimulation",
    "FrictionFit",
    "FrictionLaw",
    "JointModel",
    "LinearFriction",
    "OutputError",
    "PDController",
    "RobotSimIdentResult",
    "RobotSimulation",
    "SerialRobot",
    "SimIdentResult",
    "SmoothCoulomb",
    "Stribeck",
    "TX40Link2",
    "TX40Simulation",
    "TabulatedFriction",
    "Trajectory",
    "ViscousCoulomb",
    "asym_friction",
    "asym_friction_basis",
    "bang_bang_reference",
    "cross_validate_friction",
    "base_parameters",
    "default_parameters",
    "emps",
    "emps_asym_regressors",
    "emps_regression",
    "emps_regressors",
    "encoder_quantum",
    "fit_friction",
    "friction_basis",
    "gravity_basis",
    "identify_emps_by_simulation",
    "identify_robot_by_simulation",
    "joint_model",
    "joint_regressors",
    "link_parameters",
    "measure",
    "quantise",
    "quintic_reference",
    "robot",
    "robot_output_error",
    "select_friction",
    "simulate_emps",
    "simulate_robot",
    "simulate_tx40_link2",
    "step_reference",
    "tx40_robot",
    "white_noise",
]
