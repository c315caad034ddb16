"""Parallel-in-time kernels (issue 17): associative-scan Kalman filter/smoother and IIR filters.

Every parallel result is checked against the sequential kernels (the same
numbers to 1e-8 relative or better) and against independent references: the
dense Gaussian posterior and log-density (`dense.py`), scipy's
second-order-section `sosfiltfilt`, finite differences for gradients.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal

import jaxsdp
from dense import dense_loglik_u, dense_posterior
from helpers import EMPS_MAT, requires_emps
from jaxsdp._kalman.general import fixed_interval_smoother, kalman_filter
from jaxsdp._kalman.models import as_models, assemble
from jaxsdp._kalman.parallel import parallel_filter_smoother
from jaxsdp._scan import linear_recurrence, prefix_scan

DLR_FIELDS = ("par", "parse", "par_filt", "parse_filt", "state", "state_se", "fit", "resid", "innov", "innov_var")
SCALARS = ("sigma2", "loglik", "J")

# (models, NVRs, regressor columns): one block of every kind, and several blocks
CASES = [
    ("RW", 1e-3, 1),
    ("IRW", 1e-9, 1),  # singular Q, tiny NVR
    ("IRW", 1e-4, 1),
    (jaxsdp.SRW(alpha=0.9), 1e-6, 1),
    ("LLT", [1e-5, 1e-8], 1),
    ("Constant", None, 1),
    (["RW", "IRW", "LLT"], [1e-4, 1e-6, 1e-5, 1e-7], 3),
    (["IRW", "Constant"], [1e-6], 2),
]


def _data(p, N, seed=0, missing=True):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, N)
    z = np.ones((N, 1)) if p == 1 else np.c_[rng.normal(size=N), 1.0 + rng.normal(size=(N, p - 1))]
    y = np.sin(6 * t) * z[:, 0] + (t * z[:, 1] if p > 1 else 0.0) + 0.1 * rng.normal(size=N)
    if missing:
        y[[3, 50, 51, 52, N - 1]] = np.nan
    return y, z


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(b)
    assert np.array_equal(ok, np.isfinite(a))
    return float(np.max(np.abs(a[ok] - b[ok])) / max(np.max(np.abs(b[ok])), 1e-300)) if ok.any() else 0.0


def _both(fn):
    return fn("sequential"), fn("parallel")


@pytest.mark.parametrize("model,nvr,p", CASES)
def test_dlr_parallel_equals_sequential(model, nvr, p):
    y, z = _data(p, 3000)
    seq, par = _both(lambda m: jaxsdp.dlr(y, z, model=model, nvr=nvr, method=m))
    for f in DLR_FIELDS + SCALARS:
        assert _rel(getattr(par, f), getattr(seq, f)) < 1e-8, f
    assert bool(par.definite) == bool(seq.definite)


@pytest.mark.parametrize("model,nvr,p", [c for c in CASES if c[1] is not None])
def test_parallel_smoother_equals_dense_posterior(model, nvr, p):
    y, z = _data(p, 150, seed=2)
    models = as_models(model, p)
    ss = assemble(models, jnp.atleast_1d(jnp.asarray(nvr, float)) * jnp.ones(sum(m.n_nvr for m in models)))
    F, Q, H = np.asarray(ss.F), np.asarray(ss.Q), z @ np.asarray(ss.S)
    n = F.shape[0]
    x0 = np.linspace(0.1, 0.3, n)
    out = parallel_filter_smoother(jnp.asarray(y), jnp.asarray(H), F, Q, jnp.asarray(x0), 1e5 * jnp.eye(n))
    mean, cov, *_ = dense_posterior(y, H, F, Q, 1e5, x0)
    blocks = np.stack([cov[t * n : (t + 1) * n, t * n : (t + 1) * n] for t in range(len(y))])
    np.testing.assert_allclose(out.x_smooth, mean, rtol=1e-8, atol=1e-8 * np.abs(mean).max())
    np.testing.assert_allclose(out.P_smooth, blocks, rtol=1e-8, atol=1e-8 * np.abs(blocks).max())
    # the exact Gaussian log-density from the parallel innovations, singular Q included
    obs = out.observed
    s2 = 0.7
    ll = jnp.sum(
        jnp.where(obs, -0.5 * (jnp.log(2 * jnp.pi * s2 * out.innov_var) + out.innov**2 / (s2 * out.innov_var)), 0)
    )
    np.testing.assert_allclose(ll, dense_loglik_u(y, H, F, Q, 1e5, x0, s2), rtol=1e-9)


def test_general_kernels_parallel_with_ties():
    # the dense kernels' `advance` (tied SDP states: identity transition, no noise)
    y, z = _data(2, 400, seed=3)
    ss = assemble(as_models(["IRW", "RW"], 2), jnp.array([1e-4, 1e-2]))
    H = jnp.asarray(z) @ ss.S
    adv = jnp.asarray(np.random.default_rng(0).random(400) > 0.3).at[0].set(True)
    args = (jnp.asarray(y), H, ss.F, ss.Q, jnp.array([0.1, 0.0, 0.2]), 1e5 * jnp.eye(3))
    fs, fp = (kalman_filter(*args, advance=adv, method=m) for m in ("sequential", "parallel"))
    ss_, sp = (
        fixed_interval_smoother(f, ss.F, ss.Q, advance=adv, method=m) for f, m in ((fs, "sequential"), (fp, "parallel"))
    )
    for a, b in [(fp.x_filt, fs.x_filt), (fp.P_filt, fs.P_filt), (fp.innov, fs.innov), (fp.gain, fs.gain)]:
        assert _rel(a, b) < 1e-9
    assert _rel(sp.x_smooth, ss_.x_smooth) < 1e-9 and _rel(sp.P_smooth_diag, ss_.P_smooth_diag) < 1e-9


def test_long_irw_singular_q_exact_loglik_and_gradient():
    # The peers' parallel log-likelihoods are NaN for IRW (singular Q); ours is exact.
    y, z = _data(1, 25_000, seed=4)
    seq, par = _both(lambda m: jaxsdp.dlr(y, z, model="IRW", nvr=1e-9, method=m))
    assert np.isfinite(float(par.loglik))
    assert _rel(par.loglik, seq.loglik) < 1e-10 and _rel(par.par, seq.par) < 1e-8
    g = {
        m: jax.grad(lambda b: jaxsdp.dlr_loglik(y, z, model="IRW", nvr=10.0**b, method=m).loglik)(-9.0)
        for m in ("sequential", "parallel")
    }
    assert abs(float(g["parallel"]) - float(g["sequential"])) <= 1e-8 * abs(float(g["sequential"]))


def test_parallel_gradients_match_finite_differences():
    y, z = _data(3, 300, seed=5)
    model, nvr = ["RW", "IRW", "LLT"], np.array([1e-3, 1e-5, 1e-4, 1e-6])

    def loglik(b):
        return jaxsdp.dlr_loglik(y, z, model=model, nvr=10.0**b, method="parallel").loglik

    b0 = jnp.log10(nvr)
    g = jax.grad(loglik)(b0)
    gs = jax.grad(lambda b: jaxsdp.dlr_loglik(y, z, model=model, nvr=10.0**b, method="sequential").loglik)(b0)
    # (the parallel log-likelihood carries ~3e-11 relative rounding: a wider step)
    h = 1e-3
    fd = np.array([(loglik(b0.at[i].add(h)) - loglik(b0.at[i].add(-h))) / (2 * h) for i in range(4)])
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(g, gs, rtol=1e-7, atol=1e-9)
    # w.r.t. the data, through the smoother
    yc = np.nan_to_num(y)
    f = lambda yy: jnp.sum(jaxsdp.dlr(yy, z, model=model, nvr=nvr, method="parallel").par ** 2)
    gy = jax.grad(f)(jnp.asarray(yc))
    v = np.random.default_rng(0).normal(size=yc.shape)
    fd = (f(yc + 1e-6 * v) - f(yc - 1e-6 * v)) / 2e-6
    np.testing.assert_allclose(float(gy @ v), float(fd), rtol=1e-6)


def test_parallel_under_jit_and_vmap():
    # complete series: the batching rule shares the covariance work; one missing sample: per series
    z = np.ones((500, 1))
    run = jax.jit(jax.vmap(lambda y: jaxsdp.dlr(y, z, model="IRW", nvr=1e-5, method="parallel").par))
    for missing in (False, True):
        Y = np.stack([_data(1, 500, seed=s, missing=missing and s == 1)[0] for s in range(4)])
        batch = run(jnp.asarray(Y))
        for i in range(4):
            one = jaxsdp.dlr(Y[i], z, model="IRW", nvr=1e-5, method="sequential").par
            assert _rel(batch[i], one) < 1e-9
    # a batched regressor and NVR (no shared rule)
    Z = jnp.asarray(1.0 + 0.1 * np.random.default_rng(0).normal(size=(3, 500, 1)))
    nv = jnp.array([1e-6, 1e-5, 1e-4])
    out = jax.vmap(lambda zz, v: jaxsdp.dlr(Y[0], zz, model="IRW", nvr=v, method="parallel").par)(Z, nv)
    for i in range(3):
        assert _rel(out[i], jaxsdp.dlr(Y[0], Z[i], model="IRW", nvr=nv[i], method="sequential").par) < 1e-9


def test_ml_nvr_parallel_equals_sequential():
    y, z = _data(1, 2000, seed=6)
    for model in ("RW", "IRW", "LLT"):
        seq, par = _both(lambda m: jaxsdp.ml_nvr(y, z, model=model, method=m))
        assert bool(par.converged) and int(par.steps) == int(seq.steps)
        np.testing.assert_allclose(par.log10_nvr, seq.log10_nvr, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(par.log10_nvr_se, seq.log10_nvr_se, rtol=1e-7)
    seq, par = _both(lambda m: jaxsdp.dlr(y, z, model="IRW", nvr="ml", method=m))
    assert _rel(par.par, seq.par) < 1e-8


def test_sdp_and_multi_sdp_parallel():
    rng = np.random.default_rng(0)
    N = 1500
    x = rng.uniform(-2.0, 2.0, (N, 2))
    x[:, 1] = np.round(x[:, 1], 2)  # ties: tied states share one estimate
    y = np.tanh(2 * x[:, 0]) + 0.5 * np.sign(x[:, 1]) * x[:, 1] ** 2 + 0.05 * rng.normal(size=N)
    z = np.c_[np.ones(N), 1.0 + 0.3 * np.cos(x[:, 0])]
    for model in ("RW", "IRW"):
        # fixed NVRs: the same smoothing to rounding
        seq, par = _both(lambda m: jaxsdp.sdp(y, z, x, model=model, nvr=[1e-3, 1e-2], method=m))
        for f in ("par", "parse", "fit", "term_loglik"):
            assert _rel(getattr(par, f), getattr(seq, f)) < 1e-8, (model, f)
        # ML NVRs: the same search, to the optimiser's tolerance (1e-5 decades)
        seq, par = _both(lambda m: jaxsdp.sdp(y, z, x, model=model, method=m))
        np.testing.assert_allclose(np.log10(par.nvr), np.log10(seq.nvr), atol=1e-5)
        assert int(par.sweeps) == int(seq.sweeps) and _rel(par.par, seq.par) < 1e-5
    seq, par = _both(lambda m: jaxsdp.multi_sdp(y, x, method=m))
    np.testing.assert_allclose(np.log10(par.nvr), np.log10(seq.nvr), atol=1e-5)
    assert _rel(par.d, seq.d) < 1e-5


def test_smooth_derivatives_parallel():
    t = np.arange(0.0, 2.0, 1e-3)
    q = np.sin(2 * np.pi * t) + 1e-4 * np.random.default_rng(0).normal(size=t.size)
    q[100] = np.nan
    seq, par = _both(lambda m: jaxsdp.smooth_derivatives(q, 1e-3, cutoff_hz=20.0, method=m))
    for f in ("q", "dq", "ddq", "q_se", "dq_se", "ddq_se", "sigma2", "loglik"):
        assert _rel(getattr(par, f), getattr(seq, f)) < 1e-8, f
    # ML NVR: the same search, to the optimiser's tolerance (1e-5 decades, as `sdp` above): the two kernels' last
    # digits differ and the likelihood is flat at its maximum (1.5e-6 relative on an AVX2 machine)
    seq, par = _both(lambda m: jaxsdp.smooth_derivatives(q, 1e-3, method=m))
    np.testing.assert_allclose(np.log10(par.nvr), np.log10(seq.nvr), atol=1e-5)


def _signal(N, seed=0):
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.normal(size=N)) * 1e-3 + np.sin(np.arange(N) * 0.01)


@pytest.mark.parametrize(
    "ba,seq_tol",
    [
        (scipy.signal.butter(4, 100 / 500), 1e-10),  # the EMPS processing
        (scipy.signal.butter(2, 5 / 500), 1e-10),
        (jaxsdp.decimation_filter(2), 1e-10),
        # the b/a recursion of the decimation filter carries its own ~1e-8 rounding
        (jaxsdp.decimation_filter(10), 1e-7),
    ],
)
def test_filtfilt_parallel(ba, seq_tol):
    b, a = ba
    x = _signal(25_000)
    seq, par = _both(lambda m: jaxsdp.filtfilt(x, b, a, method=m))
    padlen = 3 * (len(b) - 1)
    sos = scipy.signal.sosfiltfilt(scipy.signal.tf2sos(b, a), x, padtype="odd", padlen=padlen)
    assert _rel(par, sos) < 1e-12  # the accurate reference: second-order sections
    assert _rel(par, seq) < seq_tol
    assert _rel(seq, sos) < seq_tol  # ... and the sequential b/a form is that far from it too


def test_decimate_and_butter_parallel():
    x = _signal(5000, seed=1)
    for mode in ("matlab", "scipy"):
        seq, par = _both(lambda m: jaxsdp.decimate(x, 10, mode=mode, method=m))
        assert seq.shape == par.shape and _rel(par, seq) < 1e-7
    seq, par = _both(lambda m: jaxsdp.butter_derivatives(x, 1e-3, cutoff_hz=50.0, method=m))
    for f in ("q", "dq", "ddq"):
        assert _rel(getattr(par, f), getattr(seq, f)) < 1e-9


def test_prefix_scan_and_linear_recurrence():
    rng = np.random.default_rng(0)
    for N in (1, 2, 7, 64, 100):
        M = jnp.asarray(rng.normal(size=(N, 2, 2)) * 0.5)
        later_after_earlier = lambda a, b: jnp.einsum("...ij,...jk->...ik", b, a)
        fwd, rev = [M[0]], [M[-1]]
        for k in range(1, N):
            fwd.append(M[k] @ fwd[-1])
            rev.insert(0, rev[0] @ M[N - 1 - k])
        np.testing.assert_allclose(prefix_scan(later_after_earlier, M), np.stack(fwd), atol=1e-12)
        np.testing.assert_allclose(prefix_scan(later_after_earlier, M, reverse=True), np.stack(rev), atol=1e-12)
        A, c = jnp.asarray(rng.normal(size=(3, 3)) * 0.4), jnp.asarray(rng.normal(size=(N, 3)))
        z, zs = np.zeros(3), []
        for k in range(N):
            z = np.asarray(A) @ z + np.asarray(c[k])
            zs.append(z)
        np.testing.assert_allclose(linear_recurrence(A, c), np.stack(zs), atol=1e-13)


def test_set_kernel_method_names_only_functions_with_a_method():
    # the docstring's "Applies to ..." list is a claim: every function it names takes `method`
    import inspect
    import re

    doc = inspect.getdoc(jaxsdp.set_kernel_method)
    applies = doc[doc.index("Applies to") : doc.index("and the studies")]
    names = re.findall(r"`(\w+)`", applies)
    assert len(names) >= 9, names
    for name in names:
        assert "method" in inspect.signature(getattr(jaxsdp, name)).parameters, name
    assert "method" not in inspect.signature(jaxsdp.lfilter).parameters  # one form only, said so


def test_method_setting_and_errors():
    assert jaxsdp.resolve_method("parallel") == "parallel"
    assert jaxsdp.resolve_method("sequential") == "sequential"
    expected = "parallel" if jax.default_backend() in ("gpu", "tpu") else "sequential"
    assert jaxsdp.resolve_method("auto") == expected and jaxsdp.resolve_method() == expected
    with jaxsdp.kernel_method("parallel"):
        assert jaxsdp.resolve_method() == "parallel"
        with jaxsdp.kernel_method("sequential"):
            assert jaxsdp.resolve_method() == "sequential"
        assert jaxsdp.resolve_method() == "parallel"
    assert jaxsdp.resolve_method() == expected
    old = jaxsdp.set_kernel_method("parallel")
    try:
        assert jaxsdp.resolve_method() == "parallel"
        assert jaxsdp.resolve_method("sequential") == "sequential"  # an explicit method wins
    finally:
        jaxsdp.set_kernel_method(old)
    for bad in ("fast", "GPU", 1):
        with pytest.raises(ValueError, match="`method` must be one of"):
            jaxsdp.resolve_method(bad)
    with pytest.raises(ValueError, match="`method` must be one of"):
        jaxsdp.dlr(np.ones(10), np.ones((10, 1)), nvr=1e-3, method="gpu")
    with pytest.raises(ValueError, match="`method` must be one of"):
        with jaxsdp.kernel_method("threads"):
            pass
    # the context switches a call that leaves `method` out (and the jit cache keeps both)
    y, z = _data(1, 300)
    with jaxsdp.kernel_method("parallel"):
        a = jaxsdp.dlr(y, z, model="IRW", nvr=1e-5)
    b = jaxsdp.dlr(y, z, model="IRW", nvr=1e-5, method="sequential")
    assert _rel(a.par, b.par) < 1e-9


@requires_emps
def test_emps_pipeline_forced_parallel_reproduces_published(emps_real_study):
    # The whole EMPS study on the parallel kernels (CPU here): derivatives by the
    # parallel Butterworth, decimation by the parallel Chebyshev sections, SDP by
    # the parallel smoother. The published IDIM-LS results still come out; the
    # SDP stage (no published figure to match) agrees with the sequential kernels.
    from jaxsdp.studies.emps import emps_study

    st = emps_study(EMPS_MAT, method="parallel", check_decimation=False)
    np.testing.assert_allclose(st.idim.theta, [95.1089, 203.5034, 20.3935, -3.1648], rtol=1e-4)
    assert abs(float(st.idim.relative_error) - 4.083) <= 0.005
    np.testing.assert_array_equal(np.round(np.asarray(st.idim.rel_std), 2), [0.11, 0.56, 0.50, 1.40])
    np.testing.assert_allclose(st.idim_asym.theta, [95.1540, 166.7061, 20.1440, 240.4236, 20.6277], rtol=1e-4)
    assert abs(float(st.idim_asym.relative_error) - 3.1117) <= 0.0005
    ref = emps_real_study  # the same study on the sequential kernels (CPU default)
    np.testing.assert_allclose(st.idim.theta, ref.idim.theta, rtol=1e-8)
    assert st.sdp.mass_constant == ref.sdp.mass_constant
    assert st.sdp.nvr_friction == pytest.approx(ref.sdp.nvr_friction, rel=1e-6)
    np.testing.assert_allclose(st.sdp.mass, ref.sdp.mass, rtol=1e-8)
