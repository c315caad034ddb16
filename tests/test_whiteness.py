"""Residual whiteness: the autocorrelation against a direct sum, Ljung-Box against scipy's chi-squared,
the decimated-noise null against Monte Carlo, Bartlett's covariance against its closed form for AR(1)."""

import jax
import numpy as np
import pytest
import scipy.stats

import jaxsdp
from jaxsdp._signal.whiteness import bartlett_covariance, decimated_noise_acf


def _acf(e, L):
    d = e - e.mean()
    return np.array([d[:-k] @ d[k:] for k in range(1, L + 1)]) / (d @ d)


def test_acf_and_ljung_box_match_direct_formulas():
    rng = np.random.default_rng(3)
    e = rng.normal(size=1500)
    e = e + 0.4 * np.roll(e, 1)
    w = jaxsdp.whiteness(e, max_lag=12)
    r = _acf(e, 12)
    np.testing.assert_allclose(w.acf, r, atol=1e-14)
    n = e.size
    q = n * (n + 2) * np.sum(r**2 / (n - np.arange(1, 13)))
    np.testing.assert_allclose(float(w.q), q, rtol=1e-12)
    np.testing.assert_allclose(float(w.p_value), scipy.stats.chi2.sf(q, 12), rtol=1e-9)
    np.testing.assert_allclose(w.band, 1.959963984540054 / np.sqrt(n), rtol=1e-12)
    assert not bool(w.white) and float(w.lag1) > 0.3


def test_white_noise_is_white_at_about_the_nominal_rate():
    keys = jax.random.split(jax.random.key(0), 60)
    p = [float(jaxsdp.whiteness(np.asarray(jax.random.normal(k, (800,)))).p_value) for k in keys]
    assert 0.0 <= np.mean(np.asarray(p) < 0.05) <= 0.15


def test_bartlett_covariance_white_and_ar1():
    np.testing.assert_allclose(bartlett_covariance(np.zeros(20), 5), np.eye(5), atol=0)
    phi = 0.6
    W = bartlett_covariance(phi ** np.arange(1, 200), 2)
    # Bartlett for AR(1): N var(r_1) = 1 - phi^2
    np.testing.assert_allclose(W[0, 0], 1 - phi**2, rtol=1e-10)


def test_decimated_noise_null_matches_monte_carlo_and_is_calibrated():
    rho = decimated_noise_acf(10, 1000)
    rng = np.random.default_rng(7)
    lag1, reject = [], 0
    runs = 40
    for _ in range(runs):
        e = np.asarray(jaxsdp.decimate(rng.normal(size=20000), 10))
        w = jaxsdp.whiteness(e, null_acf=rho)
        lag1.append(float(w.lag1))
        reject += not bool(w.white)
        assert not bool(jaxsdp.whiteness(e).white)  # against white noise it always looks correlated
    assert abs(np.mean(lag1) - rho[0]) < 3 * np.std(lag1) / np.sqrt(runs)
    assert reject / runs <= 0.2
    # A residual with extra correlation is flagged
    e = np.asarray(jaxsdp.decimate(rng.normal(size=20000), 10))
    assert not bool(jaxsdp.whiteness(e + 0.8 * np.roll(e, 3), null_acf=rho).white)
    np.testing.assert_array_equal(decimated_noise_acf(1, 4), np.zeros(4))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(residuals=np.ones(50)), "constant"),
        (dict(residuals=np.r_[np.nan, np.arange(49.0)]), "residuals"),
        (dict(residuals=np.arange(15.0)), "at least"),
        (dict(residuals=np.arange(100.0), max_lag=0), "max_lag"),
        (dict(residuals=np.arange(100.0), alpha=1.5), "alpha"),
        (dict(residuals=np.arange(100.0), null_acf=np.zeros(5)), "null_acf"),
    ],
)
def test_bad_input(kwargs, match):
    with pytest.raises(Exception, match=match):
        jaxsdp.whiteness(**kwargs)
