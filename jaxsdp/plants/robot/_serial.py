"""Serial robots from a modified Denavit-Hartenberg table: recursive Newton-Euler dynamics in JAX.

**Kinematics** (Khalil & Dombre's modified DH, the paper's Table 3): frame j
is reached from frame j-1 by Rot_x(alpha_j) Trans_x(d_j) Rot_z(theta_j + q_j)
Trans_z(r_j), so its orientation is R_j = Rot_x(alpha_j) Rot_z(theta_j + q_j)
and its origin, in frame j-1, is p_j = (d_j, -r_j sin alpha_j, r_j cos alpha_j).

**Inertial parameters** of link j, in frame j and about its origin (the
standard parameters of robot identification): the inertia tensor
J_j = [[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]] (kg m^2), the first moments
MS_j = (MX, MY, MZ) = m_j c_j (kg m) and the mass M (kg), stored as the row
`[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]`. From a centre-of-mass inertia I_c:
J = I_c + m (|c|^2 I - c c^T) (parallel axis).

**Inverse dynamics** (recursive Newton-Euler, gravity g along -z_0 as a base
acceleration dv_0 = (0, 0, g)): forward,

    w_j = R^T w_{j-1} + dq_j z,   dw_j = R^T dw_{j-1} + (R^T w_{j-1}) x dq_j z + ddq_j z,
    dv_j = R^T (dv_{j-1} + dw_{j-1} x p_j + w_{j-1} x (w_{j-1} x p_j)),
    F_j = M dv_j + dw_j x MS_j + w_j x (w_j x MS_j),   N_j = J_j dw_j + w_j x (J_j w_j) + MS_j x dv_j;

backward, f_j = F_j + R_{j+1} f_{j+1}, n_j = N_j + R_{j+1} n_{j+1} + p_{j+1} x R_{j+1} f_{j+1},
tau_j = n_j . z. The model is linear in the inertial parameters, so the
identification regressor is the Jacobian of the torque with respect to them
(`SerialRobot.regressor`).

**Drives** (joint side): tau_motor = tau_rigid + Ia ddq + Fv dq + Fc sign(dq) + offset.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._runtime import x64

INERTIAL_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
DRIVE_NAMES = ("Ia", "Fv", "Fc", "offset")


def _rot_x(a):
    c, s = jnp.cos(a), jnp.sin(a)
    o, z = jnp.ones_like(a), jnp.zeros_like(a)
    return jnp.stack([jnp.stack([o, z, z]), jnp.stack([z, c, -s]), jnp.stack([z, s, c])])


def _rot_z(a):
    c, s = jnp.cos(a), jnp.sin(a)
    o, z = jnp.ones_like(a), jnp.zeros_like(a)
    return jnp.stack([jnp.stack([c, -s, z]), jnp.stack([s, c, z]), jnp.stack([z, z, o])])


def _tensor(p):
    xx, xy, xz, yy, yz, zz = p[0], p[1], p[2], p[3], p[4], p[5]
    return jnp.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def link_parameters(mass, com, inertia_com, psi=0.0) -> np.ndarray:
    """Standard inertial parameters `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` of a link about its frame origin.

    J = R_z(psi) I_c R_z(psi)^T + m (|c|^2 I - c c^T), MS = m c, from the mass
    m (kg), the centre of mass c (m, in the link frame) and the inertia about
    the centre of mass I_c (kg m^2; a 3x3 matrix or its six entries
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


class SerialRobot(eqx.Module):
    """A serial robot with revolute joints from a modified DH table, with its rigid-body and drive parameters.

    **Fields:** `alpha`, `d`, `theta`, `r` (n,): the MDH rows (rad, m, rad,
    m; `theta` is the joint-angle offset); `inertial` (n, 10): each link's
    `[XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M]` about its frame origin, in its
    frame (kg m^2, kg m, kg); `Ia` (n,) actuator inertia on the joint side
    (kg m^2); `Fv` (N m s/rad), `Fc` (N m), `offset` (N m) (n,) joint friction
    and offsets; `ratios` (static) gear ratios motor/joint; `g` (m/s^2),
    gravity along -z_0.

    **Methods** (inputs of shape (..., n), batched over the leading axes):
    `inverse_dynamics(q, dq, ddq)` rigid-body torques (N m, no friction, no
    actuator inertia); `gravity_torques(q)`; `mass_matrix(q)` (..., n, n);
    `forward_dynamics(q, dq, tau)` the frictionless ddq with the actuator
    inertia (Cholesky solve);
    `drive_torques(q, dq, ddq)` the motor torques with actuator inertia,
    friction and offsets; `regressor(q, dq, ddq)` (..., n, 10 n) the
    Jacobian of `inverse_dynamics` w.r.t. `inertial`.
    """

    alpha: jax.Array
    d: jax.Array
    theta: jax.Array
    r: jax.Array
    inertial: jax.Array
    Ia: jax.Array
    Fv: jax.Array
    Fc: jax.Array
    offset: jax.Array
    g: jax.Array
    ratios: tuple = eqx.field(static=True)

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.alpha.shape[0])

    def _check(self, name, x):
        x = jnp.asarray(x, dtype=jnp.float64)
        if x.ndim < 1 or x.shape[-1] != self.n:
            raise ValueError(f"`{name}` must have shape (..., {self.n}); got {tuple(x.shape)}")
        return x

    def _rnea(self, inertial, q, dq, ddq, g):
        n = self.n
        z = jnp.array([0.0, 0.0, 1.0])
        w, dw, dv = jnp.zeros(3), jnp.zeros(3), jnp.array([0.0, 0.0, 1.0]) * g
        Rs, ps, F, N = [], [], [], []
        for j in range(n):
            R = _rot_x(self.alpha[j]) @ _rot_z(self.theta[j] + q[j])
            sa, ca = jnp.sin(self.alpha[j]), jnp.cos(self.alpha[j])
            p = jnp.stack([self.d[j], -self.r[j] * sa, self.r[j] * ca])
            dv = R.T @ (dv + jnp.cross(dw, p) + jnp.cross(w, jnp.cross(w, p)))
            wr = R.T @ w
            w = wr + dq[j] * z
            dw = R.T @ dw + jnp.cross(wr, dq[j] * z) + ddq[j] * z
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
            tau[j] = nn[2]
        return jnp.stack(tau)

    def _batched(self, fn, *args, signature):
        return jnp.vectorize(fn, signature=signature)(*args)

    @x64
    def inverse_dynamics(self, q, dq, ddq):
        """Rigid-body joint torques tau = M(q) ddq + c(q, dq) + g(q) (N m), recursive Newton-Euler.

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
        """Gravity torques g(q) = inverse_dynamics(q, 0, 0) (N m).

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
        """Joint-space mass matrix M(q) (kg m^2), column k = inverse_dynamics(q, 0, e_k) - g(q), symmetrised.

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
        """Frictionless accelerations ddq = (M(q) + diag(Ia))^-1 (tau - c(q, dq) - g(q)) (rad/s^2), Cholesky solve.

        The reflected actuator inertia Ia (the armature) is included: without
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
            return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(M), tt - bias)

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
        """d tau / d inertial: the (..., n, 10 n) identification regressor of the rigid-body torques.

        tau = Y(q, dq, ddq) theta with theta the link parameters stacked link
        by link (`parameter_names`), exact because the model is linear in them.
        With `joint` (1-based), only that joint's row (..., 10 n), by one
        reverse-mode derivative per state.

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

        if joint is not None:
            if isinstance(joint, bool) or not isinstance(joint, int) or not 1 <= joint <= self.n:
                raise ValueError(f"`joint` must be a joint number in 1..{self.n}; got {joint!r}")

            def row(a, b, c):
                fn = lambda th: self._rnea(th.reshape(self.n, 10), a, b, c, self.g)[joint - 1]
                return jax.grad(fn)(self.inertial.ravel())

            return self._batched(row, q, dq, ddq, signature="(n),(n),(n)->(m)")

        def one(a, b, c):
            fn = lambda th: self._rnea(th.reshape(self.n, 10), a, b, c, self.g)
            return jax.jacfwd(fn)(self.inertial.ravel())

        return self._batched(one, q, dq, ddq, signature="(n),(n),(n)->(n,m)")

    def parameter_names(self) -> tuple[str, ...]:
        """Names of the stacked inertial parameters, `XX1, XY1, ..., M1, XX2, ...`.

        Example:
            >>> from jaxsdp.plants import tx40_robot
            >>> tx40_robot().parameter_names()[:3]
            ('XX1', 'XY1', 'XZ1')
        """
        return tuple(f"{k}{j + 1}" for j in range(self.n) for k in INERTIAL_NAMES)


class BaseParameters(NamedTuple):
    """Base parameters of a regressor (`base_parameters`).

    **Fields:** `rank`; `independent` (names of the base columns, in pivot
    order); `dependent` (names of the others); `combination` (rank, p - rank)
    matrix K: each base parameter is theta_i + sum_k K_ik theta_dep_k;
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

    def values(self, theta) -> np.ndarray:
        """Base parameters theta_ind + K theta_dep of a full parameter vector `theta` (p,).

        Example:
            >>> import numpy as np
            >>> from jaxsdp.plants import base_parameters
            >>> x = np.random.default_rng(0).normal(size=(50, 2))
            >>> b = base_parameters(np.c_[x, x[:, 0] * 2.0], ("a", "b", "c"))
            >>> b.independent, b.values([1.0, 1.0, 1.0]).tolist()  # c + a / 2, b
            (('c', 'b'), [1.5, 1.0])
        """
        theta = np.asarray(theta, dtype=float)
        p = len(self.independent) + len(self.dependent)
        if theta.shape != (p,):
            raise ValueError(f"`theta` must have shape ({p},); got {theta.shape}")
        return theta[self.columns] + self.combination @ theta[self.dependent_columns]


def base_parameters(W, names, *, tol: float = 1e-8) -> BaseParameters:
    """Base parameters by QR with column pivoting: W P = Q R, rank = #{|R_ii| > tol |R_11|}.

    With R = [[R1, R2], [0, 0]] the columns of W P split into independent
    (first `rank`) and dependent ones, W_dep = W_ind K with K = R1^-1 R2 (a
    triangular solve), so W theta = W_ind (theta_ind + K theta_dep): the
    base parameters are theta_ind + K theta_dep. Columns that are zero
    everywhere (parameters with no effect) are dependent with K = 0.

    **Arguments:** `W` (m, p) a regressor stacked over many random states;
    `names` (p,); `tol` relative threshold on the diagonal of R.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import base_parameters
        >>> x = np.random.default_rng(0).normal(size=(50, 2))
        >>> b = base_parameters(np.c_[x, x[:, 0] * 2.0], ("a", "b", "c"))
        >>> b.rank, len(b.dependent)
        (2, 1)
    """
    import scipy.linalg

    W = np.asarray(W, dtype=float)
    names = tuple(names)
    if W.ndim != 2 or W.shape[1] != len(names):
        raise ValueError(f"`W` must be (m, {len(names)}) for {len(names)} names; got {W.shape}")
    _, R, piv = scipy.linalg.qr(W, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > tol * diag[0])) if diag.size and diag[0] > 0 else 0
    ind, dep = piv[:rank], piv[rank:]
    K = scipy.linalg.solve_triangular(R[:rank, :rank], R[:rank, rank:]) if rank else np.zeros((0, len(dep)))
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
