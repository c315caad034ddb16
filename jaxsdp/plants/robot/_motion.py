"""Which joints move in a set of joint logs (the experiment the logs come from).

The paper identifies link 2 in two experiments: only link 2 moving (its
Table 4) and all six joints moving (Table 5, where the neglected coupling
of the moving links shows in the SDP curves). `joint_motion` tells them
apart from the logs: a joint moves when its angle spans at least
`MOVING_RANGE` after a zero-phase low-pass filter (which removes the
encoder and controller jitter of a joint held in place).
"""

import math

import numpy as np

from ..._records import JointLogs
from ..._runtime import x64

#: A joint whose low-passed angle spans less than this (rad, about 3 degrees) is held, not moving.
MOVING_RANGE = 0.05
#: Cut-off (Hz) of the zero-phase Butterworth applied before the range and speed are measured.
MOTION_CUTOFF_HZ = 20.0


@x64
def joint_motion(logs: JointLogs, *, min_range: float = MOVING_RANGE, cutoff_hz: float = MOTION_CUTOFF_HZ) -> dict:
    """Range and rms speed of every joint of `logs`, and whether it moves.

    Each joint-side angle is low-passed (Butterworth order 4 at `cutoff_hz`,
    zero phase; none when the record is too short or the cut-off is above
    Nyquist), then `range` = max - min (rad) and `rms_speed` = the rms of its
    central-difference derivative (rad/s); the joint `moves` when
    range >= `min_range` (rad).

    **Returns:** `{joint: {"range": rad, "rms_speed": rad/s, "moves": bool}}`
    in the logs' joint order.

    Example:
        >>> from jaxsdp.data import tx40_builtin_data
        >>> from jaxsdp.plants.robot import joint_motion
        >>> [j for j, m in joint_motion(tx40_builtin_data().logs).items() if m["moves"]]  # only link 2 moves
        [2]
    """
    if not isinstance(logs, JointLogs):
        raise ValueError(f"`logs` must be a JointLogs (jaxsdp.data.load_joint_logs); got {type(logs).__name__}")
    if not (np.isfinite(min_range) and min_range > 0):
        raise ValueError(f"`min_range` must be a positive angle (rad); got {min_range!r}")
    import scipy.signal

    dt = float(logs.dt)
    q = np.asarray(logs.q, dtype=float)
    wn = 2.0 * cutoff_hz * dt
    if 0 < wn < 1 and q.shape[0] > 30:
        b, a = scipy.signal.butter(4, wn)
        q = scipy.signal.filtfilt(b, a, q, axis=0)
    speed = np.gradient(q, dt, axis=0)
    out = {}
    for col, joint in enumerate(logs.joints):
        rng = float(np.ptp(q[:, col]))
        out[int(joint)] = {
            "range": rng,
            "rms_speed": float(np.sqrt(np.mean(speed[:, col] ** 2))),
            "moves": bool(rng >= min_range),
        }
    return out


def moving_joints(motion: dict) -> list[int]:
    """The joints of a `joint_motion` result that move."""
    return [j for j, m in motion.items() if m["moves"]]


#: The dropped ends end where the filter's start-up in the acceleration falls below this share of the motion's
#: rms acceleration (`edge_transient`; the robot study's dropped ends).
EDGE_TOL = 1e-2


def joint_angles(q) -> np.ndarray:
    """`q` (N,) or (N, joints) as a float (N, joints) array, checked finite."""
    q = np.asarray(q, dtype=float)
    if q.ndim == 1:
        q = q[:, None]
    if q.ndim != 2 or q.shape[0] < 2:
        raise ValueError(f"`q` must be (N,) or (N, joints) joint positions; got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError("`q` contains NaN or inf")
    return q


def edge_transient(fs: float, q, cutoff_hz: float) -> float:
    r"""The size of the zero-phase filter's start-up in the acceleration, over the motion's rms acceleration.

    At each end of each moving joint, the velocity $v$ and acceleration $a$ at the end sample of a cubic fitted by least
    squares to the first (last) $4 f_s / f_c$ samples (the part beyond two standard errors: encoder steps are not a
    motion); MATLAB's `filtfilt` padding starts the filter from
    the steady state of the end sample, a velocity step $v$ whose transient in the acceleration starts near
    $2 \pi f_c |v|$, and the odd reflection flips the acceleration, a step $2 |a|$. Returns
    $\max (2 \pi f_c |v|, 2 |a|) / \mathrm{rms}(\ddot q)$ over the joints and ends ($\ddot q$ of the
    angle low-passed at `cutoff_hz`, over the middle half); 0 when no joint moves. `q` (N, joints) rad or m.
    """
    import scipy.linalg
    import scipy.signal

    qa = joint_angles(q)
    n = qa.shape[0]
    m = max(8, min(n // 4, math.ceil(4.0 * fs / cutoff_hz)))
    wn = 2.0 * cutoff_hz / fs
    if not (0 < wn < 1) or n < 4 * m:
        return 0.0
    dt = 1.0 / fs
    ddq = np.gradient(
        np.gradient(scipy.signal.filtfilt(*scipy.signal.butter(4, wn), qa, axis=0), dt, axis=0), dt, axis=0
    )
    rms = np.sqrt(np.mean(ddq[n // 4 : n - n // 4] ** 2, axis=0))
    span = m * dt
    u = np.arange(m) / m  # time over the window's span: a well-conditioned basis
    Q, R = np.linalg.qr(np.stack([np.ones(m), u, u**2, u**3], axis=1))
    Rinv_t = scipy.linalg.solve_triangular(R, np.eye(4), trans="T")  # rows: the coefficients' sensitivities
    worst = 0.0
    for joint in range(qa.shape[1]):
        if not rms[joint] > 0 or np.ptp(qa[:, joint]) <= MOVING_RANGE:
            continue
        for end in (qa[:m, joint], qa[::-1][:m, joint]):  # the last end read backwards: the same fit
            c = scipy.linalg.solve_triangular(R, Q.T @ end)
            s = np.sqrt(np.sum((end - Q @ (Q.T @ end)) ** 2) / (m - 4))
            se = s * np.linalg.norm(Rinv_t, axis=1)
            # the significant part only (beyond 2 standard errors): an encoder's steps are not a motion
            v = max(abs(c[1]) - 2 * se[1], 0.0) / span
            a = max(abs(2 * c[2]) - 4 * se[2], 0.0) / span**2
            worst = max(worst, float(max(2 * np.pi * cutoff_hz * v, 2 * a) / rms[joint]))
    return worst
