"""Each joint judged identifiable or not, and the identified model against its description (host-side NumPy).

Before the fit, from the joint-side logs alone (`screen_channels`): a joint
whose rows would bias the parameters the joints share is left out of the
stacked LS when

- (a) its torque channel reports nothing: the most frequent exact value
  (0.0 for a drive that logs nothing) fills more than `MAX_REPEATED` = 50 %
  of the samples, or the channel is constant (peak-to-peak at most
  `CONSTANT_PTP` = 1e-9 of the largest torque of the logs). Real currents
  never repeat one float in half the samples (real TX40: at most 0.6 %);
- (b) its torque is at the noise level: the RMS of its variation (zero-phase
  Butterworth order 4 at `min(MOTION_CUTOFF_HZ, fs / 10)`, mean removed)
  is below `MIN_SNR` = 3 times the noise, estimated robustly from the second
  differences, sigma = 1.4826 MAD(d2 tau) / sqrt(6) (a smooth torque hardly
  enters them; real TX40: 14 to 216 times);
- (c) the joint barely moves: its low-passed position spans less than
  `MIN_RANGE_RAD` (1 degree) or `MIN_RANGE_M` (1 mm, a prismatic joint), or
  fewer than `MIN_MOVING` = 5 % of the samples are faster than the rest
  threshold (default: 1 % of the low-passed peak speed, at least 0.01 rad/s
  or 1 mm/s; real TX40: 114 to 400 degrees, 76 to 78 % of the samples).

Each verdict's reasons are sentences naming the joint by its description's
name and its torque channel, with the value and the threshold.

After the fit (`judge_estimates`): (d) a relative error of 100 % or more on
the joint's rows, (e) non-physical estimates beyond their standard deviation:
a base parameter that is a single motor inertia, viscous or Coulomb friction
(value + std < 0), or the identified joint-space inertia Ia_j + M_jj(q)
negative beyond its standard deviation at a logged configuration.

`description_comparison`: each base parameter against the description's value
of the same combination; `velocity_check`: a logged velocity against the
derivative of the logged position; `stacked_error`: the stacked relative error
over some joints.
"""

import math
import re
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from ._joint import BASE_STATES
from ._joint_stages import MIN_REST_SPEED, REST_FRACTION
from ._motion import MOTION_CUTOFF_HZ

#: (a) A torque channel whose most frequent exact value fills more than this share of the samples reports nothing.
MAX_REPEATED = 0.5
#: (a) A torque channel whose peak-to-peak is at most this share of the logs' largest |torque| is constant.
CONSTANT_PTP = 1e-9
#: (b) The torque's low-passed variation (RMS) must be at least this many times its noise.
MIN_SNR = 3.0
#: (c) A revolute joint must span at least this (rad, 1 degree), a prismatic joint `MIN_RANGE_M` (m)...
MIN_RANGE_RAD = math.radians(1.0)
MIN_RANGE_M = 1e-3
#: ...and move (faster than the rest threshold) in at least this share of the samples.
MIN_MOVING = 0.05
#: (c) The automatic rest threshold's floor for a prismatic joint (m/s; revolute: `MIN_REST_SPEED` rad/s).
MIN_REST_SPEED_LINEAR = 1e-3
#: (d) A joint whose relative error (%) is at least this is not identified.
MAX_RELATIVE_ERROR = 100.0
#: Identified and described values differ when their ratio is beyond this factor either way (or of opposite sign)...
MAX_DESCRIPTION_FACTOR = 3.0
#: ...for an estimate whose standard deviation is below this share (%) of the larger of the two values...
MAX_REL_STD = 30.0
#: ...and a described value that matters: at least this share of the largest described value of its units...
MIN_NOMINAL_SHARE = 0.01
#: ...whose torque is at least this share of the RMS torque of the joint it loads most.
MIN_TORQUE_SHARE = 0.05
#: A base parameter is a gravity parameter when its gravity column is at least this share of its whole column (RMS).
GRAVITY_SHARE = 0.5
#: A logged velocity whose scale against the position's derivative is off by more than this share is flagged...
MAX_VELOCITY_SCALE = 0.1
#: ...and one whose correlation with it is below this.
MIN_VELOCITY_CORRELATION = 0.9

_NAME = re.compile(r"^(XX|XY|XZ|YY|YZ|ZZ|MX|MY|MZ|M|Ia|Fv|Fc|offset)(\d+)$")
_DRIVE = ("Ia", "Fv", "Fc", "offset")


class JointVerdict(NamedTuple):
    """Whether a joint can be identified from its logs: `identifiable`, and the `reasons` it cannot (sentences)."""

    identifiable: bool
    reasons: tuple = ()


def combine(*verdicts: dict) -> dict:
    """Joint -> `JointVerdict` of several judgements: identifiable when every one says so, their reasons joined."""
    out = {}
    for verdict in verdicts:
        for j, v in verdict.items():
            old = out.get(j, JointVerdict(True))
            out[j] = JointVerdict(old.identifiable and v.identifiable, old.reasons + tuple(v.reasons))
    return out


def _verdicts(joints, reasons: dict) -> dict:
    return {j: JointVerdict(not reasons.get(j), tuple(reasons.get(j, ()))) for j in joints}


def _names(robot) -> tuple:
    n = robot.n
    return tuple(robot.names) if robot.names else tuple(f"joint{j}" for j in range(1, n + 1))


def _is_prismatic(robot, j: int) -> bool:
    return bool(robot.prismatic[j - 1]) if robot.prismatic else False


def _units(robot, j: int) -> dict:
    """Units of joint `j`'s torque, position, speed and inertia."""
    if _is_prismatic(robot, j):
        return {"tau": "N", "q": "mm", "q_scale": 1e3, "dq": "m/s", "inertia": "kg", "Fv": "N s/m"}
    return {"tau": "N m", "q": "deg", "q_scale": 180 / math.pi, "dq": "rad/s", "inertia": "kg m^2", "Fv": "N m s/rad"}


def _lowpass(x: np.ndarray, dt: float) -> tuple[np.ndarray, float]:
    """Zero-phase Butterworth order 4 at min(`MOTION_CUTOFF_HZ`, fs / 10) along axis 0, and the cut-off (Hz)."""
    import scipy.signal

    fc = min(MOTION_CUTOFF_HZ, 0.1 / dt)
    if x.shape[0] <= 30:
        return x, fc
    sos = scipy.signal.butter(4, 2.0 * fc * dt, output="sos")
    return scipy.signal.sosfiltfilt(sos, x, axis=0), fc


def noise_level(tau) -> float:
    """Robust standard deviation of white noise on `tau` (N,): 1.4826 MAD(d2 tau) / sqrt(6)."""
    d2 = np.diff(np.asarray(tau, dtype=float), n=2)
    if d2.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def _threshold(rest_threshold, j: int, peak: float, prismatic: bool) -> float:
    if isinstance(rest_threshold, dict):
        rest_threshold = rest_threshold.get(j)
    if rest_threshold is None or (isinstance(rest_threshold, str) and rest_threshold == "auto"):
        return max(REST_FRACTION * peak, MIN_REST_SPEED_LINEAR if prismatic else MIN_REST_SPEED)
    number = isinstance(rest_threshold, (int, float, np.floating)) and not isinstance(rest_threshold, bool)
    v = float(rest_threshold) if number else math.nan
    if not (math.isfinite(v) and v >= 0):
        raise ValueError(
            "`rest_threshold` must be None, 'auto', a speed >= 0 (rad/s, m/s) or a dict of them; "
            f"got {rest_threshold!r}"
        )
    return v


def screen_channels(logs, robot, *, rest_threshold=None) -> dict:
    """Joint -> `JointVerdict` from the joint-side logs alone, before any fit: (a), (b), (c) of the module.

    **Arguments:** `logs` (`JointLogs` in the model's convention); `robot`
    (`SerialRobot`: the joints' names, which are prismatic); `rest_threshold`:
    the speed (rad/s, m/s) below which a sample is at rest, "auto" or None (1 %
    of the joint's peak speed, at least 0.01 rad/s or 1 mm/s), or a dict joint
    -> one of these.
    """
    q = np.asarray(logs.q, dtype=float)
    tau = np.asarray(logs.tau, dtype=float)
    if q.ndim != 2 or tau.shape != q.shape or q.shape[1] != len(logs.joints):
        raise ValueError(f"`logs` must hold q and tau of shape (N, {len(logs.joints)}); got {q.shape}, {tau.shape}")
    dt = float(logs.dt)
    names = _names(robot)
    qs, fc = _lowpass(q, dt)
    ts, _ = _lowpass(tau, dt)
    speed = np.abs(np.gradient(qs, dt, axis=0)) if q.shape[0] > 1 else np.zeros_like(q)
    scale = float(np.max(np.abs(tau))) if tau.size else 0.0
    reasons = {}
    for col, j in enumerate(logs.joints):
        u, name, why = _units(robot, j), names[j - 1], []
        x = tau[:, col]
        values, counts = np.unique(x, return_counts=True)
        share = float(counts.max()) / x.size
        if values.size == 1 or float(np.ptp(x)) <= CONSTANT_PTP * scale:
            why.append(
                f"the torque channel of joint '{name}' is constant ({float(np.median(x)):.3g} {u['tau']}): its "
                "drive reports nothing; log its torque or current"
            )
        elif share > MAX_REPEATED:
            value = float(values[np.argmax(counts)])
            what = "exactly 0" if value == 0.0 else f"exactly {value:.6g} {u['tau']}"
            why.append(
                f"the torque channel of joint '{name}' is {what} in {100 * share:.3g} % of the samples (at most "
                f"{100 * MAX_REPEATED:g} %): its drive reports nothing most of the time; log its torque or current"
            )
        else:
            # white noise of standard deviation sigma keeps sigma sqrt(2 fc dt) below the cut-off fc: the
            # channel's variation there is compared with the noise in the same band
            sigma = noise_level(x) * math.sqrt(min(1.0, 2.0 * fc * dt))
            variation = float(np.std(ts[:, col]))
            if sigma > 0 and variation < MIN_SNR * sigma:
                why.append(
                    f"the torque channel of joint '{name}' is at the noise level: its variation below {fc:.3g} Hz "
                    f"(RMS {variation:.3g} {u['tau']}) is {variation / sigma:.3g} times the noise in that band "
                    f"({sigma:.3g} {u['tau']}; at least {MIN_SNR:g} needed); check that the channel is the joint's "
                    "torque or current"
                )
        prismatic = _is_prismatic(robot, j)
        span = float(np.ptp(qs[:, col]))
        min_range = MIN_RANGE_M if prismatic else MIN_RANGE_RAD
        threshold = _threshold(rest_threshold, j, float(np.max(speed[:, col])), prismatic)
        moving = float(np.mean(speed[:, col] >= threshold))
        if span < min_range:
            why.append(
                f"joint '{name}' barely moves: it spans {span * u['q_scale']:.3g} {u['q']} (at least "
                f"{min_range * u['q_scale']:.3g} {u['q']} needed); a trajectory that moves it identifies it"
            )
        elif moving < MIN_MOVING:
            why.append(
                f"joint '{name}' moves in only {100 * moving:.3g} % of the samples (faster than {threshold:.3g} "
                f"{u['dq']}; at least {100 * MIN_MOVING:g} % needed); a trajectory that moves it identifies it"
            )
        reasons[int(j)] = why
    return _verdicts([int(j) for j in logs.joints], reasons)


def logged_angles(idim) -> np.ndarray:
    """(M, n) the decimated joint angles of a `RobotIDIM` (every joint's processed log)."""
    return np.stack([np.asarray(p.q, dtype=float) for p in idim.inputs], axis=1)


def _blocks(model, q, states: int = BASE_STATES):
    """At K of the logged configurations `q` (M, n) (the shape `robot_model` compiled), the base regressor's gravity
    rows G (K, rows, rank) and, per row i, the rows D_i (K, rank) of the diagonal inertia Ia_i + M_ii(q) (offsets
    left out)."""
    n, rows = model.robot.n, model.rows
    q = np.asarray(q, dtype=float)
    k = max(states // (len(rows) + 1), 1)
    pick = np.linspace(0, q.shape[0] - 1, k).round().astype(int)
    ddq = np.concatenate([np.zeros((k, n))] + [np.tile(np.eye(n)[j - 1], (k, 1)) for j in rows])
    qq = np.tile(q[pick], (len(rows) + 1, 1))
    pad = states - ddq.shape[0]
    if pad > 0:
        ddq, qq = np.concatenate([ddq, np.zeros((pad, n))]), np.concatenate([qq, np.zeros((pad, n))])
    W = np.array(model.regressor(jnp.asarray(qq), jnp.zeros_like(jnp.asarray(qq)), jnp.asarray(ddq)))
    W[:, :, [i for i, name in enumerate(model.names) if name.startswith("offset")]] = 0.0
    G = W[:k]
    D = [W[(i + 1) * k : (i + 2) * k, i, :] - G[:, i, :] for i in range(len(rows))]
    return G, D


def _split(name: str):
    m = _NAME.match(name)
    return (m.group(1), int(m.group(2))) if m else (None, None)


def _sign_advice(channels: list, drives_given: bool, names) -> str:
    joints = sorted(set(channels))
    which = ("joint " if len(joints) == 1 else "joints ") + ", ".join(f"'{names[j - 1]}'" for j in joints)
    if drives_given:
        return f"check the signs of the drives' ratios and torque constants (`drives`) for {which}"
    channels = "the torque channel of " if len(joints) == 1 else "the torque channels of "
    return f"{channels}{which} may be empty, noisy or of the wrong sign"


def judge_estimates(idim, *, drives_given: bool) -> tuple[dict, list]:
    """Joint -> `JointVerdict` after the fit ((d), (e) of the module), and the warnings on non-physical signs.

    **Arguments:** `idim` (`RobotIDIM`); `drives_given`: whether the logs were
    converted by drives (then the warnings advise checking them; else they name
    the torque channels).

    **Returns:** `(verdicts, warnings)` (`judge`'s).
    """
    res = idim.result
    return judge(
        idim.model, res.theta, res.std, res.cov, idim.relative_error, logged_angles(idim), drives_given=drives_given
    )


def judge(model, theta, std, cov, relative_error: dict, q, *, drives_given: bool) -> tuple[dict, list]:
    """`judge_estimates` on the estimate's arrays: `model` (`RobotModel`), `theta`, `std`, `cov` over its base
    parameters, `relative_error` (joint -> % on its rows used), `q` (M, n) logged angles (rad or m)."""
    names = _names(model.robot)
    theta = np.asarray(theta, dtype=float)
    std = np.asarray(std, dtype=float)
    reasons = {j: [] for j in model.rows}
    for j in model.rows:
        rel = float(relative_error[j])
        if not rel < MAX_RELATIVE_ERROR:
            reasons[j].append(
                f"the model's error on the torque of joint '{names[j - 1]}' is {rel:.3g} % of it (relative error at "
                f"least {MAX_RELATIVE_ERROR:g} %): its torque channel does not follow the motion"
            )
    negative, inertia = [], []
    for i, (name, comb) in enumerate(zip(model.names, model.base.names)):
        kind, j = _split(name)
        if kind not in ("Ia", "Fv", "Fc") or comb != name or not theta[i] + std[i] < 0:
            continue
        u = _units(model.robot, j)
        value = f"{name} = {theta[i]:.3g} {dict(Ia=u['inertia'], Fv=u['Fv'], Fc=u['tau'])[kind]}"
        rel = 100.0 * std[i] / abs(theta[i])
        negative.append((j, f"{value}, relative standard deviation {rel:.3g} %"))
        what = dict(Ia="motor inertia", Fv="viscous friction", Fc="Coulomb friction")[kind]
        reasons.setdefault(j, []).append(
            f"the {what} of joint '{names[j - 1]}' {value} is negative beyond its standard deviation ({rel:.3g} %): "
            "physically impossible"
        )
    _, D = _blocks(model, q)
    cov = np.asarray(cov, dtype=float)
    for i, j in enumerate(model.rows):
        d = D[i] @ theta
        s = np.sqrt(np.maximum(np.einsum("kp,pq,kq->k", D[i], cov, D[i]), 0.0))
        bad = d + s < 0
        if bad.any():
            where = (
                f"at {100 * bad.mean():.3g} % of the logged configurations (down to {float(d.min()):.3g} "
                f"{_units(model.robot, j)['inertia']})"
            )
            inertia.append((j, f"joint '{names[j - 1]}' {where}"))
            reasons[j].append(
                f"the identified inertia Ia + M_jj(q) of joint '{names[j - 1]}' is negative beyond its standard "
                f"deviation {where}: physically impossible"
            )
    warnings = []
    if negative:
        warnings.append(
            "negative motor inertia or friction estimates beyond their standard deviation "
            f"({'; '.join(t for _, t in negative)}): physically impossible; "
            + _sign_advice([j for j, _ in negative], drives_given, names)
        )
    if inertia:
        warnings.append(
            "the identified joint-space inertia Ia_j + M_jj(q) is negative beyond its standard deviation for "
            f"{'; '.join(t for _, t in inertia)}: physically impossible; "
            + _sign_advice([j for j, _ in inertia], drives_given, names)
        )
    return _verdicts(model.rows, reasons), warnings


def stacked_error(idim, joints) -> float:
    """100 ||y - fit|| / ||y|| (%) over the rows in motion of `joints` (`RobotIDIM.stacked_relative_error`'s
    definition, restricted to those joints)."""
    rows = idim.model.rows
    joints = [int(j) for j in joints]
    if not joints or any(j not in rows for j in joints):
        raise ValueError(f"`joints` must be one or more of the identified joints {rows}; got {joints}")
    cols = [rows.index(j) for j in joints]
    y, fit = np.asarray(idim.y)[:, cols], np.asarray(idim.fit)[:, cols]
    keep = np.asarray(idim.moving)[:, cols]
    return float(100.0 * np.linalg.norm((y - fit)[keep]) / np.linalg.norm(y[keep]))


def _full_theta(robot) -> np.ndarray:
    """The description's full parameter vector in `robot_model`'s order (links, then Ia, Fv, Fc per motor, offsets)."""
    drives = np.stack([np.asarray(robot.Ia), np.asarray(robot.Fv), np.asarray(robot.Fc)], axis=1).ravel()
    return np.concatenate([np.asarray(robot.inertial, dtype=float).ravel(), drives, np.asarray(robot.offset)])


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x**2))) if x.size else 0.0


def _kind(kind: str, prismatic: bool) -> tuple[str, str]:
    """(units class, unit) of a standard parameter kind."""
    if kind in ("XX", "XY", "XZ", "YY", "YZ", "ZZ") or (kind == "Ia" and not prismatic):
        return "inertia", "kg m^2"
    if kind in ("MX", "MY", "MZ"):
        return "first moment", "kg m"
    if kind in ("M", "Ia"):
        return "mass", "kg"
    return kind, {"Fv": "N s/m" if prismatic else "N m s/rad"}.get(kind, "N" if prismatic else "N m")


def description_comparison(idim, robot) -> tuple[list, list]:
    """Each identified base parameter beside the value the description gives the same combination; `(rows, warnings)`.

    A parameter is compared when the description gives every term of its
    combination (a URDF has no motor inertia, friction or offset: a
    combination with one it lacks is not compared) and its described value
    matters: at least `MIN_NOMINAL_SHARE` of the largest described value of
    the same units, and a torque at least `MIN_TORQUE_SHARE` of the RMS torque
    of the joint it loads most. It differs when the ratio identified /
    described is beyond `MAX_DESCRIPTION_FACTOR` either way (or negative) and
    the estimate is well determined (standard deviation below `MAX_REL_STD` %
    of the larger of the two values: an estimate that collapses towards 0,
    the issue's carried mass at 0.5 % of the description's, is well
    determined when its standard deviation is small against the
    description's value). The warning names the likely cause: for a gravity
    parameter (its gravity column at least `GRAVITY_SHARE` of its whole
    column, RMS over the logs) found too small or of the opposite sign, a
    torque without the gravity load; too large, a load the description lacks
    or the torque scale; for an inertia, the torque or time scale (and, when
    a gravity load is missing, the bias it puts on the shared parameters).

    **Rows:** `{"name", "combination", "kind", "unit", "identified", "rel_std",
    "nominal", "ratio", "flag", "note"}` (`ratio` None and `flag` None when not
    compared; `flag` True when it differs).
    """
    model, res = idim.model, idim.result
    names = _names(robot)
    theta = np.asarray(res.theta, dtype=float)
    rel_std = np.asarray(res.rel_std, dtype=float)
    std = np.asarray(res.std, dtype=float)
    nominal = np.asarray(model.nominal, dtype=float)
    described = dict(zip(model.full_names, _full_theta(model.robot)))
    K, dep = np.asarray(model.base.combination), model.base.dependent
    G, _ = _blocks(model, logged_angles(idim))
    X, y, moving = np.asarray(idim.X), np.asarray(idim.y), np.asarray(idim.moving)
    rows_rms = [_rms(y[moving[:, i], i]) for i in range(len(model.rows))]
    kinds = []
    for i, name in enumerate(model.names):
        kind, j = _split(name)
        kinds.append(_kind(kind, _is_prismatic(robot, j)) if kind else ("other", ""))
    largest = {}
    for (cls, _), v in zip(kinds, nominal):
        largest[cls] = max(largest.get(cls, 0.0), abs(v))
    rows, flagged = [], {}
    for i, name in enumerate(model.names):
        cls, unit = kinds[i]
        terms = [name] + [dep[k] for k in np.flatnonzero(K[i])]
        lacks = [t for t in terms if _split(t)[0] in _DRIVE and described.get(t, 0.0) == 0.0]
        torque = [_rms(X[moving[:, r], r, i] * nominal[i]) / max(rows_rms[r], 1e-300) for r in range(len(model.rows))]
        ratio, flag, note = None, None, ""
        if lacks:
            note = f"not compared: the description gives no {', '.join(lacks)}"
        elif nominal[i] == 0.0:
            note = "not compared: the description's value is 0"
        elif abs(nominal[i]) < MIN_NOMINAL_SHARE * largest[cls]:
            note = "not compared: the description's value is negligible"
        elif max(torque) < MIN_TORQUE_SHARE:
            note = (
                f"not compared: with the description's value it moves the torques by {100 * max(torque):.2g} % on "
                f"this motion, below the {100 * MIN_TORQUE_SHARE:g} % a comparison needs (not determined by these data)"
            )
        else:
            ratio = float(theta[i] / nominal[i])
            differs = not (1 / MAX_DESCRIPTION_FACTOR <= ratio <= MAX_DESCRIPTION_FACTOR)
            spread = 100.0 * std[i] / max(abs(theta[i]), abs(nominal[i]))
            flag = bool(differs and spread < MAX_REL_STD)
            if differs and not flag:
                note = f"differs, but not well determined (standard deviation {spread:.3g} % of the larger value)"
        if flag:
            column = _rms(X[:, :, i][moving])
            gravity = column > 0 and _rms(G[:, :, i]) >= GRAVITY_SHARE * column
            if gravity:
                cause = "small gravity" if ratio < 1 / MAX_DESCRIPTION_FACTOR else "large gravity"
            else:
                cause = "inertia" if ratio > 0 else "negative inertia"
            flagged.setdefault(cause, []).append(
                f"{name} = {theta[i]:.3g} {unit}, {ratio:.3g} times the description's {nominal[i]:.3g}"
            )
        rows.append(
            {
                "name": name,
                "combination": model.base.names[i],
                "kind": cls,
                "unit": unit,
                "identified": float(theta[i]),
                "rel_std": float(rel_std[i]),
                "nominal": float(nominal[i]),
                "ratio": ratio,
                "flag": flag,
                "note": note,
            }
        )
    warnings = []
    lacking = _gravity_missing(idim, G, rows_rms, names)
    if lacking:
        items = flagged.pop("small gravity", [])
        warnings.append(
            f"the logged {lacking} may lack the gravity load (drives that compensate gravity or report only the "
            "dynamic part)"
            + (f"; base parameters that differ from the description's: {'; '.join(items)}" if items else "")
        )
    for cause, items in flagged.items():
        warnings.append(
            f"identified base parameters differ from the description's by more than a factor of "
            f"{MAX_DESCRIPTION_FACTOR:g} ({'; '.join(items)}): likely {_CAUSES[cause]}"
            + (", or they follow from the missing gravity load (previous warning)" if lacking else "")
        )
    return rows, warnings


_CAUSES = {
    "small gravity": "the description's masses or centres of mass, or a spring or counterweight it lacks",
    "large gravity": "a load the description lacks (a payload, cables) or the torque scale (the drives' torque "
    "constants and gear ratios, `drives`)",
    "inertia": "the torque scale (the drives' torque constants and gear ratios, `drives`) or the time scale (the "
    "logs' time column or `dt`)",
    "negative inertia": "a torque channel of the wrong sign (the drives' signs, `drives`)",
}


def _gravity_missing(idim, G, rows_rms, names) -> str:
    """The joints whose identified gravity torque is below 1 / `MAX_DESCRIPTION_FACTOR` of the description's, in words
    ("torque of joint 'a' (0.01 times the description's)", ...), or "" when none.

    Per joint: p = <g_nom, g_id> / <g_nom, g_nom> over the K configurations (linear in the estimates, its standard
    deviation from their covariance), for joints whose nominal gravity torque is at least `MIN_TORQUE_SHARE` of
    their RMS torque and p well determined (standard deviation below `MAX_REL_STD` % of max(|p|, 1))."""
    model, res = idim.model, idim.result
    theta, cov = np.asarray(res.theta, dtype=float), np.asarray(res.cov, dtype=float)
    out = []
    for i, j in enumerate(model.rows):
        g_nom = G[:, i, :] @ np.asarray(model.nominal, dtype=float)
        if not _rms(g_nom) >= MIN_TORQUE_SHARE * rows_rms[i]:
            continue
        a = G[:, i, :].T @ g_nom / (g_nom @ g_nom)
        p, sp = float(a @ theta), float(np.sqrt(max(a @ cov @ a, 0.0)))
        if p < 1 / MAX_DESCRIPTION_FACTOR and sp < MAX_REL_STD / 100 * max(abs(p), 1.0):
            force = "force" if _is_prismatic(model.robot, j) else "torque"
            out.append(f"{force} of joint '{names[j - 1]}' (its gravity {force} {p:.3g} times the description's)")
    return ", ".join(out)


def velocity_check(logs, inputs, *, robot=None) -> list:
    """Warnings where the logs' velocity (`logs.dq`, model convention) disagrees with the derivative of the position.

    Per joint, on the full-rate samples the preprocessing kept
    (`inputs[j - 1].dq_full`, the first `drop` samples and as many at the end
    left out): the least-squares scale s of dq_logged = s dq_derivative and
    the correlation; a warning when s is off 1 by more than
    `MAX_VELOCITY_SCALE` (naming the likely cause: 57.3, degrees; 1000,
    millimetres; a negative sign; a gear ratio, the motor side; else the time
    scale) or the correlation is below `MIN_VELOCITY_CORRELATION`. Nothing
    when the logs carry no velocity. `robot`: names the joints and which are
    prismatic.
    """
    dq = getattr(logs, "dq", None)
    if dq is None:
        return []
    dq = np.asarray(dq, dtype=float)
    out = []
    for col, j in enumerate(logs.joints):
        name = f"'{_names(robot)[j - 1]}'" if robot is not None else str(j)
        prismatic = robot is not None and _is_prismatic(robot, j)
        p = inputs[j - 1]
        est = np.asarray(p.dq_full, dtype=float)
        logged = dq[p.drop : p.drop + est.size, col]
        end = est.size - min(int(p.drop), est.size // 10)
        est, logged = est[:end], logged[:end]
        if not (np.any(est) and np.any(logged)):
            continue
        s = float(logged @ est / (est @ est))
        r = float(np.corrcoef(logged, est)[0, 1])
        what = f"the logged velocity of joint {name}"
        if not abs(r) >= MIN_VELOCITY_CORRELATION:
            out.append(
                f"{what} agrees poorly with the derivative of its logged position (correlation {r:.3g}, at least "
                f"{MIN_VELOCITY_CORRELATION:g}): the velocity of another joint, a delay or noise; check the velocity "
                "column"
            )
            continue
        if abs(s - 1.0) <= MAX_VELOCITY_SCALE:
            continue
        unit, factor = ("mm/s", 1e3) if prismatic else ("degrees/s", 180 / math.pi)
        if abs(s / factor - 1.0) <= MAX_VELOCITY_SCALE:
            cause = f"it is in {unit}, not {'m/s' if prismatic else 'rad/s'}"
        elif s < 0:
            cause = "it has the opposite sign (the drives' signs, `drives`)"
        elif s > 2.0:
            cause = f"it is on the motor side (a gear ratio of about {s:.3g}; the drives' ratios, `drives`)"
        else:
            cause = "the time scale differs (the logs' time column or `dt`) or the velocity's units"
        out.append(f"{what} is {s:.3g} times the derivative of its logged position (correlation {r:.3g}): {cause}")
    return out
