"""Serial robots (revolute and prismatic joints): recursive Newton-Euler dynamics in JAX.

**Kinematics** (the general form a URDF writes, `SerialRobot.from_urdf`):
frame j is reached from frame j-1 by a fixed origin (rotation R0_j,
translation p0_j, both in frame j-1) and then the joint's motion about or
along its unit axis a_j (in frame j): revolute R_j = R0_j Rot(a_j, q_j),
p_j = p0_j; prismatic R_j = R0_j, p_j = p0_j + R0_j a_j q_j. A modified
Denavit-Hartenberg row (Khalil & Dombre, the paper's Table 3;
`SerialRobot.from_mdh`) is the case R0_j = Rot_x(alpha_j) Rot_z(theta_j),
p0_j = (d_j, -r_j sin alpha_j, r_j cos alpha_j), a_j = z.

**Inertial parameters** of link j, in frame j and about its origin (the
standard parameters of robot identification): the inertia tensor
J_j = [[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]] (kg m^2), the first moments
MS_j = (MX, MY, MZ) = m_j c_j (kg m) and the mass M (kg), stored as the row
`[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]`. From a centre-of-mass inertia I_c:
J = I_c + m (|c|^2 I - c c^T) (parallel axis).

**Inverse dynamics** (recursive Newton-Euler, gravity g along -z_0 as a base
acceleration dv_0 = (0, 0, g)): forward,

    w_j = R^T w_{j-1} + dq_j a_j,   dw_j = R^T dw_{j-1} + (R^T w_{j-1}) x dq_j a_j + ddq_j a_j,
    dv_j = R^T (dv_{j-1} + dw_{j-1} x p_j + w_{j-1} x (w_{j-1} x p_j)),
    F_j = M dv_j + dw_j x MS_j + w_j x (w_j x MS_j),   N_j = J_j dw_j + w_j x (J_j w_j) + MS_j x dv_j

(prismatic: w_j = R^T w_{j-1}, dw_j = R^T dw_{j-1}, dv_j gains 2 w_j x dq_j a_j
+ ddq_j a_j); backward, f_j = F_j + R_{j+1} f_{j+1}, n_j = N_j + R_{j+1} n_{j+1}
+ p_{j+1} x R_{j+1} f_{j+1}, tau_j = n_j . a_j (prismatic: f_j . a_j). The
model is linear in the inertial parameters, so the
identification regressor is the Jacobian of the torque with respect to them
(`SerialRobot.regressor`, formed by the recursion written for it: `_regressor`).

**Drives** (joint side): tau_motor = tau_rigid + Ia ddq + Fv dq + Fc sign(dq) + offset.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._linalg import spd_solve
from ..._runtime import X64_LINE, x64
from ._inertia import link_parameters
from ._regressor import regressor_rows

INERTIAL_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
DRIVE_NAMES = ("Ia", "Fv", "Fc", "offset")


def _axis_rotation(a, angle):
    """Rot(a, angle) by Rodrigues' formula, a a unit vector."""
    K = jnp.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return jnp.eye(3) + jnp.sin(angle) * K + (1.0 - jnp.cos(angle)) * (K @ K)


def mdh_origin(alpha, d, theta, r):
    """(R0, p0) of a modified DH row: R0 = Rot_x(alpha) Rot_z(theta), p0 = (d, -r sin alpha, r cos alpha)."""
    alpha, theta = float(alpha), float(theta)
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    Rz = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    return Rx @ Rz, np.array([float(d), -float(r) * sa, float(r) * ca])


def _tensor(p):
    xx, xy, xz, yy, yz, zz = p[0], p[1], p[2], p[3], p[4], p[5]
    return jnp.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


class SerialRobot(eqx.Module):
    """A serial robot (revolute and prismatic joints) with its rigid-body and drive parameters.

    Build one from a URDF (`SerialRobot.from_urdf`) or a modified DH table
    (`SerialRobot.from_mdh`; the nominal TX40: `tx40_robot`).

    **Fields:** `rotation` (n, 3, 3) and `translation` (n, 3): each joint's
    fixed origin in the previous link's frame (m); `axis` (n, 3): its unit
    axis in its own frame; `prismatic` (static, n bools); `inertial` (n, 10): each link's
    `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` about its frame origin, in its
    frame (kg m^2, kg m, kg); `Ia` (n,) actuator inertia on the joint side
    (kg m^2); `Fv` (N m s/rad), `Fc` (N m), `offset` (N m) (n,) joint friction
    and offsets; `ratios` (static) gear ratios motor/joint; `g` (m/s^2),
    gravity along -z_0; `names` (static): the joints' names; `limits`
    (static): name -> (lower, upper, velocity, effort) where the description
    gives them (rad or m, rad/s or m/s, N m or N), else empty; `locked`
    (static): joints of the description held at 0 and merged into a link.

    **Methods** (inputs of shape (..., n), batched over the leading axes):
    `inverse_dynamics(q, dq, ddq)` rigid-body torques (N m, no friction, no
    actuator inertia); `gravity_torques(q)`; `mass_matrix(q)` (..., n, n);
    `forward_dynamics(q, dq, tau)` the frictionless ddq with the actuator
    inertia (Cholesky solve);
    `drive_torques(q, dq, ddq)` the motor torques with actuator inertia,
    friction and offsets; `regressor(q, dq, ddq)` (..., n, 10 n) the
    Jacobian of `inverse_dynamics` w.r.t. `inertial`.
    """

    rotation: jax.Array
    translation: jax.Array
    axis: jax.Array
    inertial: jax.Array
    Ia: jax.Array
    Fv: jax.Array
    Fc: jax.Array
    offset: jax.Array
    g: jax.Array
    ratios: tuple = eqx.field(static=True)
    prismatic: tuple = eqx.field(static=True, default=())
    names: tuple = eqx.field(static=True, default=())
    limits: dict = eqx.field(static=True, default_factory=dict)
    locked: tuple = eqx.field(static=True, default=())

    def __check_init__(self):
        n = self.rotation.shape[0]
        if self.rotation.shape != (n, 3, 3) or self.translation.shape != (n, 3) or self.axis.shape != (n, 3):
            raise ValueError("`rotation`, `translation`, `axis` must have shapes (n, 3, 3), (n, 3), (n, 3)")
        if self.prismatic and len(self.prismatic) != n:
            raise ValueError(f"`prismatic` must have {n} entries; got {len(self.prismatic)}")

    @property
    @x64
    def n(self) -> int:
        """Number of joints."""
        return int(self.rotation.shape[0])

    def _is_prismatic(self, j) -> bool:
        return bool(self.prismatic[j]) if self.prismatic else False

    @classmethod
    @x64
    def from_mdh(cls, table, *, inertias, Ia=0.0, Fv=0.0, Fc=0.0, offset=0.0, ratios=None, g=9.81, prismatic=None):
        """A robot from a modified DH table (Khalil & Dombre; the paper's Table 3).

        `table` (n, 4): rows (alpha rad, d m, theta rad, r m), theta the
        joint-angle offset; frame j = Rot_x(alpha) Trans_x(d) Rot_z(theta + q)
        Trans_z(r) (prismatic joints: r + q). `inertias`: (n, 10) standard
        parameters `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` about each frame
        origin, or per link `(mass, com, inertia_com)` or `(mass, com, psi,
        inertia_com)` (`link_parameters`); `Ia`, `Fv`, `Fc`, `offset`: drives
        (scalars or n values); `ratios` (default 1); `g` (m/s^2); `prismatic`
        (n bools, default all revolute).

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import SerialRobot, tx40_robot
            >>> from jaxsdp.plants.robot._tx40 import TX40_MDH
            >>> r = SerialRobot.from_mdh(TX40_MDH, inertias=tx40_robot().inertial)
            >>> q = np.full(6, 0.4)
            >>> bool(np.allclose(r.gravity_torques(q), tx40_robot().gravity_torques(q)))
            True
        """
        rows = np.asarray(table, dtype=float)
        if rows.ndim != 2 or rows.shape[1] != 4 or rows.shape[0] < 1 or not np.all(np.isfinite(rows)):
            raise ValueError(f"`table` must be (n, 4) finite rows (alpha, d, theta, r); got shape {rows.shape}")
        n = rows.shape[0]
        origins = [mdh_origin(*row) for row in rows]
        inertial = _inertial_rows(inertias, n)
        drives = {
            k: np.broadcast_to(np.asarray(v, dtype=float), (n,))
            for k, v in dict(Ia=Ia, Fv=Fv, Fc=Fc, offset=offset).items()
        }
        ratios = (1.0,) * n if ratios is None else tuple(float(v) for v in ratios)
        if len(ratios) != n:
            raise ValueError(f"`ratios` must have {n} entries; got {len(ratios)}")
        prismatic = (False,) * n if prismatic is None else tuple(bool(v) for v in prismatic)
        return cls(
            rotation=jnp.asarray(np.stack([o[0] for o in origins])),
            translation=jnp.asarray(np.stack([o[1] for o in origins])),
            axis=jnp.asarray(np.tile([0.0, 0.0, 1.0], (n, 1))),
            inertial=jnp.asarray(inertial),
            g=jnp.asarray(float(g)),
            ratios=ratios,
            prismatic=prismatic,
            names=tuple(f"joint{j + 1}" for j in range(n)),
            **{k: jnp.asarray(v) for k, v in drives.items()},
        )

    @classmethod
    @x64
    def from_urdf(cls, path, *, base_link=None, tip_link=None, joints=None, g=9.81):
        """A robot from a URDF file: the chain from `base_link` (default: the root) to `tip_link` (default: the
        last moving joint's link), its revolute, continuous and prismatic joints (or those named in `joints`;
        the others held at 0 and merged), gravity `g` along -z of the base (`_urdf.read_urdf`: the model, the
        errors).

        Example:
            >>> import pathlib, tempfile
            >>> from jaxsdp.plants import SerialRobot
            >>> f = pathlib.Path(tempfile.mkdtemp()) / "pendulum.urdf"
            >>> _ = f.write_text('<robot name="p"><link name="base"/><link name="rod"><inertial>'
            ...     '<mass value="1"/><origin xyz="0 0 -1"/></inertial></link><joint name="swing" '
            ...     'type="continuous"><parent link="base"/><child link="rod"/><axis xyz="1 0 0"/></joint></robot>')
            >>> round(float(SerialRobot.from_urdf(f).mass_matrix([0.0])[0, 0]), 6)  # 1 kg at 1 m
            1.0
        """
        from ._urdf import read_urdf

        return cls(**read_urdf(path, base_link=base_link, tip_link=tip_link, joints=joints, g=g))

    def _check(self, name, x):
        x = jnp.asarray(x, dtype=jnp.float64)
        if x.ndim < 1 or x.shape[-1] != self.n:
            raise ValueError(f"`{name}` must have shape (..., {self.n}); got {tuple(x.shape)}")
        return x

    def _rnea(self, inertial, q, dq, ddq, g):
        n = self.n
        w, dw, dv = jnp.zeros(3), jnp.zeros(3), jnp.array([0.0, 0.0, 1.0]) * g
        Rs, ps, F, N = [], [], [], []
        for j in range(n):
            a, R0, p0 = self.axis[j], self.rotation[j], self.translation[j]
            if self._is_prismatic(j):
                R, p = R0, p0 + R0 @ a * q[j]
            else:
                R, p = R0 @ _axis_rotation(a, q[j]), p0
            dv = R.T @ (dv + jnp.cross(dw, p) + jnp.cross(w, jnp.cross(w, p)))
            wr = R.T @ w
            if self._is_prismatic(j):
                w = wr
                dw = R.T @ dw
                dv = dv + 2.0 * jnp.cross(w, dq[j] * a) + ddq[j] * a
            else:
                w = wr + dq[j] * a
                dw = R.T @ dw + jnp.cross(wr, dq[j] * a) + ddq[j] * a
            pj = inertial[j]
            J, ms, m = _tensor(pj), pj[6:9], pj[9]
            F.append(m * dv + jnp.cross(dw, ms) + jnp.cross(w, jnp.cross(w, ms)))
            N.append(J @ dw + jnp.cross(w, J @ w) + jnp.cross(ms, dv))
            Rs.append(R)
            ps.append(p)
        f, nn = jnp.zeros(3), jnp.zeros(3)
        tau = [None] * n
        for j in reversed(range(n)):
            if j + 1 < n:
                fc = Rs[j + 1] @ f
                nn = N[j] + Rs[j + 1] @ nn + jnp.cross(ps[j + 1], fc)
                f = F[j] + fc
            else:
                f, nn = F[j], N[j]
            tau[j] = (f if self._is_prismatic(j) else nn) @ self.axis[j]
        return jnp.stack(tau)

    def _batched(self, fn, *args, signature):
        return jnp.vectorize(fn, signature=signature)(*args)

    @x64
    def inverse_dynamics(self, q, dq, ddq):
        r"""Rigid-body joint torques $\tau = M(q) \ddot q + c(q, \dot q) + g(q)$ (N m), recursive Newton-Euler.

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import tx40_robot
            >>> robot = tx40_robot()
            >>> robot.inverse_dynamics(np.zeros(6), np.zeros(6), np.zeros(6)).shape
            (6,)
        """
        q, dq, ddq = (self._check(k, v) for k, v in (("q", q), ("dq", dq), ("ddq", ddq)))
        fn = lambda a, b, c: self._rnea(self.inertial, a, b, c, self.g)
        return self._batched(fn, q, dq, ddq, signature="(n),(n),(n)->(n)")

    @x64
    def gravity_torques(self, q):
        """Gravity torques $g(q)$ = `inverse_dynamics(q, 0, 0)` (N m).

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import tx40_robot
            >>> abs(float(tx40_robot().gravity_torques(np.zeros(6))[0])) < 1e-12  # joint 1's axis is vertical
            True
        """
        q = self._check("q", q)
        zero = jnp.zeros_like(q)
        return self.inverse_dynamics(q, zero, zero)

    @x64
    def mass_matrix(self, q):
        """Joint-space mass matrix $M(q)$ (kg m^2), column $k$ = `inverse_dynamics(q, 0, e_k) - g(q)`, symmetrised.

        Rigid body only (no actuator inertia): positive semi-definite; singular
        when a link has no inertia about its own axis (the TX40's link 6).

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import tx40_robot
            >>> robot = tx40_robot()
            >>> M = robot.mass_matrix(np.zeros(6))
            >>> M.shape, bool(np.all(np.linalg.eigvalsh(M + np.diag(robot.Ia)) > 0))  # with the actuators
            ((6, 6), True)
        """
        q = self._check("q", q)

        def one(qq):
            zero = jnp.zeros_like(qq)
            cols = jax.vmap(lambda e: self._rnea(self.inertial, qq, zero, e, 0.0))(jnp.eye(self.n))
            return 0.5 * (cols + cols.T)

        return self._batched(one, q, signature="(n)->(n,n)")

    @x64
    def forward_dynamics(self, q, dq, tau):
        r"""Frictionless accelerations $\ddot q = (M(q) + diag(I_a))^{-1} (\tau - c(q, \dot q) - g(q))$ (rad/s^2).

        Solved by Cholesky. The reflected actuator inertia Ia (the armature) is included: without
        it a link with no inertia about its own axis (the TX40's link 6) makes
        M(q) singular.

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import tx40_robot
            >>> robot = tx40_robot()
            >>> q, dq, ddq = np.full(6, 0.3), np.full(6, -0.2), np.linspace(-1, 1, 6)
            >>> tau = robot.inverse_dynamics(q, dq, ddq) + robot.Ia * ddq
            >>> bool(np.allclose(robot.forward_dynamics(q, dq, tau), ddq))
            True
        """
        q, dq, tau = (self._check(k, v) for k, v in (("q", q), ("dq", dq), ("tau", tau)))

        def one(qq, vv, tt):
            bias = self._rnea(self.inertial, qq, vv, jnp.zeros_like(qq), self.g)
            M = self.mass_matrix(qq) + jnp.diag(self.Ia)
            return spd_solve(M, tt - bias)

        return self._batched(one, q, dq, tau, signature="(n),(n),(n)->(n)")

    @x64
    def drive_torques(self, q, dq, ddq):
        """Joint torques the drives apply: inverse_dynamics + Ia ddq + Fv dq + Fc sign(dq) + offset (N m).

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import tx40_robot
            >>> robot = tx40_robot()
            >>> tau = robot.drive_torques(np.zeros(6), np.ones(6), np.zeros(6))
            >>> bool(np.allclose(tau - robot.inverse_dynamics(np.zeros(6), np.ones(6), np.zeros(6)),
            ...                  robot.Fv + robot.Fc + robot.offset))
            True
        """
        q, dq, ddq = (self._check(k, v) for k, v in (("q", q), ("dq", dq), ("ddq", ddq)))
        rigid = self.inverse_dynamics(q, dq, ddq)
        return rigid + self.Ia * ddq + self.Fv * dq + self.Fc * jnp.sign(dq) + self.offset

    @x64
    def regressor(self, q, dq, ddq, *, joint: int | None = None):
        r"""d tau / d inertial: the (..., n, 10 n) identification regressor of the rigid-body torques.

        $\tau = Y(q, \dot q, \ddot q) \theta$ with $\theta$ the link parameters stacked link
        by link (`parameter_names`), exact because the model is linear in them.
        With `joint` (1-based), only that joint's row (..., 10 n). Formed by the
        Newton-Euler recursion written for the regressor (`jaxsdp.plants.robot._regressor`),
        not by differentiating the torques (its own derivative is the torques' second one).

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import tx40_robot
            >>> robot = tx40_robot()
            >>> q, dq, ddq = np.full(6, 0.3), np.full(6, -0.2), np.linspace(-1, 1, 6)
            >>> Y = robot.regressor(q, dq, ddq)
            >>> Y.shape, bool(np.allclose(Y @ robot.inertial.ravel(), robot.inverse_dynamics(q, dq, ddq)))
            ((6, 60), True)
        """
        q, dq, ddq = (self._check(k, v) for k, v in (("q", q), ("dq", dq), ("ddq", ddq)))
        if joint is not None and (isinstance(joint, bool) or not isinstance(joint, int) or not 1 <= joint <= self.n):
            raise ValueError(f"`joint` must be a joint number in 1..{self.n}; got {joint!r}")
        shape = jnp.broadcast_shapes(q.shape, dq.shape, ddq.shape)
        flat = [jnp.broadcast_to(x, shape).reshape(-1, self.n) for x in (q, dq, ddq)]
        rows = tuple(range(self.n)) if joint is None else (joint - 1,)
        eye = np.eye(self.n)
        felt = tuple(tuple(bool(x) for x in row) for row in eye)
        Y = regressor_rows(self, *flat, eye, eye, rows, tuple(range(10 * self.n)), felt)
        return Y.reshape(shape[:-1] + (10 * self.n,)) if joint is not None else Y.reshape(shape + (10 * self.n,))

    @x64
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the stacked inertial parameters, `XX1, XY1, ..., M1, XX2, ...`.

        Example:
            >>> from jaxsdp.plants import tx40_robot
            >>> tx40_robot().parameter_names()[:3]
            ('XX1', 'XY1', 'XZ1')
        """
        return tuple(f"{k}{j + 1}" for j in range(self.n) for k in INERTIAL_NAMES)


def _inertial_rows(inertias, n: int) -> np.ndarray:
    """(n, 10) standard parameters from an (n, 10) array or per-link (mass, com, [psi,] inertia_com) tuples."""
    try:
        arr = np.asarray(inertias, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is not None and arr.shape == (n, 10):
        if not np.all(np.isfinite(arr)):
            raise ValueError("`inertias` must be finite")
        return arr
    if len(inertias) != n:
        raise ValueError(f"`inertias` must be (n, 10) standard parameters or {n} link tuples; got {len(inertias)}")
    rows = []
    for link in inertias:
        if len(link) == 3:
            rows.append(link_parameters(link[0], link[1], link[2]))
        elif len(link) == 4:
            rows.append(link_parameters(link[0], link[1], link[3], link[2]))
        else:
            raise ValueError(
                "each link of `inertias` must be (mass, com, inertia_com) or (mass, com, psi, inertia_com)"
            )
    return np.stack(rows)


class BaseParameters(NamedTuple):
    r"""Base parameters of a regressor (`base_parameters`).

    **Fields:** `rank`; `independent` (names of the base columns, in the
    order of the names); `dependent` (names of the others); `combination` (rank, p - rank)
    matrix $K$: each base parameter is $\theta_i + \sum_k K_{ik} \theta_{dep,k}$;
    `names` of the base parameters written out (e.g. `ZZ2 + 0.05 M3 + ...`);
    `columns`, `dependent_columns`: indices of the independent and dependent
    columns. `values(theta)` maps a full parameter vector to the base ones.
    """

    rank: int
    independent: tuple
    dependent: tuple
    combination: np.ndarray
    names: tuple
    columns: np.ndarray
    dependent_columns: np.ndarray

    @x64
    def values(self, theta) -> np.ndarray:
        """Base parameters theta_ind + K theta_dep of a full parameter vector `theta` (p,).

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import base_parameters
            >>> x = np.random.default_rng(0).normal(size=(50, 2))
            >>> b = base_parameters(np.c_[x, x[:, 0] * 2.0], ("a", "b", "c"))
            >>> b.independent, b.values([1.0, 1.0, 1.0]).round(12).tolist()  # a + 2 c, b
            (('a', 'b'), [3.0, 1.0])
        """
        theta = np.asarray(theta, dtype=float)
        p = len(self.independent) + len(self.dependent)
        if theta.shape != (p,):
            raise ValueError(f"`theta` must have shape ({p},); got {theta.shape}")
        return theta[self.columns] + self.combination @ theta[self.dependent_columns]


@x64
def base_parameters(W, names, *, tol: float = 1e-8) -> BaseParameters:
    r"""Base parameters: the first independent columns of `W`, in the order of `names`.

    Column $j$ is independent when its part orthogonal to the independent
    columns before it, $r_j = (I - Q Q^T) w_j$ (Gram-Schmidt twice, $Q$ their
    orthonormal basis), has $\|r_j\| > tol \cdot \max_k \|w_k\|$, the threshold of QR
    with column pivoting's rank rule ($|R_{ii}| > tol \cdot |R_{11}|$, $|R_{11}|$ the
    largest column norm). The dependent columns
    are $W_{dep} = W_{ind} K$ with $K = R^{-1} Q^T W_{dep}$ ($R$ the triangle of
    $W_{ind} = Q R$), so $W \theta = W_{ind} (\theta_{ind} + K \theta_{dep})$: the base
    parameters are $\theta_{ind} + K \theta_{dep}$. Columns that are zero everywhere
    (parameters with no effect) are dependent with $K = 0$.

    **Why in order, not by pivots:** where several columns enter the same
    combinations (a robot's XX_j, YY_j, ZZ_j), QR with column pivoting keeps
    whichever the rounding of `W` makes largest, so the base parameters' names
    could change with the machine, the BLAS or the regressor's code. In order,
    the choice is the same wherever it runs, and on a modified-DH chain (joint
    axes along z) the textbook one, Khalil's regrouping: XX_j and ZZ_j kept,
    YY_j regrouped into them, a motor's Ia_j into ZZ_j; list a parameter
    earlier in `names` (and `W`) to keep it. When the two rank rules disagree
    (a column independent only at the threshold), a `UserWarning` says that
    the rank depends on `tol`; another says when the kept columns are nearly
    dependent (condition number above $tol^{-1/2}$ with unit columns: large
    combinations, where pivoting would have kept a better-conditioned set).
    A float32 `W` is refused: its rounding hides the exact dependencies.

    **Arguments:** `W` (m, p) a regressor stacked over many random states;
    `names` (p,); `tol` relative threshold.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import base_parameters
        >>> x = np.random.default_rng(0).normal(size=(50, 2))
        >>> b = base_parameters(np.c_[x, x[:, 0] * 2.0], ("a", "b", "c"))
        >>> b.rank, b.independent, b.names[0]  # c = 2 a: a is kept, c regrouped into it
        (2, ('a', 'b'), 'a +2 c')
    """
    import warnings

    import scipy.linalg

    names = tuple(names)
    if not (isinstance(tol, (int, float, np.floating)) and 0 < tol < 1):
        raise ValueError(f"`tol` must be a number in (0, 1); got {tol!r}")
    kind = np.asarray(W).dtype
    if np.issubdtype(kind, np.floating) and 100 * np.finfo(kind).eps > tol:
        raise ValueError(
            f"`W` is {kind}: its rounding ({np.finfo(kind).eps:.1e} relative) hides the exact dependencies between "
            f"columns that the base parameters are found from at tol={tol:g}; build `W` in float64 (with JAX, "
            f"enable 64-bit mode first: {X64_LINE}) or pass a `tol` of at least {100 * np.finfo(kind).eps:.0e}"
        )
    W = np.asarray(W, dtype=float)
    if W.ndim != 2 or W.shape[1] != len(names):
        raise ValueError(f"`W` must be (m, {len(names)}) for {len(names)} names; got {W.shape}")
    if not np.all(np.isfinite(W)):
        raise ValueError("`W` must be finite")
    m, p = W.shape
    norms = np.linalg.norm(W, axis=0)
    scale = float(norms.max()) if p else 0.0
    Q = np.zeros((m, min(m, p)))  # orthonormal basis of the kept columns
    R = np.zeros((min(m, p), min(m, p)))  # their triangle, W[:, ind] = Q R
    ind = []
    for j in range(p):
        k = len(ind)
        if scale == 0.0 or norms[j] <= tol * scale or k == Q.shape[1]:
            continue
        c1 = Q[:, :k].T @ W[:, j]
        r = W[:, j] - Q[:, :k] @ c1
        c2 = Q[:, :k].T @ r  # the second pass (Gram-Schmidt twice is orthogonal to rounding)
        r = r - Q[:, :k] @ c2
        size = np.linalg.norm(r)
        if size > tol * scale:
            Q[:, k], R[:k, k], R[k, k] = r / size, c1 + c2, size
            ind.append(j)
    rank = len(ind)
    dep = np.setdiff1d(np.arange(p), ind)
    ind, R = np.asarray(ind, dtype=int), R[:rank, :rank]
    if p and scale > 0:
        diag = np.abs(np.diag(scipy.linalg.qr(W, mode="r", pivoting=True)[0]))
        pivoted = int(np.sum(diag > tol * diag[0]))
        if pivoted != rank:
            warnings.warn(
                f"base parameters: rank {rank} in order, {pivoted} by pivoted QR at tol={tol:g}: a column is "
                "independent only at the threshold, so the rank depends on `tol` (columns near-dependent on the "
                "states drawn)",
                UserWarning,
                stacklevel=3,  # the caller's line (under the x64 wrapper)
            )
    K = scipy.linalg.solve_triangular(R, Q[:, :rank].T @ W[:, dep]) if rank else np.zeros((0, len(dep)))
    if rank > 1:
        sv = np.linalg.svd(R / norms[ind][None, :], compute_uv=False)  # the kept columns, unit norm
        if sv[-1] * np.sqrt(1 / tol) < sv[0]:
            warnings.warn(
                f"base parameters: the columns kept in the names' order are nearly dependent (condition number "
                f"{sv[0] / sv[-1]:.1e} with unit columns): their estimates will be poorly determined"
                + (f", and the combinations have coefficients up to {np.abs(K).max():.1e}" if K.size else "")
                + "; list the parameters in another order to keep a better-conditioned set",
                UserWarning,
                stacklevel=3,
            )
    K[np.abs(K) < 1e-10] = 0.0
    out = []
    for i, col in enumerate(ind):
        terms = [names[col]] + [f"{K[i, k]:+.4g} {names[dep[k]]}" for k in range(len(dep)) if K[i, k] != 0]
        out.append(" ".join(terms))
    return BaseParameters(
        rank=rank,
        independent=tuple(names[i] for i in ind),
        dependent=tuple(names[i] for i in dep),
        combination=K,
        names=tuple(out),
        columns=np.asarray(ind),
        dependent_columns=np.asarray(dep),
    )
