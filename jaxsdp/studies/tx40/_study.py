"""The TX40 study (paper section 3): one joint's IDIM-LS and multi-SDP from joint logs, with Tables 4-5.

`tx40_study` runs the stages (`_stages`) in order with per-stage timings,
collects the warnings a careful engineer would raise (physically impossible
signs, collinearity, NVRs on a bound, no convergence, serially correlated
residuals, SDP curves away from their parametric shapes) and returns a
`TX40Study`: tables laid out like the paper's Tables 4 and 5, a JSON-ready
`summary()`. The built-in data (`jaxsdp.data.tx40_builtin_data`) are the
"only link 2 moving" experiment simulated from Table 4; real logs are read
with `jaxsdp.data.load_joint_logs`.
"""

import dataclasses
import pathlib
import time
from collections.abc import Callable
from typing import Literal

import equinox as eqx
import numpy as np

from ..._checks import OptionError
from ..._idim.trust import bound_advice, conditioning_warnings, nvr_bound, sign_warnings
from ..._runtime import follows_method, x64
from ..._sdp.multi import MultiBackfitting
from ..._signal.preprocess import Preprocessed, Preprocessing
from ...data._joint_logs import JointLogs
from ...data._model_convention import coupling_transmission, model_convention
from ...plants.emps._checks import MIN_DECIMATED
from ...plants.robot._joint_full import (
    MAX_GRAVITY_DEVIATION,
    JointFullModel,
    check_all_joints,
    coupling_explained,
    full_rigid_torque,
    joint_full_model,
)
from ...plants.robot._joint_stages import (
    JOINT_PREPROCESSING,
    MIN_SPEED,
    REST_FRACTION,
    SHAPE_THRESHOLD,
    JointIDIM,
    JointSDP,
    joint_idim_ls,
    joint_multi_sdp,
    joint_preprocess,
    moving_mask,
)
from ...plants.robot._motion import joint_motion
from .._contract import Study, fast_loops, versions
from .._output import StageTimer
from ._checks import scale_checks
from ._checks import settings_check as run_settings_check
from ._figures import tx40_figures
from ._options import FullModel, TX40Builtin
from ._paper import choose_reference, reference_table
from ._report import findings, recovery, recovery_warnings, report_markdown, study_summary, study_tables, text_output

#: Stages of `tx40_study` (keys of `timings`, besides `total`).
STAGES = ("load", "derivatives", "idim_ls", "sdp")
#: The stage of `settings_check=True` (after "sdp").
CHECK_STAGE = "settings_check"
#: Further stages with `full_model=True`.
FULL_STAGES = ("full_model", "full_model_sdp")
_UNITS = {"ZZ": "kg m^2", "MX": "kg m", "MY": "kg m", "Fv": "N m s/rad", "Fc": "N m", "offset": "N m"}


class TX40Study(Study):
    """All results of `tx40_study` for one joint.

    **Fields:** `inputs` (`Preprocessed`), `idim` (`JointIDIM`: IDIM-LS of
    eq. 22 and its residual whiteness), `sdp` (`JointSDP`: multi-SDP with the
    inertia fixed, projections, relative errors, whiteness), `reference`
    (name -> value or None) and `reference_label`, `published` (the paper's
    estimates for the chosen table, or None), `truth` (the simulated truth
    for built-in data, else None), `joint`, `timings` (stage -> s), `source`,
    `samples` (raw), `sample_time` (raw, s), `preprocessing`, `settings`
    (the options, for the report), `warnings`, `plausible`.

    With `full_model=True`: `full` (`JointFullModel`: IDIM-LS with the
    six-joint rigid-body model's base parameters), `full_sdp` (`JointSDP`:
    the multi-SDP of the full model's residual, its rigid-body torque known)
    and `coupling` (`coupling_explained`: how much of the one-joint SDP
    curves' departure from eq. (20) the coupling torque explains); else None.

    `data_files`: the log files the built-in experiment wrote (names, in
    `logs_dir`); `findings`: the conclusions in words, each with its evidence;
    `versions` (jaxsdp, jax) and `fast_loops`; `motion` (`joint_motion` of
    the logs: which joints move), `reference_name` and `reference_reason`
    (which table, and why); `checks` (`settings_check`: the shape verdict
    and the IDIM-LS estimates at neighbouring settings; None with
    `settings_check=False`); `scale_checks` (`_checks.scale_checks`: the
    identified inertia against the description, with the likely cause of a
    mismatch: time scale, units).
    """

    inputs: Preprocessed
    idim: JointIDIM
    sdp: JointSDP
    timings: dict
    reference: dict | None = eqx.field(static=True)
    reference_label: str = eqx.field(static=True)
    published: dict | None = eqx.field(static=True)
    truth: dict | None = eqx.field(static=True)
    joint: int = eqx.field(static=True)
    source: str = eqx.field(static=True)
    samples: int = eqx.field(static=True)
    sample_time: float = eqx.field(static=True)
    preprocessing: str = eqx.field(static=True)
    settings: dict = eqx.field(static=True)
    warnings: tuple = eqx.field(static=True, default=())
    plausible: bool = eqx.field(static=True, default=True)
    full: JointFullModel | None = None
    full_sdp: JointSDP | None = None
    coupling: dict | None = eqx.field(static=True, default=None)
    data_files: tuple = eqx.field(static=True, default=())
    findings: tuple = eqx.field(static=True, default=())
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)
    motion: dict = eqx.field(static=True, default_factory=dict)
    reference_name: str = eqx.field(static=True, default="none")
    reference_reason: str = eqx.field(static=True, default="")
    checks: dict | None = eqx.field(static=True, default=None)
    scale_checks: tuple = eqx.field(static=True, default=())

    @property
    @x64
    def shape_verdict(self) -> str:
        """ "mismatch" or "match" (the SDP curves against eq. (20)'s shapes); "fragile" when the neighbouring
        settings of `checks` disagree."""
        if self.checks is not None:
            return self.checks["verdict"]
        return "mismatch" if self.sdp.shape.mismatch else "match"

    @x64
    def names(self) -> dict:
        """Generic name (ZZ, MX, ...) -> this joint's parameter name (ZZ2, MX2, ...)."""
        return {k: f"{k}{self.joint}" for k in ("ZZ", "Fv", "Fc", "MX", "MY", "offset")}

    @x64
    def sdp_estimates(self) -> dict:
        """The IDIM-SDP column: name -> (value, relative std %) from the projections; the offset is the sum."""
        n, s = self.names(), self.sdp
        out = {}
        for k, src in (("Fv", s.friction), ("Fc", s.friction), ("MX", s.gravity), ("MY", s.gravity)):
            p = src.param(n[k])
            out[n[k]] = (p.value, p.rel_std)
        rel = 100.0 * s.offset_sum_std / abs(s.offset_sum) if s.offset_sum != 0 else float("inf")
        out[n["offset"]] = (s.offset_sum, rel)
        return out

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp tx40`): the IDIM-LS and multi-SDP estimates (ZZ kg m^2, MX
        and MY kg m, Fv N m s/rad, Fc and offset N m) with their relative standard deviations (%) and relative
        errors (%), the residual whiteness, the reference table, the recovery of a known truth, the full model
        when run, `data`, `settings`, `warnings`, `timings` (s) and `versions`."""
        return study_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md` of `jaxsdp tx40`): warnings, data and settings, the Table 4/5 layout
        (estimates in kg m^2, kg m, N m s/rad, N m; relative standard deviations %), recovery, whiteness, the
        paper's estimates, findings, the figures (name -> file name, embedded when given) and the timings (s)."""
        return report_markdown(self, list(dict(figures or {}).values()))

    @x64
    def text(self) -> str:
        """What `jaxsdp tx40` prints: the data line, the Table 4/5 layout (kg m^2, kg m, N m s/rad, N m;
        relative standard deviations %), the multi-SDP outcome and the residual whiteness (the warnings are
        printed once, on stderr, by the command)."""
        return text_output(self)

    @x64
    def figures(self) -> dict:
        """Every figure (name -> matplotlib Figure; angles rad, speeds rad/s, torques N m), keyed by its file
        stem: the paper's Figs. 7-9 (10-11 when all links move), the residual autocorrelation, and
        `fig_full_model` when the full model ran (`tx40_figures`)."""
        return tx40_figures(self)

    @x64
    def tables(self, *, warnings: bool = True) -> str:
        """The paper's Table 4/5 layout as text (IDIM-LS, IDIM-SDP, reference), after the warnings."""
        return study_tables(self, warnings=warnings)


def backfit_warnings(sdp: JointSDP, label: str, terms: tuple, max_nvr) -> list[str]:
    """A multi-SDP's NVRs on a bound of their search and a back-fitting that did not converge, as warnings."""
    res, out = sdp.result, []
    for term, nvr in zip(terms, np.asarray(res.nvr, dtype=float)):
        bound = nvr_bound(float(nvr), max_nvr=max_nvr, lower_log10=-12.0)
        if bound is not None:
            option = "`max_nvr` of MultiBackfitting, tx40_study's `sdp`, in Python"
            out.append(f"{label}: " + bound_advice(term, bound, option=option))
    if not bool(res.converged):
        out.append(
            f"{label}: back-fitting stopped after {int(res.iterations)} iterations without meeting tol = "
            f"{sdp.tol:g}; the curves may still move (raise max_iter)"
        )
    return out


def study_warnings(idim: JointIDIM, sdp: JointSDP, joint: int, max_nvr) -> tuple[list[str], list[str]]:
    """(physical, other) warnings of a TX40 study's IDIM-LS and multi-SDP."""
    n = {k: f"{k}{joint}" for k in ("ZZ", "Fv", "Fc")}
    units = {f"{k}{joint}": u for k, u in _UNITS.items()}
    physical = sign_warnings(
        idim.result, label="IDIM-LS", positive=(n["ZZ"],), nonnegative=(n["Fv"], n["Fc"]), units=units
    )
    physical += sign_warnings(
        sdp.friction, label="IDIM-SDP friction projection", nonnegative=(n["Fv"], n["Fc"]), units=units
    )
    other = conditioning_warnings(
        idim.result,
        np.asarray(idim.regression.X)[np.asarray(idim.moving)],
        label="IDIM-LS",
        check=(n["ZZ"], n["Fv"], n["Fc"]),
    )
    other += backfit_warnings(sdp, "multi-SDP", ("d_q(q) (gravity)", "d_dq(dq) (friction)"), max_nvr)
    for label, w in (("IDIM-LS", idim.whiteness), ("multi-SDP", sdp.whiteness)):
        if not bool(w.white):
            other.append(
                f"{label} residual is serially correlated ({w.text()}): the model leaves structure in the torque "
                "(unmodelled dynamics, e.g. coupling with moving joints) or the torque noise is coloured; the "
                "relative standard deviations are then optimistic"
            )
    if sdp.shape.mismatch:
        other.append(
            f"the SDP curves depart from the parametric shapes of eq. (20): {sdp.shape.evidence()}; curve minus "
            f"projection: gravity {sdp.mismatch[0]:.1f} %, friction {sdp.mismatch[1]:.1f} % of the torque; the "
            "one-joint model misses effects the SDP curves capture (the paper's all-joints case: coupling of the "
            "moving links)"
        )
    return physical, other


def shape_warnings(check: dict | None) -> list[str]:
    """A warning when the shape verdict changes with the processing settings (`settings_check`)."""
    if check is None or check["verdict"] != "fragile":
        return []
    rows = ", ".join(f"{r['setting']}: {r['statistic']:.1f} %" for r in check["shape"])
    return [
        f"the shape verdict is fragile: whether the SDP curves depart from eq. (20)'s shapes changes with the "
        f"processing ({rows}; threshold {SHAPE_THRESHOLD:g} %): do not read either verdict from this record alone"
    ]


def full_model_warnings(full: JointFullModel, sdp: JointSDP, joint: int, max_nvr) -> tuple[list[str], list[str]]:
    """(physical, other) warnings of the full-model IDIM-LS and of the multi-SDP of its residual."""
    units = {f"Fv{joint}": _UNITS["Fv"], f"Fc{joint}": _UNITS["Fc"]}
    fric = (f"Fv{joint}", f"Fc{joint}")
    physical = sign_warnings(full.result, label="full-model IDIM-LS", nonnegative=fric, units=units)
    physical += sign_warnings(sdp.friction, label="full model + SDP friction projection", nonnegative=fric, units=units)
    if not full.gravity_deviation <= MAX_GRAVITY_DEVIATION:
        physical.append(
            f"full-model IDIM-LS: joint {joint}'s identified gravity torque is {full.gravity_deviation:.0f} % away "
            "from the nominal robot's (more than a CAD model's error): the logs' joint angles are probably not in the "
            "model's convention; check the joint-angle offsets and the wrist coupling (`joint_offsets`, "
            "`wrist_coupling`)"
        )
    poor = full.poorly_excited()
    other = []
    if poor:
        other.append(
            f"full-model IDIM-LS: {len(poor)} of {full.model.rank} base parameters are not excited by this trajectory "
            f"(relative standard deviation > 100 %: {', '.join(poor)}); their estimates are meaningless, the fit "
            "and the well-determined ones are not affected"
        )
    if not bool(full.whiteness.white):
        other.append(
            f"full-model IDIM-LS residual is serially correlated ({full.whiteness.text()}): the rigid-body model "
            "leaves structure in the torque (friction's shape, flexibility) or the torque noise is coloured"
        )
    other += backfit_warnings(sdp, "full model + SDP", ("d_q(q)", "d_dq(dq) (friction)"), max_nvr)
    return physical, other


@x64
@follows_method
def tx40_study(
    logs: JointLogs | TX40Builtin | None = None,
    *,
    joint: int = 2,
    preprocessing: Preprocessing | None = None,
    min_speed: float | Literal["auto"] = MIN_SPEED,
    inertia: float | None = None,
    sdp: MultiBackfitting | None = None,
    full_model: FullModel | None = None,
    reference="auto",
    settings_check: bool = True,
    truth: dict | None = None,
    progress: Callable[[str], None] | None = None,
    method: str | None = None,
) -> TX40Study:
    r"""Run the TX40 study of one joint: preprocessing, IDIM-LS (eq. 22), multi-SDP (section 3.3), projections.

    The joint is seen as a one-degree-of-freedom arm (eq. 20),
    $\tau = ZZ \ddot q - g MX \cos q + g MY \sin q + F_v \dot q + F_c sign(\dot q) + offset + e$
    (N m), identified by IDIM-LS on the samples in motion, then by multi-SDP
    back-fitting $\tau - ZZ \ddot q = d_q(q) + d_{\dot q}(\dot q) + e$ with the
    inertia fixed, and each curve's least-squares projection on its
    parametric shape (the paper's IDIM-SDP estimates).

    **Defaults** (what the report states): Butterworth order 4 at 100 Hz on
    the joint angle and central differences (the EMPS benchmark's and the
    paper's processing), the first 100 samples (20 ms) dropped, decimation
    by 10 (5 kHz -> 500 Hz, MATLAB-compatible: `Preprocessing(Butterworth(100.0,
    4), drop=100, decimate=10)`), samples at rest (|dq| below 1 % of the joint's peak speed, "auto") left
    out of IDIM-LS and of the curves' projections (the back-fitting uses
    every sample), the inertia of the multi-SDP fixed at the IDIM-LS
    estimate, RW for both SDPs with ML NVRs at every iteration (cap 1), tol
    1 % (the paper's), at most 20 iterations (`MultiBackfitting()`).

    **Arguments:**

    - `logs`: a `JointLogs` (joint side, `jaxsdp.data.load_joint_logs`; its
      `source` names it in the report), or a `TX40Builtin` (a built-in
      experiment written as real TX40 logs and read back: `case` "link2",
      only link 2 moving, its truth known, or "all", all six joints moving on
      the nominal TX40; noise `seed`; `logs_dir`), or None for `TX40Builtin()`.
    - `joint`: its number in the logs (default 2).
    - `preprocessing`: a `jaxsdp.Preprocessing` (derivatives, drop,
      decimation; `joint_preprocess`), or None for the defaults above.
    - `min_speed`: the rest threshold (rad/s), or "auto" (1 % of the joint's
      peak speed, `rest_threshold`).
    - `inertia`: None (IDIM-LS) or a value (kg m^2, e.g. CAD).
    - `sdp`: the multi-SDP's back-fitting, a `jaxsdp.MultiBackfitting`
      (`model`, `tol`, `max_iter`, `max_nvr`), or None for the defaults above.
    - `full_model`: None, or a `FullModel` (beyond the paper; the logs must
      hold all joints): the joint is also identified with the full rigid-body
      model of `FullModel.robot` (default `jaxsdp.plants.tx40_robot()`: its
      kinematics, and its nominal parameters as the comparison), after
      bringing the logs to its convention (`jaxsdp.data.model_convention`
      with `joint_offsets`, rad per joint, and `wrist_coupling`, a pair of
      joints or None; the TX40's by default), then the multi-SDP of its
      residual with the rigid-body torque known. Without it, the scale check
      of the inertia uses the nominal TX40 in the TX40's convention (the
      simulated robot for `TX40Builtin(case="all")`).
    - `reference`: "auto" (default: the paper's table of the experiment the
      logs come from, `choose_reference`: Table 5 when other joints move
      besides the identified one, Table 4 when only it moves, none for a
      joint other than 2), "table4", "table5", "none"/None or a dict
      name -> value for the tables' reference column.
    - `settings_check`: re-run the shape test and IDIM-LS at neighbouring
      settings (`_checks.settings_check`; a "fragile" shape verdict is warned).
    - `truth`: known true values (simulated logs; the built-in experiment
      brings its own).
    - `progress`: callback called with each stage name (`STAGES`, then
      `FULL_STAGES`) before it runs; `method`: the Kalman and IIR kernels of
      every stage (None: the current setting, see `jaxsdp.set_kernel_method`).

    **Returns:** a `TX40Study` (`tables()`, `summary()`, `warnings`).

    Example:
        >>> from jaxsdp import Butterworth, MultiBackfitting, Preprocessing
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.studies.tx40 import tx40_study
        >>> logs, truth, _, _ = tx40_builtin_data()
        >>> study = tx40_study(logs, truth=truth)
        >>> round(study.idim.result["Fv2"], 1), bool(study.sdp.result.converged), study.plausible
        (5.7, True, True)
        >>> slower = Preprocessing(Butterworth(50.0, 4), drop=100, decimate=20)
        >>> s = tx40_study(logs, preprocessing=slower, sdp=MultiBackfitting(tol=0.005), settings_check=False)
        >>> s.settings["decimate"], s.settings["cutoff_hz"], s.settings["tol"]
        (20, 50.0, 0.005)
    """
    built = None
    full = full_model
    if logs is None or isinstance(logs, TX40Builtin):
        builtin = TX40Builtin() if logs is None else logs
        if truth is not None or (full is not None and full.robot is not None):
            raise ValueError(
                "`truth` and `FullModel.robot` come with the built-in experiment (logs None or a TX40Builtin); "
                "give them with JointLogs"
            )
    elif not isinstance(logs, JointLogs):
        raise ValueError(
            "`logs` must be a JointLogs (jaxsdp.data.load_joint_logs), a TX40Builtin (a built-in experiment) or "
            f"None; got {type(logs).__name__}"
        )
    pre = JOINT_PREPROCESSING if preprocessing is None else preprocessing
    if not isinstance(pre, Preprocessing):
        raise ValueError(f"`preprocessing` must be None or a jaxsdp.Preprocessing(...); got {type(pre).__name__}")
    sdp = MultiBackfitting() if sdp is None else sdp
    if not isinstance(sdp, MultiBackfitting):
        raise ValueError(f"`sdp` must be None or a jaxsdp.MultiBackfitting(...); got {type(sdp).__name__}")
    if full is not None and not isinstance(full, FullModel):
        raise ValueError(f"`full_model` must be None or a FullModel(...); got {type(full).__name__}")
    if inertia is not None and not (np.isfinite(inertia) and inertia > 0):
        raise ValueError(f"`inertia` must be None or a positive finite value (kg m^2); got {inertia!r}")
    if not (isinstance(reference, str) and reference == "auto"):
        reference_table(reference)  # a bad value fails before any work
    description = FullModel() if full is None else full
    robot, joint_offsets, wrist_coupling = description.robot, description.joint_offsets, description.wrist_coupling
    source = None
    timed = StageTimer(progress, {"load": 0.0})
    if not isinstance(logs, JointLogs):
        if progress is not None:
            progress("simulate")
        t0 = time.perf_counter()
        built = _builtin_data(builtin.case, int(builtin.seed), builtin.logs_dir)
        timed.timings["load"] = time.perf_counter() - t0
        logs = built.logs
        truth, robot = (built.truth, None) if builtin.case == "link2" else (None, built.truth["robot"])
        source = BUILTIN_SOURCES[builtin.case]
    logs.joint(joint)  # ValueError naming the available joints
    motion = joint_motion(logs)
    reference, reference_reason = choose_reference(reference, motion, joint)
    ref, ref_label, published = reference_table(reference)
    if full is not None:
        from ...plants.robot._tx40 import tx40_robot

        robot = tx40_robot() if robot is None else robot
        check_all_joints(logs, robot)  # before the convention, whose errors would name its own arguments
        model_logs = model_convention(logs, offsets=joint_offsets, coupling=wrist_coupling)  # fails early
    pre_kw = pre._options()
    drop, decimate = pre.drop, pre.decimate
    samples = int(logs.q.shape[0])
    if samples - drop < MIN_DECIMATED * decimate:
        raise (OptionError if samples - drop >= MIN_DECIMATED else ValueError)(
            f"the logs hold {samples} samples ({samples * float(logs.dt):.3g} s); after the first {drop} (dropped: "
            f"the filter's start-up) decimation by {decimate} leaves {max(samples - drop, 0) // decimate}, and the "
            f"fits need at least {MIN_DECIMATED}: "
            + ("use a smaller decimation (`decimate`)" if samples - drop >= MIN_DECIMATED else "use a longer record")
        )
    inputs = timed("derivatives", lambda: joint_preprocess(logs, joint=joint, **pre_kw))
    moving_mask(inputs, min_speed)  # fails early on a joint that does not move
    idim = timed("idim_ls", lambda: joint_idim_ls(inputs, joint=joint, min_speed=min_speed))
    zz = idim.result[f"ZZ{joint}"] if inertia is None else float(inertia)
    if not zz > 0:
        raise ValueError(
            f"IDIM-LS gives ZZ{joint} = {zz:.4g} kg m^2 <= 0: the multi-SDP needs a positive inertia; "
            "pass a CAD value (`inertia`)"
        )
    one = timed(
        "sdp",
        lambda: joint_multi_sdp(
            inputs,
            inertia=zz,
            inertia_source="IDIM-LS" if inertia is None else "given",
            moving=idim.moving,
            joint=joint,
            sdp=sdp,
        ),
    )
    checks = None
    if settings_check:
        if published is not None:
            rsd = published["idim_ls_rsd"]
            scales = {k: abs(published["idim_ls"][k]) * rsd[k] / 100.0 for k in rsd}
        else:
            scales = {k: float(v) for k, v in zip(idim.result.names, np.asarray(idim.result.std))}
        checks = timed(
            CHECK_STAGE,
            lambda: run_settings_check(
                logs,
                inputs=inputs,
                idim=idim,
                sdp=one,
                settings={
                    "joint": joint,
                    "min_speed": min_speed,
                    "decimate": decimate,
                    "cutoff_hz": pre_kw["cutoff_hz"],
                    "inertia": "IDIM-LS" if inertia is None else inertia,
                },
                pre_kw=pre_kw,
                sdp_kw=dict(sdp=sdp),
                scales=scales,
            ),
        )
    physical, other = study_warnings(idim, one, joint, sdp.max_nvr)
    scale_kw = dict(joint=joint, reference=ref, basis=f"the {ref_label}", robot=robot, offsets=joint_offsets)
    scales, scale_warnings = scale_checks(logs, inputs, idim, coupling=wrist_coupling, **scale_kw)
    physical = scale_warnings + physical
    other += shape_warnings(checks)
    full_fit = full_sdp = coupling = None
    if full is not None:
        full_fit, own = timed(
            "full_model",
            lambda: joint_full_model(
                model_logs,
                robot=robot,
                joint=joint,
                min_speed=min_speed,
                preprocessing=pre_kw,
                transmission=coupling_transmission(robot.n, wrist_coupling),
            ),
        )
        full_sdp = timed(
            "full_model_sdp",
            lambda: joint_multi_sdp(
                own,
                known=full_rigid_torque(full_fit),
                inertia_source="full rigid-body model",
                moving=moving_mask(own, min_speed),  # full.moving, or in the coupled motor's coordinate
                joint=joint,
                sdp=sdp,
            ),
        )
        coupling = coupling_explained(full_fit, one)
        p2, o2 = full_model_warnings(full_fit, full_sdp, joint, sdp.max_nvr)
        physical, other = physical + p2, other + o2
    timings = timed.total()
    settings = {
        "joint": int(joint),
        "derivatives": pre_kw["derivatives"],
        "cutoff_hz": pre_kw["cutoff_hz"],
        "order": pre_kw["order"],
        "drop": drop,
        "decimate": decimate,
        "mode": pre.mode,
        "min_speed": idim.min_speed,
        "min_speed_rule": (
            f"auto: {100 * REST_FRACTION:g} % of the joint's peak speed" if isinstance(min_speed, str) else "given"
        ),
        "inertia": "IDIM-LS" if inertia is None else float(inertia),
        "model": list(one.model),
        "tol": float(sdp.tol),
        "max_iter": int(sdp.max_iter),
        "max_nvr": sdp.max_nvr,
        "nvr": "maximum likelihood at every iteration"
        if sdp.optimise_on == "all"
        else "maximum likelihood on the first iteration",
        "full_model": full is not None,
    }
    if full is not None:
        settings["joint_offsets"] = [float(v) for v in np.asarray(joint_offsets if joint_offsets is not None else [])]
        settings["wrist_coupling"] = None if wrist_coupling is None else [int(v) for v in wrist_coupling]
    study = TX40Study(
        inputs=inputs,
        idim=idim,
        sdp=one,
        timings=timings,
        reference=ref,
        reference_label=ref_label,
        published=published,
        truth=None if truth is None else {k: float(v) for k, v in truth.items()},
        joint=int(joint),
        source=logs.source if source is None else source,
        samples=int(logs.q.shape[0]),
        sample_time=float(logs.dt),
        preprocessing=inputs.description,
        settings=settings,
        warnings=tuple(physical + other),
        plausible=not physical,
        scale_checks=tuple(scales),
        full=full_fit,
        full_sdp=full_sdp,
        coupling=coupling,
        data_files=() if built is None else tuple(pathlib.Path(f).name for f in built.files or ()),
        versions=versions(),
        fast_loops=fast_loops(),
        motion=motion,
        reference_name=reference if isinstance(reference, str) else ("given" if reference is not None else "none"),
        reference_reason=reference_reason,
        checks=checks,
    )
    rec_warnings = recovery_warnings(recovery(study))
    if rec_warnings:
        study = dataclasses.replace(study, warnings=study.warnings + tuple(rec_warnings))
    return dataclasses.replace(study, findings=tuple(findings(study)))


#: What the built-in experiments are called in the report.
BUILTIN_SOURCES = {
    "link2": "built-in TX40 'only link 2 moving' experiment (simulated from the paper's Table 4)",
    "all": "built-in TX40 'all joints moving' experiment (the nominal six-joint TX40)",
}


def _builtin_data(case: str, seed: int, folder):
    from ...data._tx40_all_joints import tx40_all_joints_data
    from ...data._tx40_builtin import tx40_builtin_data

    make = tx40_builtin_data if case == "link2" else tx40_all_joints_data
    return make(folder, seed=seed)
