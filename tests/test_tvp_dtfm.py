"""Time-variable transfer functions by refined IV (`jaxsdp.tvp.dtfm`): a pole that drifts and a gain that jumps
under white and coloured output noise, where `darx` (least squares) is biased; constant coefficients against the
time-invariant refined IV of `jaxsdp.tfest.rivbj`; noise-free data; gaps; jit, vmap and gradients."""

import jax
import numpy as np
import pytest
import scipy.signal as sig

import jaxsdp.tvp as tvp
from jaxsdp.tfest import rivbj

jax.config.update("jax_enable_x64", True)

N = 1500


def _drifting_system(colour=0.0, noise=0.4, seed=0, n=N):
    """x_k = pole_k x_(k-1) + gain_k u_(k-1), the pole drifting 0.5 -> 0.9, the gain jumping 1 -> 2 at n/2;
    y = x + xi, xi white (colour 0) or AR(1) with pole `colour`, its std `noise` times x's."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    k = np.arange(n)
    pole, gain = 0.5 + 0.4 * k / n, np.where(k < n // 2, 1.0, 2.0)
    x = np.zeros(n)
    for i in range(1, n):
        x[i] = pole[i] * x[i - 1] + gain[i] * u[i - 1]
    xi = sig.lfilter([1.0], [1.0, -colour], rng.standard_normal(n))
    return x + noise * x.std() / xi.std() * xi, u, np.column_stack([pole, gain])


#: Samples away from the ends and from the jump (where a random walk smooths a step over tens of samples).
K = np.arange(N)
AWAY = (np.abs(K - N // 2) > 100) & (K > 50) & (K < N - 50)


def _rmse(coef, truth):
    return np.sqrt(np.mean((np.asarray(coef)[AWAY] - truth[AWAY]) ** 2, axis=0))


@pytest.fixture(scope="module")
def white():
    y, u, truth = _drifting_system()
    return y, u, truth, tvp.darx(y, u, na=1, nb=1, delay=1, demean=False), tvp.dtfm(y, u, na=1, nb=1)


def test_dtfm_removes_the_bias_darx_has_under_white_output_noise(white):
    """Measured (seed 0, away from the ends and the jump): the pole's RMS error 0.184 for darx (bias -0.156:
    pulled towards zero, 3.7 times its median standard error), 0.014 for dtfm; the gain's 0.119 and 0.083."""
    _, _, truth, ls, iv = white
    assert bool(iv.converged) and 1 <= int(iv.iterations) <= 12 and float(iv.change) < 1e-4
    assert bool(iv.nvr_fit.converged) and bool(iv.definite) and iv.nvr_estimated
    err_ls, err_iv = _rmse(ls.coef, truth), _rmse(iv.coef, truth)
    bias_ls = np.mean(np.asarray(ls.coef)[AWAY, 0] - truth[AWAY, 0])
    # darx's pole error is its bias, not its smoothing error
    assert bias_ls < -0.1 and abs(bias_ls) > 3 * np.median(np.asarray(ls.coef_se)[AWAY, 0])
    assert err_iv[0] < 0.25 * err_ls[0] and err_iv[0] < 0.03, (err_ls, err_iv)
    assert err_iv[1] < err_ls[1]
    # the truth inside dtfm's 95 % band almost everywhere away from the jump, on both coefficients
    inside = np.abs(np.asarray(iv.coef)[AWAY] - truth[AWAY]) < 1.96 * np.asarray(iv.coef_se)[AWAY]
    assert np.all(inside.mean(axis=0) > 0.9), inside.mean(axis=0)
    # the jump is found: the gain's NVR above the drifting pole's
    assert float(iv.nvr[1]) > 10 * float(iv.nvr[0])
    # the auxiliary model's output is the noise-free output: its residual is the white measurement noise
    r = np.asarray(iv.resid)[100:]
    assert abs(np.corrcoef(r[1:], r[:-1])[0, 1]) < 0.1
    np.testing.assert_allclose(iv.d, [1.0])


def test_coloured_noise_with_an_ar_noise_model():
    """AR(1) output noise (pole 0.9): darx's pole is pushed towards the noise's (measured, seed 0: RMS error
    0.102, bias +0.075); dtfm with nd=1 finds the noise pole and brings the error to 0.017 (gain: 0.072 and 0.066).
    With the white-noise default nd=0 the prefiltered error is coloured, the NVRs follow the noise and the
    iteration diverges: `converged` says so."""
    y, u, truth = _drifting_system(colour=0.9)
    ls = tvp.darx(y, u, na=1, nb=1, delay=1, demean=False)
    iv = tvp.dtfm(y, u, na=1, nb=1, nd=1)
    assert bool(iv.converged)
    err_ls, err_iv = _rmse(ls.coef, truth), _rmse(iv.coef, truth)
    assert err_iv[0] < 0.25 * err_ls[0] and err_iv[1] < 1.1 * err_ls[1], (err_ls, err_iv)
    np.testing.assert_allclose(iv.d[1], -0.9, atol=0.05)
    inside = np.abs(np.asarray(iv.coef)[AWAY] - truth[AWAY]) < 1.96 * np.asarray(iv.coef_se)[AWAY]
    assert np.all(inside.mean(axis=0) > 0.9), inside.mean(axis=0)
    wrong = tvp.dtfm(y, u, na=1, nb=1)  # nd=0
    assert not bool(wrong.converged) and int(wrong.iterations) == 20


def test_constant_coefficients_give_the_time_invariant_refined_iv_estimate():
    """With NVRs of 0 the IV smoother is the IV normal equations and the fixed point is discrete refined IV with
    an AR noise model: `rivbj` (independent code: one Gram matrix of filtered features); they differ only in the
    first rows (rivbj's zeros before the record, dtfm's first sample with its lags) and the diffuse prior."""
    rng = np.random.default_rng(5)
    n = 1000
    u = rng.standard_normal(n)
    x = sig.lfilter([0.0, 0.5, 0.3], [1.0, -1.2, 0.5], u)
    xi = sig.lfilter([1.0], [1.0, -0.8], rng.standard_normal(n))
    y = x + 0.5 * x.std() / xi.std() * xi
    res = tvp.dtfm(y, u, na=2, nb=2, nd=1, nvr=0.0, tol=1e-10, iterations=50)
    ref = rivbj(y, u, n=2, m=1, nc=0, nd=1, delay=1)
    assert bool(res.converged)
    coef, se = np.asarray(res.coef), np.asarray(res.coef_se)
    np.testing.assert_allclose(coef, np.broadcast_to(coef[-1], coef.shape), atol=1e-9)  # constant
    want = np.r_[-np.asarray(ref.den)[1:], np.asarray(ref.num)]
    ref_se = np.sqrt(np.diag(np.asarray(ref.cov)))
    assert np.all(np.abs(coef[-1] - want) < 0.03 * ref_se), (coef[-1], want, ref_se)
    np.testing.assert_allclose(se[-1], ref_se, rtol=0.01)
    np.testing.assert_allclose(res.d, ref.d, atol=1e-3)
    np.testing.assert_allclose(res.sigma2, ref.sigma2, rtol=0.01)
    # and darx, least squares on the same data, is far from it
    far = np.asarray(tvp.darx(y, u, na=2, nb=2, delay=1, nvr=0.0, demean=False).coef)[-1]
    assert np.abs(far - want)[0] > 5 * ref_se[0]  # measured: 0.156, 8.5 standard errors


def test_noise_free_data_and_no_iteration_give_darx():
    """Noise-free data: darx is exact and so is dtfm (its simulated output is the data). `iterations=0` is
    darx's estimate on any data."""
    rng = np.random.default_rng(2)
    n = 400
    u = rng.standard_normal(n)
    y = sig.lfilter([0.0, 0.4, 0.2], [1.0, -1.3, 0.6], u)
    truth = np.array([1.3, -0.6, 0.4, 0.2])
    ls = tvp.darx(y, u, na=2, nb=2, delay=1, nvr=1e-4, demean=False)
    iv = tvp.dtfm(y, u, na=2, nb=2, nvr=1e-4)
    # exact but for the diffuse prior's pull towards 0 (P0 = 1e5): 3e-7 at the start
    np.testing.assert_allclose(np.asarray(ls.coef)[4:], np.broadcast_to(truth, (n - 4, 4)), atol=1e-6)
    np.testing.assert_allclose(np.asarray(iv.coef)[4:], np.asarray(ls.coef)[4:], atol=1e-6)
    np.testing.assert_allclose(iv.x_hat, y, atol=1e-6)
    noisy = y + 0.3 * y.std() * rng.standard_normal(n)
    start = tvp.dtfm(noisy, u, na=2, nb=2, nvr=1e-4, iterations=0)
    ref = tvp.darx(noisy, u, na=2, nb=2, delay=1, nvr=1e-4, demean=False)
    np.testing.assert_allclose(start.coef, ref.coef, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(start.coef_se, ref.coef_se, rtol=1e-9)
    np.testing.assert_allclose(start.sigma2, ref.sigma2, rtol=1e-12)
    assert int(start.iterations) == 0 and not bool(start.converged)


def test_missing_samples_are_skipped_and_bridged_by_the_model(white):
    """NaN in y: the sample and the `na` after it leave the regression, the prefilter and the noise model run
    over the gap on the simulated output; the estimate stays within its standard errors of the full data's."""
    y, u, truth, _, full = white
    gappy = y.copy()
    gappy[300:340] = np.nan
    gappy[1100:1103] = np.nan
    res = tvp.dtfm(gappy, u, na=1, nb=1)
    assert bool(res.converged)
    coef, se = np.asarray(res.coef), np.asarray(res.coef_se)
    assert np.all(np.isfinite(coef)) and np.all(np.isfinite(res.x_hat))
    assert np.isnan(res.resid[310]) and np.isfinite(res.resid[350])
    assert np.all(np.abs(coef[AWAY] - np.asarray(full.coef)[AWAY]) < se[AWAY])
    assert np.all(_rmse(coef, truth) < 1.2 * _rmse(full.coef, truth))
    # the gap widens the band where it is (the gain's, whose NVR is the larger: by 20 %)
    assert se[320, 1] > 1.1 * float(np.asarray(full.coef_se)[320, 1])


def test_dtfm_under_jit_vmap_and_grad():
    ys, us = [], []
    for s in range(3):
        y, u, _ = _drifting_system(seed=s, n=300)
        ys.append(y)
        us.append(u)
    ys, us = np.stack(ys), np.stack(us)

    def coef(y, u):
        return tvp.dtfm(y, u, na=1, nb=1, nvr=(1e-5, 1e-3), iterations=3, tol=0.0).coef

    batched = jax.jit(jax.vmap(coef))(ys, us)
    for b, y, u in zip(batched, ys, us, strict=True):
        np.testing.assert_allclose(b, coef(y, u), rtol=1e-9, atol=1e-12)

    # reverse mode through the three passes, against central differences along a direction
    direction = np.random.default_rng(9).standard_normal(300)

    def pole(y):
        return coef(y, us[0])[150, 0]

    g = jax.grad(pole)(ys[0])
    eps = 1e-6
    fd = (float(pole(ys[0] + eps * direction)) - float(pole(ys[0] - eps * direction))) / (2 * eps)
    np.testing.assert_allclose(float(g @ direction), fd, rtol=1e-5)


def test_stabilised_keeps_stable_polynomials_and_moves_the_others_inside():
    from jaxsdp.tvp._dtfm import stabilised

    stable = np.array([[-1.2, 0.5], [0.3, -0.4], [-1.8, 0.81 * 0.99]])
    np.testing.assert_array_equal(stabilised(stable), stable)
    unstable = np.array([[-2.5, 1.0], [0.0, -1.2], [-1.0, -0.5]])
    out = np.asarray(stabilised(unstable))
    for a in out:
        assert np.max(np.abs(np.roots(np.r_[1.0, a]))) < 1.0
    np.testing.assert_allclose(stabilised(np.array([[1.5]])), [[0.999]])


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(na=0, nb=1), "na"),
        (dict(na=1, nb=0), "nb"),
        (dict(na=1, nb=1, delay=-1), "delay"),
        (dict(na=1, nb=1, nd=-1), "nd"),
        (dict(na=1, nb=1, iterations=-1), "iterations"),
        (dict(na=1, nb=1, tol=-1.0), "tol"),
        (dict(na=1, nb=1, nvr=(1e-3,)), "shape"),
        (dict(na=1, nb=1, nvr="fast"), "ml"),
        (dict(na=1, nb=1, model="Constant"), "Constant"),
        (dict(na=1, nb=1, nvr=1e-3, P0=0.0), "P0"),
        (dict(na=1, nb=1, nvr=1e-3, burn_in=100), "burn_in"),
        (dict(na=9, nb=9, nvr=1e-3), "samples"),
    ],
)
def test_refused_by_name(kwargs, match):
    y, u, _ = _drifting_system(n=40)
    with pytest.raises(ValueError, match=match):
        tvp.dtfm(y, u, **kwargs)


def test_refused_data():
    y, u, _ = _drifting_system(n=40)
    with pytest.raises(ValueError, match="shape"):
        tvp.dtfm(y, u[:-1], na=1, nb=1, nvr=1e-3)
    with pytest.raises(ValueError, match="u"):
        tvp.dtfm(y, np.where(np.arange(40) == 5, np.nan, u), na=1, nb=1, nvr=1e-3)
    with pytest.raises(ValueError, match="inf"):
        tvp.dtfm(np.where(np.arange(40) == 5, np.inf, y), u, na=1, nb=1, nvr=1e-3)
    with pytest.raises(ValueError, match="observed"):
        tvp.dtfm(np.where(np.arange(40) < 36, np.nan, y), u, na=1, nb=1, nvr=1e-3)
