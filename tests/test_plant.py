"""EMPS closed-loop simulator, friction models, trajectories and noise."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import EMPS_MAT, requires_emps
from jaxsdp import butter_derivatives
from jaxsdp.data import load_emps
from jaxsdp.plants import (
    AsymmetricFriction,
    EMPSController,
    EMPSInitial,
    EMPSPlant,
    LinearFriction,
    TabulatedFriction,
    bang_bang_reference,
    encoder_quantum,
    measure,
    quantise,
    quintic_reference,
    simulate_emps,
    step_reference,
    white_noise,
)
from jaxsdp.plants._stick_slip import stick_slip_step as _stick_slip_step

M, FV, FC, OFF = 95.1089, 203.5034, 20.3935, -3.1648
DT = 1e-3
T = np.arange(450) * DT
# Forward move, reversal, stop: exercises zero crossings and sticking.
REF = bang_bang_reference(T, velocities=[0.05, -0.05, 0.0], switch_times=[0.02, 0.15, 0.30], accel=0.84)
QG = np.asarray(REF.q)


def rel(a, b):
    return 100 * np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(np.asarray(a))


# ---------------------------------------------------------------- friction


def test_friction_values_and_sign_convention():
    lin = LinearFriction(FV, FC, OFF)
    v = jnp.array([-0.1, 0.0, 0.2])
    np.testing.assert_allclose(lin(v), [-0.1 * FV - FC + OFF, OFF, 0.2 * FV + FC + OFF])
    asym = AsymmetricFriction(166.7, 20.1, 240.4, 20.6, 0.5)
    np.testing.assert_allclose(asym(v), [-0.1 * 240.4 - 20.6 + 0.5, 0.5 + (20.1 - 20.6) / 2, 0.2 * 166.7 + 20.1 + 0.5])


def test_tabulated_interpolation_and_linear_extrapolation():
    tab = TabulatedFriction([-0.1, -0.05, 0.0, 0.05, 0.1], [-30.0, -25.0, 0.0, 24.0, 32.0])
    v = jnp.array([-0.2, -0.075, 0.025, 0.1, 0.3])
    # Inside: linear interpolation. Outside: slope of the end segments.
    expected = [-30.0 - 0.1 * 100.0, -27.5, 12.0, 32.0, 32.0 + 0.2 * 160.0]
    np.testing.assert_allclose(tab(v), expected, rtol=1e-12)
    np.testing.assert_allclose(tab(jnp.array(0.0)), 0.0)


# The linear law as a table that repeats v = 0 (f(0-) at the first zero, f(0+) at
# the second). Tables in these tests all have 40 knots so that they share compilations.
_VG = np.r_[np.linspace(-1.0, 0.0, 20), np.linspace(0.0, 1.0, 20)]
JUMP_TABLE = TabulatedFriction(_VG, FV * _VG + FC * np.where(np.arange(40) >= 20, 1.0, -1.0) + OFF)


def test_tabulated_with_coulomb_jump_equals_linear_model():
    pick = _VG[[0, 10, 30, 39]]
    np.testing.assert_allclose(JUMP_TABLE(pick), LinearFriction(FV, FC, OFF)(pick))
    sim_lin = simulate_emps(QG)
    sim_tab = simulate_emps(QG, plant=EMPSPlant(M, JUMP_TABLE))
    np.testing.assert_allclose(sim_tab.q, sim_lin.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sim_tab.force, sim_lin.force, rtol=0, atol=1e-8)


def test_tabulated_continuous_curve_converges_with_substeps():
    # Smooth Coulomb-like transition (no jump, same grid size as above: one compilation):
    # the local-linearisation scheme is already accurate with one sub-step per sample.
    vg = np.linspace(-0.2, 0.2, 40)
    plant = EMPSPlant(M, TabulatedFriction(vg, FV * vg + FC * np.tanh(vg / 0.005) + OFF))
    one = simulate_emps(QG, plant=plant)
    eight = simulate_emps(QG, plant=plant, substeps=8)
    assert np.abs(np.asarray(one.q) - np.asarray(eight.q)).max() < 1e-7  # q ~ 2e-3 m
    assert rel(eight.force, one.force) < 0.1


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: LinearFriction(-1.0, FC), "Fv"),
        (lambda: LinearFriction(FV, -0.1), "Fc"),
        (lambda: AsymmetricFriction(1.0, 1.0, -1.0, 1.0), "Fv_neg"),
        (lambda: AsymmetricFriction(1.0, -1.0, 1.0, 1.0), "Fc_pos"),
        (lambda: TabulatedFriction([0.0, -1.0], [0.0, 1.0]), "v_grid"),
        (lambda: TabulatedFriction([0.0, 1.0, 2.0], [0.0, 1.0]), "v_grid"),
        (lambda: EMPSPlant(0.0), "M"),
        (lambda: EMPSPlant(-95.0), "M"),
    ],
)
def test_non_physical_parameters_raise(make, name):
    with pytest.raises(ValueError, match=name):
        make()


# ------------------------------------------------------- Coulomb / stick-slip


_jit_step = jax.jit(_stick_slip_step)


def _step(q0, v0, u, h):
    fr = jax.tree_util.tree_map(jnp.asarray, LinearFriction(FV, FC, OFF))
    q0, v0, u, mass, h = (jnp.asarray(x, dtype=jnp.float64) for x in (q0, v0, u, M, h))
    q, v = _jit_step(q0, v0, u, mass, fr, h)
    return float(q), float(v)


def test_sticks_exactly_below_breakaway():
    # |u - offset| <= Fc: a mass at rest stays exactly at rest (no creep, unlike a smoothed sign).
    for u in (OFF + FC * 0.999, OFF - FC * 0.999, OFF):
        assert _step(0.1, 0.0, u, 0.5) == (0.1, 0.0)


def test_breakaway_from_rest_matches_closed_form():
    u, h = OFF + FC + 50.0, 0.02
    q, v = _step(0.0, 0.0, u, h)
    a = u - FC - OFF
    v_ref = a / FV * (1 - math.exp(-FV * h / M))
    q_ref = a / FV * (h - M / FV * (1 - math.exp(-FV * h / M)))
    assert v == pytest.approx(v_ref, rel=1e-13)
    assert q == pytest.approx(q_ref, rel=1e-12)


def test_deceleration_stops_at_exact_time_and_sticks():
    # u = offset: M dv/dt = -Fv v - Fc until v = 0 at t* = M/Fv log(1 + Fv v0 / Fc), then sticks.
    v0 = 0.05
    t_stop = M / FV * math.log1p(FV * v0 / FC)
    q_stop = (M / FV) * (v0 + FC / FV) * (1 - math.exp(-FV * t_stop / M)) - FC / FV * t_stop
    for h in (0.5 * t_stop, 1.5 * t_stop, 10 * t_stop):
        q, v = _step(0.0, v0, OFF, h)
        if h < t_stop:
            assert v > 0
        else:
            assert v == 0.0
            assert q == pytest.approx(q_stop, rel=1e-12)


def test_reversal_through_zero_is_exact():
    # Crossing then moving the other way: one step equals a fine composition and the
    # analytic two-phase solution.
    v0, u, h = 0.01, OFF - FC - 300.0, 0.004
    q1, v1 = _step(0.0, v0, u, h)
    q, v = 0.0, v0
    for _ in range(13):
        q, v = _step(q, v, u, h / 13)
    assert (q1, v1) == pytest.approx((q, v), rel=1e-11)
    a1, a2 = u - FC - OFF, u + FC - OFF
    t_star = M / FV * math.log1p(-FV * v0 / a1)
    q_star = v0 * M / FV * (1 - math.exp(-FV * t_star / M)) + a1 / FV * (
        t_star - M / FV * (1 - math.exp(-FV * t_star / M))
    )
    r = h - t_star
    v_ref = a2 / FV * (1 - math.exp(-FV * r / M))
    q_ref = q_star + a2 / FV * (r - M / FV * (1 - math.exp(-FV * r / M)))
    assert v1 == pytest.approx(v_ref, rel=1e-11)
    assert q1 == pytest.approx(q_ref, rel=1e-11)


def test_closed_loop_step_is_an_exact_flow():
    # An exact flow satisfies phi_h = (phi_{h/n})^n; any approximate scheme for the
    # discontinuous ODE would not, to this precision. (Run on the tabulated form of
    # the linear law, shown identical to LinearFriction above, to share compilations.)
    a = simulate_emps(QG, plant=EMPSPlant(M, JUMP_TABLE))
    b = simulate_emps(QG, plant=EMPSPlant(M, JUMP_TABLE), substeps=8)
    assert np.any(np.asarray(a.dq) == 0.0)  # the run contains sticking phases
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(b.dq, a.dq, rtol=0, atol=1e-11)


def _reference_closed_loop(qg, n_sub):
    """Independent brute-force simulation: the controller written out and the plant
    integrated with explicit sub-steps and Karnopp-style stick detection."""
    c = EMPSController()
    kp, kv, gtau = float(c.kp), float(c.kv), float(c.gtau)
    q, v = float(qg[0]), 0.0
    qm_prev, qf_prev, vir_prev = q, q, 0.0
    qs, fs = [], []
    h = DT / n_sub
    for k in range(len(qg)):
        qf = 0.5 * q + 0.5 * qm_prev
        vir = min(10.0, max(-10.0, kv * (kp * (qg[k] - q) - (qf - qf_prev) / DT)))
        u = gtau * vir_prev
        qs.append(q)
        fs.append(u)
        qm_prev, qf_prev, vir_prev = q, qf, vir
        for _ in range(n_sub):
            if v == 0.0 and abs(u - OFF) <= FC:
                continue
            s = math.copysign(1.0, v) if v != 0.0 else math.copysign(1.0, u - OFF)
            vn = v + h * (u - FV * v - FC * s - OFF) / M
            if v != 0.0 and vn * v < 0:
                vn = 0.0
            q += 0.5 * h * (v + vn)
            v = vn
    return np.array(qs), np.array(fs)


def test_agrees_with_brute_force_reference():
    q_ref, f_ref = _reference_closed_loop(QG, 200)
    sim = simulate_emps(QG)
    assert np.abs(np.asarray(sim.q) - q_ref).max() < 1e-8
    assert rel(f_ref[5:], np.asarray(sim.force)[5:]) < 0.05


def test_identity_of_sampled_signals():
    # M ddq = force - f(dq) at every sample where the mass moves, and q_meas = q.
    sim = simulate_emps(QG)
    fr = LinearFriction(FV, FC, OFF)
    moving = np.asarray(sim.dq) != 0
    lhs = M * np.asarray(sim.ddq)[moving]
    rhs = np.asarray(sim.force - fr(sim.dq))[moving]
    np.testing.assert_allclose(lhs, rhs, rtol=1e-10, atol=1e-9)
    np.testing.assert_array_equal(sim.q_meas, sim.q)
    # Force is the controller output delayed by one sample.
    c = EMPSController()
    np.testing.assert_allclose(sim.force[1:], float(c.gtau) * sim.vir[:-1])
    assert sim.force[0] == 0.0


# ----------------------------------------------------------- real data


@requires_emps
def test_validation_on_real_emps_data():
    d = load_emps(EMPS_MAT)
    # Standard processing of the measurement: 4th-order zero-phase Butterworth at
    # 100 Hz (MATLAB filtfilt padding) and central differences.
    meas = butter_derivatives(d.qm, DT, cutoff_hz=100.0)
    sim = simulate_emps(d.qg, plant=EMPSPlant(M, LinearFriction(FV, FC, OFF)), initial=EMPSInitial(q=d.qm[0]))
    k = slice(49, None)  # as the benchmark script: drop the first 49 samples
    # Measured: processed as above; simulated: plant states used directly (as the
    # benchmark's script does); force: gtau * vir measured vs force acting on the plant.
    e_q = rel(meas.q[k], sim.q[k])
    e_dq = rel(meas.dq[k], sim.dq[k])
    e_ddq = rel(meas.ddq[k], sim.ddq[k])
    e_f = rel(d.force[k], sim.force[k])
    print(f"EMPS validation: q {e_q:.4f} %  dq {e_dq:.4f} %  ddq {e_ddq:.3f} %  force {e_f:.3f} %")
    assert e_q <= 0.02
    assert e_dq <= 0.3
    assert e_f <= 6.0
    assert e_ddq <= 10.0  # published: 8.60 %
    # Against the raw (quantised) measured position as well.
    assert rel(d.qm[k], sim.q[k]) <= 0.02


# ------------------------------------------------ differentiability, vmap


def _loss(theta, qg):
    plant = EMPSPlant(theta[0], LinearFriction(theta[1], theta[2], theta[3]))
    ctrl = EMPSController(kp=theta[4], kv=theta[5])
    sim = simulate_emps(qg, plant=plant, controller=ctrl)
    return jnp.mean(sim.force**2) * 1e-3 + jnp.mean((sim.q - qg) ** 2) * 1e8


_jit_grad = jax.jit(jax.grad(_loss))
THETA = np.array([M, FV, FC, OFF, 160.18, 243.45])


def test_gradient_matches_central_differences():
    # Reverse-mode gradient (jitted) vs central differences of the eager simulator.
    grad = np.asarray(_jit_grad(THETA, QG))
    fd = np.zeros(6)
    for i in range(6):
        e = np.zeros(6)
        e[i] = 1e-5 * abs(THETA[i])
        fd[i] = (float(_loss(THETA + e, QG)) - float(_loss(THETA - e, QG))) / (2 * e[i])
    np.testing.assert_allclose(grad, fd, rtol=1e-5)


def test_vmap_equals_loop_over_plants_and_noise_keys():
    Ms = jnp.array([80.0, 95.0, 110.0])
    keys = jax.random.split(jax.random.key(0), 3)
    qg = jnp.asarray(QG)

    def run(m, key):
        noise = white_noise(key, qg.shape[0], sigma=1e-6)
        return simulate_emps(qg, plant=EMPSPlant(m), measurement_noise=noise).force

    batched = jax.vmap(run)(Ms, keys)
    for i in range(3):
        np.testing.assert_allclose(batched[i], run(Ms[i], keys[i]), rtol=1e-12, atol=1e-9)


def test_encoder_quantisation_in_loop():
    quantum = encoder_quantum()
    assert quantum == pytest.approx(5e-8)
    sim = simulate_emps(QG, quantum=quantum)
    counts = np.asarray(sim.q_meas) / quantum
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    assert np.abs(np.asarray(sim.q_meas) - np.asarray(sim.q)).max() <= quantum / 2 + 1e-15


# ------------------------------------------------------------- bad input


def test_bad_inputs_raise_value_error_naming_the_argument():
    with pytest.raises(ValueError, match="`t`"):
        simulate_emps(QG, t=T[::-1])
    with pytest.raises(ValueError, match="`t`"):
        simulate_emps(QG, t=np.r_[T[:10], T[9], T[11:]])
    with pytest.raises(ValueError, match="`t`"):
        simulate_emps(QG, t=T[:-1])
    with pytest.raises(ValueError, match="measurement_noise"):
        simulate_emps(QG, measurement_noise=np.zeros(10))
    with pytest.raises(ValueError, match="`qg`"):
        simulate_emps(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="`qg`"):
        simulate_emps(np.r_[0.0, np.nan])
    with pytest.raises(ValueError, match="substeps"):
        simulate_emps(QG, substeps=0)
    with pytest.raises(ValueError, match="`M`"):
        simulate_emps(QG, plant=EMPSPlant(-1.0))
    # Parameters that bypassed the constructor (e.g. produced by tree manipulation).
    import equinox as eqx

    bad = eqx.tree_at(lambda p: p.friction.Fc, EMPSPlant(), np.float64(-1.0))
    with pytest.raises(ValueError, match="Fc"):
        simulate_emps(QG, plant=bad)
    bad_m = eqx.tree_at(lambda p: p.M, EMPSPlant(), np.float64(0.0))
    with pytest.raises(ValueError, match="M"):
        simulate_emps(QG, plant=bad_m)


def test_traced_non_physical_parameters_are_caught_under_jit():
    for i, name in [(0, "M"), (2, "Fc")]:
        bad = THETA.copy()
        bad[i] = -1.0
        with pytest.raises(Exception, match=name):
            jax.block_until_ready(_jit_grad(bad, QG))


# ----------------------------------------------------------- trajectories


def test_trajectory_derivatives_are_consistent():
    t = np.arange(0, 2.0, 1e-4)
    refs = [
        bang_bang_reference(t, velocities=[0.04, 0.12, -0.08, 0.0], switch_times=[0.1, 0.5, 1.0, 1.6], accel=0.84),
        quintic_reference(t, knot_times=[0.0, 0.3, 0.9, 1.2, 1.8], knot_positions=[0.0, 0.0, 1.0, 1.0, -0.5]),
    ]
    for r in refs:
        q, dq, ddq = (np.asarray(x) for x in r)
        np.testing.assert_allclose(np.gradient(q, 1e-4)[2:-2], dq[2:-2], atol=1e-3 * np.abs(dq).max())
        inner = np.abs(np.gradient(dq, 1e-4) - ddq)[2:-2]
        assert np.median(inner) < 1e-6 * np.abs(ddq).max() + 1e-9
    bb = refs[0]
    assert set(np.round(np.unique(np.asarray(bb.ddq)), 6)) <= {-0.84, 0.0, 0.84}
    qu = refs[1]
    np.testing.assert_allclose(np.asarray(qu.q)[[0, 3000, 9000, 12000]], [0.0, 0.0, 1.0, 1.0], atol=1e-12)
    assert abs(float(qu.q[-1]) + 0.5) < 1e-12


def test_step_reference():
    t = np.arange(0, 1.0, 0.01)
    r = step_reference(t, step_times=[0.2, 0.5], levels=[0.05, -0.02], q0=0.01)
    q = np.asarray(r.q)
    assert q[0] == pytest.approx(0.01) and q[30] == pytest.approx(0.05) and q[-1] == pytest.approx(-0.02)


def test_noise_is_reproducible_and_vmappable():
    q = jnp.linspace(0.0, 0.01, 500)
    key = jax.random.key(42)
    a = measure(key, q, sigma=1e-6, quantum=5e-8)
    b = measure(key, q, sigma=1e-6, quantum=5e-8)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, measure(jax.random.key(1), q, sigma=1e-6, quantum=5e-8))
    keys = jax.random.split(key, 4)
    batch = jax.vmap(lambda k: measure(k, q, sigma=1e-6))(keys)
    np.testing.assert_allclose(batch[2], measure(keys[2], q, sigma=1e-6))
    noise = np.asarray(batch - q)
    assert 0.8e-6 < noise.std() < 1.2e-6
    np.testing.assert_allclose(quantise(jnp.array([1.24e-7, -2.6e-7]), 5e-8), [1.0e-7, -2.5e-7])
