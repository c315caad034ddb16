"""Parametric IDIM-SDP stage of the EMPS study (paper section 2.6, Table 2).

The friction SDP curve of the SDP stage regressed on the asymmetric friction
model of eq. (17), then the final IDIM-LS with that model.
"""

from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._idim.ls import IDIMResult, idim_ls
from ..._idim.parametric import parametric_stage
from ..._runtime import x64
from ..._sdp.backfit import SDPResult
from ..._signal.preprocess import Preprocessed
from ..._signal.regressors import Regressors
from ._model import asym_friction_basis
from ._preprocess import emps_regression
from ._sdp_stage import EMPSSDPStage, weighted_mass


class EMPSIDIMSDP(eqx.Module):
    r"""Parametric IDIM-SDP stage (paper section 2.6, Table 2).

    **Fields:**

    - `friction`: `IDIMResult` of the SDP friction curve $d_{fric}(\dot q_k)$ (N)
      regressed on the eq. (17) basis (`Fv_pos` N/(m/s), `Fc_pos` N,
      `Fv_neg` N/(m/s), `Fc_neg` N); its `relative_error` is that of the
      curve fit (%). `basis`: "parallel" or "pointwise" (see `emps_idim_sdp`).
    - `mass`: the SDP mass (kg, `EMPSSDPStage.mass`).
    - `fv_ratio`: $F_v^- / F_v^+$ from the curve fit (asymmetry; 1 = symmetric).
    - `relative_error`: force relative error (%) of the resulting IDIM-SDP
      model $M \ddot q$ + eq. (17), $100 \|y - X \theta\| / \|y\|$, with the
      asymmetric regressors parallel-decimated as for IDIM-LS
      (`emps_regression(inputs, friction="asymmetric")`), or evaluated on the
      decimated SDP signals when no `inputs` are given.
    - `asym`: the final IDIM-LS with the asymmetric model
      `[ddq, O+, sign O+, O-, sign O-]` (parallel decimation), or None.

    `theta` gives `{"M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"}`, `table()`
    the paper's Table 2 layout.
    """

    friction: IDIMResult
    mass: float
    fv_ratio: float
    relative_error: float
    asym: IDIMResult | None
    basis: str = eqx.field(static=True, default="parallel")

    @property
    @x64
    def theta(self) -> dict:
        """`{"M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"}` of the parametric stage."""
        out = {"M": self.mass}
        out.update({n: float(v) for n, v in zip(self.friction.names, np.asarray(self.friction.theta))})
        return out

    @x64
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
        + ("" if res.asym is None else f", {fv_ratio(res.asym):.3f} (IDIM-LS)")
        + f"; friction curve fit relative error {float(res.friction.relative_error):.3f} %"
    )
    return "\n".join(lines)


def fv_ratio(r: IDIMResult) -> float:
    th = dict(zip(r.names, np.asarray(r.theta, dtype=float)))
    return float(th["Fv_neg"] / th["Fv_pos"])


@x64
def emps_idim_sdp(
    sdp_result,
    inputs: Preprocessed | None = None,
    *,
    basis: Literal["parallel", "pointwise"] = "parallel",
    asym: IDIMResult | bool = True,
) -> EMPSIDIMSDP:
    r"""Parametric IDIM-SDP stage: the friction SDP curve regressed on eq. (17).

    $$
    d_{fric}(\dot q_k) = F_v^+ O^+(\dot q_k) + F_c^+ sign(O^+(\dot q_k))
    + F_v^- O^-(\dot q_k) + F_c^- sign(O^-(\dot q_k)) + \varepsilon_k,
    $$

    $O^+(v) = \max(v, 0)$, $O^-(v) = \min(v, 0)$, solved by least squares
    (`jaxsdp.parametric_stage`; $d_{fric}$ in N, $\dot q$ in m/s, $F_v$ in N/(m/s), $F_c$ in
    N), then the final IDIM-LS with the asymmetric model.

    **Basis columns.** With `basis="parallel"` (default, needs `inputs`) the
    four columns are built on the undecimated velocity and decimated with the
    force (parallel decimation, `emps_regression(inputs, friction="asymmetric")`),
    so the Coulomb steps are low-pass filtered exactly as the force the SDP
    curve was estimated from; the curve, in time order, is regressed on them.
    With `basis="pointwise"` they are evaluated on the decimated velocity,
    i.e. the sorted curve is fitted by the ideal discontinuous law: the
    decimation filter smears the Coulomb step of the curve over
    $|\dot q| \lesssim |\ddot q| \tau$ ($\tau \sim$ the filter's delay spread),
    which biases Fc down and Fv up by a few per cent. (On a synthetic
    plant with 95 kg, 165/20/240/20.6: parallel 166.0/19.84/240.4/20.54,
    pointwise 170.0/19.07/244.0/19.79.)

    **No offset column:** for $\dot q \ne 0$,
    $sign(O^+(\dot q)) - sign(O^-(\dot q)) = 1$, so a
    constant column is exactly collinear with the two Coulomb columns. The
    SDP friction curve does contain the offset (the regressor 1 absorbs every
    constant force); in eq. (17) it is split into the two Coulomb levels
    ($F_c^+ = F_c + offset$, $F_c^- = F_c - offset$), as in the
    paper's Table 2 and the asymmetric IDIM-LS.

    **Arguments:**

    - `sdp_result`: an `EMPSSDPStage` (preferred), or a `jaxsdp.SDPResult` of
      the model `z = [ddq, 1]`, `x = [ddq, dq]` on `inputs` (then the mass is
      the acceleration-weighted mean of term 0).
    - `inputs`: the `jaxsdp.Preprocessed` of the SDP stage (needed for
      `basis="parallel"`, the asymmetric IDIM-LS and a `SDPResult`).
    - `basis`: `"parallel"` or `"pointwise"`, see above.
    - `asym`: True (default) to run the asymmetric IDIM-LS, False to skip
      it, or an `IDIMResult` already computed.

    **Returns:** an `EMPSIDIMSDP`.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.studies.emps import emps_idim_sdp, emps_preprocess, emps_sdp_stage
        >>> data, truth, _ = emps_builtin_data(0)
        >>> inputs = emps_preprocess(data)
        >>> res = emps_idim_sdp(emps_sdp_stage(inputs), inputs)
        >>> round(res.fv_ratio, 2), round(truth["fv_ratio"], 2)  # Fv_neg / Fv_pos
        (1.45, 1.44)
        >>> sorted(res.theta)
        ['Fc_neg', 'Fc_pos', 'Fv_neg', 'Fv_pos', 'M']
    """
    if basis not in ("parallel", "pointwise"):
        raise ValueError(f"`basis` must be 'parallel' or 'pointwise'; got {basis!r}")
    if inputs is not None and not isinstance(inputs, Preprocessed):
        raise ValueError(f"`inputs` must be a jaxsdp.Preprocessed or None; got {type(inputs).__name__}")
    if isinstance(sdp_result, EMPSSDPStage):
        curve, dq, ddq, y, mass = sdp_result.friction, sdp_result.dq, sdp_result.ddq, sdp_result.y, sdp_result.mass
    elif isinstance(sdp_result, SDPResult):
        if inputs is None:
            raise ValueError("`inputs` is required when `sdp_result` is a jaxsdp.SDPResult")
        curve, dq, ddq, y = sdp_result.par[:, 1], inputs.dq, inputs.ddq, inputs.y
        if sdp_result.par.ndim != 2 or sdp_result.par.shape[1] != 2:
            raise ValueError(f"`sdp_result` must have 2 terms (mass, friction); got par shape {sdp_result.par.shape}")
        mass = float(weighted_mass(sdp_result.par[:, 0], ddq))
    else:
        raise ValueError(f"`sdp_result` must be an EMPSSDPStage or SDPResult; got {type(sdp_result).__name__}")
    needs_inputs = basis == "parallel" or (asym is True)
    if needs_inputs and inputs is None:
        raise ValueError(
            "`inputs` is required for basis='parallel' and for the asymmetric IDIM-LS "
            "(or pass basis='pointwise', asym=False)"
        )
    reg = None if inputs is None else emps_regression(inputs, friction="asymmetric")
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
        friction=fric,
        mass=float(mass),
        fv_ratio=fv_ratio(fric),
        relative_error=rel,
        asym=asym_res,
        basis=basis,
    )
