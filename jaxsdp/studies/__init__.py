"""Studies: one subpackage per study, each holding its pipeline, figures and report writer.

- `jaxsdp.studies.emps`: the EMPS identification study (paper section 2),
  the back end of `jaxsdp emps`;
- `jaxsdp.studies.control`: the SDP control study (paper section 4), the
  back end of `jaxsdp control`.
"""

from . import control as control
from . import emps as emps

__all__ = [
    "control",
    "emps",
]
