"""Dynamic AR and ARX (`jaxsdp.tvp.dar`, `darx`) and the time-frequency spectrum (`darsp`): the dense Gaussian
likelihood, a chirp-driven AR process whose instantaneous frequency is known, a gain that jumps and one that
drifts."""

import jax
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import jaxsdp.tvp as tvp
from dense import dense_loglik_u

jax.config.update("jax_enable_x64", True)


def _ar2_sweep(n=3000, r=0.95, f0=0.05, f1=0.2, seed=0):
    """AR(2) with poles r exp(+-j theta_k), theta_k / 2 pi sweeping f0 -> f1 cycles per sample; its spectral peak."""
    rng = np.random.default_rng(seed)
    theta = 2 * np.pi * np.linspace(f0, f1, n)
    y = np.zeros(n)
    e = rng.standard_normal(n)
    for k in range(2, n):
        y[k] = 2 * r * np.cos(theta[k]) * y[k - 1] - r**2 * y[k - 2] + e[k]
    peak = np.arccos((1 + r**2) * np.cos(theta) / (2 * r)) / (2 * np.pi)  # the AR(2) spectrum's maximum
    return y, peak


def test_dar_loglik_is_the_dense_gaussian_of_its_lagged_regression():
    y, _ = _ar2_sweep(n=80, seed=1)
    y[40] = np.nan  # its own sample and the next two (their lags) leave the likelihood
    nvr = (1e-3, 1e-4)
    res = tvp.dar(y, 2, nvr=nvr, burn_in=0)
    yd = y - np.nanmean(y)
    Z = np.column_stack([np.r_[np.nan, yd[:-1]], np.r_[np.nan, np.nan, yd[:-2]]])
    target = np.where(np.isnan(Z).any(axis=1), np.nan, yd)
    H = np.nan_to_num(Z)
    F, Q = np.eye(2), np.diag(nvr)

    def neg(log_s2):
        return -dense_loglik_u(target, H, F, Q, 1e5, np.zeros(2), np.exp(log_s2))

    best = minimize_scalar(neg, bounds=(-10.0, 5.0), method="bounded", options={"xatol": 1e-10})
    np.testing.assert_allclose(res.loglik, -best.fun, rtol=1e-9)
    fit = np.asarray(res.fit)
    assert np.isnan(fit[[0, 1, 40, 41, 42]]).all() and np.isfinite(fit[43])


def test_darsp_tracks_the_instantaneous_frequency_of_a_sweeping_resonance():
    y, peak = _ar2_sweep()
    res = tvp.dar(y, 2)
    assert bool(res.nvr_fit.converged)
    sp = tvp.darsp(res, n_freq=1024)
    inner = slice(300, 2700)  # away from the ends, where the smoother has one side only
    rel = np.abs(np.asarray(sp.peak)[inner] - peak[inner]) / peak[inner]
    assert np.median(rel) < 0.03 and np.percentile(rel, 90) < 0.08, (np.median(rel), np.percentile(rel, 90))
    # the a2 coefficient (-r^2, constant) is found constant: its NVR far below a1's
    assert float(res.nvr[1]) < 1e-2 * float(res.nvr[0])
    np.testing.assert_allclose(np.median(np.asarray(res.coef)[inner, 1]), -(0.95**2), atol=0.03)
    # dt scales the frequency axis and the power density
    sp_hz = tvp.darsp(res, n_freq=1024, dt=1e-3)
    np.testing.assert_allclose(sp_hz.peak, np.asarray(sp.peak) / 1e-3)
    np.testing.assert_allclose(sp_hz.power, np.asarray(sp.power) * 1e-3, rtol=1e-12)


def test_darx_follows_a_gain_that_jumps_and_a_pole_that_drifts():
    rng = np.random.default_rng(3)
    n = 2000
    u = rng.standard_normal(n)
    k = np.arange(n)
    gain = np.where(k < n // 2, 1.0, 2.0)
    pole = 0.3 + 0.4 * k / n
    y = np.zeros(n)
    for i in range(1, n):
        y[i] = pole[i] * y[i - 1] + gain[i] * u[i - 1] + 0.05 * rng.standard_normal()
    res = tvp.darx(y, u, na=1, nb=1, delay=1, demean=False)
    coef = np.asarray(res.coef)
    se = np.asarray(res.coef_se)
    away = (np.abs(k - n // 2) > 60) & (k > 50) & (k < n - 50)
    assert np.max(np.abs(coef[away, 1] - gain[away])) < 0.1
    assert np.max(np.abs(coef[away, 0] - pole[away])) < 0.08
    # the truth inside the 99 % band almost everywhere away from the jump
    inside = np.abs(coef[away, 1] - gain[away]) < 2.58 * se[away, 1]
    assert inside.mean() > 0.9
    assert float(res.nvr[1]) > 10 * float(res.nvr[0])  # the jumping gain's NVR above the drifting pole's


def test_dar_under_jit_vmap_and_grad():
    ys = np.stack([_ar2_sweep(n=200, seed=s)[0] for s in range(3)])

    def loglik(y, log_nvr):
        return tvp.dar(y, 2, nvr=10.0**log_nvr).loglik

    b = np.array([-3.0, -4.0])
    batched = jax.jit(jax.vmap(loglik, in_axes=(0, None)))(ys, b)
    np.testing.assert_allclose(batched, [float(loglik(y, b)) for y in ys], rtol=1e-10)
    g = jax.grad(loglik, argnums=1)(ys[0], b)
    eps = 1e-5
    fd = [(float(loglik(ys[0], b + eps * e)) - float(loglik(ys[0], b - eps * e))) / (2 * eps) for e in np.eye(2)]
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6)


def test_the_likelihood_skips_the_samples_without_lags_and_does_not_depend_on_the_diffuse_prior():
    """The burn-in counts from the first sample with all its lags: a diffuse start's first innovations (which
    depend on P0) stay out of the likelihood whatever the order and the delay."""
    y, _ = _ar2_sweep(n=400, seed=6)
    u = np.random.default_rng(6).standard_normal(400)
    for fit in (
        lambda P0: tvp.dar(y, 3, nvr=1e-3, P0=P0),
        lambda P0: tvp.darx(y, u, na=1, nb=2, delay=5, nvr=1e-3, P0=P0),
    ):
        np.testing.assert_allclose(fit(1e7).loglik, fit(1e5).loglik, rtol=0, atol=0.01)
    assert tvp.darx(y, u, na=1, nb=2, delay=5, nvr=1e-3).start == 6


def test_tied_nvr_is_one_nvr_for_every_coefficient():
    y, _ = _ar2_sweep(n=400, seed=4)
    tied = tvp.dar(y, 2, nvr=1e-3, tied=True)
    untied = tvp.dar(y, 2, nvr=(1e-3, 1e-3))
    assert tied.nvr.shape == (1,)
    np.testing.assert_allclose(tied.coef, untied.coef, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(tied.loglik, untied.loglik, rtol=1e-12)


def test_spectrum_plot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    y, _ = _ar2_sweep(n=300)
    ax = tvp.darsp(tvp.dar(y, 2, nvr=1e-3), n_freq=64).plot()
    assert ax.get_ylabel() == "frequency"
    plt.close(ax.figure)


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda y: tvp.dar(y, 0), "order"),
        (lambda y: tvp.dar(y, 2, nvr=(1e-3,)), "shape"),
        (lambda y: tvp.dar(y[:6], 2), "samples"),
        (lambda y: tvp.darx(y, y[:-1], na=1, nb=1), "shape"),
        (lambda y: tvp.darx(y, y, na=1, nb=1, delay=-1), "delay"),
        (lambda y: tvp.darsp(tvp.darx(y, y, na=0, nb=1, nvr=1e-3)), "no AR part"),
        (lambda y: tvp.darsp(y), "DARResult"),
        (lambda y: tvp.darsp(tvp.dar(y, 1, nvr=1e-3), dt=0.0), "dt"),
        (lambda y: tvp.dar(y, 1, nvr=-1e-3), "non-negative"),
        (lambda y: tvp.dar(y, 1, nvr=1e-3, P0=0.0), "P0"),
        (lambda y: tvp.dar(np.where(np.arange(100) == 3, np.inf, y), 1, nvr=1e-3), "inf"),
        (lambda y: tvp.dar(y, 1, model="CONST", nvr="ml"), "Constant"),
        (lambda y: tvp.dar(y, 1, nvr=1e-3, burn_in=-1), "burn_in"),
    ],
)
def test_refused_by_name(call, match):
    y, _ = _ar2_sweep(n=100)
    with pytest.raises(ValueError, match=match):
        call(y)


def test_dar_forecast_is_the_ar_forecast_of_its_last_coefficients():
    """Beyond the data, the AR(p) with the last coefficients and sigma^2: statsmodels' ARIMA forecast with those
    parameters (its mean and variance are exact for a known AR), and the one-step fit with its smoother's
    standard error over the data."""
    sm = pytest.importorskip("statsmodels.api", reason="statsmodels is in the test extra")
    y, _ = _ar2_sweep(n=500, seed=8)
    h = 15
    res = tvp.dar(y, 2, nvr=1e-6, demean=False, horizon=h)
    fc = res.forecast
    phi, s2 = np.asarray(res.coef)[-1], float(res.sigma2)
    ref = sm.tsa.arima.ARIMA(y, order=(2, 0, 0), trend="n").filter(np.r_[phi, s2]).get_forecast(h)
    np.testing.assert_allclose(fc.mean[-h:], ref.predicted_mean, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fc.obs_se[-h:]) ** 2, ref.var_pred_mean, rtol=1e-9)
    assert fc.horizon == h and np.isnan(fc.mean[:2]).all()
    np.testing.assert_allclose(fc.mean[:500], res.fit)
    lo, hi = fc.interval(0.95)
    assert np.all(lo[-h:] < fc.mean[-h:]) and np.all(hi[-h:] > fc.mean[-h:])
    with pytest.raises(ValueError, match="last 2 samples"):
        tvp.dar(np.r_[y[:-1], np.nan], 2, nvr=1e-6, horizon=3)
