"""IDIM-LS of every joint of a robot at once on joint logs, read on the host: `robot_idim_ls` and `RobotIDIM`.

`robot_idim_ls` runs the robot pipeline (`RobotPipeline`: processing, the
stacked base regressor, parallel decimation, the rows at rest and the
filter's end transient weighted out) and reads its fit: the named IDIM-LS
result on the rows used, each joint's relative error (in motion and over
the whole record), the whiteness of each residual, the rest thresholds and
the rows' times. `robot_residual_sdp` then gives each joint's multi-SDP of
what the rigid body leaves.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._idim.estimators import IDIMIV, IVFit
from ..._idim.ls import IDIMResult, estimate_fields, rank_checked
from ..._records import JointLogs
from ..._runtime import x64
from ..._signal.filtering import decimate_start
from ..._signal.preprocess import Butterworth, Preprocessing, Smoothing
from ._joint_full import POORLY_EXCITED, in_motor_coordinate, poorly_excited
from ._joint_stages import DROP, MIN_SPEED, REST_FRACTION, moving_mask, residual_whiteness, rest_threshold
from ._pipeline import RobotPipeline
from ._stacked import RobotModel


class RobotIDIM(eqx.Module):
    """IDIM-LS of a robot's joints, all at once (`robot_idim_ls`).

    **Fields:** `result` (`IDIMResult` over the base parameters: values,
    standard deviations, relative ones %, condition number), `model`
    (`RobotModel`), `relative_error` (joint -> % on its rows used, those in
    motion), `relative_error_all` (joint -> % of `record_fit` over the whole
    record: every decimated row, rows at rest included; only the `tail` rows
    of the filter's end transient left out),
    `stacked_relative_error` (%), `whiteness` (joint -> `Whiteness` of its
    residual), `samples` (joint -> rows used), `y`, `fit`, `moving` ((M,
    joints) decimated torques, the model's fit and the rows used), `X` ((M,
    joints, rank) the decimated base regressor), `min_speed` (joint -> the
    rest threshold used, rad/s or m/s for a prismatic joint), `record_fit`
    ((M, joints): the model over the whole record, each motor's Coulomb term
    off where that motor is at rest, `record_fit`), `t` ((M,) s:
    the log's time of each decimated row, `logs.t[0]` plus the dropped
    samples and the decimation's phase), `tail` (the last rows, left out of
    every error: the zero-phase filter's end transient), `iv` (the iterated
    IDIM-IV, `IVFit`: iterations, convergence, the IDIM-LS start, when
    `robot_idim_ls` was given `iv`: `result` and every error are then the
    IV estimate's; else None).
    """

    result: IDIMResult
    y: jax.Array
    X: jax.Array
    fit: jax.Array
    moving: jax.Array
    whiteness: dict
    model: RobotModel
    inputs: tuple
    relative_error: dict = eqx.field(static=True)
    stacked_relative_error: float = eqx.field(static=True)
    samples: dict = eqx.field(static=True)
    min_speed: dict = eqx.field(static=True)
    relative_error_all: dict = eqx.field(static=True, default_factory=dict)
    record_fit: jax.Array | None = None
    t: jax.Array | None = None
    tail: int = eqx.field(static=True, default=0)
    iv: IVFit | None = None

    @x64
    def poorly_excited(self, limit: float = POORLY_EXCITED) -> tuple:
        """Base parameters with a relative standard deviation above `limit` (%)."""
        return poorly_excited(self.result, limit)


@x64
def robot_idim_ls(
    logs: JointLogs,
    model: RobotModel,
    *,
    preprocessing: dict | Preprocessing | None = None,
    min_speed=MIN_SPEED,
    iv: IDIMIV | None = None,
    loop=None,
) -> RobotIDIM:
    """IDIM-LS of every joint of `model` at once, on joint logs in the model's convention.

    The robot pipeline (`RobotPipeline`) on the logs: each joint's angle
    processed as the one-joint studies do (`preprocessing`: a
    `jaxsdp.Preprocessing`, or a dict of `joint_preprocess`'s options,
    Butterworth at 100 Hz, 100 samples dropped at both ends, decimation by
    10 by default); the stacked regressor built at the full rate on all
    joints' filtered states and decimated like the torques (parallel
    decimation); each joint's rows at rest (|dq_j| below its `min_speed`,
    default 1 % of its peak speed) left out; one LS on all the rows left
    (the pipeline's estimate, read as a named result on the rows used). Each joint's relative error is given on
    its rows in motion (`relative_error`) and over the whole record, rows at
    rest included (`relative_error_all`, the figure other toolboxes quote).
    With `iv` (`jaxsdp.IDIMIV`) and `loop` (the `RobotExperiment` that made the logs, or one that follows the
    logged angles): the iterated bias-compensated IDIM-IV started from that estimate (`RobotPipeline`'s), its
    instruments the identified robot simulated noise free in `loop`; the result and every error are the IV's.

    **Returns:** a `RobotIDIM`.

    Example:
        >>> import numpy as np
        >>> import jax.numpy as jnp
        >>> from jaxsdp.data import JointLogs
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.plants.robot import robot_idim_ls, robot_model
        >>> arm = SerialRobot.from_mdh([[0.0, 0.0, 0.0, 0.0]], inertias=[(2.0, [0.5, 0.0, 0.0], np.zeros(6))],
        ...                            Fv=3.0, Fc=1.0)
        >>> t = np.arange(0, 10, 1e-3)[:, None]
        >>> q, dq, ddq = np.sin(t), np.cos(t), -np.sin(t)  # a horizontal arm: no gravity torque
        >>> logs = JointLogs(q=jnp.asarray(q), tau=arm.drive_torques(q, dq, ddq), t=jnp.asarray(t[:, 0]),
        ...                  dt=1e-3, joints=(1,), source="sim", converted="none")
        >>> res = robot_idim_ls(logs, robot_model(arm))
        >>> {k: round(float(v), 3) for k, v in zip(res.result.names, res.result.theta)}  # ZZ1 = 2 * 0.5^2
        {'ZZ1': 0.5, 'Fv1': 3.0, 'Fc1': 1.0, 'offset1': 0.0}
    """
    if not isinstance(logs, JointLogs):
        raise ValueError(f"`logs` must be a JointLogs; got {type(logs).__name__}")
    fixed = None if isinstance(min_speed, str) and min_speed == "auto" else min_speed
    pipeline = RobotPipeline.of(
        model,
        preprocessing=preprocessing_of(preprocessing),
        rest_fraction=REST_FRACTION,
        min_speed=fixed,
        iv=iv,
        loop=loop,
    )
    fitted = pipeline(logs)
    inputs = list(fitted.inputs)
    thresholds = {j: rest_threshold(inputs[j - 1], min_speed) for j in model.rows}
    y, X = fitted.y, fitted.X
    moving = np.asarray(fitted.weights) > 0  # in motion, and not the zero-phase filter's end transient
    for i, j in enumerate(model.rows):  # the one-joint stages' check: enough samples in motion
        in_motion = int(np.sum(np.abs(np.asarray(inputs[j - 1].dq)) >= thresholds[j]))
        if in_motion < 20:
            raise ValueError(
                f"joint {j}: only {in_motion} of {moving.shape[0]} samples move faster than min_speed = "
                f"{thresholds[j]:g} rad/s: the joint hardly moves in this record (wrong joint, or lower `min_speed`)"
            )
    tail = -(-int(inputs[0].drop) // int(inputs[0].decimate))
    result = named_result(fitted, model.names, moving)  # the pipeline's estimate, read on the rows used
    fit = jnp.einsum("mjp,p->mj", X, jnp.asarray(result.theta))
    whole = record_fit(np.asarray(X), np.asarray(result.theta), model, inputs, min_speed)
    rel, rel_all, white, samples = {}, {}, {}, {}
    yy, ff = np.asarray(y), np.asarray(fit)
    record = slice(0, yy.shape[0] - tail)
    for i, j in enumerate(model.rows):
        k = moving[:, i]
        e = yy[k, i] - ff[k, i]
        rel[j] = relative_error(e, yy[k, i])
        rel_all[j] = relative_error(yy[record, i] - whole[record, i], yy[record, i])
        white[j] = residual_whiteness(jnp.asarray(e), inputs[j - 1].decimate)
        samples[j] = int(k.sum())
    e_all = (yy - ff)[moving]
    return RobotIDIM(
        result=result,
        y=y,
        X=X,
        fit=fit,
        moving=jnp.asarray(moving),
        model=model,
        relative_error=rel,
        stacked_relative_error=relative_error(e_all, yy[moving]),
        whiteness=white,
        inputs=tuple(inputs),
        samples=samples,
        min_speed=thresholds,
        relative_error_all=rel_all,
        record_fit=jnp.asarray(whole),
        t=jnp.asarray(row_times(logs, inputs[0], yy.shape[0])),
        tail=tail,
        iv=fitted.idim_iv,
    )


def named_result(fitted, names, moving: np.ndarray) -> IDIMResult:
    """The `IDIMResult` of a `RobotFit` on its rows used (`moving`, (M, joints)): the pipeline's estimate,
    standard errors and condition number (the rows weighted out are zeros), its residuals and fit on those rows
    stacked joint after joint as `idim_ls(y[moving], X[moving])` would give them; ValueError when the regressor
    is numerically rank deficient there."""
    y, X = jnp.asarray(fitted.y)[moving], jnp.asarray(fitted.X)[moving]
    n, p = X.shape
    fields = estimate_fields(y, fitted.theta, X @ fitted.theta, fitted.cov, fitted.sigma**2, None)
    return IDIMResult(**fields, cond=rank_checked("X", fitted.cond, n, p), names=tuple(names), dof=n - p)


def record_fit(X: np.ndarray, theta: np.ndarray, model: RobotModel, inputs, min_speed=MIN_SPEED) -> np.ndarray:
    """(M, joints): the model `X theta` over the whole record, each motor k's Coulomb column `Fc<k>` set to 0 on
    the rows where it is at rest (|du_k| below `rest_threshold(., min_speed)` of its coordinate du_k: the
    joint's dq_k without a coupling, `in_motor_coordinate`). There sign(du_k) is the sign of noise, and the
    friction passes through the stick region within +-Fc_k, which the model does not describe: the one-joint
    studies' definition (`JointIDIM.record_fit`). In motion it is the fit."""
    X = np.array(X, dtype=float)
    for c, name in enumerate(model.names):
        if not (name.startswith("Fc") and name[2:].isdigit()):
            continue
        k = int(name[2:])
        own, _ = in_motor_coordinate(inputs[k - 1], inputs, k, model.transmission)
        X[np.abs(np.asarray(own.dq)) < rest_threshold(own, min_speed), :, c] = 0.0
    return X @ np.asarray(theta, dtype=float)


def relative_error(e, y) -> float:
    """100 ||e|| / ||y|| (%); inf when y is all zeros (and e is not), NaN when both are."""
    ne, ny = float(np.linalg.norm(e)), float(np.linalg.norm(y))
    if ny > 0.0:
        return 100.0 * ne / ny
    return math.inf if ne > 0.0 else math.nan


def row_times(logs: JointLogs, inputs, rows: int) -> np.ndarray:
    """(rows,) s: the log's time of each decimated row of `inputs` (a `Preprocessed` of `logs`): `logs.t[0]`
    plus the `drop` samples removed and the decimation's phase (`decimate` keeps every r-th sample from
    `decimate_start`)."""
    r = int(inputs.decimate)
    start = 0 if r == 1 else decimate_start(int(inputs.y_full.shape[0]), r, inputs.mode)
    k = int(inputs.drop) + start + r * np.arange(rows)
    return float(np.asarray(logs.t)[0]) + k * float(inputs.dt_full)


def own_columns(model: RobotModel, joint: int) -> np.ndarray:
    """Mask of the base parameters that are joint `joint`'s own friction and offset (Fv, Fc, offset)."""
    own = {f"{k}{joint}" for k in ("Fv", "Fc", "offset")}
    return np.array([name in own for name in model.names])


@x64
def robot_residual_sdp(res: RobotIDIM, *, joints=None, model=("RW", "RW"), tol: float = 0.01, max_iter: int = 20):
    """The multi-SDP of each joint's torque once the full model's rigid body (and the other motors) is known.

    For joint j: y_j - known_j = d_q(q_j) + d_dq(dq_j) + e, known_j the
    stacked model's fit without the joint's own Fv, Fc and offset
    (`own_columns`), the curves in the joint's own angle and velocity (for
    a coupled motor, the velocity of its own coordinate (C^-1 dq)_j, where
    its friction lives: the TX40's motor 6, dq5 + dq6)
    (`joint_multi_sdp`: back-fitting on every sample, projections and the
    shape test on the samples in motion). What the curves find is what the
    rigid-body model misses on that joint: friction's shape, a position
    dependence (a cable, a spring, flexibility), coupling left out.

    **Returns:** `{joint: JointSDP}` for `joints` (default all of `res`).
    """
    from ..._sdp.multi import MultiBackfitting
    from ._joint_stages import joint_multi_sdp

    rows = res.model.rows if joints is None else tuple(int(j) for j in joints)
    theta = jnp.asarray(res.result.theta)
    out = {}
    for j in rows:
        if j not in res.model.rows:
            raise ValueError(f"joint {j} is not one of the identified joints {res.model.rows}")
        i = res.model.rows.index(j)
        own, coupled = in_motor_coordinate(res.inputs[j - 1], res.inputs, j, res.model.transmission)
        moving = moving_mask(own, "auto") if coupled else np.asarray(res.moving)[:, i]
        keep = ~own_columns(res.model, j)
        known = res.X[:, i, :][:, keep] @ theta[keep]
        out[j] = joint_multi_sdp(
            own,
            known=known,
            inertia_source="full model",
            moving=moving,
            joint=j,
            sdp=MultiBackfitting(model=model, tol=tol, max_iter=max_iter),
        )
    return out


def preprocessing_of(preprocessing) -> Preprocessing:
    """`robot_idim_ls`'s `preprocessing` as a `Preprocessing`: one given as is, a dict of `joint_preprocess`'s
    options (`derivatives`, `cutoff_hz`, `order`, `nvr`, `drop`, `decimate`, `mode`) with its defaults."""
    if isinstance(preprocessing, Preprocessing):
        return preprocessing
    kw = {} if preprocessing is None else dict(preprocessing)
    known = {"derivatives", "cutoff_hz", "order", "nvr", "drop", "decimate", "mode"}
    if set(kw) - known:
        raise ValueError(f"`preprocessing` has unknown options {sorted(set(kw) - known)}; known: {sorted(known)}")
    if kw.get("derivatives", "butterworth") == "smooth":
        derivatives = Smoothing(kw.get("cutoff_hz", 100.0), kw.get("nvr"))
    elif kw.get("derivatives", "butterworth") == "butterworth":
        derivatives = Butterworth(kw.get("cutoff_hz", 100.0), kw.get("order", 4))
    else:
        raise ValueError(f"`derivatives` must be 'butterworth' or 'smooth'; got {kw['derivatives']!r}")
    drop, decimate, mode = kw.get("drop", DROP), kw.get("decimate", 10), kw.get("mode", "matlab")
    return Preprocessing(derivatives, drop=drop, decimate=decimate, mode=mode)
