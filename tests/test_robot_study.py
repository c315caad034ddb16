"""`jaxsdp robot` (issue 31, item 6): any robot from its URDF and joint logs, all joints at once."""

import json

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import ARM_URDF, TX40_CURRENTS, TX40_POSITIONS, TX40_URDF, requires_tx40, requires_tx40_urdf
from jaxsdp._cli import main
from jaxsdp.data import IrregularSamplingError, load_joint_logs
from jaxsdp.plants import SerialRobot
from jaxsdp.studies.robot import RobotStudy, example_study, figures, report, summary, text
from jaxsdp.studies.robot._example import example_motion

jax.config.update("jax_enable_x64", True)


def test_example_study_contract():
    s = example_study()
    assert isinstance(s, RobotStudy)
    out = summary(s)
    assert set(out["joints"]) == {"joint1", "joint2"}
    assert {"relative_error", "sdp_relative_error", "whiteness"} <= set(out["joints"]["joint1"])
    assert out["rank"] == len(out["base_parameters"]) and out["condition_number"] > 0
    assert {"name", "value", "rel_std", "combination", "nominal"} <= set(out["base_parameters"][0])
    # a parametric truth with white noise: the curves follow the parametric shapes, no false finding
    assert not any(j["shape_mismatch"] for j in out["joints"].values())
    assert report(s).startswith("# Robot study") and "Stacked" in text(s)
    assert list(figures(s)) == ["joints", "sdp_curves"]
    json.dumps(out)


@requires_tx40
@requires_tx40_urdf
def test_cli_robot_tx40_six_joints(tmp_path):
    out = tmp_path / "robot"
    argv = ["robot", "--urdf", str(TX40_URDF), "--drives", "tx40", "--positions", str(TX40_POSITIONS)]
    argv += ["--torques", str(TX40_CURRENTS), "--dt", "2e-4", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    s = json.loads((out / "summary.json").read_text())
    assert list(s["joints"]) == [f"joint_{j}" for j in range(1, 7)]
    toolbox = [12.5, 14.2, 21.8, 18.3, 21.3, 21.8]
    for (name, j), limit in zip(s["joints"].items(), toolbox):
        assert j["relative_error"] < limit, (name, j["relative_error"])
        assert j["sdp_relative_error"] < j["relative_error"], name
    assert s["stacked_relative_error"] < 14.6 and s["rank"] == 58
    # issue 42: no joint flagged, the whole record (rows at rest included) also below the toolbox's figures
    for (name, j), limit in zip(s["joints"].items(), toolbox):
        assert j["identifiable"] is True and j["reason"] is None, (name, j["reason"])
        assert j["relative_error_all"] < limit, (name, j["relative_error_all"])
    assert not [w for w in s["warnings"] if "serially correlated" not in w], s["warnings"]
    assert s["cross_validation"]["fitted"] == 2 and s["settings"]["reasons"]["cutoff_hz"]
    # the scales agree with the URDF (test_plausibility.py: no false alarm on real logs)
    assert s["plausible"] and all(r["passed"] is not False for r in s["scale_checks"]), s["scale_checks"]
    assert (out / "joints.png").exists() and (out / "sdp_curves.png").exists()


def test_cli_robot_errors(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<notarobot/>")
    csv = tmp_path / "x.csv"
    csv.write_text("Joint_1\n" + "\n".join(str(0.01 * k) for k in range(20)) + "\n")
    argv = ["robot", "--urdf", str(bad), "--positions", str(csv), "--torques", str(csv), "--dt", "1e-3"]
    assert main([*argv, "--out", str(tmp_path / "o")]) == 1
    assert main(["robot", "--positions", str(csv)]) == 2  # --urdf is required: a usage error


def _two_link_files(tmp_path, *, jitter=False):
    """A two-link arm's URDF and joint-side logs (20 s at 1 kHz, white torque noise) with a time column starting
    at 1 s (and every sample from the 200th one period late when `jitter`: a gap, which the default
    irregular="jitter" refuses; steps within 0.5-1.5 dt are stamping jitter, resampled: test_joint_log_names.py)."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM_URDF)
    arm = SerialRobot.from_urdf(urdf)
    arm = eqx.tree_at(lambda r: (r.Ia, r.Fv, r.Fc), arm, (jnp.full(2, 0.1), jnp.array([2.0, 1.0]), jnp.ones(2)))
    dt = 1e-3
    t = np.arange(0.0, 20.0, dt)
    q, dq, ddq = example_motion(t)
    tau = np.asarray(arm.drive_torques(q, dq, ddq)) + 0.5 * np.random.default_rng(0).standard_normal(q.shape)
    stamps = t + 1.0
    if jitter:
        stamps[200:] += dt
    head = "Joint_1,Joint_2"
    pos, trq = tmp_path / "q.csv", tmp_path / "tau.csv"
    np.savetxt(pos, np.column_stack([stamps, q]), delimiter=",", header="time," + head, comments="", fmt="%.12g")
    np.savetxt(trq, tau, delimiter=",", header=head, comments="")
    return urdf, pos, trq, (q, dt)


def test_joint_logs_time_column(tmp_path):
    _, pos, trq, (q, dt) = _two_link_files(tmp_path)
    got = load_joint_logs(pos, trq)
    assert got.dt == pytest.approx(dt, rel=1e-9) and float(got.t[0]) == pytest.approx(1.0)
    np.testing.assert_allclose(np.asarray(got.q), q, rtol=1e-10, atol=1e-12)
    assert got.resampled is None and load_joint_logs(pos, trq, dt=dt).dt == pytest.approx(dt, rel=1e-9)
    with pytest.raises(ValueError, match="steps by"):
        load_joint_logs(pos, trq, dt=2 * dt)
    jit_dir = tmp_path / "jit"
    jit_dir.mkdir()
    _, pos2, trq2, _ = _two_link_files(jit_dir, jitter=True)
    with pytest.raises(IrregularSamplingError, match="sample 200"):
        load_joint_logs(pos2, trq2)
    res = load_joint_logs(pos2, trq2, irregular="resample")
    assert res.resampled.startswith("resampled") and abs(res.q.shape[0] - q.shape[0]) <= 1


def test_cli_robot_time_column_and_resample(tmp_path, capsys):
    jit_dir = tmp_path / "jit"
    jit_dir.mkdir()
    urdf, pos, trq, _ = _two_link_files(jit_dir, jitter=True)
    argv = ["robot", "--urdf", str(urdf), "--positions", str(pos), "--torques", str(trq), "--quiet"]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 1
    assert "pass --resample" in capsys.readouterr().err
    assert main([*argv, "--resample", "--no-sdp", "--out", str(tmp_path / "b")]) == 0
    s = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert s["data"]["resampled"].startswith("resampled") and s["data"]["sample_time"] > 0


def test_cli_robot_excite(tmp_path):
    urdf, *_ = _two_link_files(tmp_path)
    out = tmp_path / "ex"
    argv = ["robot", "--urdf", str(urdf), "--excite", "--harmonics", "3", "--f0", "0.2", "--max-steps", "30"]
    assert main([*argv, "--out", str(out), "--quiet"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["condition_number"] < s["condition_number_start"]
    assert {"q0", "a", "b", "range", "peak_velocity", "peak_acceleration"} <= set(s["trajectory"]["joints"]["joint1"])
    # the simulated robot is identified on it: every base parameter within 4 std or below 0.2 % of the torques
    assert s["recovery"] and all(abs(r["z"]) < 4 or r["torque_share"] < 0.2 for r in s["recovery"])
    traj = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    lim = np.asarray(s["limits"]["q"])
    assert traj.shape == (1000, 1 + 3 * 2)
    assert np.all(traj[:, 1:3] >= lim[:, 0] - 1e-9) and np.all(traj[:, 1:3] <= lim[:, 1] + 1e-9)
    assert np.all(np.abs(traj[:, 3:5]) <= np.asarray(s["limits"]["velocity"]) + 1e-9)
    assert (out / "trajectory.png").exists() and (out / "report.md").read_text().startswith("# Exciting trajectory")


def test_cli_robot_mode_errors(tmp_path, capsys):
    urdf, pos, trq, _ = _two_link_files(tmp_path)
    assert main(["robot", "--urdf", str(urdf), "--excite", "--positions", str(pos)]) == 2
    assert "drop --positions" in capsys.readouterr().err
    assert main(["robot", "--urdf", str(urdf), "--positions", str(pos)]) == 2
    assert "--torques required" in capsys.readouterr().err
    # options the chosen mode would ignore are refused, not dropped silently
    assert main(["robot", "--urdf", str(urdf), "--excite", "--decimate", "5", "--dt", "0.001"]) == 2
    assert "drop --dt, --decimate" in capsys.readouterr().err
    assert main(["robot", "--urdf", str(urdf), "--positions", str(pos), "--torques", str(trq), "--harmonics", "3"]) == 2
    assert "--harmonics only apply with --excite" in capsys.readouterr().err
    head = "Joint_1,Joint_2"
    bare = tmp_path / "bare.csv"
    np.savetxt(bare, np.zeros((50, 2)), delimiter=",", header=head, comments="")
    assert main(["robot", "--urdf", str(urdf), "--positions", str(bare), "--torques", str(bare)]) == 2  # usage
    assert "give the sampling period --dt" in capsys.readouterr().err
