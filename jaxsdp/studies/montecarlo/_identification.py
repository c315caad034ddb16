"""Monte Carlo of the EMPS identification study: are the estimates unbiased and their intervals honest?

Each run is one noisy closed-loop experiment on the built-in EMPS plant
(`EMPSExperiment` on the reference of `jaxsdp.data.emps_builtin_data`:
asymmetric friction, the benchmark's controller and bang-bang reference,
24,841 samples at 1 kHz) followed by the EMPS study's identification, the
pure `EMPSPipeline` (this module holds no estimation code of its own), so
that `jaxsdp.monte_carlo` vectorises the runs: `run(key, theta) =
run_values(pipeline(experiment(key, theta)), theta)`.

1. **Experiment**: position read by the controller with white noise of
   `position_noise` encoder counts (std) and quantised to one count (5e-8 m);
   white force-measurement noise of `force_noise` N (std) on the recorded
   force (it does not enter the loop); optionally the plant
   (M, Fv+, Fc+, Fv-, Fc-) drawn uniform within +-`plant_spread` of the truth.
2. **Derivatives**: the benchmark's processing (`emps_preprocess`: 100 Hz
   Butterworth + central differences, 49 samples dropped, decimation by 10,
   parallel decimation of the regressors).
3. **IDIM-LS**, linear friction (M, Fv, Fc, offset) and asymmetric (eq. 17),
   with the paper's white-residual covariance sigma^2 (X^T X)^-1 (`"iid"`)
   and, for the asymmetric model, the Newey-West covariance (`"hac"`).
4. **IDIM-IV** (`emps_idim_iv`: bias-compensated, instruments from the
   model simulated noise-free in the same closed loop, Newey-West
   covariance), iterated from the asymmetric IDIM-LS to `iv_tol` or
   `iv_max_iter` steps: the same instruments (`iv_instruments`) and
   convergence test as the study, in a `while_loop` (`iv_iterate`).
5. **SDP stage** (`emps_sdp_stage`'s model `sdp_regression`, RW terms, ML
   NVRs, its `weighted_mass`): the mass is flagged
   constant when its NVR is below 1e-6; **IDIM-SDP**: the friction curve
   regressed on the parallel-decimated eq. (17) columns, the mass the
   acceleration-weighted SDP mass.

Per estimator and parameter the summary gives the mean, std, 5th and 95th
percentiles of the estimates; against the truth of each run i, the error
e_i = theta_hat_i - theta_i, its mean (`bias`) and std (`error_std`, also in
% as std(e_i / theta_i)); the mean reported standard error over the spread
of the error (`se_to_spread`; with `plant_spread > 0` the spread of the
estimates holds the spread of the plants, so the error's is used); and the
coverage of the stated 95 % intervals theta_hat +- 1.96 se. The
linear-friction model has a true value only for M (the plant's friction is
asymmetric): its other parameters get `se_to_spread` against the estimates'
spread, and only when every run has the same plant.
"""

import dataclasses
import pathlib

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._idim.estimators import IDIMIV
from ..._idim.trust import asymmetry_test
from ..._montecarlo import monte_carlo
from ..._runtime import x64
from ..._sdp.backfit import CONSTANT_NVR
from ..._sdp.options import Backfitting
from ..._signal.preprocess import Butterworth, Preprocessing
from ...data import EMPS_BUILTIN_TRUTH, emps_builtin_reference
from ...data._emps_builtin import BUILTIN_DT, BUILTIN_SAMPLES
from ...plants.emps._model import EMPS_DROP
from ...plants.emps._pipeline import EMPSExperiment, EMPSFit, EMPSPipeline
from .._contract import Study
from .._output import fraction_pct, percentiles
from ._control import few_runs_warning, uniform_around
from ._figures import identification_figures
from ._report import identification_report, identification_summary, identification_text
from ._shared import ASYM_NAMES, ESTIMATORS, LINEAR_NAMES, MIN_COVERAGE, Z95, run_record  # noqa: F401 (re-exported)


def identification_pipeline(settings: "IdentificationSettings") -> EMPSPipeline:
    """The EMPS study's pipeline with the Monte Carlo's settings: the benchmark's processing at `cutoff_hz` and
    `decimate`, IDIM-LS, IDIM-IV (`iv_max_iter`, `iv_tol`) and the SDP stage when switched on."""
    s = settings
    return EMPSPipeline(
        preprocessing=Preprocessing(Butterworth(s.cutoff_hz), drop=EMPS_DROP, decimate=s.decimate),
        iv=IDIMIV(max_iter=s.iv_max_iter, tol=s.iv_tol) if s.iv else None,
        sdp=Backfitting() if s.sdp else None,
    )


def identification_experiment(settings: "IdentificationSettings") -> EMPSExperiment:
    """The noisy closed-loop experiment on the built-in plant's reference (24,841 samples at 1 kHz)."""
    qg = jnp.asarray(emps_builtin_reference(BUILTIN_SAMPLES, BUILTIN_DT).q)
    return EMPSExperiment(qg, dt=BUILTIN_DT, position_noise=settings.position_noise, force_noise=settings.force_noise)


def run_values(fit: EMPSFit, theta) -> dict:
    """What one run keeps of its `EMPSFit` (estimates, standard errors, verdicts; not the signals)."""

    def est(r):
        return dict(theta=r.theta, se=r.std)

    ratio, ratio_se, found = asymmetry_test(fit.idim_asym.theta, fit.idim_asym.cov)
    out = dict(
        truth=theta,
        idim_ls=est(fit.idim),
        idim_ls_asym=est(fit.idim_asym),
        idim_ls_asym_hac=est(fit.idim_asym_hac),
        asymmetry=dict(ratio=ratio, ratio_se=ratio_se, found=found),
    )
    if fit.idim_iv is not None:
        iv = fit.idim_iv
        out["idim_iv"] = dict(**est(iv.result), iterations=iv.iterations, converged=iv.converged)
    if fit.sdp is not None:
        curve = fit.idim_sdp
        out["idim_sdp"] = dict(theta=fit.idim_sdp_theta, se=jnp.concatenate([jnp.full((1,), jnp.nan), curve.std]))
        out["sdp"] = dict(
            nvr=fit.sdp.nvr,
            mass_constant=fit.sdp.nvr[0] < CONSTANT_NVR,
            converged=fit.sdp.converged,
            relative_error=fit.sdp.relative_error,
            fv_ratio=curve.theta[2] / curve.theta[0],
        )
    return out


def _run(settings: "IdentificationSettings"):
    """One Monte Carlo run: `run(key, theta)` = the pipeline on the experiment, reduced by `run_values`."""
    experiment, pipeline = identification_experiment(settings), identification_pipeline(settings)

    def run(key, theta):
        return run_values(pipeline(experiment(key, theta)), theta)

    return run


@dataclasses.dataclass(frozen=True)
class IdentificationSettings:
    """Options of `identification_robustness`: the experiment's noise, the plant draws, the stages run.

    `position_noise`: std of the white position noise the controller reads,
    in encoder counts (5e-8 m; 1, as the built-in data set); `force_noise`:
    std of the white force-measurement noise (N); `plant_spread`: plants
    drawn uniform within +- this fraction of the truth (0: the truth in every
    run); `cutoff_hz`, `decimate`: the derivative filter (Hz) and decimation
    factor; `iv`, `sdp`: run IDIM-IV and the SDP/IDIM-SDP stages;
    `iv_max_iter`, `iv_tol`: the IV iteration.
    """

    position_noise: float = 1.0
    force_noise: float = 0.5
    plant_spread: float = 0.0
    cutoff_hz: float = 100.0
    decimate: int = 10
    iv: bool = True
    sdp: bool = True
    iv_max_iter: int = 10
    iv_tol: float = 1e-4

    def __post_init__(self):
        for name in ("position_noise", "force_noise", "plant_spread"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v < np.inf:
                raise ValueError(f"`{name}` must be a finite number >= 0; got {v!r}")
        if not self.plant_spread < 1.0:
            raise ValueError(f"`plant_spread` must be below 1 (a fraction of the truth); got {self.plant_spread!r}")
        if not (isinstance(self.cutoff_hz, (int, float)) and 0.0 < self.cutoff_hz < 500.0):
            raise ValueError(f"`cutoff_hz` must lie in (0, 500) Hz (Nyquist at 1 kHz); got {self.cutoff_hz!r}")
        for name in ("decimate", "iv_max_iter"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"`{name}` must be an integer >= 1; got {v!r}")
        if not (isinstance(self.iv_tol, (int, float)) and 0.0 < self.iv_tol < 1.0):
            raise ValueError(f"`iv_tol` must lie in (0, 1); got {self.iv_tol!r}")


def draw_truths(runs: int, *, spread: float, seed: int) -> np.ndarray:
    """(runs, 5) true plants (M, Fv+, Fc+, Fv-, Fc-): the built-in truth, or uniform +-`spread` around it."""
    truth = np.array([EMPS_BUILTIN_TRUTH[k] for k in ASYM_NAMES], dtype=float)
    if spread == 0.0:
        return np.tile(truth, (runs, 1))
    return uniform_around(truth, runs, spread=spread, seed=seed)


def _estimator_summary(est: dict, truth: np.ndarray, names) -> tuple[dict, int]:
    theta, se = np.asarray(est["theta"], float), np.asarray(est["se"], float)
    ok = np.all(np.isfinite(theta), axis=1)
    same_plant = bool(np.all(truth == truth[:1]))
    out = {}
    for j, name in enumerate(names):
        th, s = theta[ok, j], se[ok, j]
        entry = percentiles(th)
        has_truth = name in ASYM_NAMES and (names is ASYM_NAMES or name == "M")
        entry.update(
            bias=None,
            bias_pct=None,
            error_std=None,
            error_std_pct=None,
            mean_reported_se=None,
            se_to_spread=None,
            coverage_95=None,
        )
        if has_truth and th.size:
            tr = truth[ok, ASYM_NAMES.index(name)]
            err = th - tr
            entry["bias"] = float(err.mean())
            entry["bias_pct"] = float(100.0 * np.mean(err / tr))
            entry["error_std"] = float(err.std())
            entry["error_std_pct"] = float(100.0 * np.std(err / tr))
            if np.all(np.isfinite(s)):
                entry["coverage_95"] = float(np.mean(np.abs(err) <= Z95 * s))
        # the spread the stated se is held against: of the error (estimate - truth of its run); without a
        # truth, of the estimate, and only when every run had the same plant (else it holds the plants' spread)
        spread = entry["error_std"] if has_truth else (entry["std"] if same_plant else None)
        if np.any(np.isfinite(s)):
            entry["mean_reported_se"] = float(np.nanmean(s))
            if spread:
                entry["se_to_spread"] = entry["mean_reported_se"] / spread
        out[name] = entry
    return out, int((~ok).sum())


class IdentificationRobustness(Study):
    """Result of `identification_robustness`: per-run estimates and their summary.

    `truth` (runs, 5) the true plant of each run (M, Fv+, Fc+, Fv-, Fc-);
    `estimates` estimator -> {"theta": (runs, p), "se": (runs, p)} for
    `ESTIMATORS` (those run); `iv` IV iterations and convergence per run;
    `sdp` SDP NVRs, mass-constant flags, ...; `asymmetry` Fv-/Fv+ of the
    asymmetric IDIM-LS, its standard error and the verdict per run;
    `statistics` per estimator and parameter the statistics over the runs (bias, spread, coverage; with the
    asymmetry, IV and SDP figures: what `summary()` adds to the run's figures);
    `settings`, `seed`, `runs`, `devices`, `chunk_size`, `seconds` (the run's wall time, s, compilation
    included), `runs_per_second`; `warnings` (tuple of one-line messages).
    `timings` (s per stage, the run as `study`), `versions` (jaxsdp, jax) and
    `fast_loops`.

    **Methods:** `summary()`, `report(figures=None)`, `text()`, `figures()` (the study contract,
    `jaxsdp.studies.montecarlo.summary` and the like), `with_timings(timings)`.
    """

    truth: np.ndarray
    estimates: dict
    iv: dict | None
    sdp: dict | None
    asymmetry: dict
    statistics: dict = eqx.field(static=True)
    settings: IdentificationSettings = eqx.field(static=True)
    seed: int = eqx.field(static=True)
    runs: int = eqx.field(static=True)
    devices: int = eqx.field(static=True)
    chunk_size: int = eqx.field(static=True)
    seconds: float = eqx.field(static=True)
    runs_per_second: float = eqx.field(static=True)
    warnings: tuple = eqx.field(static=True, converter=tuple)
    timings: dict = eqx.field(default_factory=dict)
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp montecarlo --study identification`,
        `identification_summary`): the run (runs, devices, `seconds` s, `runs_per_second`), settings, mean truth
        (M kg, Fv N s/m, Fc N), per estimator and parameter the estimates' mean/std/p05/p95, `bias`,
        `bias_pct` (%), `error_std`, `error_std_pct` (%), `mean_reported_se`, `se_to_spread`, `coverage_95`
        (fraction); the asymmetry, IV and SDP figures; `warnings`, `timings` (s), `versions`."""
        return identification_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md`, `identification_report`): the experiments, the warnings, per
        estimator a table of bias (%), error std (%), stated se (%), se/spread and coverage (%), the findings;
        `figures` (name -> file name) are embedded when given."""
        return identification_report(self, [pathlib.Path(name) for name in (figures or {}).values()])

    @x64
    def text(self) -> str:
        """What `jaxsdp montecarlo --study identification` prints (`identification_text`): the run (runs, devices, s,
        runs/s), then per estimator each parameter's bias (% of the truth) and coverage of its 95 % intervals."""
        return identification_text(self)

    @x64
    def figures(self) -> dict:
        """`identification_figures`: `mc_estimates`, per parameter the histograms of the estimates' error (% of
        the truth) against the normal law of their stated standard errors."""
        return identification_figures(self)


def summarise_identification(values: dict, truth: np.ndarray, settings: IdentificationSettings) -> tuple[dict, list]:
    """The study's summary and its warnings.

    Per estimator and parameter: `mean`, `std`, `p05`, `p95` of the estimates; `bias`, `bias_pct`,
    `error_std`, `error_std_pct` of the error estimate - truth (per run: the plants may differ);
    `mean_reported_se`; `se_to_spread` = mean_reported_se / error_std; `coverage_95`.
    """
    summary, warnings = {"estimators": {}}, []
    runs = truth.shape[0]
    warnings += few_runs_warning(runs)
    for key, (label, names) in ESTIMATORS.items():
        if key not in values:
            continue
        params, failed = _estimator_summary(values[key], truth, names)
        summary["estimators"][key] = dict(label=label, failed_runs=failed, parameters=params)
        if failed:
            warnings.append(f"{key}: no finite estimate in {failed} of {runs} runs (left out of its statistics)")
        low = [(n, e) for n, e in params.items() if e["coverage_95"] is not None and e["coverage_95"] < MIN_COVERAGE]
        if low:
            cover = ", ".join(f"{n} {fraction_pct(e['coverage_95'])}" for n, e in low)
            n, e = max(low, key=lambda ne: abs(ne[1]["bias"]) / ne[1]["mean_reported_se"])
            warnings.append(
                f"{label}: the stated 95 % intervals cover the truth in fewer than {100 * MIN_COVERAGE:.0f} % of the "
                f"runs ({cover}): its standard errors understate the error (worst, {n}: bias {e['bias_pct']:+.2f} % "
                f"against a mean stated se of {100 * e['mean_reported_se'] / abs(e['mean']):.2f} %)"
            )
    a = values["asymmetry"]
    summary["asymmetry"] = dict(
        found_fraction=float(np.mean(a["found"])),
        fv_ratio=percentiles(a["ratio"]),
        true_fv_ratio=percentiles(truth[:, 3] / truth[:, 1]),
    )
    if "idim_iv" in values:
        iv = values["idim_iv"]
        conv = float(np.mean(iv["converged"]))
        summary["idim_iv"] = dict(
            converged_fraction=conv, iterations=percentiles(iv["iterations"]), max_iter=settings.iv_max_iter
        )
        if conv < 1.0:
            failed = int(np.sum(~np.asarray(iv["converged"], bool)))
            warnings.append(
                f"IDIM-IV did not converge within {settings.iv_max_iter} iterations in {failed} of {runs} runs "
                f"({fraction_pct(1.0 - conv, digits=1)}; their last iterate is reported)"
            )
    if "sdp" in values:
        s = values["sdp"]
        nvr = np.asarray(s["nvr"], float)
        summary["sdp"] = dict(
            mass_constant_fraction=float(np.mean(s["mass_constant"])),
            converged_fraction=float(np.mean(s["converged"])),
            friction_nvr_at_cap_fraction=float(np.mean(nvr[:, 1] >= Backfitting().max_nvr * (1 - 1e-9))),
            log10_mass_nvr=percentiles(np.log10(np.maximum(nvr[:, 0], 1e-300))),
            relative_error=percentiles(s["relative_error"]),
            fv_ratio=percentiles(s["fv_ratio"]),
            constant_nvr=CONSTANT_NVR,
        )
    return summary, warnings


@x64
def identification_robustness(
    runs: int = 1000,
    *,
    seed: int = 0,
    settings: IdentificationSettings | None = None,
    chunk_size: int | None = None,
    devices=None,
    progress: bool = True,
) -> IdentificationRobustness:
    """Monte Carlo of the EMPS identification study on the built-in plant: bias, spread, honest intervals.

    Each run simulates one noisy closed-loop experiment on the built-in EMPS
    plant (encoder noise and quantisation in the loop, force-measurement
    noise on the record, optionally a plant drawn around the truth), then
    runs the study's stages on it in JAX: the benchmark's preprocessing,
    IDIM-LS (linear and asymmetric friction), IDIM-IV, the SDP stage and
    IDIM-SDP. Per estimator and parameter (M kg, Fv N s/m, Fc N, offset N;
    asymmetric: `Fv_pos`, `Fc_pos`, `Fv_neg`, `Fc_neg`) the summary gives
    the estimates' mean, std and 5-95 % percentiles, the error against each
    run's truth (bias, spread, in units and %), the mean stated standard
    error over the error's spread, and the coverage of the 95 % intervals.

    **Arguments:** `runs` (experiments), `seed` (the noise of run i is
    drawn from `fold_in(key(seed), i)`; the plant draws, with
    `settings.plant_spread > 0`, from `seed` too), `settings` (an
    `IdentificationSettings`: noise levels, plant spread, which stages),
    `chunk_size`, `devices`, `progress` as `jaxsdp.monte_carlo`.

    **Returns** an `IdentificationRobustness` (per-run estimates, their `statistics`, `warnings`).

    Example:
        >>> from jaxsdp.studies.montecarlo import IdentificationSettings, identification_robustness
        >>> res = identification_robustness(4, settings=IdentificationSettings(sdp=False), progress=False)
        >>> iv = res.statistics["estimators"]["idim_iv"]["parameters"]["M"]
        >>> abs(iv["bias_pct"]) < 0.1  # % of the true mass, 95.15 kg
        True
    """
    s = IdentificationSettings() if settings is None else settings
    if not isinstance(s, IdentificationSettings):
        raise ValueError(f"`settings` must be an IdentificationSettings; got {type(s).__name__}")
    truth = draw_truths(runs, spread=s.plant_spread, seed=seed)
    out = monte_carlo(
        _run(s),
        seed,
        runs,
        params=truth,
        chunk_size=chunk_size,
        devices=devices,
        progress=progress,
        desc="identification",
    )
    values = out.values
    summary, warnings = summarise_identification(values, truth, s)
    return IdentificationRobustness(
        truth=truth,
        estimates={k: values[k] for k in ESTIMATORS if k in values},
        iv=values.get("idim_iv"),
        sdp=values.get("sdp"),
        asymmetry=values["asymmetry"],
        statistics=summary,
        settings=s,
        warnings=warnings,
        **run_record(out, seed),
    )
