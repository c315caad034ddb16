r"""Second (parametric) SDP stage: a non-parametric SDP curve regressed on basis functions.

Given an estimated SDP curve $\hat c(x_k)$ (e.g. the friction $d(\dot q)$ of
`jaxsdp.sdp`) and user basis functions $\phi_i(x)$ of its state,

$$\hat c(x_k) = \sum_i \theta_i \phi_i(x_k) + \varepsilon_k$$

is solved by least squares exactly as IDIM-LS (`jaxsdp.idim_ls`): estimates,
relative standard deviations $100\,\sigma_i/|\theta_i|$ (%), relative error
$100\,\|\hat c - \Phi\hat\theta\| / \|\hat c\|$ (%) and condition number.
This is the paper's IDIM-SDP stage (section 2.6, Table 2; section 3.4, Table 4).
"""

from .._runtime import x64
from .ls import IDIMResult, idim_ls


@x64
def parametric_stage(curve, basis, *, names=None) -> IDIMResult:
    """Least-squares fit of an SDP curve (N,) on basis columns `basis` (N, k).

    `basis` may be an (N, k) array (with `names`) or a `jaxsdp.Regressors`.
    Returns an `IDIMResult` (fields `theta`, `std`, `rel_std`, `relative_error`, ...).
    """
    if hasattr(basis, "X") and hasattr(basis, "names"):
        names = basis.names if names is None else names
        basis = basis.X
    return idim_ls(curve, basis, names=names)
