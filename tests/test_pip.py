"""PIP control and the DARE: against scipy, python-control, an independent NMSS build, finite differences."""

import control
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg as sl
import scipy.signal as ss

from jaxsdp.control._dare import solve_dare
from jaxsdp.control._pip import closed_loop_tf, nmss, pip_init, pip_lq, pip_simulate, pip_step

PAPER = ([0.0, 0.0107, -0.0088, 0.0025], [1.0, -1.8660, 0.8706])  # model (30), dt = 0.01 s
# (several cases share the paper's orders n = 2, m = 3, and so their compiled programs)
CASES = {
    "paper": (*PAPER, dict(ew=10.0, uw=1.0, xw=1.0)),
    "first_order": ([0.0, 0.5], [1.0, -0.9], dict(ew=2.0, uw=0.5, xw=3.0)),
    # B = 0.2 z^-1 (1 + z^-1)(1 + 1.5 z^-1): zeros at z = -1 (on the unit circle) and z = -1.5
    "zero_at_minus_one": ([0.0, 0.2, 0.5, 0.3], [1.0, -1.5, 0.7], dict(ew=5.0, uw=1.0, xw=1.0)),
    "m_greater_than_n": ([0.0, 0.1, 0.2, 0.3, 0.1], [1.0, -0.5], dict(ew=1.0, uw=2.0, xw=0.5)),
    "pure_delay": ([0.0, 0.0, 0.3, 0.1], [1.0, -1.2, 0.2], dict(ew=1.0, uw=1.0, xw=1.0)),  # b1 = 0; an integrator
}


def _random_system(rng, n, m, singular=False):
    a = rng.normal(size=(n, n)) * 0.8
    if singular:
        a[-1] = 0.0
    b = rng.normal(size=(n, m))
    c = rng.normal(size=(n, n))
    q = c.T @ c + 0.1 * np.eye(n)
    s = rng.normal(size=(m, m))
    return a, b, q, s @ s.T + np.eye(m)


# --- DARE -------------------------------------------------------------------------------------------


def _np_residual(a, b, q, r, p):
    pa = p @ a
    return a.T @ pa - pa.T @ b @ np.linalg.solve(r + b.T @ p @ b, b.T @ pa) + q - p


def test_dare_matches_scipy():
    rng = np.random.default_rng(0)
    for i in range(6):  # random systems, often open-loop unstable; every other one with a singular A
        a, b, q, r = _random_system(rng, 4, 2, singular=i % 2 == 1)
        expected = sl.solve_discrete_are(a, b, q, r)
        p = np.asarray(solve_dare(a, b, q, r))
        assert np.max(np.abs(p - expected)) <= 1e-9 * np.max(np.abs(expected))
        assert np.array_equal(p, p.T)
        assert np.max(np.abs(_np_residual(a, b, q, r, p))) < 1e-12 * np.max(np.abs(p))


@pytest.mark.parametrize("case", sorted(CASES))
def test_dare_matches_scipy_on_nmss(case):
    num, den, w = CASES[case]
    d = pip_lq(num, den, **w)
    f, g, q, r = (np.asarray(x) for x in (d.F, d.g, d.Q, d.R))
    expected = sl.solve_discrete_are(f, g[:, None], q, r)
    assert np.linalg.matrix_rank(f) < f.shape[0] or case == "first_order"  # F is singular (but for n = m = 1)
    assert np.max(np.abs(np.asarray(d.P) - expected)) <= 1e-9 * np.max(np.abs(expected))
    assert float(d.dare_residual) < 1e-12


def test_dare_derivatives_match_finite_differences():
    rng = np.random.default_rng(3)
    a, b, q, r = _random_system(rng, 3, 2)
    f = lambda a, q: jnp.trace(solve_dare(a, b, q, r)) + solve_dare(a, b, q, r)[0, 1]

    @jax.jit
    def derivatives(a, q, ta, tq):  # value, jvp and gradient (its transpose) from one linearisation
        value, f_jvp = jax.linearize(f, a, q)
        grads = jax.linear_transpose(f_jvp, a, q)(jnp.ones_like(value))
        return value, f_jvp(ta, tq), grads

    ta, tq = rng.normal(size=a.shape), rng.normal(size=q.shape)
    tq = tq + tq.T
    _, tangent, (ga, gq) = (np.asarray(x) if not isinstance(x, tuple) else x for x in derivatives(a, q, ta, tq))
    value = lambda a, q: float(derivatives(a, q, ta, tq)[0])
    h = 1e-6
    for i, j in [(0, 0), (1, 2), (2, 1)]:
        e = np.zeros_like(a)
        e[i, j] = h
        fd_a = (value(a + e, q) - value(a - e, q)) / (2 * h)
        assert np.isclose(float(ga[i, j]), fd_a, rtol=1e-6)
        es = e + e.T if i != j else e  # Q stays symmetric
        fd_q = (value(a, q + es) - value(a, q - es)) / (2 * h)
        assert np.isclose(float(gq[i, j] + (gq[j, i] if i != j else 0.0)), fd_q, rtol=1e-6)
    fd_dir = (value(a + h * ta, q + h * tq) - value(a - h * ta, q - h * tq)) / (2 * h)  # forward mode
    assert np.isclose(float(tangent), fd_dir, rtol=1e-6)
    assert np.isclose(float(tangent), float(np.sum(ga * ta) + np.sum(gq * tq)), rtol=1e-9)


def test_dare_jit_and_vmap_equal_loops():
    rng = np.random.default_rng(5)
    systems = [_random_system(rng, 4, 2, singular=i == 1) for i in range(4)]
    a, b, q, r = (np.stack(x) for x in zip(*systems))
    batched = jax.jit(jax.vmap(solve_dare))(a, b, q, r)
    for i in range(4):
        assert np.allclose(batched[i], solve_dare(a[i], b[i], q[i], r[i]), rtol=1e-12, atol=0)


def test_dare_bad_input():
    a, b, q, r = np.eye(2), np.ones(2), np.eye(2), 1.0
    with pytest.raises(ValueError, match="`b` must have shape"):
        solve_dare(a, np.ones(3), q, r)
    with pytest.raises(ValueError, match="`q` must have the shape"):
        solve_dare(a, b, np.eye(3), r)
    with pytest.raises(ValueError, match="`r` must have shape"):
        solve_dare(a, b, q, np.eye(2))
    with pytest.raises(ValueError, match="NaN or inf"):
        solve_dare(a * np.nan, b, q, r)


# --- NMSS and gains -------------------------------------------------------------------------------


def _nmss_reference(num, den, ew, uw, xw):
    """F, g, Q, R built independently, straight from the state definition."""
    b, a = np.asarray(num, float)[1:], np.asarray(den, float)[1:]
    n, m = len(a), len(b)
    size = n + m
    f, g = np.zeros((size, size)), np.zeros(size)
    f[0, :n] = -a
    f[0, n : n + m - 1] = b[1:]
    g[0] = b[0]
    for i in range(1, n):
        f[i, i - 1] = 1.0
    if m > 1:
        g[n] = 1.0
        for j in range(1, m - 1):
            f[n + j, n + j - 1] = 1.0
    f[-1] = -f[0]
    f[-1, -1] = 1.0
    g[-1] = -g[0]
    q = np.diag([xw / n] * n + [uw / m] * (m - 1) + [ew])
    return f, g, q, np.array([[uw / m]])


@pytest.mark.parametrize("case", sorted(CASES))
def test_gains_match_python_control(case):
    num, den, w = CASES[case]
    f, g, q, r = _nmss_reference(num, den, **w)
    d = pip_lq(num, den, **w)
    for name, ours, ref in (("F", d.F, f), ("g", d.g, g), ("Q", d.Q, q), ("R", d.R, r)):
        assert np.array_equal(np.asarray(ours), ref), name
    k, _, _ = control.dlqr(f, g[:, None], q, r)
    assert np.max(np.abs(np.asarray(d.gains) - k[0])) <= 1e-8 * np.max(np.abs(k))
    named = d.named_gains()
    n, m = len(den) - 1, len(num) - 1
    assert sorted(named) == sorted([f"f{i}" for i in range(n)] + [f"g{j}" for j in range(1, m)] + ["kI"])
    assert np.isclose(float(named["kI"]), -k[0, -1], rtol=1e-8) and float(named["kI"]) > 0


@pytest.mark.parametrize("case", ["paper", "m_greater_than_n"])
def test_nmss_reproduces_the_difference_equation(case):
    num, den, _ = CASES[case]
    s = nmss(num, den)
    rng = np.random.default_rng(1)
    u, r = rng.normal(size=30), rng.normal(size=31)
    a, b = np.asarray(den)[1:], np.asarray(num)[1:]
    n, m = len(a), len(b)
    y = np.zeros(31)
    for k in range(1, 31):
        y[k] = -sum(a[i] * y[k - 1 - i] for i in range(n) if k - 1 - i >= 0) + sum(
            b[j] * u[k - 1 - j] for j in range(m) if k - 1 - j >= 0
        )
    x, z = np.zeros(n + m), r[0] - y[0]
    x[-1] = z
    f, g, d, h = (np.asarray(v) for v in (s.F, s.g, s.d, s.h))
    for k in range(30):
        x = f @ x + g * u[k] + d * r[k + 1]
        z += r[k + 1] - y[k + 1]
        expected = [y[k + 1 - i] if k + 1 - i >= 0 else 0.0 for i in range(n)]
        expected += [u[k - j] if k - j >= 0 else 0.0 for j in range(m - 1)] + [z]
        assert np.allclose(x, expected, atol=1e-12) and np.isclose(h @ x, y[k + 1])


@pytest.mark.parametrize("case", sorted(CASES))
def test_closed_loop_poles_and_type_one(case):
    num, den, w = CASES[case]
    d = pip_lq(num, den, **w)
    acl = np.asarray(d.F) - np.outer(np.asarray(d.g), np.asarray(d.gains))
    eig = np.linalg.eigvals(acl)
    assert np.allclose(np.poly(eig).real, np.asarray(d.cl_den), atol=1e-9)  # charpoly of F - g k
    if case == "paper":  # the property (the other shapes' are checked batched in the vmap test)
        ours = np.asarray(d.closed_loop_poles)
        assert np.allclose(np.poly(ours).real, np.asarray(d.cl_den), atol=1e-9)
        big = np.sort_complex(eig[np.abs(eig) > 1e-3])  # the defective zero eigenvalues are ill-posed
        assert np.allclose(big, np.sort_complex(ours[np.abs(ours) > 1e-3]), atol=1e-9)
        assert np.all(np.diff(np.abs(ours)) <= 1e-12)  # largest modulus first
    assert np.max(np.abs(eig)) < 1.0
    assert np.isclose(np.sum(d.cl_num) / np.sum(d.cl_den), 1.0, rtol=1e-12)  # unity steady-state gain
    sim = pip_simulate(d, num, den, np.ones(400))
    assert abs(float(sim.y[-1]) - 1.0) < 1e-8  # zero steady-state error to a step
    # the simulated step response is the closed-loop TF's
    ref = ss.lfilter(np.asarray(d.cl_num), np.asarray(d.cl_den), np.ones(400))
    assert np.allclose(np.asarray(sim.y), ref, atol=1e-10)


def test_feedback_and_forward_forms():
    num, den, w = CASES["paper"]
    fb, fw = pip_lq(num, den, **w), pip_lq(num, den, form="forward", **w)
    r = np.concatenate([np.zeros(5), np.ones(100), 0.3 * np.ones(295)])
    s1, s2 = pip_simulate(fb, num, den, r), pip_simulate(fw, num, den, r)
    assert np.allclose(s1.y, s2.y, atol=1e-12) and np.allclose(s1.u, s2.u, atol=1e-12)
    plant = ([0.0, 0.013, -0.0088, 0.0025], [1.0, -1.84, 0.85])  # gain and dynamics mismatch
    m1, m2 = pip_simulate(fb, *plant, r), pip_simulate(fw, *plant, r)
    assert np.max(np.abs(m1.y - m2.y)) > 1e-2
    for m in (m1, m2):  # integral action still removes the steady-state error
        assert abs(float(m.y[-1]) - 0.3) < 1e-4


def _serial_cl_den(d, lg):
    """D (G A + LG F B) + LG kI B: the nominal loop with u_applied = LG u_PIP, the controller unaware of LG."""
    k, num, den, n, m = np.asarray(d.gains), np.asarray(d.num), np.asarray(d.den), d.n, d.m
    f, g = k[:n], np.r_[1.0, k[n : n + m - 1]]
    p = np.convolve([1.0, -1.0], np.convolve(g, den) + lg * np.convolve(f, num))
    return p + np.r_[lg * -k[-1] * num, np.zeros(n)]


def test_loop_gain_placements():
    num, den, w = CASES["paper"]
    d, fw = pip_lq(num, den, **w), pip_lq(num, den, form="forward", **w)
    r = np.ones(400)
    # "internal": the state feedback -LG k x on the plant's inputs, i.e. the design with gains LG k
    internal = pip_simulate(d, num, den, r, loop_gain=5.0, loop_gain_mode="internal")
    cl_num, cl_den = closed_loop_tf(d.num, d.den, 5.0 * d.gains, d.n, d.m)
    assert np.allclose(internal.y, ss.lfilter(np.asarray(cl_num), np.asarray(cl_den), r), atol=1e-10)
    assert abs(float(internal.y[-1]) - 1.0) < 1e-8
    same = pip_simulate(fw, num, den, r, loop_gain=5.0, loop_gain_mode="internal")  # the internal model sees LG
    assert np.allclose(same.y, internal.y, atol=1e-12)
    # "serial": u_applied = LG u_PIP
    serial = pip_simulate(d, num, den, r, loop_gain=1.5, loop_gain_mode="serial")
    assert np.allclose(serial.y, ss.lfilter(1.5 * np.asarray(d.cl_num), _serial_cl_den(d, 1.5), r), atol=1e-10)
    # the forward form's internal model misses LG
    unaware = pip_simulate(fw, num, den, r, loop_gain=1.5, loop_gain_mode="serial")
    assert np.max(np.abs(unaware.y - serial.y)) > 1e-2
    # the stability limits quoted in pip_step's docstring
    rho = lambda p: np.max(np.abs(np.roots(p)))
    internal_den = lambda lg: np.asarray(closed_loop_tf(d.num, d.den, lg * d.gains, d.n, d.m)[1])
    assert rho(_serial_cl_den(d, 2.14)) < 1.0 < rho(_serial_cl_den(d, 2.16))
    assert rho(internal_den(5.93)) < 1.0 < rho(internal_den(5.95))


def test_pip_step_and_init():
    num, den, w = CASES["zero_at_minus_one"]
    d = pip_lq(num, den, form="forward", **w)  # (the feedback form's step is the same function)
    r = np.ones(400)
    for mode in ("serial", "internal"):
        sim = pip_simulate(d, num, den, r, loop_gain=1.5, loop_gain_mode=mode)
        s, yp, up = pip_init(d), np.zeros(2), np.zeros(3)
        for k in range(40):
            y = -np.asarray(den)[1:] @ yp + np.asarray(num)[1:] @ up
            if mode == "serial":  # a gain block after the controller
                u, s = pip_step(d, s, r[k], y)
                u = 1.5 * u
            else:
                u, s = pip_step(d, s, r[k], y, loop_gain=1.5, loop_gain_mode="internal")
            yp, up = np.r_[y, yp[:-1]], np.r_[u, up[:-1]]
            assert np.isclose(y, sim.y[k], atol=1e-12) and np.isclose(u, sim.u[k], atol=1e-12)
    # bumpless start at rest at y0: the controller keeps the equilibrium input
    s = pip_init(d, 2.0)
    u0 = 2.0 * sum(den) / sum(num)
    for _ in range(5):
        u, s = pip_step(d, s, 2.0, 2.0)
        assert np.isclose(float(u), u0, rtol=1e-12)


def test_gradients_of_a_closed_loop_cost():
    num, _, _ = CASES["paper"]
    r = jnp.ones(150)

    def cost(w, loop_gain, den):  # sum of squared tracking errors of a unit step
        d = pip_lq(num, den, ew=w[0], uw=w[1], xw=w[2])
        return jnp.sum((r - pip_simulate(d, num, den, r, loop_gain=loop_gain).y) ** 2)

    value_and_grad = jax.jit(jax.value_and_grad(cost, argnums=(0, 1, 2)))  # one compiled program
    f = lambda *args: value_and_grad(*args)[0]
    w, lg, den = jnp.array([10.0, 1.0, 1.0]), jnp.asarray(1.3), jnp.asarray(CASES["paper"][1])
    _, (gw, glg, gden) = value_and_grad(w, lg, den)
    for i in range(3):  # w.r.t. the weights ew, uw, xw
        e = jnp.zeros(3).at[i].set(1e-4 * w[i])
        fd = (f(w + e, lg, den) - f(w - e, lg, den)) / (2e-4 * w[i])
        assert np.isclose(float(gw[i]), float(fd), rtol=1e-5), i
    fd = (f(w, lg + 1e-5, den) - f(w, lg - 1e-5, den)) / 2e-5  # w.r.t. a loop gain on u
    assert np.isclose(float(glg), float(fd), rtol=1e-5)
    for i in (1, 2):  # w.r.t. the model's coefficients (design and plant together)
        e = jnp.zeros(3).at[i].set(1e-6)
        fd = (f(w, lg, den + e) - f(w, lg, den - e)) / 2e-6
        assert np.isclose(float(gden[i]), float(fd), rtol=1e-5), i
    with pytest.raises(Exception, match="`ew`: must be finite and positive"):  # traced: a runtime guard
        jax.block_until_ready(value_and_grad(w.at[0].set(-1.0), lg, den))


def test_vmap_over_designs_equals_a_loop():
    num, den = PAPER
    ews = jnp.array([0.5, 2.0, 10.0, 50.0])
    designs = jax.vmap(lambda ew: pip_lq(num, den, ew=ew))(ews)
    r = jnp.ones(400)
    sims = jax.vmap(lambda d: pip_simulate(d, num, den, r))(designs)
    k_i = designs.named_gains()["kI"]
    for i, ew in enumerate(ews):
        d = pip_lq(num, den, ew=ew)
        assert np.allclose(designs.gains[i], d.gains, rtol=1e-12, atol=0)
        assert np.allclose(designs.cl_den[i], d.cl_den, rtol=1e-12, atol=1e-15)
        assert np.allclose(sims.y[i], pip_simulate(d, num, den, r).y, rtol=1e-12, atol=1e-15)
        assert np.isclose(k_i[i], d.named_gains()["kI"], rtol=1e-12)
    poles = np.asarray(designs.closed_loop_poles)  # batched eigenvalues, largest first
    assert poles.shape == (4, 5) and np.all(np.diff(np.abs(poles), axis=1) <= 1e-12)
    for i in range(4):
        assert np.allclose(np.poly(poles[i]).real, designs.cl_den[i], atol=1e-9)


@pytest.mark.parametrize(
    "num,den,kwargs,match",
    [
        ([0.0, 1.0], [2.0, -1.0], {}, "monic"),
        ([0.0, 1.0], [0.0, 1.0, -0.5], {}, "zero leading coefficient"),
        ([0.1, 1.0], [1.0, -0.5], {}, "b0 = num\\[0\\] must be 0"),
        ([0.0], [1.0, -0.5], {}, "m >= 1"),
        ([0.0, 1.0], [1.0, -0.5], dict(ew=0.0), "`ew`: must be finite and positive"),
        ([0.0, 1.0], [1.0, -0.5], dict(uw=-1.0), "`uw`: must be finite and positive"),
        ([0.0, 1.0], [1.0, -0.5], dict(xw=np.nan), "`xw`: must be finite and positive"),
        ([0.0, 1.0], [1.0, -0.5], dict(ew=[1.0, 2.0]), "`ew` must be a scalar"),
        ([[0.0, 1.0]], [1.0, -0.5], {}, "`num` must be a non-empty 1-D"),
        ([0.0, 1.0], [1.0, -0.5], dict(form="observer"), "`form` must be one of"),
        ([0.0, np.nan], [1.0, -0.5], {}, "NaN or inf"),
    ],
)
def test_bad_input(num, den, kwargs, match):
    with pytest.raises(ValueError, match=match):
        pip_lq(num, den, **kwargs)


def test_bad_simulation_input():
    d = pip_lq(*PAPER)
    with pytest.raises(ValueError, match="`r` must be 1-D"):
        pip_simulate(d, *PAPER, np.ones((10, 2)))
    with pytest.raises(ValueError, match="plant: b0"):
        pip_simulate(d, [0.1, 0.01], [1.0, -0.9], np.ones(10))
    with pytest.raises(ValueError, match="`y` must be 0-D"):
        pip_step(d, pip_init(d), 1.0, np.ones(2))
    with pytest.raises(ValueError, match="`loop_gain_mode` must be one of"):
        pip_simulate(d, *PAPER, np.ones(10), loop_gain_mode="parallel")
    with pytest.raises(ValueError, match="`state` does not fit this design"):
        pip_step(d, pip_init(pip_lq([0.0, 0.5], [1.0, -0.9])), 1.0, 0.0)


def test_no_integral_action_or_no_stabilising_solution():
    with pytest.raises(ValueError, match="integral action is impossible"):
        pip_lq([0.0, 1.0, -1.0], [1.0, -0.5])
    b = 0.3 * np.poly([1.0, 0.5])  # (1 - z^-1)(1 - 0.5 z^-1): B(1) is 0 up to rounding
    with pytest.raises(ValueError, match="integral action is impossible"):
        pip_lq(np.r_[0.0, b], [1.0, -1.2, 0.3])
    with pytest.raises(ValueError, match="no stabilising LQ solution"):  # A and B share the unstable root z = 2
        pip_lq([0.0, 1.0, -1.5, -1.0], [1.0, -2.5, 1.0])  # B = z^-1 (1 - 2 z^-1)(1 + 0.5 z^-1)
