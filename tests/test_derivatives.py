"""Smoothing derivatives: frequency response, recovery bound, ML, bad input."""

import jax
import numpy as np
import pytest

import jaxsdp
from jaxsdp._signal.smoothing import smoother_gain

DT = 1e-3


def _aliased(w, m, nvr, K=4000):
    """Interior frequency response of the m-th derivative smoother (per-sample units).

    Independent of the package: Wiener smoother of the sampled continuous
    process with spectrum 1/W^6, W = w + 2 pi j, computed from truncated
    aliasing sums: R_m = NVR S_m / (1 + NVR S_0), S_m = sum (i W)^m / W^6.
    """
    j = np.arange(-K, K + 1)
    W = w + 2 * np.pi * j
    S0 = np.sum(W**-6.0)
    Sm = np.sum((1j * W) ** m * W**-6.0)
    return nvr * Sm / (1 + nvr * S0)


def test_gain_is_one_half_at_cutoff():
    for fc in (5.0, 20.0, 100.0):
        nvr = float(jaxsdp.nvr_from_cutoff(fc, DT))
        assert abs(smoother_gain(fc, nvr, DT) - 0.5) < 1e-12
        # independent check of the closed-form spectrum
        assert abs(_aliased(2 * np.pi * fc * DT, 0, nvr).real - 0.5) < 1e-9
        np.testing.assert_allclose(jaxsdp.cutoff_from_nvr(nvr, DT), fc, rtol=1e-9)
    # and the smoother really halves a sinusoid at the cut-off (interior of a long record)
    fc = 20.0
    N = 20000
    x = np.sin(2 * np.pi * fc * np.arange(N) * DT)
    d = jaxsdp.smooth_derivatives(x, DT, cutoff_hz=fc)
    ratio = np.std(d.q[5000:-5000]) / np.std(x[5000:-5000])
    assert abs(ratio - 0.5) < 1e-3


def test_sum_of_sines_recovered_within_derived_bound():
    """Derivatives of sum_i A_i sin(2 pi f_i t) + white noise (sigma) at 1 kHz.

    Bound (interior, away from the ends): in steady state the m-th
    derivative estimate is the zero-phase filter R_m(w) applied to the
    data, so its error is the sum of
      - a deterministic bias, amplitude A_i |R_m(w_i) - (i w_i)^m| / dt^m per sine;
      - a noise part with variance sigma^2 (1/2pi) int |R_m(w)|^2 dw / dt^(2m).
    Predicted RMS = sqrt(sum bias_i^2 / 2 + noise variance). The measured RMS
    error must lie within [0.7, 1.3] x predicted (the noise part of the RMS
    fluctuates by a few per cent over one realisation).
    """
    rng = np.random.default_rng(0)
    N = 6000
    t = np.arange(N) * DT
    A = np.array([1.0, 0.3, 0.05])
    f = np.array([1.0, 7.0, 23.0])
    sigma = 1e-4
    true = [
        sum(a * np.sin(2 * np.pi * fi * t) for a, fi in zip(A, f)),
        sum(a * 2 * np.pi * fi * np.cos(2 * np.pi * fi * t) for a, fi in zip(A, f)),
        -sum(a * (2 * np.pi * fi) ** 2 * np.sin(2 * np.pi * fi * t) for a, fi in zip(A, f)),
    ]
    y = true[0] + sigma * rng.normal(size=N)
    fc = 40.0
    d = jaxsdp.smooth_derivatives(y, DT, cutoff_hz=fc)
    nvr = float(d.nvr)
    ws = np.linspace(-np.pi, np.pi, 4000)  # even count: avoids w = 0
    inner = slice(500, -500)
    for m, est in enumerate([d.q, d.dq, d.ddq]):
        bias2 = sum(
            (a * abs(_aliased(2 * np.pi * fi * DT, m, nvr) - (1j * 2 * np.pi * fi * DT) ** m) / DT**m) ** 2 / 2
            for a, fi in zip(A, f)
        )
        R2 = np.array([abs(_aliased(w, m, nvr, K=300)) ** 2 for w in ws])
        noise_var = sigma**2 * np.trapezoid(R2, ws) / (2 * np.pi) / DT ** (2 * m)
        predicted = np.sqrt(bias2 + noise_var)
        rms = np.sqrt(np.mean((np.asarray(est) - true[m])[inner] ** 2))
        assert 0.7 * predicted <= rms <= 1.3 * predicted, (m, rms, predicted)
    # and the errors are small: relative RMS < 0.5 % (q), 3 % (dq), 6 % (ddq): the 23 Hz term,
    # large in the derivatives, is attenuated by about 3.5 % at a 40 Hz cut-off
    for m, tol in zip(range(3), (5e-3, 3e-2, 6e-2)):
        est = [d.q, d.dq, d.ddq][m]
        rel = np.linalg.norm((np.asarray(est) - true[m])[inner]) / np.linalg.norm(true[m][inner])
        assert rel < tol, (m, rel)


def test_ml_nvr_and_standard_errors():
    rng = np.random.default_rng(1)
    N = 4000
    t = np.arange(N) * DT
    q = np.sin(2 * np.pi * 2.0 * t) + 0.2 * np.sin(2 * np.pi * 11.0 * t)
    y = q + 1e-3 * rng.normal(size=N)
    d = jaxsdp.smooth_derivatives(y, DT)
    assert np.isfinite(float(d.nvr)) and float(d.nvr) > 0
    # ML noise variance close to the truth
    np.testing.assert_allclose(float(d.sigma2), 1e-6, rtol=0.1)
    inner = slice(200, -200)
    err = np.asarray(d.q - q)[inner]
    # the standard errors describe the position error (about 95 % within 2 se)
    frac = np.mean(np.abs(err) < 2 * np.asarray(d.q_se)[inner])
    assert frac > 0.85
    # passing the ML NVR back gives the same result
    d2 = jaxsdp.smooth_derivatives(y, DT, nvr=float(d.nvr))
    np.testing.assert_allclose(d2.dq, d.dq, rtol=1e-10, atol=1e-12)


def test_missing_samples_interpolated():
    N = 1000
    t = np.arange(N) * DT
    q = np.sin(2 * np.pi * 1.0 * t)
    y = q.copy()
    y[400:410] = np.nan
    d = jaxsdp.smooth_derivatives(y, DT, cutoff_hz=20.0)
    assert np.all(np.isfinite(d.q))
    assert np.max(np.abs(np.asarray(d.q[400:410]) - q[400:410])) < 1e-4


def test_jit_vmap_grad():
    N = 500
    t = np.arange(N) * DT
    ys = np.stack([np.sin(2 * np.pi * f * t) for f in (1.0, 2.0, 3.0)])
    f = lambda y: jaxsdp.smooth_derivatives(y, DT, cutoff_hz=30.0).dq
    out = jax.vmap(f)(ys)
    for i in range(3):
        np.testing.assert_allclose(out[i], f(ys[i]), rtol=1e-10, atol=1e-10)
    # gradient w.r.t. the cut-off frequency matches finite differences
    g = lambda fc: jaxsdp.smooth_derivatives(ys[0], DT, cutoff_hz=fc).loglik
    gd = jax.grad(g)(30.0)
    h = 1e-3
    np.testing.assert_allclose(gd, (g(30.0 + h) - g(30.0 - h)) / (2 * h), rtol=1e-5)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(q=np.ones((10, 2)), dt=DT), "`q` must be 1-D"),
        (dict(q=np.ones(3), dt=DT), "at least 5"),
        (dict(q=np.full(10, np.nan), dt=DT), "all values are NaN"),
        (dict(q=np.r_[np.ones(9), np.inf], dt=DT), "inf"),
        (dict(q=np.ones(10), dt=-1.0), "`dt`"),
        (dict(q=np.ones(10), dt=DT, nvr=1.0, cutoff_hz=10.0), "at most one"),
        (dict(q=np.ones(10), dt=DT, cutoff_hz=600.0), "Nyquist"),
        (dict(q=np.ones(10), dt=DT, nvr=-1.0), "`nvr`"),
    ],
)
def test_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        jaxsdp.smooth_derivatives(kwargs.pop("q"), kwargs.pop("dt"), **kwargs)
