"""The measurement records every layer reads: an EMPS closed-loop record, a position-force record, joint logs.

Plain containers (float64 arrays, static metadata), made by the loaders and
built-in data sets of `jaxsdp.data` (which re-exports them) and read by the
plant families' identification stages.
"""

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float

from ._runtime import x64


class EMPSData(eqx.Module):
    """The EMPS estimation data set (Janot, Gautier & Brunot, 2019).

    **Fields:**

    - `t`: time (s), shape `(N,)`, strictly increasing.
    - `qm`: measured motor position on the load side (m).
    - `qg`: reference position of the closed loop (m).
    - `vir`: controller output voltage (V).
    - `force`: applied force `gtau * vir` (N).
    - `gtau`: drive gain (N/V).
    - `kp`: outer position-loop gain (1/s).
    - `kv`: inner velocity-loop gain (V/(m/s)).
    - `dt`: sampling period (s), `(t[-1] - t[0]) / (N - 1)` once every step
      is within the loader's `max_jitter` of the median step; the median step
      (the grid step) if the record was resampled.
    - `resampled`: `None`, or a one-line description of the resampling onto
      a uniform grid (`load_emps(..., irregular="resample")`).
    - `path`: the absolute path of the file read (`load_emps`), or None.
    """

    t: Float[Array, " N"]
    qm: Float[Array, " N"]
    qg: Float[Array, " N"]
    vir: Float[Array, " N"]
    force: Float[Array, " N"]
    gtau: float
    kp: float
    kv: float
    dt: float = eqx.field(static=True)
    resampled: str | None = eqx.field(default=None, static=True)
    path: str | None = eqx.field(default=None, static=True)


class Measurements(eqx.Module):
    """Sampled position and force measurements read by `load_measurements`.

    **Fields:** `t` time (s), `q` position, `force` force/torque, all shape
    `(N,)`; `dt` the sampling period (s): `(t[-1] - t[0]) / (N - 1)` once
    every step is within `max_jitter` of the median step, the median step
    (the grid step) if the record was resampled; `resampled`: `None`, or a
    one-line description of the resampling (`irregular="resample"`); `path`:
    the absolute path of the file read, or None.
    """

    t: Float[Array, " N"]
    q: Float[Array, " N"]
    force: Float[Array, " N"]
    dt: float = eqx.field(static=True)
    resampled: str | None = eqx.field(default=None, static=True)
    path: str | None = eqx.field(default=None, static=True)


class JointLogs(eqx.Module):
    """Joint-side angles and torques of a robot, sampled uniformly (`load_joint_logs`, `load_joint_bag`).

    **Fields:**

    - `q`: joint angles (rad), shape `(N, n)`, one column per joint.
    - `tau`: joint torques (N m), shape `(N, n)`.
    - `t`: time (s), shape `(N,)`, `t[k] = t[0] + k * dt`.
    - `dt`: sampling period (s).
    - `joints`: the 1-based joint number of each column, e.g. `(1, 2, 3, 4, 5, 6)` or `(2,)`.
    - `source`: the files read, e.g. `"positions.csv + torques.csv"`.
    - `converted`: one line describing the conversion from the files' values
      (motor side) to the joint side.
    - `resampled`: how an irregular (or jittered) time column was resampled
      onto the uniform grid, or `None`.
    - `dq`: joint velocities as logged (rad/s, or m/s for a prismatic joint),
      shape `(N, n)`, or `None` when the logs hold none (a velocities file, a
      velocity column, or a bag's velocity arrays).
    - `notes`: what the loader did that a user should know, one line each:
      columns ignored, the time base of a bag (default `()`).

    **Properties and methods:** `fs`, the sampling frequency `1 / dt` (Hz);
    `joint(j)`, the pair `(q_j, tau_j)` of joint number `j`, each shape `(N,)`.

    Example:
        >>> import jax.numpy as jnp
        >>> from jaxsdp.data import JointLogs
        >>> logs = JointLogs(q=jnp.zeros((20, 2)), tau=jnp.ones((20, 2)), t=jnp.arange(20) * 1e-3, dt=1e-3,
        ...                  joints=(2, 3), source="q.csv + tau.csv", converted="none")
        >>> q3, tau3 = logs.joint(3)
        >>> logs.fs, q3.shape, float(tau3[0])  # Hz, (N,), N m
        (1000.0, (20,), 1.0)
    """

    q: Float[Array, "N n"]
    tau: Float[Array, "N n"]
    t: Float[Array, " N"]
    dt: float = eqx.field(static=True)
    joints: tuple[int, ...] = eqx.field(static=True)
    source: str = eqx.field(static=True)
    converted: str = eqx.field(static=True)
    resampled: str | None = eqx.field(static=True, default=None)
    dq: Float[Array, "N n"] | None = None
    notes: tuple[str, ...] = eqx.field(static=True, default=())

    def __check_init__(self):
        if self.dq is not None and np.shape(self.dq) != np.shape(self.q):
            raise ValueError(f"`dq` must have the shape of `q` {np.shape(self.q)}; got {np.shape(self.dq)}")

    @property
    @x64
    def fs(self) -> float:
        """Sampling frequency `1 / dt` (Hz)."""
        return 1.0 / self.dt

    @x64
    def joint(self, j: int) -> tuple[Float[Array, " N"], Float[Array, " N"]]:
        """The angle (rad) and torque (N m) columns of joint number `j` (1-based), each shape `(N,)`."""
        if isinstance(j, bool) or not isinstance(j, (int, np.integer)) or int(j) not in self.joints:
            available = ", ".join(str(k) for k in self.joints)
            raise ValueError(f"joint {j!r} is not in these logs ({self.source}); available joints: {available}")
        i = self.joints.index(int(j))
        return self.q[:, i], self.tau[:, i]
