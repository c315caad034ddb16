"""Data: loaders of measurement files (EMPS records, robot joint logs) and the built-in (simulated,
known-truth) data sets (the EMPS, the TX40 "only link 2 moving" and "all joints moving" experiments), and
the conversion of joint logs to a robot model's convention (`model_convention`)."""

from ._emps_builtin import (
    EMPS_BUILTIN_TRUTH as EMPS_BUILTIN_TRUTH,
)
from ._emps_builtin import (
    emps_builtin_data as emps_builtin_data,
)
from ._emps_builtin import (
    emps_builtin_reference as emps_builtin_reference,
)
from ._joint_logs import (
    JointLogs as JointLogs,
)
from ._joint_logs import (
    load_joint_logs as load_joint_logs,
)
from ._joint_logs import (
    write_joint_logs as write_joint_logs,
)
from ._loaders import (
    EMPSData as EMPSData,
)
from ._loaders import (
    IrregularSamplingError as IrregularSamplingError,
)
from ._loaders import (
    Measurements as Measurements,
)
from ._loaders import (
    load_emps as load_emps,
)
from ._loaders import (
    load_measurements as load_measurements,
)
from ._model_convention import (
    TX40_JOINT_OFFSETS as TX40_JOINT_OFFSETS,
)
from ._model_convention import (
    TX40_WRIST_COUPLING as TX40_WRIST_COUPLING,
)
from ._model_convention import (
    model_convention as model_convention,
)
from ._tx40_all_joints import (
    tx40_all_joints_data as tx40_all_joints_data,
)
from ._tx40_builtin import (
    TX40_BUILTIN_TRUTH as TX40_BUILTIN_TRUTH,
)
from ._tx40_builtin import (
    TX40Builtin as TX40Builtin,
)
from ._tx40_builtin import (
    tx40_builtin_data as tx40_builtin_data,
)
from ._tx40_builtin import (
    tx40_builtin_reference as tx40_builtin_reference,
)

__all__ = [
    "EMPSData",
    "EMPS_BUILTIN_TRUTH",
    "IrregularSamplingError",
    "JointLogs",
    "Measurements",
    "TX40Builtin",
    "TX40_BUILTIN_TRUTH",
    "TX40_JOINT_OFFSETS",
    "TX40_WRIST_COUPLING",
    "emps_builtin_data",
    "emps_builtin_reference",
    "load_emps",
    "load_joint_logs",
    "load_measurements",
    "model_convention",
    "tx40_all_joints_data",
    "tx40_builtin_data",
    "tx40_builtin_reference",
    "write_joint_logs",
]
