"""jaxsdp: differentiable state-dependent parameter identification in JAX.

Every public entry point computes in float64 (it runs under
`jax.enable_x64(True)`); importing jaxsdp does not change global JAX config.
"""

__version__ = "0.1.0"

from ._dlr import DLRResult as DLRResult, dlr as dlr
from ._models import (
    IRW as IRW,
    LLT as LLT,
    RW as RW,
    SRW as SRW,
    Constant as Constant,
    ParameterModel as ParameterModel,
)
from ._nvr import NVRFit as NVRFit, ml_nvr as ml_nvr
from ._derivatives import (
    Derivatives as Derivatives,
    cutoff_from_nvr as cutoff_from_nvr,
    nvr_from_cutoff as nvr_from_cutoff,
    smooth_derivatives as smooth_derivatives,
)
