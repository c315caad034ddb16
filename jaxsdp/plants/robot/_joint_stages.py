"""The stages of the TX40 study for one joint: preprocessing, IDIM-LS (eq. 22), multi-SDP (section 3.3).

1. `joint_preprocess`: the EMPS benchmark's processing of one joint's log
   (`jaxsdp.preprocess`: zero-phase Butterworth on the angle, central
   differences, border removal, decimation; smoothing derivatives as an option).
2. `joint_idim_ls`: IDIM-LS with the basis of eq. (22),
   `[ddq, -g cos q, g sin q, dq, sign dq, 1]` (parallel decimation), on the
   samples in motion (|dq| >= `min_speed`, by default 1 % of the joint's
   peak speed: at rest the joint is held by static friction, which eq. (21)
   does not describe), with the residual whiteness test.
3. `joint_multi_sdp`: tau - ZZ ddq = d_q(q) + d_dq(dq) + e by multi-SDP
   back-fitting with the inertia fixed (IDIM-LS, or a CAD value) on every
   sample (the curves are free functions: near dq = 0 the friction curve
   takes the torque that holds the joint), then the parametric projection of
   each curve on the samples in motion, gravity on `[-g cos q, g sin q, 1]`
   and friction on `[dq, sign dq, 1]` (the paper's IDIM-SDP estimates), the
   two offsets and their sum, the relative errors of the SDP model and of the
   rebuilt parametric model, and the shape test (`ShapeTest`): do the curves
   depart from the parametric shapes by more than their flexibility explains?
"""

from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._idim.ls import IDIMResult, idim_ls
from ..._idim.parametric import parametric_stage
from ..._kalman.models import ParameterModel
from ..._records import JointLogs
from ..._runtime import x64
from ..._sdp.multi import MultiBackfitting, MultiSDPResult, multi_sdp
from ..._signal.preprocess import Butterworth, Preprocessed, Preprocessing, preprocess
from ..._signal.regressors import Regression
from ..._signal.whiteness import Whiteness, decimated_noise_acf, whiteness
from ._joint_model import GRAVITY, friction_basis, gravity_basis, joint_regressors

#: Samples dropped at the start of the record (20 ms at 5 kHz: the Butterworth's start-up).
DROP = 100
#: The TX40 study's processing (`tx40_study(preprocessing=None)`): Butterworth order 4 at 100 Hz and central
#: differences, the first `DROP` samples dropped, decimation by 10 (5 kHz -> 500 Hz), MATLAB-compatible.
JOINT_PREPROCESSING = Preprocessing(Butterworth(100.0, 4), drop=DROP, decimate=10, mode="matlab")
#: Default rest threshold: "auto", `REST_FRACTION` of the joint's peak speed (`rest_threshold`).
MIN_SPEED = "auto"
#: Samples slower than this share of the joint's peak speed are at rest, held by static friction...
REST_FRACTION = 0.01
#: ...and at least this speed (rad/s), so that a joint that does not move has no samples in motion.
MIN_REST_SPEED = 0.01
#: The SDP curves depart from the parametric shapes when they lower the residual variance
#: (degrees of freedom counted) by more than this share (%, `ShapeTest`).
SHAPE_THRESHOLD = 15.0
#: Lags of the whiteness test (at the decimated rate).
MAX_LAG = 20


@x64
def joint_preprocess(
    logs: JointLogs,
    *,
    joint: int = 2,
    derivatives: Literal["butterworth", "smooth"] = "butterworth",
    cutoff_hz: float | None = 100.0,
    order: int = 4,
    nvr: float | None = None,
    drop: int = DROP,
    decimate: int = 10,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
) -> Preprocessed:
    """One joint's angle and torque, processed as the EMPS benchmark (`jaxsdp.preprocess`).

    Zero-phase Butterworth (`order`, `cutoff_hz`, MATLAB padding) on the
    joint angle, central differences for dq and ddq (or, with
    `derivatives="smooth"`, smoothing derivatives), the first `drop` samples
    removed, each signal decimated by `decimate` (`mode`, MATLAB-compatible
    by default).

    **Returns:** a `Preprocessed` (q rad, dq rad/s, ddq rad/s^2, y N m).

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.studies.tx40 import joint_preprocess
        >>> p = joint_preprocess(tx40_builtin_data().logs)
        >>> p.y.shape, round(p.dt, 6)  # 500 Hz
        ((4490,), 0.002)
    """
    if not isinstance(logs, JointLogs):
        raise ValueError(f"`logs` must be a JointLogs (jaxsdp.data.load_joint_logs); got {type(logs).__name__}")
    q, tau = logs.joint(joint)
    return preprocess(
        q,
        tau,
        dt=logs.dt,
        derivatives=derivatives,
        cutoff_hz=cutoff_hz,
        order=order,
        nvr=nvr,
        drop=drop,
        decimate=decimate,
        mode=mode,
    )


def residual_whiteness(residuals, decimate: int, *, max_lag: int = MAX_LAG) -> Whiteness:
    """`jaxsdp.whiteness` of a residual at the decimated rate, against white noise decimated by `decimate`."""
    null = None if decimate == 1 else decimated_noise_acf(decimate, 50 * max_lag)
    return whiteness(residuals, max_lag=max_lag, null_acf=null)


class JointIDIM(eqx.Module):
    r"""IDIM-LS of one joint with eq. (22) (`joint_idim_ls`).

    **Fields:** `result` (`IDIMResult`: ZZ kg m^2, MX and MY kg m, Fv
    N m s/rad, Fc and offset N m), `regression` (the parallel-decimated
    `y`, `X`, `names`, all samples), `moving` (bool mask of the samples used:
    $|\dot q| \ge$ `min_speed`), `whiteness` (of the residual), `min_speed` (rad/s,
    the threshold used), `joint`; `record_fit`, `relative_error_record`
    (properties: the model over the whole record, the Coulomb term off at rest;
    its relative error, %; `result.relative_error` is over the samples used).
    """

    result: IDIMResult
    regression: Regression
    moving: jnp.ndarray
    whiteness: Whiteness
    min_speed: float = eqx.field(static=True)
    joint: int = eqx.field(static=True)

    @property
    @x64
    def record_fit(self) -> jnp.ndarray:
        """Eq. (22) with the estimates over the whole record: in motion the fit, at rest (|dq| < `min_speed`) the
        Coulomb term left out (sign(dq) is the sign of noise there; static friction holds the joint within
        +-Fc, which eq. (21) does not describe)."""
        reg = self.regression
        X = jnp.asarray(reg.X)
        coulomb = list(reg.names).index(f"Fc{self.joint}")
        X = X.at[:, coulomb].multiply(jnp.asarray(self.moving, X.dtype))
        return X @ self.result.theta

    @property
    @x64
    def relative_error_record(self) -> float:
        """100 ||y - `record_fit`|| / ||y|| (%) over the whole record, samples at rest included (the paper's
        definition)."""
        return _relerr(self.regression.y, self.record_fit)


@x64
def rest_threshold(inputs: Preprocessed, min_speed="auto") -> float:
    """The speed (rad/s) below which a decimated sample counts as at rest.

    `min_speed` "auto": `REST_FRACTION` (1 %) of the joint's peak speed
    max |dq| in the record, at least `MIN_REST_SPEED` (0.01 rad/s); 0.050
    rad/s on the real TX40 logs, whose joint 2 peaks at 5.0 rad/s. It scales
    with the trajectory, and it leaves out the samples where the velocity
    estimate's sign is not reliable and the Stribeck region, which eq. (21)
    does not describe. A number is used as given.

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.plants.robot import joint_preprocess, rest_threshold
        >>> p = joint_preprocess(tx40_builtin_data().logs)
        >>> round(rest_threshold(p), 4), rest_threshold(p, 0.05)  # rad/s: 1 % of a 2.2 rad/s peak
        (0.0225, 0.05)
    """
    if isinstance(min_speed, str):
        if min_speed != "auto":
            raise ValueError(f"`min_speed` must be 'auto' or a finite value >= 0 (rad/s); got {min_speed!r}")
        return max(REST_FRACTION * float(np.max(np.abs(np.asarray(inputs.dq)))), MIN_REST_SPEED)
    if isinstance(min_speed, bool) or not (np.isfinite(min_speed) and min_speed >= 0):
        raise ValueError(f"`min_speed` must be 'auto' or a finite value >= 0 (rad/s); got {min_speed!r}")
    return float(min_speed)


def moving_mask(inputs: Preprocessed, min_speed="auto") -> np.ndarray:
    """Decimated samples in motion, |dq| >= `rest_threshold(inputs, min_speed)`; ValueError when fewer than 20."""
    threshold = rest_threshold(inputs, min_speed)
    keep = np.abs(np.asarray(inputs.dq)) >= threshold
    if keep.sum() < 20:
        raise ValueError(
            f"only {int(keep.sum())} of {keep.size} samples move faster than min_speed = {threshold:g} rad/s: "
            "the joint hardly moves in this record (wrong joint, or lower min_speed)"
        )
    return keep


@x64
def joint_idim_ls(inputs: Preprocessed, *, joint: int = 2, min_speed=MIN_SPEED, g=GRAVITY) -> JointIDIM:
    r"""IDIM-LS of one joint as a one-degree-of-freedom arm (eqs. 20-23) on the samples in motion.

    $\tau = ZZ \ddot q - g MX \cos q + g MY \sin q + F_v \dot q + F_c sign(\dot q) + offset + e$,
    the regressors built on the full-rate signals and decimated like the
    torque (parallel decimation), the samples with $|\dot q| <$ `min_speed` left
    out (at rest, static friction holds the joint: eq. 21 does not apply;
    "auto": 1 % of the peak speed, `rest_threshold`; the value used is
    `JointIDIM.min_speed`).
    The residual is tested for whiteness against white noise through the
    decimation filter (`residual_whiteness`).

    **Returns:** a `JointIDIM` (`result`, `whiteness`, ...).

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.studies.tx40 import joint_idim_ls, joint_preprocess
        >>> ls = joint_idim_ls(joint_preprocess(tx40_builtin_data().logs))
        >>> round(ls.result["ZZ2"], 2), round(ls.result["MX2"], 2)  # truth 1.60 kg m^2, 2.80 kg m
        (1.6, 2.82)
    """
    keep = moving_mask(inputs, min_speed)
    reg = inputs.regression(joint_regressors(inputs.q_full, inputs.dq_full, inputs.ddq_full, joint=joint, g=g))
    result = idim_ls(reg.y[keep], reg.X[keep], names=reg.names)
    return JointIDIM(
        result=result,
        regression=reg,
        moving=jnp.asarray(keep),
        whiteness=residual_whiteness(result.residuals, inputs.decimate),
        min_speed=rest_threshold(inputs, min_speed),
        joint=int(joint),
    )


class ShapeTest(eqx.Module):
    r"""Do the SDP curves depart from their parametric shapes (eq. 20)? (`joint_multi_sdp`).

    On the samples in motion (at least `REST_FRACTION` of the peak speed),
    the parametric model (the curves' projections: $p = 5$ free parameters,
    MX, MY, Fv, Fc and one offset) and the SDP model (the two curves, their
    effective degrees of freedom `edf` the trace of the smoothers' hat
    matrices there) each give an unbiased residual variance,

    $$ s^2_{par} = RSS_{par} / (N - p), \quad s^2_{sdp} = RSS_{sdp} / (N - edf), $$

    and `statistic` = $100 (1 - s^2_{sdp} / s^2_{par})$ is the share of the variance
    the parametric model leaves that the curves explain after paying for
    their flexibility (a curve that only follows noise explains about its
    degrees of freedom' worth, which the counts remove). `mismatch` when it
    exceeds `threshold` (%, `SHAPE_THRESHOLD`). An effect size rather than a
    p-value: with thousands of serially correlated samples an F-test rejects
    any model, the simulated parametric truth included.

    **Fields:** `statistic`, `threshold` (%), `mismatch` (bool), `samples`
    (N), `parameters` (p), `edf`, `variance_parametric`, `variance_sdp`
    (units of the torque squared).
    """

    statistic: float
    threshold: float
    mismatch: bool
    samples: int
    parameters: int
    edf: float
    variance_parametric: float
    variance_sdp: float

    @x64
    def evidence(self) -> str:
        """The statistic and its threshold in words."""
        return (
            f"the curves explain {self.statistic:.1f} % of the residual variance the parametric model leaves, "
            f"their {self.edf:.0f} degrees of freedom counted (mismatch above {self.threshold:g} %; "
            f"{self.samples} samples in motion)"
        )

    @x64
    def text(self) -> str:
        """The verdict and its evidence."""
        verdict = "depart from" if self.mismatch else "follow"
        return f"the SDP curves {verdict} the parametric shapes: {self.evidence()}"


class JointSDP(eqx.Module):
    r"""Multi-SDP of one joint (section 3.3) and its parametric projections (`joint_multi_sdp`).

    **Fields:**

    - `result`: the `MultiSDPResult` of $y - ZZ \ddot q = d_q(q) + d_{\dot q}(\dot q) + e$
      (`d[:, 0]` gravity, `d[:, 1]` friction, N m), back-fitted on every
      sample (`fit_on="all"`, the default) or on those in motion;
    - `inertia` (kg m^2) and `inertia_source` ("IDIM-LS", "given", or the
      known torque's source, then `inertia` is 0);
    - `gravity`: `IDIMResult` of $d_q$ on `[-g cos q, g sin q, 1]` (MX, MY kg m, offset N m),
      on the samples in motion (`moving`);
    - `friction`: `IDIMResult` of $d_{\dot q}$ on `[dq, sign dq, 1]` (Fv N m s/rad, Fc, offset N m), idem;
    - `offset_sum`, `offset_sum_std` (N m): the two offsets added, the
      identified constant (only their sum is identified);
    - `relative_error`: $100 \|y - ZZ \ddot q - d_q - d_{\dot q}\| / \|y\|$ (%), the SDP
      model over the samples fitted (the whole record by default, the paper's
      definition); `relative_error_moving`: over the samples in motion;
    - `parametric_fit`: $ZZ \ddot q$ (or the known torque) + the two projections, on
      the samples fitted; `parametric_relative_error`,
      `parametric_relative_error_moving` (%);
    - `mismatch`: $100 \|d_j - projection_j\| / \|y\|$ per curve (gravity,
      friction) in motion, % of the torque: how far each curve is from its shape;
    - `shape`: the `ShapeTest` (do the curves depart from the parametric shapes?);
    - `whiteness`: of the SDP residual; `q`, `dq`, `ddq`, `y`: the samples
      fitted; `moving`: bool mask of those in motion; `model`, `tol`, `fit_on`.
    """

    result: MultiSDPResult
    inertia: float
    gravity: IDIMResult
    friction: IDIMResult
    offset_sum: float
    offset_sum_std: float
    relative_error: float
    relative_error_moving: float
    parametric_fit: jnp.ndarray
    parametric_relative_error: float
    parametric_relative_error_moving: float
    mismatch: tuple
    shape: ShapeTest
    whiteness: Whiteness
    q: jnp.ndarray
    dq: jnp.ndarray
    ddq: jnp.ndarray
    y: jnp.ndarray
    moving: jnp.ndarray
    inertia_source: str = eqx.field(static=True)
    model: tuple = eqx.field(static=True)
    tol: float = eqx.field(static=True)
    fit_on: str = eqx.field(static=True, default="all")


def _relerr(y, fit) -> float:
    return float(100.0 * jnp.linalg.norm(y - fit) / jnp.linalg.norm(y))


def _project(d, q, dq, joint, g):
    return (
        parametric_stage(d[:, 0], gravity_basis(q, joint=joint, g=g)),
        parametric_stage(d[:, 1], friction_basis(dq, joint=joint)),
    )


def shape_test(res: MultiSDPResult, y, known, q, dq, mask, *, joint: int = 2, g=GRAVITY, threshold=SHAPE_THRESHOLD):
    """The `ShapeTest` of a two-curve multi-SDP (gravity, friction) on the samples `mask` (bool, in motion)."""
    mask = np.asarray(mask, bool)
    n = int(mask.sum())
    d = res.d[mask]
    grav, fric = _project(d, q[mask], dq[mask], joint, g)
    rss_par = float(jnp.sum((y[mask] - known[mask] - grav.fit - fric.fit) ** 2))
    rss_sdp = float(jnp.sum(res.resid[mask] ** 2))
    m = res.d.shape[1]
    # the additive model shares one constant between its m curves
    edf = float(jnp.sum(res.leverage[mask])) - (m - 1) * n / mask.size
    p = 5
    s2_par, s2_sdp = rss_par / (n - p), rss_sdp / max(n - edf, 1.0)
    stat = 100.0 * (1.0 - s2_sdp / s2_par)
    return ShapeTest(
        statistic=stat,
        threshold=float(threshold),
        mismatch=bool(stat > threshold),
        samples=n,
        parameters=p,
        edf=edf,
        variance_parametric=s2_par,
        variance_sdp=s2_sdp,
    )


@x64
def joint_multi_sdp(
    inputs: Preprocessed,
    *,
    inertia: float | None = None,
    inertia_source: str = "given",
    known=None,
    moving=None,
    fit_on: Literal["all", "moving"] = "all",
    joint: int = 2,
    sdp: MultiBackfitting | None = None,
    shape_threshold: float = SHAPE_THRESHOLD,
    g=GRAVITY,
) -> JointSDP:
    r"""Multi-SDP of one joint with the inertia fixed: $y - ZZ \ddot q = d_q(q) + d_{\dot q}(\dot q) + e$ (eqs. 24-25).

    With `known` (a torque at the decimated samples, e.g. a full rigid-body
    model's) instead of `inertia`: $y - known = d_q(q) + d_{\dot q}(\dot q) + e$.

    Back-fitting (`jaxsdp.multi_sdp`) of a gravity SDP $d_q$ in the order of $q$
    and a friction SDP $d_{\dot q}$ in the order of $\dot q$, NVRs by maximum likelihood
    at every iteration, until $\|d^k - d^{k-1}\| / \|d^k\| \le$ `tol` (1 %, the
    paper's), on every sample (`fit_on="all"`: the curves are free
    functions, so the samples at rest are no model error for them; the
    paper's and the original toolbox's practice) or on those in motion
    (`fit_on="moving"`). Then each curve is projected by least squares on
    the samples in motion (the paper's IDIM-SDP estimates):

    $$ d_q(q) \approx MX (-g \cos q) + MY (g \sin q) + offset_q, $$

    $$ d_{\dot q}(\dot q) \approx F_v \dot q + F_c sign(\dot q) + offset_{\dot q}, $$

    the parametric model $ZZ \ddot q$ + both projections is rebuilt, and the
    `ShapeTest` says whether the curves depart from those shapes.

    **Arguments:** `inputs` (`joint_preprocess`); `inertia` ZZ (kg m^2, > 0:
    from IDIM-LS or a CAD value) and its `inertia_source` label, or `known`
    (N m, one value per decimated sample; then `inertia` is reported as 0); `moving`
    (bool mask of the decimated samples in motion, default all: the
    projections' samples; the shape test also leaves out those below
    `REST_FRACTION` of the peak speed); `fit_on`; `sdp`: the back-fitting
    options, a `jaxsdp.MultiBackfitting` (`model`: "RW" or "IRW" per SDP, or
    one for both; `tol`, `max_iter`, `max_nvr`, `optimise_on`; None: its
    defaults, RW curves, ML NVRs at every iteration capped at 1, tol 1 %, at
    most 20 iterations); `shape_threshold` (%, `ShapeTest`).

    **Returns:** a `JointSDP`.

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.studies.tx40 import joint_multi_sdp, joint_preprocess
        >>> p = joint_preprocess(tx40_builtin_data().logs)
        >>> s = joint_multi_sdp(p, inertia=1.60)
        >>> bool(s.result.converged), round(s.gravity["MX2"], 2), s.shape.mismatch  # truth 2.80 kg m
        (True, 2.79, False)
        >>> from jaxsdp import MultiBackfitting
        >>> joint_multi_sdp(p, inertia=1.60, sdp=MultiBackfitting(model="IRW", tol=0.005)).model
        ('IRW', 'IRW')
    """
    sdp = MultiBackfitting() if sdp is None else sdp
    if not isinstance(sdp, MultiBackfitting):
        raise ValueError(f"`sdp` must be None or a jaxsdp.MultiBackfitting(...); got {type(sdp).__name__}")
    if (inertia is None) == (known is None):
        raise ValueError("give exactly one of `inertia` (the term ZZ ddq) and `known` (a known torque)")
    if inertia is not None and not (np.isfinite(inertia) and inertia > 0):
        raise ValueError(f"`inertia` must be a positive finite value (kg m^2); got {inertia!r}")
    if fit_on not in ("all", "moving"):
        raise ValueError(f"`fit_on` must be 'all' or 'moving'; got {fit_on!r}")
    m = inputs.y.shape[0]
    keep = np.ones(m, bool) if moving is None else np.asarray(moving, bool)
    if keep.shape != (m,):
        raise ValueError(f"`moving` must be a mask of the {m} decimated samples; got {keep.shape}")
    rows = keep if fit_on == "moving" else np.ones(m, bool)
    y, q, dq, ddq = (v[rows] for v in (inputs.y, inputs.q, inputs.dq, inputs.ddq))
    if known is not None:
        known = jnp.asarray(known, dtype=jnp.float64)
        if known.shape != (m,) or not bool(jnp.all(jnp.isfinite(known))):
            raise ValueError(f"`known` must be a finite torque at the {m} decimated samples; got {known.shape}")
        w, a, inertia = known[rows], 1.0, 0.0
    else:
        w, a = ddq, inertia
    res = multi_sdp(
        y,
        jnp.stack([q, dq], axis=1),
        w=w,
        a=a,
        **sdp._options(),
    )
    mov = keep[rows]
    grav, fric = _project(res.d[mov], q[mov], dq[mov], joint, g)
    fit = a * w + gravity_basis(q, joint=joint, g=g).X @ grav.theta + friction_basis(dq, joint=joint).X @ fric.theta
    og, of = grav.param("offset"), fric.param("offset")
    ym = y[mov]
    mism = tuple(
        float(100.0 * jnp.linalg.norm(c.residuals) / jnp.linalg.norm(ym)) for c in (grav, fric)
    )  # curve minus its projection
    in_motion = mov & (np.abs(np.asarray(dq)) >= rest_threshold(inputs, "auto"))
    shape = shape_test(res, y, a * w, q, dq, in_motion, joint=joint, g=g, threshold=shape_threshold)
    model = sdp.model
    models = (model, model) if isinstance(model, (str, ParameterModel)) else tuple(model)
    return JointSDP(
        result=res,
        inertia=float(inertia),
        gravity=grav,
        friction=fric,
        offset_sum=og.value + of.value,
        offset_sum_std=float(np.hypot(og.std, of.std)),
        relative_error=float(res.relative_error),
        relative_error_moving=_relerr(ym, res.fit[mov]),
        parametric_fit=fit,
        parametric_relative_error=_relerr(y, fit),
        parametric_relative_error_moving=_relerr(ym, fit[mov]),
        mismatch=mism,
        shape=shape,
        whiteness=residual_whiteness(res.resid, inputs.decimate),
        q=q,
        dq=dq,
        ddq=ddq,
        y=y,
        moving=jnp.asarray(mov),
        inertia_source=inertia_source,
        model=tuple(str(m) for m in models),
        tol=float(sdp.tol),
        fit_on=fit_on,
    )
