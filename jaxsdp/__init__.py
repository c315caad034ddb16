"""jaxsdp: differentiable state-dependent parameter identification in JAX.

The top level holds the estimation core (dynamic linear regression `dlr`,
ML noise variance ratios `ml_nvr`, SDP back-fitting `sdp` and `multi_sdp`),
the signal processing (filters, decimation, derivatives, `preprocess`,
`regressors`, `whiteness`) and identification (`idim_ls`, `idim_iv`,
`parametric_stage`) layers, the Monte Carlo runner `monte_carlo`, saving
and loading results, and the kernel settings. The layers above it are
subpackages:

- `jaxsdp.tfest`: continuous-time transfer-function estimation (SRIVC,
  `c2d`), beside IDIM in the identification layer;
- `jaxsdp.plants`: friction laws, references and measurement noise, and one
  folder per plant family: `plants.emps` (the EMPS axis, its benchmark
  controller, inverse dynamic model and identification stages) and
  `plants.robot` (serial robots: modified DH, Newton-Euler, base
  parameters, one joint's identification stages; the TX40 as data);
- `jaxsdp.data`: loaders of EMPS records and robot joint logs, the built-in
  (simulated, known-truth) data sets;
- `jaxsdp.control`: SDP control design on the EMPS plant (SDP-PD, PIP-LQ,
  the PIP-SDP cascade) and the designs on the nominal model that the
  studies share (`identify_friction`, `nominal_design`);
- `jaxsdp.studies`: one subpackage per study (`emps`, `control`, `tx40`,
  `montecarlo`), the back ends of the `jaxsdp` command.

Every public entry point computes in float64 (it runs under
`jax.enable_x64(True)`); importing jaxsdp does not change `jax.config`. With
JAX's 64-bit mode off, results come back as float64 NumPy arrays, and a call
inside the caller's own `jax.jit`/`grad`/`vmap` raises `Float64Error`, naming
the line that enables the mode: `jax.config.update("jax_enable_x64", True)`.
Importing jaxsdp before JAX initialises its backend adds one XLA-CPU option
for faster scan loops (documented and measured in `jaxsdp._runtime`; opt out
with `JAXSDP_FAST_LOOPS=0`; `jaxsdp.fast_loops_status()` reports it).

The names below are re-exported from the private modules that define them,
grouped per module; `__all__` lists them (`tests/test_docs.py` checks it
against the imports).
"""

# Must run before anything initialises JAX's CPU backend; see `jaxsdp._runtime`.
from ._runtime import Float64Error, Float64Warning, fast_loops_status, kernel_method, resolve_method, set_kernel_method
from ._runtime import enable_fast_loops as _enable_fast_loops

_enable_fast_loops()

# The layers above the core, as subpackages.
from . import control, data, plants, studies, tfest, tvp

# Identification: IDIM-LS, IDIM-IV and the parametric SDP stage.
from ._idim.estimators import IDIMIV, IDIMLS, IID, IVFit, NeweyWest
from ._idim.iv import IDIMIVResult, Instruments, idim_iv, idim_iv_iterate
from ._idim.ls import IDIMResult, ParamEstimate, idim_ls, idim_table
from ._idim.parametric import parametric_stage

# Saving and reloading results (.npz, or JSON-ready dicts).
from ._io import from_dict, load, save, to_dict

# Estimation core: Kalman filter/smoother kernels, parameter models, ML NVRs.
from ._kalman.dlr import DLRResult, dlr
from ._kalman.general import Likelihood
from ._kalman.models import IRW, LLT, RW, SRW, Constant, ParameterModel
from ._kalman.nvr import NVRFit, dlr_loglik, ml_nvr

# Monte Carlo runner: vectorised, chunked, sharded over devices and hosts.
from ._montecarlo import MonteCarloOutput, monte_carlo

# Estimation core: SDP back-fitting, multi-SDP, CAPTAIN-style NVR search.
from ._sdp.backfit import SDPResult, sdp
from ._sdp.captain import captain_nvrs
from ._sdp.multi import MultiBackfitting, MultiSDPResult, multi_sdp
from ._sdp.options import MLNVR, Backfitting, CaptainNVR, FixedNVR

# Signal processing: filtering, decimation, derivatives, preprocessing, whiteness.
from ._signal.butterworth import FilteredDerivatives, butter_derivatives
from ._signal.filtering import decimate, decimation_filter, filtfilt, lfilter, lfilter_zi
from ._signal.preprocess import Butterworth, Preprocessed, Preprocessing, Smoothing, preprocess
from ._signal.regressors import Regression, Regressors, parallel_decimate, regressors
from ._signal.smoothing import Derivatives, cutoff_from_nvr, nvr_from_cutoff, smooth_derivatives
from ._signal.whiteness import Whiteness, whiteness
from ._version import __version__ as __version__

__all__ = [
    "IDIMIV",
    "IDIMLS",
    "IID",
    "IRW",
    "IVFit",
    "MLNVR",
    "Backfitting",
    "MultiBackfitting",
    "Butterworth",
    "FixedNVR",
    "CaptainNVR",
    "NeweyWest",
    "Preprocessing",
    "Smoothing",
    "LLT",
    "RW",
    "SRW",
    "Constant",
    "DLRResult",
    "Derivatives",
    "FilteredDerivatives",
    "Float64Error",
    "Float64Warning",
    "IDIMIVResult",
    "IDIMResult",
    "Instruments",
    "Likelihood",
    "MonteCarloOutput",
    "MultiSDPResult",
    "NVRFit",
    "ParamEstimate",
    "ParameterModel",
    "Preprocessed",
    "Regression",
    "Regressors",
    "SDPResult",
    "Whiteness",
    "butter_derivatives",
    "captain_nvrs",
    "control",
    "cutoff_from_nvr",
    "data",
    "decimate",
    "decimation_filter",
    "dlr",
    "dlr_loglik",
    "fast_loops_status",
    "filtfilt",
    "from_dict",
    "idim_iv",
    "idim_iv_iterate",
    "idim_ls",
    "idim_table",
    "kernel_method",
    "lfilter",
    "lfilter_zi",
    "load",
    "ml_nvr",
    "monte_carlo",
    "multi_sdp",
    "nvr_from_cutoff",
    "parallel_decimate",
    "parametric_stage",
    "plants",
    "preprocess",
    "regressors",
    "resolve_method",
    "save",
    "sdp",
    "set_kernel_method",
    "smooth_derivatives",
    "studies",
    "tfest",
    "tvp",
    "to_dict",
    "whiteness",
]
