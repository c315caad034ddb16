"""`dlr` under `jax.vmap`: the shared-covariance batch rule equals the per-series kernels."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxsdp
import jaxsdp._kalman.dlr_block as dlr_small

FIELDS = (
    "par",
    "parse",
    "par_filt",
    "parse_filt",
    "state",
    "state_se",
    "fit",
    "resid",
    "innov",
    "innov_var",
    "sigma2",
    "loglik",
    "J",
)


def _batch(B=5, N=120, seed=0, p_nan=0.0):
    rng = np.random.default_rng(seed)
    t = np.arange(N)
    Y = np.sin(2 * np.pi * t / 60 + rng.uniform(0, 6, (B, 1))) + 0.2 * rng.normal(size=(B, N))
    if p_nan:
        Y[rng.uniform(size=(B, N)) < p_nan] = np.nan
    z = (1.5 + np.cos(t / 9.0))[:, None]
    return Y, z


def _loop(Y, z, model, nvr):
    return [jaxsdp.dlr(y, z, model=model, nvr=nvr) for y in Y]


def _assert_equal(batched, loop, rtol=1e-9):
    for name in FIELDS:
        got = np.asarray(getattr(batched, name))
        want = np.stack([np.asarray(getattr(r, name)) for r in loop])
        scale = np.nanmax(np.abs(want)) if np.isfinite(want).any() else 1.0
        np.testing.assert_allclose(got, want, rtol=rtol, atol=rtol * scale, err_msg=name)


@pytest.mark.parametrize(
    "model,nvr",
    [("RW", 0.05), ("IRW", 1e-3), ("LLT", [1e-2, 1e-4]), (jaxsdp.SRW(alpha=0.7), 1e-2), ("CONST", [])],
)
def test_shared_covariance_batch_equals_loop(model, nvr, monkeypatch):
    """Complete series with a shared regressor: the covariances are computed once for the batch."""
    traced = []
    shared = dlr_small._shared_covariance
    monkeypatch.setattr(dlr_small, "_shared_covariance", lambda *a, **k: traced.append(1) or shared(*a, **k))
    Y, z = _batch()
    nvr = jnp.asarray(nvr, float)
    batched = jax.jit(jax.vmap(lambda y: jaxsdp.dlr(y, z, model=model, nvr=nvr)))(Y)
    assert traced, "the shared-covariance rule was not used"
    _assert_equal(batched, _loop(Y, z, model, nvr))


def test_shared_covariance_batch_with_one_burn_in():
    """burn_in = dim(s): sigma^2 and the likelihood use the same samples (one set of sums)."""
    Y, z = _batch(seed=5)
    batched = jax.vmap(lambda y: jaxsdp.dlr(y, z, model="IRW", nvr=1e-3, burn_in=2))(Y)
    _assert_equal(batched, [jaxsdp.dlr(y, z, model="IRW", nvr=1e-3, burn_in=2) for y in Y])
    assert np.all(np.isfinite(np.asarray(batched.sigma2)))


def test_batch_with_missing_samples_uses_per_series_kernels():
    Y, z = _batch(p_nan=0.05, seed=1)
    batched = jax.vmap(lambda y: jaxsdp.dlr(y, z, model="IRW", nvr=1e-3))(Y)
    _assert_equal(batched, _loop(Y, z, "IRW", 1e-3))
    assert np.isnan(np.asarray(batched.innov)).sum() == np.isnan(Y).sum()


def test_batched_regressor_and_nvr_use_per_series_kernels():
    Y, z = _batch(seed=2)
    Z = np.stack([z * (1 + 0.1 * i) for i in range(Y.shape[0])])
    nvrs = jnp.logspace(-4, -1, Y.shape[0])
    got = jax.vmap(lambda y, zz, q: jaxsdp.dlr(y, zz, model="RW", nvr=q))(Y, Z, nvrs)
    want = [jaxsdp.dlr(y, zz, model="RW", nvr=q) for y, zz, q in zip(Y, Z, nvrs)]
    _assert_equal(got, want)


def test_grad_and_jvp_through_vmap():
    """Derivatives of batched results go through the per-series kernels' rules."""
    Y, z = _batch(B=3, seed=3)

    def total_J(b):
        return jnp.sum(jax.vmap(lambda y: jaxsdp.dlr(y, z, model="IRW", nvr=10.0**b).J)(Y))

    g = jax.grad(total_J)(-2.0)
    h = 1e-5
    fd = (total_J(-2.0 + h) - total_J(-2.0 - h)) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-5)
    _, t = jax.jvp(total_J, (-2.0,), (1.0,))
    np.testing.assert_allclose(t, g, rtol=1e-10)
    # per-series gradients under vmap of grad
    gs = jax.vmap(jax.grad(lambda y: jnp.sum(jaxsdp.dlr(y, z, model="IRW", nvr=1e-3).par ** 2)))(Y)
    g0 = jax.grad(lambda y: jnp.sum(jaxsdp.dlr(y, z, model="IRW", nvr=1e-3).par ** 2))(Y[0])
    np.testing.assert_allclose(gs[0], g0, rtol=1e-10)


@pytest.mark.parametrize("model,nvr", [("IRW", [1e-3]), (["RW", "IRW"], [1e-2, 1e-4]), ("LLT", [1e-2, 1e-3])])
def test_dlr_loglik_equals_dlr_and_differentiates(model, nvr):
    rng = np.random.default_rng(4)
    N = 200
    z = np.c_[np.ones(N), rng.normal(size=N)] if isinstance(model, list) else np.ones((N, 1))
    y = np.cumsum(rng.normal(size=N)) * 0.1 + z[:, -1] + 0.3 * rng.normal(size=N)
    y[[7, 50, 51]] = np.nan
    nvr = jnp.asarray(nvr)
    lik = jaxsdp.dlr_loglik(y, z, model=model, nvr=nvr)
    full = jaxsdp.dlr(y, z, model=model, nvr=nvr)
    np.testing.assert_allclose(lik.loglik, full.loglik, rtol=1e-11)
    np.testing.assert_allclose(lik.J, full.J, rtol=1e-11)
    f = lambda b: jaxsdp.dlr_loglik(y, z, model=model, nvr=10.0**b).loglik
    b = jnp.log10(nvr)
    g = jax.grad(f)(b)
    _, t = jax.jvp(f, (b,), (jnp.ones_like(b),))
    np.testing.assert_allclose(t, jnp.sum(g), rtol=1e-9)
    h = 1e-5
    for i in range(b.shape[0]):
        e = jnp.zeros_like(b).at[i].set(h)
        np.testing.assert_allclose(g[i], (f(b + e) - f(b - e)) / (2 * h), rtol=1e-5, atol=1e-6)


def test_dlr_loglik_bad_input():
    with pytest.raises(ValueError, match="`nvr`"):
        jaxsdp.dlr_loglik(np.ones(10), np.ones((10, 1)), model="RW", nvr=-1.0)
    with pytest.raises(ValueError, match="`z`"):
        jaxsdp.dlr_loglik(np.ones(10), np.ones((9, 1)), model="RW", nvr=1.0)
