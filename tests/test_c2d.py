"""ZOH discretisation `c2d` against scipy.signal.cont2discrete, an upsampled simulation, finite differences."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal as sig

from jaxsdp.tfest._c2d import c2d

BENCH = ([-6400.0, 1600.0], [1.0, 5.0, 408.0, 416.0, 1600.0])
CASES = {
    "n1-strict": ([2.0], [1.0, 1.0]),
    "n1-biproper": ([3.0, -1.0], [1.0, 0.5]),
    "n2-strict": ([1.0], [1.0, 0.4, 4.0]),
    "n2-biproper": ([1.0, 2.0, 3.0], [1.0, 0.4, 4.0]),
    "n4-benchmark": BENCH,
    "n4-biproper": ([1.0, 0.0, -2.0, 2.0, 1.0], [1.0, 5.0, 408.0, 416.0, 1600.0]),
}


def _scipy(num, den, dt):
    nd, dd, _ = sig.cont2discrete((num, den), dt, method="zoh")
    return nd.ravel(), np.asarray(dd)


def _close(got, want, tol=1e-10):
    got = np.asarray(got)
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=tol, atol=tol * np.max(np.abs(want)))


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("dt", [0.01, 0.1])
def test_c2d_matches_scipy(name, dt):
    num, den = CASES[name]
    num_d, den_d = c2d(num, den, dt)
    want_num, want_den = _scipy(num, den, dt)
    _close(num_d, want_num)
    _close(den_d, want_den)


def test_whole_sample_delay_pads_with_zeros():
    num, den = CASES["n2-biproper"]
    num_d, den_d = c2d(num, den, 0.1, delay=0.3)
    want_num, want_den = _scipy(num, den, 0.1)
    _close(num_d, np.r_[0.0, 0.0, 0.0, want_num])
    _close(den_d, np.r_[want_den, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("name", ["n1-biproper", "n2-strict"])
def test_fractional_delay_matches_upsampled_simulation(name):
    # A delay of 2.5 samples at dt is 5 whole samples at dt / 2: simulate the input held over
    # pairs of half-steps with scipy's exact ZOH model at dt / 2 and keep every other sample.
    num, den = CASES[name]
    dt = 0.1
    u = np.random.default_rng(0).standard_normal(120)
    num_d, den_d = c2d(num, den, dt, delay=0.25)
    assert num_d.shape == den_d.shape == (len(den) + 3,)
    y = sig.lfilter(np.asarray(num_d), np.asarray(den_d), u)
    nh, dh = _scipy(num, den, dt / 2)
    yh = sig.lfilter(np.r_[np.zeros(5), nh], dh, np.repeat(u, 2))[::2]
    np.testing.assert_allclose(y, yh, rtol=0, atol=1e-11 * np.max(np.abs(yh)))


def test_c2d_gradient_matches_finite_differences():
    num, den = CASES["n2-biproper"]
    w = jnp.linspace(0.5, 1.5, 3)

    def f(params):
        a1, a2, b0, dt = params
        nd, dd = c2d(jnp.stack([b0, 2.0, 3.0]), jnp.stack([1.0, a1, a2]), dt)
        return jnp.sum(w * nd) + jnp.sum(w[::-1] * dd)

    x = jnp.array([0.4, 4.0, 1.0, 0.1])
    g = np.asarray(jax.grad(f)(x))
    h = 1e-6
    fd = np.array([(f(x.at[i].add(h)) - f(x.at[i].add(-h))) / (2 * h) for i in range(4)])
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=1e-8)


def test_c2d_under_jit_and_vmap():
    num, den = CASES["n1-biproper"]
    dts = jnp.array([0.01, 0.02, 0.05])
    nd, dd = jax.vmap(jax.jit(lambda dt: c2d(num, den, dt)))(dts)
    for i, dt in enumerate([0.01, 0.02, 0.05]):
        want_num, want_den = _scipy(num, den, dt)
        _close(nd[i], want_num)
        _close(dd[i], want_den)


@pytest.mark.parametrize(
    "args,kwargs,match",
    [
        (([1.0], [1.0, 1.0], 0.0), {}, "dt"),
        (([1.0], [1.0, 1.0], -0.1), {}, "dt"),
        (([1.0], [2.0, 1.0], 0.1), {}, "monic"),
        (([1.0, 1.0, 1.0], [1.0, 1.0], 0.1), {}, "exceeds"),
        (([1.0], [1.0, np.nan], 0.1), {}, "NaN"),
        (([1.0], [1.0, 1.0], 0.1), {"delay": -0.1}, "delay"),
    ],
)
def test_c2d_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        c2d(*args, **kwargs)
