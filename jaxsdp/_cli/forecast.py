"""`jaxsdp forecast`: forecast a series of a CSV file with a dynamic harmonic regression, with intervals.

1. the series: one column of `--data` (`--column`, or the only numeric column), missing values (empty, NA, NaN)
   kept as missing samples, its time column (`--time-column`, or one named t, time, date, ... or holding ISO
   dates) checked regular;
2. `jaxsdp.studies.forecast.forecast_study`: the DHR (`jaxsdp.tvp.dhr`: a `--trend` and harmonics of
   `--periods`, NVRs by maximum likelihood or `--nvr`), `--horizon` samples forecast with `--level` intervals,
   the last `--holdout` samples forecast from the others and scored, the one-step errors' whiteness;
3. prints the model and the first forecasts, writes `report.md`, `summary.json`, `forecast.csv` and the figures.

Every option is checked, and the file read and checked against them, before any fit.
"""

import argparse
import math
import pathlib

from .._kalman.models import as_model
from ..data._series import read_series
from ..studies.forecast._study import check_options, forecast_study
from .common import CLIError, data_file, fraction, int_at_least, positive_float, run_study

NAME = "forecast"
DEFAULT_OUT = "jaxsdp-forecast-out"
TRENDS = ("IRW", "LLT", "RW")
LABELS = {
    "load": "Reading the series",
    "holdout": "Hold-out fit: all but the last --holdout samples",
    "fit": "DHR fit and forecast",
    "diagnostics": "One-step prediction errors",
    "figures": "Figures",
    "report": "Writing report.md, summary.json and forecast.csv",
}


def _period(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a period in samples, a number >= 2; got {text!r}") from None
    if not (math.isfinite(v) and v >= 2.0):
        raise argparse.ArgumentTypeError(
            f"must be a period in samples, a number >= 2 (a shorter one aliases onto a longer one); got {text!r}"
        )
    return v


def add_parser(sub) -> None:
    """Register the `forecast` subcommand on the subparsers `sub`."""
    p = sub.add_parser(
        NAME,
        help="forecast a series (CSV) with a dynamic harmonic regression: intervals, hold-out check, decomposition",
        description=(
            "Forecast one series of a CSV file with a dynamic harmonic regression (a trend and harmonics of the "
            "given periods with time-variable amplitudes, NVRs by maximum likelihood): forecasts with intervals, "
            "an optional hold-out check of them against the last samples, the decomposition and the one-step "
            "errors' whiteness. Writes report.md, summary.json, forecast.csv and the figures to --out."
        ),
        epilog="Example: jaxsdp forecast --data co2.csv --periods 12 6 4 3 2.4 2 --horizon 24 --holdout 24",
    )
    p.add_argument("--data", metavar="FILE", required=True, help="CSV file with a header, one row per sample")
    p.add_argument(
        "--column",
        metavar="NAME",
        default=None,
        help="the series' column (default: the only numeric column besides the time column)",
    )
    p.add_argument(
        "--time-column",
        metavar="NAME",
        default=None,
        help="the time column: numbers, ISO 8601 dates or YYYYMMDD dates on a regular step (default: a column "
        "named t, time or date, an increasing year or month column, or one holding ISO dates; none: the samples "
        "are numbered)",
    )
    p.add_argument(
        "--dt",
        metavar="STEP",
        type=positive_float,
        default=None,
        help="the sampling step, when the file has no time column (labels the forecasts' times)",
    )
    p.add_argument(
        "--periods",
        metavar="P",
        nargs="+",
        type=_period,
        required=True,
        help="the harmonics' periods in samples, each >= 2 (a monthly series' year and its harmonics: 12 6 4 3 2.4 2)",
    )
    p.add_argument("--horizon", metavar="H", type=int_at_least(0), required=True, help="samples to forecast")
    p.add_argument(
        "--holdout",
        metavar="K",
        type=int_at_least(0),
        default=0,
        help="also fit all but the last K samples and score its forecasts of them: RMSE, interval coverage, "
        "against the seasonal naive forecast (default: 0, none)",
    )
    p.add_argument("--trend", choices=TRENDS, default="IRW", help="the trend model (default: IRW, a smooth trend)")
    p.add_argument(
        "--nvr",
        metavar="NVR",
        nargs="+",
        default=["ml"],
        help="ml (maximum likelihood, the default) or the NVRs: the trend's (two for LLT), then one per period",
    )
    p.add_argument("--level", metavar="L", type=fraction, default=0.95, help="interval level (default: 0.95)")
    p.add_argument("--out", metavar="DIR", default=DEFAULT_OUT, help=f"output directory (default: ./{DEFAULT_OUT})")
    p.set_defaults(run=run_forecast)


def _nvr(args):
    """--nvr as the study's `nvr`: "ml", or one non-negative number per NVR (CLIError code 2 otherwise)."""
    if args.nvr == ["ml"]:
        return "ml"
    expected = as_model(args.trend).n_nvr + len(args.periods)
    try:
        values = [float(v) for v in args.nvr]
    except ValueError:
        raise CLIError(f"--nvr: give ml, or numbers; got {' '.join(args.nvr)}", code=2) from None
    if not all(math.isfinite(v) and v >= 0 for v in values):
        raise CLIError(f"--nvr: each NVR must be a number >= 0; got {' '.join(args.nvr)}", code=2)
    if len(values) != expected:
        raise CLIError(
            f"--nvr: {len(values)} value(s) for the {expected} NVRs of --trend {args.trend} and {len(args.periods)} "
            f"period(s) (the trend's {as_model(args.trend).n_nvr}, then one per period)",
            code=2,
        )
    return tuple(values)


def _call(args, nvr, progress, staging):
    """Read and check the series against the options, then run the study."""
    progress.start("load")
    path = data_file(args.data)
    try:
        series = read_series(path, column=args.column, time_column=args.time_column)
    except OSError as e:
        raise CLIError(f"--data {args.data}: {e.strerror or e}") from None
    except ValueError as e:
        if type(e) is not ValueError:  # an OptionError: a column the file has not
            raise
        raise CLIError(f"--data: {e}") from None
    if args.dt is not None and series.time_column is not None:
        raise CLIError(
            f"--dt gives the sampling step of a file without time stamps; {path.name} has the time column "
            f"{series.time_column!r} (drop --dt)",
            code=2,
        )
    check_options(
        series.y, periods=args.periods, horizon=args.horizon, holdout=args.holdout, level=args.level, trend=args.trend
    )
    time = f", time column {series.time_column!r}" if series.time_column is not None else ""
    time += "".join(f" ({note})" for note in series.notes)
    return forecast_study(
        series.y,
        periods=args.periods,
        horizon=args.horizon,
        time=series.axis if series.time_column is not None else None,
        dt=args.dt,
        trend=args.trend,
        nvr=nvr,
        level=args.level,
        holdout=args.holdout,
        name=series.column,
        source=f"{path.name}, column {series.column!r}{time}",
        progress=progress.start,
    )


def _csv(study, folder: pathlib.Path) -> list[str]:
    if not study.horizon:
        return []
    (folder / "forecast.csv").write_text(study.csv())
    return ["forecast.csv"]


def run_forecast(args) -> int:
    """Check the options and --out, read and check the series, run the study, write what it returns."""
    nvr = _nvr(args)
    stages = ["load"] + (["holdout"] if args.holdout else []) + ["fit", "diagnostics"]
    return run_study(
        args,
        name=NAME,
        stages=stages,
        labels=LABELS,
        call=lambda progress, staging: _call(args, nvr, progress, staging),
        extra_files=_csv,
    )
