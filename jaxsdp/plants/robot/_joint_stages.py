"""The stages of the TX40 study for one joint: preprocessing, IDIM-LS (eq. 22), multi-SDP (section 3.3).

1. `joint_preprocess`: the EMPS benchmark's processing of one joint's log
   (`jaxsdp.preprocess`: zero-phase Butterworth on the angle, central
   differences, border removal, decimation; smoothing derivatives as an option).
2. `joint_idim_ls`: IDIM-LS with the basis of eq. (22),
   `[ddq, -g cos q, g sin q, dq, sign dq, 1]` (parallel decimation), on the
   samples in motion (|dq| >= `min_speed`: at rest the joint is held by
   static friction, which eq. (21) does not describe), with the residual
   whiteness test.
3. `joint_multi_sdp`: tau - ZZ ddq = d_q(q) + d_dq(dq) + e by multi-SDP
   back-fitting with the inertia fixed (IDIM-LS, or a CAD value), then the
   parametric projection of each curve, gravity on `[-g cos q, g sin q, 1]`
   and friction on `[dq, sign dq, 1]` (the paper's IDIM-SDP estimates), the
   two offsets and their sum, and the relative errors of the SDP model and
   of the rebuilt parametric model.
"""

from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._idim.ls import IDIMResult, idim_ls
from ..._idim.parametric import parametric_stage
from ..._records import JointLogs
from ..._runtime import x64
from ..._sdp.multi import MultiSDPResult, multi_sdp
from ..._signal.preprocess import Preprocessed, preprocess
from ..._signal.regressors import Regression
from ..._signal.whiteness import Whiteness, decimated_noise_acf, whiteness
from ._tx40_link2 import GRAVITY, friction_basis, gravity_basis, joint_regressors

#: Samples dropped at the start of the record (20 ms at 5 kHz: the Butterworth's start-up).
DROP = 100
#: Samples slower than this (rad/s) are at rest, held by static friction: left out of both fits.
MIN_SPEED = 0.01
#: Lags of the whiteness test (at the decimated rate).
MAX_LAG = 20


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
    """IDIM-LS of one joint with eq. (22) (`joint_idim_ls`).

    **Fields:** `result` (`IDIMResult`: ZZ kg m^2, MX and MY kg m, Fv
    N m s/rad, Fc and offset N m), `regression` (the parallel-decimated
    `y`, `X`, `names`, all samples), `moving` (bool mask of the samples used:
    |dq| >= `min_speed`), `whiteness` (of the residual), `min_speed` (rad/s),
    `joint`.
    """

    result: IDIMResult
    regression: Regression
    moving: jnp.ndarray
    whiteness: Whiteness
    min_speed: float = eqx.field(static=True)
    joint: int = eqx.field(static=True)


def moving_mask(inputs: Preprocessed, min_speed: float) -> np.ndarray:
    """Decimated samples in motion, |dq| >= `min_speed` (rad/s); ValueError when fewer than 20 remain."""
    if not (np.isfinite(min_speed) and min_speed >= 0):
        raise ValueError(f"`min_speed` must be a finite value >= 0 (rad/s); got {min_speed!r}")
    keep = np.abs(np.asarray(inputs.dq)) >= min_speed
    if keep.sum() < 20:
        raise ValueError(
            f"only {int(keep.sum())} of {keep.size} samples move faster than min_speed = {min_speed:g} rad/s: "
            "the joint hardly moves in this record (wrong joint, or lower min_speed)"
        )
    return keep


@x64
def joint_idim_ls(inputs: Preprocessed, *, joint: int = 2, min_speed: float = MIN_SPEED, g=GRAVITY) -> JointIDIM:
    """IDIM-LS of one joint as a one-degree-of-freedom arm (eqs. 20-23) on the samples in motion.

    tau = ZZ ddq - g MX cos(q) + g MY sin(q) + Fv dq + Fc sign(dq) + offset + e,
    the regressors built on the full-rate signals and decimated like the
    torque (parallel decimation), the samples with |dq| < `min_speed` left
    out (at rest, static friction holds the joint: eq. 21 does not apply).
    The residual is tested for whiteness against white noise through the
    decimation filter (`residual_whiteness`).

    **Returns:** a `JointIDIM` (`result`, `whiteness`, ...).

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.studies.tx40 import joint_idim_ls, joint_preprocess
        >>> ls = joint_idim_ls(joint_preprocess(tx40_builtin_data().logs))
        >>> round(ls.result["ZZ2"], 2), round(ls.result["MX2"], 2)  # truth 1.60 kg m^2, 2.80 kg m
        (1.61, 2.82)
    """
    keep = moving_mask(inputs, min_speed)
    reg = inputs.regression(joint_regressors(inputs.q_full, inputs.dq_full, inputs.ddq_full, joint=joint, g=g))
    result = idim_ls(reg.y[keep], reg.X[keep], names=reg.names)
    return JointIDIM(
        result=result,
        regression=reg,
        moving=jnp.asarray(keep),
        whiteness=residual_whiteness(result.residuals, inputs.decimate),
        min_speed=float(min_speed),
        joint=int(joint),
    )


class JointSDP(eqx.Module):
    """Multi-SDP of one joint (section 3.3) and its parametric projections (`joint_multi_sdp`).

    **Fields:**

    - `result`: the `MultiSDPResult` of y - ZZ ddq = d_q(q) + d_dq(dq) + e
      (`d[:, 0]` gravity, `d[:, 1]` friction, N m);
    - `inertia` (kg m^2) and `inertia_source` ("IDIM-LS", "given", or the
      known torque's source, then `inertia` is 0);
    - `gravity`: `IDIMResult` of d_q on `[-g cos q, g sin q, 1]` (MX, MY kg m, offset N m);
    - `friction`: `IDIMResult` of d_dq on `[dq, sign dq, 1]` (Fv N m s/rad, Fc, offset N m);
    - `offset_sum`, `offset_sum_std` (N m): the two offsets added, the
      identified constant (only their sum is identified);
    - `relative_error`: 100 ||y - ZZ ddq - d_q - d_dq|| / ||y|| (%), the SDP model;
    - `parametric_fit`: ZZ ddq (or the known torque) + the two projections;
      `parametric_relative_error` (%);
    - `mismatch`: 100 ||d_j - projection_j|| / ||y|| per curve (gravity,
      friction), % of the torque: how far each curve is from its parametric shape;
    - `whiteness`: of the SDP residual; `q`, `dq`, `ddq`, `y`: the samples used;
      `model`, `tol`.
    """

    result: MultiSDPResult
    inertia: float
    gravity: IDIMResult
    friction: IDIMResult
    offset_sum: float
    offset_sum_std: float
    relative_error: float
    parametric_fit: jnp.ndarray
    parametric_relative_error: float
    mismatch: tuple
    whiteness: Whiteness
    q: jnp.ndarray
    dq: jnp.ndarray
    ddq: jnp.ndarray
    y: jnp.ndarray
    inertia_source: str = eqx.field(static=True)
    model: tuple = eqx.field(static=True)
    tol: float = eqx.field(static=True)


def _relerr(y, fit) -> float:
    return float(100.0 * jnp.linalg.norm(y - fit) / jnp.linalg.norm(y))


@x64
def joint_multi_sdp(
    inputs: Preprocessed,
    *,
    inertia: float | None = None,
    inertia_source: str = "given",
    known=None,
    moving=None,
    joint: int = 2,
    model=("RW", "RW"),
    tol: float = 0.01,
    max_iter: int = 20,
    max_nvr: float | None = 1.0,
    optimise_on: Literal["first", "all"] = "all",
    g=GRAVITY,
) -> JointSDP:
    """Multi-SDP of one joint with the inertia fixed: y - ZZ ddq = d_q(q) + d_dq(dq) + e (eqs. 24-25).

    With `known` (a torque at the decimated samples, e.g. a full rigid-body
    model's) instead of `inertia`: y - known = d_q(q) + d_dq(dq) + e.

    Back-fitting (`jaxsdp.multi_sdp`) of a gravity SDP d_q in the order of q
    and a friction SDP d_dq in the order of dq, NVRs by maximum likelihood
    at every iteration, until ||d^k - d^{k-1}|| / ||d^k|| <= `tol` (1 %, the
    paper's). Then each curve is projected by least squares (the paper's
    IDIM-SDP estimates):

        d_q(q) ~ MX (-g cos q) + MY (g sin q) + offset_q,
        d_dq(dq) ~ Fv dq + Fc sign(dq) + offset_dq,

    and the parametric model ZZ ddq + both projections is rebuilt.

    **Arguments:** `inputs` (`joint_preprocess`); `inertia` ZZ (kg m^2, > 0:
    from IDIM-LS or a CAD value) and its `inertia_source` label, or `known`
    (N m, one value per decimated sample; then `inertia` is reported as 0); `moving`
    (bool mask of the decimated samples to use, default all);
    `model` (one of "RW", "IRW" per SDP, or one for both), `tol`,
    `max_iter`, `max_nvr`, `optimise_on` as `jaxsdp.multi_sdp`.

    **Returns:** a `JointSDP`.

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.studies.tx40 import joint_multi_sdp, joint_preprocess
        >>> p = joint_preprocess(tx40_builtin_data().logs)
        >>> s = joint_multi_sdp(p, inertia=1.60)
        >>> bool(s.result.converged), round(s.gravity["MX2"], 2)  # truth 2.80 kg m
        (True, 2.79)
    """
    if (inertia is None) == (known is None):
        raise ValueError("give exactly one of `inertia` (the term ZZ ddq) and `known` (a known torque)")
    if inertia is not None and not (np.isfinite(inertia) and inertia > 0):
        raise ValueError(f"`inertia` must be a positive finite value (kg m^2); got {inertia!r}")
    m = inputs.y.shape[0]
    keep = np.ones(m, bool) if moving is None else np.asarray(moving, bool)
    if keep.shape != (m,):
        raise ValueError(f"`moving` must be a mask of the {m} decimated samples; got {keep.shape}")
    y, q, dq, ddq = (v[keep] for v in (inputs.y, inputs.q, inputs.dq, inputs.ddq))
    if known is not None:
        known = jnp.asarray(known, dtype=jnp.float64)
        if known.shape != (m,) or not bool(jnp.all(jnp.isfinite(known))):
            raise ValueError(f"`known` must be a finite torque at the {m} decimated samples; got {known.shape}")
        w, a, inertia = known[keep], 1.0, 0.0
    else:
        w, a = ddq, inertia
    res = multi_sdp(
        y,
        jnp.stack([q, dq], axis=1),
        w=w,
        a=a,
        model=model,
        tol=tol,
        max_iter=max_iter,
        max_nvr=max_nvr,
        optimise_on=optimise_on,
    )
    grav = parametric_stage(res.d[:, 0], gravity_basis(q, joint=joint, g=g))
    fric = parametric_stage(res.d[:, 1], friction_basis(dq, joint=joint))
    fit = a * w + grav.fit + fric.fit
    og, of = grav.param("offset"), fric.param("offset")
    mism = tuple(
        float(100.0 * jnp.linalg.norm(c.residuals) / jnp.linalg.norm(y)) for c in (grav, fric)
    )  # curve minus its projection
    models = (model, model) if isinstance(model, str) else tuple(model)
    return JointSDP(
        result=res,
        inertia=float(inertia),
        gravity=grav,
        friction=fric,
        offset_sum=og.value + of.value,
        offset_sum_std=float(np.hypot(og.std, of.std)),
        relative_error=float(res.relative_error),
        parametric_fit=fit,
        parametric_relative_error=_relerr(y, fit),
        mismatch=mism,
        whiteness=residual_whiteness(res.resid, inputs.decimate),
        q=q,
        dq=dq,
        ddq=ddq,
        y=y,
        inertia_source=inertia_source,
        model=tuple(str(m) for m in models),
        tol=float(tol),
    )
