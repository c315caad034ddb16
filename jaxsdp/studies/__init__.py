"""Studies: one subpackage per study, each holding its pipeline, figures and report writer.

- `jaxsdp.studies.emps`: the EMPS identification study (paper section 2),
  the back end of `jaxsdp emps`;
- `jaxsdp.studies.control`: the SDP control study (paper section 4), the
  back end of `jaxsdp control`;
- `jaxsdp.studies.tx40`: the TX40 robot study (paper section 3), the back
  end of `jaxsdp tx40`;
- `jaxsdp.studies.montecarlo`: Monte Carlo robustness studies (control
  robustness of the SDP controllers so far).
"""

from . import control as control
from . import emps as emps
from . import montecarlo as montecarlo
from . import tx40 as tx40

__all__ = [
    "control",
    "emps",
    "montecarlo",
    "tx40",
]
