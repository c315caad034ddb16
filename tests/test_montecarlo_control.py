"""Control robustness by Monte Carlo (issue 18, item 3): nominal design held fixed, plants drawn."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxsdp.control import SDPPD, simulate_control, step_metrics
from jaxsdp.plants import AsymmetricFriction, EMPSPlant
from jaxsdp.studies.control import ControlSettings, nominal_design
from jaxsdp.studies.montecarlo import CONTROLLERS, PARAMETERS, control_robustness, step_statistics


@pytest.fixture(scope="module")
def nominal():
    return nominal_design()


def test_step_statistics_match_step_metrics(nominal):
    s = ControlSettings()
    r = jnp.full(400, s.step)
    with jax.enable_x64(True):
        sim = simulate_control(SDPPD(nominal.model, wn=s.wn, eta=s.eta), r, q0=0.0, dt=s.dt)
        st = step_statistics(sim.t, sim.q, sim.dq, sim.force, s.step)
    ref = step_metrics(sim.t, sim.q, s.step, y0=0.0, velocity=sim.dq, force=sim.force)
    np.testing.assert_allclose(float(st["settling_time_s"]), ref.settling_time, rtol=1e-12)
    np.testing.assert_allclose(float(st["overshoot_pct"]), ref.overshoot, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(float(st["peak_velocity"]), ref.peak_velocity, rtol=1e-12)
    assert bool(st["stable"]) and bool(st["settled"])
    # an unbounded response is unstable and never settles
    t = jnp.arange(100) * 1e-3
    bad = step_statistics(t, jnp.exp(50 * t), jnp.zeros(100), jnp.zeros(100), 0.05)
    assert not bool(bad["stable"]) and np.isinf(float(bad["settling_time_s"]))


def test_control_robustness_draws_and_summary(nominal):
    res = control_robustness(24, nominal=nominal, chunk_size=16, progress=False)
    assert res.parameters.shape == (24, len(PARAMETERS)) and res.runs == 24
    mean = np.array([nominal.asymmetric[k] for k in PARAMETERS])
    assert np.all(np.abs(res.parameters / mean - 1) <= 0.2 + 1e-12)
    for c in CONTROLLERS:
        assert res.stats[c]["settling_time_s"].shape == (24,)
        assert 0.0 <= res.statistics[c]["stable_fraction"] <= 1.0
        s = res.statistics[c]["settling_time_s"]
        assert s["p05"] <= s["mean"] <= s["p95"]
    # the PIP-SDP keeps the speed near its limit, the PD loops (ideal drive) far above it
    assert res.statistics["pip_sdp"]["peak_velocity"]["mean"] < 0.2 < res.statistics["sdp_pd"]["peak_velocity"]["mean"]
    assert res.envelope.shape[0] == 24
    # one draw equals a direct simulation of that plant
    th = res.parameters[3]
    plant = EMPSPlant(th[0], AsymmetricFriction(*th[1:]))
    s = ControlSettings()
    with jax.enable_x64(True):
        sim = simulate_control(SDPPD(nominal.model, wn=s.wn, eta=s.eta), jnp.full(400, s.step), plant=plant, q0=0.0)
    np.testing.assert_allclose(res.stats["sdp_pd"]["peak_velocity"][3], float(jnp.max(jnp.abs(sim.dq))), rtol=1e-10)
    # covariance draws: the identification's own uncertainty, much narrower than +-20 %
    cov = control_robustness(16, draws="covariance", nominal=nominal, progress=False)
    assert np.all(np.abs(cov.parameters / mean - 1) < 0.1)


def test_control_robustness_bad_arguments(nominal):
    with pytest.raises(ValueError, match="`draws`"):
        control_robustness(4, draws="normal", nominal=nominal, progress=False)
    with pytest.raises(ValueError, match="`spread`"):
        control_robustness(4, spread=1.5, nominal=nominal, progress=False)


def test_control_robustness_real_drive(nominal):
    from jaxsdp.control import REAL_DRIVE

    s = ControlSettings()
    assert 100.0 <= nominal.wn_real <= 300.0  # the largest wn the drive's delay allows (control study: 215)
    res = control_robustness(16, nominal=nominal, drive="real", progress=False)
    assert res.drive == "real"
    limit = float(REAL_DRIVE.force_limit)
    for c in CONTROLLERS:
        assert np.all(res.stats[c]["peak_force"] <= limit * (1 + 1e-12))
    # issue 41: a saturated drive's force is its limit: such runs are "at the limit", and a warning says so
    assert res.statistics["linear_pd"]["at_force_limit"] == res.statistics["sdp_pd"]["at_force_limit"] == 1.0
    (near,) = [w for w in res.warnings if w.startswith("at the EMPS drive's limit (peak |F| within 5 %")]
    assert "linear PD in 100" in near and "SDP-PD in 100" in near and near.endswith("(the drive saturates)")
    # one draw equals a direct simulation of that plant through the real drive, SDP-PD at wn_real
    th = res.parameters[5]
    plant = EMPSPlant(th[0], AsymmetricFriction(*th[1:]))
    r = jnp.full(int(round(s.t_real / s.dt)), s.step)
    with jax.enable_x64(True):
        ctrl = SDPPD(nominal.model, wn=nominal.wn_real, eta=s.eta)
        sim = simulate_control(ctrl, r, plant=plant, q0=0.0, drive=REAL_DRIVE)
    np.testing.assert_allclose(res.stats["sdp_pd"]["peak_velocity"][5], float(jnp.max(jnp.abs(sim.dq))), rtol=1e-10)
    with pytest.raises(ValueError, match="drive"):
        control_robustness(4, nominal=nominal, drive="fast", progress=False)


def test_ideal_drive_designs_above_the_drive_limit_are_flagged(nominal):
    """Issue 29: with the ideal drive, the report names the controllers whose peak force exceeds the EMPS
    drive's 351.5 N and in what share of the plants; the default cascade stays near the limit (mean below it)."""
    from jaxsdp.control import REAL_DRIVE

    res = control_robustness(24, nominal=nominal, chunk_size=16, progress=False)
    limit = float(REAL_DRIVE.force_limit)
    (warning,) = [w for w in res.warnings if w.startswith("infeasible on the EMPS drive")]
    assert "linear PD in 100 %" in warning.replace("100.0 %", "100 %") and "SDP-PD in" in warning
    pip = res.statistics["pip_sdp"]
    assert pip["peak_force"]["mean"] < limit and pip["stable_fraction"] == 1.0
    assert ("PIP-SDP in" in warning) == (pip["above_saturation"] > 0)
    # issue 41: runs within 5 % of the limit are counted and named apart from those above it
    pf = np.asarray(res.stats["pip_sdp"]["peak_force"])
    assert pip["at_force_limit"] == np.mean((pf >= 0.95 * limit) & (pf <= limit * (1 + 1e-9)))
    near = [w for w in res.warnings if w.startswith("at the EMPS drive's limit")]
    assert bool(near and "PIP-SDP in" in near[0]) == (pip["at_force_limit"] > 0)


def test_too_few_runs_are_called_so(nominal):
    res = control_robustness(4, nominal=nominal, progress=False)
    assert res.warnings[0].startswith("only 4 run(s): coverages, fractions and spreads from fewer than 30 runs")
    assert not any(w.startswith("only") for w in control_robustness(32, nominal=nominal, progress=False).warnings)


def test_the_results_present_themselves(nominal):
    """Issue 44: each Monte Carlo result is a `Study` that knows its own presentation (no table by type); it is
    immutable, and `with_timings` keeps the run's own figures (`seconds`, `runs_per_second`)."""
    import dataclasses
    import pathlib

    from jaxsdp.studies import montecarlo
    from jaxsdp.studies._contract import Study
    from jaxsdp.studies.montecarlo import control_figures, text_output
    from jaxsdp.studies.montecarlo._report import control_report, control_summary

    res = control_robustness(16, nominal=nominal, progress=False)
    assert isinstance(res, Study) and isinstance(res.warnings, tuple)
    assert res.summary() == control_summary(res) == montecarlo.summary(res)
    assert res.summary()["controllers"] == res.statistics
    assert res.text() == text_output(res) == montecarlo.text(res)
    links = {"mc_envelope": "out/mc_envelope.png"}
    assert res.report({"mc_envelope": "mc_envelope.png"}) == montecarlo.report(res, figures=links)
    assert montecarlo.report(res, figures=links) == control_report(res, [pathlib.Path("mc_envelope.png")])
    assert "![mc_envelope](mc_envelope.png)" in res.report({"mc_envelope": "mc_envelope.png"})
    assert sorted(res.figures()) == sorted(control_figures(res)) == ["mc_envelope", "mc_settling"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.seconds = 0.0
    later = res.with_timings({**res.timings, "figures": 1.5})
    assert later.timings["figures"] == 1.5 and "figures" not in res.timings
    assert (later.seconds, later.runs_per_second) == (res.seconds, res.runs_per_second) and res.seconds > 0
    for fn in (montecarlo.summary, montecarlo.text, montecarlo.figures):
        with pytest.raises(ValueError, match="`result` must be"):
            fn(res.statistics)
