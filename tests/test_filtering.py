import fractions
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

from jaxsdp import (
    FilteredDerivatives,
    butter_derivatives,
    decimate,
    decimation_filter,
    filtfilt,
    lfilter,
    lfilter_zi,
)


def _signal(n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    return np.sin(0.01 * t) + 0.3 * rng.standard_normal(n) + 0.01 * rng.standard_normal(n).cumsum()


FILTERS = {
    "butter4": scipy.signal.butter(4, 0.2),
    # len(b) != len(a) and a[0] != 1
    "unnormalised": (np.array([0.5, 0.2]), np.array([2.0, -0.9, 0.2])),
    "fir": (np.array([0.25, 0.5, 0.25]), np.array([1.0])),
}


def _rel_err(actual, expected):
    expected = np.asarray(expected)
    return np.max(np.abs(np.asarray(actual) - expected)) / np.max(np.abs(expected))


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_lfilter_matches_scipy(name):
    b, a = FILTERS[name]
    x = _signal(900, seed=1)
    assert _rel_err(lfilter(x, b, a), scipy.signal.lfilter(b, a, x)) < 1e-12
    zi = np.linspace(-1.0, 2.0, max(len(a), len(b)) - 1)
    y, zf = lfilter(x, b, a, zi=zi, return_state=True)
    y_ref, zf_ref = scipy.signal.lfilter(b, a, x, zi=zi)
    assert _rel_err(y, y_ref) < 1e-12
    np.testing.assert_allclose(np.asarray(zf), zf_ref, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(np.asarray(lfilter_zi(b, a)), scipy.signal.lfilter_zi(b, a), rtol=1e-12, atol=1e-14)


def test_lfilter_zi_gives_steady_state():
    b, a = scipy.signal.butter(3, 0.1)
    y = lfilter(np.full(50, 2.5), b, a, zi=2.5 * lfilter_zi(b, a))
    np.testing.assert_allclose(np.asarray(y), 2.5, rtol=1e-12)


def test_lfilter_zi_exact_for_badly_conditioned_filter():
    # Exact rational solution of (I - A) zi = b[1:] - a[1:] b[0] for the
    # decimation filter, whose sum(a) ~ 1e-6 makes scipy's float solve lose
    # ~9 digits.
    b, a = scipy.signal.cheby1(8, 0.05, 0.08)
    bf = [fractions.Fraction(float(v)) for v in b]
    af = [fractions.Fraction(float(v)) for v in a]
    n = len(bf)
    # Back-substitution of the companion system, exactly:
    # z_{n-2} = b_{n-1} - a_{n-1} y, z_i = z_{i+1} + b_{i+1} - a_{i+1} y,
    # y = b_0 + z_0.
    # Write z_i = c_i + d_i y and solve y = b_0 + c_0 + d_0 y.
    c, d = [fractions.Fraction(0)] * (n - 1), [fractions.Fraction(0)] * (n - 1)
    c[n - 2], d[n - 2] = bf[n - 1], -af[n - 1]
    for i in range(n - 3, -1, -1):
        c[i], d[i] = c[i + 1] + bf[i + 1], d[i + 1] - af[i + 1]
    y = (bf[0] + c[0]) / (1 - d[0])
    exact = np.array([float(ci + di * y) for ci, di in zip(c, d)])
    zi = np.asarray(lfilter_zi(b, a))
    assert np.max(np.abs(zi - exact)) / np.max(np.abs(exact)) < 1e-13
    # Started in steady state, the step response is flat at the DC gain
    # (10^(-0.05/20) for an even-order Chebyshev I).
    y_step = np.asarray(lfilter(np.ones(200), b, a, zi=zi))
    # (rounding in this badly conditioned recursion drifts by ~1e-8).
    np.testing.assert_allclose(y_step, float(y), rtol=1e-7)
    np.testing.assert_allclose(float(y), 10 ** (-0.05 / 20), rtol=1e-7)


@pytest.mark.parametrize("name", sorted(FILTERS))
@pytest.mark.parametrize("padding", ["matlab", "scipy"])
def test_filtfilt_matches_scipy(name, padding):
    b, a = FILTERS[name]
    n = max(len(a), len(b))
    padlen = 3 * (n - 1) if padding == "matlab" else 3 * n
    x = _signal(900, seed=2)
    y = filtfilt(x, b, a, padding=padding)
    assert y.dtype == jnp.float64 and y.shape == x.shape
    assert _rel_err(y, scipy.signal.filtfilt(b, a, x, padlen=padlen)) < 1e-12


def test_filtfilt_decimation_filter_matches_scipy():
    # The 8th-order Chebyshev in b/a form is badly conditioned: a relative
    # perturbation of 1e-15 of the input moves scipy's own output by ~1e-8,
    # so the two float64 implementations can only agree to that level.
    b, a = decimation_filter(10)
    x = _signal(3000, seed=3)
    y = filtfilt(x, b, a)
    y_ref = scipy.signal.filtfilt(b, a, x, padlen=3 * (len(a) - 1))
    x_pert = x * (1 + 1e-15 * np.random.default_rng(0).standard_normal(x.shape))
    sensitivity = _rel_err(scipy.signal.filtfilt(b, a, x_pert, padlen=3 * (len(a) - 1)), y_ref)
    assert _rel_err(y, y_ref) < max(1e-7, 50 * sensitivity)
    assert _rel_err(y, y_ref) < 1e-7


def test_filtfilt_zero_phase_and_dc():
    b, a = scipy.signal.butter(4, 0.1)
    t = np.arange(2000)
    x = np.sin(2 * np.pi * 0.005 * t)  # far inside the pass band
    y = np.asarray(filtfilt(x, b, a))
    # No delay: the peak stays in place and the amplitude is ~1.
    np.testing.assert_allclose(y[200:-200], x[200:-200], atol=2e-5)
    np.testing.assert_allclose(np.asarray(filtfilt(np.full(100, 3.0), b, a)), 3.0, rtol=1e-12)


def test_filtfilt_vmap_and_jit():
    b, a = scipy.signal.butter(2, 0.15)
    xs = np.stack([_signal(200, seed=s) for s in range(4)])
    # jit + vmap over signals, with traced filter coefficients.
    batched = jax.jit(jax.vmap(lambda x, b, a: filtfilt(x, b, a), in_axes=(0, None, None)))(xs, b, a)
    for i, x in enumerate(xs):
        assert _rel_err(batched[i], scipy.signal.filtfilt(b, a, x, padlen=6)) < 1e-12
    dec = jax.jit(jax.vmap(lambda x: decimate(x, 4)))(xs)
    assert dec.shape == (4, 50)
    np.testing.assert_allclose(np.asarray(dec[2]), np.asarray(decimate(xs[2], 4)), rtol=1e-9, atol=1e-12)


def test_filtfilt_gradients():
    # filtfilt is linear in x: the gradient of w . F(x) is F^T w, with F
    # assembled column by column from scipy.
    b, a = scipy.signal.butter(2, 0.25)
    n = 40
    F = np.stack([scipy.signal.filtfilt(b, a, e, padlen=6) for e in np.eye(n)], axis=1)
    rng = np.random.default_rng(4)
    x, w = rng.standard_normal(n), rng.standard_normal(n)
    grad = jax.jit(jax.grad(lambda x_, b_, a_: jnp.dot(w, filtfilt(x_, b_, a_)), argnums=(0, 1, 2)))
    g, gb, ga = grad(jnp.asarray(x), jnp.asarray(b), jnp.asarray(a))
    np.testing.assert_allclose(np.asarray(g), F.T @ w, rtol=1e-10, atol=1e-12)

    # Gradient in the coefficients against central differences of scipy.
    def loss_ref(b_, a_):
        return w @ scipy.signal.filtfilt(b_, a_, x, padlen=6)

    h = 1e-6
    for i in range(len(b)):
        e = np.eye(len(b))[i] * h
        fd = (loss_ref(b + e, a) - loss_ref(b - e, a)) / (2 * h)
        np.testing.assert_allclose(float(gb[i]), fd, rtol=1e-5, atol=1e-7)
    for i in range(1, len(a)):
        e = np.eye(len(a))[i] * h
        fd = (loss_ref(b, a + e) - loss_ref(b, a - e)) / (2 * h)
        np.testing.assert_allclose(float(ga[i]), fd, rtol=1e-5, atol=1e-7)


def test_decimation_filter():
    b, a = decimation_filter(10)
    b_ref, a_ref = scipy.signal.cheby1(8, 0.05, 0.08)
    np.testing.assert_array_equal(b, b_ref)
    np.testing.assert_array_equal(a, a_ref)
    # For large factors MATLAB lowers the order until the b/a design has
    # its -0.05 dB point at the cut-off.
    b, a = decimation_filter(30)
    assert len(a) < 9
    _, h = scipy.signal.freqz(b, a, worN=[np.pi * 0.8 / 30])
    assert abs(20 * np.log10(abs(h[0])) + 0.05) < 1e-6


@pytest.mark.parametrize("n, r", [(1000, 10), (1003, 10), (1009, 5), (1009, 2)])
def test_decimate_matches_reference(n, r):
    x = _signal(n, seed=n + r)
    b, a = scipy.signal.cheby1(8, 0.05, 0.8 / r)
    filtered = scipy.signal.filtfilt(b, a, x, padlen=3 * (len(a) - 1))
    nout = math.ceil(n / r)
    start = r - (r * nout - n)  # MATLAB's 1-based nbeg
    y_matlab = decimate(x, r)
    y_scipy = decimate(x, r, mode="scipy")
    assert y_matlab.shape == (nout,) and y_scipy.shape == (nout,)
    assert _rel_err(y_matlab, filtered[start - 1 :: r]) < 1e-7
    assert _rel_err(y_scipy, filtered[::r]) < 1e-7
    np.testing.assert_array_equal(np.asarray(decimate(x, r, mode="octave")), np.asarray(y_scipy))
    # MATLAB mode always keeps the last sample.
    assert abs(float(y_matlab[-1]) - filtered[-1]) < 1e-7 * np.max(np.abs(filtered))


def test_decimate_scipy_mode_agrees_with_scipy_away_from_ends():
    # scipy.signal.decimate pads differently (3 * len(a) samples), so only the
    # middle, where the end transients have died out, is comparable.
    x = _signal(3000, seed=6)
    b, a = scipy.signal.cheby1(8, 0.05, 0.08)
    ref = scipy.signal.decimate(x, 10, ftype=scipy.signal.dlti(b, a), zero_phase=True)
    y = np.asarray(decimate(x, 10, mode="scipy"))
    mid = slice(len(ref) // 3, 2 * len(ref) // 3)
    assert y.shape == ref.shape
    assert _rel_err(y[mid], ref[mid]) < 1e-7


def test_decimate_removes_alias():
    t = np.arange(3000)
    slow = np.sin(2 * np.pi * 0.004 * t)
    fast = np.sin(2 * np.pi * 0.3 * t)  # above the new Nyquist frequency 0.05
    mid = slice(100, 200)  # away from the (long) end transients
    # The fast component is removed (stop band: filtfilt squares the gain) ...
    assert np.max(np.abs(np.asarray(decimate(fast, 10))[mid])) < 1e-6
    # ... and the slow one kept within the pass-band ripple (2 x 0.05 dB).
    y = np.asarray(decimate(slow + fast, 10))
    ripple = 1 - 10 ** (-0.1 / 20)
    np.testing.assert_allclose(y[mid], slow[9::10][mid], atol=ripple + 1e-6)


def test_butter_derivatives_matches_scipy_numpy():
    dt = 1e-3
    n = 3000
    t = np.arange(n) * dt
    rng = np.random.default_rng(5)
    q = np.sin(2 * np.pi * 1.5 * t) + 1e-5 * np.round(rng.standard_normal(n) * 3)
    for padding, padlen in [("matlab", 12), ("scipy", 15)]:
        out = butter_derivatives(q, dt, cutoff_hz=100.0, padding=padding)
        assert isinstance(out, FilteredDerivatives)
        b, a = scipy.signal.butter(4, 100.0 / 500.0)
        q_ref = scipy.signal.filtfilt(b, a, q, padlen=padlen)
        dq_ref = np.gradient(q_ref, dt)
        ddq_ref = np.gradient(dq_ref, dt)
        assert _rel_err(out.q, q_ref) < 1e-12
        assert _rel_err(out.dq, dq_ref) < 1e-10
        assert _rel_err(out.ddq, ddq_ref) < 1e-8


def test_butter_derivatives_accuracy_on_sine():
    dt = 1e-3
    t = np.arange(3000) * dt
    w = 2 * np.pi * 2.0
    out = butter_derivatives(np.sin(w * t), dt, cutoff_hz=50.0)
    inner = slice(100, -100)
    np.testing.assert_allclose(np.asarray(out.q)[inner], np.sin(w * t)[inner], atol=1e-6)
    np.testing.assert_allclose(np.asarray(out.dq)[inner] / w, np.cos(w * t)[inner], atol=1e-4)
    np.testing.assert_allclose(np.asarray(out.ddq)[inner] / w**2, -np.sin(w * t)[inner], atol=1e-3)


def test_bad_inputs():
    b, a = scipy.signal.butter(4, 0.2)
    x = _signal(100)
    with pytest.raises(ValueError, match=r"`x` must be 1-D; got shape \(2, 50\)"):
        filtfilt(x.reshape(2, 50), b, a)
    with pytest.raises(ValueError, match="`x`.*NaN"):
        filtfilt(np.where(np.arange(100) == 7, np.nan, x), b, a)
    with pytest.raises(ValueError, match="`x`.*NaN"):
        decimate(np.where(np.arange(100) == 7, np.inf, x), 2)
    with pytest.raises(ValueError, match=r"more than 12 samples.*\(12,\)"):
        filtfilt(x[:12], b, a)
    with pytest.raises(ValueError, match="more than 15 samples"):
        filtfilt(x[:15], b, a, padding="scipy")
    with pytest.raises(ValueError, match="padding"):
        filtfilt(x, b, a, padding="odd")
    with pytest.raises(ValueError, match=r"a\[0\]"):
        filtfilt(x, b, np.r_[0.0, a[1:]])
    with pytest.raises(ValueError, match="`b` must be 1-D"):
        lfilter(x, np.ones((2, 2)), a)
    with pytest.raises(ValueError, match=r"`zi` must have shape \(4,\)"):
        lfilter(x, b, a, zi=np.zeros(3))
    for r in [1, 0, 2.5, True, "10"]:
        with pytest.raises(ValueError, match="`r` must be an integer >= 2"):
            decimate(x, r)
    with pytest.raises(ValueError, match="`mode`"):
        decimate(x, 2, mode="fir")
    with pytest.raises(ValueError, match="more than 24 samples"):
        decimate(x[:24], 2)
    with pytest.raises(ValueError, match="Nyquist"):
        butter_derivatives(x, 1e-3, cutoff_hz=500.0)
    with pytest.raises(ValueError, match="`cutoff_hz` must be positive"):
        butter_derivatives(x, 1e-3, cutoff_hz=-1.0)
    with pytest.raises(ValueError, match="`dt` must be positive"):
        butter_derivatives(x, 0.0, cutoff_hz=10.0)
    with pytest.raises(ValueError, match="`order`"):
        butter_derivatives(x, 1e-3, cutoff_hz=10.0, order=0)
    with pytest.raises(ValueError, match=r"`q` must be 1-D; got shape \(100, 1\)"):
        butter_derivatives(x[:, None], 1e-3, cutoff_hz=10.0)


def test_nan_under_jit_is_caught():
    b, a = scipy.signal.butter(2, 0.2)
    x = jnp.asarray(_signal(60)).at[5].set(jnp.nan)
    with pytest.raises(Exception, match="NaN or inf"):
        jax.jit(lambda x: filtfilt(x, b, a))(x).block_until_ready()


def test_decimate_columns_is_decimate_of_each_column():
    """One filter over every column (the robot pipeline's parallel decimation) equals `decimate` per column."""
    from jaxsdp._signal.filtering import decimate_columns

    X = jnp.asarray(np.random.default_rng(0).standard_normal((997, 7)).cumsum(axis=0))
    for r, mode in ((2, "matlab"), (3, "scipy"), (10, "matlab")):
        ref = np.stack([np.asarray(decimate(X[:, j], r, mode=mode)) for j in range(X.shape[1])], axis=1)
        out = np.asarray(decimate_columns(X, r, mode=mode))
        np.testing.assert_allclose(out, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))
