"""Forecasts of the time-variable transfer function (`jaxsdp.tvp.dtfm(..., u_future=...)`): the mean against the TF
simulated by hand with the last coefficients plus the AR(nd) noise forecast, the variance against the AR(nd) closed
form (nd = 0 and 1), the input's future entering after the delay only, no horizon leaving the estimate unchanged,
the last sample missing, the refusals."""

import jax
import numpy as np
import pytest
from scipy.signal import lfilter

import jaxsdp.tvp as tvp

jax.config.update("jax_enable_x64", True)

N = 400


def _tf(na, nb, delay, nd, seed):
    """y = x + xi: x a stable TF with constant coefficients driven by white u, xi white (nd = 0) or AR(1), pole 0.8."""
    rng = np.random.default_rng(seed)
    phi, beta = (np.array([0.7]), np.array([1.2, -0.5]))[na - 1], np.array([1.0, 0.5])[:nb]
    u = rng.standard_normal(N)
    x = np.zeros(N)
    for k in range(N):
        x[k] = sum(phi[i] * x[k - 1 - i] for i in range(na) if k - 1 - i >= 0) + sum(
            beta[j] * u[k - delay - j] for j in range(nb) if k - delay - j >= 0
        )
    xi = lfilter([1.0], [1.0, -0.8] if nd else [1.0], rng.standard_normal(N))
    return x + 0.3 * x.std() / xi.std() * xi, u


def _fit(y, u, na, nb, delay, nd, u_future=None):
    return tvp.dtfm(y, u, na=na, nb=nb, delay=delay, nd=nd, nvr=1e-6, iterations=4, u_future=u_future)


def _by_hand(res, u, u_future, na, delay):
    """The closed forms at the result's last coefficients: x continued by the TF from x_hat, the noise's forecast
    a^j xi_(N-1) (a = -d_1; 0 for white noise) and its variance sigma^2 (1 + a^2 + ... + a^(2(j-1)))."""
    coef, x_hat = np.asarray(res.coef)[-1], np.asarray(res.x_hat)
    phi, beta = coef[:na], coef[na:]
    h, uu = u_future.shape[0], np.r_[u, u_future]
    x = list(x_hat)
    for k in range(N, N + h):
        x.append(sum(phi[i] * x[k - 1 - i] for i in range(na)) + sum(b * uu[k - delay - j] for j, b in enumerate(beta)))
    a = -float(res.d[1]) if res.d.shape[0] > 1 else 0.0
    j = np.arange(1, h + 1)
    xi_last = float(res.resid[-1])
    var = float(res.sigma2) * np.cumsum(a ** (2 * (j - 1)))
    return np.asarray(x[N:]) + a**j * xi_last, var, a


@pytest.mark.parametrize(
    "na, nb, delay, nd, h",
    [
        (1, 1, 1, 0, 5),  # white noise: the forecast is the simulated TF, its variance sigma^2 at every step
        (2, 2, 3, 1, 7),  # AR(1) noise, delay < horizon: the last forecasts use u_future
        (1, 2, 5, 1, 3),  # delay > horizon: every input the forecast uses is in the data
    ],
)
def test_dtfm_forecast_is_the_tf_and_ar_noise_closed_form(na, nb, delay, nd, h):
    y, u = _tf(na, nb, delay, nd, seed=20 + na + delay)
    u_future = np.random.default_rng(98).standard_normal(h)
    res = _fit(y, u, na, nb, delay, nd, u_future)
    fc = res.forecast
    mean, var, a = _by_hand(res, u, u_future, na, delay)
    s2 = float(res.sigma2)
    assert fc.horizon == h and res.d.shape == (nd + 1,) and (nd == 0 or 0.5 < a < 0.95)
    np.testing.assert_allclose(fc.mean[N:], mean, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fc.obs_se[N:]) ** 2, var, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(fc.se[N:]) ** 2 + s2, var, rtol=1e-12)
    # over the data: the one-step prediction x_hat_k + a xi_(k-1), its variance sigma^2, no coefficient uncertainty
    xi = np.asarray(res.resid)
    np.testing.assert_allclose(fc.mean[1:N], np.asarray(res.x_hat)[1:] + a * xi[:-1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fc.obs_se[:N]) ** 2, s2, rtol=1e-12)
    np.testing.assert_array_equal(np.asarray(fc.se[:N]), 0.0)
    # the input adds no variance: another u_future moves the mean from step d + 1 on, never the intervals
    other = _fit(y, u, na, nb, delay, nd, u_future + 1.0).forecast
    np.testing.assert_array_equal(np.asarray(other.obs_se), np.asarray(fc.obs_se))
    moved = np.abs(np.asarray(other.mean[N:]) - np.asarray(fc.mean[N:])) > 1e-6
    np.testing.assert_array_equal(moved, np.arange(h) >= delay)


def test_dtfm_without_u_future_is_unchanged_and_has_no_horizon():
    y, u = _tf(1, 1, 1, 1, seed=3)
    plain, ahead = _fit(y, u, 1, 1, 1, 1), _fit(y, u, 1, 1, 1, 1, np.ones(4))
    assert plain.forecast.horizon == 0 and ahead.forecast.horizon == 4
    for name in ("coef", "coef_se", "x_hat", "resid", "d", "nvr", "sigma2", "loglik", "J", "iterations", "change"):
        np.testing.assert_array_equal(np.asarray(getattr(plain, name)), np.asarray(getattr(ahead, name)), err_msg=name)
    for name in ("mean", "se", "obs_se"):
        np.testing.assert_array_equal(
            np.asarray(getattr(plain.forecast, name)), np.asarray(getattr(ahead.forecast, name))[:N], err_msg=name
        )


def test_dtfm_forecast_after_a_missing_last_sample():
    """y's last sample missing: the noise is forecast from the last observed residual, one step further."""
    y, u = _tf(1, 1, 1, 1, seed=4)
    y[-1] = np.nan
    res = _fit(y, u, 1, 1, 1, 1, np.ones(2))
    fc, a, s2 = res.forecast, -float(res.d[1]), float(res.sigma2)
    xi = float(res.resid[-2])
    coef, x_hat = np.asarray(res.coef)[-1], np.asarray(res.x_hat)
    x1 = coef[0] * x_hat[-1] + coef[1] * u[-1]
    x = np.array([x_hat[-1], x1, coef[0] * x1 + coef[1]])
    np.testing.assert_allclose(fc.mean[N - 1 :], x + a ** np.arange(1, 4) * xi, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fc.obs_se[N - 1 :]) ** 2, s2 * np.cumsum(a ** (2 * np.arange(3))), rtol=1e-12)
    assert np.isfinite(fc.filled).all()


@pytest.mark.parametrize(
    "u_future, match",
    [([1.0, np.nan], "u_future"), (np.ones((3, 1)), "u_future"), ("abc", "u_future")],
)
def test_dtfm_forecast_refusals(u_future, match):
    y, u = _tf(1, 1, 1, 0, seed=5)
    with pytest.raises(ValueError, match=match):
        tvp.dtfm(y, u, na=1, nb=1, nvr=1e-6, iterations=1, u_future=u_future)
