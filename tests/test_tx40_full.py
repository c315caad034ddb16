"""The TX40 with all joints moving (paper section 3.4.2) and beyond it: the link-2 model's mis-specification,
the full six-joint model's recovery of the truth to the noise floor, the SDP of its residual, the convention
check, and `jaxsdp tx40 --case all --model full`."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

from jaxsdp._cli import main
from jaxsdp.data import JointLogs, model_convention, tx40_all_joints_data
from jaxsdp.plants.robot._joint_full import joint_full_model
from jaxsdp.studies.tx40 import FullModel, example_study, tx40_study
from jaxsdp.studies.tx40._report_full import departure
from jaxsdp.studies.tx40._study import full_model_warnings


@pytest.fixture(scope="module")
def built():
    return tx40_all_joints_data()


@pytest.fixture(scope="module")
def study(built):
    return tx40_study(built.logs, reference="table5", full_model=FullModel(robot=built.truth["robot"]))


def test_all_joints_moving_shows_the_papers_finding(study):
    link2 = example_study()  # only link 2 moving
    le = float(study.idim.result.relative_error)
    assert le > float(link2.idim.result.relative_error) + 8  # paper: 20.0 % against 5.8 %
    assert study.sdp.relative_error < le - 2  # paper: 11.0 %
    text = " ".join(study.warnings)
    assert "IDIM-LS residual is serially correlated" in text and "depart from the parametric shapes" in text
    # gravity of the upright arm in the log convention appears on MY2 (paper: -3.29 to -3.60)
    assert study.idim.result["MY2"] < -2.0 and abs(study.idim.result["MX2"]) < 1.0


def test_full_model_recovers_the_truth_to_the_noise_floor(study):
    f = study.full
    assert f.model.rank == 38 and "Ia2" in f.model.base.dependent  # ZZ2 and Ia2 both multiply ddq2 alone
    keep = np.asarray(f.moving)
    y, X = np.asarray(f.regression.y)[keep], np.asarray(f.regression.X)[keep]
    floor = 100 * np.linalg.norm(y - X @ f.model.nominal) / np.linalg.norm(y)  # the true model, same processing
    assert 0.97 * floor < f.relative_error <= floor  # LS reaches the noise floor, no lower than overfitting allows
    assert f.relative_error < 0.5 * float(study.idim.result.relative_error)
    assert bool(f.whiteness.white)
    est, nom, rel = f.estimates(), f.nominal(), f.rel_std()
    well = [k for k in f.model.names if rel[k] < 5.0]
    assert {"ZZ2", "MX2", "MY3", "Fv2", "Fc2"} <= set(well)
    for k in well:  # within 4 standard deviations of the truth
        assert abs(est[k] - nom[k]) < 4 * rel[k] / 100 * abs(est[k]), (k, est[k], nom[k], rel[k])
    assert f.gravity_deviation < 15
    assert not any("convention" in w for w in study.warnings) and study.plausible


def test_full_model_explains_the_sdp_mismatch(study):
    fs, c = study.full_sdp, study.coupling
    assert bool(fs.result.converged) and fs.relative_error <= study.full.relative_error
    assert departure(study.sdp) == pytest.approx(c["departure"], rel=1e-9)
    assert departure(fs) < 0.3 * c["departure"]  # the one-joint curves' departure is the coupling
    assert 20 < c["explained"] <= 100 and c["coupling"] > 5
    truth = study.full.model.robot
    assert fs.friction["Fv2"] == pytest.approx(float(truth.Fv[1]), rel=0.06)  # SDP's smoothing of the step:
    assert fs.friction["Fc2"] == pytest.approx(float(truth.Fc[1]), rel=0.06)  # a few per cent, as for link 2
    s = study.summary()
    fm = s["full_model"]
    assert set(fm["base_parameters"]) == set(fm["rel_std"]) == set(f"{k}" for k in study.full.model.names)
    assert fm["rank"] == 38 and fm["relative_error"] == pytest.approx(study.full.relative_error)
    fsd = s["full_model_sdp"]
    assert {"relative_error", "iterations", "nvr", "friction_curve"} <= set(fsd)
    dq = np.asarray(fsd["friction_curve"]["dq"])
    assert np.all(np.diff(dq) >= 0) and len(dq) == len(fsd["friction_curve"]["d"]) <= 400
    json.dumps(s, allow_nan=False)


def test_convention_mismatch_shows(built, study):
    """The logs read without the TX40's joint offsets: the gravity fit lands far from the nominal robot."""
    wrong = model_convention(built.logs, offsets=None)
    pre = dict(derivatives="butterworth", cutoff_hz=100.0, order=4, nvr=None, drop=100, decimate=10, mode="matlab")
    f, _ = joint_full_model(wrong, robot=built.truth["robot"], joint=2, min_speed=0.01, preprocessing=pre)
    assert f.gravity_deviation > 100
    physical, _ = full_model_warnings(f, study.full_sdp, 2, 1.0)
    assert any("convention" in w for w in physical)


def test_model_convention_inverts_the_tx40_logs():
    q = np.random.default_rng(0).normal(size=(30, 6))
    tau = np.random.default_rng(1).normal(size=(30, 6))
    C = np.eye(6)
    C[5, 4] = 1.0  # joint side: q6_log = q6 + q5 (motor 6 turns with joint 5)
    D = np.eye(6)
    D[4, 5] = 1.0  # tau5 = tau5_log + tau6_log
    offsets = np.array([0.0, -np.pi / 2, np.pi / 2, 0, 0, 0])
    q_log = (q - offsets) @ C.T
    tau_log = np.linalg.solve(D, tau.T).T
    logs = JointLogs(
        q=jnp.asarray(q_log), tau=jnp.asarray(tau_log), t=jnp.arange(30) * 1e-3, dt=1e-3,
        joints=(1, 2, 3, 4, 5, 6), source="s", converted="c",
    )  # fmt: skip
    m = model_convention(logs)
    assert np.allclose(m.q, q, atol=1e-12) and np.allclose(m.tau, tau, atol=1e-12)
    with pytest.raises(ValueError, match="offsets"):
        model_convention(logs, offsets=(0.0, 1.0))
    with pytest.raises(ValueError, match="coupling"):
        model_convention(logs, coupling=(5, 7))
    two = JointLogs(q=logs.q[:, :2], tau=logs.tau[:, :2], t=logs.t, dt=1e-3, joints=(1, 2), source="s", converted="c")
    with pytest.raises(ValueError, match="full model needs the logs of all 6 joints"):
        tx40_study(two, full_model=FullModel(joint_offsets=None, wrist_coupling=None))
    with pytest.raises(ValueError, match="`wrist_coupling`"):
        FullModel(wrist_coupling=(5, 5))
    with pytest.raises(ValueError, match="`full_model`"):
        tx40_study(two, full_model=True)


def test_cli_all_joints_full_model(tmp_path, capsys):
    out = tmp_path / "all"
    assert main(["tx40", "--case", "all", "--model", "full", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "Full six-joint model" in printed and "full model + SDP" in printed
    s = json.loads((out / "summary.json").read_text())
    assert s["reference"]["label"].startswith("paper Table 5")
    assert {"relative_error", "rank", "base_parameters", "rel_std"} <= set(s["full_model"])
    assert {"relative_error", "iterations", "nvr", "friction_curve"} <= set(s["full_model_sdp"])
    assert s["full_model"]["relative_error"] < 0.5 * s["idim_ls"]["relative_error"]
    report = (out / "report.md").read_text()
    assert "Beyond the paper: the full six-joint model" in report and "paper IDIM-LS" in report
    assert (out / "fig_full_model.png").is_file()


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--model", "full"], "--case all"),
        (["--joint-offsets", "0,0,0,0,0,0"], "--model full"),
        (["--case", "all", "--model", "full", "--wrist-coupling", "5"], "two joint numbers"),
    ],
)
def test_cli_full_model_errors(tmp_path, capsys, extra, message):
    assert main(["tx40", "--out", str(tmp_path / "o"), "--quiet", *extra]) != 0
    assert message in capsys.readouterr().err
