"""jaxsdp: differentiable state-dependent parameter identification in JAX.

The top level is the estimation core and its signal processing and
identification layers; the plants, data sets and studies are subpackages:

- `jaxsdp.plants`: friction laws, references and measurement noise, the EMPS
  and TX40 simulators, the EMPS identification model, identification
  through the simulator;
- `jaxsdp.data`: loaders and built-in data sets;
- `jaxsdp.studies`: one subpackage per study (`jaxsdp.studies.emps`).

Every public entry point computes in float64 (it runs under
`jax.enable_x64(True)`); importing jaxsdp does not change `jax.config`.
Importing jaxsdp before JAX initialises its backend adds one XLA-CPU option
that makes scan loops much faster (documented in `jaxsdp._runtime`; opt out
with `JAXSDP_FAST_LOOPS=0`; `jaxsdp.fast_loops_status()` reports it).
"""

# Must run before anything initialises JAX's CPU backend; see `jaxsdp._runtime`.
from ._runtime import enable_fast_loops as _enable_fast_loops, fast_loops_status as fast_loops_status

_enable_fast_loops()

from ._version import __version__ as __version__

# Estimation core: Kalman filter/smoother kernels, parameter models, ML NVRs, SDP.
from ._kalman.dlr import DLRResult as DLRResult, dlr as dlr
from ._kalman.general import Likelihood as Likelihood
from ._kalman.models import (
    IRW as IRW,
    LLT as LLT,
    RW as RW,
    SRW as SRW,
    Constant as Constant,
    ParameterModel as ParameterModel,
)
from ._kalman.nvr import NVRFit as NVRFit, dlr_loglik as dlr_loglik, ml_nvr as ml_nvr
from ._sdp.backfit import SDPResult as SDPResult, sdp as sdp
from ._sdp.captain import captain_nvrs as captain_nvrs
from ._sdp.multi import MultiSDPResult as MultiSDPResult, multi_sdp as multi_sdp

# Signal processing: filtering, decimation, derivatives, preprocessing.
from ._signal.butterworth import FilteredDerivatives as FilteredDerivatives, butter_derivatives as butter_derivatives
from ._signal.filtering import (
    decimate as decimate,
    decimation_filter as decimation_filter,
    filtfilt as filtfilt,
    lfilter as lfilter,
    lfilter_zi as lfilter_zi,
)
from ._signal.preprocess import Preprocessed as Preprocessed, preprocess as preprocess
from ._signal.regressors import (
    Regression as Regression,
    Regressors as Regressors,
    parallel_decimate as parallel_decimate,
    regressors as regressors,
)
from ._signal.smoothing import (
    Derivatives as Derivatives,
    cutoff_from_nvr as cutoff_from_nvr,
    nvr_from_cutoff as nvr_from_cutoff,
    smooth_derivatives as smooth_derivatives,
)

# Identification: IDIM-LS and the parametric SDP stage.
from ._idim.ls import IDIMResult as IDIMResult, idim_ls as idim_ls, idim_table as idim_table
from ._idim.parametric import parametric_stage as parametric_stage

# The layers above the core, as subpackages.
from . import data as data, plants as plants, studies as studies
