"""TX40 link 2 under PD control: eqs. (20)-(21), Table 4 values, data generation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal as ss

from jaxsdp.plants import LinearFriction, PDController, TX40Link2, quintic_reference, simulate_tx40_link2

DT = 2e-4  # 5 kHz
G = 9.81
T = np.arange(0, 4.0, DT)
# Fifth-order rest-to-rest moves of link 2 with dwells (section 3.4.1 excitation).
REF = quintic_reference(
    T,
    knot_times=[0.0, 0.3, 1.0, 1.3, 2.0, 2.3, 3.0, 3.3, 4.0],
    knot_positions=[0.0, 0.0, 1.2, 1.2, -0.6, -0.6, 0.5, 0.5, 0.5],
)
QR = np.asarray(REF.q)


def _regressor(q, dq, ddq):
    return np.c_[ddq, -G * np.cos(q), G * np.sin(q), dq, np.sign(dq), np.ones_like(q)]


def test_defaults_are_table_4_reference_values():
    p = TX40Link2()
    assert (float(p.ZZ2), float(p.MX2), float(p.MY2)) == (1.60, 2.80, 0.0)
    fr = p.friction
    assert (float(fr.Fv), float(fr.Fc), float(fr.offset)) == (5.68, 7.77, 0.0)
    q = jnp.array([0.0, jnp.pi / 2])
    np.testing.assert_allclose(p.gravity(q), [-G * 2.80, 0.0], atol=1e-12)


def test_link2_dataset_satisfies_eq_20_and_idim_recovers_table_4():
    quantum = 2 * np.pi / 2**20  # 20-bit joint encoder
    sim = simulate_tx40_link2(QR, quantum=quantum)
    q, dq, ddq, tau = (np.asarray(x) for x in (sim.q, sim.dq, sim.ddq, sim.tau))
    assert np.abs(q - QR).max() < 0.02  # PD tracking within about a degree
    # Eq. (20) holds sample by sample wherever the link moves (it sticks during dwells).
    moving = dq != 0
    assert 0.3 < moving.mean() < 0.9
    theta_true = np.array([1.60, 2.80, 0.0, 5.68, 7.77, 0.0])
    np.testing.assert_allclose(_regressor(q, dq, ddq)[moving] @ theta_true, tau[moving], atol=1e-9)
    # IDIM-LS from the quantised measurement (zero-phase Butterworth + central differences).
    b, a = ss.butter(4, 100 / 2500)
    qf = ss.filtfilt(b, a, np.asarray(sim.q_meas))
    dqf = np.gradient(qf, DT)
    ddqf = np.gradient(dqf, DT)
    keep = np.abs(dqf) > 0.05
    keep[:100] = keep[-100:] = False
    X = _regressor(qf, dqf, ddqf)[keep]
    theta, *_ = np.linalg.lstsq(X, tau[keep], rcond=None)
    np.testing.assert_allclose(theta[[0, 1, 3, 4]], theta_true[[0, 1, 3, 4]], rtol=0.02)
    assert abs(theta[2]) < 0.05 and abs(theta[5]) < 0.05


def test_substeps_converge():
    a = simulate_tx40_link2(QR)
    b = simulate_tx40_link2(QR, substeps=16)
    assert np.abs(np.asarray(a.q) - np.asarray(b.q)).max() < 1e-9
    assert np.abs(np.asarray(a.dq) - np.asarray(b.dq)).max() < 1e-6


def _loss(theta, qr):
    plant = TX40Link2(theta[0], theta[1], theta[2], LinearFriction(theta[3], theta[4], 0.0))
    ctrl = PDController(kp=theta[5], kd=theta[6])
    sim = simulate_tx40_link2(qr, plant=plant, controller=ctrl)
    return jnp.mean(sim.tau**2) + 1e4 * jnp.mean((sim.q - qr) ** 2)


def test_gradient_matches_central_differences():
    # Reverse-mode gradient (jitted) vs central differences of the eager simulator.
    theta = np.array([1.6, 2.8, 0.1, 5.68, 7.77, 6316.5, 201.1])
    grad = np.asarray(jax.jit(jax.grad(_loss))(theta, QR))
    fd = np.zeros(theta.shape[0])
    for i in range(theta.shape[0]):
        e = np.zeros(theta.shape[0])
        e[i] = 1e-5 * abs(theta[i])
        fd[i] = (float(_loss(theta + e, QR)) - float(_loss(theta - e, QR))) / (2 * e[i])
    np.testing.assert_allclose(grad, fd, rtol=1e-4)


def test_vmap_equals_loop():
    zz = jnp.array([1.4, 1.6, 1.8])
    run = lambda z: simulate_tx40_link2(QR, plant=TX40Link2(ZZ2=z)).tau  # noqa: E731
    batched = jax.vmap(run)(zz)
    for i in range(3):
        np.testing.assert_allclose(batched[i], run(zz[i]), rtol=1e-12, atol=1e-9)


def test_bad_inputs():
    with pytest.raises(ValueError, match="ZZ2"):
        TX40Link2(ZZ2=0.0)
    with pytest.raises(ValueError, match="Fc"):
        TX40Link2(friction=LinearFriction(5.68, -7.77))
    with pytest.raises(ValueError, match="`t`"):
        simulate_tx40_link2(QR[:100], t=T[:99])
    with pytest.raises(ValueError, match="`t`"):
        simulate_tx40_link2(QR[:100], t=-T[:100])
    with pytest.raises(ValueError, match="measurement_noise"):
        simulate_tx40_link2(QR[:100], measurement_noise=np.zeros(99))
    with pytest.raises(ValueError, match="tau_max"):
        PDController(tau_max=-1.0)
    with pytest.raises(ValueError, match="delay"):
        PDController(delay=2)


def test_quintic_via_points_interpolate_position_velocity_acceleration():
    kt = np.array([0.0, 0.4, 0.9, 1.5])
    kq, kv, ka = np.array([0.0, 0.5, -0.2, 0.3]), np.array([0.0, 1.5, -0.8, 0.0]), np.array([0.0, -3.0, 2.0, 0.0])
    t = np.linspace(0.0, 1.6, 16001)
    r = quintic_reference(t, knot_times=kt, knot_positions=kq, knot_velocities=kv, knot_accelerations=ka)
    idx = [int(round(k / 1e-4)) for k in kt[1:-1]]
    np.testing.assert_allclose(np.asarray(r.q)[idx], kq[1:-1], atol=1e-12)
    np.testing.assert_allclose(np.asarray(r.dq)[idx], kv[1:-1], atol=1e-9)
    np.testing.assert_allclose(np.asarray(r.ddq)[idx], ka[1:-1], atol=1e-8)
    # dq and ddq are the derivatives of q (central differences, away from the knots, where the jerk jumps)
    h = t[1] - t[0]
    away = np.min(np.abs(t[:, None] - kt[None, :]), axis=1) > 2.5 * h
    np.testing.assert_allclose(np.gradient(np.asarray(r.q), h)[away], np.asarray(r.dq)[away], atol=1e-5)
    np.testing.assert_allclose(np.gradient(np.asarray(r.dq), h)[away], np.asarray(r.ddq)[away], atol=1e-4)
    # zero velocities and accelerations: the rest-to-rest chain
    a = quintic_reference(t, knot_times=kt, knot_positions=kq)
    s = np.clip((t - 0.4) / 0.5, 0, 1)
    inside = (t >= 0.4) & (t <= 0.9)
    np.testing.assert_allclose(
        np.asarray(a.q)[inside], (0.5 - 0.7 * s**3 * (10 - 15 * s + 6 * s**2))[inside], atol=1e-12
    )
    with pytest.raises(ValueError, match="first and last knot"):
        quintic_reference(t, knot_times=kt, knot_positions=kq, knot_velocities=[1.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="strictly increasing"):
        quintic_reference(t, knot_times=[0.0, 1.0, 0.5], knot_positions=[0.0, 1.0, 0.0])


def test_joint_regressors_and_bases():
    from jaxsdp.plants import friction_basis, gravity_basis, joint_regressors

    q, dq, ddq = np.array([0.3, -1.0]), np.array([0.5, -0.2]), np.array([2.0, 1.0])
    reg = joint_regressors(q, dq, ddq, joint=3)
    assert reg.names == ("ZZ3", "MX3", "MY3", "Fv3", "Fc3", "offset3")
    np.testing.assert_allclose(reg.X, _regressor(q, dq, ddq), atol=1e-15)
    np.testing.assert_allclose(gravity_basis(q).X, _regressor(q, dq, ddq)[:, [1, 2, 5]], atol=1e-15)
    np.testing.assert_allclose(friction_basis(dq).X, _regressor(q, dq, ddq)[:, [3, 4, 5]], atol=1e-15)
    with pytest.raises(ValueError, match="joint"):
        joint_regressors(q, dq, ddq, joint=0)
    with pytest.raises(ValueError, match="1-D of one length"):
        joint_regressors(q, dq[:1], ddq)
