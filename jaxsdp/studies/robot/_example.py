"""A robot study on simulated data, computed once per process, for the examples in the docstrings."""

import functools

from ..._runtime import x64


def example_motion(t):
    """Two joints' angles (rad), rates and accelerations at the instants `t` (s), each (N, 2): two sines per
    joint, 0.8 rad at 0.23/0.31 Hz and 0.3 rad at 1.07/0.83 Hz."""
    import numpy as np

    w = 2 * np.pi * np.array([[0.23, 0.31], [1.07, 0.83]])
    s = [np.sin(w[i] * t[:, None]) for i in range(2)]
    c = [np.cos(w[i] * t[:, None]) for i in range(2)]
    q = 0.8 * s[0] + 0.3 * s[1]
    dq = 0.8 * w[0] * c[0] + 0.3 * w[1] * c[1]
    ddq = -0.8 * w[0] ** 2 * s[0] - 0.3 * w[1] ** 2 * s[1]
    return q, dq, ddq


@x64
@functools.lru_cache(maxsize=1)
def example_study():
    """`robot_study` on a simulated two-joint planar arm (modified DH, white torque noise 2 N m), cached.

    Example:
        >>> from jaxsdp.studies.robot import example_study
        >>> example_study().idim.model.rank > 0
        True
    """
    import jax.numpy as jnp
    import numpy as np

    from ...data._joint_logs import JointLogs
    from ...plants.robot._serial import SerialRobot
    from ._study import robot_study

    arm = SerialRobot.from_mdh(
        [[0.0, 0.0, 0.0, 0.0], [0.0, 0.4, 0.0, 0.0]],
        inertias=[
            (3.0, [0.2, 0.0, 0.0], [0.01, 0, 0, 0.02, 0, 0.02]),
            (1.5, [0.15, 0.01, 0.0], [0.005, 0, 0, 0.01, 0, 0.01]),
        ],
        Ia=0.1,
        Fv=[2.0, 1.0],
        Fc=[1.5, 0.8],
        offset=[0.3, -0.2],
    )
    dt = 1e-3
    t = np.arange(0.0, 20.0, dt)
    q, dq, ddq = example_motion(t)
    noise = 2.0 * np.random.default_rng(0).standard_normal(q.shape)  # N m, white
    tau = np.asarray(arm.drive_torques(q, dq, ddq)) + noise
    logs = JointLogs(
        q=jnp.asarray(q),
        tau=jnp.asarray(tau),
        t=jnp.asarray(t),
        dt=dt,
        joints=(1, 2),
        source="simulated arm",
        converted="none",
    )
    return robot_study(logs, robot=arm, sdp=True)  # the processing that suits 1 kHz logs
