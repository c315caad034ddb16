"""Bad input to `dlr`/`ml_nvr` raises a ValueError naming the argument, before any work."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxsdp

N = 50
Y = np.linspace(0.0, 1.0, N)
Z = np.ones((N, 1))


@pytest.mark.parametrize(
    "y,z,kwargs,match",
    [
        (np.ones((N, 2)), Z, {}, r"`y` must be 1-D; got shape \(50, 2\)"),
        (Y, np.ones(N), {}, r"`z` must be 2-D; got shape \(50,\)"),
        (Y, np.ones((N + 1, 1)), {}, r"one row per sample of `y`: y has shape \(50,\), z has shape \(51, 1\)"),
        (Y, np.r_[np.ones(N - 1), np.nan][:, None], {}, r"`z`: contains NaN or inf"),
        (Y, np.r_[np.ones(N - 1), np.inf][:, None], {}, r"`z`: contains NaN or inf"),
        (np.full(N, np.nan), Z, {}, r"`y`: all values are NaN"),
        (np.r_[Y[:-1], np.inf], Z, {}, r"`y`: contains inf"),
        (Y, Z, dict(nvr=-1e-3), r"`nvr`: must be non-negative"),
        (Y, Z, dict(nvr=[1e-3, 1e-3]), r"`nvr` must be a scalar or have shape \(1,\)"),
        (Y[:3], Z[:3], dict(model="IRW"), r"`y` has 3 samples; the model needs at least 4"),
        (Y, Z, dict(model="XYZ"), r"`model` entries must be"),
        (Y, np.ones((N, 2)), dict(model=["RW"]), r"`model` has 1 entries but there are 2 regressors"),
        (Y, Z, dict(P0=-1.0), r"`P0`: must be positive"),
    ],
)
def test_dlr_bad_input(y, z, kwargs, match):
    with pytest.raises(ValueError, match=match):
        jaxsdp.dlr(y, z, **{"nvr": 1e-3, **kwargs})


@pytest.mark.parametrize("alpha", [0.0, -0.5, 1.5])
def test_srw_alpha_out_of_range(alpha):
    with pytest.raises(ValueError, match=r"SRW `alpha` must lie in \(0, 1\]"):
        jaxsdp.SRW(alpha=alpha)


def test_srw_alpha_one_is_irw():
    rng = np.random.default_rng(0)
    y = rng.normal(size=N).cumsum()
    a = jaxsdp.dlr(y, Z, model=jaxsdp.SRW(alpha=1.0), nvr=1e-3)
    b = jaxsdp.dlr(y, Z, model="IRW", nvr=1e-3)
    np.testing.assert_allclose(a.par, b.par, rtol=1e-12)


def test_negative_nvr_inside_jit_raises():
    f = eqx.filter_jit(lambda nvr: jaxsdp.dlr(Y, Z, model="RW", nvr=nvr).loglik)
    assert np.isfinite(f(jnp.array(1e-3)))
    with pytest.raises(eqx.EquinoxRuntimeError, match="`nvr`: must be non-negative"):
        f(jnp.array(-1e-3)).block_until_ready()
    # under plain jax.jit the same message surfaces through XLA's runtime error
    g = jax.jit(lambda nvr: jaxsdp.dlr(Y, Z, model="RW", nvr=nvr).loglik)
    with pytest.raises(Exception, match="`nvr`: must be non-negative"):
        g(jnp.array(-1e-3)).block_until_ready()


@pytest.mark.parametrize(
    "y,z,match",
    [
        (Y, np.r_[np.ones(N - 1), np.nan][:, None], r"`z`: contains NaN or inf"),
        (Y, np.r_[np.ones(N - 1), -np.inf][:, None], r"`z`: contains NaN or inf"),
        (np.full(N, np.nan), Z, r"`y`: all values are NaN"),
        (np.r_[np.nan, Y[1:-1], np.inf], Z, r"`y`: contains inf"),
        (np.r_[Y[:-1], -np.inf], Z, r"`y`: contains inf"),
    ],
)
def test_bad_data_inside_jit_raises(y, z, match):
    """Traced data: the checks run inside the computation, one reduction per array, with the right message."""
    f = eqx.filter_jit(lambda y, z: jaxsdp.dlr(y, z, model="IRW", nvr=1e-3).par)
    assert np.isfinite(f(jnp.asarray(Y), jnp.asarray(Z))).all()
    with pytest.raises(eqx.EquinoxRuntimeError, match=match):
        f(jnp.asarray(y), jnp.asarray(z)).block_until_ready()


def test_ml_nvr_bad_input():
    with pytest.raises(ValueError, match="every block is Constant"):
        jaxsdp.ml_nvr(Y, Z, model="CONST")
    with pytest.raises(ValueError, match="`nvr0`"):
        jaxsdp.ml_nvr(Y, Z, model="RW", nvr0=0.0)
