"""Each robot joint's friction law (issue 45 item 4 for robots): proposed by BIC on the joint's partial residual,
evaluated through the decimation filter, kept only where it lowers the joint's held-out error, estimated jointly
with the rigid body."""

import jax
import numpy as np
import pytest

from helpers import two_link_arm
from jaxsdp import Butterworth, Preprocessing
from jaxsdp._records import JointLogs
from jaxsdp.plants import simulate_robot
from jaxsdp.plants.robot import robot_idim_ls, robot_model
from jaxsdp.plants.robot._friction import MIN_GAIN, robot_friction

FS, FC2, VS = 0.6, 0.5, 0.2  # joint 2's static friction above its Coulomb level (N m) and Stribeck speed (rad/s)


@pytest.fixture(scope="module")
def fitted():
    """A two-link arm whose joint 1 has viscous + Coulomb friction and joint 2 Stribeck's law: the logged torques
    are the inverse dynamics of the simulated motion plus joint 2's Stribeck excess, with 1 % noise."""
    robot = two_link_arm(Fc=FC2)
    dt = 1e-3
    t = np.arange(8000) * dt
    ramp = (1 - np.exp(-2 * t))[:, None]
    q1 = 0.8 * np.sin(2 * np.pi * 0.5 * t) + 0.3 * np.sin(2 * np.pi * 1.3 * t)
    q2 = 0.6 * np.sin(2 * np.pi * 0.7 * t + 0.4) + 0.3 * np.sin(2 * np.pi * 1.9 * t)
    sim = simulate_robot(robot, ramp * np.stack([q1, q2], axis=1), dt=dt)
    tau = np.array(jax.vmap(robot.drive_torques)(sim.q, sim.dq, sim.ddq))
    v2 = np.asarray(sim.dq[:, 1])
    tau[:, 1] += FS * np.sign(v2) * np.exp(-((v2 / VS) ** 2))
    tau += 0.01 * tau.std(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    logs = JointLogs(q=np.asarray(sim.q), tau=tau, t=t, dt=dt, joints=(1, 2), source="simulated", converted="none")
    res = robot_idim_ls(logs, robot_model(robot), preprocessing=Preprocessing(Butterworth(40.0), drop=100, decimate=2))
    return res, robot_friction(res), logs, robot


def test_stribeck_joint_found_and_linear_joint_kept(fitted):
    res, out, _, _ = fitted
    assert out.chosen == {1: "ViscousCoulomb", 2: "Stribeck"}
    # joint 1's proposal (the filter's smear at reversals) did not lower its held-out error by MIN_GAIN: reverted
    assert out.proposed[1] != "ViscousCoulomb" and out.reverted == (1,)
    values = dict(zip(out.names, np.asarray(out.theta)))
    assert abs(values["Fc2"] - FC2) < 0.05 * FC2 and abs(values["Fv2"] - 1.0) < 0.02
    assert values["Fs2"] > FC2 + 0.5 * FS and 0.5 * VS < values["vs2"] < 2 * VS  # the hump, smeared by the filter
    assert out.converged


def test_every_law_kept_lowers_its_joint_held_out_error_or_is_linear(fitted):
    res, out, _, _ = fitted
    for k, law in out.chosen.items():
        cv = out.cross_validated[k]
        assert law == "ViscousCoulomb" or cv["chosen"] <= (1 - MIN_GAIN) * cv["linear"], (k, law, cv)
    assert out.cross_validated[2]["chosen"] < 0.8 * out.cross_validated[2]["linear"]
    # the linear model is IDIM-LS's own: its in-sample errors are the study's
    for j, e in res.relative_error.items():
        np.testing.assert_allclose(out.relative_error[j]["linear"], e, rtol=1e-6)


def test_candidates_and_summary(fitted):
    _, out, _, _ = fitted
    s = out.summary()
    assert set(s["motors"]) == {"motor_1", "motor_2"}
    m2 = s["motors"]["motor_2"]
    assert m2["chosen"] == "Stribeck" and set(m2["parameters"]) == {"Fv2", "Fc2", "Fs2", "vs2"}
    bic = {law: c["bic"] for law, c in m2["candidates"].items()}
    assert min(bic, key=bic.get) == "Stribeck"
    assert s["joints"]["joint_2"]["cross_validated"]["chosen"] < s["joints"]["joint_2"]["cross_validated"]["linear"]


def test_options_checked(fitted):
    res, _, _, _ = fitted
    with pytest.raises(ValueError, match="`folds`"):
        robot_friction(res, folds=1)
    with pytest.raises(ValueError, match="`min_gain`"):
        robot_friction(res, min_gain=1.5)
    with pytest.raises(ValueError, match="`laws`"):
        robot_friction(res, laws=())
    with pytest.raises(ValueError, match="RobotIDIM"):
        robot_friction(object())


def test_robot_study_friction_stage(fitted):
    """`robot_study(friction=...)`: the same laws as `robot_friction` on the same rows, in the findings, report.md
    and summary.json (joints by name); refused when not a law."""
    from jaxsdp.plants._friction_laws import LAWS
    from jaxsdp.plants.robot import RobotProcessing
    from jaxsdp.studies.robot import robot_study

    _, out, logs, robot = fitted
    processing = RobotProcessing(cutoff_hz=40.0, decimate=2, drop=100)
    s = robot_study(logs, robot=robot, processing=processing, friction=LAWS, physical=False, folds=0)
    assert s.friction.chosen == out.chosen and s.friction.names == out.names
    np.testing.assert_allclose(np.asarray(s.friction.theta), np.asarray(out.theta), rtol=1e-6)
    assert "friction" in s.timings and s.settings["friction"] == [type(law).__name__ for law in LAWS]
    summary = s.summary()["friction"]
    assert summary["motors"]["joint2"]["chosen"] == "Stribeck" and summary["reverted"] == ["joint1"]
    assert any(f.startswith("Friction laws") and "joint2 Stribeck" in f for f in s.findings)
    section = s.report().split("## Friction laws")[1]
    assert "Proposals reverted to viscous + Coulomb: joint1" in section and "Stribeck speed" in section
    with pytest.raises(ValueError, match="`friction` must be"):
        robot_study(logs, robot=robot, friction="auto")
