"""The robot identification pipeline as a pure Module and the robot Monte Carlo (issue 44)."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import two_link_arm as arm
from jaxsdp import Butterworth, Preprocessing
from jaxsdp._signal.regressors import Regressors
from jaxsdp.plants import SerialRobot, simulate_robot
from jaxsdp.plants.robot import RobotExperiment, RobotPipeline, joint_preprocess, robot_idim_ls, robot_model
from jaxsdp.plants.robot._joint_stages import moving_mask
from jaxsdp.plants.robot._stacked import full_parameters
from jaxsdp.studies.montecarlo import RobotSettings, robot_robustness
from jaxsdp.studies.montecarlo._robot import drawn_robot

PROCESSING = dict(cutoff_hz=40.0, decimate=2, drop=100)


@pytest.fixture(scope="module")
def setup():
    robot = arm()
    t = np.arange(6000) * 1e-3
    ramp = (1 - np.exp(-2 * t))[:, None]
    q1 = 0.8 * np.sin(2 * np.pi * 0.5 * t) + 0.3 * np.sin(2 * np.pi * 1.3 * t)
    q2 = 0.6 * np.sin(2 * np.pi * 0.7 * t + 0.4) + 0.3 * np.sin(2 * np.pi * 1.9 * t)
    qr = ramp * np.stack([q1, q2], axis=1)
    tau = np.asarray(simulate_robot(robot, qr, dt=1e-3).tau)
    experiment = RobotExperiment(jnp.asarray(qr), controller=robot, torque_noise=jnp.asarray(0.01 * tau.std(axis=0)))
    model = robot_model(robot)
    pipeline = RobotPipeline.of(model, preprocessing=Preprocessing(Butterworth(40.0), drop=100, decimate=2))
    return robot, model, experiment, pipeline


def test_pipeline_equals_robot_idim_ls(setup):
    """The rows at rest weighted out instead of dropped: the same least squares to rounding."""
    robot, model, experiment, pipeline = setup
    logs = experiment(jax.random.key(0), robot)
    fit = pipeline(logs)
    ref = robot_idim_ls(logs, model, preprocessing=PROCESSING)
    np.testing.assert_allclose(fit.theta, ref.result.theta, rtol=0, atol=1e-10 * float(np.max(np.abs(ref.result.std))))
    np.testing.assert_allclose(fit.std, ref.result.std, rtol=1e-12)
    np.testing.assert_allclose(fit.sigma, ref.result.sigma, rtol=1e-12)
    assert int(fit.rows_used) == int(np.asarray(ref.moving).sum())


def test_robot_idim_ls_reads_the_rows_the_one_joint_stages_make(setup):
    """`robot_idim_ls` runs the pipeline: its rows equal those of the one-joint stages (each joint's
    `joint_preprocess`, the stacked regressor decimated column by column), its rows used those of `moving_mask`
    without the end transient, and its estimate NumPy's least squares on them."""
    robot, model, experiment, _ = setup
    logs = experiment(jax.random.key(2), robot)
    res = robot_idim_ls(logs, model, preprocessing=PROCESSING)
    inputs = [joint_preprocess(logs, joint=j, **PROCESSING) for j in (1, 2)]
    q, dq, ddq = (jnp.stack([getattr(p, k) for p in inputs], axis=1) for k in ("q_full", "dq_full", "ddq_full"))
    W = model.regressor(q, dq, ddq)
    tail = -(-PROCESSING["drop"] // PROCESSING["decimate"])
    for i, p in enumerate(inputs):
        reg = p.regression(Regressors(X=W[:, i, :], names=model.names))
        np.testing.assert_allclose(res.y[:, i], reg.y, rtol=1e-12, atol=1e-12 * float(np.max(np.abs(reg.y))))
        np.testing.assert_allclose(res.X[:, i], reg.X, rtol=0, atol=1e-11 * float(np.max(np.abs(reg.X))))
        keep = moving_mask(p)
        keep[-tail:] = False
        np.testing.assert_array_equal(np.asarray(res.moving)[:, i], keep)
    used = np.asarray(res.moving)
    theta = np.linalg.lstsq(np.asarray(res.X)[used], np.asarray(res.y)[used], rcond=None)[0]
    np.testing.assert_allclose(res.result.theta, theta, rtol=0, atol=1e-8 * float(np.max(np.abs(res.result.std))))


def test_vmap_over_robots_and_records_equals_the_loop(setup):
    """Three drawn robots, each simulated and identified: one `vmap` against the loop (jitted)."""
    robot, model, experiment, pipeline = setup
    draws = jnp.asarray(1.0 + 0.1 * np.random.default_rng(0).uniform(-1, 1, (3, 3 * robot.n)))
    keys = jax.random.split(jax.random.key(1), 3)

    def run(key, draw):
        return pipeline(experiment(key, drawn_robot(robot, draw)))

    batch = eqx.filter_jit(jax.vmap(run))(keys, draws)
    one = eqx.filter_jit(run)
    for i in range(3):
        fit = one(keys[i], draws[i])
        scale = np.asarray(fit.std)
        np.testing.assert_allclose(batch.theta[i], fit.theta, rtol=0, atol=1e-6 * float(scale.max()))
        np.testing.assert_allclose(batch.std[i], fit.std, rtol=1e-8)
        truth = model.base.values(full_parameters(drawn_robot(robot, draws[i])))
        # each run identifies its own robot: within 3 % (the processing's bias on the inertias) plus 5 stated se
        assert np.all(np.abs(np.asarray(fit.theta) - truth) < 0.03 * np.abs(truth) + 5 * scale)


@pytest.mark.parametrize("dt", [1e-3, 5e-4])
def test_robot_monte_carlo_summary_is_what_the_runs_say(dt):
    res = robot_robustness(24, robot=arm(), settings=RobotSettings(dt=dt, excite_steps=20), progress=False)
    assert res.theta.shape == res.truth.shape == res.se.shape == (24, len(res.names))
    p = res.statistics["parameters"]
    for j, name in enumerate(res.names):
        err = res.theta[:, j] - res.truth[:, j]
        np.testing.assert_allclose(p[name]["bias"], err.mean(), rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(p[name]["coverage_95"], np.mean(np.abs(err) <= 1.959963984540054 * res.se[:, j]))
    # every base parameter honest at 1 and 2 kHz: the trajectory starts in motion, and the ends dropped follow
    # the filter's start-up (`processing_defaults`); 50 samples at 2 kHz covered ZZ2, MX2, MY2 and Ia2 0 % of the
    # time (biases of 5-9 stated se)
    assert res.statistics["processing"]["drop"] == round(111 * 1e-3 / dt)
    assert res.statistics["coverage_95"]["min"] >= 0.75
    below = res.statistics["below_min_coverage"]
    assert all(k in res.warnings[-1] for k in ("IDIM-LS", "cover")) == bool(below)
    assert res.warnings[0].startswith("only 24 run(s)")
    assert res.iv_theta is None and "iv" not in res.statistics and "IDIM-IV" not in res.report() + res.text()


def test_robot_monte_carlo_says_a_given_drop_is_short():
    res = robot_robustness(2, robot=arm(), settings=RobotSettings(dt=5e-4, excite_steps=5, drop=50), progress=False)
    assert res.statistics["processing"]["drop"] == 50
    assert any("fewer than the" in w and "start-up" in w for w in res.warnings)


def test_cli_montecarlo_robot(tmp_path, capsys):
    """`jaxsdp montecarlo --study robot --urdf FILE`: summary.json, report.md and the coverage figure."""
    import json

    from helpers import ARM_URDF
    from jaxsdp._cli import main

    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM_URDF)
    out = tmp_path / "out"
    code = main(["montecarlo", "--study", "robot", "--runs", "4", "--urdf", str(urdf), "--out", str(out), "--quiet"])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["study"] == "robot" and summary["runs"] == 4 and summary["robot"] == "arm.urdf"
    assert set(summary["parameters"]) and summary["coverage_95"]["min"] <= summary["coverage_95"]["median"]
    report = (out / "report.md").read_text()
    assert "# Monte Carlo: robot identification (arm.urdf)" in report and "mc_robot_coverage" in report
    assert (out / "mc_robot_coverage.png").exists()
    assert "Robot Monte Carlo (arm.urdf): 4 runs" in capsys.readouterr().out
    assert main(["montecarlo", "--study", "control", "--urdf", str(urdf), "--out", str(tmp_path / "x")]) == 2
    for flag in (["--iv"], ["--disturbance", "0.5"]):
        assert main(["montecarlo", "--study", "identification", *flag, "--out", str(tmp_path / "y")]) == 2
    assert "apply to --study robot only" in capsys.readouterr().err


def test_cli_montecarlo_robot_iv_settings(tmp_path, monkeypatch):
    """`--iv --disturbance F` reach the study's settings (the study itself: tests/test_robot_iv.py)."""
    import jaxsdp.studies.montecarlo as mc
    from jaxsdp._cli import main

    seen = {}

    def fake(runs, **kw):
        seen.update(kw)
        raise SystemExit(0)

    monkeypatch.setattr(mc, "robot_robustness", fake)
    with pytest.raises(SystemExit):
        main(["montecarlo", "--study", "robot", "--runs", "2", "--iv", "--disturbance", "0.5", "--out",
              str(tmp_path / "o"), "--quiet"])  # fmt: skip
    assert seen["settings"].iv is True and seen["settings"].disturbance == 0.5


def test_the_logged_torque_is_centred_on_the_sample(setup):
    """`centred` (default): the log at t_k is the mean of the torques held on either side, (tau_{k-1} + tau_k) / 2,
    the torque the central-difference acceleration at t_k answers to; `centred=False` logs the held command."""
    robot, _, experiment, _ = setup
    quiet = eqx.tree_at(lambda e: e.torque_noise, experiment, jnp.zeros(robot.n))
    held = dataclasses.replace(quiet, centred=False)
    tau_c = np.asarray(quiet(jax.random.key(0), robot).tau)
    tau_h = np.asarray(held(jax.random.key(0), robot).tau)
    np.testing.assert_array_equal(tau_c[1:], 0.5 * (tau_h[1:] + tau_h[:-1]))
    np.testing.assert_array_equal(tau_c[0], tau_h[0])


def test_joint_weights_are_weighted_least_squares(setup):
    """`joint_weights=True`: each joint's rows divided by its residual standard deviation from the first fit, then
    solved again; checked against NumPy's least squares on the rows the pipeline returns."""
    robot, _, experiment, pipeline = setup
    logs = experiment(jax.random.key(3), robot)
    plain = pipeline(logs)
    weighted = dataclasses.replace(pipeline, joint_weights=True)(logs)
    y, X, w = np.asarray(plain.y), np.asarray(plain.X), np.asarray(plain.weights)
    res = (y - X @ np.asarray(plain.theta)) * w
    sig = np.sqrt((res**2).sum(0) / w.sum(0))
    np.testing.assert_allclose(plain.joint_sigma, sig, rtol=1e-10)
    s = w / sig
    A, b = (X * s[..., None]).reshape(-1, X.shape[-1]), (y * s).reshape(-1)
    theta = np.linalg.lstsq(A, b, rcond=None)[0]
    np.testing.assert_allclose(weighted.theta, theta, rtol=0, atol=1e-9 * float(np.max(np.abs(weighted.std))))
    e = b - A @ theta
    used = int(w.sum())
    cov = (e @ e) / (used - A.shape[1]) * np.linalg.inv(A.T @ A)
    np.testing.assert_allclose(weighted.std, np.sqrt(np.diag(cov)), rtol=1e-8)
    assert abs(float(weighted.sigma) - 1.0) < 0.05  # the weighted rows' residual: unit variance


def test_diagnose_reads_one_fit_as_the_study_judges_it(setup):
    """`RobotPipeline.diagnose(fit)`: each joint's relative error on its rows used, identifiability, and the study's
    physical checks (`judge`); a motor inertia made negative in the logs' torques is called physically impossible."""
    robot, model, experiment, pipeline = setup
    logs = experiment(jax.random.key(0), robot)
    fit = pipeline(logs)
    d = pipeline.diagnose(fit)
    assert d.identifiable and d.warnings == () and all(v.identifiable for v in d.verdicts.values())
    y, X, w = np.asarray(fit.y), np.asarray(fit.X), np.asarray(fit.weights)
    r = (y[:, 1] - X[:, 1] @ np.asarray(fit.theta)) * w[:, 1]
    assert d.relative_error[2] == pytest.approx(100 * np.linalg.norm(r) / np.linalg.norm(y[:, 1] * w[:, 1]), rel=1e-12)
    # joint 2's torque with a large negative armature term: Ia2 < 0 beyond its standard deviation
    sim = simulate_robot(robot, np.asarray(experiment.reference), dt=1e-3)
    tau = np.asarray(logs.tau).copy()
    tau[:, 1] -= 0.5 * np.asarray(sim.ddq)[:, 1]
    bad = pipeline.diagnose(pipeline(dataclasses.replace(logs, tau=jnp.asarray(tau))))
    assert any("physically impossible" in msg for msg in bad.warnings), bad.warnings
    with pytest.raises(ValueError, match="one RobotFit"):
        pipeline.diagnose(jax.tree.map(lambda x: x[None], fit))
    with pytest.raises(ValueError, match="RobotPipeline.of"):
        RobotPipeline(robot, pipeline.rows, pipeline.columns, pipeline.names).diagnose(fit)


def test_the_tx40_link2_model_is_the_robot_pipeline_of_a_one_link_arm():
    """Eq. (20), the paper's one-joint model of TX40 link 2, is the base model of a one-link arm whose axis is
    horizontal (modified DH alpha = -pi/2): the robot pipeline on joint 2's logs alone gives the link-2 study's
    IDIM-LS (`joint_idim_ls` on `joint_preprocess`, its closed-form regressors) to rounding, ZZ with the
    armature (the one-link base parameter ZZ1 + Ia1)."""
    from jaxsdp.data import JointLogs, tx40_builtin_data
    from jaxsdp.plants.robot import joint_idim_ls

    logs = tx40_builtin_data().logs
    one = JointLogs(
        q=logs.q[:, 1:2], tau=logs.tau[:, 1:2], t=logs.t, dt=logs.dt, joints=(1,), source="link 2", converted="none"
    )
    arm = SerialRobot.from_mdh([[-np.pi / 2, 0, 0, 0]], inertias=[(1.0, np.zeros(3), np.zeros(6))], Ia=0.1)
    model = robot_model(arm)
    assert model.names == ("ZZ1", "MX1", "MY1", "Fv1", "Fc1", "offset1")
    processing = Preprocessing(Butterworth(100.0), drop=100, decimate=10)  # the link-2 study's defaults
    fit = RobotPipeline.of(model, preprocessing=processing)(one)
    paper = joint_idim_ls(joint_preprocess(logs, joint=2)).result
    assert paper.names == ("ZZ2", "MX2", "MY2", "Fv2", "Fc2", "offset2")
    np.testing.assert_allclose(fit.theta, paper.theta, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(fit.std, paper.std, rtol=1e-8)
