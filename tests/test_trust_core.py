"""Results a user can trust: bad NVRs and bounds are errors, flags and reasons tell the truth.

Each test here failed before the fix it covers (issue "Results a user can
trust", items 4, 4b and 10): NaN or a false "converged" from the API, a
line-search failure reported as convergence, a covariance losing positive
definiteness hidden by a floor, an NVR on its bound reported with a standard
error, `dlr` silently using a default NVR, LaTeX in the public docstrings.
"""

import inspect

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxsdp
from jaxsdp._kalman.nvr import CONVERGED, FIXED, STALLED, _resolve_flat_zeros, bfgs_minimise


def _sdp_data(N=300, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2.0, 2.0, (N, 2))
    z = np.c_[rng.normal(size=N) + 2.0, np.ones(N)]
    y = (1.0 + 0.3 * np.sin(x[:, 0])) * z[:, 0] + np.tanh(2 * x[:, 1]) + 0.05 * rng.normal(size=N)
    return y, z, x


def _rw(N=400, seed=0, scale=0.1, noise=0.1):
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.normal(size=N)) * scale + noise * rng.normal(size=N), np.ones((N, 1))


# --------------------------------------------------------------------------- #
# 4. Non-positive / non-finite NVRs and bounds are ValueErrors at call time
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(max_nvr=-1.0), r"`max_nvr` must be None or a finite number > 0"),
        (dict(max_nvr=0.0), r"`max_nvr` must be None or a finite number > 0"),
        (dict(max_nvr=np.inf), r"`max_nvr` must be None or a finite number > 0"),
        (dict(max_nvr=np.nan), r"`max_nvr`"),
        (dict(nvr=[np.inf, 1e-3]), r"`nvr`: fixed NVRs must be non-negative and finite"),
        (dict(nvr=[-np.inf, np.nan]), r"`nvr`: fixed NVRs must be non-negative and finite"),
        (dict(nvr0=0.0), r"`nvr0` must be a finite number > 0"),
        (dict(nvr0=np.inf), r"`nvr0`"),
        (dict(nvr0=1e-40), r"`nvr0`: must be finite and in \[1e-30, 1e6\]"),
    ],
)
def test_sdp_rejects_bad_nvrs_and_bounds(kwargs, match):
    """Fixed NVRs are checked by `sdp`; the search's settings by `MLNVR` when it is made, or by `sdp` (the start's
    range)."""
    y, z, x = _sdp_data(N=60)
    with pytest.raises(ValueError, match=match):
        nvr = kwargs["nvr"] if "nvr" in kwargs else jaxsdp.MLNVR(**kwargs)
        jaxsdp.sdp(y, z, x, nvr=nvr)


def test_sdp_and_multi_sdp_reject_constant_output():
    _, z, x = _sdp_data(N=60)
    with pytest.raises(ValueError, match=r"`y`: has zero variance"):
        jaxsdp.sdp(np.zeros(60), z, x)
    with pytest.raises(ValueError, match=r"`y`: has zero variance"):
        jaxsdp.multi_sdp(np.full(60, 3.0), x)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(max_nvr=-1.0), r"`max_nvr`"),
        (dict(nvr=[np.inf, np.nan]), r"`nvr`"),
        (dict(nvr0=np.nan), r"`nvr0`"),
    ],
)
def test_multi_sdp_and_captain_reject_bad_nvrs(kwargs, match):
    y, z, x = _sdp_data(N=60)
    with pytest.raises(ValueError, match=match):
        jaxsdp.multi_sdp(y, x, nvr=kwargs["nvr"] if "nvr" in kwargs else jaxsdp.MLNVR(**kwargs))
    with pytest.raises(ValueError, match=match):
        jaxsdp.captain_nvrs(y, z, x, **kwargs)


def test_ml_nvr_zero_output_is_an_error_not_a_converged_start_value():
    # before: the start value, converged=True and loglik=inf
    z = np.ones((100, 1))
    with pytest.raises(ValueError, match=r"`y`: has zero variance"):
        jaxsdp.ml_nvr(np.zeros(100), z)
    with pytest.raises(ValueError, match=r"`y`: has zero variance"):
        jaxsdp.ml_nvr(np.r_[np.full(99, 2.0), np.nan], z)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(nvr0=0.0), r"`nvr0`"),
        (dict(nvr0=np.inf), r"`nvr0`"),
        (dict(nvr0=-1e-3), r"`nvr0`"),
        (dict(max_nvr=-1.0), r"`max_nvr`"),
        (dict(max_nvr=np.inf), r"`max_nvr`"),
        (dict(P0=np.inf), r"`P0`"),
    ],
)
def test_ml_nvr_rejects_bad_start_and_bounds(kwargs, match):
    y, z = _rw(100)
    with pytest.raises(ValueError, match=match):
        jaxsdp.ml_nvr(y, z, **kwargs)


@pytest.mark.parametrize("fn", [jaxsdp.dlr, jaxsdp.dlr_loglik])
@pytest.mark.parametrize("bad", [np.inf, np.nan, -1e-3, [1e-3, np.inf]])
def test_dlr_rejects_nonfinite_or_negative_nvr(fn, bad):
    y, _ = _rw(50)
    z = np.ones((50, 2)) if np.ndim(bad) else np.ones((50, 1))
    with pytest.raises(ValueError, match=r"`nvr`: must be non-negative and finite"):
        fn(y, z, nvr=bad)


def test_dlr_nvr_is_required_for_traced_values_too():
    y, z = _rw(50)
    with pytest.raises(Exception, match=r"`nvr`: must be non-negative and finite"):
        jax.jit(lambda v: jaxsdp.dlr(y, z, nvr=v).loglik)(jnp.inf)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(nvr=np.inf), r"`nvr`"),
        (dict(nvr0=0.0), r"`nvr0`"),
        (dict(nvr0=np.inf), r"`nvr0`"),
        (dict(P0=-1.0), r"`P0`"),
    ],
)
def test_smooth_derivatives_rejects_bad_nvrs(kwargs, match):
    q = np.sin(np.linspace(0.0, 3.0, 50))
    with pytest.raises(ValueError, match=match):
        jaxsdp.smooth_derivatives(q, 1e-3, **kwargs)


def test_smooth_derivatives_ml_rejects_constant_signal_and_reports_its_fit():
    with pytest.raises(ValueError, match=r"`q`: has zero variance"):
        jaxsdp.smooth_derivatives(np.ones(50), 1e-3)
    rng = np.random.default_rng(2)
    t = np.arange(400) * 1e-3
    d = jaxsdp.smooth_derivatives(np.sin(2 * np.pi * 3 * t) + 1e-3 * rng.normal(size=400), 1e-3)
    assert isinstance(d.nvr_fit, jaxsdp.NVRFit)
    assert bool(d.nvr_fit.converged) and not bool(d.nvr_fit.at_bound[0])
    assert float(d.nvr) == pytest.approx(float(d.nvr_fit.nvr[0]))
    assert jaxsdp.smooth_derivatives(np.sin(t), 1e-3, nvr=1e-6).nvr_fit is None


# --------------------------------------------------------------------------- #
# 4b. Convergence and covariance flags that can be believed
# --------------------------------------------------------------------------- #


def test_bfgs_failed_line_search_is_not_converged():
    # f is NaN beyond b = 1: from b = 1 no step decreases it, far from the minimum at 3
    f = lambda b: jnp.where(b[0] > 1.0, jnp.nan, (b[0] - 3.0) ** 2)
    b, fb, steps, status = bfgs_minimise(f, jnp.array([0.0]))
    assert float(b[0]) == pytest.approx(1.0)
    assert int(status) == STALLED  # before: `done = ~ok | ...` was returned as converged
    # a smooth problem still converges
    b, fb, steps, status = bfgs_minimise(lambda b: jnp.sum((b - 2.0) ** 2), jnp.array([0.0, 1.0]))
    assert int(status) == CONVERGED and np.allclose(b, 2.0, atol=1e-4)


def test_ml_nvr_flags_cap_and_gives_no_standard_error_there():
    y, z = _rw(400, scale=1.0, noise=0.1)  # true NVR 100
    fit = jaxsdp.ml_nvr(y, z, max_nvr=1e-2)
    assert float(fit.nvr[0]) == pytest.approx(1e-2)
    assert bool(fit.at_bound[0]) and bool(fit.converged)
    assert np.isinf(fit.log10_nvr_se[0])
    assert "bound" in fit.reason
    free = jaxsdp.ml_nvr(y, z)
    assert not bool(free.at_bound[0]) and free.reason == "converged"
    assert np.isfinite(free.log10_nvr_se[0])


def test_ml_nvr_status_under_vmap():
    y1, z = _rw(300, seed=1)
    y2, _ = _rw(300, seed=2, scale=10.0)  # true NVRs 1 and 1e4
    fits = jax.vmap(lambda y: jaxsdp.ml_nvr(y, z, max_nvr=10.0))(jnp.stack([y1, y2]))
    assert fits.status.shape == (2,) and fits.at_bound.shape == (2, 1)
    assert list(fits.reason)[0] == "converged" and "bound" in list(fits.reason)[1]


def test_sdp_reports_nvr_on_its_bound_without_standard_error():
    rng = np.random.default_rng(1)
    x = rng.uniform(-1.0, 1.0, (400, 2))
    y = np.sin(3 * x[:, 0]) + np.sign(x[:, 1]) * 0.5 + 0.05 * rng.normal(size=400)
    r = jaxsdp.sdp(y, np.ones((400, 2)), x, nvr=jaxsdp.MLNVR(max_nvr=1e-2))
    assert r.nvr_at_bound.shape == (2,) and r.nvr_converged.shape == (2,) and r.definite.shape == (2,)
    on = np.asarray(r.nvr_at_bound)
    assert on.any()
    np.testing.assert_allclose(np.asarray(r.nvr)[on], 1e-2)
    assert np.all(np.isinf(np.asarray(r.log10_nvr_se)[on]))
    assert np.all(np.isfinite(np.asarray(r.log10_nvr_se)[~on]))
    assert "bound" in r.reason and r.reason.startswith("back-fitting converged")
    # fixed NVRs: no standard error (NaN), status FIXED, never "on a bound"
    f = jaxsdp.sdp(y, np.ones((400, 2)), x, nvr=[1e-2, np.nan])
    assert int(f.nvr_status[0]) == FIXED and bool(f.nvr_converged[0]) and not bool(f.nvr_at_bound[0])
    assert np.isnan(f.log10_nvr_se[0])
    assert "term 0 NVR: fixed" in f.reason
    m = jaxsdp.multi_sdp(y, x, nvr=jaxsdp.MLNVR(max_nvr=1e-2))
    assert np.asarray(m.nvr_at_bound).any() and np.all(np.isinf(np.asarray(m.log10_nvr_se)[np.asarray(m.nvr_at_bound)]))


def test_closed_form_kernels_flag_loss_of_positive_definiteness():
    # a huge diffuse P0 with a large regressor: the IRW covariance loses positive
    # definiteness in floating point; the kernels floored it (determinant 1e-300,
    # P22 clipped at 0) and returned zero standard errors without a word
    rng = np.random.default_rng(0)
    N = 2000
    y = np.sin(np.linspace(0.0, 6.0, N)) + 0.1 * rng.normal(size=N)
    z = np.full((N, 1), 1e4)
    bad = jaxsdp.dlr(y, z, model="IRW", nvr=0.0, P0=1e10)
    assert not bool(bad.definite)
    good = jaxsdp.dlr(y, np.ones((N, 1)), model="IRW", nvr=1e-3)
    assert bool(good.definite)
    # the batching rule (shared covariances) reports it too
    Y = np.stack([y, y[::-1]])
    batch = jax.vmap(lambda yy: jaxsdp.dlr(yy, z, model="IRW", nvr=0.0, P0=1e10).definite)(Y)
    assert batch.shape == (2,) and not np.asarray(batch).any()
    ok = jax.vmap(lambda yy: jaxsdp.dlr(yy, np.ones((N, 1)), model="IRW", nvr=1e-3).definite)(Y)
    assert np.asarray(ok).all()
    # several blocks (dense kernels): a definite result says so
    assert bool(jaxsdp.dlr(y, np.c_[np.ones(N), np.linspace(0, 1, N)], nvr=1e-3).definite)


def test_sdp_reports_definite_terms():
    y, z, x = _sdp_data()
    r = jaxsdp.sdp(y, z, x, model="IRW")
    assert np.asarray(r.definite).all()


# --------------------------------------------------------------------------- #
# 10. `dlr` never uses an NVR the user did not choose
# --------------------------------------------------------------------------- #


def test_dlr_and_dlr_loglik_require_nvr():
    y, z = _rw(50)
    with pytest.raises(ValueError, match=r"`nvr` is required"):
        jaxsdp.dlr(y, z)
    with pytest.raises(ValueError, match=r"`nvr` is required"):
        jaxsdp.dlr_loglik(y, z, model="IRW")
    with pytest.raises(ValueError, match=r'`nvr` must be NVR values or "ml"'):
        jaxsdp.dlr(y, z, nvr="auto")
    with pytest.raises(ValueError, match=r"`nvr` must be numbers here"):
        jaxsdp.dlr_loglik(y, z, nvr="ml")
    # all-Constant models take no NVR
    r = jaxsdp.dlr(y, z, model="CONST")
    assert r.nvr.shape == (0,) and not bool(r.nvr_estimated) and r.nvr_fit is None


def test_dlr_nvr_ml_estimates_and_says_so():
    y, z = _rw(400)
    r = jaxsdp.dlr(y, z, nvr="ml")
    fit = jaxsdp.ml_nvr(y, z)
    assert bool(r.nvr_estimated) and isinstance(r.nvr_fit, jaxsdp.NVRFit)
    np.testing.assert_allclose(r.nvr, fit.nvr, rtol=1e-12)
    np.testing.assert_allclose(r.loglik, jaxsdp.dlr(y, z, nvr=fit.nvr).loglik, rtol=1e-12)
    assert not bool(jaxsdp.dlr(y, z, nvr=fit.nvr).nvr_estimated)
    # jit-able: "ml" is a static choice
    nv = jax.jit(lambda yy: jaxsdp.dlr(yy, z, nvr="ml").nvr)(jnp.asarray(y))
    np.testing.assert_allclose(nv, fit.nvr, rtol=1e-10)


# --------------------------------------------------------------------------- #
# Docstrings: readable on their own (help()), with an example
# --------------------------------------------------------------------------- #

PUBLIC = [
    jaxsdp.dlr,
    jaxsdp.dlr_loglik,
    jaxsdp.ml_nvr,
    jaxsdp.sdp,
    jaxsdp.multi_sdp,
    jaxsdp.captain_nvrs,
    jaxsdp.smooth_derivatives,
    jaxsdp.nvr_from_cutoff,
    jaxsdp.cutoff_from_nvr,
]


@pytest.mark.parametrize("fn", PUBLIC, ids=lambda f: f.__name__)
def test_public_docstrings_are_self_contained(fn):
    doc = inspect.getdoc(fn)
    assert "module docstring" not in doc
    # maths as LaTeX symbols inside $...$ (issue 43), no TeX markup (tests/test_docs.py checks the rule)
    assert "\\frac" not in doc and "\\text" not in doc and "\\begin" not in doc
    assert "Example:" in doc and ">>> " in doc


def test_an_nvr_the_data_cannot_tell_from_zero_is_reported_at_zero_not_stalled():
    # J is flat in b[1] all the way down (an NVR with no effect on the likelihood): BFGS stalls in rounding noise
    J = lambda b: (b[0] - 1.0) ** 2 + 1e-20 * 10.0 ** b[1]
    b, status, zeroed = _resolve_flat_zeros(J, jnp.array([1.0 + 1e-9, -14.0]), jnp.asarray(STALLED), -30.0)
    assert int(status) == CONVERGED and np.asarray(zeroed).tolist() == [False, True]
    assert float(b[1]) == -30.0 and float(b[0]) == pytest.approx(1.0)
    # not settled in the other NVR (gradient far from 0): the stall stands, nothing is changed
    b2, status2, zeroed2 = _resolve_flat_zeros(J, jnp.array([0.0, -14.0]), jnp.asarray(STALLED), -30.0)
    assert int(status2) == STALLED and not np.any(zeroed2) and float(b2[1]) == -14.0
    # a converged search is left as it is
    b3, status3, _ = _resolve_flat_zeros(J, jnp.array([1.0, -14.0]), jnp.asarray(CONVERGED), -30.0)
    assert int(status3) == CONVERGED and float(b3[1]) == -14.0
    # an NVR that matters is never zeroed
    J2 = lambda b: (b[0] - 1.0) ** 2 + (b[1] + 3.0) ** 2
    _, status4, zeroed4 = _resolve_flat_zeros(J2, jnp.array([1.0, -3.0 + 1e-9]), jnp.asarray(STALLED), -30.0)
    assert not np.any(zeroed4) and int(status4) == STALLED


def test_the_burn_in_counts_observed_samples_so_leading_gaps_change_nothing():
    rng = np.random.default_rng(4)
    z = np.column_stack([np.ones(200), rng.normal(size=200)])
    y = z @ np.array([1.0, 0.5]) + 0.1 * rng.normal(size=200)
    gapped = np.concatenate([np.full(7, np.nan), y])
    zg = np.concatenate([rng.normal(size=(7, 2)), z])
    # the 7 gaps only widen the diffuse prior further (by O(1/P0) in what follows); before, the first
    # observations' innovations (variance ~ P0) entered the likelihood and sigma^2 (off by ~log P0 each)
    for model in ("RW", "IRW"):
        a = jaxsdp.dlr(y, z, model=model, nvr=[1e-4, 1e-3], P0=1e8)
        b = jaxsdp.dlr(gapped, zg, model=model, nvr=[1e-4, 1e-3], P0=1e8)
        np.testing.assert_allclose(float(b.loglik), float(a.loglik), rtol=1e-6)
        np.testing.assert_allclose(float(b.sigma2), float(a.sigma2), rtol=1e-6)
        np.testing.assert_allclose(np.asarray(b.par)[7:], np.asarray(a.par), rtol=1e-6, atol=1e-8)
