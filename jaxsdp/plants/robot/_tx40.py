"""The nominal six-joint Stäubli TX40 (`tx40_robot`): the paper's Table 3 kinematics and published nominal dynamics.

Numbers of `tx40.md` (the paper's Table 3 for the modified DH table; the
nominal CAD-style inertial, friction and drive values published with the
open-source FIGAROH TX40 identification example). The link inertias are
given there about each centre of mass, in a frame turned by psi about z_j;
`link_parameters` moves them to the standard parameters about the frame
origin. The wrist's extra motor-6 terms (motor 6 turning with joint 5) are
not part of this joint-side model.
"""

import math

import numpy as np

from ..._runtime import x64
from ._joint_model import GRAVITY
from ._serial import SerialRobot, link_parameters
from ._tx40_link2 import TX40_GEAR_RATIOS

#: Modified DH rows (alpha rad, d m, theta offset rad, r m), the paper's Table 3.
TX40_MDH = (
    (0.0, 0.0, 0.0, 0.0),
    (-math.pi / 2, 0.0, 0.0, 0.0),
    (0.0, 0.225, 0.0, 0.035),
    (math.pi / 2, 0.0, 0.0, 0.225),
    (-math.pi / 2, 0.0, 0.0, 0.0),
    (math.pi / 2, 0.0, 0.0, 0.0),
)
#: Per link: mass (kg), centre of mass (m, frame j), psi (rad), inertia about the centre of mass
#: [Ixx, Ixy, Ixz, Iyy, Iyz, Izz] (kg m^2) in the frame turned by psi about z_j.
TX40_LINKS = (
    (10.50, (0.000, 0.020, -0.043), 0.0, (0.055, 0.000, 0.000, 0.047, 0.003, 0.035)),
    (3.60, (0.109, -0.002, 0.134), -math.pi / 2, (0.009, 0.000, 0.002, 0.038, 0.000, 0.040)),
    (4.07, (0.008, 0.006, 0.041), -math.pi / 2, (0.012, 0.000, 0.001, 0.012, -0.001, 0.004)),
    (3.62, (-0.004, 0.002, -0.107), math.pi / 2, (0.013, 0.000, 0.000, 0.014, 0.001, 0.004)),
    (1.02, (-0.004, -0.003, -0.001), -math.pi / 2, (0.001, 0.000, 0.000, 0.001, 0.000, 0.001)),
    (0.20, (0.000, 0.000, 0.042), -math.pi / 2, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
)
#: Joint-side drives: actuator inertia (kg m^2), viscous (N m s/rad), Coulomb (N m), offset (N m).
TX40_DRIVES = dict(
    Ia=(0.362, 0.362, 0.0988, 0.0313, 0.0468, 0.0105),
    Fv=(8.05, 5.53, 1.97, 1.11, 1.86, 0.65),
    Fc=(7.14, 8.26, 6.34, 2.48, 3.03, 0.282),
    offset=(0.392, 1.37, 0.326, -0.102, -0.0288, 0.127),
)


@x64
def tx40_robot() -> SerialRobot:
    r"""The nominal Stäubli TX40: six revolute joints, modified DH table of the paper's Table 3.

    Link parameters `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` about each frame
    origin, converted from the nominal centre-of-mass values (`TX40_LINKS`,
    $J = R_z(\psi) I_c R_z(\psi)^T + m (|c|^2 I - c c^T)$, $MS = m c$); drives
    (`TX40_DRIVES`: Ia, Fv, Fc, offset, joint side) and gear ratios
    (32, 32, 45, -48, 45, 32); gravity 9.81 m/s^2 along -z_0. Joint angles
    in the MDH convention of Table 3.

    **Returns:** a `SerialRobot`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import tx40_robot
        >>> robot = tx40_robot()
        >>> robot.n, robot.ratios
        (6, (32.0, 32.0, 45.0, -48.0, 45.0, 32.0))
        >>> (np.round(np.asarray(robot.gravity_torques(np.zeros(6))), 2) + 0.0).tolist()  # N m, arm horizontal
        [0.0, -23.65, -0.14, 0.0, 0.04, 0.0]
    """
    inertial = np.stack([link_parameters(m, c, ic, psi) for m, c, psi, ic in TX40_LINKS])
    return SerialRobot.from_mdh(TX40_MDH, inertias=inertial, ratios=TX40_GEAR_RATIOS, g=GRAVITY, **TX40_DRIVES)
