"""Kalman filter / fixed-interval smoother against the dense joint Gaussian posterior."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import multivariate_normal

import jaxsdp
from dense import dense_loglik_u, dense_posterior
from jaxsdp._kalman.general import concentrated_loglik, fixed_interval_smoother, gaussian_loglik, kalman_filter
from jaxsdp._kalman.models import as_models, assemble

CASES = [
    (["RW", "IRW"], [1e-2, 1e-3]),
    (["LLT", jaxsdp.SRW(alpha=0.9)], [1e-2, 1e-3, 1e-2]),
    (["CONST", "RW"], [0.1]),
    (["IRW", "IRW"], [1e-5, 1e-1]),
    (["RW"], [0.5]),
]


def _data(p, N=150, seed=0):
    rng = np.random.default_rng(seed)
    z = np.c_[np.ones(N), rng.normal(size=(N, p - 1))] if p > 1 else np.ones((N, 1))
    y = rng.normal(size=N).cumsum() * 0.3 + z[:, -1] * 2.0 + 0.2 * rng.normal(size=N)
    y[[10, 11, 12, 60, N - 1]] = np.nan
    return y, z


def _system(mods, nvr, z):
    models = as_models(mods, z.shape[1])
    ss = assemble(models, jnp.asarray(nvr, dtype=float))
    F, Q, S = map(np.asarray, (ss.F, ss.Q, ss.S))
    return F, Q, z @ S


@pytest.mark.parametrize("P0", [1e5, 10.0])
@pytest.mark.parametrize("mods,nvr", CASES)
def test_smoother_equals_dense_posterior(mods, nvr, P0):
    y, z = _data(len(mods))
    F, Q, H = _system(mods, nvr, z)
    n = F.shape[0]
    x0 = np.linspace(0.1, 0.3, n)
    filt = kalman_filter(jnp.asarray(y), jnp.asarray(H), F, Q, jnp.asarray(x0), P0 * jnp.eye(n))
    sm = fixed_interval_smoother(filt, F, Q, full_cov=True)
    mean, cov, *_ = dense_posterior(y, H, F, Q, P0, x0)
    scale = np.abs(mean).max()
    np.testing.assert_allclose(sm.x_smooth, mean, rtol=1e-8, atol=1e-8 * scale)
    N = len(y)
    blocks = np.stack([cov[t * n : (t + 1) * n, t * n : (t + 1) * n] for t in range(N)])
    np.testing.assert_allclose(sm.P_smooth, blocks, rtol=1e-8, atol=1e-8 * np.abs(blocks).max())
    np.testing.assert_allclose(sm.P_smooth_diag, np.diagonal(blocks, axis1=1, axis2=2), rtol=1e-8)


@pytest.mark.parametrize("mods,nvr", CASES)
def test_loglik_equals_dense_mvn(mods, nvr):
    y, z = _data(len(mods), N=120, seed=1)
    F, Q, H = _system(mods, nvr, z)
    n = F.shape[0]
    x0 = np.zeros(n)
    for P0 in (10.0, 1e5):
        filt = kalman_filter(jnp.asarray(y), jnp.asarray(H), F, Q, jnp.asarray(x0), P0 * jnp.eye(n))
        _, _, prior_mean, prior_cov, Hs = dense_posterior(y, H, F, Q, P0, x0)
        for s2 in (0.3, 2.0):
            ll = gaussian_loglik(filt.innov, filt.innov_var, filt.observed, s2)
            ref = dense_loglik_u(y, H, F, Q, P0, x0, s2)
            np.testing.assert_allclose(ll, ref, rtol=1e-9)
            if P0 == 10.0:  # scipy's MVN needs a moderately conditioned covariance
                obs = ~np.isnan(y)
                Ho = Hs[obs]
                mvn = multivariate_normal(Ho @ prior_mean, s2 * (Ho @ prior_cov @ Ho.T + np.eye(obs.sum())))
                np.testing.assert_allclose(ll, mvn.logpdf(y[obs]), rtol=1e-9)
        # concentrated likelihood (no burn-in) = dense log-density at its maximiser sigma2_hat
        lik = concentrated_loglik(filt.innov, filt.innov_var, filt.observed, burn_in=0, sigma2_burn_in=0)
        ref = dense_loglik_u(y, H, F, Q, P0, x0, float(lik.sigma2))
        np.testing.assert_allclose(lik.loglik, ref, rtol=1e-9)
        assert dense_loglik_u(y, H, F, Q, P0, x0, 1.2 * float(lik.sigma2)) < ref
        assert dense_loglik_u(y, H, F, Q, P0, x0, 0.8 * float(lik.sigma2)) < ref


def test_dlr_fields_consistent():
    y, z = _data(2)
    r = jaxsdp.dlr(y, z, model=["RW", "IRW"], nvr=[1e-2, 1e-3])
    N = len(y)
    assert r.par.shape == (N, 2) and r.parse.shape == (N, 2) and r.state.shape == (N, 3)
    np.testing.assert_allclose(r.fit, np.sum(z * np.asarray(r.par), axis=1), rtol=1e-12)
    miss = np.isnan(y)
    assert np.all(np.isnan(r.innov[miss])) and np.all(np.isfinite(r.innov[~miss]))
    assert np.all(np.isfinite(r.par)) and np.all(np.isfinite(r.parse))
    # sigma2 = mean squared normalised innovation after the first dim(s) samples
    e2 = (np.asarray(r.innov) ** 2 / (np.asarray(r.innov_var) / float(r.sigma2)))[3:]
    np.testing.assert_allclose(r.sigma2, np.nanmean(e2), rtol=1e-12)
    # standard errors are sqrt(sigma2 * P)
    np.testing.assert_allclose(r.parse[:, 1], r.state_se[:, 1], rtol=1e-12)
    # smoothing reduces uncertainty relative to filtering
    assert np.all(np.asarray(r.parse) <= np.asarray(r.parse_filt) * (1 + 1e-9))


def test_constant_model_is_least_squares():
    rng = np.random.default_rng(3)
    N = 300
    z = np.c_[np.ones(N), rng.normal(size=N)]
    y = z @ np.array([1.5, -0.7]) + 0.1 * rng.normal(size=N)
    r = jaxsdp.dlr(y, z, model="CONST", P0=1e10)  # (no NVR to give: every block is Constant)
    beta = np.linalg.lstsq(z, y, rcond=None)[0]
    np.testing.assert_allclose(r.par, np.broadcast_to(beta, (N, 2)), rtol=1e-6)
    # RW with NVR = 0 is the same model
    r2 = jaxsdp.dlr(y, z, model="RW", nvr=0.0, P0=1e10)
    np.testing.assert_allclose(r2.par, r.par, rtol=1e-10)


def test_grad_loglik_wrt_log10_nvr_matches_finite_differences():
    y, z = _data(2, N=200, seed=4)

    def ll(b):
        return jaxsdp.dlr(y, z, model=["RW", "IRW"], nvr=10.0**b).loglik

    b = jnp.array([-2.0, -3.0])
    g = jax.grad(ll)(b)
    h = 1e-5
    fd = np.array([(ll(b.at[i].add(h)) - ll(b.at[i].add(-h))) / (2 * h) for i in range(2)])
    np.testing.assert_allclose(g, fd, rtol=1e-6)
    # forward mode agrees with reverse mode
    _, jv = jax.jvp(ll, (b,), (jnp.array([1.0, 0.0]),))
    np.testing.assert_allclose(jv, g[0], rtol=1e-9)


def test_grad_wrt_data_matches_finite_differences():
    y, z = _data(2, N=80, seed=5)
    y = np.nan_to_num(y)

    def f(yy):
        r = jaxsdp.dlr(yy, z, model=["RW", "IRW"], nvr=[1e-2, 1e-3])
        return r.loglik + jnp.sum(r.par[:, 1] ** 2)

    g = jax.grad(f)(jnp.asarray(y))
    rng = np.random.default_rng(0)
    d = rng.normal(size=y.shape)
    h = 1e-6
    fd = (f(y + h * d) - f(y - h * d)) / (2 * h)
    np.testing.assert_allclose(jnp.dot(g, d), fd, rtol=1e-6)


def test_jit_and_vmap_equal_loop():
    rng = np.random.default_rng(6)
    B, N = 5, 100
    z = np.c_[np.ones(N), rng.normal(size=N)]
    ys = rng.normal(size=(B, N)).cumsum(axis=1) * 0.1 + z[:, 1]
    nvrs = 10.0 ** rng.uniform(-4, -1, size=(B, 2))

    def run(y, nvr):
        r = jaxsdp.dlr(y, z, model=["RW", "IRW"], nvr=nvr)
        return r.par, r.loglik

    par_v, ll_v = jax.vmap(run)(ys, nvrs)
    par_j, ll_j = jax.jit(jax.vmap(run))(ys, nvrs)
    for i in range(B):
        par, ll = run(ys[i], nvrs[i])
        np.testing.assert_allclose(par_v[i], par, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(ll_v[i], ll, rtol=1e-10)
        np.testing.assert_allclose(par_j[i], par, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(ll_j[i], ll, rtol=1e-10)


def test_float64_without_global_x64():
    y, z = _data(1)
    with jax.enable_x64(False):
        r = jaxsdp.dlr(y, z, model="RW", nvr=1e-2)
    assert r.par.dtype == jnp.float64


def test_ml_nvr_matches_grid_minimiser():
    rng = np.random.default_rng(7)
    N = 2000
    theta = np.cumsum(rng.normal(size=N)) * 0.02
    y = theta + 0.1 * rng.normal(size=N)
    z = np.ones((N, 1))
    fit = jaxsdp.ml_nvr(y, z, model="RW")
    step = 0.02
    grid = np.arange(-4.0, 0.0 + step / 2, step)
    J = [float(jaxsdp.dlr(y, z, model="RW", nvr=10.0**b).J) for b in grid]
    b_grid = grid[int(np.argmin(J))]
    assert bool(fit.converged)
    assert abs(float(fit.log10_nvr[0]) - b_grid) <= step
    # a standard error from the curvature, finite and small for 2000 samples
    assert 0 < float(fit.log10_nvr_se[0]) < 0.5
    # the ML likelihood is at least the best grid value
    assert float(fit.J) <= min(J) + 1e-9


def test_ml_nvr_grad_zero_at_optimum():
    rng = np.random.default_rng(8)
    N = 1000
    y = np.cumsum(rng.normal(size=N)) * 0.05 + 0.1 * rng.normal(size=N)
    z = np.ones((N, 1))
    fit = jaxsdp.ml_nvr(y, z, model="IRW")
    g = jax.grad(lambda b: jaxsdp.dlr(y, z, model="IRW", nvr=10.0**b).J)(fit.log10_nvr)
    assert abs(float(g[0])) < 1e-2


@pytest.mark.parametrize(
    "model,nvr",
    [("RW", [0.1]), ("CONST", []), ("IRW", [1e-3]), (jaxsdp.SRW(alpha=0.8), [1e-2]), ("LLT", [1e-2, 1e-3])],
)
def test_closed_form_single_block_equals_dense_posterior(model, nvr):
    """`dlr` with one regressor uses the closed-form kernels of `jaxsdp._kalman.closed_form`."""
    rng = np.random.default_rng(11)
    N = 150
    z = (rng.normal(size=N) + 2.0)[:, None]
    y = np.cumsum(rng.normal(size=N)) * 0.2 + rng.normal(size=N)
    y[[5, 6, 70, N - 1]] = np.nan
    F, Q, H = _system([model], nvr, z)
    n = F.shape[0]
    r = jaxsdp.dlr(y, z, model=model, nvr=jnp.asarray(nvr, float) if nvr else 0.0)
    mean, cov, *_ = dense_posterior(y, H, F, Q, 1e5, np.zeros(n))
    var = np.diag(cov).reshape(N, n)
    np.testing.assert_allclose(r.state, mean, rtol=1e-8, atol=1e-8 * np.abs(mean).max())
    np.testing.assert_allclose(np.asarray(r.state_se) ** 2 / float(r.sigma2), var, rtol=1e-8)
    # and the same numbers as the general dense-matrix kernels
    filt = kalman_filter(jnp.asarray(y), jnp.asarray(H), F, Q, jnp.zeros(n), 1e5 * jnp.eye(n))
    lik = concentrated_loglik(filt.innov, filt.innov_var, filt.observed, burn_in=n + 1, sigma2_burn_in=n)
    np.testing.assert_allclose(r.loglik, lik.loglik, rtol=1e-10)


def test_ml_nvr_has_no_solver_option():
    """The optimistix `solver=` option was dropped (it reported false convergence; see `ml_nvr`)."""
    with pytest.raises(TypeError, match="solver"):
        jaxsdp.ml_nvr(np.ones(20), np.ones((20, 1)), solver=object())
