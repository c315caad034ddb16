"""Data: loaders of measurement files and the built-in (simulated, known-truth) data sets."""

from ._emps_builtin import (
    EMPS_BUILTIN_TRUTH as EMPS_BUILTIN_TRUTH,
    emps_builtin_data as emps_builtin_data,
    emps_builtin_reference as emps_builtin_reference,
)
from ._loaders import (
    EMPSData as EMPSData,
    Measurements as Measurements,
    load_emps as load_emps,
    load_measurements as load_measurements,
)
