"""Data: loaders of measurement files and the built-in (simulated, known-truth) data sets."""

from ._emps_builtin import (
    EMPS_BUILTIN_TRUTH as EMPS_BUILTIN_TRUTH,
)
from ._emps_builtin import (
    emps_builtin_data as emps_builtin_data,
)
from ._emps_builtin import (
    emps_builtin_reference as emps_builtin_reference,
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

__all__ = [
    "EMPSData",
    "EMPS_BUILTIN_TRUTH",
    "IrregularSamplingError",
    "Measurements",
    "emps_builtin_data",
    "emps_builtin_reference",
    "load_emps",
    "load_measurements",
]
