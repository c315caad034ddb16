r"""The robot identification pipeline as one pure JAX Module, and the experiment that makes its records.

`RobotPipeline.of(model)(logs) -> RobotFit`: every joint of `model`
(`robot_model`) identified at once by IDIM-LS on joint logs, as
`robot_idim_ls` does, in JAX:

1. each joint's angle and torque processed (`Preprocessing`: Butterworth,
   central differences, the first `drop` samples removed, decimation);
2. the stacked base regressor built at the full rate on the filtered states,
   decimated like the torques (parallel decimation);
3. the rows where joint $j$ is at rest ($|\dot q_j| <$ `rest_fraction` of its peak
   speed, at least 0.01 rad/s) and the filter's end transient left out, by
   zero weights (a fixed shape, so that the pipeline jits and vmaps);
4. one least squares over every joint's rows kept,
   $\hat\beta = \arg\min \|W (y - X \beta)\|$, with $\hat\sigma^2 = \|W(y - X\hat\beta)\|^2 / (n_{kept} - p)$
   and the covariance $\hat\sigma^2 (X^T W X)^{-1}$.

`RobotExperiment(reference, dt=..., ...)(key, robot) -> JointLogs` simulates
a robot following `reference` under the joint PD control of a fixed
controller (`simulate_robot`) and adds white torque noise. Both are pure:
`monte_carlo` vmaps them over drawn robots (`jaxsdp.studies.montecarlo.robot_robustness`).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ..._idim.estimators import IDIMLS
from ..._records import JointLogs
from ..._runtime import x64
from ..._signal.preprocess import Butterworth, Preprocessing
from ..._signal.regressors import parallel_decimate
from ._joint import drive_matrix, stacked_rows
from ._joint_full import check_all_joints
from ._serial import SerialRobot
from ._sim import simulate_loop
from ._stacked import RobotModel

__all__ = ["RobotPipeline", "RobotFit", "RobotExperiment"]

#: Fewest rad/s a joint must move to count as in motion (as `rest_threshold`).
MIN_REST_SPEED = 0.01


class RobotFit(eqx.Module):
    r"""What `RobotPipeline` returns (arrays only; batched under `vmap`).

    **Fields:** `theta` (rank,) the base parameters (in `names` order, SI units: kg m^2, kg m, kg, N m s/rad, N m),
    `std` their standard errors, `cov` their covariance, `sigma` the residual standard deviation (N m),
    `rows_used` the decimated rows kept (all joints), `relative_error` (%) $100 \|W(y - X\hat\beta)\| / \|W y\|$,
    `y`, `X` the decimated torques (M, joints) and regressors (M, joints, rank), `weights` (M, joints) 1 where
    a row was used, `dq` (M, joints) the decimated joint speeds.
    """

    theta: Float[Array, " p"]
    std: Float[Array, " p"]
    cov: Float[Array, "p p"]
    sigma: Float[Array, ""]
    rows_used: Int[Array, ""]
    relative_error: Float[Array, ""]
    y: Float[Array, "M j"]
    X: Float[Array, "M j p"]
    weights: Float[Array, "M j"]
    dq: Float[Array, "M j"]


class RobotPipeline(eqx.Module):
    r"""IDIM-LS of every joint of a robot model at once, pure: `RobotPipeline.of(model)(logs) -> RobotFit`.

    **Fields:** `robot` (the `SerialRobot` whose kinematics make the regressor), `rows`, `columns`, `names`,
    `transmission` (static: the modelled joints, the base columns and names of `robot_model`, the drives'
    coupling as nested tuples or None), `preprocessing` (`Preprocessing`; default Butterworth order 4 at 40 Hz,
    200 samples dropped, decimation by 2, as the excitation study's check), `rest_fraction` (rows with
    $|\dot q_j|$ below this fraction of joint $j$'s peak speed are left out; 0.01).

    The same estimate as `robot_idim_ls` on the same logs and options (to rounding: the rows at rest are
    weighted out instead of dropped, so that the shapes are fixed); the logs' sample time is static, so a batch
    of logs of one length and rate is one `vmap`. It holds the robot's arrays: jit it with `eqx.filter_jit`.
    With no more rows in motion than base parameters the standard errors are not finite (`rows_used` says so).
    """

    robot: SerialRobot
    rows: tuple = eqx.field(static=True)
    columns: tuple = eqx.field(static=True)
    names: tuple = eqx.field(static=True)
    transmission: tuple | None = eqx.field(static=True, default=None)
    preprocessing: Preprocessing = Preprocessing(Butterworth(40.0), drop=200, decimate=2)
    rest_fraction: float = eqx.field(static=True, default=0.01)

    @classmethod
    @x64
    def of(cls, model: RobotModel, **options) -> "RobotPipeline":
        """The pipeline of a `robot_model` (its robot, joints, base columns and coupling); `options` set the
        other fields (`preprocessing`, `rest_fraction`)."""
        if not isinstance(model, RobotModel):
            raise ValueError(f"`model` must be a RobotModel (jaxsdp.plants.robot.robot_model); got {model!r}")
        C = None if model.transmission is None else tuple(map(tuple, np.asarray(model.transmission, float)))
        columns = tuple(int(c) for c in np.asarray(model.base.columns))
        return cls(model.robot, tuple(model.rows), columns, tuple(model.names), C, **options)

    def _regressor(self, q, dq, ddq):
        n = self.robot.n
        C = None if self.transmission is None else np.asarray(self.transmission)
        Cinv, G = drive_matrix(n, C)
        W = stacked_rows(self.robot, q, dq, ddq, Cinv, G, tuple(j - 1 for j in self.rows))
        return W[:, :, np.asarray(self.columns)]

    @x64
    def __call__(self, logs: JointLogs) -> RobotFit:
        if not isinstance(logs, JointLogs):
            raise ValueError(f"`logs` must be a JointLogs; got {type(logs).__name__}")
        n = self.robot.n
        check_all_joints(logs, self.robot)  # every joint, in order 1..n (static: no cost under jit)
        pre = self.preprocessing
        inputs = [pre._run(logs.q[:, j], logs.tau[:, j], logs.dt) for j in range(n)]
        q, dq, ddq = (jnp.stack([getattr(p, k) for p in inputs], axis=1) for k in ("q_full", "dq_full", "ddq_full"))
        W = self._regressor(q, dq, ddq)  # (N full, rows, rank)
        ys, Xs, ws, speeds = [], [], [], []
        for i, j in enumerate(self.rows):
            own = inputs[j - 1]
            reg = parallel_decimate(own.y_full, W[:, i, :], pre.decimate, mode=pre.mode)
            y, X = reg.y, reg.X
            speed = jnp.abs(own.dq)
            threshold = jnp.maximum(self.rest_fraction * jnp.max(speed), MIN_REST_SPEED)
            ys.append(y)
            Xs.append(X)
            ws.append((speed >= threshold).astype(y.dtype))
            speeds.append(own.dq)
        y, X, w = jnp.stack(ys, axis=1), jnp.stack(Xs, axis=1), jnp.stack(ws, axis=1)
        tail = -(-pre.drop // pre.decimate)  # the zero-phase filter's end transient, as robot_idim_ls
        if tail:
            w = w.at[-tail:].set(0.0)
        p = X.shape[-1]
        yw, Xw = (y * w).reshape(-1), (X * w[..., None]).reshape(-1, p)
        fit = IDIMLS()._solve(yw, Xw, self.names)
        n_rows, used = yw.shape[0], jnp.sum(w)
        scale = (n_rows - p) / (used - p)  # the rows at rest are zeros: sigma^2 over the rows used
        return RobotFit(
            theta=fit.theta,
            std=fit.std * jnp.sqrt(scale),
            cov=fit.cov * scale,
            sigma=fit.sigma * jnp.sqrt(scale),
            rows_used=used.astype(jnp.int32),
            relative_error=fit.relative_error,
            y=y,
            X=X,
            weights=w,
            dq=jnp.stack(speeds, axis=1),
        )


class RobotExperiment(eqx.Module):
    r"""One closed-loop experiment on a robot: `RobotExperiment(reference, dt=..., controller=...)(key, robot)`.

    The robot follows `reference` (N, n) rad under joint PD control with gravity feed-forward
    (`simulate_robot`: `controller`'s gains, critically damped at `bandwidth_hz` on its inertia, and its gravity
    model: a fixed controller, whatever the robot), `substeps` semi-implicit steps per sample of `dt` s; the
    logged torques carry white noise of `torque_noise` (n,) N m (std). Returns the `JointLogs` (joint side).
    Pure: vmapped over keys and robots, it makes a Monte Carlo's records (jit it with `eqx.filter_jit`: it holds
    arrays).
    """

    reference: Float[Array, "N n"]
    controller: SerialRobot
    torque_noise: Float[Array, " n"]
    dt: float = eqx.field(static=True, default=1e-3)
    bandwidth_hz: float = eqx.field(static=True, default=10.0)
    eps: float = eqx.field(static=True, default=1e-3)
    substeps: int = eqx.field(static=True, default=4)

    @x64
    def __call__(self, key, robot: SerialRobot) -> JointLogs:
        qr = jnp.asarray(self.reference, dtype=jnp.float64)
        ctrl = self.controller
        n = qr.shape[1]
        J = jnp.diag(ctrl.mass_matrix(qr[0])) + ctrl.Ia
        w = 2 * jnp.pi * self.bandwidth_hz
        zeros = jnp.zeros_like(qr)
        sim = simulate_loop(
            robot, ctrl, qr, self.dt, J * w**2, 2 * J * w, jnp.full(n, jnp.inf), jnp.zeros(n), zeros, self.eps,
            self.substeps, 1,
        )  # fmt: skip
        tau = sim.tau + self.torque_noise * jax.random.normal(key, sim.tau.shape)
        t = jnp.arange(qr.shape[0]) * self.dt
        joints = tuple(range(1, n + 1))
        return JointLogs(q=sim.q, tau=tau, t=t, dt=self.dt, joints=joints, source="simulated", converted="none")
