"""A robot study on simulated data, computed once per process, for the examples in the docstrings."""

import functools


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
    w = 2 * np.pi * np.array([[0.23, 0.31], [1.07, 0.83]])
    q = np.stack([0.8 * np.sin(w[0, k] * t) + 0.3 * np.sin(w[1, k] * t) for k in range(2)], axis=1)
    dq = np.stack([0.8 * w[0, k] * np.cos(w[0, k] * t) + 0.3 * w[1, k] * np.cos(w[1, k] * t) for k in range(2)], 1)
    ddq = np.stack(
        [-0.8 * w[0, k] ** 2 * np.sin(w[0, k] * t) - 0.3 * w[1, k] ** 2 * np.sin(w[1, k] * t) for k in range(2)], 1
    )
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
    return robot_study(logs, robot=arm, decimate=10, drop=100, sdp=True)
