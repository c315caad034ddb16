r"""The EMPS inverse dynamic model: regressors of the linear and the asymmetric friction models.

$\tau = M\ddot q + F_v\dot q + F_c\operatorname{sign}\dot q + \text{offset}$
(the benchmark's model) and its direction-dependent friction variant,
eqs. (17)-(18) of the SDP paper. These are the columns IDIM-LS regresses the
force on (`jaxsdp.idim_ls`, parallel decimation by
`jaxsdp.Preprocessed.regression`) and that the parametric IDIM-SDP stage
regresses the friction SDP curve on.
"""

import jax
import jax.numpy as jnp
from jaxtyping import ArrayLike

from .._checks import as_float_array
from .._runtime import x64
from .._signal.regressors import Regressors


def _motion(dq, ddq):
    dq = as_float_array("dq", dq, ndim=1)
    ddq = as_float_array("ddq", ddq, ndim=1)
    if dq.shape != ddq.shape:
        raise ValueError(f"`dq` and `ddq` must have the same shape; got {tuple(dq.shape)} and {tuple(ddq.shape)}")
    return dq, ddq


@x64
def emps_regressors(dq: ArrayLike, ddq: ArrayLike) -> Regressors:
    r"""EMPS inverse dynamic model $\tau = M\ddot q + F_v \dot q + F_c
    \operatorname{sign}(\dot q) + \text{offset}$.

    Columns `[ddq, dq, sign(dq), 1]` named `("M", "Fv", "Fc", "offset")`
    (units kg, N/(m/s), N, N for SI inputs). `sign(0) = 0` as in MATLAB.
    """
    dq, ddq = _motion(dq, ddq)
    X = jnp.stack([ddq, dq, jnp.sign(dq), jnp.ones_like(dq)], axis=1)
    return Regressors(X=X, names=("M", "Fv", "Fc", "offset"))


@x64
def emps_asym_regressors(dq: ArrayLike, ddq: ArrayLike) -> Regressors:
    r"""EMPS model with direction-dependent friction (eqs. 17-18 of the SDP paper).

    $\tau = M\ddot q + F_v^+ O^+(\dot q) + F_c^+ \operatorname{sign}(O^+(\dot q))
    + F_v^- O^-(\dot q) + F_c^- \operatorname{sign}(O^-(\dot q))$, with
    $O^\pm(v) = v (1 \pm \operatorname{sign} v)/2$ (so $O^+(v) = \max(v, 0)$,
    $O^-(v) = \min(v, 0)$). Columns named
    `("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")`; no offset column.
    """
    dq, ddq = _motion(dq, ddq)
    s = jnp.sign(dq)
    pos = dq * (1 + s) / 2
    neg = dq * (1 - s) / 2
    X = jnp.stack([ddq, pos, jnp.sign(pos), neg, jnp.sign(neg)], axis=1)
    return Regressors(X=X, names=("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"))


@x64
def asym_friction_basis(dq) -> Regressors:
    r"""Asymmetric friction basis of eq. (17):
    $[O^+(\dot q), \operatorname{sign}O^+(\dot q), O^-(\dot q), \operatorname{sign}O^-(\dot q)]$,
    named `("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")` (the friction columns of
    `emps_asym_regressors`; no offset column, see `jaxsdp.studies.emps.emps_idim_sdp`)."""
    dq = as_float_array("dq", dq, ndim=1)
    regs = emps_asym_regressors(dq, jnp.zeros_like(dq))
    return Regressors(X=regs.X[:, 1:], names=regs.names[1:])


def asym_friction(theta, dq) -> jax.Array:
    """Friction force of eq. (17) with `theta = (Fv_pos, Fc_pos, Fv_neg, Fc_neg)`."""
    with jax.enable_x64(True):
        return asym_friction_basis(dq).X @ jnp.asarray(theta, dtype=jnp.float64)
