"""Issue 29, item 7: a user who has not enabled x64 gets float64 results that stay float64 (NumPy arrays), with
no flood of truncation warnings; with x64 enabled and inside a trace the results are JAX arrays as before."""

import warnings

import jax
import jax.numpy as jnp
import numpy as np

import jaxsdp


def _data():
    rng = np.random.default_rng(0)
    X = rng.standard_normal((200, 3))
    return X @ np.array([1.0, 2.0, 3.0]) + 0.01 * rng.standard_normal(200), X


def test_results_without_x64_are_float64_numpy_and_quiet():
    y, X = _data()
    with jax.enable_x64(False), warnings.catch_warnings():
        warnings.simplefilter("error")  # a truncation warning fails the test
        res = jaxsdp.idim_ls(y, X)
        assert isinstance(res.theta, np.ndarray) and res.theta.dtype == np.float64
        assert isinstance(res.cov, np.ndarray) and res.cov.dtype == np.float64
        np.testing.assert_allclose(res.theta, [1.0, 2.0, 3.0], atol=5e-3)
        assert float(np.sum(res.theta * 2)) > 0  # arithmetic in float64, no warning
        sm = jaxsdp.sdp(y, X[:, :1], X[:, :1], model="RW", nvr=1e-3)
        assert isinstance(sm.par, np.ndarray) and sm.par.dtype == np.float64


def test_results_with_x64_and_under_transforms_stay_jax_arrays():
    y, X = _data()
    assert isinstance(jaxsdp.idim_ls(y, X).theta, jax.Array)  # the suite runs with x64 enabled
    theta = jax.jit(lambda yy: jaxsdp.idim_ls(yy, X).theta)(jnp.asarray(y))
    assert isinstance(theta, jax.Array) and theta.dtype == jnp.float64
