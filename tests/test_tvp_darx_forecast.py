"""Forecasts of the dynamic ARX (`jaxsdp.tvp.darx(..., u_future=...)`): statsmodels' SARIMAX forecast at the same
coefficients (the ARX written as a regression on the AR-filtered inputs with AR errors), the delay longer and
shorter than the horizon, no AR part, the refusals."""

import jax
import numpy as np
import pytest
from scipy.signal import lfilter

import jaxsdp.tvp as tvp

jax.config.update("jax_enable_x64", True)


def _arx(n, na, nb, delay, seed):
    """A stable ARX with constant coefficients driven by white noise, and its input."""
    rng = np.random.default_rng(seed)
    phi = np.array([0.6, -0.2])[:na]
    beta = np.array([1.0, -0.5])[:nb]
    u = rng.standard_normal(n)
    y = np.zeros(n)
    for k in range(n):
        ar = sum(phi[i] * y[k - 1 - i] for i in range(na) if k - 1 - i >= 0)
        x = sum(beta[j] * u[k - delay - j] for j in range(nb) if k - delay - j >= 0)
        y[k] = ar + x + 0.3 * rng.standard_normal() + 2.0  # a mean that `demean` removes
    return y, u


def _sarimax_forecast(y, u, u_future, phi, beta, s2, mu, delay):
    """The ARX y_k - mu = sum_i phi_i (y_{k-i} - mu) + sum_j beta_j u_{k-d-j} + e_k as SARIMAX's regression with AR
    errors: y_k - mu = sum_j beta_j w_jk + eta_k, w_j the input u_{k-d-j} filtered by 1 / (1 - sum_i phi_i q^-i) and
    eta an AR with phi; forecast with the known exogenous w over the horizon. Returns (mean, variance)."""
    sm = pytest.importorskip("statsmodels.api", reason="statsmodels is in the test extra")
    n, h = y.shape[0], u_future.shape[0]
    uu = np.r_[u, u_future]
    cols = []
    for j in range(len(beta)):
        shifted = np.r_[np.zeros(delay + j), uu[: n + h - delay - j]]
        cols.append(lfilter([1.0], np.r_[1.0, -phi], shifted))
    W = np.column_stack(cols)
    model = sm.tsa.SARIMAX(y - mu, exog=W[:n], order=(len(phi), 0, 0), trend="n")
    assert model.param_names[: len(beta)] == [f"x{j + 1}" for j in range(len(beta))]
    ref = model.filter(np.r_[beta, phi, s2]).get_forecast(h, exog=W[n:])
    return np.asarray(ref.predicted_mean) + mu, np.asarray(ref.var_pred_mean)


@pytest.mark.parametrize(
    "na, nb, delay, h",
    [
        (2, 2, 1, 9),  # delay < horizon: the last forecasts use u_future
        (1, 2, 6, 4),  # delay > horizon: every input the forecast uses is in the data
        (2, 1, 0, 5),  # no delay: u_future from the first forecast on
        (0, 2, 2, 6),  # no AR part: the variance is sigma^2 at every step
    ],
)
def test_darx_forecast_is_sarimax_forecast_at_its_last_coefficients(na, nb, delay, h):
    y, u = _arx(400, na, nb, delay, seed=10 + na + delay)
    u_future = np.random.default_rng(99).standard_normal(h)
    res = tvp.darx(y, u, na=na, nb=nb, delay=delay, nvr=1e-6, u_future=u_future)
    fc = res.forecast
    coef, s2, mu = np.asarray(res.coef)[-1], float(res.sigma2), float(res.mean)
    mean, var = _sarimax_forecast(y, u, u_future, coef[:na], coef[na:], s2, mu, delay)
    assert fc.horizon == h
    np.testing.assert_allclose(fc.mean[-h:], mean, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fc.obs_se[-h:]) ** 2, var, rtol=1e-9)
    np.testing.assert_allclose(np.asarray(fc.se[-h:]) ** 2 + s2, var, rtol=1e-9)
    np.testing.assert_allclose(fc.mean[:400], res.fit)  # the one-step fit over the data, as without a forecast
    # the inputs add no variance: another u_future moves the mean from step d + 1 on, never the intervals
    other = tvp.darx(y, u, na=na, nb=nb, delay=delay, nvr=1e-6, u_future=u_future + 1.0).forecast
    np.testing.assert_array_equal(np.asarray(other.obs_se), np.asarray(fc.obs_se))
    moved = np.abs(np.asarray(other.mean[-h:]) - np.asarray(fc.mean[-h:])) > 1e-6
    np.testing.assert_array_equal(moved, np.arange(h) >= delay)
    if na == 0:
        np.testing.assert_allclose(np.asarray(fc.obs_se[-h:]) ** 2, s2, rtol=1e-12)
        np.testing.assert_allclose(fc.se[-h:], 0.0, atol=1e-12)


def test_darx_without_u_future_has_no_horizon_and_the_same_fit():
    y, u = _arx(200, 1, 1, 1, seed=3)
    plain = tvp.darx(y, u, na=1, nb=1, delay=1, nvr=1e-4)
    ahead = tvp.darx(y, u, na=1, nb=1, delay=1, nvr=1e-4, u_future=np.ones(3))
    assert plain.forecast.horizon == 0 and ahead.forecast.horizon == 3
    np.testing.assert_array_equal(np.asarray(plain.coef), np.asarray(ahead.coef))
    np.testing.assert_array_equal(np.asarray(plain.forecast.mean), np.asarray(ahead.forecast.mean)[:200])


def test_darx_forecast_under_jit():
    y, u = _arx(200, 1, 1, 1, seed=4)

    def mean(y, u, uf):
        return tvp.darx(y, u, na=1, nb=1, delay=1, nvr=1e-4, u_future=uf).forecast.mean

    uf = np.linspace(-1.0, 1.0, 4)
    np.testing.assert_allclose(jax.jit(mean)(y, u, uf), mean(y, u, uf), rtol=1e-12)


@pytest.mark.parametrize(
    "kwargs, y_last, match",
    [
        ({"u_future": [1.0, np.nan]}, 0.0, "u_future"),
        ({"u_future": np.ones((3, 1))}, 0.0, "u_future"),
        ({"u_future": "abc"}, 0.0, "u_future"),
        ({"u_future": np.ones(3)}, np.nan, "last 2 samples"),
    ],
)
def test_darx_forecast_refusals(kwargs, y_last, match):
    y, u = _arx(100, 2, 1, 1, seed=5)
    y[-1] = y_last
    with pytest.raises(ValueError, match=match):
        tvp.darx(y, u, na=2, nb=1, delay=1, nvr=1e-4, **kwargs)


def test_darx_forecast_without_ar_part_needs_no_last_sample():
    y, u = _arx(100, 0, 1, 1, seed=6)
    y[-1] = np.nan
    res = tvp.darx(y, u, na=0, nb=1, delay=1, nvr=1e-4, u_future=np.ones(2))
    beta, mu = float(res.coef[-1, 0]), float(res.mean)
    np.testing.assert_allclose(res.forecast.mean[-2:], [beta * u[-1] + mu, beta + mu], rtol=1e-12)
