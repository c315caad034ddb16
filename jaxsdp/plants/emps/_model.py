"""The EMPS inverse dynamic model: regressors of the linear and the asymmetric friction models.

force = M ddq + Fv dq + Fc sign(dq) + offset (the benchmark's model) and its
direction-dependent friction variant, eqs. (17)-(18) of the SDP paper. These are the columns IDIM-LS regresses the
force on (`jaxsdp.idim_ls`, parallel decimation by
`jaxsdp.Preprocessed.regression`) and that the parametric IDIM-SDP stage
regresses the friction SDP curve on.
"""

from typing import Literal

import jax
import jax.numpy as jnp
from jaxtyping import ArrayLike

from ..._checks import as_float_array
from ..._runtime import x64
from ..._signal.preprocess import Preprocessed
from ..._signal.regressors import Regression, Regressors

#: Parameter names of the EMPS linear-friction model (kg, N/(m/s), N, N), the columns of `emps_regressors`.
EMPS_LINEAR_NAMES = ("M", "Fv", "Fc", "offset")
#: Parameter names of the asymmetric-friction model (kg, N/(m/s), N, N/(m/s), N), the columns of `emps_asym_regressors`.
EMPS_ASYM_NAMES = ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")
#: Samples the EMPS benchmark's processing drops at the start of a record (its filters' transient).
EMPS_DROP = 49


def _motion(dq, ddq):
    dq = as_float_array("dq", dq, ndim=1)
    ddq = as_float_array("ddq", ddq, ndim=1)
    if dq.shape != ddq.shape:
        raise ValueError(f"`dq` and `ddq` must have the same shape; got {tuple(dq.shape)} and {tuple(ddq.shape)}")
    return dq, ddq


@x64
def emps_regressors(dq: ArrayLike, ddq: ArrayLike) -> Regressors:
    r"""Regressors of the EMPS inverse dynamic model (the benchmark's linear friction).

    $$ force = M \ddot q + F_v \dot q + F_c sign(\dot q) + offset $$

    Columns `[ddq, dq, sign(dq), 1]` named `("M", "Fv", "Fc", "offset")`:
    with `dq` in m/s and `ddq` in m/s^2 and the force in N, the parameters
    are in kg, N/(m/s), N, N. `sign(0) = 0` as in MATLAB.

    **Arguments:** `dq`, `ddq`: velocity and acceleration, shape `(N,)`.

    **Returns:** a `jaxsdp.Regressors` with `X` of shape `(N, 4)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import emps_regressors
        >>> reg = emps_regressors(np.array([-0.1, 0.0, 0.2]), np.array([1.0, 0.0, -1.0]))
        >>> reg.names
        ('M', 'Fv', 'Fc', 'offset')
        >>> np.asarray(reg.X).tolist()
        [[1.0, -0.1, -1.0, 1.0], [0.0, 0.0, 0.0, 1.0], [-1.0, 0.2, 1.0, 1.0]]
    """
    dq, ddq = _motion(dq, ddq)
    X = jnp.stack([ddq, dq, jnp.sign(dq), jnp.ones_like(dq)], axis=1)
    return Regressors(X=X, names=EMPS_LINEAR_NAMES)


@x64
def emps_asym_regressors(dq: ArrayLike, ddq: ArrayLike) -> Regressors:
    r"""Regressors of the EMPS model with direction-dependent friction (eqs. 17-18 of the SDP paper).

    $$ force = M \ddot q + F_v^+ O^+(\dot q) + F_c^+ sign(O^+(\dot q)) + F_v^- O^-(\dot q) + F_c^- sign(O^-(\dot q)), $$

    $$ O^+(v) = v (1 + sign(v)) / 2 = \max(v, 0), \quad O^-(v) = v (1 - sign(v)) / 2 = \min(v, 0). $$

    Columns named `("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")` (kg,
    N/(m/s), N, N/(m/s), N for `dq` in m/s, `ddq` in m/s^2, force in N); no
    offset column (it is collinear with the two Coulomb columns).

    **Arguments:** `dq`, `ddq`: velocity and acceleration, shape `(N,)`.

    **Returns:** a `jaxsdp.Regressors` with `X` of shape `(N, 5)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import emps_asym_regressors
        >>> reg = emps_asym_regressors(np.array([-0.1, 0.2]), np.array([1.0, -1.0]))
        >>> reg.names
        ('M', 'Fv_pos', 'Fc_pos', 'Fv_neg', 'Fc_neg')
        >>> (np.asarray(reg.X) + 0.0).tolist()
        [[1.0, 0.0, 0.0, -0.1, -1.0], [-1.0, 0.2, 1.0, 0.0, 0.0]]
    """
    dq, ddq = _motion(dq, ddq)
    s = jnp.sign(dq)
    pos = dq * (1 + s) / 2
    neg = dq * (1 - s) / 2
    X = jnp.stack([ddq, pos, jnp.sign(pos), neg, jnp.sign(neg)], axis=1)
    return Regressors(X=X, names=EMPS_ASYM_NAMES)


@x64
def asym_friction_basis(dq) -> Regressors:
    r"""Asymmetric friction basis of eq. (17): the friction columns of `emps_asym_regressors`.

    Columns `[O+(dq), sign(O+(dq)), O-(dq), sign(O-(dq))]` with
    $O^+(v) = \max(v, 0)$, $O^-(v) = \min(v, 0)$, named
    `("Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")` (coefficients in N/(m/s), N,
    N/(m/s), N for `dq` in m/s and a force in N); no offset column, see
    `jaxsdp.studies.emps.emps_idim_sdp`.

    **Arguments:** `dq`: velocity, shape `(N,)`.

    **Returns:** a `jaxsdp.Regressors` with `X` of shape `(N, 4)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import asym_friction_basis
        >>> basis = asym_friction_basis(np.array([-0.1, 0.2]))
        >>> (np.asarray(basis.X) + 0.0).tolist()
        [[0.0, 0.0, -0.1, -1.0], [0.2, 1.0, 0.0, 0.0]]
    """
    dq = as_float_array("dq", dq, ndim=1)
    regs = emps_asym_regressors(dq, jnp.zeros_like(dq))
    return Regressors(X=regs.X[:, 1:], names=regs.names[1:])


@x64
def asym_friction(theta, dq) -> jax.Array:
    r"""Friction force of eq. (17), `asym_friction_basis(dq).X @ theta`.

    $$ f(\dot q) = F_v^+ \dot q + F_c^+ \quad (\dot q > 0), $$

    $$ f(\dot q) = F_v^- \dot q - F_c^- \quad (\dot q < 0), \quad f(0) = 0, $$

    with `theta = (Fv_pos, Fc_pos, Fv_neg, Fc_neg)` (N/(m/s), N, N/(m/s), N)
    and `dq` (m/s), shape `(N,)`; returns the force (N), shape `(N,)`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import asym_friction
        >>> f = asym_friction([166.7, 20.14, 240.4, 20.63], np.array([-0.1, 0.0, 0.2]))
        >>> np.round(np.asarray(f), 2).tolist()
        [-44.67, 0.0, 53.48]
    """
    with jax.enable_x64(True):
        return asym_friction_basis(dq).X @ jnp.asarray(theta, dtype=jnp.float64)


@x64
def emps_regression(inputs: Preprocessed, *, friction: Literal["linear", "asymmetric"] = "linear") -> Regression:
    r"""The EMPS regressors on the full-rate signals of `inputs`, parallel-decimated with the force.

    `friction="linear"`: `jaxsdp.plants.emps_regressors`,
    $force = M \ddot q + F_v \dot q + F_c sign(\dot q) + offset$ (kg, N/(m/s), N, N);
    `"asymmetric"`: `jaxsdp.plants.emps_asym_regressors` (eqs. 17-18,
    `M, Fv_pos, Fc_pos, Fv_neg, Fc_neg`). Columns are built on `dq_full`,
    `ddq_full` and decimated with the force (`Preprocessed.regression`).
    The published IDIM-LS procedure is `idim_ls(reg.y, reg.X, names=reg.names)`.

    **Arguments:** `inputs`: a `jaxsdp.Preprocessed` (`jaxsdp.preprocess`, or
    `jaxsdp.studies.emps.emps_preprocess` for the benchmark's processing);
    `friction`: `"linear"` or `"asymmetric"`.

    **Returns:** a `jaxsdp.Regression` (`y` force in N, `X`, `names`).

    Example:
        >>> from jaxsdp import idim_ls
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.plants import emps_regression
        >>> from jaxsdp.studies.emps import emps_preprocess
        >>> data, truth, _ = emps_builtin_data(0)
        >>> reg = emps_regression(emps_preprocess(data))
        >>> reg.names, reg.X.shape
        (('M', 'Fv', 'Fc', 'offset'), (2480, 4))
        >>> round(idim_ls(reg.y, reg.X, names=reg.names)["M"], 1)  # kg (truth 95.15)
        95.4
    """
    if not isinstance(inputs, Preprocessed):
        raise ValueError(f"`inputs` must be a jaxsdp.Preprocessed; got {type(inputs).__name__}")
    builders = {"linear": emps_regressors, "asymmetric": emps_asym_regressors}
    if friction not in builders:
        raise ValueError(f"`friction` must be 'linear' or 'asymmetric'; got {friction!r}")
    return inputs.regression(builders[friction](inputs.dq_full, inputs.ddq_full))
