"""Monte Carlo of the EMPS identification study: are the estimates unbiased and their intervals honest?

Each run is one noisy closed-loop experiment on the built-in EMPS plant
(`jaxsdp.data.emps_builtin_data`: asymmetric friction, the benchmark's
controller and bang-bang reference, 24,841 samples at 1 kHz) followed by
the whole identification study, all in JAX so that the runs are
vectorised by `jaxsdp.monte_carlo`:

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
   convergence test as the study, in a `lax.while_loop`.
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

import jax
import jax.numpy as jnp
import numpy as np

from ..._idim.iv import iv_converged, relative_error
from ..._idim.trust import asymmetry_test
from ..._idim.unrolled import unrolled_estimate
from ..._montecarlo import monte_carlo
from ..._runtime import x64
from ..._sdp.backfit import CONSTANT_NVR, sdp
from ..._signal.preprocess import preprocess
from ...data import EMPS_BUILTIN_TRUTH, emps_builtin_reference
from ...data._emps_builtin import BUILTIN_DT, BUILTIN_SAMPLES
from ...plants import AsymmetricFriction, EMPSController, EMPSPlant, encoder_quantum
from ...plants.emps._idim_iv import iv_instruments
from ...plants.emps._model import EMPS_ASYM_NAMES, EMPS_DROP, EMPS_LINEAR_NAMES, emps_regression
from ...plants.emps._plant import simulate_closed_loop
from ...plants.emps._sdp_stage import sdp_regression, weighted_mass
from .._contract import fast_loops, versions
from .._output import fraction_pct, percentiles
from ._control import few_runs_warning, uniform_around

ASYM_NAMES = EMPS_ASYM_NAMES
LINEAR_NAMES = EMPS_LINEAR_NAMES
#: Estimators compared, with their parameter names and covariance.
ESTIMATORS = {
    "idim_ls": ("IDIM-LS, linear friction (iid)", LINEAR_NAMES),
    "idim_ls_asym": ("IDIM-LS, asymmetric (iid, the paper's)", ASYM_NAMES),
    "idim_ls_asym_hac": ("IDIM-LS, asymmetric (Newey-West)", ASYM_NAMES),
    "idim_iv": ("IDIM-IV, bias-compensated (Newey-West)", ASYM_NAMES),
    "idim_sdp": ("IDIM-SDP (curve fit)", ASYM_NAMES),
}
Z95 = 1.959963984540054
#: Coverage of the stated 95 % intervals below which an estimator's intervals are called dishonest.
MIN_COVERAGE = 0.90
#: Cap on the SDP stage's ML NVRs (`emps_sdp_stage`'s default); a friction NVR there is "at its cap".
MAX_NVR = 1.0
#: The IV iterate is kept physical for its simulation: each parameter at least this fraction of its start.
IV_FLOOR = 0.05


def _plant(theta):
    return EMPSPlant(theta[0], AsymmetricFriction(theta[1], theta[2], theta[3], theta[4], 0.0))


def _estimate(out):
    return dict(theta=out["theta"], se=out["std"])


def _iv(reg, theta0, sim_loop, options, *, max_iter, tol):
    """Bias-compensated iterated IDIM-IV in JAX: `emps_idim_iv`'s iteration (`idim_iv_iterate`: the same
    instruments `iv_instruments`, the same convergence test `iv_converged`) as a `lax.while_loop`, with the
    LAPACK-free `unrolled_estimate` so that it runs vmapped."""
    y, X = reg.y, reg.X
    nan = jnp.asarray(jnp.nan)
    floor = IV_FLOOR * jnp.abs(theta0)

    def relerr(th):
        return relative_error(y, X, th)

    def step(theta):
        sim = sim_loop(_plant(jnp.maximum(theta, floor)))
        inst = iv_instruments(preprocess(sim.q, sim.force, **options), theta)
        return unrolled_estimate(y - inst.y_offset, X, inst.Z, nan, cov="hac")

    def body(c):
        k, theta, rho, _, _ = c
        est = step(theta)
        new = est["theta"]
        rho_new = relerr(new)
        return k + 1, new, rho_new, iv_converged(theta, new, rho, rho_new, tol), est

    init = (0, theta0, relerr(theta0), jnp.array(False), unrolled_estimate(y, X, X, nan, cov="hac"))
    k, _, _, done, est = jax.lax.while_loop(lambda c: (c[0] < max_iter) & ~c[3], body, init)
    return dict(theta=est["theta"], se=est["std"], iterations=k, converged=done)


def pipeline_parts(settings: "IdentificationSettings"):
    """One Monte Carlo run in pure, jittable parts: `experiment(key, theta) -> (q_meas, force)` (the noisy
    closed-loop record of plant `theta`), `identify(q_meas, force) -> dict` (the study's stages on it), and
    `identify_inputs(inputs, q0)`, the stages after the preprocessing (`q0` the first position reading)."""
    s = settings
    n, dt = BUILTIN_SAMPLES, BUILTIN_DT
    qg = jnp.asarray(emps_builtin_reference(n, dt).q)
    t = jnp.arange(n) * dt
    ctrl = EMPSController()
    quantum = encoder_quantum()
    options = dict(dt=dt, cutoff_hz=s.cutoff_hz, drop=EMPS_DROP, decimate=s.decimate)

    def loop(plant, noise, q_quantum, q0):
        return simulate_closed_loop(qg, t, dt, plant, ctrl, q0, 0.0, 0.0, noise, q_quantum, 1)

    def experiment(key, theta):
        kq, kf = jax.random.split(key)
        sim = loop(_plant(theta), s.position_noise * quantum * jax.random.normal(kq, (n,)), quantum, qg[0])
        return sim.q_meas, sim.force + s.force_noise * jax.random.normal(kf, (n,))

    def identify(q_meas, force):
        return identify_inputs(preprocess(q_meas, force, **options), q_meas[0])

    def identify_inputs(inputs, q0):
        lin = emps_regression(inputs, friction="linear")
        asym = emps_regression(inputs, friction="asymmetric")
        nan = jnp.asarray(jnp.nan)
        ls_asym = unrolled_estimate(asym.y, asym.X, asym.X, nan, cov="iid")
        ratio, ratio_se, found = asymmetry_test(ls_asym["theta"], ls_asym["cov"])
        out = dict(
            idim_ls=_estimate(unrolled_estimate(lin.y, lin.X, lin.X, nan, cov="iid")),
            idim_ls_asym=_estimate(ls_asym),
            idim_ls_asym_hac=_estimate(unrolled_estimate(asym.y, asym.X, asym.X, nan, cov="hac")),
            asymmetry=dict(ratio=ratio, ratio_se=ratio_se, found=found),
        )
        if s.iv:
            zeros = jnp.zeros(n)
            out["idim_iv"] = _iv(
                asym,
                ls_asym["theta"],
                lambda plant: loop(plant, zeros, 0.0, q0),  # from the first reading, as emps_idim_iv
                options,
                max_iter=s.iv_max_iter,
                tol=s.iv_tol,
            )
        if s.sdp:
            res = sdp(*sdp_regression(inputs), model="RW", max_nvr=MAX_NVR)  # emps_sdp_stage's defaults
            mass = weighted_mass(res.par[:, 0], inputs.ddq)
            fric = unrolled_estimate(res.par[:, 1], asym.X[:, 1:], asym.X[:, 1:], nan, cov="iid")
            out["idim_sdp"] = dict(
                theta=jnp.concatenate([mass[None], fric["theta"]]),
                se=jnp.concatenate([jnp.full((1,), jnp.nan), fric["std"]]),
            )
            out["sdp"] = dict(
                nvr=res.nvr,
                mass_constant=res.nvr[0] < CONSTANT_NVR,
                converged=res.converged,
                relative_error=res.relative_error,
                fv_ratio=fric["theta"][2] / fric["theta"][0],
            )
        return out

    return experiment, identify, identify_inputs


def _pipeline(settings: "IdentificationSettings"):
    experiment, identify, _ = pipeline_parts(settings)

    def run(key, theta):
        return dict(truth=theta, **identify(*experiment(key, theta)))

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


@dataclasses.dataclass
class IdentificationRobustness:
    """Result of `identification_robustness`: per-run estimates and their summary.

    `truth` (runs, 5) the true plant of each run (M, Fv+, Fc+, Fv-, Fc-);
    `estimates` estimator -> {"theta": (runs, p), "se": (runs, p)} for
    `ESTIMATORS` (those run); `iv` IV iterations and convergence per run;
    `sdp` SDP NVRs, mass-constant flags, ...; `asymmetry` Fv-/Fv+ of the
    asymmetric IDIM-LS, its standard error and the verdict per run;
    `summary` the JSON-ready summary (`summary.json` of `jaxsdp montecarlo`);
    `settings`, `seed`, `runs`, `devices`, `chunk_size`, `seconds`,
    `runs_per_second`; `warnings`.
    `timings` (s per stage, the run as `study`), `versions` (jaxsdp, jax) and
    `fast_loops`.
    """

    truth: np.ndarray
    estimates: dict
    iv: dict | None
    sdp: dict | None
    asymmetry: dict
    summary: dict
    settings: IdentificationSettings
    seed: int
    runs: int
    devices: int
    chunk_size: int
    seconds: float
    runs_per_second: float
    warnings: list
    timings: dict = dataclasses.field(default_factory=dict)
    versions: dict = dataclasses.field(default_factory=dict)
    fast_loops: str | None = None


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
            friction_nvr_at_cap_fraction=float(np.mean(nvr[:, 1] >= MAX_NVR * (1 - 1e-9))),
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

    **Returns** an `IdentificationRobustness` (per-run estimates, `summary`, `warnings`).

    Example:
        >>> from jaxsdp.studies.montecarlo import IdentificationSettings, identification_robustness
        >>> res = identification_robustness(4, settings=IdentificationSettings(sdp=False), progress=False)
        >>> iv = res.summary["estimators"]["idim_iv"]["parameters"]["M"]
        >>> abs(iv["bias_pct"]) < 0.1  # % of the true mass, 95.15 kg
        True
    """
    s = IdentificationSettings() if settings is None else settings
    if not isinstance(s, IdentificationSettings):
        raise ValueError(f"`settings` must be an IdentificationSettings; got {type(s).__name__}")
    truth = draw_truths(runs, spread=s.plant_spread, seed=seed)
    out = monte_carlo(
        _pipeline(s),
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
        summary=summary,
        settings=s,
        seed=int(seed),
        runs=out.runs,
        devices=out.devices,
        chunk_size=out.chunk_size,
        seconds=out.seconds,
        timings={"study": float(out.seconds)},
        versions=versions(),
        fast_loops=fast_loops(),
        runs_per_second=out.runs_per_second,
        warnings=warnings,
    )
