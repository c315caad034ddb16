"""A `SerialRobot` from a URDF file (the description format of ROS, pinocchio, MuJoCo, FIGAROH).

Read with the standard library's XML parser (`xml.etree.ElementTree`): a
URDF is a small XML document, and the ecosystem's parsers either pull in a
ROS installation (`urdf_parser_py`, `urdfdom`) or a whole dynamics library
(pinocchio), whose model jaxsdp would then have to convert anyway; the
subset read here (links' `inertial`, joints' `origin`, `axis`, `limit`,
`mimic`, `type`) is what dynamics needs.

**Model.** The chain of joints from `base_link` to `tip_link`; each
revolute, continuous or prismatic joint on it is a joint of the robot
(unless `joints` names a subset), with its `origin` (xyz, and rpy as
R = Rz(yaw) Ry(pitch) Rx(roll)) and unit `axis`. Fixed joints, chain
joints left out of `joints`, and every branch hanging off the chain (a
gripper's fingers, a camera) are rigid: held at 0 and merged into the
moving link they hang from (`SerialRobot.locked` names the held joints);
their transforms fold into the next joint's origin. Each link's `inertial`
(mass, centre of mass and inertia about it, in the frame `origin` of the
link) is moved to the standard parameters about the moving frame
(J = R I_c R^T + m (|c|^2 I - c c^T), MS = m c). Links before the first
moving joint do not move and are left out. Gravity is 9.81 m/s^2 along
-z of `base_link`.
"""

import pathlib
import xml.etree.ElementTree as ET

import jax.numpy as jnp
import numpy as np

from ..._checks import OptionError
from ._inertia import link_parameters

#: Joint types that move.
MOVING_TYPES = ("revolute", "continuous", "prismatic")
#: Joint types a serial-chain model cannot hold.
UNSUPPORTED_TYPES = ("floating", "planar")


def _floats(text, n, what):
    try:
        v = np.array([float(x) for x in (text or "").split()], dtype=float)
    except ValueError:
        raise ValueError(f"{what}: not {n} numbers: {text!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what}: need {n} finite numbers; got {text!r}")
    return v


def rpy_matrix(rpy) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _origin(elem, what):
    """(R, p) of an `<origin>` child of `elem` (identity when absent)."""
    o = elem.find("origin") if elem is not None else None
    if o is None:
        return np.eye(3), np.zeros(3)
    xyz = _floats(o.get("xyz", "0 0 0"), 3, f"{what} origin xyz")
    rpy = _floats(o.get("rpy", "0 0 0"), 3, f"{what} origin rpy")
    return rpy_matrix(rpy), xyz


def _link_inertia(link):
    """(mass, centre of mass, inertia about it as 3x3) of a `<link>`, in the link's frame; zeros without one."""
    name = link.get("name")
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    m_el = inertial.find("mass")
    mass = float(m_el.get("value")) if m_el is not None else 0.0
    if not (np.isfinite(mass) and mass >= 0):
        raise ValueError(f"link '{name}': mass must be finite and >= 0; got {mass}")
    R, c = _origin(inertial, f"link '{name}' inertial")
    i_el = inertial.find("inertia")
    if i_el is None:
        Ic = np.zeros((3, 3))
    else:
        k = {a: float(i_el.get(a, "0")) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        Ic = np.array([[k["ixx"], k["ixy"], k["ixz"]], [k["ixy"], k["iyy"], k["iyz"]], [k["ixz"], k["iyz"], k["izz"]]])
    return mass, c, R @ Ic @ R.T


class _Joint:
    def __init__(self, el):
        self.name = el.get("name")
        self.type = el.get("type")
        parent, child = el.find("parent"), el.find("child")
        if parent is None or child is None:
            raise ValueError(f"joint '{self.name}': needs a <parent link=...> and a <child link=...>")
        self.parent, self.child = parent.get("link"), child.get("link")
        self.R, self.p = _origin(el, f"joint '{self.name}'")
        ax = el.find("axis")
        a = np.array([1.0, 0.0, 0.0]) if ax is None else _floats(ax.get("xyz"), 3, f"joint '{self.name}' axis")
        norm = float(np.linalg.norm(a))
        if self.type in MOVING_TYPES and not norm > 0:
            raise ValueError(f"joint '{self.name}': the axis is zero")
        self.axis = a / norm if norm > 0 else a
        lim = el.find("limit")
        self.limit = None
        if lim is not None:
            self.limit = tuple(
                float(lim.get(k)) if lim.get(k) is not None else float("nan")
                for k in ("lower", "upper", "velocity", "effort")
            )
        self.mimic = el.find("mimic") is not None


def read_urdf(path, *, base_link=None, tip_link=None, joints=None, g: float = 9.81) -> dict:
    """The fields of a `SerialRobot` from a URDF file (see the module for the model); `SerialRobot.from_urdf`.

    **Arguments:** `path` (a `.urdf` file); `base_link` (default: the tree's
    root); `tip_link` (default: the link after the last moving joint, when
    the moving joints lie on one path); `joints`: names of the chain's joints
    that move (default: every revolute, continuous and prismatic joint on
    the chain; the others are held at 0); `g` (m/s^2).

    Errors (ValueError, naming the element): a file that is not a URDF, a
    link with two parents, several roots, an unknown `base_link`/`tip_link`
    or joint, a tip that is not below the base, moving joints on several
    branches without a `tip_link` (not a serial chain), a floating or planar
    joint on the chain, a mimic joint among the moving ones; several roots
    without `base_link`, an unknown `base_link`/`tip_link` and a tip that is
    not below the base raise its subclass `OptionError` (an option that does
    not fit the file).

    **Returns:** the keyword arguments of `SerialRobot` (`names`, `limits`,
    `locked` filled; drives zero, gear ratios 1).

    Example:
        >>> import pathlib, tempfile
        >>> from jaxsdp.plants import SerialRobot
        >>> urdf = '''<robot name="arm"><link name="base"/>
        ...   <link name="l1"><inertial><mass value="2"/><origin xyz="0.5 0 0"/>
        ...     <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
        ...   <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        ...     <axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="2" effort="50"/></joint></robot>'''
        >>> f = pathlib.Path(tempfile.mkdtemp()) / "arm.urdf"
        >>> _ = f.write_text(urdf)
        >>> arm = SerialRobot.from_urdf(f)
        >>> arm.names, round(float(arm.gravity_torques([0.0])[0]), 3)  # 2 kg at 0.5 m on +x, axis +y
        (('j1',), -9.81)
    """
    path = pathlib.Path(path)
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise ValueError(f"{path}: cannot read it as XML ({e})") from None
    if root.tag != "robot":
        raise ValueError(f"{path}: the root element is <{root.tag}>, not <robot>: not a URDF")
    links = {el.get("name"): el for el in root.findall("link")}
    all_joints = [_Joint(el) for el in root.findall("joint")]
    by_child, children = {}, {}
    for j in all_joints:
        for end in (j.parent, j.child):
            if end not in links:
                raise ValueError(f"joint '{j.name}': link '{end}' is not defined in {path.name}")
        if j.child in by_child:
            raise ValueError(f"link '{j.child}' has two parent joints ('{by_child[j.child].name}', '{j.name}')")
        by_child[j.child] = j
        children.setdefault(j.parent, []).append(j)
    roots = [name for name in links if name not in by_child]
    if base_link is None:
        if len(roots) != 1:
            raise OptionError(f"{path.name}: {len(roots)} root links {roots}; name the base with base_link")
        base_link = roots[0]
    if base_link not in links:
        raise OptionError(f"base_link '{base_link}' is not a link of {path.name} (links: {sorted(links)})")

    def subtree(link):
        out = []
        for j in children.get(link, []):
            out.append(j)
            out += subtree(j.child)
        return out

    if joints is not None:
        joints = [str(n) for n in joints]
        unknown = [n for n in joints if n not in {j.name for j in all_joints}]
        if unknown:
            raise ValueError(f"joints {unknown} are not on the chain: {path.name} has no such joint")
    below = subtree(base_link)
    if tip_link is None:
        moving = [j for j in below if j.type in MOVING_TYPES and (joints is None or j.name in joints)]
        if not moving:
            raise ValueError(f"no revolute, continuous or prismatic joint below '{base_link}' in {path.name}")

        def ancestors(j):
            out = set()
            while j is not None:
                out.add(j.name)
                j = by_child.get(j.parent)
            return out

        deepest = max(moving, key=lambda j: len(ancestors(j)))
        chain_names = ancestors(deepest)
        off = [j.name for j in moving if j.name not in chain_names]
        if off:
            # where the branches part: the child link of the deepest joint common to the chain and every branch
            by_name = {j.name: j for j in below}
            common = set.intersection(chain_names, *(ancestors(by_name[o]) for o in off))
            split = max((by_name[c] for c in common if c in by_name), key=lambda j: len(ancestors(j)), default=None)
            split_link = base_link if split is None else split.child
            raise ValueError(
                f"{path.name} is not a serial chain below '{base_link}': moving joints {off} lie on another branch "
                f"than '{deepest.name}'; pass tip_link='{split_link}' (the chain up to where the branches part, "
                f"without them) or tip_link='{deepest.child}' (the chain to '{deepest.name}'), or joints="
            )
        tip_link = deepest.child
    if tip_link not in links:
        raise OptionError(f"tip_link '{tip_link}' is not a link of {path.name} (links: {sorted(links)})")
    chain, link = [], tip_link
    while link != base_link:
        j = by_child.get(link)
        if j is None:
            raise OptionError(f"tip_link '{tip_link}' is not below base_link '{base_link}'")
        chain.append(j)
        link = j.parent
    chain.reverse()
    for j in chain:
        if j.type in UNSUPPORTED_TYPES:
            raise ValueError(f"joint '{j.name}' is {j.type}: a serial-chain model holds revolute and prismatic joints")
        if j.type not in MOVING_TYPES + ("fixed",):
            raise ValueError(f"joint '{j.name}': unknown type '{j.type}'")
    if joints is not None:
        names_on_chain = {j.name for j in chain}
        unknown = [n for n in joints if n not in names_on_chain]
        if unknown:
            raise ValueError(f"joints {unknown} are not on the chain from '{base_link}' to '{tip_link}'")
    moves = [j.type in MOVING_TYPES and (joints is None or j.name in joints) for j in chain]
    for j, mv in zip(chain, moves):
        if mv and j.mimic:
            raise ValueError(f"joint '{j.name}' is a mimic joint: not supported among the moving joints")
    if not any(moves):
        raise ValueError(f"no moving joint on the chain from '{base_link}' to '{tip_link}'")
    on_chain = {j.name for j in chain}
    locked = [j.name for j, mv in zip(chain, moves) if not mv and j.type in MOVING_TYPES]

    # walk the chain: transforms from the current moving frame; bodies collect the links rigidly attached
    R_acc, p_acc = np.eye(3), np.zeros(3)  # from the last moving frame (or the base) to the current link
    origins, axes, prismatic, names, limits, bodies = [], [], [], [], {}, []

    def attach(body, link_name, R, p):
        """Add a link (at R, p in the body frame) and, held at 0, every branch off the chain below it."""
        m, c, Ic = _link_inertia(links[link_name])
        body += link_parameters(m, R @ c + p, R @ Ic @ R.T)
        for jj in children.get(link_name, []):
            if jj.name in on_chain:
                continue
            if jj.type in MOVING_TYPES:
                locked.append(jj.name)
            elif jj.type in UNSUPPORTED_TYPES:
                raise ValueError(f"joint '{jj.name}' is {jj.type}: a serial-chain model cannot hold it")
            attach(body, jj.child, R @ jj.R, R @ jj.p + p)

    for j, mv in zip(chain, moves):
        R_j, p_j = R_acc @ j.R, R_acc @ j.p + p_acc
        if mv:
            origins.append((R_j, p_j))
            axes.append(j.axis)
            prismatic.append(j.type == "prismatic")
            names.append(j.name)
            if j.limit is not None:
                limits[j.name] = j.limit
            body = np.zeros(10)
            bodies.append(body)
            R_acc, p_acc = np.eye(3), np.zeros(3)
            attach(body, j.child, R_acc, p_acc)
        else:
            R_acc, p_acc = R_j, p_j
            if bodies:
                attach(bodies[-1], j.child, R_acc, p_acc)
    n = len(names)
    return dict(
        rotation=jnp.asarray(np.stack([o[0] for o in origins])),
        translation=jnp.asarray(np.stack([o[1] for o in origins])),
        axis=jnp.asarray(np.stack(axes)),
        inertial=jnp.asarray(np.stack(bodies)),
        Ia=jnp.zeros(n),
        Fv=jnp.zeros(n),
        Fc=jnp.zeros(n),
        offset=jnp.zeros(n),
        g=jnp.asarray(float(g)),
        ratios=(1.0,) * n,
        prismatic=tuple(prismatic),
        names=tuple(names),
        limits=limits,
        locked=tuple(dict.fromkeys(locked)),
    )
