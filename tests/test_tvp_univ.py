"""`jaxsdp.tvp.univ`, the trend plus AR(p) perturbations, against independent references: the dense Gaussian of
the state-space model, statsmodels' unobserved-components model at the same variances, the AR's closed forms."""

import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg as sla

import jaxsdp.tvp as tvp
from jaxsdp.tvp._univ import ar_covariance, ar_pacf, constrain_ar, unconstrain_ar

jax.config.update("jax_enable_x64", True)

IRW = (np.array([[1.0, 1.0], [0.0, 1.0]]), lambda v: np.diag([0.0, v[0]]))
TRENDS = {
    "IRW": IRW,
    "RW": (np.ones((1, 1)), lambda v: np.full((1, 1), v[0])),
    "LLT": (IRW[0], lambda v: np.diag([v[0], v[1]])),
}


def _series(n=60, seed=0, gap=True):
    rng = np.random.default_rng(seed)
    e = np.zeros(n)
    for k in range(2, n):
        e[k] = 0.9 * e[k - 1] - 0.4 * e[k - 2] + 0.3 * rng.standard_normal()
    y = 0.02 * np.arange(n) ** 1.3 + e + 0.05 * rng.standard_normal(n)
    if gap:
        y[25:29] = np.nan
    return y


def _system(trend, nvr_trend, ar):
    """F, Q of [trend states, AR companion states] and the observation row h, built by hand."""
    Ft, Qt = TRENDS[trend]
    p = len(ar)
    A = np.zeros((p, p))
    A[0] = ar
    A[1:, :-1] = np.eye(p - 1)
    Qa = np.zeros((p, p))
    Qa[0, 0] = 1.0
    h = np.zeros(len(Ft) + p)
    h[0] = h[len(Ft)] = 1.0
    return sla.block_diag(Ft, A), sla.block_diag(Qt(nvr_trend), Qa), h, len(Ft), A, Qa


def _dense(y, trend, nvr_trend, ar, r, P0):
    """The dense Gaussian of the model (sigma^2 = 1 units): concentrated log-likelihood, the ML sigma^2, the states'
    posterior mean (N, n) and covariance (N n, N n). The latent u = (z, u_r) ~ N(0, I): z the diffuse trend start
    (scaled by sqrt(P0)), u_r the AR's stationary start (its Lyapunov covariance by SciPy) and the state noises.
    z is conditioned on in its precision form (no P0 cancels), u_r in the covariance form C = B_r B_r^T + r I."""
    F, Q, h, nT, A, Qa = _system(trend, nvr_trend, ar)
    N, n = len(y), F.shape[0]
    ev, V = np.linalg.eigh(Q)
    C = V[:, ev > 1e-300] * np.sqrt(ev[ev > 1e-300])
    q = C.shape[1]
    L0 = sla.block_diag(np.sqrt(P0) * np.eye(nT), np.linalg.cholesky(sla.solve_discrete_lyapunov(A, Qa)))
    powers = [np.eye(n)]
    for _ in range(N):
        powers.append(F @ powers[-1])
    Amap = np.zeros((N * n, n + N * q))
    for t in range(N):  # s_t = F^(t+1) s_0 + sum_(j<=t) F^(t-j) C w_j (the kernel's prior is the state before k = 0)
        Amap[t * n : (t + 1) * n, :n] = powers[t + 1] @ L0
        for j in range(t + 1):
            Amap[t * n : (t + 1) * n, n + j * q : n + (j + 1) * q] = powers[t - j] @ C
    obs = ~np.isnan(y)
    Hs = np.zeros((N, N * n))
    for t in range(N):
        Hs[t, t * n : (t + 1) * n] = h
    B = Hs[obs] @ Amap
    d = np.zeros(Amap.shape[1], bool)
    d[:nT] = True
    G, Br, Az, Ar = B[:, d], B[:, ~d], Amap[:, d], Amap[:, ~d]
    cf = sla.cho_factor(Br @ Br.T + r * np.eye(obs.sum()))
    yo = y[obs]
    Ci_y, Ci_G = sla.cho_solve(cf, yo), sla.cho_solve(cf, G)
    lf = sla.cho_factor(np.eye(nT) + G.T @ Ci_G)
    w = G.T @ Ci_y
    quad = yo @ Ci_y - w @ sla.cho_solve(lf, w)
    m = obs.sum()
    logdet = 2 * np.sum(np.log(np.diag(cf[0]))) + 2 * np.sum(np.log(np.diag(lf[0])))
    loglik = -0.5 * m * (np.log(2 * np.pi * quad / m) + 1.0) - 0.5 * logdet
    K = Az - Ar @ (Br.T @ Ci_G)
    mean = K @ sla.cho_solve(lf, w) + Ar @ (Br.T @ Ci_y)
    cov = K @ sla.cho_solve(lf, np.eye(nT)) @ K.T + Ar @ (np.eye(Ar.shape[1]) - Br.T @ sla.cho_solve(cf, Br)) @ Ar.T
    return loglik, quad / m, mean.reshape(N, n), cov, nT


def test_the_ar_transform_is_statsmodels_and_the_prior_is_the_lyapunov_solution():
    tools = pytest.importorskip("statsmodels.tsa.statespace.tools", reason="statsmodels is in the test extra")
    rng = np.random.default_rng(0)
    constrain, unconstrain, cov = jax.jit(constrain_ar), jax.jit(unconstrain_ar), jax.jit(ar_covariance)
    for p in (1, 2, 5):
        x = 2.0 * rng.standard_normal(p)
        a = tools.constrain_stationary_univariate(x)
        np.testing.assert_allclose(constrain(jnp.asarray(x)), a, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(unconstrain(jnp.asarray(a)), tools.unconstrain_stationary_univariate(a), rtol=1e-9)
        assert np.all(np.abs(np.roots(np.r_[1.0, -a])) < 1.0)  # stationary: the companion's eigenvalues inside
        np.testing.assert_allclose(ar_pacf(a), -x / np.sqrt(1 + x**2), rtol=1e-10)
        _, _, _, _, A, Qa = _system("RW", [0.0], a)
        np.testing.assert_allclose(cov(jnp.asarray(a)), sla.solve_discrete_lyapunov(A, Qa), rtol=1e-10)


@pytest.mark.parametrize(
    "trend,nvr,ar,irregular",
    [
        ("IRW", (1e-3,), (0.9, -0.4), False),
        ("IRW", (1e-3, 0.2), (0.9, -0.4), True),
        ("RW", (0.05,), (0.6,), False),
        ("LLT", (1e-2, 1e-4, 0.5), (0.5, 0.2, -0.3), True),
    ],
)
def test_univ_loglik_is_the_dense_gaussian_maximised_over_sigma2(trend, nvr, ar, irregular):
    y = _series()
    k = len(nvr) - int(irregular)
    res = tvp.univ(y, len(ar), trend=trend, irregular=irregular, nvr=nvr, ar=ar, P0=1e5, burn_in=0)
    ll, s2, *_ = _dense(y, trend, nvr[:k], np.array(ar), nvr[-1] if irregular else 0.0, 1e5)
    np.testing.assert_allclose(res.loglik, ll, rtol=1e-9)
    np.testing.assert_allclose(res.sigma2, s2, rtol=1e-9)
    assert not bool(res.estimated) and res.fit is None and bool(res.definite)


@pytest.mark.parametrize(
    "trend,flags,irregular",
    [
        ("IRW", dict(level=True, trend=True, stochastic_trend=True), False),
        ("IRW", dict(level=True, trend=True, stochastic_trend=True), True),
        ("RW", dict(level=True, stochastic_level=True), True),
        ("LLT", dict(level=True, trend=True, stochastic_level=True, stochastic_trend=True), False),
    ],
)
def test_univ_loglik_is_statsmodels_unobserved_components(trend, flags, irregular):
    """The same model as statsmodels' `UnobservedComponents(..., autoregressive=p, irregular=)`, started at univ's
    prior (statsmodels' known initial state is the prediction for the first sample: F P0 F^T + Q)."""
    sm = pytest.importorskip("statsmodels.api", reason="statsmodels is in the test extra")
    y, ar, P0 = _series(seed=4), np.array([0.9, -0.4]), 1e3
    nvr_trend = {"IRW": [2e-3], "RW": [0.03], "LLT": [1e-2, 1e-4]}[trend]
    nvr = (*nvr_trend, 0.3) if irregular else tuple(nvr_trend)
    res = tvp.univ(y, 2, trend=trend, irregular=irregular, nvr=nvr, ar=ar, P0=P0, burn_in=0)
    s2 = float(res.sigma2)
    F, Q, _, nT, A, Qa = _system(trend, nvr_trend, ar)
    P_trend = F[:nT, :nT] @ (P0 * np.eye(nT)) @ F[:nT, :nT].T + Q[:nT, :nT]
    P1 = sla.block_diag(P_trend, sla.solve_discrete_lyapunov(A, Qa))
    mod = sm.tsa.UnobservedComponents(y, autoregressive=2, irregular=irregular, **flags)
    mod.ssm.initialize_known(np.zeros(mod.k_states), s2 * P1)
    mod.loglikelihood_burn = 0
    values = {"sigma2.irregular": 0.3 * s2, "sigma2.ar": s2, "ar.L1": ar[0], "ar.L2": ar[1]}
    values["sigma2.level" if trend in ("RW", "LLT") else "sigma2.trend"] = nvr_trend[0] * s2
    if trend == "LLT":
        values["sigma2.trend"] = nvr_trend[1] * s2
    ll = mod.loglike(np.array([values[name] for name in mod.param_names]))
    np.testing.assert_allclose(res.loglik, ll, rtol=1e-8)


def test_components_gaps_and_forecast_are_the_dense_posterior_and_the_ar_decays_as_a_power():
    y, h, ar, nvr = _series(seed=1), 10, np.array([0.9, -0.4]), (1e-3, 0.2)
    N = len(y)
    res = tvp.univ(y, 2, irregular=True, nvr=nvr, ar=ar, horizon=h, P0=1e5)
    ypad = np.concatenate([y, np.full(h, np.nan)])
    _, _, mean, cov, nT = _dense(ypad, "IRW", nvr[:1], ar, nvr[1], 1e5)
    n = mean.shape[1]
    s2 = float(res.sigma2)  # the ML sigma^2 over the samples after the burn-in (the dense one is over all)

    def signal(states):
        r = np.zeros(n)
        r[states] = 1.0  # the trend's level, the AR's current value, or both
        v = np.array([r @ cov[k * n : (k + 1) * n, k * n : (k + 1) * n] @ r for k in range(N + h)])
        return mean @ r, np.sqrt(s2 * v)

    for name, got, got_se, states in [
        ("trend", res.trend, res.trend_se, [0]),
        ("perturbation", res.perturbation, res.perturbation_se, [nT]),
        ("signal", res.forecast.mean, res.forecast.se, [0, nT]),
    ]:
        m, se = signal(states)
        np.testing.assert_allclose(got, m, rtol=1e-8, atol=1e-8, err_msg=name)
        np.testing.assert_allclose(got_se, se, rtol=1e-7, atol=1e-10, err_msg=name)
    np.testing.assert_allclose(res.forecast.obs_se, np.sqrt(res.forecast.se**2 + nvr[1] * s2), rtol=1e-12)
    np.testing.assert_allclose(res.forecast.sigma2, nvr[1] * s2, rtol=1e-12)
    np.testing.assert_allclose(res.resid, y - res.trend[:N] - res.perturbation[:N], rtol=1e-12)
    assert np.all(np.isfinite(res.forecast.filled)) and res.forecast.horizon == h
    # beyond the data the AR's mean is a^j propagated from its last state, the IRW trend a straight line
    state = np.asarray(res.perturbation)[N - 1 : N - 3 : -1]  # [e_(N-1), e_(N-2)] given all the data
    _, _, _, _, A, _ = _system("IRW", nvr[:1], ar)
    powers = np.array([(np.linalg.matrix_power(A, j) @ state)[0] for j in range(1, h + 1)])
    np.testing.assert_allclose(res.perturbation[N:], powers, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.diff(np.asarray(res.trend)[N - 1 :], 2), 0.0, atol=1e-9)


def test_without_irregular_the_components_add_up_to_the_data_and_fill_the_gap_as_the_dense_posterior():
    y, ar, nvr = _series(seed=2), np.array([0.6]), (0.05,)
    res = tvp.univ(y, 1, trend="RW", nvr=nvr, ar=ar, horizon=3)
    N = len(y)
    _, _, mean, cov, nT = _dense(np.concatenate([y, np.full(3, np.nan)]), "RW", nvr, ar, 0.0, 1e5)
    np.testing.assert_allclose(res.trend, mean[:, 0], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(res.perturbation, mean[:, nT], rtol=1e-8, atol=1e-8)
    var_t = np.array([cov[k * 2, k * 2] for k in range(N + 3)])
    np.testing.assert_allclose(res.trend_se, np.sqrt(float(res.sigma2) * var_t), rtol=1e-7)
    obs = ~np.isnan(y)
    np.testing.assert_allclose((res.trend + res.perturbation)[:N][obs], y[obs], rtol=1e-10)
    np.testing.assert_allclose(res.forecast.se[:N][obs], 0.0, atol=1e-6 * np.nanstd(y))
    np.testing.assert_allclose(res.forecast.obs_se, res.forecast.se)  # no irregular: a new value is the signal


def _simulate(n, seed, ar, nvr_trend, irregular=0.0, sigma=0.5):
    rng = np.random.default_rng(seed)
    slope = np.cumsum(np.sqrt(nvr_trend) * sigma * rng.standard_normal(n)) + 0.01
    trend = 10.0 + np.cumsum(slope)
    e = np.zeros(n)
    for k in range(n):
        e[k] = sum(a * e[k - i - 1] for i, a in enumerate(ar) if k - i - 1 >= 0) + sigma * rng.standard_normal()
    return trend + e + np.sqrt(irregular) * sigma * rng.standard_normal(n), trend, e


def test_ml_recovers_the_ar_and_the_trend_nvr_of_a_long_simulated_series():
    """1000 samples of an IRW trend (NVR 1e-4) and an AR(2): the estimates' standard errors are about 0.035 for
    each coefficient and 0.15 for log10 NVR (the fit's curvature), so the bounds are some 3 of them."""
    ar, nvr = np.array([0.7, -0.3]), 1e-4
    y, trend, e = _simulate(1000, 11, ar, nvr)
    res = tvp.univ(y, 2)
    assert bool(res.fit.converged) and not np.any(res.fit.at_bound), res.fit.reason
    np.testing.assert_allclose(res.ar, ar, atol=0.1)
    assert abs(np.log10(float(res.nvr[0])) - np.log10(nvr)) < 0.5
    np.testing.assert_allclose(np.sqrt(float(res.sigma2)), 0.5, rtol=0.05)
    assert np.sqrt(np.mean((np.asarray(res.trend) - trend) ** 2)) < 0.5 * np.std(e)
    np.testing.assert_allclose(res.fit.loglik, res.loglik, rtol=1e-12)
    other = tvp.univ(y, 2, ar0=[1.2, -0.4])  # another start, the same maximum
    np.testing.assert_allclose(other.ar, res.ar, atol=1e-3)
    np.testing.assert_allclose(other.loglik, res.loglik, rtol=1e-9)
    # a maximum: each hyperparameter moved (half a decade, 0.05 in a coefficient) lowers the likelihood
    base = float(res.loglik)
    for step in (-0.5, 0.5):
        assert float(tvp.univ(y, 2, nvr=float(res.nvr[0]) * 10**step, ar=res.ar).loglik) < base
    for i in range(2):
        for step in (-0.05, 0.05):
            moved = np.asarray(res.ar).copy()
            moved[i] += step
            assert float(tvp.univ(y, 2, nvr=res.nvr, ar=moved).loglik) < base


def test_ml_with_an_irregular_finds_its_ratio_from_the_default_start():
    """The irregular's ratio starts at 1: from 1e-4 (the trend's start) the likelihood is flat in its log10 and
    the search stops at a saddle, the ratio where it started and the AR off (the guide says so)."""
    ar, ratio = np.array([0.7, -0.3]), 0.5
    y, _, _ = _simulate(1000, 11, ar, 1e-4, irregular=ratio)
    res = tvp.univ(y, 2, irregular=True)
    assert bool(res.fit.converged) and not np.any(res.fit.at_bound), res.fit.reason
    np.testing.assert_allclose(res.ar, ar, atol=0.1)
    assert abs(np.log10(float(res.nvr[1])) - np.log10(ratio)) < 0.5
    np.testing.assert_allclose(np.sqrt(float(res.sigma2)), 0.5, rtol=0.15)
    stuck = tvp.univ(y, 2, irregular=True, nvr0=1e-4)
    assert not bool(stuck.fit.converged) and "not a minimum" in stuck.fit.reason
    np.testing.assert_allclose(stuck.nvr[1], 1e-4, rtol=0.05)
    assert float(stuck.loglik) < float(res.loglik) and abs(float(stuck.ar[0]) - ar[0]) > 0.1


def test_ml_is_statsmodels_maximum_likelihood_estimate():
    """statsmodels' own fit of the same model (its approximate diffuse start: variance 1e6, the likelihood from the
    third sample) reaches the same estimate; its log-likelihood at univ's estimate is as high as at its own."""
    sm = pytest.importorskip("statsmodels.api", reason="statsmodels is in the test extra")
    y, _, _ = _simulate(300, 5, np.array([0.7, -0.3]), 1e-4)
    res = tvp.univ(y, 2)
    mod = sm.tsa.UnobservedComponents(
        y, level=True, trend=True, stochastic_trend=True, autoregressive=2, irregular=False
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # statsmodels' optimiser's convergence chatter
        fit = mod.fit(disp=False)
    trend_var, ar_var, *ar = fit.params
    np.testing.assert_allclose(res.ar, ar, atol=1e-3)
    assert abs(np.log10(float(res.nvr[0]) / (trend_var / ar_var))) < 0.01
    np.testing.assert_allclose(res.sigma2, ar_var, rtol=1e-3)
    np.testing.assert_allclose(res.loglik, fit.llf, atol=2e-3)  # P0 = 1e5 here, 1e6 there
    s2 = float(res.sigma2)
    assert mod.loglike(np.r_[float(res.nvr[0]) * s2, s2, np.asarray(res.ar)]) >= fit.llf - 1e-6


def test_jit_vmap_and_grad():
    ys = np.stack([_series(seed=s, gap=False) for s in range(3)])

    def loglik(y, b):
        return tvp.univ(y, 2, irregular=True, nvr=10.0 ** b[:2], ar=constrain_ar(b[2:])).loglik

    b = np.array([-3.0, -0.7, -0.8, 0.4])
    batched = jax.jit(jax.vmap(loglik, in_axes=(0, None)))(ys, b)
    np.testing.assert_allclose(batched, [float(loglik(y, b)) for y in ys], rtol=1e-10)
    g = jax.grad(loglik, argnums=1)(ys[0], b)
    eps = 1e-5
    fd = [(float(loglik(ys[0], b + eps * e)) - float(loglik(ys[0], b - eps * e))) / (2 * eps) for e in np.eye(4)]
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize(
    "args,kwargs,match",
    [
        ((0,), {}, "ar_order"),
        ((1.5,), {}, "ar_order"),
        ((True,), {}, "ar_order"),
        ((2,), dict(ar=[0.5]), r"shape \(2,\)"),
        ((1,), dict(ar=[1.0]), "stationary"),
        ((2,), dict(ar=[0.5, 0.6]), "stationary"),
        ((2,), dict(ar=[np.nan, 0.1]), "finite"),
        ((1,), dict(ar0=[-1.2]), "`ar0`: must be a stationary"),
        ((1,), dict(nvr=(1e-3, 1e-3)), r"shape \(1,\)"),
        ((1,), dict(nvr="auto"), '"ml"'),
        ((1,), dict(nvr=-1.0), "non-negative"),
        ((1,), dict(trend=None), "trend"),
        ((1,), dict(trend="CONST", ar=[0.5]), "nothing to estimate"),
        ((1,), dict(horizon=-1), "horizon"),
        ((1,), dict(burn_in=60), "burn_in"),
        ((1,), dict(P0=0.0), "P0"),
    ],
)
def test_univ_refuses_bad_arguments_by_name(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        tvp.univ(_series(), *args, **kwargs)


def test_univ_refuses_a_series_without_data():
    with pytest.raises(ValueError, match="NaN"):
        tvp.univ(np.full(40, np.nan), 1, nvr=1e-3, ar=[0.5])
    y = np.full(40, np.nan)
    y[:4] = 1.0 + np.arange(4.0)
    with pytest.raises(ValueError, match="observed samples"):
        tvp.univ(y, 2, nvr=1e-3, ar=[0.5, 0.1])
