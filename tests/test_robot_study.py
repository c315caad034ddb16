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
    assert main(["robot", "--urdf", str(bad), "--excite", "--friction", "auto", "--out", str(tmp_path / "e")]) == 2
    assert main(["robot", "--urdf", str(bad), "--excite", "--estimator", "iv", "--out", str(tmp_path / "e")]) == 2


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
    argv += ["--resample", "--no-sdp", "--friction", "viscous-coulomb", "--estimator", "iv"]
    assert main([*argv, "--out", str(tmp_path / "b")]) == 0
    s = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert s["data"]["resampled"].startswith("resampled") and s["data"]["sample_time"] > 0
    # --friction: the laws' stage in summary.json and report.md (the arm's friction is linear: kept)
    assert s["settings"]["friction"] == ["ViscousCoulomb"]
    assert {m["chosen"] for m in s["friction"]["motors"].values()} == {"ViscousCoulomb"}
    assert "## Friction laws" in (tmp_path / "b" / "report.md").read_text()
    # --estimator iv: the study's estimate is IDIM-IV's, beside its IDIM-LS start
    assert s["settings"]["estimator"] == "IDIM-IV" and s["idim_iv"]["iterations"] >= 1


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


def test_cli_robot_physical_and_export_urdf(tmp_path, capsys):
    """The physically consistent estimate in the report and summary.json, and `--export-urdf FILE`: a URDF pinocchio
    loads with the identified inertias and a drives file beside it (issue 45, items 1 and 2); its misuses exit 2
    before any work."""
    urdf, pos, trq, _ = _two_link_files(tmp_path)
    argv = ["robot", "--urdf", str(urdf), "--positions", str(pos), "--torques", str(trq), "--no-sdp", "--quiet"]
    target = tmp_path / "identified.urdf"
    assert main([*argv, "--out", str(tmp_path / "o"), "--export-urdf", str(target)]) == 0
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    phys = s["physical"]
    assert phys["converged"] and set(phys["relative_error"]) == {"joint1", "joint2"}
    for e in phys["relative_error"].values():  # the arm is physical: consistency costs nothing measurable
        assert abs(e["physical"] - e["unconstrained"]) < 0.05
    assert all(b["mass"] > 0 for b in phys["links"].values())
    assert "## Physically consistent estimate" in (tmp_path / "o" / "report.md").read_text()
    drives = json.loads(target.with_suffix(".drives.json").read_text())
    assert [j["name"] for j in drives["joints"]] == ["joint1", "joint2"]
    back = SerialRobot.from_urdf(target)
    masses = [phys["links"][f"link{k}"]["mass"] for k in (1, 2)]
    np.testing.assert_allclose(np.asarray(back.inertial)[:, 9], masses, rtol=1e-12)
    capsys.readouterr()
    for extra, match in ((["--export-urdf", str(tmp_path / "a.xml")], ".urdf"),
                         (["--export-urdf", str(target), "--no-physical"], "--no-physical")):  # fmt: skip
        assert main([*argv, "--out", str(tmp_path / "p"), *extra]) == 2
        assert match in capsys.readouterr().err
    assert main([*argv, "--out", str(tmp_path / "q"), "--no-physical"]) == 0
    assert json.loads((tmp_path / "q" / "summary.json").read_text())["physical"] is None


def test_physical_estimate_recovers_the_identifiable_full_parameters(tmp_path):
    """A simulated two-link arm with known physical parameters (20 s at 1 kHz, 0.5 N m of torque noise): every full
    parameter the data identify ("data") within 4 of its standard errors (plus 1 % of its value) of the truth."""
    urdf, pos, trq, _ = _two_link_files(tmp_path)
    arm = SerialRobot.from_urdf(urdf)
    truth_robot = eqx.tree_at(lambda r: (r.Ia, r.Fv, r.Fc), arm, (jnp.full(2, 0.1), jnp.array([2.0, 1.0]), jnp.ones(2)))
    from jaxsdp.plants.robot._stacked import full_parameters

    s = robot_study_of(pos, trq, arm)
    est = s.physical
    assert bool(est.converged) and est.warnings() == ()
    truth = full_parameters(truth_robot)
    theta, std = np.asarray(est.theta), np.asarray(est.std)
    seen = [i for i, src in enumerate(est.source) if src == "data"]
    assert len(seen) >= 8
    for i in seen:
        assert abs(theta[i] - truth[i]) <= 4 * std[i] + 0.01 * abs(truth[i]) + 1e-9, (est.names[i], theta[i], truth[i])


def robot_study_of(pos, trq, robot):
    from jaxsdp.studies.robot import robot_study

    return robot_study(load_joint_logs(pos, trq), robot=robot, sdp=False, folds=0)


@requires_tx40
@requires_tx40_urdf
def test_tx40_logs_physical_estimate_and_exported_urdf(tmp_path):
    """Issue 45 on the shared TX40 logs: every link of the consistent estimate a body, each joint's relative error
    within 1 point of the unconstrained fit's, and the exported URDF with its drives file, loaded by pinocchio,
    reproduces the identified torques (the stacked model with the physical base parameters) to 1e-8; the friction law
    kept per joint lowers its cross-validated error or is linear (item 4)."""
    pin = pytest.importorskip("pinocchio")
    from jaxsdp.data import Drives
    from jaxsdp.plants._friction_laws import LAWS
    from jaxsdp.plants.robot import pseudo_inertia, write_urdf
    from jaxsdp.studies.robot import robot_study

    robot = SerialRobot.from_urdf(TX40_URDF)
    logs = load_joint_logs(TX40_POSITIONS, TX40_CURRENTS, dt=2e-4, names=robot.names)
    s = robot_study(logs, robot=robot, drives=Drives.builtin("tx40"), sdp=False, folds=0, friction=LAWS)
    friction = s.friction
    assert friction.converged and set(friction.chosen) == set(range(1, 7))
    for k, law in friction.chosen.items():
        cv = friction.cross_validated[k]
        assert law == "ViscousCoulomb" or cv["chosen"] <= (1 - friction.min_gain) * cv["linear"], (k, law, cv)
    # the real logs' residual is not linear in the speed: most joints keep a richer law (Stribeck: 5 of 6)
    assert sum(law != "ViscousCoulomb" for law in friction.chosen.values()) >= 4, friction.chosen
    est = s.physical
    assert bool(est.converged)
    assert np.linalg.eigvalsh(np.asarray(pseudo_inertia(est.links()))).min() > 0
    physical = est.relative_error(s.idim)
    for j, e in s.idim.relative_error.items():
        assert abs(physical[j] - e) < 1.0, (j, e, physical[j])
    model = s.idim.model
    urdf, drives_file = write_urdf(est.robot(robot), tmp_path / "tx40.urdf", transmission=model.transmission)
    drives = json.loads(drives_file.read_text())
    pm = pin.buildModelFromUrdf(str(urdf))
    data = pm.createData()
    C = np.asarray(drives["transmission"])
    G, Cinv = np.linalg.inv(C).T, np.linalg.inv(C)
    Ia, Fv, Fc, offset = (np.array([j[k] for j in drives["joints"]]) for k in ("Ia", "Fv", "Fc", "offset"))
    q, dq, ddq = np.random.default_rng(0).uniform(-2, 2, (3, 20, 6))
    expected = np.asarray(model.regressor(q, dq, ddq)) @ np.asarray(est.base)
    for k in range(20):
        du, ddu = Cinv @ dq[k], Cinv @ ddq[k]
        tau = pin.rnea(pm, data, q[k], dq[k], ddq[k]) + G @ (Ia * ddu + Fv * du + Fc * np.sign(du)) + offset
        np.testing.assert_allclose(tau, expected[k], atol=1e-8 * max(1.0, np.abs(expected[k]).max()))
