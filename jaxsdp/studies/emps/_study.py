"""The EMPS identification study (paper section 2): IDIM-LS, SDP stage, IDIM-SDP.

Workflow on an EMPS-type record (position + force of one linear axis):

1. **Preprocessing** (`emps_preprocess`: the generic `jaxsdp.preprocess`
   with the benchmark's settings): velocity and acceleration by Butterworth
   filtering and central differences (or smoothing), first samples dropped,
   decimation.
2. **IDIM-LS** with the symmetric model `[ddq, dq, sign(dq), 1]` and the
   asymmetric model of eqs. (17)-(18) (`emps_regression` + `jaxsdp.idim_ls`:
   parallel decimation of the regressors, the published procedure).
3. **SDP stage** (`emps_sdp_stage`, eq. 13): y_k = M(ddq_k) ddq_k +
   d_fric(dq_k) * 1 + e_k with ML NVRs (regressors z = [ddq, 1],
   states x = [ddq, dq]) on the decimated
   signals. A mass NVR below `constant_nvr` flags the mass as
   acceleration-independent.
4. **IDIM-SDP** (`emps_idim_sdp`, eq. 17, Table 2): the friction SDP curve
   regressed on [O+(dq), sign O+(dq), O-(dq), sign O-(dq)] (O+ = max(dq, 0),
   O- = min(dq, 0)), and the final IDIM-LS with the
   asymmetric model.

`emps_study` runs the estimation stages as one pure `EMPSPipeline` (built
from its option objects `Preprocessing`, `IDIMIV`, `Backfitting`; run
eagerly, bit for bit the stages run one by one), reads the fit on the host
(`fits_from`: the checks, warnings and findings), and
returns an `EMPSStudy` (tables, a JSON-ready `summary()`), the back end of
the `jaxsdp emps` command; `emps_figures` draws the paper's figures from it
and `report_markdown` its report.
"""

import dataclasses
import pathlib
from collections.abc import Callable

import equinox as eqx
import numpy as np

from ..._idim.estimators import IDIMIV
from ..._idim.iv import IDIMIVResult
from ..._idim.ls import IDIMResult
from ..._runtime import follows_method, x64
from ..._sdp.backfit import CONSTANT_NVR
from ..._sdp.options import MLNVR, Backfitting
from ..._signal.preprocess import Butterworth, Preprocessed, Preprocessing
from ...data._emps_builtin import emps_builtin_data
from ...data._loaders import EMPSData, load_record
from ...plants._friction_laws import FrictionLaw
from ...plants.emps._checks import check_emps_data, check_length
from ...plants.emps._diagnosis import fits_from
from ...plants.emps._friction_stage import EMPSFriction, emps_friction
from ...plants.emps._idim_iv import iv_failure, iv_fit_result
from ...plants.emps._idim_sdp import EMPSIDIMSDP
from ...plants.emps._pipeline import EMPSPipeline
from ...plants.emps._preprocess import emps_preprocess
from ...plants.emps._sdp_stage import EMPSSDPStage, sdp_stage_with, searched_backfitting, stage_options
from .._contract import Study, fast_loops, versions
from .._output import StageTimer
from ._figures import emps_figures
from ._report import findings, fv_ratio_se, recovery, report_markdown, text_output
from ._simulation_check import simulation_check


class EMPSStudy(Study):
    """All results of `emps_study`.

    **Fields:** `inputs` (`Preprocessed`), `idim` (IDIM-LS, symmetric model
    `M, Fv, Fc, offset`), `idim_asym` (IDIM-LS, asymmetric model), `sdp`
    (`EMPSSDPStage`), `idim_sdp` (`EMPSIDIMSDP`), `timings` (stage ->
    seconds: `load`, `derivatives`, `identification`, `total`, ...), `source` (file name or description), `samples`
    (raw samples), `sample_time` (raw sample time, s), `preprocessing`
    (description), `derivatives` ("butterworth" or "smooth").

    `idim_iv`: the IDIM-IV estimate of the asymmetric model (the pipeline's `IDIMIV`, as `emps_idim_iv`)
    when `emps_study` was given `iv`, else None; `estimator` records which: "ls" (none), "iv"
    (bias-compensated) or "iv-plain" (`IDIMIV(compensate=False)`).

    **Trust:** `warnings` (tuple of one-line messages: physically impossible
    parameters, nearly collinear regressors, NVRs on a bound, a back-fitting
    that did not converge, a finding that changes with the decimation factor);
    `mass_check` (decimation factor -> SDP mass NVR, constancy flag and
    acceleration-weighted SDP mass, at the chosen factor and its neighbours
    half and twice it; empty when `check_decimation=False`); `scale_checks`
    (`EMPSFits.scales`: travel, speed, acceleration, mass and Coulomb
    friction against what a linear axis in m, N and s allows; a failed one is
    warned with its likely cause: units, time scale); `plausible` (False when
    a physical check failed: the findings then describe the fit, not the
    machine).

    **Checks against the data and the truth:** `simulation`
    (`simulation_check`: the identified model simulated in the data's closed
    loop, relative errors %; None with `check_simulation=False`), `truth`
    (the built-in plant's parameters, None for measured data), `recovery`
    (estimates against `truth`, `recovery`), `data_info` (the file's path and
    resampling, or the built-in plant's description), `findings` (one
    sentence each, with its evidence), `versions` (jaxsdp, jax) and
    `fast_loops`.
    """

    inputs: Preprocessed
    idim: IDIMResult
    idim_asym: IDIMResult
    sdp: EMPSSDPStage
    idim_sdp: EMPSIDIMSDP
    idim_iv: IDIMIVResult | None
    timings: dict
    source: str = eqx.field(static=True)
    samples: int = eqx.field(static=True)
    sample_time: float = eqx.field(static=True)
    preprocessing: str = eqx.field(static=True)
    derivatives: str = eqx.field(static=True)
    estimator: str = eqx.field(static=True, default="ls")
    warnings: tuple = eqx.field(static=True, default=())
    mass_check: dict = eqx.field(static=True, default_factory=dict)
    plausible: bool = eqx.field(static=True, default=True)
    scale_checks: tuple = eqx.field(static=True, default=())
    simulation: dict | None = eqx.field(static=True, default=None)
    truth: dict | None = eqx.field(static=True, default=None)
    recovery: dict | None = eqx.field(static=True, default=None)
    data_info: dict = eqx.field(static=True, default_factory=dict)
    findings: tuple = eqx.field(static=True, default=())
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)
    friction: EMPSFriction | None = None

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp emps`): `idim_ls`, `idim_ls_asym` (estimates, standard
        deviations, relative standard deviations %, covariances, relative errors %), `sdp`, `idim_sdp`,
        `idim_iv`, `simulation`, `truth` and `recovery`, `warnings`, `timings` (s), `data`, `versions`."""
        return study_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md` of `jaxsdp emps`): warnings, findings, the paper's Tables 1 and 2, the
        SDP stage, the checks, the figures (name -> file name, linked when given) and the timings."""
        return report_markdown(self, study_summary(self), dict(figures or {}))

    @x64
    def text(self) -> str:
        """What `jaxsdp emps` prints: the paper's tables, the simulation check, the recovery of the built-in
        plant's truth and the findings (the warnings are printed once, on stderr, by the command)."""
        return text_output(self, study_summary(self))

    @x64
    def figures(self) -> dict:
        """The paper's Figs. 3-5 (SDP mass, linear and asymmetric friction) and the force reconstruction
        (`emps_figures`)."""
        return emps_figures(self)

    @x64
    def tables(self, *, warnings: bool = True) -> str:
        """The paper's Table 1 (IDIM-LS), the SDP stage and Table 2 (IDIM-SDP) as text, after the
        warnings (unless `warnings=False`)."""
        return study_tables(self, warnings=warnings)


def _theta(r: IDIMResult) -> dict:
    return {n: float(v) for n, v in zip(r.names, np.asarray(r.theta, dtype=float))}


def _uncertainty(r: IDIMResult) -> dict:
    """Standard deviations, relative standard deviations (%), covariance and condition number."""
    names = list(r.names)
    return {
        "std": dict(zip(names, np.asarray(r.std, dtype=float).tolist())),
        "rel_std": dict(zip(names, np.asarray(r.rel_std, dtype=float).tolist())),
        "cov": {"names": names, "matrix": np.asarray(r.cov, dtype=float).tolist()},
        "cond": float(r.cond),
        "dof": int(r.dof),
    }


def _iv_summary(study: EMPSStudy) -> dict | None:
    iv = study.idim_iv
    if iv is None:
        return None
    return {
        **_theta(iv.result),
        "relative_error": iv.measured_relative_error,
        **_uncertainty(iv.result),
        "variant": IV_VARIANTS[study.estimator],
        "cov_type": iv.result.cov_type,
        "iterations": int(iv.iterations),
        "converged": bool(iv.converged),
    }


def study_summary(study: EMPSStudy) -> dict:
    """Plain-Python summary of an `EMPSStudy`: the keys of `summary.json` (`jaxsdp emps`)."""
    i, a, s, p = study.idim, study.idim_asym, study.sdp, study.idim_sdp
    se = [None if not np.isfinite(v) else float(v) for v in np.asarray(s.log10_nvr_se, dtype=float)]
    out = {
        "warnings": list(study.warnings),
        "plausible": bool(study.plausible),
        "scale_checks": list(study.scale_checks),
        "idim_ls": {**_theta(i), "relative_error": float(i.relative_error), **_uncertainty(i)},
        "idim_ls_asym": {
            **_theta(a),
            "relative_error": float(a.relative_error),
            **_uncertainty(a),
            **dict(zip(("fv_ratio", "fv_ratio_se"), fv_ratio_se(a)[:2])),
        },
        "sdp": {
            "nvr_mass": s.nvr_mass,
            "nvr_friction": s.nvr_friction,
            "log10_nvr_se": se,
            "nvr_at_bound": {"mass": s.nvr_bound[0], "friction": s.nvr_bound[1]},
            "max_nvr": s.max_nvr,
            "converged": bool(s.result.converged),
            "mass_constant": bool(s.mass_constant),
            "mass": s.mass,
            "relative_error": s.relative_error,
            "r2": s.r2,
            "model": s.model,
            "nvr_search": s.nvr_search,
            "sweeps": int(s.result.sweeps),
        },
        "mass_constancy": {str(k): v for k, v in study.mass_check.items()},
        "idim_iv": _iv_summary(study),
        "idim_sdp": {
            **p.theta,
            "fv_ratio": p.fv_ratio,
            "relative_error": p.relative_error,
            "curve_fit_relative_error": float(p.friction.relative_error),
            "curve_fit": _uncertainty(p.friction),
        },
        "timings": {k: float(v) for k, v in study.timings.items()},
        "data": {
            "source": study.source,
            "samples": int(study.samples),
            "sample_time": float(study.sample_time),
            "preprocessing": study.preprocessing,
            "decimated_samples": int(study.inputs.y.shape[0]),
            "decimated_sample_time": float(study.inputs.dt),
            **study.data_info,
        },
        "simulation": study.simulation,
        "truth": study.truth,
    }
    if study.friction is not None:
        out["friction"] = study.friction.summary()
    if study.truth is not None:
        out["recovery"] = study.recovery
    out["fast_loops"] = study.fast_loops
    out["versions"] = dict(study.versions)
    return out


def study_tables(study: EMPSStudy, *, warnings: bool = True) -> str:
    """Text tables of an `EMPSStudy` (its warnings first, unless `warnings=False`)."""
    warn = ["WARNINGS\n" + "\n".join(f"- {w}" for w in study.warnings)] if study.warnings and warnings else []
    return "\n\n".join(
        warn
        + [
            f"Data: {study.source}, {study.samples} samples, dt = {study.sample_time:g} s; {study.preprocessing}",
            "Table 1. IDIM-LS, linear friction model\n" + study.idim.table(),
            "IDIM-LS, asymmetric friction model (eq. 18)\n" + study.idim_asym.table(),
        ]
        + (
            []
            if study.idim_iv is None
            else [f"IDIM-IV, asymmetric friction model ({IV_VARIANTS[study.estimator]})\n" + study.idim_iv.table()]
        )
        + [
            study.sdp.table(),
            "Table 2. IDIM-SDP, asymmetric friction model (eq. 17)\n" + study.idim_sdp.table(),
        ]
    )


#: What each estimator (`estimator_name` of the study's `iv`) adds to IDIM-LS.
IV_VARIANTS = {
    "iv": "bias-compensated IDIM-IV, HAC standard deviations",
    "iv-plain": "plain IDIM-IV of Janot et al. (2014), HAC standard deviations",
}


def decimation_check(data, stage: EMPSSDPStage, preprocessing: Preprocessing, sdp: Backfitting) -> dict:
    """SDP mass NVR and flag at `preprocessing.decimate` and its neighbours half and twice it (the SDP stage
    `sdp` on the record processed by `preprocessing` at each factor; `stage` is the one at the chosen factor).

    The mass-constancy flag rests on a local ML search of the mass NVR; on the
    EMPS data it changes with the decimation (the built-in plant, whose mass is
    constant, is flagged acceleration-dependent at 5). A finding that holds at
    one setting only is reported as fragile.
    """
    decimate = preprocessing.decimate
    out = {decimate: _mass_entry(stage)}
    for d in sorted({max(decimate // 2, 1), 2 * decimate} - {decimate}):
        try:
            check_length(int(np.shape(data.force)[0]), drop=preprocessing.drop, decimate=d)
            inputs = emps_preprocess(data, **dataclasses.replace(preprocessing, decimate=d)._options())
            out[d] = _mass_entry(sdp_stage_with(sdp, inputs))
        except ValueError as e:  # too few samples at 2 * decimate
            out[d] = {"skipped": str(e)}
    return dict(sorted(out.items()))


def _mass_entry(stage: EMPSSDPStage) -> dict:
    return {"nvr_mass": stage.nvr_mass, "mass_constant": bool(stage.mass_constant), "mass": stage.mass}


def mass_check_warnings(check: dict, decimate: int) -> list[str]:
    skipped = [f"{d} ({v['skipped']})" for d, v in check.items() if "skipped" in v]
    out = (
        [f"SDP stage: the mass-constancy finding was not checked at decimation {', '.join(skipped)}"] if skipped else []
    )
    flags = {d: v["mass_constant"] for d, v in check.items() if "mass_constant" in v}
    if len(set(flags.values())) <= 1:
        return out
    desc = ", ".join(f"{d}: {'constant' if f else 'acceleration-dependent'}" for d, f in flags.items())
    return out + [
        f"SDP stage: the mass-constancy finding depends on the decimation factor ({desc}); it is fragile, "
        f"not a property of the machine established by these data"
    ]


#: The study's SDP stage when `sdp` is None: random-walk terms, ML NVRs by gradient from 1e-4 capped at 1, a mass
#: NVR below `CONSTANT_NVR` (1e-6) calling the mass constant.
DEFAULT_SDP = Backfitting(model="RW", nvr=MLNVR(1e-4, 1.0), constant_nvr=CONSTANT_NVR)


def estimator_name(iv: IDIMIV | None) -> str:
    """The study's name of its estimators: "ls" (IDIM-LS only, `iv=None`), "iv" (with the bias-compensated
    IDIM-IV) or "iv-plain" (with the plain IDIM-IV, `compensate=False`)."""
    return "ls" if iv is None else ("iv" if iv.compensate else "iv-plain")


def study_pipeline(inputs, *, preprocessing: Preprocessing, iv: IDIMIV | None, sdp: Backfitting):
    """The study's `EMPSPipeline` for its options, and the CAPTAIN search's standard errors (None for the
    gradient search). A `CaptainNVR` search runs here, on the host, and fixes the pipeline's NVRs."""
    backfitting, search_se = searched_backfitting(sdp, inputs)
    return EMPSPipeline(preprocessing=preprocessing, iv=iv, sdp=backfitting), search_se


def iv_result(fit, options) -> tuple:
    """(`IDIMIVResult` or None, warnings) of the fit's IDIM-IV, read on the host."""
    if options is None:
        return None, []
    iv = fit.idim_iv
    k = int(iv.iterations)
    if not np.all(np.isfinite(np.asarray(iv.result.theta))):
        return None, [f"IDIM-IV failed and is not reported: its estimate is not finite after {k} iterations"]
    result = iv_fit_result(iv, options.tol)
    warnings = []
    if result.failed:
        warnings.append(iv_failure(k))
    elif not result.converged:
        warnings.append(
            f"IDIM-IV did not converge in {k} iterations (tol {options.tol:g}); its estimate is the last iterate"
        )
    return result, warnings


@x64
@follows_method
def emps_study(
    data=None,
    *,
    seed: int | None = None,
    preprocessing: Preprocessing | None = None,
    iv: IDIMIV | None = None,
    sdp: Backfitting | None = None,
    check_decimation: bool = True,
    check_simulation: bool = True,
    friction=None,
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
    method: str | None = None,
) -> EMPSStudy:
    r"""Run the whole EMPS study with per-stage timings.

    The model is the paper's: the force $y_k$ (N) of a linear axis of mass $M$ (kg) with friction,
    $y_k = M \ddot q_k + F_v \dot q_k + F_c sign(\dot q_k) + o + e_k$ (IDIM-LS, linear friction; the
    asymmetric model of eqs. 17-18 has $F_v, F_c$ per direction), then the SDP stage
    $y_k = M(\ddot q_k) \ddot q_k + d_{fric}(\dot q_k) + e_k$ (eq. 13) and IDIM-SDP (eq. 17).

    **Arguments:**

    - `data`: None (the built-in simulated plant, `jaxsdp.data.emps_builtin_data`:
      its truth is known and the estimates are checked against it,
      `EMPSStudy.recovery`), a path (`.mat`: `jaxsdp.data.load_emps`; otherwise
      the CSV format of `jaxsdp.data.load_measurements`), an `EMPSData` or a
      `Measurements`.
    - `seed`: the built-in plant's measurement-noise seed (default 0; only
      with `data=None`).
    - `preprocessing`: a `jaxsdp.Preprocessing` (derivatives by
      `jaxsdp.Butterworth(cutoff_hz, order)` or `jaxsdp.Smoothing(cutoff_hz, nvr)`, `drop`, `decimate`, `mode`);
      None: `Preprocessing.emps()`, the benchmark's (Butterworth order 4 at 100 Hz, central differences, 49
      samples dropped, decimation by 10, MATLAB mode).
    - `iv`: None (IDIM-LS only), or a `jaxsdp.IDIMIV` to add the IDIM-IV of
      the asymmetric model (`emps_idim_iv`: instruments from the identified model simulated in the data's
      closed loop; needs an `EMPSData` with its reference `qg`): `IDIMIV()` the bias-compensated IV (20
      iterations at most, tolerance 1e-4, HAC standard deviations), `IDIMIV(compensate=False)` the plain IDIM-IV
      of Janot et al. (2014), which does not remove the processing bias.
    - `sdp`: the SDP stage's back-fitting, a `jaxsdp.Backfitting` (`emps_sdp_stage`): `model`, the NVR search
      (`jaxsdp.MLNVR(nvr0, max_nvr)` by gradient, `jaxsdp.CaptainNVR(nvr0, max_nvr)` the CAPTAIN toolbox's
      simplex search on the host, or `jaxsdp.FixedNVR(nvr)`), `constant_nvr` (a mass NVR below it calls the mass
      constant), ...; None: random-walk terms, ML NVRs from 1e-4 capped at 1, `constant_nvr` 1e-6.
    - `check_decimation`: also run the SDP stage at half and twice the decimation factor
      and report the mass-constancy flag at each (`EMPSStudy.mass_check`); a
      flag that changes is reported as a fragile finding in `warnings`.
    - `check_simulation`: also simulate the identified IDIM-LS model in the
      data's closed loop against the data (`simulation_check`; skipped for a
      record without reference, e.g. a CSV file).
    - `friction`: None (the paper's linear laws only), a friction law of `jaxsdp.plants` (`Stribeck()`, ...) or a
      tuple of them (the one of least BIC is chosen): the law estimated with the mass
      and the offset on the decimated rows, its held-out error beside the asymmetric linear law's, its distance to
      the SDP friction curve (`emps_friction`; `EMPSStudy.friction`, stage `friction`).
    - `source`: description for the summary (default: file name or type).
    - `progress`: optional callback called with each stage name before it runs.
    - `method`: the Kalman and IIR kernels of every stage ("sequential",
      "parallel", "auto"; None: the current setting, see `jaxsdp.set_kernel_method`).

    Stages (keys of `timings`): `simulate_plant` (built-in plant) or `load`
    (0 unless `data` is a path), `derivatives`, `identification` (the
    study's `EMPSPipeline`: IDIM-LS, the SDP stage with its NVR search,
    IDIM-SDP and IDIM-IV, in one call), `decimation_check`, `simulation`, and
    `total`. Times include JAX compilation the first time a shape is seen.

    **Returns:** an `EMPSStudy`: `idim`, `idim_asym` (IDIM-LS), `sdp`,
    `idim_sdp`, `idim_iv`, `simulation`, `recovery`, `warnings`, `findings`;
    `jaxsdp.studies.emps.summary`, `report`, `text` and `figures` present it.

    **Raises:** `ValueError` for bad options or unusable data (checked before
    any processing: `check_emps_data`).

    Example:
        >>> import jaxsdp
        >>> from jaxsdp.data import emps_builtin_data
        >>> data, truth, _ = emps_builtin_data(0)  # simulated EMPS, M = 95.15 kg
        >>> study = emps_study(data, check_decimation=False)
        >>> round(study.idim_asym["M"], 1), study.sdp.mass_constant, study.plausible
        (95.4, True, True)
        >>> builtin = emps_study(check_decimation=False)  # the same plant, its truth known
        >>> round(builtin.recovery["idim_ls_asym"]["M"], 2)  # error %
        0.25
        >>> captain = emps_study(data, sdp=jaxsdp.Backfitting(model="RW", nvr=jaxsdp.CaptainNVR()),
        ...                      check_decimation=False, check_simulation=False)
        >>> captain.sdp.nvr_search, captain.sdp.mass_constant
        ('captain', True)
    """
    preprocessing = Preprocessing.emps() if preprocessing is None else preprocessing
    sdp = DEFAULT_SDP if sdp is None else sdp
    for name, value, kind in (("preprocessing", preprocessing, Preprocessing), ("sdp", sdp, Backfitting)):
        if not isinstance(value, kind):
            raise ValueError(f"`{name}` must be a jaxsdp.{kind.__name__} or None; got {value!r}")
    if iv is not None and not isinstance(iv, IDIMIV):
        raise ValueError(f"`iv` must be a jaxsdp.IDIMIV or None; got {iv!r}")
    estimator = estimator_name(iv)
    derivatives = "butterworth" if isinstance(preprocessing.derivatives, Butterworth) else "smooth"
    cutoff_hz = preprocessing.derivatives.cutoff_hz
    timed = StageTimer(progress)
    truth, data_info = None, {}
    if data is None:
        noise_seed = 0 if seed is None else seed
        if isinstance(noise_seed, bool) or not isinstance(noise_seed, (int, np.integer)) or not 0 <= noise_seed < 2**32:
            raise ValueError(f"`seed` must be an integer in [0, 2**32); got {seed!r}")
        data, truth, data_info = timed("simulate_plant", lambda: emps_builtin_data(int(noise_seed)))
        name = f"built-in EMPS plant (seed {int(noise_seed)})"
    else:
        if seed is not None:
            raise ValueError("`seed` sets the built-in plant's measurement noise; it applies with data=None only")
        data, name = timed("load", lambda: load_record(data))
        if data.path is not None:
            name = pathlib.Path(data.path).name
            data_info["path"] = data.path
        if data.resampled is not None:
            data_info["resampled"] = data.resampled
    if isinstance(data, EMPSData):  # the record's drive gain (N/V) and controller gains
        data_info.update(gtau=float(data.gtau), kp=float(data.kp), kv=float(data.kv))
    decimate = preprocessing.decimate
    check_emps_data(data, drop=preprocessing.drop, decimate=decimate, cutoff_hz=cutoff_hz)
    if iv is not None and not isinstance(data, EMPSData):
        raise ValueError(
            f"`iv` (IDIM-IV, {estimator!r}) simulates the closed loop to build its instruments and needs the reference "
            "position `qg` and the controller gains: an EMPS .mat record or the built-in plant, "
            "not a CSV of t, q, force"
        )
    inputs = timed("derivatives", lambda: emps_preprocess(data, **preprocessing._options()))

    def identify():
        pipeline, search_se = study_pipeline(inputs, preprocessing=preprocessing, iv=iv, sdp=sdp)
        return pipeline, search_se, pipeline.estimate(inputs, data if pipeline.iv is not None else None)

    pipeline, search_se, fit = timed("identification", identify)
    fitted = fits_from(fit, search_se=search_se, **stage_options(sdp))
    idim, idim_asym, stage, idim_sdp, _ = fitted
    idim_iv, iv_warnings = iv_result(fit, pipeline.iv)
    laws = None
    if friction is not None:
        laws = (friction,) if isinstance(friction, FrictionLaw) else tuple(friction)
        if not laws or not all(isinstance(law, FrictionLaw) for law in laws):
            raise ValueError(f"`friction` must be None, a jaxsdp.plants friction law or a tuple of them; got {laws!r}")
    curve = np.asarray(stage.friction) if np.shape(stage.friction) == np.shape(inputs.dq) else None
    law_fit = None if laws is None else timed("friction", lambda: emps_friction(inputs, laws=laws, curve=curve))
    mass_check = {}
    if check_decimation:
        mass_check = timed("decimation_check", lambda: decimation_check(data, stage, preprocessing, sdp))
    physical, fit = fitted.checks(None if idim_iv is None else {"IDIM-IV (asymmetric friction)": idim_iv.result})
    scale_checks, scale_warnings = fitted.scales(inputs)
    physical = scale_warnings + physical
    warnings = physical + fit + mass_check_warnings(mass_check, decimate)
    warnings += iv_warnings
    study = EMPSStudy(
        inputs=inputs,
        idim=idim,
        idim_asym=idim_asym,
        sdp=stage,
        idim_sdp=idim_sdp,
        idim_iv=idim_iv,
        timings=timed.timings,
        source=name if source is None else source,
        samples=int(np.shape(data.force)[0]),
        sample_time=float(data.dt),
        preprocessing=inputs.description,
        derivatives=derivatives,
        estimator=estimator,
        warnings=tuple(warnings),
        mass_check=mass_check,
        plausible=not physical,
        scale_checks=tuple(scale_checks),
        data_info=data_info,
        versions=versions(),
        fast_loops=fast_loops(),
        friction=law_fit,
    )
    simulation = timed("simulation", lambda: simulation_check(data, study)) if check_simulation else None
    if simulation is not None and simulation.get("reproduces") is False:
        limits = simulation["limits"]
        bad = ", ".join(f"{k} {simulation[k]:.4g} % (limit {limits[k]:g} %)" for k in simulation["failed"])
        warnings.append(
            f"closed-loop simulation: the identified IDIM-LS model does not reproduce the data ({bad}): the model "
            "or the data are wrong; check the units (position in m, force in N, time in s) and the controller "
            "gains of the record"
        )
    rec = None
    if truth is not None:
        rec = recovery(study_summary(dataclasses.replace(study, simulation=simulation, truth=truth)), truth)
        warnings += rec["warnings"]
    study = dataclasses.replace(
        study, simulation=simulation, truth=truth, recovery=rec, warnings=tuple(warnings), timings=timed.total()
    )
    return dataclasses.replace(study, findings=tuple(findings(study, study_summary(study))))
