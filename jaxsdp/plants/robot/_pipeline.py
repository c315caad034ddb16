r"""The robot identification pipeline as one pure JAX Module, and the experiment that makes its records.

`RobotPipeline.of(model)(logs) -> RobotFit`: every joint of `model`
(`robot_model`) identified at once by IDIM-LS on joint logs, as
`robot_idim_ls` does, in JAX:

1. each joint's angle and torque processed (`Preprocessing`: Butterworth,
   central differences, the first `drop` samples removed, decimation);
2. the stacked base regressor built at the full rate on the filtered states,
   decimated like the torques (parallel decimation, every column through one filter);
3. the rows where joint $j$ is at rest ($|\dot q_j| <$ `rest_fraction` of its peak
   speed, at least 0.01 rad/s, or `min_speed`) and the filter's end transient left out, by
   zero weights (a fixed shape, so that the pipeline jits and vmaps);
4. one least squares over every joint's rows kept,
   $\hat\beta = \arg\min \|W (y - X \beta)\|$, with $\hat\sigma^2 = \|W(y - X\hat\beta)\|^2 / (n_{kept} - p)$
   and the covariance $\hat\sigma^2 (X^T W X)^{-1}$.

`RobotExperiment(reference, dt=..., ...)(key, robot) -> JointLogs` simulates
a robot following `reference` under the joint PD control of a fixed
controller (`simulate_robot`) and adds white torque noise. Both are pure:
`monte_carlo` vmaps them over drawn robots (`jaxsdp.studies.montecarlo.robot_robustness`).
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ..._idim.estimators import IDIMLS
from ..._records import JointLogs
from ..._runtime import x64
from ..._signal.filtering import decimate_columns
from ..._signal.preprocess import Butterworth, Preprocessing
from ._joint import drive_matrix, stacked_rows
from ._joint_full import check_all_joints
from ._judgement import judge
from ._serial import SerialRobot
from ._sim import simulate_loop
from ._stacked import RobotModel

__all__ = ["RobotPipeline", "RobotFit", "RobotDiagnosis", "RobotExperiment"]

#: Fewest rad/s a joint must move to count as in motion (as `rest_threshold`).
MIN_REST_SPEED = 0.01


class RobotFit(eqx.Module):
    r"""What `RobotPipeline` returns (arrays only; batched under `vmap`).

    **Fields:** `theta` (rank,) the base parameters (in `names` order, SI units: kg m^2, kg m, kg, N m s/rad, N m),
    `std` their standard errors, `cov` their covariance, `sigma` the residual standard deviation (N m; with
    `joint_weights`, of the weighted rows: near 1), `joint_sigma` (j,) each joint's residual standard deviation
    (N m, over its rows used),
    `rows_used` the decimated rows kept (all joints), `cond` the 2-norm condition number of the regressor on
    those rows (weighted with `joint_weights`), `relative_error` (%) $100 \|W(y - X\hat\beta)\| / \|W y\|$,
    `y`, `X` the decimated torques (M, joints) and regressors (M, joints, rank), `weights` (M, joints) 1 where
    a row was used, `dq` (M, joints) the decimated joint speeds, `q` (M, n) every joint's decimated angle,
    `inputs` (n,) each joint's processed record (`Preprocessed`: decimated and full-rate angle, rates, torque).
    """

    theta: Float[Array, " p"]
    std: Float[Array, " p"]
    cov: Float[Array, "p p"]
    sigma: Float[Array, ""]
    joint_sigma: Float[Array, " j"]
    rows_used: Int[Array, ""]
    cond: Float[Array, ""]
    relative_error: Float[Array, ""]
    y: Float[Array, "M j"]
    X: Float[Array, "M j p"]
    weights: Float[Array, "M j"]
    dq: Float[Array, "M j"]
    q: Float[Array, "M n"]
    inputs: tuple = ()


class RobotPipeline(eqx.Module):
    r"""IDIM-LS of every joint of a robot model at once, pure: `RobotPipeline.of(model)(logs) -> RobotFit`.

    **Fields:** `robot` (the `SerialRobot` whose kinematics make the regressor), `rows`, `columns`, `names`,
    `transmission` (static: the modelled joints, the base columns and names of `robot_model`, the drives'
    coupling as nested tuples or None), `preprocessing` (`Preprocessing`; default Butterworth order 4 at 40 Hz,
    200 samples dropped, decimation by 2, as the excitation study's check), `rest_fraction` (rows with
    $|\dot q_j|$ below this fraction of joint $j$'s peak speed are left out, at least 0.01 rad/s; 0.01), `min_speed`
    (a fixed rest threshold instead, rad/s or m/s; None), `ls` the estimator
    (`IDIMLS()`: the white-residual covariance; `IDIMLS(cov=NeweyWest())` for residuals the filters coloured).

    `robot_idim_ls` runs it and reads its rows on the host (its named result, on the rows used, equals this
    estimate to rounding: the rows at rest are weighted out here, so that the shapes are fixed); the logs' sample
    time is static, so a batch of logs of one length and rate is one `vmap`. It holds the robot's arrays: jit it
    with `eqx.filter_jit`. With no more rows in motion than base parameters the standard errors are not finite
    (`rows_used` says so).
    """

    robot: SerialRobot
    rows: tuple = eqx.field(static=True)
    columns: tuple = eqx.field(static=True)
    names: tuple = eqx.field(static=True)
    transmission: tuple | None = eqx.field(static=True, default=None)
    preprocessing: Preprocessing = Preprocessing(Butterworth(40.0), drop=200, decimate=2)
    rest_fraction: float = eqx.field(static=True, default=0.01)
    min_speed: float | None = eqx.field(static=True, default=None)
    ls: IDIMLS = IDIMLS()
    joint_weights: bool = eqx.field(static=True, default=False)
    model: "_Held | None" = eqx.field(static=True, default=None)

    @classmethod
    @x64
    def of(cls, model: RobotModel, **options) -> "RobotPipeline":
        """The pipeline of a `robot_model` (its robot, joints, base columns and coupling); `options` set the
        other fields (`preprocessing`, `rest_fraction`)."""
        if not isinstance(model, RobotModel):
            raise ValueError(f"`model` must be a RobotModel (jaxsdp.plants.robot.robot_model); got {model!r}")
        C = None if model.transmission is None else tuple(tuple(map(float, r)) for r in np.asarray(model.transmission))
        columns = tuple(int(c) for c in np.asarray(model.base.columns))
        return cls(model.robot, tuple(model.rows), columns, tuple(model.names), C, **options, model=_Held(model))

    @x64
    def diagnose(self, fit: RobotFit, *, drives_given: bool = False) -> "RobotDiagnosis":
        """The host-side reading of one fit (not a batch): each joint's relative error on its rows used, whether
        there are more rows in motion than base parameters and the standard errors are finite, and the physical
        checks of the robot study (`judge`: motor inertias and friction negative beyond a standard deviation, the
        joint-space inertia $I_{a,j} + M_{jj}(q)$ negative at logged configurations; `drives_given` as there).
        Needs the pipeline made by `RobotPipeline.of` (it holds the model)."""
        if self.model is None:
            raise ValueError("`diagnose` needs the robot model: make the pipeline with RobotPipeline.of(model)")
        if not isinstance(fit, RobotFit) or np.ndim(fit.theta) != 1:
            raise ValueError("`fit` must be one RobotFit (index a batch first: jax.tree.map(lambda x: x[i], fits))")
        model = self.model.value
        y, X, w = (np.asarray(a, dtype=float) for a in (fit.y, fit.X, fit.weights))
        theta, std = np.asarray(fit.theta, dtype=float), np.asarray(fit.std, dtype=float)
        res = (y - X @ theta) * w
        relative_error = {
            j: float(100 * np.linalg.norm(res[:, i]) / max(np.linalg.norm(y[:, i] * w[:, i]), np.finfo(float).tiny))
            for i, j in enumerate(self.rows)
        }
        warnings = []
        used, p = int(fit.rows_used), theta.shape[0]
        identifiable = used > p and bool(np.all(np.isfinite(std)))
        if used <= p:
            warnings.append(
                f"{used} rows in motion for {p} base parameters: not identifiable (a longer or more exciting "
                "record, or a smaller `rest_fraction`)"
            )
        elif not np.all(np.isfinite(std)):
            warnings.append("standard errors not finite: the regressor is rank deficient on the rows used")
        verdicts, signs = judge(model, theta, std, fit.cov, relative_error, fit.q, drives_given=drives_given)
        return RobotDiagnosis(verdicts, tuple(warnings + signs), relative_error, used, identifiable)

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
        # parallel decimation of every joint's torque and regressor columns in one filter (one scan over all
        # columns, not one per column: a six-joint robot has a few hundred)
        rows = len(self.rows)
        y_full = jnp.stack([inputs[j - 1].y_full for j in self.rows], axis=1)  # (N full, rows)
        both = jnp.concatenate([y_full, W.reshape(W.shape[0], -1)], axis=1)
        both = both if pre.decimate == 1 else decimate_columns(both, pre.decimate, mode=pre.mode)
        y, X = both[:, :rows], both[:, rows:].reshape(both.shape[0], rows, W.shape[2])
        ws, speeds = [], []
        for j in self.rows:
            own = inputs[j - 1]
            speed = jnp.abs(own.dq)
            if self.min_speed is None:
                threshold = jnp.maximum(self.rest_fraction * jnp.max(speed), MIN_REST_SPEED)
            else:
                threshold = jnp.asarray(self.min_speed, dtype=speed.dtype)
            ws.append((speed >= threshold).astype(y.dtype))
            speeds.append(own.dq)
        w = jnp.stack(ws, axis=1)
        tail = -(-pre.drop // pre.decimate)  # the zero-phase filter's end transient, as robot_idim_ls
        if tail:
            w = w.at[-tail:].set(0.0)
        p = X.shape[-1]
        yw, Xw = (y * w).reshape(-1), (X * w[..., None]).reshape(-1, p)
        fit = self.ls._solve(yw, Xw, self.names)
        relative_error = fit.relative_error
        joint_sigma = _joint_sigma(y, X, w, fit.theta)
        if self.joint_weights:  # each joint's rows over its residual standard deviation, and solve again
            scaled = w / joint_sigma
            fit = self.ls._solve((y * scaled).reshape(-1), (X * scaled[..., None]).reshape(-1, p), self.names)
            relative_error = 100 * jnp.linalg.norm((y - X @ fit.theta) * w) / jnp.linalg.norm(y * w)
            joint_sigma = _joint_sigma(y, X, w, fit.theta)
        n_rows, used = yw.shape[0], jnp.sum(w)
        scale = (n_rows - p) / (used - p)  # the rows at rest are zeros: sigma^2 over the rows used
        return RobotFit(
            theta=fit.theta,
            std=fit.std * jnp.sqrt(scale),
            cov=fit.cov * scale,
            sigma=fit.sigma * jnp.sqrt(scale),
            joint_sigma=joint_sigma,
            rows_used=used.astype(jnp.int32),
            cond=fit.cond,  # the rows weighted out are zeros: the singular values of the rows used
            relative_error=relative_error,
            y=y,
            X=X,
            weights=w,
            dq=jnp.stack(speeds, axis=1),
            q=jnp.stack([p.q for p in inputs], axis=1),
            inputs=tuple(inputs),
        )


class _Held:
    """A static field's holder compared by identity (the model's NumPy arrays are not hashable)."""

    __slots__ = ("value",)

    def __init__(self, value):
        self.value = value

    def __hash__(self):
        return id(self.value)

    def __eq__(self, other):
        return isinstance(other, _Held) and other.value is self.value


class RobotDiagnosis(NamedTuple):
    """What `RobotPipeline.diagnose` reads from one fit: `verdicts` (joint -> `JointVerdict`: identifiable, and the
    reasons it is not), `warnings` (one-line messages: identifiability, physically impossible estimates),
    `relative_error` (joint -> % on its rows used), `rows_used`, `identifiable` (more rows in motion than base
    parameters and finite standard errors)."""

    verdicts: dict
    warnings: tuple
    relative_error: dict
    rows_used: int
    identifiable: bool


def _joint_sigma(y, X, w, theta):
    """Each joint's residual standard deviation (N m) over its rows used (`w` 1)."""
    res = (y - X @ theta) * w
    return jnp.sqrt(jnp.sum(res**2, axis=0) / jnp.maximum(jnp.sum(w, axis=0), 1.0))


class RobotExperiment(eqx.Module):
    r"""One closed-loop experiment on a robot: `RobotExperiment(reference, dt=..., controller=...)(key, robot)`.

    The robot follows `reference` (N, n) rad under joint PD control with gravity feed-forward
    (`simulate_robot`: `controller`'s gains, critically damped at `bandwidth_hz` on its inertia, and its gravity
    model: a fixed controller, whatever the robot), `substeps` semi-implicit steps per sample of `dt` s; the
    logged torques carry white noise of `torque_noise` (n,) N m (std). Returns the `JointLogs` (joint side).

    The drive holds $\tau_k$ over $[t_k, t_{k+1})$; with `centred` (default) the log at $t_k$ is
    $(\tau_{k-1} + \tau_k) / 2$, the torque over the interval centred on $t_k$ (what a current sensor that
    averages over one period reads). That is the torque the central-difference acceleration at $t_k$ answers to,
    $(q_{k+1} - 2 q_k + q_{k-1}) / \Delta t^2 = (\ddot q_{k-1/2} + \ddot q_{k+1/2}) / 2$; logging the held
    $\tau_k$ instead (`centred=False`) puts half a sample between torque and motion, and IDIM-LS's estimates of
    the simulated TX40 move by up to 2.7 of their standard errors (the Monte Carlo's coverage fell to 6 %).
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
    centred: bool = eqx.field(static=True, default=True)

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
        held = sim.tau
        logged = jnp.concatenate([held[:1], 0.5 * (held[1:] + held[:-1])]) if self.centred else held
        tau = logged + self.torque_noise * jax.random.normal(key, held.shape)
        t = jnp.arange(qr.shape[0]) * self.dt
        joints = tuple(range(1, n + 1))
        return JointLogs(q=sim.q, tau=tau, t=t, dt=self.dt, joints=joints, source="simulated", converted="none")
