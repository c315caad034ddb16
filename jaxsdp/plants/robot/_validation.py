"""Validation of a robot's stacked IDIM-LS: cross-validation over blocks of the record, and each joint's units.

`robot_cross_validation` splits the record's decimated rows into contiguous
blocks in time; for each block the LS fit on the other blocks (same base
regressor, same rows in motion) predicts the held-out one:

    theta_b = argmin ||y_train - X_train theta||,   e_b = y_b - X_b theta_b,

per joint 100 ||e_b|| / ||y_b|| (%) on its held-out rows in motion. Held-out
errors close to the in-sample ones say the model does not fit the noise of
one stretch of the record; far above them, that the estimates depend on
which motion they saw. `joint_units` gives a joint's effort, position and
velocity units (N m, rad, rad/s; a prismatic joint N, m, m/s).
"""

import numpy as np

from ._robot_idim import RobotIDIM, relative_error
from ._serial import SerialRobot

#: Relative singular value (columns scaled to unit norm) below which a training regressor is rank deficient.
RANK_TOL = 1e-10
#: Rows in motion, per base parameter, a training block needs at least.
MIN_ROWS_PER_PARAMETER = 2


def joint_units(robot: SerialRobot, joint: int) -> dict:
    """The units of joint `joint` (1-based) of `robot`: {"effort", "position", "velocity", "acceleration"}.

    A revolute joint: N m, rad, rad/s, rad/s^2; a prismatic joint (`robot.prismatic[joint - 1]`): N, m, m/s,
    m/s^2.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import SerialRobot
        >>> from jaxsdp.plants.robot._validation import joint_units
        >>> arm = SerialRobot.from_mdh([[0.0, 0.0, 0.0, 0.0]] * 2, inertias=np.ones((2, 10)), prismatic=[False, True])
        >>> joint_units(arm, 2)["effort"], joint_units(arm, 1)["velocity"]
        ('N', 'rad/s')
    """
    n = robot.n
    if isinstance(joint, bool) or not isinstance(joint, (int, np.integer)) or not 1 <= joint <= n:
        raise ValueError(f"`joint` must be a joint number in 1..{n}; got {joint!r}")
    if robot.prismatic and robot.prismatic[joint - 1]:
        return {"effort": "N", "position": "m", "velocity": "m/s", "acceleration": "m/s^2"}
    return {"effort": "N m", "position": "rad", "velocity": "rad/s", "acceleration": "rad/s^2"}


def _blocks(rows: int, folds: int) -> list[tuple[int, int]]:
    edges = np.linspace(0, rows, folds + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def _qr_fit(A: np.ndarray, a: np.ndarray, names) -> tuple[np.ndarray | None, str | None]:
    """LS of a ~ A theta by QR of A's unit-norm columns: (theta, None), or (None, why) when A (rows, p) is rank
    deficient: the relative singular values of R (those of the scaled A) below `RANK_TOL`, and the parameters
    the null directions weigh on."""
    norms = np.linalg.norm(A, axis=0)
    norms = np.where(norms > 0.0, norms, 1.0)
    p = A.shape[1]
    Rb = np.linalg.qr(np.column_stack([A / norms, a]), mode="r")  # [R, Q^T a] without forming Q
    R, qa = Rb[:p, :p], Rb[:p, p]
    _, s, vt = np.linalg.svd(R)
    rel = s / s[0] if s[0] > 0.0 else np.zeros_like(s)
    weak = rel < RANK_TOL
    if not weak.any():
        return np.linalg.solve(R, qa) / norms, None
    weight = np.linalg.norm(vt[weak], axis=0)
    order = [c for c in np.argsort(-weight) if weight[c] >= 0.1 * weight.max()][:6]
    return None, (
        f"rank deficient: the other blocks leave {int(weak.sum())} of {len(names)} base parameters unidentified "
        f"(relative singular value {float(rel.min()):.3g} < {RANK_TOL:g}; {', '.join(names[c] for c in order)}): "
        "the motion that excites them lies in the held-out block; use fewer folds or a record that repeats its "
        "excitation"
    )


def robot_cross_validation(idim: RobotIDIM, *, folds: int = 2) -> dict:
    """Cross-validation of a stacked IDIM-LS (`robot_idim_ls`) over `folds` contiguous blocks of the record.

    The decimated rows of the record (those before the filter's end
    transient, `idim.tail`) are split into `folds` blocks of equal length in
    time; for each block, LS (QR of the unit-norm columns, host-side NumPy)
    on the rows in motion of the other blocks (`idim.moving`, the same base
    regressor `idim.X`) predicts the block's rows in motion. A fold whose
    training regressor is rank deficient (relative singular value below
    `RANK_TOL` = 1e-10, or fewer than 2 rows per base parameter) is not
    fitted: its errors are None and `reason` says why.

    **Returns:** a JSON-ready dict (joints by number, errors in %):

    - `folds`: one dict per block: `fold` (1-based), `rows` ([first, stop)
      decimated rows), `time` ([start, end] s of the log, or None),
      `samples` (joint -> held-out rows in motion), `relative_error`
      (joint -> held-out %, None where the joint has no row in motion in the
      block; None when the fold was not fitted), `stacked_relative_error`
      (held-out, all joints' rows), `reason` (None, or why it was not fitted);
    - `relative_error` (joint -> %): over every held-out row of the folds
      fitted (each row predicted by the fit that did not see it; None when
      none); `stacked_relative_error`;
    - `in_sample` (joint -> %: `idim.relative_error`) and
      `stacked_in_sample` (%), for comparison; `fitted` (folds fitted).

    Example:
        >>> from jaxsdp.plants.robot._validation import robot_cross_validation
        >>> from jaxsdp.studies.robot import example_study
        >>> cv = robot_cross_validation(example_study().idim, folds=2)
        >>> cv["fitted"], round(cv["relative_error"][1], 1), round(cv["in_sample"][1], 1)  # %
        (2, 16.2, 16.2)
    """
    if not isinstance(idim, RobotIDIM):
        raise ValueError(f"`idim` must be a RobotIDIM (robot_idim_ls); got {type(idim).__name__}")
    y, X = np.asarray(idim.y, dtype=float), np.asarray(idim.X, dtype=float)
    moving = np.asarray(idim.moving, dtype=bool)
    rows, p = y.shape[0] - int(idim.tail), X.shape[-1]
    if isinstance(folds, bool) or not isinstance(folds, (int, np.integer)) or not 2 <= folds <= rows // 10:
        raise ValueError(f"`folds` must be an integer in 2..{rows // 10} (10 rows per block at least); got {folds!r}")
    t = None if idim.t is None else np.asarray(idim.t, dtype=float)
    joints, names = idim.model.rows, idim.model.names
    held_e = {j: [] for j in joints}
    held_y = {j: [] for j in joints}
    out = []
    for b, (lo, hi) in enumerate(_blocks(rows, int(folds))):
        block = np.zeros(y.shape[0], dtype=bool)
        block[lo:hi] = True
        train, test = moving & ~block[:, None], moving & block[:, None]
        entry = {
            "fold": b + 1,
            "rows": [lo, hi],
            "time": None if t is None else [float(t[lo]), float(t[hi - 1])],
            "samples": {j: int(test[:, i].sum()) for i, j in enumerate(joints)},
            "relative_error": None,
            "stacked_relative_error": None,
            "reason": None,
        }
        A, a = X[train], y[train]
        if A.shape[0] < MIN_ROWS_PER_PARAMETER * p:
            entry["reason"] = (
                f"too few rows in motion outside the block ({A.shape[0]} for {p} base parameters, "
                f"{MIN_ROWS_PER_PARAMETER * p} needed): use fewer folds"
            )
        else:
            theta, entry["reason"] = _qr_fit(A, a, names)
        if entry["reason"] is not None:
            out.append(entry)
            continue
        pred = X @ theta
        errs = {}
        for i, j in enumerate(joints):
            k = test[:, i]
            if not k.any():
                errs[j] = None
                continue
            held_e[j].append(y[k, i] - pred[k, i])
            held_y[j].append(y[k, i])
            errs[j] = relative_error(held_e[j][-1], held_y[j][-1])
        entry["relative_error"] = errs
        entry["stacked_relative_error"] = relative_error(y[test] - pred[test], y[test])
        out.append(entry)
    total = {
        j: relative_error(np.concatenate(held_e[j]), np.concatenate(held_y[j])) if held_e[j] else None for j in joints
    }
    fitted = [e for e in out if e["reason"] is None]
    stacked = None
    if fitted:
        e_all = np.concatenate([np.concatenate(held_e[j]) for j in joints if held_e[j]])
        y_all = np.concatenate([np.concatenate(held_y[j]) for j in joints if held_y[j]])
        stacked = relative_error(e_all, y_all)
    return {
        "folds": out,
        "relative_error": total,
        "stacked_relative_error": stacked,
        "in_sample": dict(idim.relative_error),
        "stacked_in_sample": float(idim.stacked_relative_error),
        "fitted": len(fitted),
    }
