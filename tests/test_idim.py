import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal
import scipy.stats

from helpers import EMPS_DEC10_CSV, EMPS_MAT, requires_emps, requires_emps_csv
from jaxsdp import (
    IDIMResult,
    Preprocessed,
    Regression,
    Regressors,
    decimate,
    idim_ls,
    idim_table,
    parallel_decimate,
    regressors,
)
from jaxsdp._idim.ls import ParamEstimate
from jaxsdp.data import Measurements
from jaxsdp.plants import emps_asym_regressors, emps_regressors
from jaxsdp.studies.emps import emps_preprocess, emps_regression


def _problem(n=300, p=4, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, p)) * np.array([1.0, 10.0, 0.1, 3.0])[:p]
    theta = rng.standard_normal(p)
    y = X @ theta + 0.05 * rng.standard_normal(n)
    return y, X, theta


def test_idim_ls_matches_numpy_reference():
    y, X, _ = _problem()
    res = idim_ls(y, X, names=["a", "b", "c", "d"])
    assert isinstance(res, IDIMResult)
    n, p = X.shape
    # Independent reference: numpy lstsq and the textbook covariance.
    theta_ref = np.linalg.lstsq(X, y, rcond=None)[0]
    e = y - X @ theta_ref
    s2 = e @ e / (n - p)
    cov_ref = s2 * np.linalg.inv(X.T @ X)
    std_ref = np.sqrt(np.diag(cov_ref))
    np.testing.assert_allclose(np.asarray(res.theta), theta_ref, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(res.cov), cov_ref, rtol=1e-10)
    np.testing.assert_allclose(np.asarray(res.std), std_ref, rtol=1e-10)
    np.testing.assert_allclose(np.asarray(res.rel_std), 100 * std_ref / np.abs(theta_ref), rtol=1e-10)
    np.testing.assert_allclose(float(res.sigma), math.sqrt(s2), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(res.residuals), e, atol=1e-12)
    np.testing.assert_allclose(np.asarray(res.fit), X @ theta_ref, atol=1e-12)
    np.testing.assert_allclose(float(res.relative_error), 100 * np.linalg.norm(e) / np.linalg.norm(y), rtol=1e-12)
    np.testing.assert_allclose(float(res.cond), np.linalg.cond(X), rtol=1e-10)
    assert res.names == ("a", "b", "c", "d") and res.dof == n - p
    assert res.theta.dtype == jnp.float64


def test_idim_ls_matches_linregress():
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 10, 300)
    y = 2.5 * x - 1.0 + rng.standard_normal(300)
    ref = scipy.stats.linregress(x, y)
    res = idim_ls(y, np.stack([x, np.ones_like(x)], axis=1), names=("slope", "intercept"))
    np.testing.assert_allclose(np.asarray(res.theta), [ref.slope, ref.intercept], rtol=1e-12)
    np.testing.assert_allclose(np.asarray(res.std), [ref.stderr, ref.intercept_stderr], rtol=1e-10)


def test_idim_ls_recovers_parameters_and_coverage():
    # Seeded Monte Carlo: the reported std must match the actual spread.
    rng = np.random.default_rng(4)
    X = rng.standard_normal((300, 4))
    theta = np.array([1.0, -2.0, 0.5, 0.1])
    estimates, stds = [], []
    for _ in range(150):
        y = X @ theta + 0.3 * rng.standard_normal(300)
        res = idim_ls(y, X)
        estimates.append(np.asarray(res.theta))
        stds.append(np.asarray(res.std))
    estimates, stds = np.array(estimates), np.array(stds)
    np.testing.assert_allclose(estimates.mean(0), theta, atol=0.01)
    np.testing.assert_allclose(estimates.std(0), stds.mean(0), rtol=0.2)


def test_idim_ls_jit_and_grad():
    y, X, _ = _problem(p=2)
    theta = jax.jit(lambda y, X: idim_ls(y, X).theta)(y, X)
    np.testing.assert_allclose(np.asarray(theta), np.linalg.lstsq(X, y, rcond=None)[0], rtol=1e-12)
    # d theta_0 / d y is the first row of the pseudo-inverse.
    g = jax.grad(lambda y: idim_ls(y, X).theta[0])(jnp.asarray(y))
    np.testing.assert_allclose(np.asarray(g), np.linalg.pinv(X)[0], atol=1e-12)


def test_lookup_by_name():
    y, X, _ = _problem(n=100, p=2)
    res = idim_ls(y, X, names=("k", "c"))
    assert isinstance(res["k"], float) and res["k"] == float(res.theta[0])
    p = res.param("c")
    assert isinstance(p, ParamEstimate)
    assert (p.value, p.std, p.rel_std) == (float(res.theta[1]), float(res.std[1]), float(res.rel_std[1]))
    assert res.as_dict() == {"k": res["k"], "c": res["c"]}
    with pytest.raises(KeyError, match="no parameter 'M'; the parameters are 'k', 'c'"):
        res["M"]
    with pytest.raises(KeyError, match="'k', 'c'"):
        res.param("M")
    leaves = jax.tree.leaves(res)
    assert all(isinstance(v, jax.Array) for v in leaves)  # still a pytree of arrays


def test_table_and_regressors_input():
    y, X, _ = _problem(p=2)
    res = idim_ls(y, Regressors(X=X, names=("M", "Fv")))
    assert res.names == ("M", "Fv")
    text = res.table()
    lines = text.splitlines()
    assert lines[0].split()[0] == "parameter"
    assert lines[1].startswith("M") and f"{float(res.theta[0]):.4f}" in lines[1]
    assert f"({float(res.rel_std[1]):.2f} %)" in lines[2]
    assert f"{float(res.relative_error):.4f} %" in text
    assert text == idim_table(res)
    assert idim_ls(y, X).names == ("theta1", "theta2")


def test_idim_ls_bad_inputs():
    y, X, _ = _problem(n=20, p=3)
    with pytest.raises(ValueError, match=r"`X` must be 2-D \(N, p\); got shape \(20,\)"):
        idim_ls(y, X[:, 0])
    with pytest.raises(ValueError, match=r"as many rows.*\(19, 3\)"):
        idim_ls(y, X[:19])
    with pytest.raises(ValueError, match=r"`y` must be 1-D; got shape \(20, 1\)"):
        idim_ls(y[:, None], X)
    with pytest.raises(ValueError, match="`X`.*NaN"):
        idim_ls(y, np.where(np.eye(20, 3) == 1, np.nan, X))
    with pytest.raises(ValueError, match="`y`.*NaN"):
        idim_ls(np.r_[y[:-1], np.inf], X)
    with pytest.raises(ValueError, match="more rows than columns"):
        idim_ls(y[:3], X[:3])
    with pytest.raises(ValueError, match="rank deficient"):
        idim_ls(y, np.c_[X, X[:, 0] + X[:, 1]])
    with pytest.raises(ValueError, match="`names` must be 3 strings"):
        idim_ls(y, X, names=["a", "b"])
    with pytest.raises(ValueError, match="`names` must be a sequence"):
        idim_ls(y, X, names="abc")


def test_emps_regressors():
    dq = np.array([-2.0, -0.5, 0.0, 0.5, 3.0])
    ddq = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    reg = emps_regressors(dq, ddq)
    assert reg.names == ("M", "Fv", "Fc", "offset")
    np.testing.assert_array_equal(np.asarray(reg.X), np.c_[ddq, dq, [-1, -1, 0, 1, 1], np.ones(5)])
    asym = emps_asym_regressors(dq, ddq)
    assert asym.names == ("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")
    np.testing.assert_array_equal(
        np.asarray(asym.X),
        np.c_[ddq, [0, 0, 0, 0.5, 3.0], [0, 0, 0, 1, 1], [-2.0, -0.5, 0, 0, 0], [-1, -1, 0, 0, 0]],
    )
    # O+ + O- = dq, and the asymmetric model contains the symmetric one.
    A = np.asarray(asym.X)
    np.testing.assert_array_equal(A[:, 1] + A[:, 3], dq)
    with pytest.raises(ValueError, match=r"same shape; got \(5,\) and \(4,\)"):
        emps_regressors(dq, ddq[:4])
    with pytest.raises(ValueError, match=r"`dq` must be 1-D"):
        emps_asym_regressors(dq[:, None], ddq)


def test_generic_regressors():
    x = np.linspace(-1, 1, 7)
    reg = regressors({"x": x, "x2": x**2, "c": 1.0})
    assert reg.names == ("x", "x2", "c")
    np.testing.assert_array_equal(np.asarray(reg.X), np.c_[x, x**2, np.ones(7)])
    with pytest.raises(ValueError, match=r"same length; got 'x': 7, 'y': 6"):
        regressors({"x": x, "y": x[:6]})
    with pytest.raises(ValueError, match=r"`columns\['m'\]` must be 1-D; got shape \(7, 1\)"):
        regressors({"m": x[:, None]})
    with pytest.raises(ValueError, match="non-empty mapping"):
        regressors({})


def test_parallel_decimate():
    rng = np.random.default_rng(5)
    n = 1003
    X = np.c_[np.cumsum(rng.standard_normal(n)), np.sign(np.sin(0.02 * np.arange(n))), np.ones(n)]
    theta = np.array([0.5, -2.0, 1.5])
    y = X @ theta
    reg = parallel_decimate(y, Regressors(X=X, names=("a", "b", "c")), 10)
    assert isinstance(reg, Regression) and reg.names == ("a", "b", "c")
    assert reg.X.shape == (101, 3) and reg.y.shape == (101,)
    for j in range(3):
        np.testing.assert_array_equal(np.asarray(reg.X[:, j]), np.asarray(decimate(X[:, j], 10)))
    # Filtering is linear: the model holds exactly on the decimated data.
    np.testing.assert_allclose(np.asarray(reg.y), np.asarray(reg.X) @ theta, atol=1e-7)
    # A constant passes with the DC gain of the even-order Chebyshev I
    # filter, applied twice: 10^(-2 * 0.05 / 20) (as MATLAB's decimate).
    np.testing.assert_allclose(np.asarray(reg.X[:, 2]), 10 ** (-0.1 / 20), rtol=1e-7)
    same = parallel_decimate(y, X, 1)
    np.testing.assert_array_equal(np.asarray(same.X), X)
    with pytest.raises(ValueError, match="`r` must be an integer >= 2"):
        parallel_decimate(y, X, 0)


def test_emps_preprocess_generic_measurements():
    # On a synthetic record without noise the processing must return the
    # analytic derivatives (interior) and the decimated samples.
    dt = 1e-3
    n = 4000
    t = np.arange(n) * dt
    w = 2 * np.pi * 0.5
    q = 0.1 * np.sin(w * t)
    force = 3.0 * np.cos(w * t)
    m = Measurements(t=jnp.asarray(t), q=jnp.asarray(q), force=jnp.asarray(force), dt=dt)
    out = emps_preprocess(m, cutoff_hz=50.0, drop=7, decimate=5, mode="scipy")
    assert isinstance(out, Preprocessed)
    assert out.y.shape == (math.ceil((n - 7) / 5),) and out.dt == pytest.approx(5e-3)
    inner = slice(100, -100)  # away from the end transients
    t_dec = t[7:][::5]
    # Zero-phase decimation filter gain |H|^2 at the signal frequency (the
    # Chebyshev pass-band ripple: ~0.9886 at low frequency).
    b, a = scipy.signal.cheby1(8, 0.05, 0.8 / 5)
    g = abs(scipy.signal.freqz(b, a, worN=[w * dt])[1][0]) ** 2
    assert abs(g - 10 ** (-0.1 / 20)) < 1e-4
    sin, cos = g * np.sin(w * t_dec)[inner], g * np.cos(w * t_dec)[inner]
    np.testing.assert_allclose(np.asarray(out.q)[inner], 0.1 * sin, atol=1e-7)
    np.testing.assert_allclose(np.asarray(out.dq)[inner], 0.1 * w * cos, atol=1e-5)
    np.testing.assert_allclose(np.asarray(out.ddq)[inner], -0.1 * w**2 * sin, atol=1e-4)
    np.testing.assert_allclose(np.asarray(out.y)[inner], 3.0 * cos, atol=1e-6)
    assert out.y_full.shape == (n - 7,)
    with pytest.raises(ValueError, match="`drop` must be a non-negative integer"):
        emps_preprocess(m, drop=-1)
    with pytest.raises(ValueError, match="`decimate` must be an integer >= 1"):
        emps_preprocess(m, decimate=0)
    with pytest.raises(ValueError, match="`mode`"):
        emps_preprocess(m, mode="fir")
    with pytest.raises(ValueError, match="`data` must be an EMPSData or Measurements"):
        emps_preprocess({"q": q})


# --------------------------------------------------------------------------- #
# The EMPS benchmark (real data)
# --------------------------------------------------------------------------- #


@pytest.fixture(scope="module")
def emps_data():
    from jaxsdp.data import load_emps

    return load_emps(EMPS_MAT)


@pytest.fixture(scope="module")
def emps_inputs(emps_data):
    return emps_preprocess(emps_data)  # 100 Hz, order 4, drop 49, r = 10, MATLAB


@requires_emps
def test_emps_published_idim_ls(emps_inputs):
    reg = emps_regression(emps_inputs)
    res = idim_ls(reg.y, reg.X, names=reg.names)
    assert res.names == ("M", "Fv", "Fc", "offset")
    assert reg.y.shape == (2480,)
    published = np.array([95.1089, 203.5034, 20.3935, -3.1648])
    np.testing.assert_allclose(np.asarray(res.theta), published, rtol=1e-4)
    assert abs(float(res.relative_error) - 4.083) <= 0.005
    # Published relative standard deviations 0.11 / 0.56 / 0.50 / 1.40 %.
    np.testing.assert_array_equal(np.round(np.asarray(res.rel_std), 2), [0.11, 0.56, 0.50, 1.40])


@requires_emps
def test_emps_published_asymmetric(emps_inputs):
    reg = emps_regression(emps_inputs, friction="asymmetric")
    res = idim_ls(reg.y, reg.X, names=reg.names)
    published = np.array([95.1540, 166.7061, 20.1440, 240.4236, 20.6277])
    np.testing.assert_allclose(np.asarray(res.theta), published, rtol=1e-4)
    assert abs(float(res.relative_error) - 3.112) <= 0.005
    assert abs(float(res.relative_error) - 3.1117) <= 0.0005


@requires_emps
def test_emps_parallel_decimation_matters(emps_inputs):
    # Decimating only dq and ddq and building sign(dq) afterwards is not the
    # published procedure and gives visibly different results.
    y = emps_inputs.y
    naive = idim_ls(y, emps_regressors(emps_inputs.dq, emps_inputs.ddq))
    assert abs(float(naive.relative_error) - 4.083) > 0.5


@requires_emps
@requires_emps_csv
def test_emps_preprocess_reproduces_reference_csv(emps_data):
    ref = np.loadtxt(EMPS_DEC10_CSV, delimiter=",", skiprows=1)  # y, ddq, dq
    assert ref.shape == (2480, 3)
    # The CSV was produced with Octave, whose decimate keeps the first sample
    # of each block; everything else is the MATLAB-convention processing.
    out = emps_preprocess(emps_data, mode="octave")
    got = np.c_[out.y, out.ddq, out.dq]
    rel = np.max(np.abs(got - ref), axis=0) / np.max(np.abs(ref), axis=0)
    assert np.all(rel < 1e-7), rel
    # MATLAB's decimate keeps a different phase (1-based start 2 here).
    assert np.max(np.abs(np.asarray(emps_preprocess(emps_data).dq) - ref[:, 2])) > 1e-4
