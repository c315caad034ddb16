"""The time-variable parameter family on the Kalman filter and smoother (the toolbox's unobserved components
and time-variable models).

- `dhr`: dynamic harmonic regression, a trend and harmonics of given
  periods with time-variable amplitudes, NVRs by maximum likelihood
  (`DHRResult`: trend, cycles, seasonal, seasonally adjusted series,
  forecast); with no periods, the trend smoother alone;
- `dlr_forecast`: forecasts and interpolation over gaps of a dynamic
  linear regression (`jaxsdp.dlr`'s model), with intervals;
- `Forecast`: a series' estimate over its samples, gaps and horizon, its
  standard errors, intervals and figure;
- `dar`, `darx`: dynamic AR and ARX models, coefficients as random walks
  (`DARResult`), and `darsp`, their time-frequency spectrum (`Spectrum`);
- `dtfm`: time-variable transfer functions, coefficients as random walks
  estimated by refined instrumental variables (`DTFMResult`);
- `trend`: the trend alone (the IRW smoother), its NVR by maximum
  likelihood or from a cut-off period (`irw_nvr`);
- `univ`: a trend plus AR(p) perturbations, the NVR(s) and AR
  coefficients by maximum likelihood (`UnivResult`);
- `harmonic_regressors`: the DHR's regressors, for `jaxsdp.dlr` users.

Conventions: time in samples (a period of 12 samples is a monthly series'
year), sample k = 0 the first; NVRs as in `jaxsdp.dlr`.
"""

from ._dar import DARResult, Spectrum, dar, darsp, darx
from ._dhr import DHRResult, dhr, harmonic_regressors
from ._dtfm import DTFMResult, dtfm
from ._forecast import Forecast, dlr_forecast
from ._trend import irw_nvr, trend
from ._univ import UnivResult, univ

__all__ = [
    "DARResult",
    "DHRResult",
    "DTFMResult",
    "Forecast",
    "Spectrum",
    "UnivResult",
    "dar",
    "darsp",
    "darx",
    "dhr",
    "dtfm",
    "dlr_forecast",
    "harmonic_regressors",
    "irw_nvr",
    "trend",
    "univ",
]
