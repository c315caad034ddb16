"""IDIM-IV for robots (issue 45 item 3): the robot pipeline's instruments from the identified robot simulated in
the experiment's loop, Newey-West intervals over instants, the disturbance the log does not show."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import two_link_arm as arm
from jaxsdp import IDIMIV, IDIMLS, IID, Butterworth, NeweyWest, Preprocessing
from jaxsdp._idim.ls import ls_estimate
from jaxsdp.data import Drives
from jaxsdp.plants import simulate_robot, tx40_robot
from jaxsdp.plants.robot import RobotExperiment, RobotPipeline, robot_model
from jaxsdp.plants.robot._sim import simulate_loop
from jaxsdp.plants.robot._stacked import full_parameters
from jaxsdp.studies.montecarlo import RobotSettings, robot_robustness

PRE = Preprocessing(Butterworth(40.0), drop=100, decimate=10)


@pytest.fixture(scope="module")
def setup():
    robot = arm()
    t = np.arange(3000) * 1e-3
    ramp = (1 - np.exp(-3 * t))[:, None]
    q1 = 0.8 * np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.sin(2 * np.pi * 1.9 * t)
    q2 = 0.6 * np.sin(2 * np.pi * 0.9 * t + 0.4) + 0.3 * np.sin(2 * np.pi * 2.3 * t)
    qr = jnp.asarray(ramp * np.stack([q1, q2], axis=1))
    tau = np.asarray(simulate_robot(robot, qr, dt=1e-3).tau)
    experiment = RobotExperiment(
        qr, controller=robot, torque_noise=jnp.asarray(0.02 * tau.std(axis=0)),
        disturbance=jnp.asarray(0.5 * tau.std(axis=0)),
    )  # fmt: skip
    model = robot_model(robot)
    options = dict(preprocessing=PRE, rest_fraction=0.15, joint_weights=True)
    ls = RobotPipeline.of(model, **options)
    iv = RobotPipeline.of(model, **options, iv=IDIMIV(), loop=experiment)
    return robot, model, experiment, ls, iv


def test_robot_of_theta_has_those_base_parameters_and_their_torques(setup):
    """`robot_of(theta)`: a robot whose base parameters are theta, so its inverse dynamics is X theta."""
    robot, model, _, _, iv = setup
    theta = model.nominal * (1 + 0.1 * np.arange(model.rank) / model.rank) + 0.01
    other = iv.robot_of(jnp.asarray(theta))
    np.testing.assert_allclose(model.base.values(full_parameters(other)), theta, rtol=1e-12, atol=1e-14)
    rng = np.random.default_rng(0)
    q, dq, ddq = (rng.standard_normal((5, 2)) for _ in range(3))
    X = np.asarray(model.regressor(q, dq, ddq))
    tau = np.stack([np.asarray(other.drive_torques(q[k], dq[k], ddq[k])) for k in range(5)])
    np.testing.assert_allclose(tau, X @ theta, rtol=1e-10, atol=1e-10)


def test_the_disturbance_acts_on_the_plant_and_not_on_the_log():
    """The plant receives tau + d; the returned tau is the drive's command alone."""
    robot = arm()
    n, N = 2, 400
    qr = jnp.asarray(np.outer(np.sin(np.linspace(0, 2, N)), [0.3, 0.2]))
    d = 0.5 * jax.random.normal(jax.random.PRNGKey(0), (N, n))
    J = jnp.diag(robot.mass_matrix(qr[0])) + robot.Ia
    w = 2 * np.pi * 10.0
    args = (robot, robot, qr, 1e-3, J * w**2, 2 * J * w, jnp.full(n, jnp.inf), jnp.zeros(n), jnp.zeros((N, n)), 1e-3)
    sim = simulate_loop(*args, 4, 1, d)
    plain = simulate_loop(*args, 4, 1, 0.0 * d)  # the same program
    # the recorded acceleration answers tau + d at each sample (the plant's equation; where every joint moves
    # faster than 0.01 rad/s, the Coulomb law's regularisation aside)
    back = np.stack([np.asarray(robot.drive_torques(sim.q[k], sim.dq[k], sim.ddq[k])) for k in range(N)])
    moving = np.all(np.abs(np.asarray(sim.dq)) > 0.01, axis=1)
    assert moving.sum() > 0.9 * N
    np.testing.assert_allclose(back[moving], np.asarray(sim.tau + d)[moving], rtol=1e-6, atol=1e-6)
    assert np.max(np.abs(np.asarray(sim.q - plain.q))) > 1e-6  # the motion answers the disturbance


def test_noise_free_iv_recovers_the_truth_the_processing_biases(setup):
    """On the loop's own noise-free record least squares carries the processing's bias (the filter's smear of
    the Coulomb steps: Fv1 0.6 % off); the bias-compensated IV removes it, since the simulated model's own
    residual carries the same bias: the true base parameters to 1e-6."""
    _, model, experiment, ls, iv = setup
    logs = experiment.simulate(arm())
    a, b = eqx.filter_jit(ls)(logs), eqx.filter_jit(iv)(logs)
    truth = model.nominal
    assert np.max(np.abs(np.asarray(a.theta) - truth) / np.maximum(np.abs(truth), 0.01)) > 3e-3
    np.testing.assert_allclose(np.asarray(b.theta), truth, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(np.asarray(b.idim_iv.start), np.asarray(a.theta), rtol=1e-12)


def test_iv_is_the_fixed_point_of_its_instruments(setup):
    """The returned estimate solves (Z^T X) theta = Z^T (y - o) with Z, o rebuilt on the host from the model
    theta simulated in the loop (NumPy least squares, not the library's QR path), to the loop's tolerance."""
    robot, _, experiment, _, iv = setup
    logs = experiment(jax.random.PRNGKey(3), robot)
    fit = eqx.filter_jit(iv)(logs)
    assert bool(fit.idim_iv.converged)
    last = np.asarray(fit.idim_iv.theta_history)[int(fit.idim_iv.iterations) - 1]  # the iterate Z was built on
    ys, Xs, _, _ = iv._rows(experiment.simulate(iv.robot_of(jnp.asarray(last))))
    y, X, w = (np.asarray(a) for a in (fit.y, fit.X, fit.weights))
    p = X.shape[-1]
    # the joint weights the IV used are the LS ones; recover them from the LS step's residual
    a = ls_estimate(jnp.asarray((y * w).reshape(-1)), jnp.asarray((X * w[..., None]).reshape(-1, p)), jnp.nan)
    sig = np.sqrt(np.sum(((y - X @ np.asarray(a["theta"])) * w) ** 2, axis=0) / w.sum(axis=0))
    scaled = w / sig
    Z = (np.asarray(Xs) * scaled[..., None]).reshape(-1, p)
    o = ((np.asarray(ys) - np.asarray(Xs) @ last) * scaled).reshape(-1)
    Xw, yw = (X * scaled[..., None]).reshape(-1, p), (y * scaled).reshape(-1)
    theta = np.linalg.solve(Z.T @ Xw, Z.T @ (yw - o))
    np.testing.assert_allclose(np.asarray(fit.theta), theta, rtol=1e-6, atol=1e-9)


def test_iv_vmaps_over_records_and_its_intervals_are_newey_west_over_instants(setup):
    robot, _, experiment, _, iv = setup

    @eqx.filter_jit
    def run(key):
        fit = iv(experiment(key, robot))
        return fit.theta, fit.std, fit.idim_iv.converged

    keys = jax.random.split(jax.random.PRNGKey(1), 2)
    theta, std, ok = jax.vmap(run)(keys)
    one = run(keys[1])
    # a batch solves by Householder QR in lax, one problem by LAPACK (`jaxsdp._linalg`): the rounding may stop
    # the loop one iteration apart, a change below the loop's tolerance, a thousandth of a standard error
    assert np.all(np.abs(np.asarray(theta[1] - one[0])) < 1e-3 * np.asarray(one[1]))
    np.testing.assert_allclose(np.asarray(std[1]), np.asarray(one[1]), rtol=1e-3)
    assert bool(jnp.all(ok)) and bool(jnp.all(jnp.isfinite(std)))


def test_grouped_newey_west_is_statsmodels_hac_groupsum():
    """The stacked joints' scores summed per instant before the Bartlett lags: statsmodels' "hac-groupsum" with
    the instant as the time index (same lag, small-sample factor N / (N - p))."""
    sm = pytest.importorskip("statsmodels.api")
    rng = np.random.default_rng(0)
    T, g, p, lag = 300, 3, 4, 5
    X = rng.standard_normal((T * g, p))
    e = np.convolve(rng.standard_normal(T * g + 4), np.ones(5) / 5, mode="valid")
    y = X @ np.arange(1.0, p + 1) + e
    time = np.repeat(np.arange(T), g)
    ref = sm.OLS(y, X).fit(cov_type="hac-groupsum", cov_kwds=dict(time=time, maxlags=lag, use_correction=False))
    out = ls_estimate(jnp.asarray(y), jnp.asarray(X), jnp.asarray(float(lag)), cov="hac", groups=g)
    N = T * g
    np.testing.assert_allclose(np.asarray(out["cov"]) * (N - p) / N, ref.cov_params(), rtol=1e-10)
    np.testing.assert_allclose(np.asarray(out["theta"]), ref.params, rtol=1e-12)


def test_iv_needs_the_loop_and_independent_drives(setup):
    _, model, experiment, _, _ = setup
    with pytest.raises(ValueError, match="closed loop to simulate its instruments"):
        RobotPipeline.of(model, iv=IDIMIV())
    with pytest.raises(ValueError, match="must be a jaxsdp.IDIMIV"):
        RobotPipeline.of(model, iv="iv", loop=experiment)
    with pytest.raises(ValueError, match="must be a jaxsdp.IDIMLS"):
        RobotPipeline.of(model, ls=IID())
    tx = robot_model(tx40_robot(), transmission=Drives.builtin("tx40").transmission)
    with pytest.raises(ValueError, match="coupled drives"):
        RobotPipeline.of(tx, iv=IDIMIV(), loop=experiment)
    short = RobotExperiment(experiment.reference[:2000], controller=experiment.controller, torque_noise=jnp.zeros(2))
    iv = RobotPipeline.of(model, preprocessing=PRE, iv=IDIMIV(), loop=short)
    with pytest.raises(ValueError, match="its reference has 2000 samples, the logs 3000"):
        iv(experiment.simulate(arm()))
    assert isinstance(RobotPipeline.of(model, ls=IDIMLS(NeweyWest())).ls.cov, NeweyWest)


def test_robot_monte_carlo_with_iv_reports_both_estimators(tmp_path):
    s = RobotSettings(f0=0.5, excite_steps=5, disturbance=0.5, torque_noise=0.02, decimate=5, iv=True)
    res = robot_robustness(3, robot=arm(), settings=s, progress=False)
    assert res.iv_theta.shape == res.iv_se.shape == res.theta.shape
    iv = res.statistics["iv"]
    assert set(iv["parameters"]) == set(res.names) and 1 <= iv["iterations"]["median"] <= IDIMIV().max_iter
    err = res.iv_theta[:, 0] - res.truth[:, 0]
    np.testing.assert_allclose(iv["parameters"][res.names[0]]["bias"], err.mean(), rtol=1e-10, atol=1e-14)
    report, text, summary = res.report(), res.text(), res.summary()
    assert "## IDIM-IV against the truth" in report and "disturbance on the plant of 50 %" in report
    assert "IDIM-IV, " in text and summary["iv"]["coverage_95"]["min"] <= 1.0
    with pytest.raises(ValueError, match="`disturbance`"):
        RobotSettings(disturbance=-1.0)
    with pytest.raises(ValueError, match="`iv`"):
        RobotSettings(iv=1)


def test_robot_study_with_iv(setup):
    """`robot_study(iv=IDIMIV())` (`jaxsdp robot --estimator iv`): the IDIM-IV from the study's own loop (the
    logged angles followed under the description's PD) is the study's estimate, every parameter within 3.5 of its
    standard errors of the truth on a record with a torque disturbance (the coverage is the Monte Carlo's test);
    in summary.json, report.md and the findings; refused with coupled drives."""
    from jaxsdp.plants.robot import RobotProcessing
    from jaxsdp.studies.robot import robot_study

    robot, model, experiment, _, _ = setup
    logs = experiment(jax.random.PRNGKey(3), robot)
    processing = RobotProcessing(cutoff_hz=40.0, decimate=10, drop=100)
    s = robot_study(logs, robot=robot, processing=processing, iv=IDIMIV(), sdp=False, physical=False, folds=0)
    fit = s.idim.iv
    assert fit is not None and bool(fit.converged) and s.settings["estimator"] == "IDIM-IV"
    truth = np.asarray(model.nominal)
    theta = np.asarray(s.idim.result.theta)
    std = np.abs(theta) * np.asarray(s.idim.result.rel_std) / 100
    assert np.max(np.abs((theta - truth) / std)) < 3.5  # one record: every parameter within its interval's reach
    assert int(fit.iterations) >= 1 and not np.allclose(theta, np.asarray(fit.start))
    out = s.summary()["idim_iv"]
    assert out["converged"] and len(out["parameters"]) == model.rank
    np.testing.assert_allclose([p["ls"] for p in out["parameters"]], np.asarray(fit.start))
    assert "## IDIM-IV" in s.report() and any(f.startswith("IDIM-IV converged") for f in s.findings)
    drives = Drives(np.ones(2), coupling=[(1, 2)])
    with pytest.raises(ValueError, match="couple motors"):
        robot_study(logs, robot=robot, drives=drives, iv=IDIMIV(), sdp=False, physical=False, folds=0)


def test_iv_stops_at_a_diverged_simulation_and_keeps_the_previous_iterate():
    """`iv_iterate`: a step whose instruments are not finite (the model simulated for them diverged) stops the
    loop, not converged, `failed`, the previous step's estimate kept (here the IDIM-LS start's: the first step)."""
    from jaxsdp._idim.estimators import iv_iterate
    from jaxsdp._idim.iv import Instruments

    key = jax.random.PRNGKey(0)
    X = jax.random.normal(key, (200, 2))
    y = X @ jnp.array([1.0, -2.0]) + 0.1 * jax.random.normal(jax.random.fold_in(key, 1), (200,))
    theta0 = jnp.linalg.lstsq(X, y)[0]

    def instruments(theta):  # finite for the first step only: the second iterate "diverges"
        return Instruments(jnp.where(jnp.abs(theta[0] - theta0[0]) > 0, jnp.nan, X + 0.01), None)

    fit = iv_iterate(y, X, instruments, theta0, ("a", "b"), IDIMIV(tol=1e-15, compensate=False, cov=IID()))
    assert bool(fit.failed) and not bool(fit.converged) and int(fit.iterations) == 1
    assert np.all(np.isfinite(np.asarray(fit.result.theta)))
    np.testing.assert_array_equal(np.asarray(fit.result.theta), np.asarray(fit.theta_history[1]))
    ok = iv_iterate(y, X, lambda th: Instruments(X + 0.01, None), theta0, ("a", "b"), IDIMIV(cov=IID()))
    assert not bool(ok.failed) and bool(ok.converged)


def test_robot_study_with_iv_on_200_hz_logs():
    """Slow logs: the instruments' loop takes its bandwidth from the sample rate (a 10 Hz PD acting once per 5 ms
    sample with one sample of delay diverges: refused by name), and the study's IDIM-IV converges."""
    from jaxsdp.plants.robot._sim import check_loop, loop_bandwidth
    from jaxsdp.studies.robot import robot_study

    robot, dt = arm(), 5e-3
    assert loop_bandwidth(1e-3) == 10.0 and loop_bandwidth(dt) == 5.0
    with pytest.raises(ValueError, match="unstable"):
        check_loop(dt, 10.0)
    t = np.arange(600) * dt
    q1 = 0.8 * np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.sin(2 * np.pi * 1.9 * t)
    q2 = 0.6 * np.sin(2 * np.pi * 0.9 * t + 0.4) + 0.3 * np.sin(2 * np.pi * 2.3 * t)
    qr = (1 - np.exp(-3 * t))[:, None] * np.stack([q1, q2], axis=1)
    with pytest.raises(ValueError, match="unstable"):
        RobotExperiment(jnp.asarray(qr), controller=robot, torque_noise=jnp.zeros(2), dt=dt, bandwidth_hz=10.0)
    experiment = RobotExperiment(jnp.asarray(qr), controller=robot, torque_noise=jnp.array([0.4, 0.15]), dt=dt)
    logs = experiment(jax.random.PRNGKey(5), robot)
    s = robot_study(logs, robot=robot, iv=IDIMIV(), sdp=False, physical=False, folds=0)
    fit = s.idim.iv
    assert bool(fit.converged) and not bool(fit.failed) and s.summary()["idim_iv"]["loop_hz"] == 5.0
    assert "critically damped at 5 Hz" in s.report()
