"""Data: loaders of measurement files (EMPS records, robot joint logs as CSV/.mat files or ROS bags) and the
built-in (simulated, known-truth) data sets (the EMPS, the TX40 "only link 2 moving" and "all joints moving"
experiments), and the conversion of joint logs to a robot model's convention (`model_convention`; in general, with any
robot's drives described as data: `Drives`, from a TOML file or built in)."""

from ._bags import load_joint_bag
from ._drives import Drives
from ._emps_builtin import EMPS_BUILTIN_TRUTH, emps_builtin_data, emps_builtin_reference
from ._joint_logs import JointLogs, load_joint_logs, write_joint_logs
from ._loaders import EMPSData, IrregularSamplingError, Measurements, load_emps, load_measurements, load_record
from ._model_convention import TX40_JOINT_OFFSETS, TX40_WRIST_COUPLING, model_convention
from ._tx40_all_joints import tx40_all_joints_data
from ._tx40_builtin import TX40_BUILTIN_TRUTH, TX40Builtin, tx40_builtin_data, tx40_builtin_reference

__all__ = [
    "EMPS_BUILTIN_TRUTH",
    "TX40_BUILTIN_TRUTH",
    "TX40_JOINT_OFFSETS",
    "TX40_WRIST_COUPLING",
    "Drives",
    "EMPSData",
    "IrregularSamplingError",
    "JointLogs",
    "Measurements",
    "TX40Builtin",
    "emps_builtin_data",
    "emps_builtin_reference",
    "load_emps",
    "load_joint_bag",
    "load_joint_logs",
    "load_measurements",
    "load_record",
    "model_convention",
    "tx40_all_joints_data",
    "tx40_builtin_data",
    "tx40_builtin_reference",
    "write_joint_logs",
]
