"""Issue 42, items 4 and 6: prismatic joints in N, m and m/s, the whole record's error, cross-validation, time axis."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxsdp.data import JointLogs
from jaxsdp.plants import SerialRobot
from jaxsdp.plants.robot import RobotProcessing
from jaxsdp.plants.robot._robot_idim import robot_idim_ls
from jaxsdp.plants.robot._stacked import robot_model
from jaxsdp.plants.robot._validation import joint_units, robot_cross_validation
from jaxsdp.studies.robot import robot_study
from jaxsdp.studies.robot._figures import robot_figures
from jaxsdp.studies.robot._report import report_markdown, study_summary, text_output

jax.config.update("jax_enable_x64", True)

DT, T0, DROP, DECIMATE = 1e-3, 3.0, 100, 10


def _arm() -> SerialRobot:
    """Three joints: a revolute base about the vertical, a prismatic joint along the vertical (gravity loads it), a
    revolute joint about a horizontal axis."""
    return SerialRobot.from_mdh(
        [[0.0, 0.0, 0.0, 0.0], [0.0, 0.2, 0.0, 0.3], [np.pi / 2, 0.0, 0.0, 0.0]],
        inertias=[
            (4.0, [0.1, 0.0, 0.0], [0.02, 0, 0, 0.03, 0, 0.03]),
            (2.0, [0.0, 0.05, 0.0], [0.01, 0, 0, 0.01, 0, 0.01]),
            (1.0, [0.2, 0.0, 0.0], [0.002, 0, 0, 0.005, 0, 0.005]),
        ],
        Ia=[0.1, 0.5, 0.05],
        Fv=[2.0, 8.0, 0.5],
        Fc=[1.0, 3.0, 0.4],
        offset=[0.2, -1.0, 0.1],
        prismatic=[False, True, False],
    )


def _logs(arm, *, seconds=12.0, rest_until=0.0, seed=0) -> JointLogs:
    """Multi-sine motion (rad, m) of the arm at 1 kHz from T0 s, joint 3 held at rest before `rest_until` (share
    of the record), torques by `drive_torques` plus white noise of 1 % of each joint's RMS torque."""
    t = np.arange(0.0, seconds, DT)
    f = np.array([[0.21, 0.29, 0.37], [0.83, 1.13, 0.97]])
    amp = np.array([[0.8, 0.08, 0.9], [0.3, 0.03, 0.4]])
    q = sum(amp[k] * np.sin(2 * np.pi * f[k] * t[:, None] + k) for k in range(2))
    if rest_until:
        a, b = rest_until * seconds, rest_until * seconds + 1.0
        x = np.clip((t - a) / (b - a), 0.0, 1.0)
        window = x**3 * (10 - 15 * x + 6 * x**2)  # C2 from rest
        q[:, 2] = window * q[:, 2]
    dq = np.gradient(q, DT, axis=0)
    ddq = np.gradient(dq, DT, axis=0)
    tau = np.asarray(arm.drive_torques(q, dq, ddq))
    noise = np.random.default_rng(seed).standard_normal(tau.shape) * 0.01 * np.sqrt(np.mean(tau**2, axis=0))
    return JointLogs(
        q=jnp.asarray(q),
        tau=jnp.asarray(tau + noise),
        t=jnp.asarray(T0 + t),
        dt=DT,
        joints=(1, 2, 3),
        source="simulated arm with a prismatic joint",
        converted="none",
    )


PRE = dict(cutoff_hz=40.0, decimate=DECIMATE, drop=DROP)


@pytest.fixture(scope="module")
def arm():
    return _arm()


@pytest.fixture(scope="module")
def moving_idim(arm):
    """Every joint in motion over the whole record."""
    return robot_idim_ls(_logs(arm), robot_model(arm), preprocessing=PRE)


@pytest.fixture(scope="module")
def resting_study(arm):
    """Joint 3 at rest over the first 55 % of the record."""
    logs = _logs(arm, rest_until=0.55, seed=1)
    return robot_study(logs, robot=arm, sdp=False, folds=0, processing=RobotProcessing(**PRE))


class _With:
    """A study with extra attributes (the `validation` and `verdicts` the lead adds to RobotStudy)."""

    def __init__(self, study, **extra):
        self._study, self._extra = study, extra

    def __getattr__(self, name):
        return self._extra[name] if name in self._extra else getattr(self._study, name)


def test_relative_error_all(moving_idim, resting_study):
    for idim in (moving_idim, resting_study.idim):
        y, fit, whole = np.asarray(idim.y), np.asarray(idim.fit), np.asarray(idim.record_fit)
        moving = np.asarray(idim.moving)
        rec = slice(0, y.shape[0] - idim.tail)
        assert idim.tail == -(-DROP // DECIMATE) and not moving[rec.stop :].any()
        for i, j in enumerate(idim.model.rows):
            want = 100 * np.linalg.norm(y[rec, i] - whole[rec, i]) / np.linalg.norm(y[rec, i])
            assert idim.relative_error_all[j] == pytest.approx(want, rel=1e-12)
            # in motion the record's fit is the fit; at rest the joint's Coulomb term is off
            np.testing.assert_allclose(whole[moving[:, i], i], fit[moving[:, i], i], rtol=1e-12)
            rest = ~moving[rec, i]
            fc = float(idim.result[f"Fc{j}"]) * np.asarray(idim.X)[rec, i, idim.model.names.index(f"Fc{j}")]
            np.testing.assert_allclose(whole[rec, i][rest], (fit[rec, i] - fc)[rest], rtol=1e-10, atol=1e-12)
    # the rows at rest count: the reversals, where the simulation's Coulomb friction switches at once while the
    # record's fit passes through 0, and joint 3's first half at rest (with the Coulomb term there, whose sign(dq)
    # is the sign of round-off, 12 %); the whole record's error stays near the noise's
    assert resting_study.idim.samples[3] < 0.5 * resting_study.idim.samples[1]
    for idim in (moving_idim, resting_study.idim):
        for j, v in idim.relative_error.items():
            assert v < 1.0 and v < idim.relative_error_all[j] < 3.0, j


def test_cross_validation_noise_only(moving_idim):
    for folds in (2, 3):
        cv = robot_cross_validation(moving_idim, folds=folds)
        assert cv["fitted"] == folds and all(f["reason"] is None for f in cv["folds"])
        assert [f["rows"][0] for f in cv["folds"]][0] == 0 and cv["folds"][-1]["rows"][1] == moving_idim.y.shape[0] - 10
        for j, v in cv["relative_error"].items():
            # a correct model with white noise: predicting unseen rows costs little more than fitting them
            assert cv["in_sample"][j] <= v < 1.25 * cv["in_sample"][j], (folds, j)
        assert cv["stacked_in_sample"] <= cv["stacked_relative_error"] < 1.25 * cv["stacked_in_sample"]
        json.dumps(cv)
    with pytest.raises(ValueError, match="folds"):
        robot_cross_validation(moving_idim, folds=1)


def test_cross_validation_rank_deficient_fold(resting_study):
    cv = robot_cross_validation(resting_study.idim, folds=2)
    first, second = cv["folds"]
    # fitted on the first half, where joint 3 rests: its friction and offset are not identified
    assert second["relative_error"] is None and second["stacked_relative_error"] is None
    assert second["reason"].startswith("rank deficient") and "Fv3" in second["reason"]
    assert "use fewer folds" in second["reason"]
    assert first["reason"] is None and first["samples"][3] == 0 and first["relative_error"][3] is None
    assert cv["fitted"] == 1 and cv["relative_error"][3] is None and cv["relative_error"][1] is not None
    assert first["time"][0] == pytest.approx(float(resting_study.idim.t[0]))


def test_joint_units(arm):
    assert joint_units(arm, 2) == {"effort": "N", "position": "m", "velocity": "m/s", "acceleration": "m/s^2"}
    assert joint_units(arm, 1)["effort"] == "N m" and joint_units(arm, 3)["velocity"] == "rad/s"
    with pytest.raises(ValueError, match="joint"):
        joint_units(arm, 4)


def test_units_in_outputs(resting_study):
    s = resting_study
    out = study_summary(s)
    assert out["joints"]["joint2"]["units"] == {
        "effort": "N",
        "position": "m",
        "velocity": "m/s",
        "acceleration": "m/s^2",
    }
    assert out["joints"]["joint1"]["units"]["effort"] == "N m"
    assert out["joints"]["joint2"]["min_speed"] == pytest.approx(s.idim.min_speed[2])
    assert out["joints"]["joint3"]["relative_error_all"] == pytest.approx(s.idim.relative_error_all[3])
    assert out["cross_validation"] is None and out["joints"]["joint1"]["identifiable"] is True
    json.dumps(out)
    for page in (text_output(s), report_markdown(s)):
        line2 = next(ln for ln in page.splitlines() if "joint2" in ln and "%" in ln)
        assert " N " in line2 and "m/s" in line2 and "rad/s" not in line2 and "N m" not in line2
        line1 = next(ln for ln in page.splitlines() if "joint1" in ln and "%" in ln)
        assert "N m" in line1 and "rad/s" in line1
        assert "whole record" in page and "Cross-validation" not in page
    rest = next(ln for ln in report_markdown(s).splitlines() if ln.startswith("- At rest"))
    assert f"joint2 {s.idim.min_speed[2]:.3g} m/s" in rest and f"joint1 {s.idim.min_speed[1]:.3g} rad/s" in rest


def test_cross_validation_and_verdicts_in_outputs(resting_study):
    cv = robot_cross_validation(resting_study.idim, folds=2)
    s = _With(resting_study, validation=cv, verdicts={3: (False, "barely moves"), 1: (True, "")})
    out = study_summary(s)
    got = out["cross_validation"]
    assert set(got["relative_error"]) == {"joint1", "joint2", "joint3"} and got["relative_error"]["joint3"] is None
    assert got["folds"][1]["relative_error"] is None and got["folds"][1]["reason"].startswith("rank deficient")
    assert out["joints"]["joint3"]["identifiable"] is False and out["joints"]["joint3"]["reason"] == "barely moves"
    json.dumps(out)
    md = report_markdown(s)
    assert "## Cross-validation" in md and "Block 2 not fitted: rank deficient" in md
    assert "no: barely moves" in md and "Cross-validation (2 blocks" in text_output(s)
    fig = robot_figures(s)["joints"]
    titles = [ax.get_title(loc="left") for ax in fig.axes if ax.get_visible()]
    assert titles[2].startswith("joint3: not identifiable: barely moves") and "not identifiable" not in titles[0]


def test_verdict_sentences_and_joint_left_out(resting_study):
    """Reasons as sentences (a `JointVerdict`-like pair), and a judged joint the fit left out (as if its rows were
    dropped before the LS): listed with its units and verdict, no numbers."""
    i = resting_study.idim
    fitted = _With(i, relative_error={j: i.relative_error[j] for j in (1, 2)})
    long = "joint3's torque channel is exact zeros in 97 % of the samples (at most 50 %): its drive logs nothing"
    s = _With(resting_study, idim=fitted, verdicts={3: (False, (long, "second reason.")), 1: (True, ())})
    out = study_summary(s)
    assert list(out["joints"]) == ["joint1", "joint2", "joint3"]
    j3 = out["joints"]["joint3"]
    assert j3["identifiable"] is False and j3["reason"] == f"{long}; second reason."
    assert j3["relative_error"] is None and j3["units"]["effort"] == "N m" and out["joints"]["joint1"]["identifiable"]
    json.dumps(out)
    row = next(ln for ln in report_markdown(s).splitlines() if ln.startswith("| joint3"))
    assert "not fitted" in row and "no: joint3's torque channel" in row
    titles = [ax.get_title(loc="left") for ax in robot_figures(s)["joints"].axes if ax.get_visible()]
    assert len(titles) == 2
    s2 = _With(resting_study, verdicts={3: (False, (long, "second reason."))})
    title = [ax.get_title(loc="left") for ax in robot_figures(s2)["joints"].axes if ax.get_visible()][2]
    assert title.startswith("joint3: not identifiable: joint3's torque") and "..." in title and "second" not in title


def test_figures_units_and_time_axis(resting_study):
    s = resting_study
    fig = robot_figures(s)["joints"]
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_ylabel() for ax in axes] == ["torque (N m)", "force (N)", "torque (N m)"]
    for ax in axes:
        lines = {ln.get_label(): ln for ln in ax.get_lines()}
        t = np.asarray(lines["measured"].get_xdata())
        # the log's time: its first sample T0, plus the dropped samples, within one decimated step
        assert T0 + DROP * DT <= t[0] < T0 + (DROP + DECIMATE) * DT
        assert np.diff(t) == pytest.approx(DECIMATE * DT)
        # the measured trace is drawn after (on top of) the fit, thinner
        order = [ln.get_label() for ln in ax.get_lines()]
        assert order.index("measured") > order.index("full model")
        assert lines["measured"].get_linewidth() < lines["full model"].get_linewidth()
