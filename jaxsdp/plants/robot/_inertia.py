"""A link's standard inertial parameters from its mass, centre of mass and inertia about it (parallel axis)."""

import numpy as np

from ..._runtime import x64


@x64
def link_parameters(mass, com, inertia_com, psi=0.0) -> np.ndarray:
    r"""Standard inertial parameters `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` of a link about its frame origin.

    $J = R_z(\psi) I_c R_z(\psi)^T + m (|c|^2 I - c c^T)$, $MS = m c$, from the mass
    $m$ (kg), the centre of mass $c$ (m, in the link frame) and the inertia about
    the centre of mass $I_c$ (kg m^2; a 3x3 matrix or its six entries
    `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`), given in a frame turned by `psi` (rad)
    about z.

    Example:
        >>> from jaxsdp.plants import link_parameters
        >>> p = link_parameters(2.0, [0.5, 0.0, 0.0], [0.1, 0, 0, 0.1, 0, 0.1])  # a rod's point mass
        >>> p.round(3).tolist()  # ZZ = 0.1 + 2 * 0.25
        [0.1, 0.0, 0.0, 0.6, 0.0, 0.6, 1.0, 0.0, 0.0, 2.0]
    """
    c = np.asarray(com, dtype=float)
    Ic = np.asarray(inertia_com, dtype=float)
    if Ic.shape == (6,):
        Ic = np.array([[Ic[0], Ic[1], Ic[2]], [Ic[1], Ic[3], Ic[4]], [Ic[2], Ic[4], Ic[5]]])
    if c.shape != (3,) or Ic.shape != (3, 3) or not np.all(np.isfinite(Ic)) or not mass >= 0:
        raise ValueError("`com` must have 3 entries, `inertia_com` 6 or 3x3, all finite, and `mass` >= 0")
    R = np.array([[np.cos(psi), -np.sin(psi), 0.0], [np.sin(psi), np.cos(psi), 0.0], [0.0, 0.0, 1.0]])
    J = R @ Ic @ R.T + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2], *(mass * c), mass])


def link_body(standard) -> tuple[float, np.ndarray, np.ndarray]:
    """The inverse of `link_parameters` (psi = 0): a link's mass (kg), centre of mass (m, link frame) and inertia about
    the centre of mass (3, 3) (kg m^2, link frame axes) from its standard parameters; a link of no positive mass has
    its centre of mass at the origin."""
    xx, xy, xz, yy, yz, zz, hx, hy, hz, m = (float(v) for v in np.asarray(standard, dtype=float))
    c = np.array([hx, hy, hz]) / m if m > 0 else np.zeros(3)
    J = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]) - m * (c @ c * np.eye(3) - np.outer(c, c))
    return m, c, J
