"""jaxsdp: differentiable state-dependent parameter identification in JAX.

The top level is the estimation core and its signal processing and
identification layers; the plants, data sets and studies are subpackages:

- `jaxsdp.plants`: friction laws, references and measurement noise, the EMPS
  and TX40 simulators, the EMPS identification model, identification
  through the simulator;
- `jaxsdp.data`: loaders and built-in data sets;
- `jaxsdp.control`: SDP control design (SDP-PD, SRIVC, PIP-LQ, the PIP-SDP
  cascade) on the EMPS plant;
- `jaxsdp.studies`: one subpackage per study (`jaxsdp.studies.emps`).

Every public entry point computes in float64 (it runs under
`jax.enable_x64(True)`); importing jaxsdp does not change `jax.config`.
Importing jaxsdp before JAX initialises its backend adds one XLA-CPU option
for faster scan loops (documented and measured in `jaxsdp._runtime`; opt out
with `JAXSDP_FAST_LOOPS=0`; `jaxsdp.fast_loops_status()` reports it).
"""

# Must run before anything initialises JAX's CPU backend; see `jaxsdp._runtime`.
from ._runtime import enable_fast_loops as _enable_fast_loops
from ._runtime import fast_loops_status as fast_loops_status
from ._runtime import kernel_method as kernel_method
from ._runtime import resolve_method as resolve_method
from ._runtime import set_kernel_method as set_kernel_method

_enable_fast_loops()

# Saving and reloading results (.npz, or JSON-ready dicts).
# The layers above the core, as subpackages.
from . import control as control
from . import data as data
from . import plants as plants
from . import studies as studies

# Identification: IDIM-LS, IDIM-IV and the parametric SDP stage.
from ._idim.iv import IDIMIVResult as IDIMIVResult
from ._idim.iv import Instruments as Instruments
from ._idim.iv import idim_iv as idim_iv
from ._idim.iv import idim_iv_iterate as idim_iv_iterate
from ._idim.ls import IDIMResult as IDIMResult
from ._idim.ls import ParamEstimate as ParamEstimate
from ._idim.ls import idim_ls as idim_ls
from ._idim.ls import idim_table as idim_table
from ._idim.parametric import parametric_stage as parametric_stage
from ._io import from_dict as from_dict
from ._io import load as load
from ._io import save as save
from ._io import to_dict as to_dict

# Estimation core: Kalman filter/smoother kernels, parameter models, ML NVRs, SDP.
from ._kalman.dlr import DLRResult as DLRResult
from ._kalman.dlr import dlr as dlr
from ._kalman.general import Likelihood as Likelihood
from ._kalman.models import (
    IRW as IRW,
)
from ._kalman.models import (
    LLT as LLT,
)
from ._kalman.models import (
    RW as RW,
)
from ._kalman.models import (
    SRW as SRW,
)
from ._kalman.models import (
    Constant as Constant,
)
from ._kalman.models import (
    ParameterModel as ParameterModel,
)
from ._kalman.nvr import NVRFit as NVRFit
from ._kalman.nvr import dlr_loglik as dlr_loglik
from ._kalman.nvr import ml_nvr as ml_nvr
from ._montecarlo import MonteCarloOutput as MonteCarloOutput
from ._montecarlo import monte_carlo as monte_carlo
from ._sdp.backfit import SDPResult as SDPResult
from ._sdp.backfit import sdp as sdp
from ._sdp.captain import captain_nvrs as captain_nvrs
from ._sdp.multi import MultiSDPResult as MultiSDPResult
from ._sdp.multi import multi_sdp as multi_sdp

# Signal processing: filtering, decimation, derivatives, preprocessing.
from ._signal.butterworth import FilteredDerivatives as FilteredDerivatives
from ._signal.butterworth import butter_derivatives as butter_derivatives
from ._signal.filtering import (
    decimate as decimate,
)
from ._signal.filtering import (
    decimation_filter as decimation_filter,
)
from ._signal.filtering import (
    filtfilt as filtfilt,
)
from ._signal.filtering import (
    lfilter as lfilter,
)
from ._signal.filtering import (
    lfilter_zi as lfilter_zi,
)
from ._signal.preprocess import Preprocessed as Preprocessed
from ._signal.preprocess import preprocess as preprocess
from ._signal.regressors import (
    Regression as Regression,
)
from ._signal.regressors import (
    Regressors as Regressors,
)
from ._signal.regressors import (
    parallel_decimate as parallel_decimate,
)
from ._signal.regressors import (
    regressors as regressors,
)
from ._signal.smoothing import (
    Derivatives as Derivatives,
)
from ._signal.smoothing import (
    cutoff_from_nvr as cutoff_from_nvr,
)
from ._signal.smoothing import (
    nvr_from_cutoff as nvr_from_cutoff,
)
from ._signal.smoothing import (
    smooth_derivatives as smooth_derivatives,
)
from ._signal.whiteness import (
    Whiteness as Whiteness,
)
from ._signal.whiteness import (
    whiteness as whiteness,
)
from ._version import __version__ as __version__

__all__ = [
    "butter_derivatives",
    "captain_nvrs",
    "Constant",
    "cutoff_from_nvr",
    "control",
    "data",
    "decimate",
    "decimation_filter",
    "Derivatives",
    "dlr",
    "dlr_loglik",
    "DLRResult",
    "fast_loops_status",
    "FilteredDerivatives",
    "filtfilt",
    "from_dict",
    "idim_iv",
    "idim_iv_iterate",
    "idim_ls",
    "kernel_method",
    "monte_carlo",
    "MonteCarloOutput",
    "idim_table",
    "IDIMIVResult",
    "IDIMResult",
    "Instruments",
    "IRW",
    "lfilter",
    "lfilter_zi",
    "Likelihood",
    "LLT",
    "load",
    "ml_nvr",
    "multi_sdp",
    "MultiSDPResult",
    "nvr_from_cutoff",
    "NVRFit",
    "parallel_decimate",
    "ParamEstimate",
    "ParameterModel",
    "parametric_stage",
    "plants",
    "preprocess",
    "Preprocessed",
    "Regression",
    "Regressors",
    "regressors",
    "RW",
    "save",
    "resolve_method",
    "sdp",
    "set_kernel_method",
    "SDPResult",
    "smooth_derivatives",
    "SRW",
    "studies",
    "to_dict",
    "Whiteness",
    "whiteness",
]
