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
from ._sdp import SDPResult as SDPResult, sdp as sdp
from ._emps_data import (
    EMPSData as EMPSData,
    Measurements as Measurements,
    load_emps as load_emps,
    load_measurements as load_measurements,
)
from ._filtering import (
    FilteredDerivatives as FilteredDerivatives,
    butter_derivatives as butter_derivatives,
    decimate as decimate,
    decimation_filter as decimation_filter,
    filtfilt as filtfilt,
    lfilter as lfilter,
    lfilter_zi as lfilter_zi,
)
from ._idim import (
    EMPSInputs as EMPSInputs,
    IDIMResult as IDIMResult,
    Regression as Regression,
    Regressors as Regressors,
    emps_asym_regressors as emps_asym_regressors,
    emps_preprocess as emps_preprocess,
    emps_regressors as emps_regressors,
    idim_ls as idim_ls,
    idim_table as idim_table,
    parallel_decimate as parallel_decimate,
    regressors as regressors,
)
from ._parametric import parametric_stage as parametric_stage
from ._multisdp import MultiSDPResult as MultiSDPResult, multi_sdp as multi_sdp
