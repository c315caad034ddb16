"""One small call of every public jaxsdp callable, for the float64 check (tests/test_float64_everywhere.py).

`CASES` maps a public name (`module.name`, or `module.Class.method` for the methods users call on models
and results) to a function that calls it on small, seeded NumPy data and returns its result.
`tests/test_float64_everywhere.py` runs every case twice, in a fresh process that never enabled JAX's 64-bit
mode (so import-time constants are made as a plain notebook makes them) and in the test process (64-bit on),
and compares the results leaf by leaf (1e-12 relative; float leaves must be float64 in both).

`ELSEWHERE` names the public callables not called here, each with where its float64 result is checked or why
none exists (settings and text-only functions, whole studies of minutes); the test fails on a public
callable in neither table, so a new name cannot escape.

Run as a script, `python tests/float64_cases.py OUT.pkl` writes {name: leaves} of every case to OUT.pkl.
"""

import functools
import pathlib
import sys

import numpy as np

_HERE = pathlib.Path(__file__).resolve().parent
if str(_HERE) not in sys.path:  # run as a script
    sys.path.insert(0, str(_HERE))

from helpers import EXAMPLE_ROBOTS, TX40_DIR  # noqa: E402

TX40_URDF = TX40_DIR / "tx40_mdh_modified.urdf"


def _rng(seed=0):
    return np.random.default_rng(seed)


def _series(n=300, seed=0):
    """A regression with a slowly varying gain: y = a(t) x + e."""
    rng = _rng(seed)
    t = np.arange(n) / n
    x = rng.standard_normal(n)
    a = 1.0 + 0.5 * np.sin(2 * np.pi * t)
    return a * x + 0.05 * rng.standard_normal(n), x[:, None]


def _axis(n=2000, dt=1e-3, seed=0):
    """Position and force of a 1 kg axis with viscous and Coulomb friction on a smooth excitation."""
    t = np.arange(n) * dt
    q = 0.1 * np.sin(2 * np.pi * 1.0 * t) + 0.05 * np.sin(2 * np.pi * 2.7 * t)
    dq = np.gradient(q, dt)
    ddq = np.gradient(dq, dt)
    force = 1.0 * ddq + 5.0 * dq + 2.0 * np.tanh(dq / 1e-3) + 0.01 * _rng(seed).standard_normal(n)
    return t, q, force


def _seasonal(n=96, seed=0):
    """A monthly-like series: a trend, an annual cycle of growing amplitude, noise."""
    k = np.arange(n, dtype=float)
    return 0.05 * k + (1.0 + k / n) * np.cos(2 * np.pi * k / 12) + 0.1 * _rng(seed).standard_normal(n)


@functools.lru_cache(maxsize=None)
def _preprocessed():
    import jaxsdp

    t, q, force = _axis()
    return jaxsdp.preprocess(q, force, dt=1e-3, cutoff_hz=20.0, drop=20)


@functools.lru_cache(maxsize=None)
def _emps():
    from jaxsdp.data import emps_builtin_data

    return emps_builtin_data(0)


@functools.lru_cache(maxsize=None)
def _emps_inputs():
    from jaxsdp.plants.emps import emps_preprocess

    return emps_preprocess(_emps()[0])


@functools.lru_cache(maxsize=None)
def _tx40():
    from jaxsdp.data import tx40_builtin_data

    return tx40_builtin_data()


def _key():
    import jax

    return jax.random.PRNGKey(0)


def _robot():
    """The two-link arm (tests/helpers.py): the float64 checks of the robot methods need joints, not the TX40's six
    (whose programs cost the suite minutes of compilation in both processes)."""
    from helpers import two_link_arm

    return two_link_arm()


def _states(n=6, k=4, seed=1):
    rng = _rng(seed)
    return rng.standard_normal((k, n)), rng.standard_normal((k, n)), rng.standard_normal((k, n))


def _urdf_robots():
    paths = []
    if TX40_URDF.exists():
        paths.append(TX40_URDF)
    if EXAMPLE_ROBOTS is not None:
        ur5 = EXAMPLE_ROBOTS / "ur_description" / "urdf" / "ur5_robot.urdf"
        if ur5.exists():
            paths.append(ur5)
    return paths


def _from_urdf():
    from jaxsdp.plants import SerialRobot

    out = []
    for path in _urdf_robots():
        robot = SerialRobot.from_urdf(path)
        q, dq, ddq = _states(robot.n)
        out.append((robot, robot.inverse_dynamics(q, dq, ddq)))
    return out


def _c(fn):
    return fn


def _cases():  # noqa: C901 - one table
    import jax

    import jaxsdp
    from jaxsdp import control, data, plants, tfest, tvp
    from jaxsdp.plants import emps as pe
    from jaxsdp.plants import robot as pr

    y, X = _series()
    t, q, force = _axis()
    pre = _preprocessed
    rob = _robot
    qs = functools.partial(_states, 2)

    def dlr_fit():
        return jaxsdp.dlr(y, X, nvr=1e-3)

    def idim():
        return jaxsdp.idim_ls(y, np.column_stack([X[:, 0], np.ones_like(y)]))

    def iv():
        Xr = np.column_stack([X[:, 0], np.ones_like(y)])
        return jaxsdp.idim_iv(y, Xr, Xr + 0.01 * _rng(3).standard_normal(Xr.shape))

    def pip_design():
        return control.pip_lq([0.0, 0.5], [1.0, -0.8])

    def model_from_emps():
        from jaxsdp.studies.emps import emps_study  # noqa: F401 - the layer is importable

        stage = pe.emps_sdp_stage(_emps_inputs(), nvr=(1e-4, 1e-4))
        return stage

    def drives():
        return data.Drives.builtin("tx40")

    def robot_model():
        return pr.robot_model(rob(), states=80)

    def joint_model():
        return plants.joint_model(rob(), joint=2, states=80)

    def tx40_logs():
        return _tx40().logs

    cases = {
        # estimation core
        "jaxsdp.dlr": dlr_fit,
        "jaxsdp.dlr_loglik": lambda: jaxsdp.dlr_loglik(y, X, nvr=1e-3),
        "jaxsdp.ml_nvr": lambda: jaxsdp.ml_nvr(y, X),
        "jaxsdp.sdp": lambda: jaxsdp.sdp(y, X, X, nvr=1e-3),
        "jaxsdp.multi_sdp": lambda: jaxsdp.multi_sdp(y, X, nvr=(1e-3,)),
        "jaxsdp.MultiBackfitting": lambda: jaxsdp.MultiBackfitting(max_iter=2, optimise_on="first")(y, X),
        "jaxsdp.captain_nvrs": lambda: jaxsdp.captain_nvrs(y, X, X),
        "jaxsdp.RW": lambda: (jaxsdp.RW().transition(), jaxsdp.RW().noise(np.array([1e-3]))),
        "jaxsdp.IRW": lambda: (jaxsdp.IRW().transition(), jaxsdp.IRW().noise(np.array([1e-3]))),
        "jaxsdp.SRW": lambda: (jaxsdp.SRW(alpha=0.9).transition(), jaxsdp.SRW(alpha=0.9).noise(np.array([1e-3]))),
        "jaxsdp.LLT": lambda: (jaxsdp.LLT().transition(), jaxsdp.LLT().noise(np.array([1e-3, 1e-4]))),
        "jaxsdp.Constant": lambda: (jaxsdp.Constant().transition(), jaxsdp.Constant().noise(np.array([]))),
        # signal
        "jaxsdp.butter_derivatives": lambda: jaxsdp.butter_derivatives(q, 1e-3, cutoff_hz=20.0),
        "jaxsdp.smooth_derivatives": lambda: jaxsdp.smooth_derivatives(q, 1e-3, cutoff_hz=20.0),
        "jaxsdp.cutoff_from_nvr": lambda: jaxsdp.cutoff_from_nvr(1e-8, 1e-3),
        "jaxsdp.nvr_from_cutoff": lambda: jaxsdp.nvr_from_cutoff(20.0, 1e-3),
        "jaxsdp.decimate": lambda: jaxsdp.decimate(q, 10),
        "jaxsdp.decimation_filter": lambda: jaxsdp.decimation_filter(10),
        "jaxsdp.filtfilt": lambda: jaxsdp.filtfilt(q, np.array([0.2, 0.2]), np.array([1.0, -0.6])),
        "jaxsdp.lfilter": lambda: jaxsdp.lfilter(q, np.array([0.2, 0.2]), np.array([1.0, -0.6])),
        "jaxsdp.lfilter_zi": lambda: jaxsdp.lfilter_zi(np.array([0.2, 0.2]), np.array([1.0, -0.6])),
        "jaxsdp.preprocess": pre,
        "jaxsdp.Preprocessing": lambda: jaxsdp.Preprocessing(jaxsdp.Butterworth(20.0), drop=20, decimate=2)(
            q, force, 1e-3
        ),
        "jaxsdp.Butterworth": lambda: jaxsdp.Preprocessing(jaxsdp.Butterworth(30.0, 2), drop=5)(q, force, 1e-3),
        "jaxsdp.Smoothing": lambda: jaxsdp.Preprocessing(jaxsdp.Smoothing(20.0), drop=20, decimate=1)(q, force, 1e-3),
        "jaxsdp.Preprocessing.emps": jaxsdp.Preprocessing.emps,
        "jaxsdp.IDIMLS": lambda: jaxsdp.IDIMLS()(y, np.column_stack([X[:, 0], np.ones_like(y)]), ("a", "b")),
        "jaxsdp.IID": lambda: jaxsdp.IDIMLS(jaxsdp.IID())(y, np.column_stack([X[:, 0], np.ones_like(y)]), ("a", "b")),
        "jaxsdp.NeweyWest": lambda: jaxsdp.IDIMLS(jaxsdp.NeweyWest(3))(
            y, np.column_stack([X[:, 0], np.ones_like(y)]), ("a", "b")
        ),
        "jaxsdp.Backfitting": lambda: jaxsdp.Backfitting(nvr=jaxsdp.FixedNVR(1e-3))(y, X, X),
        "jaxsdp.FixedNVR": lambda: jaxsdp.Backfitting(nvr=jaxsdp.FixedNVR((1e-3,)))(y, X, X).par,
        "jaxsdp.MLNVR": lambda: jaxsdp.Backfitting(nvr=jaxsdp.MLNVR(1e-3, 10.0))(y, X, X).nvr,
        "jaxsdp.Backfitting.max_nvr": lambda: jaxsdp.Backfitting().max_nvr,
        "jaxsdp.CaptainNVR": lambda: jaxsdp.Backfitting(nvr=jaxsdp.CaptainNVR(1e-3, 10.0))(y, X, X).nvr,
        "jaxsdp.Backfitting.searched": lambda: jaxsdp.Backfitting(nvr=jaxsdp.CaptainNVR()).searched(y, X, X)[1],
        "jaxsdp.plants.emps.asymmetric_plant": lambda: pe.asymmetric_plant([95.0, 165.0, 20.0, 240.0, 20.6]).M,
        "jaxsdp.plants.emps.EMPSExperiment": lambda: pe.EMPSExperiment(np.linspace(0.0, 0.05, 3000), dt=1e-3)(
            jax.random.key(0), np.array([95.0, 165.0, 20.0, 240.0, 20.6])
        ),
        "jaxsdp.plants.emps.EMPSPipeline": lambda: pe.EMPSPipeline(sdp=None)(_emps()[0]),
        "jaxsdp.IDIMIV": lambda: pe.EMPSPipeline(sdp=None, iv=jaxsdp.IDIMIV(max_iter=2))(_emps()[0]).idim_iv,
        "jaxsdp.plants.emps.EMPSFit.idim_sdp_theta": lambda: pe.EMPSPipeline()(_emps()[0]).idim_sdp_theta,
        "jaxsdp.plants.emps.fits_from": lambda: pe.fits_from(pe.EMPSPipeline()(_emps()[0])).idim_sdp,
        "jaxsdp.plants.emps.EMPSPipeline.diagnose": lambda: (
            pe.EMPSPipeline().diagnose(pe.EMPSPipeline()(_emps()[0])).idim
        ),
        "jaxsdp.plants.robot.RobotPipeline": _robot_pipeline_fit,
        "jaxsdp.plants.robot.RobotPipeline.of": lambda: pr.RobotPipeline.of(pr.robot_model(_arm())).robot.inertial,
        "jaxsdp.plants.robot.RobotExperiment": lambda: _robot_logs()[0],
        "jaxsdp.plants.robot.RobotPipeline.diagnose": lambda: _robot_pipeline_diagnosis().relative_error,
        "jaxsdp.plants.robot.RobotDiagnosis": lambda: list(_robot_pipeline_diagnosis().relative_error.values()),
        "jaxsdp.Preprocessed.regression": lambda: pre().regression(
            jaxsdp.regressors({"M": pre().ddq_full, "Fv": pre().dq_full, "Fc": np.sign(pre().dq_full)})
        ),
        "jaxsdp.regressors": lambda: jaxsdp.regressors({"a": X[:, 0], "b": np.ones_like(y)}),
        "jaxsdp.parallel_decimate": lambda: jaxsdp.parallel_decimate(y, np.column_stack([X[:, 0], y]), 5),
        "jaxsdp.whiteness": lambda: jaxsdp.whiteness(y),
        # identification
        "jaxsdp.idim_ls": idim,
        "jaxsdp.IDIMResult.param": lambda: idim().param("theta1"),
        "jaxsdp.idim_iv": iv,
        "jaxsdp.IDIMIVResult.std": lambda: (iv().std, iv().rel_std, iv().theta),
        "jaxsdp.idim_iv_iterate": lambda: jaxsdp.idim_iv_iterate(
            y,
            np.column_stack([X[:, 0], np.ones_like(y)]),
            lambda th: np.column_stack([X[:, 0], np.ones_like(y)]),
            np.zeros(2),
        ),
        "jaxsdp.parametric_stage": lambda: jaxsdp.parametric_stage(
            2.0 * X[:, 0] + 1.0, jaxsdp.regressors({"a": X[:, 0], "b": np.ones_like(y)})
        ),
        "jaxsdp.monte_carlo": lambda: (
            jaxsdp.monte_carlo(
                lambda key: (
                    jaxsdp.idim_ls(
                        y + 0.01 * __import__("jax").random.normal(key, y.shape),
                        np.column_stack([X[:, 0], np.ones_like(y)]),
                    ).theta
                ),
                0,
                4,
                progress=False,
            ).values
        ),
        "jaxsdp.to_dict": lambda: jaxsdp.to_dict(idim()),
        "jaxsdp.from_dict": lambda: jaxsdp.from_dict(jaxsdp.to_dict(idim())),
        # transfer functions
        "jaxsdp.tfest.srivc": lambda: tfest.srivc(*_tf_data(), n=1, m=0),
        "jaxsdp.tfest.rivcbj": lambda: tfest.rivcbj(*_tf_data(), n=1, m=0, nc=0, nd=1),
        "jaxsdp.tfest.sriv": lambda: tfest.sriv(*_tf_data()[:2], n=1, m=0, delay=1),
        "jaxsdp.tfest.rivbj": lambda: tfest.rivbj(*_tf_data()[:2], n=1, m=0, nc=0, nd=1, delay=1),
        "jaxsdp.tfest.RIVSolver": lambda: (
            tfest.rivbj(
                *_tf_data()[:2], n=1, m=0, nc=0, nd=1, delay=1, solver=tfest.RIVSolver(max_iter=20, pem=True)
            ).theta
        ),
        "jaxsdp.tfest.c2d": lambda: tfest.c2d([2.0], [1.0, 2.0], 0.01),
        "jaxsdp.tvp.dhr": lambda: tvp.dhr(_seasonal(), [12.0, 4.0], nvr=(1e-5, 1e-3, 1e-3), horizon=6),
        "jaxsdp.tvp.DHRResult": lambda: tvp.dhr(_seasonal(), [12.0], trend="RW", nvr="ml").nvr_fit,
        "jaxsdp.tvp.dlr_forecast": lambda: tvp.dlr_forecast(y, X, z_future=X[:5], nvr=1e-3),
        "jaxsdp.tvp.Forecast.interval": lambda: tvp.dlr_forecast(y, X, nvr=1e-3).interval(0.9),
        "jaxsdp.tvp.Forecast.filled": lambda: (
            tvp.dlr_forecast(np.where(np.arange(300) % 7 == 0, np.nan, y), X, nvr=1e-3).filled
        ),
        "jaxsdp.tvp.Forecast.horizon": lambda: tvp.dlr_forecast(y, X, z_future=X[:5], nvr=1e-3).horizon,
        "jaxsdp.tvp.harmonic_regressors": lambda: tvp.harmonic_regressors(24, [12.0, 2.0]),
        "jaxsdp.tvp.irw_nvr": lambda: tvp.irw_nvr(np.array([12.0, 24.0])),
        "jaxsdp.tvp.trend": lambda: tvp.trend(_seasonal(), cutoff_period=24.0, horizon=3),
        "jaxsdp.studies.forecast.forecast_study": _forecast_study,
        "jaxsdp.tvp.dar": lambda: tvp.dar(y, 2, nvr=(1e-3, 1e-4), horizon=3),
        "jaxsdp.tvp.DARResult": lambda: tvp.dar(y, 1, nvr="ml", tied=True).nvr_fit,
        "jaxsdp.tvp.darx": lambda: tvp.darx(y, X[:, 0], na=1, nb=1, nvr=1e-3, u_future=X[:4, 0]),
        "jaxsdp.tvp.darsp": lambda: tvp.darsp(tvp.dar(y, 2, nvr=1e-3), n_freq=16, dt=0.01),
        "jaxsdp.tvp.dtfm": lambda: tvp.dtfm(*_tf_data()[:2], na=1, nb=1, nvr=1e-4, iterations=3, u_future=np.ones(4)),
        "jaxsdp.tvp.DTFMResult": lambda: tvp.dtfm(*_tf_data()[:2], na=1, nb=1, nd=1, iterations=2).nvr_fit,
        "jaxsdp.tvp.univ": lambda: tvp.univ(_seasonal(), 1, horizon=3),
        "jaxsdp.tfest.cramer_rao": lambda: tfest.cramer_rao(
            _tf_data()[1], 0.01, num=[2.0], den=[1.0, 2.0], sigma2=1e-4
        ),
        "jaxsdp.tfest.structure_search": lambda: tfest.structure_search(*_tf_data(), orders=[(1, 0)]),
        # control
        "jaxsdp.control.nmss": lambda: control.nmss([0.0, 0.5], [1.0, -0.8]),
        "jaxsdp.control.pip_lq": pip_design,
        "jaxsdp.control.PIPDesign.named_gains": lambda: (pip_design().named_gains(), pip_design().closed_loop_poles),
        "jaxsdp.control.pip_init": lambda: control.pip_init(pip_design()),
        "jaxsdp.control.pip_step": lambda: control.pip_step(pip_design(), control.pip_init(pip_design()), 1.0, 0.1),
        "jaxsdp.control.pip_simulate": lambda: control.pip_simulate(pip_design(), [0.0, 0.5], [1.0, -0.8], np.ones(50)),
        "jaxsdp.control.solve_dare": lambda: control.solve_dare(
            np.array([[1.0, 0.1], [0.0, 1.0]]), np.array([[0.0], [0.1]]), np.eye(2), np.eye(1)
        ),
        "jaxsdp.control.step_metrics": lambda: control.step_metrics(t, 1 - np.exp(-t / 0.1), 1.0),
        "jaxsdp.control.tracking_cost": lambda: control.tracking_cost(t, q, q + 1e-3),
        "jaxsdp.control.true_plant": control.true_plant,
        "jaxsdp.control.LinearPD": lambda: control.LinearPD(),
        "jaxsdp.control.Drive": lambda: control.Drive(delay=1, force_limit=300.0).apply(np.array(400.0)),
        "jaxsdp.control.sdp_friction": lambda: control.sdp_friction(
            np.linspace(-0.2, 0.2, 200), 5.0 * np.linspace(-0.2, 0.2, 200) + 2.0 * np.tanh(np.linspace(-20, 20, 200))
        ).branch(np.array(0.1), 1.0),
        "jaxsdp.control.control_model": lambda: (
            control.control_model({"M": 95.1, "Fv": 203.5, "Fc": 20.4, "offset": -3.2}),
            control.control_model({"M": 95.1, "Fv": 203.5, "Fc": 20.4, "offset": -3.2}).a_dq(np.array(0.1)),
        ),
        # plants
        "jaxsdp.plants.LinearFriction": lambda: plants.LinearFriction(5.0, 2.0).branch(np.array(0.1), 1.0),
        "jaxsdp.plants.AsymmetricFriction": lambda: plants.AsymmetricFriction(5.0, 2.0, 4.0, 1.5).branch(
            np.array(-0.1), -1.0
        ),
        "jaxsdp.plants.TabulatedFriction": lambda: plants.TabulatedFriction(
            np.linspace(-1, 1, 5), np.linspace(-3, 3, 5)
        ).branch(np.array(0.3), 1.0),
        "jaxsdp.plants.asym_friction": lambda: plants.asym_friction(np.array([5.0, 2.0, 4.0, 1.5]), q),
        "jaxsdp.plants.asym_friction_basis": lambda: plants.asym_friction_basis(q),
        "jaxsdp.plants.emps_regressors": lambda: plants.emps_regressors(q, q),
        "jaxsdp.plants.emps_asym_regressors": lambda: plants.emps_asym_regressors(q, q),
        "jaxsdp.plants.emps_regression": lambda: plants.emps_regression(_emps_inputs()),
        "jaxsdp.plants.encoder_quantum": plants.encoder_quantum,
        "jaxsdp.plants.quantise": lambda: plants.quantise(q, 1e-4),
        "jaxsdp.plants.measure": lambda: plants.measure(_key(), q, sigma=1e-3),
        "jaxsdp.plants.white_noise": lambda: plants.white_noise(_key(), 10, sigma=0.1),
        "jaxsdp.plants.step_reference": lambda: plants.step_reference(t, step_times=[0.5], levels=[0.1]),
        "jaxsdp.plants.bang_bang_reference": lambda: plants.bang_bang_reference(
            t, velocities=[0.1, -0.1], switch_times=[0.2, 1.0], accel=2.0
        ),
        "jaxsdp.plants.quintic_reference": lambda: plants.quintic_reference(
            t, knot_times=[0.0, 1.0, 2.0], knot_positions=[0.0, 0.1, 0.0]
        ),
        "jaxsdp.plants.EMPSPlant": lambda: plants.EMPSPlant(),
        "jaxsdp.plants.EMPSController": lambda: plants.EMPSController(),
        "jaxsdp.plants.EMPSInitial": lambda: (
            plants.simulate_emps(np.zeros(50), initial=plants.EMPSInitial(q=0.01, dq=0.02)).q
        ),
        "jaxsdp.plants.default_parameters": lambda: plants.default_parameters(plants.EMPSPlant())(plants.EMPSPlant()),
        "jaxsdp.plants.simulate_emps": lambda: plants.simulate_emps(0.01 * np.sin(t[:500] * 6.0), dt=1e-3),
        "jaxsdp.plants.tx40_robot": lambda: plants.tx40_robot().inertial,
        "jaxsdp.plants.SerialRobot.inverse_dynamics": lambda: rob().inverse_dynamics(*qs()),
        "jaxsdp.plants.SerialRobot.gravity_torques": lambda: rob().gravity_torques(qs()[0]),
        "jaxsdp.plants.SerialRobot.mass_matrix": lambda: rob().mass_matrix(qs()[0]),
        "jaxsdp.plants.SerialRobot.forward_dynamics": lambda: rob().forward_dynamics(*qs()),
        "jaxsdp.plants.SerialRobot.drive_torques": lambda: rob().drive_torques(*qs()),
        "jaxsdp.plants.SerialRobot.regressor": lambda: rob().regressor(*qs()),
        "jaxsdp.plants.SerialRobot.from_urdf": _from_urdf,
        "jaxsdp.plants.SerialRobot.from_mdh": lambda: _from_mdh(),
        "jaxsdp.plants.link_parameters": lambda: plants.link_parameters(2.0, [0.1, 0.0, 0.2], np.eye(3) * 0.01),
        "jaxsdp.plants.base_parameters": lambda: plants.base_parameters(
            _rng(2).standard_normal((30, 4)) @ np.array([[1.0, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 0]]),
            ("a", "b", "c", "d"),
        ),
        "jaxsdp.plants.TX40Link2": lambda: plants.TX40Link2().inverse_dynamics(*(x[:, 0] for x in qs(1))),
        "jaxsdp.plants.joint_regressors": lambda: plants.joint_regressors(*(x[:, 0] for x in qs(1))),
        "jaxsdp.plants.gravity_basis": lambda: plants.gravity_basis(qs(1)[0][:, 0]),
        "jaxsdp.plants.friction_basis": lambda: plants.friction_basis(qs(1)[1][:, 0]),
        "jaxsdp.plants.joint_model": joint_model,
        "jaxsdp.plants.JointModel.regressors": lambda: joint_model().regressors(*qs()),
        "jaxsdp.plants.robot.robot_model": robot_model,
        "jaxsdp.plants.robot.RobotModel.regressor": lambda: robot_model().regressor(*qs()),
        "jaxsdp.plants.simulate_tx40_link2": lambda: plants.simulate_tx40_link2(
            0.2 * np.sin(np.arange(500) * 2e-4 * 6.0)
        ),
        "jaxsdp.plants.emps.check_emps_data": lambda: pe.check_emps_data(_emps()[0]),
        "jaxsdp.plants.emps.emps_preprocess": _emps_inputs,
        "jaxsdp.plants.emps.emps_sdp_stage": model_from_emps,
        "jaxsdp.plants.emps.emps_idim_iv": lambda: pe.emps_idim_iv(_emps()[0], _emps_inputs()),
        "jaxsdp.plants.robot.joint_preprocess": lambda: pr.joint_preprocess(tx40_logs(), joint=2),
        "jaxsdp.plants.robot.joint_idim_ls": lambda: pr.joint_idim_ls(pr.joint_preprocess(tx40_logs(), joint=2)),
        "jaxsdp.plants.robot.rest_threshold": lambda: pr.rest_threshold(pr.joint_preprocess(tx40_logs(), joint=2)),
        "jaxsdp.plants.robot.joint_motion": lambda: pr.joint_motion(tx40_logs()),
        # data
        "jaxsdp.data.emps_builtin_data": _emps,
        "jaxsdp.data.emps_builtin_reference": lambda: data.emps_builtin_reference(n=500),
        "jaxsdp.data.tx40_builtin_reference": lambda: data.tx40_builtin_reference(n=500),
        "jaxsdp.data.tx40_builtin_data": _tx40,
        "jaxsdp.data.Drives": lambda: (drives(), drives().joint_torques(np.ones((3, 6)))),
        "jaxsdp.data.model_convention": lambda: data.model_convention(tx40_logs()),
        "jaxsdp.data.load_measurements": lambda: _measurements_round_trip(t, q, force),
        "jaxsdp.data.load_record": lambda: data.load_record(_emps()[0])[0],
        "jaxsdp.data.write_joint_logs": lambda: _joint_logs_round_trip(),
        "jaxsdp.data.load_joint_bag": lambda: _joint_bag_round_trip(),
        "jaxsdp.save": lambda: _save_load(idim()),
        # simulation and control on the plants
        "jaxsdp.control.simulate_control": lambda: control.simulate_control(
            control.LinearPD(), 0.01 * np.sin(t[:400] * 6.0)
        ),
        "jaxsdp.control.SDPPD": lambda: control.simulate_control(
            control.SDPPD(control.control_model({"M": 95.1, "Fv": 203.5, "Fc": 20.4, "offset": -3.2})),
            0.01 * np.sin(t[:400] * 6.0),
        ),
        "jaxsdp.plants.simulate_robot": lambda: plants.simulate_robot(
            rob(), 0.1 * np.sin(np.arange(40)[:, None] * 2e-4 * np.arange(1, 3)), dt=2e-4
        ),
        "jaxsdp.plants.emps.emps_idim_sdp": lambda: pe.emps_idim_sdp(model_from_emps(), _emps_inputs()),
        "jaxsdp.plants.robot.robot_idim_ls": lambda: pr.robot_idim_ls(_smooth_logs(), robot_model()),
        "jaxsdp.plants.robot.physical_estimate": lambda: _physical().base,
        "jaxsdp.plants.emps.emps_friction": lambda: pe.emps_friction(_emps_inputs()).fit().p,
        "jaxsdp.plants.emps.EMPSFriction.fit": lambda: pe.emps_friction(_emps_inputs(), laws=plants.Stribeck()).fit().p,
        "jaxsdp.plants.emps.EMPSFriction.summary": lambda: list(
            pe.emps_friction(_emps_inputs()).summary()["cross_validated"].values()
        ),
        "jaxsdp.plants.fit_friction": lambda: plants.fit_friction(*_friction_data(), plants.Stribeck()).p,
        "jaxsdp.plants.FrictionFit.as_dict": lambda: list(plants.fit_friction(*_friction_data()).as_dict().values()),
        "jaxsdp.plants.select_friction": lambda: [float(f.bic) for f in plants.select_friction(*_friction_data())[1]],
        "jaxsdp.plants.cross_validate_friction": lambda: plants.cross_validate_friction(
            *_friction_data(), plants.SmoothCoulomb()
        ),
        "jaxsdp.plants.ViscousCoulomb": lambda: plants.ViscousCoulomb()(np.linspace(-1, 1, 5), [3.0, 2.0]),
        "jaxsdp.plants.AsymmetricCoulomb": lambda: plants.AsymmetricCoulomb()(np.linspace(-1, 1, 5), [3.0, 2.0, 1.0]),
        "jaxsdp.plants.SmoothCoulomb": lambda: plants.SmoothCoulomb()(np.linspace(-1, 1, 5), [3.0, 2.0, -3.0]),
        "jaxsdp.plants.Stribeck": lambda: plants.Stribeck()(np.linspace(-1, 1, 5), [3.0, 2.0, 3.0, -2.0]),
        "jaxsdp.plants.robot.PhysicalEstimate": lambda: _physical().theta,
        "jaxsdp.plants.robot.PhysicalEstimate.links": lambda: _physical().links(),
        "jaxsdp.plants.robot.PhysicalEstimate.robot": lambda: _physical().robot(_arm()).inertial,
        "jaxsdp.plants.robot.PhysicalEstimate.relative_error": lambda: list(
            pr.physical_estimate(_arm_idim().result, _arm_idim().model).relative_error(_arm_idim()).values()
        ),
        "jaxsdp.plants.robot.robot_friction": lambda: _arm_friction().theta,
        "jaxsdp.plants.robot.RobotFriction": lambda: _arm_friction().std,
        "jaxsdp.plants.robot.RobotFriction.summary": lambda: [
            c["bic"] for c in _arm_friction().summary()["motors"]["motor_2"]["candidates"].values()
        ],
        "jaxsdp.plants.robot.pseudo_inertia": lambda: pr.pseudo_inertia(
            plants.link_parameters(2.0, [0.1, 0.0, 0.2], np.eye(3) * 0.01)
        ),
        "jaxsdp.plants.robot.joint_multi_sdp": lambda: pr.joint_multi_sdp(
            pr.joint_preprocess(tx40_logs(), joint=2, decimate=10), inertia=1.0, sdp=jaxsdp.MultiBackfitting(max_iter=2)
        ),
        # the main job, and its contract (the study's numbers as summary.json holds them)
        "jaxsdp.studies.emps.emps_study": _emps_study,
    }
    return cases


@functools.lru_cache(maxsize=None)
def _smooth_logs():
    """Two joints on smooth sines for 2 s at 1 kHz, with the arm's inverse-dynamics torques, as CSV logs."""
    import tempfile

    from jaxsdp.data import load_joint_logs, write_joint_logs

    t = np.arange(2000) * 1e-3
    w = 2 * np.pi * np.array([0.5, 0.7])
    q = 0.5 * np.sin(t[:, None] * w)
    dq, ddq = 0.5 * w * np.cos(t[:, None] * w), -0.5 * w**2 * np.sin(t[:, None] * w)
    tau = np.asarray(_robot().drive_torques(q, dq, ddq))
    folder = pathlib.Path(tempfile.mkdtemp())
    write_joint_logs(folder / "q.csv", folder / "tau.csv", q, tau)
    return load_joint_logs(folder / "q.csv", folder / "tau.csv", dt=1e-3)


def _measurements_round_trip(t, q, force):
    import tempfile

    from jaxsdp.data import load_measurements

    path = pathlib.Path(tempfile.mkdtemp()) / "axis.csv"
    np.savetxt(path, np.column_stack([t, q, force]), delimiter=",", header="t,q,force", comments="", fmt="%.17g")
    return load_measurements(path)


def _joint_logs_round_trip():
    import tempfile

    from jaxsdp.data import load_joint_logs, write_joint_logs

    folder = pathlib.Path(tempfile.mkdtemp())
    q, dq, _ = _states(6, 50)
    write_joint_logs(folder / "q.csv", folder / "tau.csv", q, dq)
    return load_joint_logs(folder / "q.csv", folder / "tau.csv", dt=1e-3)


def _joint_bag_round_trip():
    """Two joints' states written as a ROS 2 MCAP bag with jittered stamps (100 Hz), read back."""
    import tempfile

    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from jaxsdp.data import load_joint_bag

    store = get_typestore(Stores.ROS2_HUMBLE)
    kind = "sensor_msgs/msg/JointState"
    JointState, Header, Time = (store.types[k] for k in (kind, "std_msgs/msg/Header", "builtin_interfaces/msg/Time"))
    q, dq, tau = _states(2, 50)
    stamps = 10**9 + np.arange(50) * 10**7 + (_rng(3).uniform(-1, 1, 50) * 2e6).astype(np.int64)  # ns
    path = pathlib.Path(tempfile.mkdtemp()) / "bag"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        topic = writer.add_connection("/joint_states", kind, typestore=store)
        for k, stamp in enumerate(stamps):
            header = Header(stamp=Time(sec=int(stamp) // 10**9, nanosec=int(stamp) % 10**9), frame_id="")
            msg = JointState(header=header, name=["b", "a"], position=q[k], velocity=dq[k], effort=tau[k])
            writer.write(topic, int(stamp), store.serialize_cdr(msg, kind))
    return load_joint_bag(path, names=("a", "b"))


def _friction_data():
    """(y, X, v) of an axis of 2 kg with Stribeck friction and an offset on a two-sine motion (seeded noise)."""
    t = np.linspace(0, 30, 1500)
    v = 0.6 * np.sin(0.7 * t) + 0.3 * np.sin(2.3 * t + 1.0)
    a = 0.42 * np.cos(0.7 * t) + 0.69 * np.cos(2.3 * t + 1.0)
    f = np.sign(v) * (2.0 + 1.5 * np.exp(-((v / 0.08) ** 2))) + 3.0 * v
    return 2.0 * a + 0.3 + f + 0.05 * np.random.default_rng(0).normal(size=t.size), np.c_[a, np.ones_like(t)], v


def _physical():
    """The physically consistent estimate of the two-joint arm's own base parameters (a covariance of 1e-4)."""
    from jaxsdp.plants import robot as pr

    model = pr.robot_model(_arm(), states=80)
    return pr.physical_estimate(dict(theta=model.nominal, cov=1e-4 * np.eye(model.rank)), model)


def _arm_idim():
    """IDIM-LS of the two-joint arm on its simulated closed-loop logs."""
    from jaxsdp.plants import robot as pr

    return pr.robot_idim_ls(_robot_logs()[0], pr.robot_model(_arm(), states=80))


@functools.lru_cache(maxsize=None)
def _arm_friction():
    """The two-joint arm's friction laws (Stribeck the one candidate: its linear friction kept by the
    cross-validation)."""
    from jaxsdp.plants import Stribeck
    from jaxsdp.plants import robot as pr

    return pr.robot_friction(_arm_idim(), laws=Stribeck())


def _arm():
    from helpers import two_link_arm

    return two_link_arm()


def _robot_logs():
    """Logs of the two-joint arm following two seconds of a slow sine under its own PD control (seeded noise)."""
    import jax

    from jaxsdp.plants import robot as pr

    t = np.arange(2000) * 1e-3
    qr = np.stack([0.5 * np.sin(2 * np.pi * t), 0.4 * np.sin(3 * np.pi * t + 0.3)], axis=1) * (1 - np.exp(-t))[:, None]
    experiment = pr.RobotExperiment(qr, controller=_arm(), torque_noise=np.array([0.01, 0.01]))
    return experiment(jax.random.key(0), _arm()), experiment


def _robot_pipeline_diagnosis():
    from jaxsdp._signal.preprocess import Butterworth, Preprocessing
    from jaxsdp.plants import robot as pr

    processing = Preprocessing(Butterworth(40.0), drop=50, decimate=2)
    pipe = pr.RobotPipeline.of(pr.robot_model(_arm()), preprocessing=processing)
    return pipe.diagnose(pipe(_robot_logs()[0]))


def _robot_pipeline_fit():
    from jaxsdp._signal.preprocess import Butterworth, Preprocessing
    from jaxsdp.plants import robot as pr

    processing = Preprocessing(Butterworth(40.0), drop=50, decimate=2)
    pipe = pr.RobotPipeline.of(pr.robot_model(_arm()), preprocessing=processing)
    return pipe(_robot_logs()[0])


def _save_load(result):
    import tempfile

    import jaxsdp

    path = pathlib.Path(tempfile.mkdtemp()) / "r.npz"
    jaxsdp.save(path, result)
    return jaxsdp.load(path)


def _emps_study():
    from jaxsdp.studies import emps

    study = emps.emps_study(_emps()[0], check_decimation=False)
    return {k: v for k, v in emps.summary(study).items() if k not in ("timings", "versions")}  # not results


def _forecast_study():
    from jaxsdp.studies import forecast

    study = forecast.forecast_study(_seasonal(), periods=[12.0], horizon=6, holdout=12, nvr=(1e-5, 1e-3))
    return {k: v for k, v in forecast.summary(study).items() if k not in ("timings", "versions")}  # not results


def _tf_data():
    """A first-order continuous system 2/(s+2) sampled at 10 ms under a seeded PRBS, with a little noise."""
    from helpers import prbs, zoh_simulate

    u = prbs(400, 5, 4)
    y = zoh_simulate([2.0], [1.0, 2.0], u, 0.01) + 1e-3 * _rng(5).standard_normal(400)
    return y, u, 0.01


def _from_mdh():
    from jaxsdp.plants import SerialRobot

    table = [(0.0, 0.0, 0.0, 0.0), (np.pi / 2, 0.0, 0.0, 0.1)]
    inertias = [np.array([1.0, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.01, 0.0, 0.01]) for _ in range(2)]
    robot = SerialRobot.from_mdh(table, inertias=inertias)
    return robot, robot.inverse_dynamics(*_states(2))


_SETTING = "a setting: takes and returns strings, no arrays"
_TEXT = "text or figures from a result whose numbers are checked by a case (the x64 decorator is checked for it)"
_STUDY = "a whole study (tens of seconds to minutes); its stages are cases here, it runs under the x64 decorator"
_SLOW = "an optimisation of tens of seconds; it runs under the x64 decorator, its kernels are cases here"

#: Public callables not called in `CASES`, and where their float64 result is checked (or why there is none).
#: Result types need no entry when a case returns one (the test collects the types in the cases' results).
ELSEWHERE = {
    "jaxsdp.fast_loops_status": _SETTING,
    "jaxsdp.kernel_method": _SETTING,
    "jaxsdp.resolve_method": _SETTING,
    "jaxsdp.set_kernel_method": _SETTING,
    "jaxsdp.idim_table": _TEXT,
    "jaxsdp.load": "the case of jaxsdp.save loads what it saved",
    "jaxsdp.data.tx40_all_joints_data": "simulated TX40 logs of the six joints (15 s); tx40_builtin_data is a case",
    "jaxsdp.data.load_emps": "reads a .mat file; load_record and load_measurements are cases, with the same checks",
    "jaxsdp.data.load_joint_logs": "the case of write_joint_logs loads what it wrote",
    "jaxsdp.data.IrregularSamplingError": "an exception",
    "jaxsdp.control.identify_friction": _STUDY,
    "jaxsdp.studies.montecarlo.robot_robustness": "a Monte Carlo of RobotPipeline after RobotExperiment, both "
    "cases here (25 s with the smallest settings); tests/test_robot_pipeline.py runs it",
    "jaxsdp.control.nominal_design": _STUDY,
    "jaxsdp.control.PIPSDP": "built from nominal_design's PIP design (a study); its parts PIP and SDPPD are cases",
    "jaxsdp.control.AbstractController": "an abstract base class (LinearPD and SDPPD are cases)",
    "jaxsdp.plants.AbstractFriction": "an abstract base class (the three friction laws are cases)",
    "jaxsdp.ParameterModel": "an abstract base class (RW, IRW, SRW, LLT, Constant are cases)",
    "jaxsdp.plants.identify_emps_by_simulation": _SLOW,
    "jaxsdp.plants.identify_robot_by_simulation": _SLOW,
    "jaxsdp.plants.robot_output_error": _SLOW,
    "jaxsdp.plants.PDController": "the TX40 link-2 controller; simulate_tx40_link2 (a case) builds and runs it",
    "jaxsdp.plants.emps.emps_fits": "the SDP stage's fits; emps_sdp_stage and emps_study (cases) run them",
    "jaxsdp.plants.robot.optimise_excitation": _SLOW,
    "jaxsdp.plants.robot.Excitation": "optimise_excitation's trajectory (see there)",
    "jaxsdp.plants.robot.ExcitationResult": "optimise_excitation's result (see there)",
    "jaxsdp.studies.control.control_study": _STUDY,
    "jaxsdp.studies.tx40.tx40_study": _STUDY,
    "jaxsdp.studies.tx40.FullModel": "an option object of tx40_study (a study): a robot and two tuples, no numbers",
    "jaxsdp.studies.tx40.TX40Builtin": "an option object of tx40_study (a study): which built-in data, no numbers",
    "jaxsdp.studies.tx40.example_study": _STUDY,
    "jaxsdp.studies.robot.robot_study": _STUDY,
    "jaxsdp.studies.robot.example_study": _STUDY,
    "jaxsdp.studies.robot.excitation_study": _STUDY,
    "jaxsdp.studies.montecarlo.control_robustness": _STUDY,
    "jaxsdp.studies.montecarlo.identification_robustness": _STUDY,
    "jaxsdp.studies.montecarlo.step_statistics": "host-side NumPy statistics of a Monte Carlo study's runs",
    "jaxsdp.studies.tx40.choose_reference": "host-side choice of reference values from a dict",
    "jaxsdp.studies.emps.emps_cross_validation": _STUDY,
    "jaxsdp.studies.emps.simulation_check": "a stage of emps_study, which is a case",
    "jaxsdp.studies.emps.recovery": "a stage of emps_study, which is a case",
    "jaxsdp.Instruments": "an input container for idim_iv: it holds the arrays it is given",
    "jaxsdp.MonteCarloOutput": "monte_carlo's result; its values are the case of monte_carlo (its seconds vary)",
    "jaxsdp.control.ControlSettings": "the control study's options (numbers as given)",
    "jaxsdp.control.FrictionEstimate": "identify_friction's result: " + _STUDY,
    "jaxsdp.control.NominalDesign": "nominal_design's result: " + _STUDY,
    "jaxsdp.plants.SimIdentResult": "identify_emps_by_simulation's result: " + _SLOW,
    "jaxsdp.plants.RobotSimIdentResult": "identify_robot_by_simulation's result: " + _SLOW,
    "jaxsdp.plants.emps.EMPSFits": "emps_fits' result (see there)",
    "jaxsdp.plants.robot.JointFullModel": "the TX40 study's full joint model: " + _STUDY,
    "jaxsdp.studies.montecarlo.IdentificationSettings": "the identification Monte Carlo study's options",
    "jaxsdp.studies.montecarlo.RobotSettings": "the robot Monte Carlo study's options",
    "jaxsdp.plants.FrictionLaw": "the friction laws' base class (no parameters of its own); each law has a case",
    "jaxsdp.plants.robot.PhysicalSolver": "physical_estimate's solver options (no numbers computed); "
    "physical_estimate's case runs them",
    "jaxsdp.plants.robot.write_urdf": "writes a URDF and a JSON file (text); the written robot's torques are checked "
    "against pinocchio in tests/test_urdf_export.py",
    "jaxsdp.plants.robot.RobotProcessing": "the robot study's processing options (numbers the defaults fill in "
    "host-side); robot_study runs them (tests/test_robot_study.py)",
    "jaxsdp.studies.robot.ExcitationDesign": "the excitation study's design options (no numbers computed); "
    "excitation_study (a study) runs them",
    "jaxsdp.plants.OutputError": "identification by simulation's solver options (no numbers); the two functions that "
    "take it: " + _SLOW,
}
_STUDY_RESULTS = (
    "jaxsdp.studies.control.ControlStudy",
    "jaxsdp.studies.tx40.TX40Study",
    "jaxsdp.studies.robot.RobotStudy",
    "jaxsdp.studies.robot.ExcitationStudy",
    "jaxsdp.studies.montecarlo.ControlRobustness",
    "jaxsdp.studies.montecarlo.IdentificationRobustness",
    "jaxsdp.studies.montecarlo.RobotRobustness",
    "jaxsdp.studies.emps.EMPSStudy",
    "jaxsdp.studies.emps.EMPSCrossValidation",
)
ELSEWHERE["jaxsdp.studies.forecast.ForecastStudy"] = "forecast_study's result: its summary is forecast_study's case"
ELSEWHERE.update({name: "a study's result type: " + _STUDY for name in _STUDY_RESULTS})
#: The contract and figure functions of each study: text, figures and summaries of a study result.
TEXT_MODULES = (
    "jaxsdp.studies.emps",
    "jaxsdp.studies.control",
    "jaxsdp.studies.tx40",
    "jaxsdp.studies.robot",
    "jaxsdp.studies.montecarlo",
    "jaxsdp.studies.forecast",
)


def cases():
    return _cases()


def leaves(result) -> list:
    """The numeric leaves of a result (arrays, NumPy scalars, floats), as NumPy arrays, in tree order."""
    import jax

    out = []
    for x in jax.tree.leaves(result):
        if isinstance(x, (bool, np.bool_)) or x is None:
            continue
        if isinstance(x, (int, float, complex, np.number, np.ndarray, jax.Array)):
            out.append(np.asarray(x))
    return out


def run_all(names=None) -> dict:
    table = cases()
    out = {}
    for name in names or table:
        out[name] = leaves(table[name]())
    return out


if __name__ == "__main__":
    import pickle

    import jaxsdp  # noqa: F401  the package first, as a user imports it

    result = run_all()
    pathlib.Path(sys.argv[1]).write_bytes(pickle.dumps(result))
