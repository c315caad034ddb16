"""The forecast study and `jaxsdp forecast` (issue 47, item 7): its forecasts are `jaxsdp.tvp.dhr`'s, its hold-out
metrics and whiteness test recomputed here independently, its warnings, the series file's reading (columns, missing
values, time stamps) and the command's errors, each before any fit.

One simulated monthly-like series of 144 samples (`helpers.seasonal_series`) with fixed NVRs serves most tests, so
that the study's programs compile once for the file; one case estimates the NVRs by maximum likelihood.
"""

import contextlib
import io
import json
import pathlib
import warnings

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import norm

import jaxsdp
import jaxsdp._cli.forecast as cli_forecast
import jaxsdp.tvp as tvp
from helpers import seasonal_series, write_series_csv
from jaxsdp._checks import OptionError
from jaxsdp._cli import main
from jaxsdp.data._series import read_series, time_axis
from jaxsdp.studies import forecast
from jaxsdp.studies.forecast._report import COVERAGE_NOTE, bound_note
from jaxsdp.studies.forecast._study import _fit_warnings, check_options, study_warnings

N, PERIODS, HORIZON, HOLDOUT = 144, (12.0, 6.0), 12, 12
NVR = (3e-6, 0.1, 1e-10)  # the IRW trend's, then one per period: the ML estimate's, rounded
DATES = np.arange(np.datetime64("2000-01"), np.datetime64("2000-01") + N).astype("datetime64[s]")


@pytest.fixture(scope="module")
def y():
    return seasonal_series(N)


@pytest.fixture(scope="module")
def study(y):
    return forecast.forecast_study(
        y, periods=PERIODS, horizon=HORIZON, holdout=HOLDOUT, nvr=NVR, time=DATES, name="y", source="test"
    )


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


# --------------------------------------------------------------------------- #
# The numbers: dhr's forecasts, the hold-out metrics, the whiteness test
# --------------------------------------------------------------------------- #


def test_forecasts_are_dhrs(study, y):
    ref = tvp.dhr(y, PERIODS, nvr=NVR, horizon=HORIZON)
    for field in ("mean", "se", "obs_se"):
        np.testing.assert_allclose(getattr(study.fit.forecast, field), getattr(ref.forecast, field), rtol=1e-12)
    lo, hi = ref.forecast.interval(0.95)
    z = norm.ppf(0.975)
    np.testing.assert_allclose(hi - np.asarray(ref.forecast.mean), z * np.asarray(ref.forecast.obs_se), rtol=1e-12)
    rows = study.summary()["forecast"]["rows"]
    assert [r["sample"] for r in rows] == list(range(N, N + HORIZON))
    np.testing.assert_allclose([r["mean"] for r in rows], np.asarray(ref.forecast.mean)[N:], rtol=1e-12)
    np.testing.assert_allclose([r["lower"] for r in rows], lo[N:], rtol=1e-12)
    np.testing.assert_allclose([r["upper"] for r in rows], hi[N:], rtol=1e-12)
    # the CSV holds the same rows, with the trend and seasonal parts that add up to the mean
    table = np.genfromtxt(io.StringIO(study.csv()), delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert list(table["time"][:2]) == ["2012-01-01", "2012-02-01"]
    np.testing.assert_allclose(table["mean"], [r["mean"] for r in rows], rtol=1e-15)
    np.testing.assert_allclose(table["trend"] + table["seasonal"], table["mean"], rtol=1e-12)


def test_holdout_metrics_recomputed_independently(study, y):
    k = HOLDOUT
    ref = tvp.dhr(y[:-k], PERIODS, nvr=NVR, horizon=k)  # the study forecasts the horizon too: same first k
    mean = np.asarray(ref.forecast.mean)[-k:]
    np.testing.assert_allclose(np.asarray(study.holdout_fit.forecast.mean)[N - k : N], mean, rtol=1e-9)
    half = norm.ppf(0.975) * np.asarray(ref.forecast.obs_se)[-k:]
    test = y[-k:]
    inside = np.abs(test - mean) <= half
    m = study.summary()["holdout"]
    assert m["observed"] == k and m["fitted"] == N - k and m["inside"] == int(inside.sum())
    np.testing.assert_allclose(m["rmse"], np.sqrt(np.mean((mean - test) ** 2)), rtol=1e-9)
    np.testing.assert_allclose(m["mae"], np.mean(np.abs(mean - test)), rtol=1e-9)
    np.testing.assert_allclose(m["bias"], np.mean(mean - test), rtol=1e-8)
    assert m["coverage"] == inside.mean()
    # a count, with no binomial p-value: one split's multi-step errors are correlated through the trend
    assert "coverage_p" not in m and COVERAGE_NOTE in study.report() and COVERAGE_NOTE in study.text()
    # the seasonal naive forecast: each held-out month is the training data's same month a year before (the gap at
    # sample 97 filled by the smoother)
    train = np.asarray(ref.forecast.filled)
    naive = train[N - k - 12 : N - k]
    np.testing.assert_allclose(m["naive_rmse"], np.sqrt(np.mean((naive - test) ** 2)), rtol=1e-9)
    assert m["rmse"] < 0.5 * m["naive_rmse"]  # the model forecasts the growing cycle, the naive one cannot
    assert [r["time"] for r in m["rows"][:1]] == ["2011-01-01"]
    assert [r["inside"] for r in m["rows"]] == inside.tolist()


def test_whiteness_of_the_one_step_errors_is_ljung_box(study, y):
    acorr_ljungbox = pytest.importorskip("statsmodels.stats.diagnostic").acorr_ljungbox
    # the DHR as jaxsdp.dlr on its regressors, one NVR per block: the same model (the same likelihood)
    z = tvp.harmonic_regressors(N, PERIODS)
    models = ["IRW", "RW", "RW", "RW", "RW"]
    res = jaxsdp.dlr(y, z, model=models, nvr=np.array([NVR[0], NVR[1], NVR[1], NVR[2], NVR[2]]))
    np.testing.assert_allclose(res.loglik, study.fit.loglik, rtol=1e-10)
    # the study takes the one-step errors from the fit (DHRResult.innov, innov_var): dlr's
    np.testing.assert_allclose(study.fit.innov, res.innov, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(study.fit.innov_var, res.innov_var, rtol=1e-12)
    assert study.fit.innov.shape == (N,) and np.isnan(np.asarray(study.fit.innov)[[40, 41, 97]]).all()
    e = (np.asarray(res.innov) / np.sqrt(np.asarray(res.innov_var)))[7:]  # after the 6 states' diffuse start
    e = e[np.isfinite(e)]
    w = study.whiteness
    assert w["n"] == len(e) == N - 7 - 3 and w["lags"] == 24  # the three gaps are after the start
    lb = acorr_ljungbox(e, lags=[24])
    np.testing.assert_allclose(w["q"], lb["lb_stat"].iloc[0], rtol=1e-10)
    np.testing.assert_allclose(w["p_value"], lb["lb_pvalue"].iloc[0], rtol=1e-8)
    assert w["white"]  # the simulated noise is white


def test_summary_holds_the_model_the_data_and_the_forecasts(study):
    s = study.summary()
    json.dumps(s, allow_nan=False)
    assert s["series"] == dict(
        name="y",
        samples=N,
        missing=3,
        time=dict(kind="date", column="time", first="2000-01-01", last="2011-12-01", step="1 month"),
    )
    assert s["model"]["periods"] == [12.0, 6.0] and s["model"]["periods_in_time"] == ["12 months (1 year)", "6 months"]
    assert [c["component"] for c in s["nvr"]["components"]] == ["trend", "period 12", "period 6"]
    assert [c["nvr"] for c in s["nvr"]["components"]] == list(NVR) and s["nvr"]["estimated"] is False
    assert s["forecast"]["level"] == 0.95 and len(s["forecast"]["rows"]) == HORIZON
    assert s["forecast"]["rows"][-1]["time"] == "2012-12-01"
    assert s["sigma2"] == float(study.fit.sigma2) and s["loglik"] == float(study.fit.loglik)
    assert (
        s["warnings"]
        == list(study.warnings)
        == [
            "3 of the 144 samples are missing (NaN): the smoother fills them, with their intervals; they do not enter "
            "the likelihood"
        ]
    )
    report = study.report()
    assert "12 samples = 12 months (1 year)" in report and "[forecast.csv](forecast.csv)" in report
    assert "2012-01-01" in study.text() and sorted(study.figures()) == ["decomposition", "forecast", "holdout"]


def test_nvrs_by_maximum_likelihood(y):
    """The one ML case: the study's NVRs are dhr's on the whole series, the hold-out fit's dhr's on its part."""
    ml = forecast.forecast_study(y, periods=PERIODS, horizon=HORIZON, holdout=HOLDOUT)
    ref = tvp.dhr(y, PERIODS, horizon=HORIZON)
    np.testing.assert_allclose(ml.fit.nvr, ref.nvr, rtol=1e-12)
    np.testing.assert_allclose(ml.holdout_fit.nvr, tvp.dhr(y[:-HOLDOUT], PERIODS, horizon=24).nvr, rtol=1e-12)
    s = ml.summary()["nvr"]
    assert s["estimated"] and s["converged"] == bool(ref.nvr_fit.converged)
    se = [v if np.isfinite(v) else None for v in np.asarray(ref.nvr_fit.log10_nvr_se).tolist()]
    assert [c["log10_se"] for c in s["components"]] == se
    # on these data the trend's NVR goes to the search's lower bound (a straight line): a normal result, one note
    # in the report and the printed text, no warning
    assert [c["at_bound"] for c in s["components"]] == [True, False, False]
    assert np.asarray(ref.nvr_fit.at_bound).tolist() == [True, False, False]
    note = "At the NVR search's lower bound (1e-30), where the data cannot tell an NVR from zero: trend (a straight"
    assert s["note"].startswith(note) and ml.report().count(note) == 1 and note in ml.text()
    assert not any("bound" in w for w in ml.warnings)
    # a search that does not converge, an NVR on the upper bound: both warned; the lower bounds noted once
    fake = eqx.tree_at(
        lambda f: (f.converged, f.at_bound, f.log10_nvr),
        ref.nvr_fit,
        (jnp.asarray(False), jnp.array([1, 1, 1]) > 0, jnp.array([-30.0, -30.0, 6.0])),
    )
    faked = eqx.tree_at(lambda r: r.nvr_fit, ref, fake)
    said = _fit_warnings(faked, ["trend", "period 12", "period 6"])
    assert len(said) == 2 and "did not converge" in said[0] and "`nvr` values" in said[0]
    assert said[1].startswith("the NVR of the period 6 is at the search's upper bound (1e6)")
    assert bound_note(faked, "IRW", PERIODS).startswith(
        "At the NVR search's lower bound (1e-30), where the data cannot tell an NVR from zero: trend (a straight "
        "line); period 12 (a constant amplitude). This is a normal result"
    )


def test_warnings(study, y):
    parts = dict(
        y=y, periods=PERIODS, trend="IRW", fit=study.fit, hold=None, horizon=HORIZON, whiteness=None, metrics={}
    )
    assert len(study_warnings(parts)) == 1  # the missing samples
    few = study_warnings(dict(parts, periods=(80.0,)))
    assert any("1.8 cycles of the longest period (80 samples)" in w for w in few)
    far = study_warnings(dict(parts, horizon=100))
    assert any("the horizon (100 samples, 8.33 times the longest period)" in w for w in far)
    coloured = study_warnings(dict(parts, whiteness=dict(white=False, p_value=1e-4, lags=24, lag1=0.6)))
    assert any("not white (Ljung-Box p = 0.0001 over 24 lags, lag-1 autocorrelation 0.60)" in w for w in coloured)
    metrics = dict(observed=12, inside=6, level=0.95, rmse=2.0, naive_rmse=1.0, naive_season=12)
    held = study_warnings(dict(parts, metrics=metrics))
    # a low coverage of one split is no warning (its errors are correlated: no binomial test), a worse RMSE is
    assert len(held) == 2 and not any("hold 6 of the 12" in w or "too narrow" in w for w in held)
    assert "above the seasonal naive forecast's (1, each value repeated from 12 samples earlier)" in held[1]


def test_correlated_noise_is_not_white(y):
    """AR(1) noise the model has no place for: the one-step errors are not white, and the study says so."""
    rng = np.random.default_rng(5)
    e = np.zeros(N)
    for k in range(1, N):
        e[k] = 0.8 * e[k - 1] + 0.3 * rng.standard_normal()
    res = forecast.forecast_study(seasonal_series(N, noise=0.0) + e, periods=PERIODS, horizon=HORIZON, nvr=NVR)
    assert not res.whiteness["white"] and res.whiteness["p_value"] < 1e-6 and res.whiteness["lag1"] > 0.4
    assert any("not white" in w for w in res.warnings)


def test_options_are_checked_before_any_fit(y):
    with pytest.raises(OptionError, match="`periods`: 200 samples is longer than the 144 samples"):
        forecast.forecast_study(y, periods=[200], horizon=1)
    with pytest.raises(OptionError, match="the 104 samples fitted .* `holdout` 40"):
        forecast.forecast_study(y, periods=[120], horizon=1, holdout=40)
    with pytest.raises(OptionError, match="`horizon` must be an integer >= 0"):
        forecast.forecast_study(y, periods=[12], horizon=-1)
    with pytest.raises(OptionError, match="`level`"):
        forecast.forecast_study(y, periods=[12], horizon=1, level=95)
    with pytest.raises(ValueError, match=r"give `time` \(the samples. time stamps\) or `dt` \(their step\), not both"):
        forecast.forecast_study(y, periods=[12], horizon=1, time=DATES, dt=1.0)
    with pytest.raises(ValueError, match="`time` is not regular: sample 100"):
        forecast.forecast_study(y, periods=[12], horizon=1, time=np.r_[np.arange(100.0), np.arange(101.0, 145.0)])
    # the hold-out fit needs its states + 2 observed samples: IRW (2) + 2 x 2 harmonics = 6 states, 8 samples
    gappy = np.r_[np.full(32, np.nan), y[32:80]]
    opts = dict(periods=[12, 6], horizon=1, level=0.95)
    assert check_options(gappy, holdout=40, **opts) == (12.0, 6.0)  # 8 observed before the hold-out: enough
    with pytest.raises(OptionError, match=r"`holdout` \(41\) leaves 7 observed samples to fit, too few for the 6 "):
        check_options(gappy, holdout=41, **opts)
    with pytest.raises(OptionError, match="`periods`: the series has 7 observed samples, too few for the 6 states"):
        check_options(np.r_[y[:7], np.full(20, np.nan)], holdout=0, **opts)


# --------------------------------------------------------------------------- #
# Reading the series: columns, missing values, time stamps
# --------------------------------------------------------------------------- #


def test_read_series_columns_missing_values_and_dates(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text(
        ",label,value\n2001-01-31,a,1.5\n2001-02-28,b,NA\n2001-03-31,c,\n2001-04-30,d,nan\n2001-05-31,e,2\n"
    )
    s = read_series(path)  # the unnamed column of ISO dates (pandas' index) is the time, the text column ignored
    assert s.column == "value" and s.time_column == "column 1" and s.axis.name == "date"
    np.testing.assert_array_equal(np.isnan(s.y), [False, True, True, True, False])
    assert s.axis.months == 1 and s.axis.month_end  # each month's last day
    assert s.axis.labels(s.axis.at([4, 5, 6])) == ["2001-05-31", "2001-06-30", "2001-07-31"]
    path.write_text("t;x\n0.1;1\n0.2;2\n0.3;3\n")  # semicolons, stamps rounded to the digits written
    s = read_series(path)
    assert s.time_column == "t" and s.axis.kind == "number" and s.axis.span(12) == "1.2 (units of t)"
    np.testing.assert_allclose(s.axis.at([3]), [0.4])


def test_time_axes():
    days = time_axis(np.arange("2020-01-01", "2020-03-01", dtype="datetime64[D]"))
    assert days.step_text() == "1 day" and days.span(7) == "7 days (1 week)"
    assert days.labels(days.at([59, 60])) == ["2020-02-29", "2020-03-01"]
    quarters = time_axis(np.arange("2000-01", "2010-01", 3, dtype="datetime64[M]"))
    assert quarters.span(4) == "12 months (1 year)" and quarters.labels(quarters.at([40])) == ["2010-01-01"]
    hours = time_axis(np.arange("2020-01-01T00", "2020-01-02T00", dtype="datetime64[h]"))
    assert hours.span(24) == "24 h" and hours.labels(hours.at([24])) == ["2020-01-02T00:00"]
    with pytest.raises(ValueError, match=r"sample 5 \(2001-07-01\) comes 6 month\(s\) after sample 4"):
        time_axis(np.r_[np.arange("2000-01", "2001-03", 3, dtype="datetime64[M]"), np.datetime64("2001-07")])


def test_time_stamps_missing_fractions_and_offsets(tmp_path):
    path = tmp_path / "s.csv"
    # a missing time stamp (NA, NaN, empty): refused, naming the file's line (the blank line counted)
    for cell in ("NA", " nan ", ""):
        path.write_text(f"time,y\n0,1\n\n1,2\n{cell},3\n3,4\n")
        with pytest.raises(ValueError, match="s.csv: time column 'time' is empty at row 5"):
            read_series(path)
    # every message names the file's own lines
    path.write_text("time,y\n\n2000-01,1\n\n2000-02,x\n")
    with pytest.raises(ValueError, match="s.csv: row 5, column 'y' is not a number: 'x'"):
        read_series(path)
    path.write_text("time,y\n2000-01,1\n\n2000-02,2\n2000-04,3\n2000-05,4\n")
    with pytest.raises(ValueError, match=r"row 5 \(2000-04-01\) comes 2 month\(s\) after row 4 \(2000-02-01\)"):
        read_series(path)
    # fractions of a second, at the stamps' own precision: a 100 ms series
    path.write_text("time,y\n" + "".join(f"2024-03-01T12:00:00.{k}00,{k}\n" for k in range(10)))
    s = read_series(path)
    assert s.axis.step_text() == "0.1 s" and s.axis.span(10) == "1 s"
    assert s.axis.labels(s.axis.at([9, 10])) == ["2024-03-01T12:00:00.900", "2024-03-01T12:00:01.000"]
    # a UTC offset shared by every stamp: kept aside, said, and written again on the labels; no warning
    path.write_text("time,y\n2024-03-01 00:00+01:00,1\n2024-03-01 01:00+01:00,2\n2024-03-01 02:00+01:00,3\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = read_series(path)
    assert s.axis.step_text() == "1 h" and s.axis.labels(s.axis.at([0, 3])) == [
        "2024-03-01T00:00+01:00",
        "2024-03-01T03:00+01:00",
    ]
    assert s.notes == ("time stamps at UTC offset +01:00, read as the local times they write",)
    path.write_text("time,y\n2024-03-31T00:00+01:00,1\n2024-03-31T01:00+01:00,2\n2024-03-31T03:00+02:00,3\n")
    with pytest.raises(ValueError, match=r"row 4 has \+02:00, row 2 \+01:00: the stamps must share one UTC offset"):
        read_series(path)


def test_time_column_names_and_compact_dates(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text("year,value\n1990,1\n1991,2\n1992,3\n")
    s = read_series(path)
    assert s.time_column == "year" and s.axis.span(10) == "10 (units of year)"
    path.write_text("Month,value\n2001-01,1\n2001-02,2\n2001-03,3\n")
    assert read_series(path).axis.months == 1
    # a month column of 1..12 beside a year column is no time axis (it does not increase): the series is named
    rows = [f"{2000 + k // 12},{k % 12 + 1},{k}" for k in range(24)]
    path.write_text("year,month,value\n" + "\n".join(rows) + "\n")
    with pytest.raises(OptionError, match=r"several numeric columns \('year', 'month', 'value'\)"):
        read_series(path)
    assert read_series(path, column="value").axis.kind == "index"
    # compact dates: YYYYMMDD in a column named as a time, YYYYMM, or given with `time_column`
    days = "".join(f"{d},{k}\n" for k, d in enumerate(["20240130", "20240131", "20240201", "20240202"]))
    path.write_text("date,value\n" + days)
    s = read_series(path)
    assert s.axis.step_text() == "1 day" and s.axis.labels(s.axis.at([4])) == ["2024-02-03"]
    assert s.notes == ("time column 'date' read as compact dates (YYYYMMDD)",)
    path.write_text("yyyymm,value\n200011,1\n200012,2\n200101,3\n")
    assert read_series(path).axis.labels(read_series(path).axis.at([3])) == ["2001-02-01"]
    path.write_text("obs,value\n" + days)
    with pytest.raises(OptionError, match=r"'obs' may be the time \(YYYYMMDD dates\): name it with `time_column`"):
        read_series(path)
    assert read_series(path, time_column="obs").axis.kind == "date"


def test_series_files_share_the_loaders_reading(tmp_path):
    """One CSV reader (`_csv.read_csv_rows`: BOM, separator, header, field counts, line numbers), one step
    tolerance, one time-name pattern; the command's option types are `common`'s."""
    import jaxsdp._cli.common as common
    import jaxsdp._cli.tx40 as tx40
    from jaxsdp.data import _loaders, _log_tables, _series, load_measurements

    path = tmp_path / "m.csv"
    path.write_text("\ufefft;q;force\n0;0;1\n\n0.001;1;2;3\n")
    fields = r"CSV row 4 of .*m.csv has 4 fields, the header has 3 \(fields separated by ';'\)"
    for read in (load_measurements, read_series):
        with pytest.raises(ValueError, match=fields):
            read(path)
    assert _series.MAX_JITTER is _loaders.MAX_JITTER and _series.off_step is _loaders.off_step
    assert _log_tables.TIME.pattern in _series.TIME_NAMES.pattern
    assert cli_forecast.fraction is common.fraction is tx40.fraction
    assert cli_forecast.positive_float is common.positive_float


# --------------------------------------------------------------------------- #
# The command
# --------------------------------------------------------------------------- #


def test_command_on_a_file_without_time(tmp_path, y):
    path = write_series_csv(tmp_path / "s.csv", y, time=None, column="load")
    out = tmp_path / "out"
    argv = ["forecast", "--data", path, "--periods", "12", "6", "--horizon", "12", "--dt", "0.5"]
    code, stdout, stderr = _run([*argv, "--nvr", *map(str, NVR), "--out", str(out), "--quiet"])
    assert code == 0, stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["source"] == "s.csv, column 'load'" and s["series"]["time"]["step"] == "0.5 (units of dt)"
    assert [r["time"] for r in s["forecast"]["rows"][:2]] == [72.0, 72.5]  # sample k at k dt
    assert s["holdout"] is None and "12 samples = 6 (units of dt)" in (out / "report.md").read_text()
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "decomposition.png",
        "forecast.csv",
        "forecast.png",
        "report.md",
        "summary.json",
    ]
    assert "Forecast, 12 samples, 95 % intervals:" in stdout
    assert stderr.strip().splitlines() == [f"jaxsdp forecast: warning: {w}" for w in s["warnings"]]
    assert len(s["warnings"]) == 1 and "3 of the 144 samples are missing" in s["warnings"][0]


@pytest.fixture
def files(tmp_path, monkeypatch):
    """Small series files for the errors, and the study replaced by a failure: each error comes before it."""

    def started(*args, **kwargs):
        pytest.fail("the study started: the check should have come first")

    monkeypatch.setattr(cli_forecast, "forecast_study", started)
    y = seasonal_series(48)
    irregular = tmp_path / "irregular.csv"
    text = pathlib.Path(write_series_csv(irregular, y)).read_text().splitlines()
    irregular.write_text("\n".join(text[:12] + text[13:]) + "\n")  # the row of 2000-12 left out
    bad = tmp_path / "bad.csv"
    bad.write_text("time,y\n2000-01,1\n2000-02,2\n2000-03,abc\n2000-04,4\n")
    na_time = tmp_path / "na_time.csv"
    na_time.write_text("time,y\n2000-01,1\n\n2000-02,2\nNA,3\n2000-04,4\n")  # a blank line: NA is on line 5
    return dict(
        good=write_series_csv(tmp_path / "good.csv", y),
        na_time=str(na_time),
        two=write_series_csv(tmp_path / "two.csv", y, extra={"z": list(range(48)), "label": ["a"] * 48}),
        irregular=str(irregular),
        bad=str(bad),
        out=str(tmp_path / "out"),
        tmp=tmp_path,
    )


ERRORS = {
    # (argv after --data FILE, exit code, fragment of the one line)
    "a text column": ("two", ["--column", "label"], 2, "--column 'label' of two.csv holds no numbers"),
    "no such column": ("good", ["--column", "load"], 2, "--column 'load' is not a column of good.csv (columns: "),
    "two numeric columns": ("two", [], 2, "several numeric columns ('y', 'z') besides the time column; name the "),
    "no such time column": ("good", ["--time-column", "date"], 2, "--time-column 'date' is not a column"),
    "a cell that is not a number": ("bad", [], 1, "--data: bad.csv: row 4, column 'y' is not a number: 'abc'"),
    "irregular time stamps": ("irregular", [], 1, "is not regular: row 13 (2001-01-01) comes 2 month(s) after row 12"),
    "a period longer than the data": ("good", ["--periods", "60"], 2, "--periods: 60 samples is longer than the 48"),
    "a period longer than the part fitted": (
        "good",
        ["--periods", "40", "--holdout", "12"],
        2,
        "--periods: 40 samples is longer than the 36 samples fitted (the 48 less the --holdout 12)",
    ),
    "--dt with a time column": ("good", ["--dt", "1"], 2, "--dt gives the sampling step of a file without time"),
    "a negative horizon": ("good", ["--horizon", "-1"], 2, "--horizon: must be an integer >= 0; got -1"),
    "a period under 2": ("good", ["--periods", "1.5"], 2, "--periods: must be a period in samples, a number >= 2"),
    "a level of 95": ("good", ["--level", "95"], 2, "--level: must lie in (0, 1); got '95'"),
    "a step of 0": ("good", ["--dt", "0"], 2, "--dt: must be a positive number; got '0'"),
    "a missing time stamp": ("na_time", [], 1, "--data: na_time.csv: time column 'time' is empty at row 5 (NA)"),
    "a hold-out that leaves too few samples": (
        "good",
        ["--periods", "4", "--holdout", "43"],
        2,
        "--holdout (43) leaves 5 observed samples to fit, too few for the 4 states of the IRW trend and 1 period(s)",
    ),
    "NVRs too few": ("good", ["--nvr", "1e-4"], 2, "--nvr: 1 value(s) for the 2 NVRs of --trend IRW and 1 period(s)"),
    "no such file": ("missing", [], 1, "no such file"),
}


@pytest.mark.parametrize("case", list(ERRORS))
def test_command_errors_come_before_any_fit(case, files):
    which, extra, expected, fragment = ERRORS[case]
    path = files.get(which, str(files["tmp"] / "missing.csv"))
    base = {"--periods": ["12"], "--horizon": ["6"]}
    for flag in ("--periods", "--horizon"):
        if flag in extra:
            base.pop(flag)
    argv = ["forecast", "--data", path, *[a for k, v in base.items() for a in (k, *v)], *extra, "--out", files["out"]]
    code, stdout, stderr = _run(argv)
    assert code == expected, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("jaxsdp forecast: error: ") and fragment in lines[0], stderr
    out = pathlib.Path(files["out"])
    assert not out.exists() or not any(out.iterdir())
    assert not list(files["tmp"].glob(".jaxsdp-*")) and not stdout


def test_command_refuses_a_non_empty_out(files):
    out = pathlib.Path(files["out"])
    out.mkdir()
    (out / "report.md").write_text("an earlier report\n")
    code, _, stderr = _run(
        ["forecast", "--data", files["good"], "--periods", "12", "--horizon", "1", "--out", str(out)]
    )
    assert code == 2 and "not empty (report.md)" in stderr
