"""Second (parametric) SDP stage: a non-parametric SDP curve regressed on basis functions.

Given an estimated SDP curve c_hat(x_k) (e.g. the friction d(dq) of
`jaxsdp.sdp`) and user basis functions phi_i(x) of its state, the model

    c_hat(x_k) = sum_i theta_i phi_i(x_k) + eps_k

is solved by least squares exactly as IDIM-LS (`jaxsdp.idim_ls`). This is
the paper's IDIM-SDP stage (section 2.6, Table 2; section 3.4, Table 4).
"""

from .._runtime import x64
from .ls import IDIMResult, idim_ls


@x64
def parametric_stage(curve, basis, *, names=None) -> IDIMResult:
    r"""Parametric SDP stage: least-squares fit of an SDP curve on basis functions of its state.

    Model: $\hat c(x_k) = \sum_i \theta_i \phi_i(x_k) + \varepsilon_k$, $k = 1..N$, with
    $\hat c$ the SDP estimate (e.g. the friction force $d(\dot q)$, N) and $\phi_i$
    basis functions of its state (e.g. $\dot q$ and $sign(\dot q)$); solved as IDIM-LS,
    $\hat\theta = \arg\min \|\hat c - \Phi \theta\|$.

    **Arguments:** `curve`: the SDP curve, shape `(N,)`; `basis`: the basis
    columns $\Phi$, an `(N, k)` array (with `names`, default `theta1, ...`) or a
    `jaxsdp.Regressors` (its names are used unless `names` is given).

    **Returns:** an `IDIMResult`: `theta` (units of the curve over those of
    each basis column, e.g. N/(m/s) for a viscous coefficient), `std`,
    `rel_std` $100 std_i / |\theta_i|$ (%), `relative_error`
    $100 \|\hat c - \Phi \theta\| / \|\hat c\|$ (%), `cond`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import parametric_stage
        >>> v = np.linspace(-1.0, 1.0, 41)  # velocity states, m/s
        >>> curve = 200 * v + 20 * np.sign(v) + 0.5 * np.cos(7 * v)  # friction SDP, N
        >>> res = parametric_stage(curve, np.c_[v, np.sign(v)], names=("Fv", "Fc"))
        >>> round(res["Fv"], 1), round(res["Fc"], 1)
        (200.0, 20.0)
    """
    if hasattr(basis, "X") and hasattr(basis, "names"):
        names = basis.names if names is None else names
        basis = basis.X
    return idim_ls(curve, basis, names=names)
