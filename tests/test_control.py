"""SDP control model, friction forms, SDP-PD and the linear PD on the continuous EMPS plant."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxsdp.control import (
    REAL_DRIVE,
    SDPPD,
    Drive,
    LinearPD,
    control_model,
    sdp_friction,
    simulate_control,
    step_metrics,
    tracking_cost,
    true_plant,
)
from jaxsdp.plants import EMPSInitial, EMPSPlant, LinearFriction

TABLE1 = dict(M=95.08, Fv=202.30, Fc=20.53, offset=-3.19)


def exact_model():
    """A control model whose friction is exactly the true plant's."""
    p = true_plant()
    return control_model(dict(M=float(p.M), Fv=200.0, Fc=20.0, offset=0.0), friction=p.friction)


def synthetic_curve(n=801):
    v = np.linspace(-0.2, 0.2, n)
    f = np.where(v > 0, 170 * v + 20, 240 * v - 20) * (1 - np.exp(-np.abs(v) / 0.005))
    return v, f


def test_control_model_coefficients_from_table1():
    mdl = control_model(TABLE1)
    assert np.allclose([mdl.c1, mdl.c3, mdl.c4], [-2.1277, 0.0336, 0.0105], atol=6e-5)
    assert np.isclose(mdl.c2, -20.53 / 95.08)
    # a_sdp(dq) dq is the friction deceleration, finite at 0 (offset only there).
    assert np.isclose(mdl.a_dq(0.0), -3.19 / 95.08)
    assert np.isclose(mdl.a_dq(0.1) / 0.1, mdl.a_sdp(0.1))
    assert np.isnan(mdl.a_sdp(0.0))


def test_control_model_from_idim_result():
    from jaxsdp import idim_ls

    rng = np.random.default_rng(0)
    x = rng.normal(size=(200, 4))
    theta = np.array([95.0, 200.0, 20.0, -3.0])
    res = idim_ls(x @ theta + 0.01 * rng.normal(size=200), x, names=("M", "Fv", "Fc", "offset"))
    mdl = control_model(res)
    assert np.isclose(mdl.c4, 1 / res["M"])


@pytest.mark.parametrize(
    "idim, match",
    [(dict(M=95.0, Fv=200.0), "missing"), (dict(M=-1.0, Fv=1.0, Fc=1.0, offset=0.0), "M"), ([1, 2], "IDIM-LS")],
)
def test_control_model_bad_input(idim, match):
    with pytest.raises(ValueError, match=match):
        control_model(idim)


def test_hybrid_friction_inside_and_beyond():
    v, f = synthetic_curve()
    law = sdp_friction(v, f, form="hybrid")
    # Beyond the data: the lines fitted on each side (exact here: the curve is linear there).
    assert np.allclose(law(np.array([-1.0, 0.5])), [-260.0, 105.0], atol=0.05)
    # Inside: the curve (bin means), continuous across zero.
    inside = np.array([-0.15, -0.05, 0.05, 0.15])
    assert np.allclose(law(inside), np.interp(inside, v, f), atol=0.5)
    tab = sdp_friction(v, f, form="tabulated")
    assert np.allclose(tab(np.array([-1.0, 1.0])), tab(np.array([-0.2, 0.2])), atol=1e-9)  # held beyond the data


@pytest.mark.parametrize(
    "case, match",
    [("gap", "gap"), ("nan", "NaN"), ("one-sided", "each side"), ("form", "form"), ("shape", "equal length")],
)
def test_sdp_friction_bad_input(case, match):
    v, f = synthetic_curve()
    kwargs = {}
    if case == "gap":
        keep = (v < 0.02) | (v > 0.09)
        v, f = v[keep], f[keep]
    elif case == "nan":
        f = f.copy()
        f[3] = np.nan
    elif case == "one-sided":
        v, f = v[v > 0], f[v > 0]
    elif case == "form":
        kwargs = dict(form="spline")
    elif case == "shape":
        f = f[:-1]
    with pytest.raises(ValueError, match=match):
        sdp_friction(v, f, **kwargs)


def test_sdp_pd_with_exact_compensation_is_the_analytic_second_order():
    # Ideal velocity sensor, no delay: as dt -> 0 the digital loop tends to
    # x = r (1 - (1 + wn t) exp(-wn t)) (eta = 1); the error is O(wn dt).
    wn, step = 250.0, 0.05
    errors = []
    for dt in (2e-5, 1e-5):
        n = int(0.06 / dt)
        sim = simulate_control(SDPPD(exact_model(), wn=wn, velocity="state"), np.full(n, step), q0=0.0, dt=dt)
        t = np.asarray(sim.t)
        x = step * (1 - (1 + wn * t) * np.exp(-wn * t))
        errors.append(np.max(np.abs(np.asarray(sim.q) - x)) / step)
    assert errors[1] < 2e-3
    assert 1.7 < errors[0] / errors[1] < 2.3  # first order in dt


def test_fig14_setting_sdp_pd_fast_and_linear_pd_oscillatory():
    r = np.full(400, 0.05)
    sdp = simulate_control(SDPPD(exact_model(), wn=250.0), r, q0=0.0)
    lin = simulate_control(LinearPD(), r, q0=0.0)
    ms = step_metrics(sdp.t, sdp.q, 0.05, y0=0.0)
    ml = step_metrics(lin.t, lin.q, 0.05, y0=0.0)
    assert ms.settling_time < 0.035 and ms.overshoot < 1.0
    # The independent check of the issue: 0.083 s and 28 % overshoot.
    assert abs(ml.settling_time - 0.083) <= 0.002 and abs(ml.overshoot - 28.0) < 1.5
    assert ml.settling_time > 2.5 * ms.settling_time


def test_real_drive_delay_and_saturation():
    r = np.full(400, 0.05)
    ctrl = SDPPD(exact_model(), wn=250.0)
    delayed = simulate_control(ctrl, r, q0=0.0, drive=Drive(delay=1))
    assert np.allclose(delayed.force[1:], delayed.command[:-1]) and delayed.force[0] == 0
    m250 = step_metrics(delayed.t, delayed.q, 0.05, y0=0.0)
    m200 = step_metrics(
        *(lambda s: (s.t, s.q))(simulate_control(SDPPD(exact_model(), wn=200.0), r, q0=0.0, drive=Drive(delay=1))),
        0.05,
        y0=0.0,
    )
    assert m250.overshoot > 10 and m250.settling_time > 0.15  # rings
    assert m200.overshoot < 2 and m200.settling_time < 0.04
    sat = simulate_control(ctrl, r, q0=0.0, drive=REAL_DRIVE)
    assert np.max(np.abs(sat.force)) <= 351.51 and np.max(np.abs(sat.command)) > 1e4


def test_vmap_over_designs_equals_loop_and_gradient_matches_fd():
    r = jnp.full(150, 0.05)
    mdl = exact_model()

    def cost(wn):
        sim = simulate_control(SDPPD(mdl, wn=wn), r, q0=0.0, drive=Drive(delay=1))
        return tracking_cost(sim.t, sim.q, sim.r, dq=sim.dq, v_max=5.0)

    wns = jnp.array([150.0, 200.0, 230.0])
    batched = jax.vmap(cost)(wns)
    looped = jnp.stack([cost(w) for w in wns])
    assert np.allclose(batched, looped, rtol=1e-12)
    g = jax.grad(cost)(200.0)
    h = 1e-3
    fd = (cost(200.0 + h) - cost(200.0 - h)) / (2 * h)
    assert np.isclose(g, fd, rtol=1e-4)


def test_simulate_control_bad_input():
    with pytest.raises(ValueError, match="AbstractController"):
        simulate_control(object(), np.zeros(10))
    with pytest.raises(ValueError, match="delay"):
        Drive(delay=2)
    with pytest.raises(ValueError, match="force_limit"):
        Drive(force_limit=-1.0)
    with pytest.raises(ValueError, match="wn"):
        SDPPD(exact_model(), wn=-1.0)
    with pytest.raises(ValueError, match="reference"):
        simulate_control(LinearPD(), np.array([0.0, np.nan, 0.0]))
    plant = EMPSPlant(95.0, LinearFriction(200.0, 20.0))
    with pytest.raises(ValueError, match="at least 2"):
        simulate_control(LinearPD(), np.zeros(1), plant=plant)


def test_benchmark_controller_and_linear_pd_on_the_real_drive_are_one_loop():
    """`simulate_emps` (the benchmark controller, command in V) and `simulate_control(LinearPD(), drive=
    REAL_DRIVE)` (the same law as a force command, the drive's delay and +-10 V gtau limit) run the one
    closed-loop simulator of the axis: the same trajectories, up to the rounding of gtau kv (...) against
    gtau (kv (...)), on a reference that saturates the drive."""
    from jaxsdp.plants import EMPSController, bang_bang_reference, simulate_emps

    t = np.arange(3000) * 1e-3
    ref = bang_bang_reference(t, velocities=[0.1, -0.05, 0.0], switch_times=[0.1, 1.0, 2.0], accel=30.0)
    plant = true_plant()
    a = simulate_emps(ref.q, plant=plant, controller=EMPSController(), initial=EMPSInitial(q=0.0))
    b = simulate_control(LinearPD(), ref.q, plant=plant, drive=REAL_DRIVE, q0=0.0)
    assert float(np.max(np.abs(a.force))) == pytest.approx(351.5, rel=1e-3)  # the drive saturates
    np.testing.assert_allclose(b.force, a.force, rtol=0, atol=1e-9 * 351.5)
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-12)
    inside = np.abs(np.asarray(b.command)) < 351.0  # unsaturated: the command is gtau vir
    gtau = float(EMPSController().gtau)
    np.testing.assert_allclose(np.asarray(b.command)[inside], gtau * np.asarray(a.vir)[inside], rtol=1e-9, atol=1e-9)
