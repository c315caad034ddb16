"""SRIVC: exact recovery on noise-free data, Monte Carlo bias and standard errors, bad input, jit and vmap.

Data are simulated exactly at the samples for a ZOH input with scipy
(cont2discrete + lfilter), independently of jaxsdp's code path.
"""

import jax
import jax.scipy.linalg as jsl
import numpy as np
import pytest

from helpers import prbs
from helpers import zoh_simulate as simulate
from jaxsdp.tfest import RIVSolver
from jaxsdp.tfest._srivc import CONVERGED, MAX_ITER, srivc
from jaxsdp.tfest._zoh import expm_taylor

# The CONTSID benchmark (Rao and Garnier): poles 2 and 20 rad/s, damping 0.25 and 0.1.
BENCH_NUM, BENCH_DEN = [-6400.0, 1600.0], [1.0, 5.0, 408.0, 416.0, 1600.0]
BENCH_DT, BENCH_N = 0.02, 2000
LOW_NUM, LOW_DEN, LOW_DT, LOW_N = [2.0, 1.0], [1.0, 1.5, 4.0], 0.05, 400


def theta(num, den):
    return np.r_[den[1:], num]


def assert_recovered(res, num, den, tol=1e-6):
    true = theta(num, den)
    rel = np.abs(np.asarray(res.theta) - true) / np.abs(true)
    assert np.max(rel) < tol, (np.asarray(res.theta), true)
    assert bool(res.converged) and int(res.status) == CONVERGED and res.reason == "converged"
    assert bool(res.stable)


@pytest.fixture(scope="module")
def low():
    u = prbs(LOW_N, 4, seed=0)
    return u, simulate(LOW_NUM, LOW_DEN, u, LOW_DT)


@pytest.fixture(scope="module")
def bench():
    u = prbs(BENCH_N, 3, seed=1)
    return u, simulate(BENCH_NUM, BENCH_DEN, u, BENCH_DT)


def test_noise_free_low_order(low):
    u, y = low
    res = srivc(y, u, LOW_DT, n=2, m=1)
    assert_recovered(res, LOW_NUM, LOW_DEN)
    np.testing.assert_allclose(res.y_model, y, atol=1e-9 * np.max(np.abs(y)))
    assert res.num.shape == (2,) and res.den.shape == (3,) and float(res.den[0]) == 1.0
    assert res.cov.shape == (4, 4) and res.num_se.shape == (2,) and res.den_se.shape == (3,)
    assert float(res.den_se[0]) == 0.0 and float(res.sigma2) < 1e-20


def test_noise_free_with_input_delay(low):
    u, _ = low
    y = simulate(LOW_NUM, LOW_DEN, u, LOW_DT, delay=3)
    assert_recovered(srivc(y, u, LOW_DT, n=2, m=1, delay=3), LOW_NUM, LOW_DEN)


def test_noise_free_two_zeros():
    # n = 3, m = 2: poles -1, -1 +- j sqrt(3); non-minimum-phase complex zeros (s^2 - s + 4).
    num, den, dt = [1.0, -1.0, 4.0], [1.0, 3.0, 6.0, 4.0], 0.02
    u = prbs(1500, 5, seed=2)
    assert_recovered(srivc(simulate(num, den, u, dt), u, dt, n=3, m=2), num, den)


def test_noise_free_contsid_benchmark(bench):
    u, y = bench
    res = srivc(y, u, BENCH_DT, n=4, m=1)
    assert_recovered(res, BENCH_NUM, BENCH_DEN)
    assert int(res.iterations) <= 10


def test_monte_carlo_benchmark(bench):
    """100 noise realisations (white, std 10 % of the noise-free output's), one jit(vmap) call.

    Measured (seed 3): means within 2.1 Monte Carlo standard errors of the
    truth, mean reported standard errors within 6 % of the Monte Carlo
    standard deviations, every run converged in at most 4 iterations.
    """
    u, y0 = bench
    runs, level = 100, 0.1
    noise_std = level * np.std(y0)
    ys = y0 + noise_std * np.random.default_rng(3).standard_normal((runs, BENCH_N))
    res = jax.jit(jax.vmap(lambda y: srivc(y, u, BENCH_DT, n=4, m=1)))(ys)
    assert np.all(np.asarray(res.converged)) and np.all(np.asarray(res.stable))
    est = np.asarray(res.theta)
    true = theta(BENCH_NUM, BENCH_DEN)
    mc_std = est.std(axis=0, ddof=1)
    z = (est.mean(axis=0) - true) / (mc_std / np.sqrt(runs))
    assert np.all(np.abs(z) < 3), z
    se = np.sqrt(np.diagonal(np.asarray(res.cov), axis1=1, axis2=2))
    np.testing.assert_allclose(np.asarray(res.den_se)[:, 1:], se[:, :4])
    np.testing.assert_allclose(np.asarray(res.num_se), se[:, 4:])
    ratio = se.mean(axis=0) / mc_std
    assert np.all(np.abs(ratio - 1) < 0.25), ratio
    np.testing.assert_allclose(np.mean(res.sigma2), noise_std**2, rtol=0.05)
    # jit(vmap) equals the plain call (which reuses the noise-free benchmark test's compiled program)
    one = srivc(ys[7], u, BENCH_DT, n=4, m=1)
    np.testing.assert_allclose(res.theta[7], one.theta, rtol=1e-9)
    np.testing.assert_allclose(res.cov[7], one.cov, rtol=1e-6)
    assert int(res.iterations[7]) == int(one.iterations)
    assert res.reason.shape == (runs,) and set(res.reason) == {"converged"}


def test_not_converged_is_flagged(low):
    u, y = low
    y = y + 0.3 * np.random.default_rng(5).standard_normal(LOW_N)
    with pytest.warns(RuntimeWarning, match="did not converge"):
        res = srivc(y, u, LOW_DT, n=2, m=1, solver=RIVSolver(max_iter=1, tol=1e-12))
    assert not bool(res.converged) and int(res.status) == MAX_ITER and int(res.iterations) == 1
    assert "iteration limit" in res.reason


def test_unstable_open_loop_data_are_refused(low):
    # 1/((s - 0.5)(s + 2)): the output grows like e^(0.5 t) over the 20 s record.
    u, _ = low
    y = simulate([1.0, 1.0], [1.0, 1.5, -1.0], u, LOW_DT)
    with pytest.raises(ValueError, match="unstable"):
        srivc(y, u, LOW_DT, n=2, m=1)


def _bad(n_samples=400):
    u = prbs(n_samples, 4, seed=0)
    return simulate(LOW_NUM, LOW_DEN, u, LOW_DT), u


@pytest.mark.parametrize(
    "case,match",
    [
        (lambda y, u: srivc(y, u, 0.05, n=1, m=2), "exceeds"),
        (lambda y, u: srivc(y, u, 0.05, n=0, m=0), "`n`"),
        (lambda y, u: srivc(y, u, 0.05, n=2, m=-1), "`m`"),
        (lambda y, u: srivc(np.r_[y[:-1], np.nan], u, 0.05, n=2, m=1), "NaN or inf"),
        (lambda y, u: srivc(y, np.r_[u[:-1], np.inf], 0.05, n=2, m=1), "NaN or inf"),
        (lambda y, u: srivc(y[:30], u[:30], 0.05, n=2, m=1), "too few samples"),
        (lambda y, u: srivc(y, u, 0.05, n=2, m=1, delay=380), "too few samples"),
        (lambda y, u: srivc(y, np.ones_like(u), 0.05, n=2, m=1), "constant"),
        (lambda y, u: srivc(np.zeros_like(y), u, 0.05, n=2, m=1), "constant"),
        (lambda y, u: srivc(y[:-1], u, 0.05, n=2, m=1), "same length"),
        (lambda y, u: srivc(y, u, 0.0, n=2, m=1), "dt"),
        (lambda y, u: srivc(y, u, -0.05, n=2, m=1), "dt"),
        (lambda y, u: srivc(y[:, None], u[:, None], 0.05, n=2, m=1), "1-D"),
        (lambda y, u: srivc(y, u, 0.05, n=2, m=1, delay=-1), "delay"),
        (lambda y, u: srivc(y, u, 0.05, n=2, m=1, lam=[1.0, -2.0]), "lam"),
        (lambda y, u: srivc(y, u, 0.05, n=2, m=1, solver=RIVSolver(tol=0.0)), "tol"),
    ],
)
def test_bad_input(case, match):
    y, u = _bad()
    with pytest.raises(ValueError, match=match):
        case(y, u)


def test_matrix_exponential_matches_jax_scipy():
    rng = np.random.default_rng(6)
    comp = np.zeros((9, 9))  # a companion-like matrix with a large norm, as the augmented filter matrices
    comp[:-1, 1:] = np.eye(8)
    comp[-1] = -np.r_[1600.0, 416.0, 408.0, 5.0, 1.0, 3.0, 2.0, 1.0, 0.5] * 0.02
    for a in [rng.standard_normal((9, 9)) * 0.01, rng.standard_normal((9, 9)) * 3.0, comp, 40 * comp]:
        want = np.asarray(jax.jit(jsl.expm)(a))
        np.testing.assert_allclose(jax.jit(expm_taylor)(a), want, rtol=0, atol=1e-13 * np.max(np.abs(want)))
