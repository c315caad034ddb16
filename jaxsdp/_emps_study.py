r"""The EMPS identification study (paper section 2): IDIM-LS, SDP stage, IDIM-SDP.

Workflow on an EMPS-type record (position + force of one linear axis):

1. **Preprocessing** (`jaxsdp.emps_preprocess`, or `emps_preprocess_smooth`
   for smoothing derivatives): velocity and acceleration, first samples
   dropped, decimation.
2. **IDIM-LS** with the symmetric model `[ddq, dq, sign(dq), 1]` and the
   asymmetric model of eqs. (17)-(18) (`EMPSInputs.regression` + `idim_ls`:
   parallel decimation of the regressors, the published procedure).
3. **SDP stage** (`emps_sdp_stage`, eq. 13): $y_k = M(\ddot q_k)\,\ddot q_k +
   d_{fric}(\dot q_k)\cdot 1 + e_k$ with ML NVRs (regressors
   $z = [\ddot q, 1]$, states $x = [\ddot q, \dot q]$) on the decimated
   signals. A mass NVR below `constant_nvr` flags the mass as
   acceleration-independent.
4. **IDIM-SDP** (`emps_idim_sdp`, eq. 17, Table 2): the friction SDP curve
   regressed on $[O^+(\dot q), \operatorname{sign}O^+(\dot q), O^-(\dot q),
   \operatorname{sign}O^-(\dot q)]$, and the final IDIM-LS with the
   asymmetric model.

`emps_study` runs all stages with per-stage timings and returns an
`EMPSStudy` (tables, a JSON-ready `summary()`), the back end of the
`jaxsdp emps` command; `jaxsdp._figures` draws the paper's figures from it.

**NVR search.** By default (`nvr_search="sdp"`) `jaxsdp.sdp` estimates
the NVRs by gradient (BFGS) maximum likelihood on the first sweep.
`emps_sdp_stage(nvr_search="captain")` instead estimates them as the
CAPTAIN toolbox does: for each term in order, the concentrated likelihood of the sorted
partial residual is minimised over $\log_{10}$ NVR by Nelder-Mead (MATLAB
`fminsearch` simplex, started at `nvr0` = 1e-4, tolerance 0.01 on
$\log_{10}$ NVR), capped at `max_nvr`; the back-fitting then runs
`jaxsdp.sdp` with these NVRs fixed (its first sweep repeats exactly the
smoothing the search used). Both give the same NVRs on the EMPS data
(a test checks it).

On the EMPS data (standard processing, decimation 10) the mass criterion of
the first sweep has a local *maximum* next to the start NVR = 1e-4 (the
partial residual still contains all the friction, whose initial estimate
is the constant LS offset). The simplex moves downhill to the flat region
and stops at NVR = 1e-23, the value the paper reports: mass constant. A
gradient search must not take a first step proportional to the (tiny)
gradient there: `jaxsdp.sdp`'s BFGS did, met its step tolerance at once and
returned NVR ~ 9e-5 (negative curvature, `log10_nvr_se` = inf); with a
first step of one decade it reaches ~4e-12 (same conclusion). Note that the
*global* minimum of that first-sweep criterion is at NVR ~ 0.1, where the
mass absorbs part of the still unmodelled friction, and that once the
friction SDP is removed the mass likelihood prefers a large NVR (the RW
then follows residual structure where the acceleration is ~0). The
"mass constant" conclusion is the CAPTAIN procedure's (local ML from 1e-4
on the first sweep), which this reproduces; it is not robust to the
processing (decimation 5 gives a mass NVR ~ 0.1 by the same procedure).
The acceleration-weighted SDP mass stays within 0.1 kg of IDIM-LS in all
these cases.

**SDP mass.** `EMPSSDPStage.mass` is the acceleration-weighted mean
$\sum_k \hat M_k \ddot q_k^2 / \sum_k \ddot q_k^2$: the constant mass whose
inertia force $M\ddot q_k$ is closest (least squares) to the SDP one
$\hat M_k \ddot q_k$. Samples with $\ddot q \approx 0$ carry no information
on $M$ (their $\hat M_k$ is an interpolation with large standard error), so
they get no weight. When the mass NVR is ~0 all $\hat M_k$ are equal and
this is simply that value; `mass_mean` is the plain mean.
"""

import os
import pathlib
import time
from collections.abc import Callable
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import scipy.optimize

from ._checks import as_float_array
from ._derivatives import smooth_derivatives
from ._emps_data import EMPSData, Measurements, load_emps, load_measurements
from ._filtering import decimate as _decimate_signal
from ._idim import (
    EMPSInputs,
    IDIMResult,
    Regressors,
    emps_asym_regressors,
    emps_preprocess,
    emps_regressors,
    idim_ls,
    position_force,
)
from ._models import LLT, Constant, as_models
from ._nvr import LOG10_NVR_BOUNDS
from ._parametric import parametric_stage
from ._sdp import (
    CONSTANT_NVR,
    SDPResult,
    _sorted_order,
    _Term,
    sdp,
    term_criterion,
    term_update,
    validate_states,
)
from ._x64 import x64

#: Names of the SDP terms of the EMPS model (eq. 13), in regression order.
SDP_TERMS = ("M(ddq)", "d_fric(dq)")
#: Names of the asymmetric friction parameters (eq. 17).
ASYM_FRICTION = ("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")


# --------------------------------------------------------------------------- #
# Preprocessing with smoothing derivatives
# --------------------------------------------------------------------------- #


@x64
def emps_preprocess_smooth(
    data,
    *,
    cutoff_hz: float | None = None,
    nvr: float | None = None,
    drop: int = 49,
    decimate: int = 10,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
) -> EMPSInputs:
    """EMPS processing with smoothing derivatives instead of Butterworth + differences.

    1. `jaxsdp.smooth_derivatives` on the whole position record (double
       integrated random walk, fixed-interval smoother): the NVR from
       `cutoff_hz`, from `nvr`, or by maximum likelihood if neither is given.
    2. Drop the first `drop` samples; 3. decimate each signal by `decimate`
       (`jaxsdp.decimate`, `mode`), exactly as `jaxsdp.emps_preprocess`.

    Returns an `EMPSInputs` (so `inputs.regression(...)` works as for the
    standard processing).
    """
    q, force, dt = position_force(data)
    _check_int("drop", drop, 0)
    _check_int("decimate", decimate, 1)
    if drop >= q.shape[0]:
        raise ValueError(f"`drop` = {drop} must be smaller than the number of samples {q.shape[0]}")
    der = smooth_derivatives(q, dt, cutoff_hz=cutoff_hz, nvr=nvr)
    full = [v[drop:] for v in (force, der.q, der.dq, der.ddq)]
    if decimate == 1:
        dec = full
    else:
        dec = [_decimate_signal(v, int(decimate), mode=mode) for v in full]
    return EMPSInputs(
        y=dec[0], q=dec[1], dq=dec[2], ddq=dec[3], dt=dt * int(decimate),
        y_full=full[0], q_full=full[1], dq_full=full[2], ddq_full=full[3], dt_full=dt,
        decimate=int(decimate), mode=mode,
    )


def _check_int(name, v, lo):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise ValueError(f"`{name}` must be an integer >= {lo}; got {v!r}")


# --------------------------------------------------------------------------- #
# SDP stage
# --------------------------------------------------------------------------- #


class EMPSSDPStage(eqx.Module):
    r"""SDP stage of the EMPS study, $y = M(\ddot q)\ddot q + d_{fric}(\dot q) + e$.

    **Fields:**

    - `result`: the `jaxsdp.SDPResult` (term 0 the mass $M(\ddot q)$, term 1
      the friction $d_{fric}(\dot q)$; `par`, `x_sorted`, `par_sorted`, ...).
    - `nvr_mass`, `nvr_friction`: the NVRs; `log10_nvr_se`: (2,) curvature
      standard errors of $\log_{10}$ NVR (inf on a flat likelihood, NaN for a
      fixed NVR).
    - `mass_constant`: mass NVR below `constant_nvr` (acceleration-independent).
    - `mass`: SDP mass, acceleration-weighted mean
      $\sum \hat M_k\ddot q_k^2/\sum\ddot q_k^2$ (kg; see the module docstring);
      `mass_mean`: plain mean of $\hat M_k$.
    - `relative_error`: $100\|y-\hat y\|/\|y\|$ (%); `r2`.
    - `y`, `ddq`, `dq`: the signals used (decimated), `dt` their period (s).
    - `model`: parameter model name(s); `nvr_search`: "captain" or "sdp";
      `constant_nvr`: the threshold.
    """

    result: SDPResult
    nvr_mass: float
    nvr_friction: float
    log10_nvr_se: np.ndarray
    mass_constant: bool
    mass: float
    mass_mean: float
    relative_error: float
    r2: float
    y: jax.Array
    ddq: jax.Array
    dq: jax.Array
    dt: float
    model: str = eqx.field(static=True)
    nvr_search: str = eqx.field(static=True)
    constant_nvr: float = eqx.field(static=True)

    @property
    def friction(self) -> jax.Array:
        r"""SDP friction $\hat d_{fric}(\dot q_k)$ in time order (N)."""
        return self.result.par[:, 1]

    @property
    def mass_curve(self) -> jax.Array:
        r"""SDP mass $\hat M(\ddot q_k)$ in time order (kg)."""
        return self.result.par[:, 0]

    def table(self) -> str:
        """Text summary: NVRs, mass, relative error."""
        return sdp_stage_table(self)


def sdp_stage_table(stage: EMPSSDPStage) -> str:
    """Format an `EMPSSDPStage` as text."""
    se = np.asarray(stage.log10_nvr_se, dtype=float)

    def fmt_se(v):
        return "fixed" if np.isnan(v) else ("flat" if not np.isfinite(v) else f"+-{v:.2f}")

    flag = "constant (acceleration-independent)" if stage.mass_constant else "state-dependent"
    lines = [
        f"SDP stage y = M(ddq)*ddq + d_fric(dq)   [{stage.model}, NVRs: {stage.nvr_search}]",
        f"  NVR M(ddq)      = {stage.nvr_mass:.3g}   (log10 se {fmt_se(se[0])})  -> mass {flag}",
        f"  NVR d_fric(dq)  = {stage.nvr_friction:.3g}   (log10 se {fmt_se(se[1])})",
        f"  SDP mass        = {stage.mass:.4f} kg (acceleration-weighted; plain mean {stage.mass_mean:.4f})",
        (
            f"  relative error  = {stage.relative_error:.3f} %   (R^2 = {stage.r2:.6f}, "
            f"{int(stage.result.sweeps)} sweeps)"
        ),
    ]
    return "\n".join(lines)


@eqx.filter_jit
def _term_criterion(b, r, zj, prev, term, P0):
    # The criterion `jaxsdp.sdp` optimises for one term, on the search bounds.
    lo, hi = LOG10_NVR_BOUNDS
    return term_criterion(r, zj, prev, term, P0)(jnp.clip(b, lo, hi)[None]).J


@eqx.filter_jit
def _term_smooth(r, zj, prev, term, nvr, P0):
    return term_update(r, zj, prev, term, nvr, optimise=False, max_log10=None, P0=P0).par


def _fminsearch_1d(f, b0: float, *, xatol: float, fatol: float, maxiter: int) -> float:
    # MATLAB fminsearch's initial simplex: x0 and x0 * 1.05 (0.00025 if x0 = 0).
    b1 = b0 * 1.05 if b0 != 0 else 0.00025
    res = scipy.optimize.minimize(
        lambda v: float(f(float(v[0]))),
        np.array([b0]),
        method="Nelder-Mead",
        options=dict(initial_simplex=np.array([[b0], [b1]]), xatol=xatol, fatol=fatol, maxiter=maxiter),
    )
    return float(res.x[0])


def _log10_se(f, b: float, h: float = 0.05) -> float:
    # Curvature standard error of log10 NVR: info = J''/2 (J = -2 loglik + const).
    d2 = (float(f(b + h)) - 2.0 * float(f(b)) + float(f(b - h))) / (h * h)
    return float(np.sqrt(2.0 / d2)) if d2 > 0 else float("inf")


@x64
def captain_nvrs(y, z, x, *, model="RW", nvr=None, nvr0=1e-4, max_nvr=1.0, P0=1e5, xatol=0.01):
    r"""ML NVRs of an SDP model on the first back-fitting sweep, CAPTAIN style.

    Starting from the constant least-squares parameters, for each term $j$ in
    order: the partial residual $r = y - \sum_{i\ne j} c_i z_i$ is sorted by
    $x_j$, $J(\log_{10}\mathrm{NVR}_j)$ (the concentrated criterion
    `jaxsdp.sdp` uses) is minimised by Nelder-Mead from $\log_{10}$ `nvr0`
    (MATLAB `fminsearch` initial simplex, tolerance `xatol` on
    $\log_{10}$ NVR), the result is clipped to the search bounds and capped at
    `max_nvr`, and $c_j$ is smoothed with it before the next term.

    `nvr`: None (all estimated) or (p,) with NaN for the entries to estimate.
    Returns `(nvr, log10_nvr_se)` as numpy arrays; pass `nvr` to
    `jaxsdp.sdp(y, z, x, nvr=nvr)` for the back-fitting.
    """
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    x = as_float_array("x", x, ndim=2)
    p = z.shape[1]
    models = as_models(model, p)
    for m in models:
        if isinstance(m, (LLT, Constant)):
            raise ValueError(f"`model`: SDP terms must be RW, IRW or SRW (one NVR each); got {m.name}")
    if z.shape[0] != y.shape[0] or x.shape != z.shape:
        raise ValueError(f"`y` (N,), `z` and `x` (N, p) must agree; got {y.shape}, {z.shape}, {x.shape}")
    x = validate_states(x)
    if nvr is None:
        fixed = np.full(p, np.nan)
    else:
        try:
            fixed = np.broadcast_to(np.asarray(nvr, dtype=float), (p,)).copy()
        except ValueError:
            raise ValueError(f"`nvr` must be None, a scalar or shape ({p},); got {nvr!r}") from None
        if np.any(fixed[~np.isnan(fixed)] < 0) or not np.all(np.isfinite(fixed[~np.isnan(fixed)])):
            raise ValueError(f"`nvr`: fixed NVRs must be finite and non-negative; got {fixed}")
    if not (np.isfinite(nvr0) and nvr0 > 0):
        raise ValueError(f"`nvr0` must be positive; got {nvr0!r}")
    P0 = jnp.asarray(P0, dtype=jnp.float64)
    lo, hi = LOG10_NVR_BOUNDS
    cap = hi if max_nvr is None else min(hi, float(np.log10(max_nvr)))
    c0 = jnp.linalg.lstsq(z, y)[0]
    par = jnp.broadcast_to(c0, z.shape)
    fit = jnp.sum(par * z, axis=1)
    out_nvr = np.empty(p)
    out_se = np.full(p, np.nan)
    for j in range(p):
        perm, adv = _sorted_order(x[:, j])
        term = _Term(models[j], perm, adv)
        zj = z[:, j]
        r = y - fit + par[:, j] * zj
        prev = par[:, j]
        if np.isnan(fixed[j]):

            def J(b, r=r, zj=zj, prev=prev, term=term):
                v = float(_term_criterion(jnp.asarray(b), r, zj, prev, term, P0))
                return v if np.isfinite(v) else np.inf

            b = _fminsearch_1d(J, float(np.log10(nvr0)), xatol=xatol, fatol=1e-4, maxiter=200)
            b = min(max(b, lo), hi, cap)
            out_se[j] = _log10_se(J, b)
            out_nvr[j] = 10.0**b
        else:
            out_nvr[j] = fixed[j]
        cj = _term_smooth(r, zj, prev, term, jnp.asarray(out_nvr[j]), P0)
        fit = fit - par[:, j] * zj + cj * zj
        par = par.at[:, j].set(cj)
    return out_nvr, out_se


def _weighted_mass(M, ddq):
    w = np.asarray(ddq, dtype=float) ** 2
    return float(np.sum(np.asarray(M, dtype=float) * w) / np.sum(w))


def _model_name(model) -> str:
    if isinstance(model, str):
        return model.upper()
    if isinstance(model, (list, tuple)):
        return "/".join(_model_name(m) for m in model)
    return getattr(model, "name", type(model).__name__)


@x64
def emps_sdp_stage(
    inputs: EMPSInputs,
    *,
    model="RW",
    nvr=None,
    nvr_search: Literal["captain", "sdp"] = "sdp",
    nvr0: float = 1e-4,
    max_nvr: float | None = 1.0,
    constant_nvr: float = CONSTANT_NVR,
    max_sweeps: int = 10,
    tol: float = 1e-3,
    P0: float = 1e5,
) -> EMPSSDPStage:
    r"""SDP stage of the EMPS study (paper section 2.5, eq. 13).

    $y_k = M(\ddot q_k)\ddot q_k + d_{fric}(\dot q_k) + e_k$ on the decimated
    signals of `inputs` (`y`, `ddq`, `dq`): regressors $z = [\ddot q, 1]$,
    states $x = [\ddot q, \dot q]$, back-fitted by `jaxsdp.sdp`.

    **Arguments:**

    - `inputs`: an `EMPSInputs` (`jaxsdp.emps_preprocess` or `emps_preprocess_smooth`).
    - `model`: `"RW"` (default), `"IRW"`, ... or one per term (mass, friction).
    - `nvr`: None (ML for both), or (2,) fixed NVRs with NaN entries estimated.
    - `nvr_search`: `"sdp"` (default: `jaxsdp.sdp`'s gradient ML search) or
      `"captain"` (Nelder-Mead on the first sweep as CAPTAIN, see the module docstring).
    - `nvr0`: start of the search (CAPTAIN's 1e-4); `max_nvr`: cap (1).
    - `constant_nvr`: mass NVRs below it flag the mass constant (1e-6).
    - `max_sweeps`, `tol`, `P0`: passed to `jaxsdp.sdp`.

    **Returns:** an `EMPSSDPStage`.
    """
    if not isinstance(inputs, EMPSInputs):
        raise ValueError(f"`inputs` must be an EMPSInputs; got {type(inputs).__name__}")
    if nvr_search not in ("captain", "sdp"):
        raise ValueError(f"`nvr_search` must be 'captain' or 'sdp'; got {nvr_search!r}")
    y, ddq, dq = inputs.y, inputs.ddq, inputs.dq
    z = jnp.stack([ddq, jnp.ones_like(ddq)], axis=1)
    x = jnp.stack([ddq, dq], axis=1)
    kw = dict(model=model, max_sweeps=max_sweeps, tol=tol, P0=P0, constant_nvr=constant_nvr, max_nvr=max_nvr)
    if nvr_search == "captain":
        nvrs, se = captain_nvrs(y, z, x, model=model, nvr=nvr, nvr0=nvr0, max_nvr=max_nvr, P0=P0)
        res = sdp(y, z, x, nvr=jnp.asarray(nvrs), **kw)
        se = np.where(np.isnan(se), np.asarray(res.log10_nvr_se), se)
    else:
        res = sdp(y, z, x, nvr=nvr, nvr0=nvr0, **kw)
        se = np.asarray(res.log10_nvr_se)
    nv = np.asarray(res.nvr, dtype=float)
    return EMPSSDPStage(
        result=res,
        nvr_mass=float(nv[0]),
        nvr_friction=float(nv[1]),
        log10_nvr_se=se,
        mass_constant=bool(nv[0] < constant_nvr),
        mass=_weighted_mass(res.par[:, 0], ddq),
        mass_mean=float(np.mean(np.asarray(res.par[:, 0]))),
        relative_error=float(res.relative_error),
        r2=float(res.r2),
        y=y,
        ddq=ddq,
        dq=dq,
        dt=float(inputs.dt),
        model=_model_name(model),
        nvr_search=nvr_search,
        constant_nvr=float(constant_nvr),
    )


# --------------------------------------------------------------------------- #
# IDIM-SDP parametric stage
# --------------------------------------------------------------------------- #


@x64
def asym_friction_basis(dq) -> Regressors:
    r"""Asymmetric friction basis of eq. (17):
    $[O^+(\dot q), \operatorname{sign}O^+(\dot q), O^-(\dot q), \operatorname{sign}O^-(\dot q)]$,
    named `("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")` (the friction columns of
    `jaxsdp.emps_asym_regressors`; no offset column, see `emps_idim_sdp`)."""
    dq = as_float_array("dq", dq, ndim=1)
    regs = emps_asym_regressors(dq, jnp.zeros_like(dq))
    return Regressors(X=regs.X[:, 1:], names=regs.names[1:])


def asym_friction(theta, dq) -> jax.Array:
    """Friction force of eq. (17) with `theta = (Fv_pos, Fc_pos, Fv_neg, Fc_neg)`."""
    with jax.enable_x64(True):
        return asym_friction_basis(dq).X @ jnp.asarray(theta, dtype=jnp.float64)


class EMPSIDIMSDP(eqx.Module):
    r"""Parametric IDIM-SDP stage (paper section 2.6, Table 2).

    **Fields:**

    - `friction`: `IDIMResult` of the SDP friction curve
      $\hat d_{fric}(\dot q_k)$ regressed on the eq. (17) basis
      (`Fv_pos, Fc_pos, Fv_neg, Fc_neg`); its `relative_error` is that of the
      curve fit. `basis`: "parallel" or "pointwise" (see `emps_idim_sdp`).
    - `mass`: the SDP mass (kg, `EMPSSDPStage.mass`).
    - `fv_ratio`: $F_v^-/F_v^+$ from the curve fit (asymmetry; 1 = symmetric).
    - `relative_error`: force relative error (%) of the resulting IDIM-SDP
      model $\hat M\ddot q + \text{eq.(17)}$, $100\|y - X\hat\theta\|/\|y\|$
      with the asymmetric regressors parallel-decimated as for IDIM-LS
      (`inputs.regression(emps_asym_regressors)`), or evaluated on the
      decimated SDP signals when no `inputs` are given.
    - `asym`: the final IDIM-LS with the asymmetric model
      `[ddq, O+, sign O+, O-, sign O-]` (parallel decimation), or None.
    """

    friction: IDIMResult
    mass: float
    fv_ratio: float
    relative_error: float
    asym: IDIMResult | None
    basis: str = eqx.field(static=True, default="parallel")

    @property
    def theta(self) -> dict:
        """`{"M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"}` of the parametric stage."""
        out = {"M": self.mass}
        out.update({n: float(v) for n, v in zip(self.friction.names, np.asarray(self.friction.theta))})
        return out

    def table(self) -> str:
        """Table 2 layout: parametric IDIM-SDP and final IDIM-LS (asymmetric)."""
        return idim_sdp_table(self)


def idim_sdp_table(res: EMPSIDIMSDP, *, digits: int = 4) -> str:
    """Format an `EMPSIDIMSDP` as text (paper Table 2 layout)."""
    names = ("M",) + tuple(res.friction.names)
    curve = [(res.mass, None)] + list(zip(np.asarray(res.friction.theta), np.asarray(res.friction.rel_std)))
    cols = ["IDIM-SDP (curve fit)"]
    rows = [[f"{v:.{digits}f}" + ("" if r is None else f" ({r:.2f} %)") for v, r in curve]]
    errs = [f"{res.relative_error:.3f} %"]
    if res.asym is not None:
        cols.append("IDIM-LS asymmetric")
        th, rs = np.asarray(res.asym.theta), np.asarray(res.asym.rel_std)
        rows.append([f"{v:.{digits}f} ({r:.2f} %)" for v, r in zip(th, rs)])
        errs.append(f"{float(res.asym.relative_error):.3f} %")
    w0 = max(len("relative error"), *(len(n) for n in names))
    ws = [max(len(c), *(len(v) for v in col), len(e)) for c, col, e in zip(cols, rows, errs)]
    lines = ["  ".join([f"{'parameter':<{w0}}"] + [f"{c:>{w}}" for c, w in zip(cols, ws)])]
    for i, n in enumerate(names):
        lines.append("  ".join([f"{n:<{w0}}"] + [f"{col[i]:>{w}}" for col, w in zip(rows, ws)]))
    lines.append("  ".join([f"{'relative error':<{w0}}"] + [f"{e:>{w}}" for e, w in zip(errs, ws)]))
    lines.append(
        f"Fv-/Fv+ = {res.fv_ratio:.3f} (curve fit)"
        + ("" if res.asym is None else f", {_fv_ratio(res.asym):.3f} (IDIM-LS)")
        + f"; friction curve fit relative error {float(res.friction.relative_error):.3f} %"
    )
    return "\n".join(lines)


def _fv_ratio(r: IDIMResult) -> float:
    th = dict(zip(r.names, np.asarray(r.theta, dtype=float)))
    return float(th["Fv_neg"] / th["Fv_pos"])


@x64
def emps_idim_sdp(
    sdp_result,
    inputs: EMPSInputs | None = None,
    *,
    basis: Literal["parallel", "pointwise"] = "parallel",
    asym: IDIMResult | bool = True,
) -> EMPSIDIMSDP:
    r"""Parametric IDIM-SDP stage: the friction SDP curve regressed on eq. (17).

    $\hat d_{fric}(\dot q_k) = F_v^+ O^+(\dot q_k) + F_c^+\operatorname{sign}O^+(\dot q_k)
    + F_v^- O^-(\dot q_k) + F_c^-\operatorname{sign}O^-(\dot q_k) + \varepsilon_k$
    by least squares (`jaxsdp.parametric_stage`), then the final IDIM-LS
    with the asymmetric model.

    **Basis columns.** With `basis="parallel"` (default, needs `inputs`) the
    four columns are built on the undecimated velocity and decimated with the
    force (parallel decimation, `inputs.regression(emps_asym_regressors)`),
    so the Coulomb steps are low-pass filtered exactly as the force the SDP
    curve was estimated from; the curve, in time order, is regressed on them.
    With `basis="pointwise"` they are evaluated on the decimated velocity,
    i.e. the sorted curve is fitted by the ideal discontinuous law: the
    decimation filter smears the Coulomb step of the curve over
    $|\dot q| \lesssim |\ddot q|\,\tau$ (tau ~ the filter's delay spread),
    which biases $F_c$ down and $F_v$ up by a few per cent. (On a synthetic
    plant with 95 kg, 165/20/240/20.6: parallel 166.0/19.84/240.4/20.54,
    pointwise 170.0/19.07/244.0/19.79.)

    **No offset column:** for $\dot q \ne 0$,
    $\operatorname{sign}O^+(\dot q) - \operatorname{sign}O^-(\dot q) = 1$, so a
    constant column is exactly collinear with the two Coulomb columns. The
    SDP friction curve does contain the offset (the regressor 1 absorbs every
    constant force); in eq. (17) it is split into the two Coulomb levels
    ($F_c^+ = F_c + \text{offset}$, $F_c^- = F_c - \text{offset}$), as in the
    paper's Table 2 and the asymmetric IDIM-LS.

    **Arguments:**

    - `sdp_result`: an `EMPSSDPStage` (preferred), or a `jaxsdp.SDPResult` of
      the model `z = [ddq, 1]`, `x = [ddq, dq]` on `inputs` (then the mass is
      the acceleration-weighted mean of term 0).
    - `inputs`: the `EMPSInputs` of the SDP stage (needed for
      `basis="parallel"`, the asymmetric IDIM-LS and a `SDPResult`).
    - `basis`: `"parallel"` or `"pointwise"`, see above.
    - `asym`: True (default) to run the asymmetric IDIM-LS, False to skip
      it, or an `IDIMResult` already computed.

    **Returns:** an `EMPSIDIMSDP`.
    """
    if basis not in ("parallel", "pointwise"):
        raise ValueError(f"`basis` must be 'parallel' or 'pointwise'; got {basis!r}")
    if inputs is not None and not isinstance(inputs, EMPSInputs):
        raise ValueError(f"`inputs` must be an EMPSInputs or None; got {type(inputs).__name__}")
    if isinstance(sdp_result, EMPSSDPStage):
        curve, dq, ddq, y, mass = sdp_result.friction, sdp_result.dq, sdp_result.ddq, sdp_result.y, sdp_result.mass
    elif isinstance(sdp_result, SDPResult):
        if inputs is None:
            raise ValueError("`inputs` is required when `sdp_result` is a jaxsdp.SDPResult")
        curve, dq, ddq, y = sdp_result.par[:, 1], inputs.dq, inputs.ddq, inputs.y
        if sdp_result.par.ndim != 2 or sdp_result.par.shape[1] != 2:
            raise ValueError(f"`sdp_result` must have 2 terms (mass, friction); got par shape {sdp_result.par.shape}")
        mass = _weighted_mass(sdp_result.par[:, 0], ddq)
    else:
        raise ValueError(f"`sdp_result` must be an EMPSSDPStage or SDPResult; got {type(sdp_result).__name__}")
    needs_inputs = basis == "parallel" or (asym is True)
    if needs_inputs and inputs is None:
        raise ValueError(
            "`inputs` is required for basis='parallel' and for the asymmetric IDIM-LS "
            "(or pass basis='pointwise', asym=False)"
        )
    reg = None if inputs is None else inputs.regression(emps_asym_regressors)
    if reg is not None and reg.y.shape[0] != curve.shape[0]:
        raise ValueError(
            f"`inputs` has {reg.y.shape[0]} decimated samples but the SDP curve has {curve.shape[0]}: "
            "not the inputs of this SDP stage"
        )
    if basis == "parallel":
        phi = Regressors(X=reg.X[:, 1:], names=reg.names[1:])
    else:
        phi = asym_friction_basis(dq)
    fric = parametric_stage(curve, phi)
    theta = jnp.concatenate([jnp.asarray([mass]), fric.theta])
    if reg is not None:
        # The model is linear in its parameters: assess it like IDIM-LS, on
        # the parallel-decimated regressors (sign columns filtered like y).
        y_rel, X_rel = reg.y, reg.X
    else:
        # Only the SDP data: the regressors evaluated on the decimated signals.
        y_rel, X_rel = y, jnp.concatenate([ddq[:, None], asym_friction_basis(dq).X], axis=1)
    rel = float(100.0 * jnp.linalg.norm(y_rel - X_rel @ theta) / jnp.linalg.norm(y_rel))
    if isinstance(asym, IDIMResult):
        asym_res = asym
    elif asym:
        asym_res = idim_ls(reg.y, reg.X, names=reg.names)
    else:
        asym_res = None
    return EMPSIDIMSDP(
        friction=fric, mass=float(mass), fv_ratio=_fv_ratio(fric), relative_error=rel, asym=asym_res,
        basis=basis,
    )


# --------------------------------------------------------------------------- #
# Full study
# --------------------------------------------------------------------------- #


class EMPSStudy(eqx.Module):
    """All results of `emps_study`.

    **Fields:** `inputs` (`EMPSInputs`), `idim` (IDIM-LS, symmetric model
    `M, Fv, Fc, offset`), `idim_asym` (IDIM-LS, asymmetric model), `sdp`
    (`EMPSSDPStage`), `idim_sdp` (`EMPSIDIMSDP`), `timings` (stage ->
    seconds: `load`, `derivatives`, `idim_ls`, `idim_ls_asym`, `sdp`,
    `idim_sdp`, `total`), `source` (file name or description), `samples`
    (raw samples), `sample_time` (raw sample time, s), `preprocessing`
    (description), `derivatives` ("butterworth" or "smooth").
    """

    inputs: EMPSInputs
    idim: IDIMResult
    idim_asym: IDIMResult
    sdp: EMPSSDPStage
    idim_sdp: EMPSIDIMSDP
    timings: dict
    source: str = eqx.field(static=True)
    samples: int = eqx.field(static=True)
    sample_time: float = eqx.field(static=True)
    preprocessing: str = eqx.field(static=True)
    derivatives: str = eqx.field(static=True)

    def summary(self) -> dict:
        """JSON-ready dict: `idim_ls`, `idim_ls_asym`, `sdp`, `idim_sdp`, `timings`, `data`."""
        return study_summary(self)

    def tables(self) -> str:
        """The paper's Table 1 (IDIM-LS), the SDP stage and Table 2 (IDIM-SDP) as text."""
        return study_tables(self)


def _theta(r: IDIMResult) -> dict:
    return {n: float(v) for n, v in zip(r.names, np.asarray(r.theta, dtype=float))}


def study_summary(study: EMPSStudy) -> dict:
    """Plain-Python summary of an `EMPSStudy` (keys of the CLI's `summary.json`
    except `simulation`)."""
    i, a, s, p = study.idim, study.idim_asym, study.sdp, study.idim_sdp
    se = [None if not np.isfinite(v) else float(v) for v in np.asarray(s.log10_nvr_se, dtype=float)]
    return {
        "idim_ls": {**_theta(i), "relative_error": float(i.relative_error)},
        "idim_ls_asym": {
            **_theta(a),
            "relative_error": float(a.relative_error),
        },
        "sdp": {
            "nvr_mass": s.nvr_mass,
            "nvr_friction": s.nvr_friction,
            "log10_nvr_se": se,
            "mass_constant": bool(s.mass_constant),
            "mass": s.mass,
            "relative_error": s.relative_error,
            "model": s.model,
            "nvr_search": s.nvr_search,
            "sweeps": int(s.result.sweeps),
        },
        "idim_sdp": {
            **p.theta,
            "fv_ratio": p.fv_ratio,
            "relative_error": p.relative_error,
            "curve_fit_relative_error": float(p.friction.relative_error),
        },
        "timings": {k: float(v) for k, v in study.timings.items()},
        "data": {
            "source": study.source,
            "samples": int(study.samples),
            "sample_time": float(study.sample_time),
            "preprocessing": study.preprocessing,
            "decimated_samples": int(study.inputs.y.shape[0]),
            "decimated_sample_time": float(study.inputs.dt),
        },
    }


def study_tables(study: EMPSStudy) -> str:
    """Text tables of an `EMPSStudy`."""
    return "\n\n".join(
        [
            f"Data: {study.source}, {study.samples} samples, dt = {study.sample_time:g} s; {study.preprocessing}",
            "Table 1. IDIM-LS, linear friction model\n" + study.idim.table(),
            "IDIM-LS, asymmetric friction model (eq. 18)\n" + study.idim_asym.table(),
            study.sdp.table(),
            "Table 2. IDIM-SDP, asymmetric friction model (eq. 17)\n" + study.idim_sdp.table(),
        ]
    )


def _ready(tree):
    jax.block_until_ready(jax.tree.leaves(eqx.filter(tree, eqx.is_array)))
    return tree


def _load(data):
    if isinstance(data, (str, os.PathLike)):
        path = pathlib.Path(data)
        if path.suffix.lower() == ".mat":
            return load_emps(path), path.name
        return load_measurements(path), path.name
    if isinstance(data, (EMPSData, Measurements)):
        return data, type(data).__name__
    raise ValueError(f"`data` must be a path, an EMPSData or a Measurements; got {type(data).__name__}")


@x64
def emps_study(
    data,
    *,
    derivatives: Literal["butterworth", "smooth"] = "butterworth",
    cutoff_hz: float | None = 100.0,
    order: int = 4,
    smooth_nvr: float | None = None,
    drop: int = 49,
    decimate: int = 10,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
    model="RW",
    nvr_search: Literal["captain", "sdp"] = "sdp",
    max_nvr: float | None = 1.0,
    constant_nvr: float = CONSTANT_NVR,
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> EMPSStudy:
    """Run the whole EMPS study with per-stage timings.

    **Arguments:**

    - `data`: a path (`.mat`: `jaxsdp.load_emps`; otherwise the CSV format of
      `jaxsdp.load_measurements`), an `EMPSData` or a `Measurements`.
    - `derivatives`: `"butterworth"` (standard: zero-phase Butterworth of
      `order` at `cutoff_hz`, central differences; `jaxsdp.emps_preprocess`)
      or `"smooth"` (`emps_preprocess_smooth`: `cutoff_hz`, or `smooth_nvr`,
      or ML if both are None).
    - `drop`, `decimate`, `mode`: border removal and decimation.
    - `model`, `nvr_search`, `max_nvr`, `constant_nvr`: the SDP stage
      (`emps_sdp_stage`).
    - `source`: description for the summary (default: file name or type).
    - `progress`: optional callback called with each stage name before it runs.

    Stages (keys of `timings`): `load` (0 unless `data` is a path),
    `derivatives`, `idim_ls`, `idim_ls_asym`, `sdp`, `idim_sdp`, and `total`.
    Times include JAX compilation the first time a shape is seen.
    """
    if derivatives not in ("butterworth", "smooth"):
        raise ValueError(f"`derivatives` must be 'butterworth' or 'smooth'; got {derivatives!r}")
    timings = {}
    note = progress if progress is not None else (lambda stage: None)

    def timed(stage, fn):
        note(stage)
        t0 = time.perf_counter()
        out = _ready(fn())
        timings[stage] = time.perf_counter() - t0
        return out

    start = time.perf_counter()
    data, name = timed("load", lambda: _load(data))
    if derivatives == "butterworth":
        if cutoff_hz is None:
            raise ValueError("`cutoff_hz` is required with derivatives='butterworth'")
        inputs = timed(
            "derivatives",
            lambda: emps_preprocess(data, cutoff_hz=cutoff_hz, order=order, drop=drop, decimate=decimate, mode=mode),
        )
        prep = f"Butterworth order {order} at {cutoff_hz:g} Hz + central differences"
    else:
        inputs = timed(
            "derivatives",
            lambda: emps_preprocess_smooth(
                data, cutoff_hz=cutoff_hz, nvr=smooth_nvr, drop=drop, decimate=decimate, mode=mode
            ),
        )
        prep = "smoothing derivatives " + (
            f"(cut-off {cutoff_hz:g} Hz)" if cutoff_hz is not None
            else f"(NVR {smooth_nvr:.3g})" if smooth_nvr is not None else "(ML NVR)"
        )
    prep += f", first {drop} samples dropped, decimation by {decimate} ({mode})"

    def ls(builder):
        reg = inputs.regression(builder)
        return idim_ls(reg.y, reg.X, names=reg.names)

    idim = timed("idim_ls", lambda: ls(emps_regressors))
    idim_asym = timed("idim_ls_asym", lambda: ls(emps_asym_regressors))
    stage = timed(
        "sdp",
        lambda: emps_sdp_stage(
            inputs, model=model, nvr_search=nvr_search, max_nvr=max_nvr, constant_nvr=constant_nvr
        ),
    )
    idim_sdp = timed("idim_sdp", lambda: emps_idim_sdp(stage, inputs, asym=idim_asym))
    timings["total"] = time.perf_counter() - start
    return EMPSStudy(
        inputs=inputs,
        idim=idim,
        idim_asym=idim_asym,
        sdp=stage,
        idim_sdp=idim_sdp,
        timings=timings,
        source=name if source is None else source,
        samples=int(np.shape(data.force)[0]),
        sample_time=float(data.dt),
        preprocessing=prep,
        derivatives=derivatives,
    )
