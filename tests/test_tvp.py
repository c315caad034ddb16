"""The time-variable family (`jaxsdp.tvp`): dynamic harmonic regression and forecasts against independent
references (the dense Gaussian of the state-space model, statsmodels' unobserved-components model)."""

import jax
import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import minimize_scalar

import jaxsdp
import jaxsdp.tvp as tvp
from dense import dense_loglik_u, dense_posterior

jax.config.update("jax_enable_x64", True)


def _series(n=72, seed=0, gap=True):
    rng = np.random.default_rng(seed)
    k = np.arange(n, dtype=float)
    y = 0.05 * k + (1.0 + k / n) * np.cos(2 * np.pi * k / 12) + 0.3 * np.sin(np.pi * k / 2)
    y = y + 0.2 * rng.standard_normal(n)
    if gap:
        y[30:34] = np.nan
    return y


def _system(n_samples, periods, q_trend, q_cycles, *, trend="IRW"):
    """H (N, n), F, Q of trend + harmonics built by hand (RW amplitudes), in the DHR's state order."""
    z = tvp.harmonic_regressors(n_samples, periods)
    blocks = [(np.array([[1.0, 1.0], [0.0, 1.0]]), np.diag([0.0, q_trend]))] if trend == "IRW" else []
    if trend == "RW":
        blocks = [(np.ones((1, 1)), np.full((1, 1), q_trend))]
    for p, q in zip(periods, q_cycles):
        blocks += [(np.ones((1, 1)), np.full((1, 1), q))] * (1 if p == 2 else 2)
    F = sla.block_diag(*[b[0] for b in blocks])
    Q = sla.block_diag(*[b[1] for b in blocks])
    H = np.zeros((n_samples, F.shape[0]))
    col = 0
    for j, (Fb, _) in enumerate(blocks):
        H[:, col] = z[:, j]
        col += Fb.shape[0]
    return H, F, Q


PERIODS = (12.0, 4.0, 2.0)  # the Nyquist period 2 has its cosine only
NVR = (1e-4, 1e-3, 1e-2, 1e-3)


@pytest.mark.parametrize("P0", [10.0, 1e5])
def test_dhr_loglik_is_the_dense_gaussian_maximised_over_sigma2(P0):
    y = _series()
    res = tvp.dhr(y, PERIODS, nvr=NVR, P0=P0, burn_in=0)
    H, F, Q = _system(len(y), PERIODS, NVR[0], NVR[1:])
    x0 = np.zeros(F.shape[0])

    def neg(log_s2):
        return -dense_loglik_u(y, H, F, Q, P0, x0, np.exp(log_s2))

    best = minimize_scalar(neg, bounds=(-10.0, 5.0), method="bounded", options={"xatol": 1e-10})
    np.testing.assert_allclose(res.loglik, -best.fun, rtol=1e-9)


def test_components_forecast_and_gaps_are_the_dense_posterior():
    y, h = _series(), 8
    res = tvp.dhr(y, PERIODS, nvr=NVR, horizon=h)
    N = len(y)
    H, F, Q = _system(N + h, PERIODS, NVR[0], NVR[1:])
    n = F.shape[0]
    ypad = np.concatenate([y, np.full(h, np.nan)])
    mean, cov, *_ = dense_posterior(ypad, H, F, Q, 1e5, np.zeros(n))
    s2 = float(res.sigma2)
    blocks = {"fit": np.arange(n), "trend": np.arange(2), "seasonal": np.arange(2, n)}
    cycle_states = [np.arange(2, 4), np.arange(4, 6), np.arange(6, 7)]

    def signal(states):
        R = np.zeros((N + h, n))
        R[:, states] = H[:, states]
        m = np.sum(R * mean, axis=1)
        v = np.array([R[k] @ cov[k * n : (k + 1) * n, k * n : (k + 1) * n] @ R[k] for k in range(N + h)])
        return m, np.sqrt(s2 * v)

    for name, got, got_se in [
        ("fit", res.forecast.mean, res.forecast.se),
        ("trend", res.trend, res.trend_se),
        ("seasonal", res.seasonal, res.seasonal_se),
    ]:
        m, se = signal(blocks[name])
        np.testing.assert_allclose(got, m, rtol=1e-8, atol=1e-8, err_msg=name)
        np.testing.assert_allclose(got_se, se, rtol=1e-7, atol=1e-10, err_msg=name)
    for i, states in enumerate(cycle_states):
        m, se = signal(states)
        np.testing.assert_allclose(res.cycles[:, i], m, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(res.cycles_se[:, i], se, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(res.forecast.obs_se, np.sqrt(res.forecast.se**2 + s2), rtol=1e-12)
    a, b = mean[:, 2], mean[:, 3]
    np.testing.assert_allclose(res.amplitude[:, 0], np.hypot(a, b), rtol=1e-8, atol=1e-10)
    filled = res.forecast.filled
    assert np.all(np.isfinite(filled)) and np.array_equal(filled[:30], y[:30])
    np.testing.assert_allclose(filled[30:34], res.forecast.mean[30:34])
    np.testing.assert_allclose(res.adjusted, y - res.seasonal[:N])


@pytest.mark.parametrize("trend,level", [("IRW", "smooth trend"), ("RW", "local level")])
def test_dhr_loglik_is_statsmodels_unobserved_components(trend, level):
    """RW amplitudes of cos/sin pairs are statsmodels' stochastic trigonometric seasonal rotated by omega k:
    the same Gaussian model, so the same likelihood at the same variances (statsmodels started at the
    DHR's prior: known initial state, no diffuse burn-in)."""
    sm = pytest.importorskip("statsmodels.api", reason="statsmodels is in the test extra")
    periods, y, P0 = (12.0, 5.0), _series(seed=3, gap=False), 1e3
    nvr = (1e-3, 2e-3, 5e-4)
    res = tvp.dhr(y, periods, trend=trend, nvr=nvr, P0=P0, burn_in=0)
    z = tvp.harmonic_regressors(len(y), periods)
    lik = jaxsdp.dlr_loglik(
        y, z, model=[trend, "RW", "RW", "RW", "RW"], nvr=(1e-3, 2e-3, 2e-3, 5e-4, 5e-4), P0=P0, burn_in=0
    )
    np.testing.assert_allclose(res.loglik, lik.loglik, rtol=1e-12)
    s2 = float(lik.sigma2)  # the concentrated-out variance: statsmodels evaluated there
    freq = [{"period": p, "harmonics": 1} for p in periods]
    mod = sm.tsa.UnobservedComponents(y, level=level, freq_seasonal=freq)
    F0 = np.array([[1.0, 1.0], [0.0, 1.0]]) if trend == "IRW" else np.ones((1, 1))
    Qt = np.diag([0.0, nvr[0]]) if trend == "IRW" else np.full((1, 1), nvr[0])
    P1 = sla.block_diag(F0 @ (P0 * np.eye(len(F0))) @ F0.T + Qt, *[(P0 + q) * np.eye(2) for q in nvr[1:]])
    mod.ssm.initialize_known(np.zeros(mod.k_states), s2 * P1)
    mod.loglikelihood_burn = 0
    params = dict(zip(mod.param_names, [np.nan] * len(mod.param_names)))
    params["sigma2.irregular"] = s2
    params["sigma2.trend" if trend == "IRW" else "sigma2.level"] = nvr[0] * s2
    for p, q in zip(periods, nvr[1:]):
        params[f"sigma2.freq_seasonal_{p}(1)"] = q * s2
    ll = mod.loglike(np.array([params[name] for name in mod.param_names]))
    np.testing.assert_allclose(res.loglik, ll, rtol=1e-10)


def test_tied_periods_are_statsmodels_seasonal_with_one_variance():
    """`tie_periods=True`: one NVR for every harmonic, statsmodels' trigonometric seasonal of period 12 with its
    harmonics 12, 6, 4 and one variance (the benchmark's `uc` model); same likelihood at the same variances."""
    sm = pytest.importorskip("statsmodels.api", reason="statsmodels is in the test extra")
    periods, y, P0, nvr = (12.0, 6.0, 4.0), _series(seed=4, gap=False), 1e3, (1e-3, 2e-3)
    res = tvp.dhr(y, periods, nvr=nvr, P0=P0, burn_in=0, tie_periods=True)
    untied = tvp.dhr(y, periods, nvr=(1e-3, 2e-3, 2e-3, 2e-3), P0=P0, burn_in=0)
    np.testing.assert_allclose(res.loglik, untied.loglik, rtol=1e-13)
    z = tvp.harmonic_regressors(len(y), periods)
    lik = jaxsdp.dlr_loglik(y, z, model=["IRW"] + ["RW"] * 6, nvr=(1e-3,) + (2e-3,) * 6, P0=P0, burn_in=0)
    s2 = float(lik.sigma2)  # the concentrated-out variance: statsmodels evaluated there
    mod = sm.tsa.UnobservedComponents(y, level="smooth trend", freq_seasonal=[{"period": 12, "harmonics": 3}])
    F0 = np.array([[1.0, 1.0], [0.0, 1.0]])
    P1 = sla.block_diag(F0 @ (P0 * np.eye(2)) @ F0.T + np.diag([0.0, nvr[0]]), (P0 + nvr[1]) * np.eye(6))
    mod.ssm.initialize_known(np.zeros(mod.k_states), s2 * P1)
    mod.loglikelihood_burn = 0
    values = {"sigma2.irregular": s2, "sigma2.trend": nvr[0] * s2, "sigma2.freq_seasonal_12(3)": nvr[1] * s2}
    ll = mod.loglike(np.array([values[name] for name in mod.param_names]))
    np.testing.assert_allclose(res.loglik, ll, rtol=1e-10)
    fit = tvp.dhr(y, periods, tie_periods=True)  # two NVRs by ML, the same likelihood as the untied at them
    assert np.shape(fit.nvr) == (2,) and bool(fit.nvr_fit.converged)
    again = tvp.dhr(y, periods, nvr=np.r_[fit.nvr[0], np.full(3, fit.nvr[1])])
    np.testing.assert_allclose(fit.loglik, again.loglik, rtol=1e-12)
    with pytest.raises(ValueError, match="shape \\(2,\\)"):
        tvp.dhr(y, periods, nvr=(1e-3, 1e-3, 1e-3), tie_periods=True)


def test_ml_nvrs_are_a_maximum_and_the_forecast_covers_a_simulated_future():
    rng = np.random.default_rng(7)
    N, h = 300, 36
    k = np.arange(N + h, dtype=float)
    amp = 1.0 + 0.5 * np.cumsum(0.02 * rng.standard_normal(N + h))  # a random-walk amplitude
    truth = 10.0 + 0.03 * k + amp * np.cos(2 * np.pi * k / 12)
    y_all = truth + 0.2 * rng.standard_normal(N + h)
    res = tvp.dhr(y_all[:N], [12.0], horizon=h)
    assert bool(res.nvr_fit.converged) and bool(res.nvr_estimated)
    for j in range(2):  # each NVR moved half a decade lowers the likelihood
        for step in (-0.5, 0.5):
            b = np.log10(np.asarray(res.nvr))
            b[j] += step
            if b[j] < -25:
                continue
            other = tvp.dhr(y_all[:N], [12.0], nvr=10.0**b)
            assert float(other.loglik) < float(res.loglik)
    lo, hi = res.forecast.interval(0.95)
    inside = (y_all[N:] >= lo[N:]) & (y_all[N:] <= hi[N:])
    assert inside.mean() >= 0.85
    assert np.sqrt(np.mean((res.forecast.mean[N:] - truth[N:]) ** 2)) < 0.5


def test_dhr_under_jit_vmap_and_grad():
    ys = np.stack([_series(seed=s, gap=False) for s in range(3)])

    def loglik(y, log_nvr):
        return tvp.dhr(y, (12.0, 4.0), nvr=10.0**log_nvr).loglik

    b = np.log10(np.array([1e-4, 1e-3, 1e-2]))
    batched = jax.jit(jax.vmap(loglik, in_axes=(0, None)))(ys, b)
    # to rounding: the diffuse start (P0 = 1e5) amplifies the order of operations' rounding to ~1e-11
    np.testing.assert_allclose(batched, [float(loglik(y, b)) for y in ys], rtol=1e-10)
    g = jax.grad(loglik, argnums=1)(ys[0], b)
    eps = 1e-5
    fd = [(float(loglik(ys[0], b + eps * e)) - float(loglik(ys[0], b - eps * e))) / (2 * eps) for e in np.eye(3)]
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6)


def test_dlr_forecast_is_the_dense_posterior_of_the_regression():
    rng = np.random.default_rng(2)
    N, h = 60, 5
    z_all = np.column_stack([np.ones(N + h), rng.standard_normal(N + h)])
    y = z_all[:N] @ np.array([1.0, 2.0]) + 0.1 * rng.standard_normal(N)
    y[10:13] = np.nan
    fc = tvp.dlr_forecast(y, z_all[:N], z_future=z_all[N:], model=["IRW", "RW"], nvr=(1e-4, 1e-3))
    F = sla.block_diag(np.array([[1.0, 1.0], [0.0, 1.0]]), np.ones((1, 1)))
    Q = np.diag([0.0, 1e-4, 1e-3])
    H = np.column_stack([z_all[:, 0], np.zeros(N + h), z_all[:, 1]])
    mean, cov, *_ = dense_posterior(np.concatenate([y, np.full(h, np.nan)]), H, F, Q, 1e5, np.zeros(3))
    m = np.sum(H * mean, axis=1)
    v = np.array([H[k] @ cov[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] @ H[k] for k in range(N + h)])
    np.testing.assert_allclose(fc.mean, m, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(fc.se, np.sqrt(float(fc.sigma2) * v), rtol=1e-7)
    assert fc.horizon == h
    # the same point estimates as jaxsdp.dlr over the data
    res = jaxsdp.dlr(y, z_all[:N], model=["IRW", "RW"], nvr=(1e-4, 1e-3))
    np.testing.assert_allclose(fc.mean[:N], np.sum(z_all[:N] * np.asarray(res.par), axis=1), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fc.sigma2, res.sigma2, rtol=1e-12)
    est = tvp.dlr_forecast(y, z_all[:N], z_future=z_all[N:], nvr="ml")
    assert est.mean.shape == (N + h,) and np.all(np.isfinite(est.obs_se))


def test_forecast_plot_draws_data_estimate_and_interval():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res = tvp.dhr(_series(), [12.0], nvr=(1e-4, 1e-3), horizon=12)
    ax = res.forecast.plot(start=10)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["95 % interval", "data", "estimate"]
    plt.close(ax.figure)
    with pytest.raises(ValueError, match="shape"):
        res.forecast.plot(t=np.arange(5))


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(periods=[1.5]), "at least 2 samples"),
        (dict(periods=[12.0, 12.0]), "twice"),
        (dict(periods=[12.0], horizon=-1), "horizon"),
        (dict(periods=[12.0], nvr=(1e-3, 1e-3, 1e-3)), r"shape \(2,\)"),
        (dict(periods=[12.0], nvr="auto"), '"ml"'),
        (dict(periods=[], trend=None), "nothing to fit"),
        (dict(periods=[np.nan]), "finite"),
        (dict(periods=[100.0]), "longer than the data"),
        (dict(periods=[12.0], nvr=-1.0), "non-negative"),
        (dict(periods=[12.0], P0=-1.0), "P0"),
        (dict(periods=[12.0], horizon=2.7), "horizon"),
        (dict(periods=[12.0], burn_in=72), "burn_in"),
        (dict(periods=[12.0], trend="CONST", cycle="CONST"), "Constant"),
    ],
)
def test_dhr_refuses_bad_arguments_by_name(kwargs, match):
    with pytest.raises(ValueError, match=match):
        tvp.dhr(_series(), **kwargs)


def test_dhr_refuses_a_series_with_too_few_observed_samples():
    y = np.full(72, np.nan)
    y[:5] = 1.0 + np.arange(5.0)
    with pytest.raises(ValueError, match="observed samples"):
        tvp.dhr(y, [12.0, 4.0], nvr=1e-3)


def test_dlr_forecast_refuses_mismatched_future_regressors():
    y, z = _series(gap=False), np.ones((72, 1))
    with pytest.raises(ValueError, match="Constant"):
        tvp.dlr_forecast(y, z, model="CONST", nvr="ml")
    with pytest.raises(ValueError, match="columns"):
        tvp.dlr_forecast(y, z, z_future=np.ones((3, 2)), nvr=1e-3)
    with pytest.raises(ValueError, match="z_future"):
        tvp.dlr_forecast(y, z, z_future=np.full((3, 1), np.nan), nvr=1e-3)
    with pytest.raises(ValueError, match="interval|level"):
        tvp.dlr_forecast(y, z, nvr=1e-3).interval(1.5)


def test_the_guide_code_runs_and_draws_its_figures():
    """docs/guides/tvp.md's code blocks (the site's build runs them for the page's figures)."""
    pytest.importorskip("statsmodels.api", reason="the guide's data ships with statsmodels (test extra)")
    import importlib.util
    import pathlib

    import matplotlib.pyplot as plt

    path = pathlib.Path(__file__).resolve().parents[1] / "docs" / "hooks.py"
    spec = importlib.util.spec_from_file_location("jaxsdp_docs_hooks", path)
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    ns = hooks.run_guide_code("tvp")
    assert {"fig_forecast", "fig_components", "fig_spectrum"} <= set(ns)
    assert ns["res"].forecast.horizon == 48 and bool(ns["res"].nvr_fit.converged)
    assert 0.3 < float(ns["rmse"]) < 2.0  # ppm, four years ahead
    assert np.all(np.isfinite(ns["filled"])) and np.all(ns["lo_gap"] < ns["filled"]) and len(ns["filled"]) == 5
    assert np.median(ns["peak_error"]) < 5.0  # Hz, a resonance sweeping 60 -> 180 Hz
    plt.close("all")


def test_irw_trend_is_the_hodrick_prescott_filter_and_its_cutoff_halves_that_period():
    hp = pytest.importorskip("statsmodels.tsa.filters.hp_filter", reason="statsmodels is in the test extra")
    rng = np.random.default_rng(5)
    y = np.cumsum(rng.standard_normal(200)) + rng.standard_normal(200)
    res = tvp.trend(y, nvr=1 / 1600.0, P0=1e8)  # HP with lambda = 1600 is the IRW smoother with NVR = 1/1600
    _, hp_trend = hp.hpfilter(y, lamb=1600.0)
    np.testing.assert_allclose(res.trend, hp_trend, rtol=0, atol=1e-7 * np.std(hp_trend))
    assert res.periods.shape == (0,) and res.cycles.shape == (200, 0)
    # the cut-off convention: a sinusoid of the cut-off period comes out at half its amplitude
    k = np.arange(2000.0)
    for period in (12.0, 40.0):
        out = np.asarray(tvp.trend(np.sin(2 * np.pi * k / period), cutoff_period=period).trend)[500:1500]
        np.testing.assert_allclose(np.std(out) / np.std(np.sin(2 * np.pi * k[500:1500] / period)), 0.5, rtol=0.01)
    with pytest.raises(ValueError, match="not both"):
        tvp.trend(y, nvr=1e-3, cutoff_period=12.0)
    with pytest.raises(ValueError, match="IRW"):
        tvp.trend(y, model="RW", cutoff_period=12.0)
    with pytest.raises(ValueError, match="above 2"):
        tvp.irw_nvr(2.0)
