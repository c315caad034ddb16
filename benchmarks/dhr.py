"""Benchmark: dynamic harmonic regression (`jaxsdp.tvp.dhr`) forecasts on a real series, against statsmodels.

The series: the Mauna Loa CO2 record that ships with statsmodels
(`statsmodels.datasets.co2`, weekly 1958-2001), as monthly means (526
months, 5 missing: NaN for every method). For each hold-out of the last h
months (h = 24, 48, 72), every method is fitted on the rest and forecasts
the h months with 95 % intervals:

- `dhr`: jaxsdp's DHR, IRW trend, RW harmonics of 12, 6, 4, 3, 2.4 and 2
  months, the 7 NVRs by maximum likelihood (its defaults);
- `dhr-tied`: the same with one NVR for all periods (`tie_periods=True`):
  the `uc` model below, fitted by jaxsdp;
- `dhr-aic`: the DHR the AIC chooses on the training months alone among
  IRW or LLT trend, one NVR per period or one for all (`CANDIDATES`);
- `uc`: statsmodels' `UnobservedComponents`, smooth trend (the IRW) plus
  the trigonometric seasonal of period 12 with 6 harmonics (one variance for
  all harmonics: statsmodels' way of writing the seasonal);
- `uc-per-period`: the same with one trigonometric seasonal per period, each
  with its own variance: the DHR's model exactly (rotated), with
  statsmodels' exact diffuse start and its L-BFGS fit;
- `sarima`: statsmodels' `SARIMAX` (1,1,1)(0,1,1)_12, the airline-type model.

Then a rolling origin (the fairer test of one model against another: one
split is a handful of correlated months): 24-month forecasts from 8
origins, every 24 months back from the end (`--origins`), pooled RMSE and
coverage over the 192 forecast months.

Printed per method and hold-out: the out-of-sample RMSE (ppm), the share of
held-out months inside the 95 % interval, the time of one fit and forecast
after the first (median of `--repeats`) and the first call's (jaxsdp's
compilation). The issue-47 targets: DHR's RMSE below `uc`'s on the same
split and its intervals covering 90-98 % of the held-out months.

Then the NVR search's start (issue 47 item 1: the toolbox's `dhropt` fits the
NVRs in the frequency domain by default, then the time-domain likelihood
finishes): per hold-out, `dhr(nvr="spectrum")` alone (the log of the DHR's
pseudo-spectrum fitted to the log of the data's AR spectrum: its time-domain
log-likelihood, hold-out RMSE and coverage, time), and ML started there
(`nvr0="spectrum"`) beside ML from `nvr0=1e-4`: log-likelihood reached, BFGS
steps, time after the first call (median of `--repeats`).

`--weekly`: the same on the weekly record itself (2,284 weeks, 59 missing): the annual period
365.25 / 7 = 52.18 weeks and its 2nd and 3rd harmonics (the DHR's `PERIODS`, the UC models' 3 harmonics; no seasonal
ARIMA, whose season must be a whole number of samples), hold-outs of the last 104, 208 and 312 weeks (2, 4, 6
years), the rolling origin 104-week forecasts every 104 weeks. Its rows go to
`benchmarks/results/cpu/dhr_weekly.json` (`--json`).

Then, per hold-out, which search found the higher optimum of the per-period model: jaxsdp's log-likelihood at
its own ML NVRs and at the variances statsmodels' `uc-per-period` fit found (`optimum-H`).

`--json PATH` writes the rows (`benchmarks/_record.py`), keyed `METHOD-H`
(e.g. `dhr-48`), `roll-METHOD`, `start-START-H` (START: `spectrum`,
`ml-spectrum`, `ml-nvr0`), and `check-rmse-H`, `check-coverage-H`,
`check-rmse-roll`, `check-coverage-roll`, `check-start-H` (both starts reach the same log-likelihood, to 1e-6).
"""

import argparse
import pathlib
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from _record import Recorder  # noqa: E402

PERIODS = (12.0, 6.0, 4.0, 3.0, 2.4, 2.0)
#: The UC models' trigonometric seasonal: (period, harmonics).
SEASON = (12, 6)
#: The weekly record's periods (`--weekly`): a year in weeks and its 2nd and 3rd harmonics.
WEEKLY_PERIODS = tuple(365.25 / 7 / k for k in (1, 2, 3))


def co2_weekly():
    import statsmodels.api as sm

    return sm.datasets.co2.load_pandas().data["co2"].to_numpy(dtype=float)


def co2_monthly():
    import statsmodels.api as sm

    weekly = sm.datasets.co2.load_pandas().data["co2"]
    return weekly.resample("MS").mean().to_numpy(dtype=float)


def _dhr(y, h, **options):
    import jaxsdp.tvp as tvp

    res = tvp.dhr(y, PERIODS, horizon=h, **options)
    return _dhr_output(res, h)


#: The DHRs the AIC chooses from (`dhr-aic`): the trend IRW (smooth) or LLT, one NVR per period or one for all.
CANDIDATES = {
    "IRW": {},
    "IRW, tied": {"tie_periods": True},
    "LLT": {"trend": "LLT"},
    "LLT, tied": {"trend": "LLT", "tie_periods": True},
}


def _dhr_aic(y, h):
    """The candidate DHR with the least AIC on the training months: -2 loglik + 2 (NVRs + sigma^2); every candidate
    has the same states and diffuse prior, so their likelihoods are comparable."""
    import jaxsdp.tvp as tvp

    fits = {name: tvp.dhr(y, PERIODS, horizon=h, **kw) for name, kw in CANDIDATES.items()}
    aic = {name: -2.0 * float(r.loglik) + 2.0 * (np.size(r.nvr) + 1) for name, r in fits.items()}
    best = min(aic, key=aic.get)
    mean, lo, hi, note = _dhr_output(fits[best], h)
    return mean, lo, hi, f"chose {best} (AIC {', '.join(f'{k} {v:.1f}' for k, v in aic.items())}); {note}"


def _dhr_output(res, h):
    lo, hi = res.forecast.interval(0.95)
    mean = np.asarray(res.forecast.mean)
    return (
        mean[-h:],
        lo[-h:],
        hi[-h:],
        f"NVRs {np.array2string(np.asarray(res.nvr), formatter={'float_kind': lambda v: f'{v:.1e}'})}; "
        f"{res.nvr_fit.reason}",
    )


def _score(mean, lo, hi, test):
    """(RMSE, share inside the interval) over the held-out samples that were observed (a missing week is NaN)."""
    seen = ~np.isnan(test)
    e = (mean - test)[seen]
    return float(np.sqrt(np.mean(e**2))), float(np.mean(((test >= lo) & (test <= hi))[seen]))


def _statsmodels(y, h, kind):
    import statsmodels.api as sm

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if kind == "sarima":
            model = sm.tsa.SARIMAX(y, order=(1, 1, 1), seasonal_order=(0, 1, 1, 12))
        elif kind == "uc":
            season = [{"period": SEASON[0], "harmonics": SEASON[1]}]
            model = sm.tsa.UnobservedComponents(y, level="smooth trend", freq_seasonal=season)
        else:
            freq = [{"period": p, "harmonics": 1} for p in PERIODS]
            model = sm.tsa.UnobservedComponents(y, level="smooth trend", freq_seasonal=freq)
        fit = model.fit(disp=False, maxiter=500)
        fc = fit.get_forecast(h)
        ci = np.asarray(fc.conf_int(alpha=0.05))
    return np.asarray(fc.predicted_mean), ci[:, 0], ci[:, 1], f"converged {fit.mle_retvals.get('converged')}"


def _optima(y, holdouts, rec):
    """Per hold-out: jaxsdp's `dhr` log-likelihood (its default search) beside jaxsdp's log-likelihood at the
    variances statsmodels' ML found for the same model (`uc-per-period`, NVR = variance / irregular variance):
    which search reached the higher optimum (`optimum-H`)."""
    import statsmodels.api as sm

    import jaxsdp.tvp as tvp

    print("The same model's optimum: jaxsdp's log-likelihood at its own ML NVRs and at statsmodels' (uc-per-period)")
    for h in holdouts:
        train = y[:-h]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            freq = [{"period": p, "harmonics": 1} for p in PERIODS]
            model = sm.tsa.UnobservedComponents(train, level="smooth trend", freq_seasonal=freq)
            fit = model.fit(disp=False, maxiter=500)
        nvr_sm = np.asarray(fit.params[1:]) / fit.params[0]
        own = float(tvp.dhr(train, PERIODS).loglik)
        at_sm = float(tvp.dhr(train, PERIODS, nvr=nvr_sm).loglik)
        rec.add(key=f"optimum-{h}", holdout=h, dhr=own, statsmodels=at_sm, dhr_higher=own >= at_sm - 1e-6)
        print(f"  h = {h}: jaxsdp {own:.3f}, at statsmodels' NVRs {at_sm:.3f}")
    print()


STARTS = {
    "spectrum": {"nvr": "spectrum"},
    "ml-spectrum": {"nvr0": "spectrum"},
    "ml-nvr0": {"nvr0": 1e-4},
}


def _starts(y, holdouts, repeats, rec):
    import jaxsdp.tvp as tvp

    print("NVR start: the frequency-domain estimate alone, and ML from it or from nvr0 = 1e-4")
    print(f"{'start':<13}{'held out':>9}{'loglik':>12}{'steps':>7}{'RMSE ppm':>10}{'95% cover':>10}{'s/fit':>8}  NVRs")
    for h in holdouts:
        train, test = y[:-h], y[-h:]
        lik = {}
        for name, kw in STARTS.items():
            tvp.dhr(train, PERIODS, horizon=h, **kw)  # compile
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                res = tvp.dhr(train, PERIODS, horizon=h, **kw)
                loglik = float(res.loglik)
                times.append(time.perf_counter() - t0)
            mean = np.asarray(res.forecast.mean)[-h:]
            lo, hi = res.forecast.interval(0.95)
            rmse, cover = _score(mean, lo[-h:], hi[-h:], test)
            steps = int(res.nvr_fit.steps) if res.nvr_fit is not None else 0
            sec = float(np.median(times))
            lik[name] = loglik
            nv = np.array2string(np.log10(np.asarray(res.nvr)), precision=2)
            print(f"{name:<13}{h:>9}{loglik:>12.4f}{steps:>7}{rmse:>10.3f}{100 * cover:>9.1f}%{sec:>8.2f}  log10 {nv}")
            rec.add(
                key=f"start-{name}-{h}",
                start=name,
                holdout=h,
                loglik=loglik,
                steps=steps,
                rmse=rmse,
                coverage=cover,
                seconds=sec,
                log10_nvr=np.log10(np.asarray(res.nvr)).tolist(),
            )
        ok = abs(lik["ml-spectrum"] - lik["ml-nvr0"]) <= 1e-6
        rec.add(key=f"check-start-{h}", ok=ok, ml_spectrum=lik["ml-spectrum"], ml_nvr0=lik["ml-nvr0"])
        print(f"  h = {h}: both starts reach the same log-likelihood (1e-6): {'yes' if ok else 'NO'}\n")


METHODS = {
    "dhr": _dhr,
    "dhr-tied": lambda y, h: _dhr(y, h, tie_periods=True),
    "dhr-aic": _dhr_aic,
    "uc": lambda y, h: _statsmodels(y, h, "uc"),
    "uc-per-period": lambda y, h: _statsmodels(y, h, "uc-per-period"),
    "sarima": lambda y, h: _statsmodels(y, h, "sarima"),
}


def _check_aic(rec, split: str, results: dict):
    """The targets for the AIC's choice too (`check-rmse-aic-SPLIT`, `check-coverage-aic-SPLIT`)."""
    (rmse, cover), uc = results["dhr-aic"], results["uc"][0]
    rec.add(key=f"check-rmse-aic-{split}", ok=rmse < uc, dhr=rmse, uc=uc)
    rec.add(key=f"check-coverage-aic-{split}", ok=0.90 <= cover <= 0.98, coverage=cover)
    print(f"  DHR chosen by AIC: RMSE below UC's: {'yes' if rmse < uc else 'NO'}; coverage {100 * cover:.1f} %")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--holdouts", type=int, nargs="+", default=None, help="samples held out (default 24 48 72 months)")
    ap.add_argument("--repeats", type=int, default=3, help="timed calls per method after the first (median)")
    ap.add_argument("--origins", type=int, default=8, help="rolling origins, 24 months apart (default 8)")
    ap.add_argument("--weekly", action="store_true", help="the weekly record instead (see the module's docstring)")
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args()
    rec = Recorder("benchmarks/dhr.py", args.json, holdouts=args.holdouts, repeats=args.repeats, origins=args.origins)
    global PERIODS, SEASON
    if args.weekly:
        y, unit, step = co2_weekly(), "weeks", 104
        PERIODS, SEASON = WEEKLY_PERIODS, (365.25 / 7, 3)
        METHODS.pop("sarima")
    else:
        y, unit, step = co2_monthly(), "months", 24
    args.holdouts = args.holdouts or [step, 2 * step, 3 * step]
    rec.doc.update(series=f"CO2, {unit}", periods=list(PERIODS), holdouts=args.holdouts)
    print(f"CO2: {len(y)} {unit}, {int(np.isnan(y).sum())} missing\n")
    print(f"{'method':<15}{'held out':>9}{'RMSE ppm':>10}{'95% cover':>10}{'s/fit':>8}{'first s':>9}  note")
    for h in args.holdouts:
        train, test = y[:-h], y[-h:]
        results = {}
        for name, fn in METHODS.items():
            t0 = time.perf_counter()
            mean, lo, hi, note = fn(train, h)
            first = time.perf_counter() - t0
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                fn(train, h)
                times.append(time.perf_counter() - t0)
            rmse, cover = _score(mean, lo, hi, test)
            results[name] = (rmse, cover)
            sec = float(np.median(times))
            print(f"{name:<15}{h:>9}{rmse:>10.3f}{100 * cover:>9.1f}%{sec:>8.2f}{first:>9.2f}  {note}")
            rec.add(key=f"{name}-{h}", method=name, holdout=h, rmse=rmse, coverage=cover, seconds=sec, first_s=first)
        ok_rmse = results["dhr"][0] < results["uc"][0]
        ok_cover = 0.90 <= results["dhr"][1] <= 0.98
        rec.add(key=f"check-rmse-{h}", ok=ok_rmse, dhr=results["dhr"][0], uc=results["uc"][0])
        rec.add(key=f"check-coverage-{h}", ok=ok_cover, coverage=results["dhr"][1])
        _check_aic(rec, str(h), results)
        print(
            f"  h = {h}: DHR RMSE below UC's: {'yes' if ok_rmse else 'NO'}; "
            f"DHR coverage in 90-98 %: {'yes' if ok_cover else 'NO'}\n"
        )
    h = step
    origins = [len(y) - h - step * k for k in range(args.origins)]
    print(f"Rolling origin: {h}-{unit[:-1]} forecasts from {len(origins)} origins ({unit} {origins[-1]}..{origins[0]})")
    pooled = {}
    for name, fn in METHODS.items():
        t0 = time.perf_counter()
        err, inside = [], []
        for o in origins:
            mean, lo, hi, _ = fn(y[:o], h)
            test = y[o : o + h]
            seen = ~np.isnan(test)
            err.append(((mean - test) ** 2)[seen])
            inside.append(((test >= lo) & (test <= hi))[seen])
        sec = (time.perf_counter() - t0) / len(origins)
        err, inside = np.concatenate(err), np.concatenate(inside)
        rmse, cover = float(np.sqrt(np.mean(err))), float(np.mean(inside))
        pooled[name] = (rmse, cover)
        print(
            f"{name:<15}{'rolling':>9}{rmse:>10.3f}{100 * cover:>9.1f}%{sec:>8.2f}{'':>9}  per fit, compiling included"
        )
        rec.add(
            key=f"roll-{name}", method=name, holdout=h, origins=len(origins), rmse=rmse, coverage=cover, seconds=sec
        )
    ok_rmse = pooled["dhr"][0] < pooled["uc"][0]
    ok_cover = 0.90 <= pooled["dhr"][1] <= 0.98
    rec.add(key="check-rmse-roll", ok=ok_rmse, dhr=pooled["dhr"][0], uc=pooled["uc"][0])
    rec.add(key="check-coverage-roll", ok=ok_cover, coverage=pooled["dhr"][1])
    _check_aic(rec, "roll", pooled)
    print(
        f"  rolling: DHR RMSE below UC's: {'yes' if ok_rmse else 'NO'}; "
        f"DHR coverage in 90-98 %: {'yes' if ok_cover else 'NO'}"
    )
    print()
    _optima(y, args.holdouts, rec)
    _starts(y, args.holdouts, args.repeats, rec)


if __name__ == "__main__":
    main()
