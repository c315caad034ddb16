"""Which joints move in a set of joint logs (the experiment the logs come from).

The paper identifies link 2 in two experiments: only link 2 moving (its
Table 4) and all six joints moving (Table 5, where the neglected coupling
of the moving links shows in the SDP curves). `joint_motion` tells them
apart from the logs: a joint moves when its angle spans at least
`MOVING_RANGE` after a zero-phase low-pass filter (which removes the
encoder and controller jitter of a joint held in place).
"""

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
