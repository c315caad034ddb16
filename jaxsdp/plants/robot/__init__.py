"""The serial-robot family: rigid-body models, their closed loops, one joint's identification stages; the TX40 as data.

- serial robots from a modified DH table with recursive Newton-Euler
  dynamics (`SerialRobot`, `link_parameters`), their base parameters
  (`base_parameters`), closed-loop simulation (`simulate_robot`) and
  identification through it (`identify_robot_by_simulation`);
- one joint's identification model: the paper's eq. (20) regressors
  (`joint_regressors`, `gravity_basis`, `friction_basis`) and the full
  model's (`joint_model`);
- one joint's identification stages, shared by every robot study:
  `joint_preprocess` -> `joint_idim_ls` -> `joint_multi_sdp` (with its
  `ShapeTest`; `rest_threshold`), the full-model stage (`JointFullModel`),
  and which joints move in a set of logs (`joint_motion`);
- all joints at once: the stacked full model and its base parameters
  (`robot_model`, with the drives' coupling) and IDIM-LS on every joint's
  rows (`robot_idim_ls`); robots from a URDF or a modified DH table
  (`SerialRobot.from_urdf`, `SerialRobot.from_mdh`); exciting Fourier
  trajectories by gradient (`optimise_excitation`); the same IDIM-LS as one
  pure Module (`RobotPipeline`), the robot study's processing options
  (`RobotProcessing`), and the closed-loop experiment that makes
  its records (`RobotExperiment`);
- physically consistent estimates: every link a rigid body through its
  pseudo-inertia (`physical_estimate`, `PhysicalEstimate`, `PhysicalSolver`,
  `pseudo_inertia`), and the identified robot written as a URDF with its
  drives beside it (`write_urdf`);
- friction laws per motor read off the residual (`robot_friction`,
  `RobotFriction`): proposed by BIC, kept where they lower the joint's
  cross-validated error, estimated jointly with the rigid body;
- the Staubli TX40 as data: its six-joint model (`tx40_robot`), gear
  ratios (`TX40_GEAR_RATIOS`) and the link-2 plant of the paper's section
  3.4.1 (`TX40Link2`, `simulate_tx40_link2`).
"""

from ._defaults import RobotProcessing
from ._excitation import Excitation, ExcitationResult, optimise_excitation
from ._friction import RobotFriction, robot_friction
from ._inertia import link_parameters
from ._joint import JointModel, joint_model
from ._joint_full import JointFullModel
from ._joint_model import friction_basis, gravity_basis, joint_regressors
from ._joint_stages import (
    JointIDIM,
    JointSDP,
    ShapeTest,
    joint_idim_ls,
    joint_multi_sdp,
    joint_preprocess,
    rest_threshold,
)
from ._motion import joint_motion
from ._physical import PhysicalEstimate, PhysicalSolver, physical_estimate, pseudo_inertia
from ._pipeline import RobotDiagnosis, RobotExperiment, RobotFit, RobotPipeline
from ._robot_idim import RobotIDIM, robot_idim_ls
from ._serial import BaseParameters, SerialRobot, base_parameters
from ._sim import RobotSimulation, simulate_robot
from ._sim_ident import RobotSimIdentResult, identify_robot_by_simulation, robot_output_error
from ._stacked import RobotModel, robot_model
from ._tx40 import tx40_robot
from ._tx40_link2 import (
    TX40_GEAR_RATIOS,
    TX40_LINK2_REFERENCE,
    PDController,
    TX40Link2,
    TX40Simulation,
    simulate_tx40_link2,
)
from ._urdf_export import write_urdf

__all__ = [
    "TX40_GEAR_RATIOS",
    "TX40_LINK2_REFERENCE",
    "BaseParameters",
    "Excitation",
    "ExcitationResult",
    "JointFullModel",
    "JointIDIM",
    "JointModel",
    "JointSDP",
    "PDController",
    "PhysicalEstimate",
    "PhysicalSolver",
    "RobotDiagnosis",
    "RobotExperiment",
    "RobotFit",
    "RobotFriction",
    "RobotIDIM",
    "RobotModel",
    "RobotPipeline",
    "RobotProcessing",
    "RobotSimIdentResult",
    "RobotSimulation",
    "SerialRobot",
    "ShapeTest",
    "TX40Link2",
    "TX40Simulation",
    "base_parameters",
    "friction_basis",
    "gravity_basis",
    "identify_robot_by_simulation",
    "joint_idim_ls",
    "joint_model",
    "joint_motion",
    "joint_multi_sdp",
    "joint_preprocess",
    "joint_regressors",
    "link_parameters",
    "optimise_excitation",
    "physical_estimate",
    "pseudo_inertia",
    "rest_threshold",
    "robot_friction",
    "robot_idim_ls",
    "robot_model",
    "robot_output_error",
    "simulate_robot",
    "simulate_tx40_link2",
    "tx40_robot",
    "write_urdf",
]
