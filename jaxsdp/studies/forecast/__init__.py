"""The forecast study: a series' dynamic harmonic regression, its forecasts with intervals, a hold-out check.

`forecast_study(y, periods=..., horizon=...)` fits `jaxsdp.tvp.dhr` (a trend
and harmonics of the given periods with time-variable amplitudes, NVRs by
maximum likelihood), forecasts `horizon` samples with intervals, optionally
fits again on all but the last `holdout` samples and scores its forecasts of
them (RMSE, interval coverage, against the seasonal naive forecast), and
tests the one-step prediction errors for whiteness. It returns a
`ForecastStudy`, the back end of `jaxsdp forecast`; `summary`, `report`,
`text` and `figures` of it give `summary.json`, `report.md`, the printed
text and the figures (the study contract, `jaxsdp.studies._contract`), its
`csv()` the command's `forecast.csv`.
"""

from .._contract import figures, report, summary, text
from ._figures import FIGURE_NAMES
from ._study import ForecastStudy, forecast_study

__all__ = [
    "FIGURE_NAMES",
    "ForecastStudy",
    "figures",
    "forecast_study",
    "report",
    "summary",
    "text",
]
