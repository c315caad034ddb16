"""Identification of the EMPS through its closed-loop simulator."""

import numpy as np
import pytest

from helpers import EMPS_MAT, requires_emps
from jaxsdp.data import load_emps
from jaxsdp.plants import (
    AsymmetricFriction,
    EMPSInitial,
    EMPSPlant,
    LinearFriction,
    bang_bang_reference,
    identify_emps_by_simulation,
    simulate_emps,
)

IDIM_LS = np.array([95.1089, 203.5034, 20.3935, -3.1648])
# A reference shaped like one cycle of the benchmark's (bang-bang acceleration,
# velocity plateaus, reversals), with as many samples as the real-data test so
# that both share one compilation.
N = 6240
T = np.arange(N) * 1e-3
QG = np.asarray(
    bang_bang_reference(
        T,
        velocities=[0.042, 0.083, 0.0, 0.125, 0.042, -0.042, -0.083, 0.0, -0.125, -0.042, 0.0],
        switch_times=[0.0, 0.45, 1.25, 1.45, 2.5, 3.05, 3.55, 4.35, 4.55, 5.6, 6.1],
        accel=0.84,
    ).q
)


def _plant(theta):
    return EMPSPlant(theta[0], LinearFriction(*theta[1:]))


@pytest.mark.parametrize("output", ["force", "position"])
def test_recovers_true_parameters_from_30_percent_off(output):
    sim = simulate_emps(QG, plant=_plant(IDIM_LS))
    y = sim.force if output == "force" else sim.q
    res = identify_emps_by_simulation(QG, y, plant0=_plant(1.3 * IDIM_LS), output=output, skip=0)
    np.testing.assert_allclose(np.array(res.estimates), IDIM_LS, rtol=1e-6)
    assert float(res.relative_error) < 1e-5 < float(res.initial_relative_error)


def test_starts_at_the_initial_guess_with_a_negative_offset():
    # A negative initial offset is the start (not its magnitude): the reported
    # initial error is the guess's own output error, and the fit gets back to the truth.
    sim = simulate_emps(QG, plant=_plant(IDIM_LS))
    guess = IDIM_LS * np.array([1.1, 0.9, 1.2, 2.0])  # offset -6.33 N
    res = identify_emps_by_simulation(QG, sim.force, plant0=_plant(guess), skip=0)
    f0 = np.asarray(simulate_emps(QG, plant=_plant(guess)).force)
    expected = 100 * np.linalg.norm(f0 - np.asarray(sim.force)) / np.linalg.norm(np.asarray(sim.force))
    np.testing.assert_allclose(float(res.initial_relative_error), expected, rtol=1e-8)
    np.testing.assert_allclose(np.array(res.estimates), IDIM_LS, rtol=1e-6)


def test_recovers_asymmetric_friction():
    truth = np.array([95.154, 166.7061, 20.144, 240.4236, 20.6277])
    sim = simulate_emps(QG, plant=EMPSPlant(truth[0], AsymmetricFriction(*truth[1:])))
    p0 = EMPSPlant(0.7 * truth[0], AsymmetricFriction(*(0.7 * truth[1:])))
    res = identify_emps_by_simulation(QG, sim.force, plant0=p0, skip=0)
    np.testing.assert_allclose(np.array(res.estimates), truth, rtol=1e-6)


@requires_emps
def test_real_emps_force_error_identification():
    d = load_emps(EMPS_MAT)
    qm, qg = np.asarray(d.qm), np.asarray(d.qg)
    # First of the four repetitions of the benchmark's reference (6.24 s).
    n = N
    force = np.asarray(d.force)[:n]
    res = identify_emps_by_simulation(qg[:n], force, plant0=_plant(1.3 * IDIM_LS), initial=EMPSInitial(q=qm[0]))
    est = np.array(res.estimates)
    print("DIDIM estimates", est, "force error %", float(res.relative_error))
    # Close to IDIM-LS (same data, different estimator) and a better simulated-force fit.
    np.testing.assert_allclose(est, IDIM_LS, rtol=0.08)
    at_idim = simulate_emps(qg[:n], plant=_plant(IDIM_LS), initial=EMPSInitial(q=qm[0])).force
    e_idim = 100 * np.linalg.norm(force[49:] - at_idim[49:]) / np.linalg.norm(force[49:])
    assert float(res.relative_error) < e_idim < 6.5


def test_bad_inputs():
    with pytest.raises(ValueError, match="output"):
        identify_emps_by_simulation(QG, QG, plant0=_plant(IDIM_LS), output="velocity")
    with pytest.raises(ValueError, match="`y`"):
        identify_emps_by_simulation(QG, QG[:-1], plant0=_plant(IDIM_LS))
    with pytest.raises(ValueError, match="plant0"):
        identify_emps_by_simulation(QG, QG, plant0=LinearFriction(1.0, 1.0))
    with pytest.raises(ValueError, match="skip"):
        identify_emps_by_simulation(QG, QG, plant0=_plant(IDIM_LS), skip=len(QG))


def test_output_error_options_set_the_solve():
    """`fit=OutputError(solver, max_steps, throw)`: the step limit is the solver's; bad options fail when made."""
    import optimistix as optx

    from jaxsdp.plants import OutputError

    sim = simulate_emps(QG, plant=_plant(IDIM_LS))
    one = identify_emps_by_simulation(
        QG, sim.force, plant0=_plant(1.3 * IDIM_LS), skip=0, fit=OutputError(optx.LevenbergMarquardt(1e-8, 1e-8), 1)
    )
    assert int(one.num_steps) <= 1 and one.result != optx.RESULTS.successful
    for bad, match in ((dict(max_steps=0), "max_steps"), (dict(solver="lm"), "solver"), (dict(throw=1), "throw")):
        with pytest.raises(ValueError, match=match):
            OutputError(**bad)
    with pytest.raises(ValueError, match="`fit`"):
        identify_emps_by_simulation(QG, sim.force, plant0=_plant(IDIM_LS), fit=optx.LevenbergMarquardt(1e-8, 1e-8))
