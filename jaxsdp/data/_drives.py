"""A robot's drives as data: gear ratios, torque constants, signs, joint offsets and the motor-joint coupling.

Motor side to model side, per motor k (reduced by its gear ratio, with its
sign convention) and then through the transmission matrix C (n x n):

    u_k = s_k pos_k / N_k              (rad, the motor angle reduced to the joint side)
    tau_u_k = s_k N_k K_k value_k      (N m; K_k = 1 when the logs hold torques)
    q = C u + offsets                   (the model's joint angles)
    tau = C^-T tau_u                    (the model's joint torques: the same power, tau . dq = tau_u . du)

C = I for independent joints; a coupled wrist whose motor b also turns with
joint a (the TX40's motors 5 and 6: q_6 = u_6 - u_5) has C = I - e_b e_a^T,
so tau_a = tau_u_a + tau_u_b: motor b's torque enters both joints' rows, and
so do its inertia and friction (in the motor coordinate u_b = q_a + q_b),
which `Drives.motor_regressor` lays out as identifiable columns.

`Drives.from_toml(path)` reads a small file::

    ratios = [32, 32, 45, -48, 45, 32]
    torque_constants = [1, 1, 1, 1, 1, 1]      # optional: the logs hold currents (A)
    signs = [1, 1, 1, 1, 1, 1]                  # optional
    offsets = [0, -1.5707963267948966, 1.5707963267948966, 0, 0, 0]   # optional, rad
    coupling = [[5, 6]]                         # optional: motor 6 also turns with joint 5
    # or transmission = [[1, 0, ...], ...]      # the full C, row by row

and `Drives.builtin("tx40")` holds the values of the TX40 logs' README.
"""

import math
import pathlib

import numpy as np

from .._runtime import x64

#: Built-in drive descriptions (`Drives.builtin`).
BUILTIN = {
    "tx40": dict(
        ratios=(32.0, 32.0, 45.0, -48.0, 45.0, 32.0),
        offsets=(0.0, -math.pi / 2, math.pi / 2, 0.0, 0.0, 0.0),
        coupling=((5, 6),),
    ),
}


def _vector(name, value, n, *, default, positive=False, nonzero=False):
    if value is None:
        return np.full(n, float(default))
    v = np.asarray(value, dtype=float)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise ValueError(f"`{name}` must be {n} finite numbers, one per motor; got {value!r}")
    if positive and not np.all(v > 0):
        raise ValueError(f"`{name}` must be positive; got {value!r}")
    if nonzero and np.any(v == 0):
        raise ValueError(f"`{name}` must be non-zero; got {value!r}")
    return v


class Drives:
    """Gear ratios, torque constants, signs, joint offsets and the transmission matrix of n motors (see the module).

    **Attributes** (NumPy, read-only by convention): `ratios` N (n,),
    `torque_constants` K (n,) or None (the logs hold torques), `signs` (n,)
    of +-1, `offsets` (n,) rad, `transmission` C (n, n), invertible. A plain
    class: a description read once, never traced.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.data import Drives
        >>> d = Drives.builtin("tx40")
        >>> u = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
        >>> q = d.joint_positions(u * d.ratios)  # motor angles -> model angles
        >>> round(float(q[5]), 3), round(float(q[1]), 4)  # q6 = u6 - u5; q2 = u2 - pi/2
        (0.1, -1.3708)
        >>> bool(np.allclose(d.motor_positions(q), u * d.ratios))
        True
    """

    @x64
    def __init__(self, ratios, *, torque_constants=None, signs=None, offsets=None, coupling=None, transmission=None):
        N = np.asarray(ratios, dtype=float)
        if N.ndim != 1 or N.size < 1:
            raise ValueError(f"`ratios` must be one gear ratio per motor; got {ratios!r}")
        n = N.size
        self.ratios = _vector("ratios", N, n, default=1.0, nonzero=True)
        self.torque_constants = (
            None
            if torque_constants is None
            else _vector("torque_constants", torque_constants, n, default=1.0, positive=True)
        )
        self.signs = _vector("signs", signs, n, default=1.0)
        if not np.all(np.abs(self.signs) == 1.0):
            raise ValueError(f"`signs` must be +1 or -1; got {signs!r}")
        self.offsets = _vector("offsets", offsets, n, default=0.0)
        if transmission is not None and coupling is not None:
            raise ValueError("give `coupling` (pairs) or `transmission` (the matrix), not both")
        if transmission is not None:
            C = np.asarray(transmission, dtype=float)
            if C.shape != (n, n) or not np.all(np.isfinite(C)):
                raise ValueError(f"`transmission` must be a finite ({n}, {n}) matrix; got shape {C.shape}")
        else:
            C = np.eye(n)
            for pair in coupling or ():
                try:
                    a, b = (int(v) for v in pair)
                except (TypeError, ValueError):
                    raise ValueError(f"`coupling` must be pairs (a, b) of joint numbers; got {pair!r}") from None
                if a == b or not (1 <= a <= n and 1 <= b <= n):
                    raise ValueError(f"`coupling` pair ({a}, {b}) must name two different joints in 1..{n}")
                C[b - 1, a - 1] -= 1.0  # q_b = u_b - u_a: motor b also turns with joint a
        if abs(np.linalg.det(C)) < 1e-12:
            raise ValueError("`transmission` is singular: the motor angles would not determine the joint angles")
        self.transmission = C

    def __repr__(self) -> str:
        coupled = "; ".join(f"motor {k} enters joints {js}" for k, js in self.coupled()) or "none"
        parts = [f"ratios={self.ratios.tolist()}"]
        if self.torque_constants is not None:  # the logs hold currents (A): K converts them (N m/A)
            parts.append(f"torque_constants={self.torque_constants.tolist()}")
        if np.any(self.signs != 1.0):
            parts.append(f"signs={self.signs.astype(int).tolist()}")
        parts.append(f"offsets={self.offsets.round(6).tolist()}")
        return f"Drives({', '.join(parts)}, coupled: {coupled})"

    @property
    @x64
    def n(self) -> int:
        """Number of motors (= joints)."""
        return int(self.ratios.size)

    @classmethod
    @x64
    def builtin(cls, name: str) -> "Drives":
        """A built-in description: "tx40" (the TX40 logs' README: ratios, MDH offsets, the coupled wrist)."""
        if name not in BUILTIN:
            raise ValueError(f"no built-in drives named {name!r}; built in: {', '.join(sorted(BUILTIN))}")
        return cls(**BUILTIN[name])

    @classmethod
    @x64
    def from_toml(cls, path) -> "Drives":
        """Read a drive description from a TOML file (keys: see the module), or a built-in name ("tx40")."""
        import tomllib

        if str(path) in BUILTIN:
            return cls.builtin(str(path))
        path = pathlib.Path(path)
        try:
            spec = tomllib.loads(path.read_text())
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise ValueError(f"{path}: cannot read the drive description ({e})") from None
        spec = spec.get("drives", spec)
        known = {"ratios", "torque_constants", "signs", "offsets", "coupling", "transmission"}
        unknown = sorted(set(spec) - known)
        if unknown:
            raise ValueError(f"{path}: unknown keys {unknown} (known: {', '.join(sorted(known))})")
        if "ratios" not in spec:
            raise ValueError(f"{path}: `ratios` is required (one gear ratio per motor)")
        ratios = spec.pop("ratios")
        return cls(ratios, **spec)

    def _check(self, name, x):
        x = np.asarray(x, dtype=float)
        if x.ndim < 1 or x.shape[-1] != self.n:
            raise ValueError(f"`{name}` must have shape (..., {self.n}); got {x.shape}")
        return x

    @x64
    def joint_positions(self, motor_positions):
        """q = C u + offsets with u = s pos / N (rad), for motor angles `motor_positions` (..., n)."""
        u = self.signs * self._check("motor_positions", motor_positions) / self.ratios
        return u @ self.transmission.T + self.offsets

    @x64
    def motor_positions(self, q):
        """The motor angles of joint angles `q` (..., n): the inverse of `joint_positions`."""
        u = np.linalg.solve(self.transmission, (self._check("q", q) - self.offsets).T).T
        return u * self.ratios / self.signs

    @x64
    def joint_torques(self, motor_values):
        """tau = C^-T (s N K value) (N m), for motor torques (or currents, with torque constants) (..., n)."""
        v = self._check("motor_values", motor_values)
        tau_u = self.signs * self.ratios * (v if self.torque_constants is None else v * self.torque_constants)
        return np.linalg.solve(self.transmission.T, tau_u.T).T

    @x64
    def motor_values(self, tau):
        """The motor torques (or currents) of joint torques `tau` (..., n): the inverse of `joint_torques`."""
        tau_u = self._check("tau", tau) @ self.transmission
        v = tau_u / (self.signs * self.ratios)
        return v if self.torque_constants is None else v / self.torque_constants

    @x64
    def motor_regressor(self, dq, ddq):
        """Columns of the motors' inertia, viscous and Coulomb friction in the joint torques: (..., n, 3 n).

        Motor k's reduced coordinate u = C^-1 (q - offsets) moves with
        du = C^-1 dq; its torque Ia_k ddu_k + Fv_k du_k + Fc_k sign(du_k)
        reaches the joints through C^-T, so its three columns (named
        `Ia_m{k}`, `Fv_m{k}`, `Fc_m{k}`, `motor_parameter_names`) are
        C^-T[:, k] times ddu_k, du_k, sign(du_k): for independent joints the
        usual per-joint Ia, Fv, Fc; for a coupled motor, the rows of every
        joint it enters.
        """
        dq, ddq = self._check("dq", dq), self._check("ddq", ddq)
        Cinv = np.linalg.inv(self.transmission)
        du, ddu = dq @ Cinv.T, ddq @ Cinv.T
        G = Cinv.T  # tau_joint = C^-T tau_u
        cols = np.stack([ddu, du, np.sign(du)], axis=-1)  # (..., n motors, 3)
        out = G[..., :, :, None] * cols[..., None, :, :]  # (..., joints, motors, 3)
        return out.reshape(*out.shape[:-2], 3 * self.n)

    @x64
    def motor_parameter_names(self) -> tuple[str, ...]:
        """`Ia_m1, Fv_m1, Fc_m1, Ia_m2, ...`: the columns of `motor_regressor`."""
        return tuple(f"{k}_m{j + 1}" for j in range(self.n) for k in ("Ia", "Fv", "Fc"))

    @x64
    def coupled(self) -> list[tuple[int, list[int]]]:
        """(motor, joints it enters) for every motor whose torque enters more than one joint (1-based)."""
        G = np.linalg.inv(self.transmission).T
        enters = [[int(j) + 1 for j in np.flatnonzero(np.abs(G[:, k]) > 1e-12)] for k in range(self.n)]
        return [(k + 1, js) for k, js in enumerate(enters) if len(js) > 1]

    @x64
    def convert(self, logs):
        """Raw joint logs (motor angles and motor torques or currents, read with `load_joint_logs(...,
        ratios=None)`) in the model's convention: `joint_positions`, `joint_torques` (a `JointLogs`); the
        velocities `dq`, when logged, through the linear part of `joint_positions` (dq = C s dpos / N, no
        offsets); `notes` kept."""
        import jax.numpy as jnp

        from ._joint_logs import JointLogs

        if not isinstance(logs, JointLogs):
            raise ValueError(f"`logs` must be a JointLogs (load_joint_logs); got {type(logs).__name__}")
        if len(logs.joints) != self.n:
            raise ValueError(f"the drives describe {self.n} motors; the logs hold {len(logs.joints)} joints")
        dq = None if logs.dq is None else (self.signs * np.asarray(logs.dq) / self.ratios) @ self.transmission.T
        return JointLogs(
            q=jnp.asarray(self.joint_positions(np.asarray(logs.q))),
            tau=jnp.asarray(self.joint_torques(np.asarray(logs.tau))),
            t=logs.t,
            dt=logs.dt,
            joints=logs.joints,
            source=logs.source,
            converted=f"{logs.converted}; drives: {self!r}",
            resampled=logs.resampled,
            dq=None if dq is None else jnp.asarray(dq),
            notes=logs.notes,
        )
