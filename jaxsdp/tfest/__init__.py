"""Transfer-function estimation: continuous-time models from sampled input-output data.

- `srivc`: the simplified refined instrumental variable method for
  continuous-time models (Young & Jakeman; CAPTAIN's `rivcbj` with white
  noise), with the parameters' standard errors (`SRIVCResult`);
- `c2d`: zero-order-hold discretisation of a continuous transfer function.

Conventions: continuous `num`, `den` highest power of s first, `den` monic;
discrete `B(z^-1)/A(z^-1)` as coefficients of z^0, z^-1, ... The refined
instrumental variable family (RIVCBJ, RIVBJ, SRIV) joins here; `RIVSolver`
holds the family's iteration options. `jaxsdp.control`
re-exports `srivc`, `SRIVCResult` and `c2d` (their former home).
"""

from ._bj import CramerRao, cramer_rao
from ._c2d import c2d
from ._riv import RIVResult, rivbj, rivcbj, sriv
from ._solver import RIVSolver
from ._srivc import SRIVCResult, srivc
from ._structure import StructureSearch, structure_search

__all__ = [
    "CramerRao",
    "RIVResult",
    "RIVSolver",
    "SRIVCResult",
    "c2d",
    "cramer_rao",
    "rivbj",
    "rivcbj",
    "sriv",
    "srivc",
    "StructureSearch",
    "structure_search",
]
