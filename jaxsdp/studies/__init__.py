"""Studies: one subpackage per study, each holding its pipeline, figures and report writer.

- `jaxsdp.studies.emps`: the EMPS identification study (paper section 2),
  the back end of `jaxsdp emps`.
"""

from . import emps as emps

__all__ = [
    "emps",
]
