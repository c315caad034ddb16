"""SDP stage of the EMPS study (paper section 2.5, eq. 13): y = M(ddq) ddq + d_fric(dq) + e.

**NVR search.** By default (`nvr_search="sdp"`) `jaxsdp.sdp` estimates
the NVRs by gradient (BFGS) maximum likelihood on the first sweep.
`emps_sdp_stage(nvr_search="captain")` (`jaxsdp.CaptainNVR`) estimates them as the
CAPTAIN toolbox does: for each term in order, the concentrated likelihood of the sorted
partial residual is minimised over log10 NVR by Nelder-Mead (MATLAB
`fminsearch` simplex, started at `nvr0` = 1e-4, tolerance 0.01 on
log10 NVR), capped at `max_nvr`; the back-fitting then runs
`jaxsdp.sdp` with these NVRs fixed (its first sweep repeats exactly the
smoothing the search used). On the real EMPS data both reach the same
conclusions (mass constant, friction NVR at its cap, SDP mass 95.1826 kg,
relative error 1.692 %) but not the same mass NVR: the simplex stops at
1e-23, BFGS at ~4e-12, both deep in the flat region far below the
constancy threshold 1e-6 (`tests/test_emps_study.py` runs both).

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
sum_k M_k ddq_k^2 / sum_k ddq_k^2: the constant mass whose
inertia force M ddq_k is closest (least squares) to the SDP one
M_k ddq_k. Samples with ddq ~ 0 carry no information
on M (their M_k is an interpolation with large standard error), so
they get no weight. When the mass NVR is ~0 all M_k are equal and
this is simply that value; `mass_mean` is the plain mean.
"""

from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._idim.trust import nvr_bound, nvr_text
from ..._kalman.nvr import LOG10_NVR_BOUNDS
from ..._runtime import x64
from ..._sdp.backfit import CONSTANT_NVR, SDPResult
from ..._sdp.options import MLNVR, Backfitting, CaptainNVR, FixedNVR
from ..._signal.preprocess import Preprocessed


class EMPSSDPStage(eqx.Module):
    r"""SDP stage of the EMPS study, $y = M(\ddot q) \ddot q + d_{fric}(\dot q) + e$.

    **Fields:**

    - `result`: the `jaxsdp.SDPResult` (term 0 the mass $M(\ddot q)$, term 1
      the friction $d_{fric}(\dot q)$; `par`, `x_sorted`, `par_sorted`, ...).
    - `nvr_mass`, `nvr_friction`: the NVRs; `log10_nvr_se`: (2,) curvature
      standard errors of $\log_{10} NVR$ (inf on a flat likelihood, NaN for a
      fixed NVR or one on a bound).
    - `mass_constant`: mass NVR below `constant_nvr` (acceleration-independent).
    - `mass`: SDP mass, acceleration-weighted mean
      $\sum_k M_k \ddot q_k^2 / \sum_k \ddot q_k^2$ (kg): the constant mass closest (least
      squares) to the SDP inertia force; samples with $\ddot q \approx 0$ carry no weight;
      `mass_mean`: plain mean of $M_k$.
    - `relative_error`: $100 \|y - \hat y\| / \|y\|$ (%); `r2`.
    - `y`, `ddq`, `dq`: the signals used (decimated), `dt` their period (s).
    - `model`: parameter model name(s); `nvr_search`: "captain", "sdp" or "fixed";
      `constant_nvr`: the threshold; `max_nvr`: the cap on the NVRs (None: none).
    - `nvr_bound`: per term (mass, friction), `"upper"` when the NVR is at the
      cap `max_nvr`, `"lower"` at the search's lower bound, else None. An NVR on
      a bound has no meaningful standard error.
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
    max_nvr: float | None = eqx.field(static=True, default=None)
    nvr_bound: tuple = eqx.field(static=True, default=(None, None))

    @property
    @x64
    def friction(self) -> jax.Array:
        """SDP friction d_fric(dq_k) in time order (N)."""
        return self.result.par[:, 1]

    @property
    @x64
    def mass_curve(self) -> jax.Array:
        """SDP mass M(ddq_k) in time order (kg)."""
        return self.result.par[:, 0]

    @x64
    def table(self) -> str:
        """Text summary: NVRs, mass, relative error."""
        return sdp_stage_table(self)


def sdp_stage_table(stage: EMPSSDPStage) -> str:
    """Format an `EMPSSDPStage` as text."""
    se = np.asarray(stage.log10_nvr_se, dtype=float)
    nvr_m, nvr_f = (
        nvr_text(v, float(e), b, max_nvr=stage.max_nvr)
        for v, e, b in zip((stage.nvr_mass, stage.nvr_friction), se, stage.nvr_bound)
    )
    flag = "constant (acceleration-independent)" if stage.mass_constant else "state-dependent"
    lines = [
        f"SDP stage y = M(ddq)*ddq + d_fric(dq)   [{stage.model}, NVRs: {stage.nvr_search}]",
        f"  NVR M(ddq)      = {nvr_m}  -> mass {flag}",
        f"  NVR d_fric(dq)  = {nvr_f}",
        f"  SDP mass        = {stage.mass:.4f} kg (acceleration-weighted; plain mean {stage.mass_mean:.4f})",
        (
            f"  relative error  = {stage.relative_error:.3f} %   (R^2 = {stage.r2:.6f}, "
            f"{int(stage.result.sweeps)} sweeps)"
        ),
    ]
    return "\n".join(lines)


def sdp_regression(inputs: Preprocessed):
    """The SDP stage's model on `inputs`: (y, z, x) with y_k = M(ddq_k) ddq_k + d_fric(dq_k) * 1 + e_k,
    regressors z = [ddq, 1] and states x = [ddq, dq] (pure `jnp`: traceable, vmappable)."""
    ddq, dq = inputs.ddq, inputs.dq
    return inputs.y, jnp.stack([ddq, jnp.ones_like(ddq)], axis=1), jnp.stack([ddq, dq], axis=1)


def weighted_mass(M, ddq):
    """The acceleration-weighted SDP mass sum_k M_k ddq_k^2 / sum_k ddq_k^2 (kg; pure `jnp`, a 0-d array)."""
    w = ddq**2
    return jnp.sum(M * w) / jnp.sum(w)


def _model_name(model) -> str:
    if isinstance(model, str):
        return model.upper()
    if isinstance(model, (list, tuple)):
        return "/".join(_model_name(m) for m in model)
    return getattr(model, "name", type(model).__name__)


@x64
def emps_sdp_stage(
    inputs: Preprocessed,
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

    $y_k = M(\ddot q_k) \ddot q_k + d_{fric}(\dot q_k) + e_k$ (force in N, mass in kg) on the
    decimated signals of `inputs` (`y`, `ddq`, `dq`): regressors $z = [\ddot q, 1]$,
    states $x = [\ddot q, \dot q]$, back-fitted by `jaxsdp.sdp`: each parameter is a
    random walk along its sorted state, smoothed by the Kalman filter and
    fixed-interval smoother, with the NVRs found by maximum likelihood.

    **Arguments:**

    - `inputs`: a `jaxsdp.Preprocessed` (`emps_preprocess`).
    - `model`: `"RW"` (default), `"IRW"`, ... or one per term (mass, friction).
    - `nvr`: None (ML for both), or (2,) fixed NVRs with NaN entries estimated.
    - `nvr_search`: `"sdp"` (default: `jaxsdp.sdp`'s gradient ML search) or
      `"captain"` (CAPTAIN's search: for each term in order, Nelder-Mead on
      $\log_{10} NVR$ of the first sweep's concentrated likelihood, from `nvr0`,
      tolerance 0.01, capped at `max_nvr`; then back-fitting with these NVRs
      fixed). On the EMPS data both find the mass constant at decimation 10
      (3.8e-12 and 1e-23: a flat likelihood below ~1e-6).
    - `nvr0`: start of the search (CAPTAIN's 1e-4); `max_nvr`: cap (1).
    - `constant_nvr`: mass NVRs below it flag the mass constant (1e-6).
    - `max_sweeps`, `tol`, `P0`: passed to `jaxsdp.sdp`.

    **Returns:** an `EMPSSDPStage`.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_preprocess
        >>> data, truth, _ = emps_builtin_data(0)
        >>> stage = emps_sdp_stage(emps_preprocess(data))
        >>> stage.mass_constant, round(stage.mass, 1), stage.nvr_bound
        (True, 95.5, (None, 'upper'))
    """
    if not isinstance(inputs, Preprocessed):
        raise ValueError(f"`inputs` must be a jaxsdp.Preprocessed; got {type(inputs).__name__}")
    backfitting, search_se = sdp_backfitting(
        inputs, model=model, nvr=nvr, nvr_search=nvr_search, nvr0=nvr0, max_nvr=max_nvr, constant_nvr=constant_nvr,
        max_sweeps=max_sweeps, tol=tol, P0=P0,
    )  # fmt: skip
    res = backfitting(*sdp_regression(inputs))
    return sdp_stage_from(
        res, inputs, model=model, nvr=nvr, nvr_search=nvr_search, max_nvr=max_nvr, constant_nvr=constant_nvr,
        search_se=search_se,
    )  # fmt: skip


def sdp_backfitting(inputs, *, model, nvr, nvr_search, nvr0, max_nvr, constant_nvr, max_sweeps=10, tol=1e-3, P0=1e5):
    """The SDP stage's `Backfitting` for `emps_sdp_stage`'s options, and the curvature standard errors of the
    CAPTAIN search (None for the gradient search, whose own are in its `SDPResult`).

    `nvr_search="sdp"`: ML by gradient inside the back-fitting (`MLNVR`; pure). `"captain"`: the NVRs found
    here, on the host, by CAPTAIN's simplex search (`CaptainNVR`, `captain_nvrs`), then fixed (`FixedNVR`)."""
    if nvr_search not in ("captain", "sdp"):
        raise ValueError(f"`nvr_search` must be 'captain' or 'sdp'; got {nvr_search!r}")
    search = CaptainNVR if nvr_search == "captain" else MLNVR
    options = Backfitting(
        model=model, nvr=search(nvr0, max_nvr, fixed=nvr), max_sweeps=max_sweeps, tol=tol, P0=P0,
        constant_nvr=constant_nvr,
    )  # fmt: skip
    return searched_backfitting(options, inputs)


def searched_backfitting(options: Backfitting, inputs: Preprocessed) -> tuple[Backfitting, np.ndarray | None]:
    """`options` with a `CaptainNVR` search run on the host on the SDP stage's regression of `inputs` and its NVRs
    fixed, and that search's curvature standard errors (`Backfitting.searched`); other options as they are, None."""
    return options.searched(*sdp_regression(inputs))


def stage_options(options: Backfitting) -> dict:
    """The keywords of `sdp_stage_from` (and `fits_from`) that a `Backfitting` stands for: `model`, `nvr` (the
    fixed NVRs, NaN where searched, or None), `nvr_search` ("sdp" for `MLNVR`, "captain" for `CaptainNVR`,
    "fixed" for `FixedNVR`), `max_nvr`, `constant_nvr`."""
    if not isinstance(options, Backfitting):
        raise ValueError(f"`sdp` must be a jaxsdp.Backfitting; got {options!r}")
    search = options.nvr
    kind = {MLNVR: "sdp", CaptainNVR: "captain", FixedNVR: "fixed"}[type(search)]
    fixed = search.nvr if isinstance(search, FixedNVR) else search.fixed
    return dict(
        model=options.model,
        nvr=None if fixed is None else np.asarray(fixed, dtype=float),
        nvr_search=kind,
        max_nvr=options.max_nvr,
        constant_nvr=options.constant_nvr,
    )


def sdp_stage_with(options: Backfitting, inputs: Preprocessed) -> EMPSSDPStage:
    """The SDP stage on `inputs` with the back-fitting `options` (a `CaptainNVR` search first, on the host): what
    `emps_sdp_stage` does with the keywords `options` stands for."""
    backfitting, search_se = searched_backfitting(options, inputs)
    res = backfitting(*sdp_regression(inputs))
    return sdp_stage_from(res, inputs, search_se=search_se, **stage_options(options))


def sdp_stage_from(
    res: SDPResult, inputs: Preprocessed, *, model, nvr, nvr_search, max_nvr, constant_nvr, search_se=None
) -> EMPSSDPStage:
    """The `EMPSSDPStage` of a back-fitting result on `inputs` (host side: NVR bounds, standard errors, the
    mass-constancy flag, Python floats)."""
    ddq, dq = inputs.ddq, inputs.dq
    se = np.asarray(res.log10_nvr_se)
    if search_se is not None:
        se = np.where(np.isnan(search_se), se, search_se)
    nv = np.asarray(res.nvr, dtype=float)
    fixed = np.zeros(2, bool) if nvr is None else ~np.isnan(np.broadcast_to(np.asarray(nvr, dtype=float), (2,)))
    bounds = tuple(
        None if f else nvr_bound(float(v), max_nvr=max_nvr, lower_log10=LOG10_NVR_BOUNDS[0]) for v, f in zip(nv, fixed)
    )
    se = np.where([b is not None for b in bounds], np.nan, se)
    return EMPSSDPStage(
        result=res,
        nvr_mass=float(nv[0]),
        nvr_friction=float(nv[1]),
        log10_nvr_se=se,
        mass_constant=bool(nv[0] < constant_nvr),
        mass=float(weighted_mass(res.par[:, 0], ddq)),
        mass_mean=float(np.mean(np.asarray(res.par[:, 0]))),
        relative_error=float(res.relative_error),
        r2=float(res.r2),
        y=inputs.y,
        ddq=ddq,
        dq=dq,
        dt=float(inputs.dt),
        model=_model_name(model),
        nvr_search=nvr_search,
        constant_nvr=float(constant_nvr),
        max_nvr=None if max_nvr is None else float(max_nvr),
        nvr_bound=bounds,
    )
