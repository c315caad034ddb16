"""State-dependent parameter estimation: recovery, ML NVRs, multi-SDP, vmap, bad input."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxsdp

G = 9.81


def _synthetic(N, sigma, seed=0, constant=False):
    rng = np.random.default_rng(seed)
    x1 = rng.uniform(-3, 3, N)
    x2 = rng.uniform(-1, 1, N)
    z1 = rng.normal(size=N)
    c1 = np.full(N, 1.5) if constant else 2 + np.sin(x1)
    c2 = np.tanh(3 * x2)
    y = c1 * z1 + c2 + sigma * rng.normal(size=N)
    return y, np.c_[z1, np.ones(N)], np.c_[x1, x2], c1, c2


@pytest.mark.parametrize("sigma", [0.05, 0.2])
def test_two_sdps_recovered(sigma):
    """RMS error of each recovered function <= 0.5 sigma (N = 2000).

    A smoother averaging ~n_eff neighbouring sorted samples has error variance
    ~ sigma^2 / n_eff plus a small bias; with ML NVRs n_eff is tens of samples
    here, so 0.5 sigma is a conservative bound proportional to the noise.
    """
    y, z, x, c1, c2 = _synthetic(2000, sigma)
    r = jaxsdp.sdp(y, z, x)
    e1 = np.sqrt(np.mean((np.asarray(r.par[:, 0]) - c1) ** 2))
    e2 = np.sqrt(np.mean((np.asarray(r.par[:, 1]) - c2) ** 2))
    assert e1 <= 0.5 * sigma and e2 <= 0.5 * sigma, (e1, e2)
    assert bool(r.converged) and 4 <= int(r.sweeps) <= 10
    assert not bool(r.constant[0]) and not bool(r.constant[1])
    # residual standard deviation close to the noise level
    np.testing.assert_allclose(np.std(np.asarray(r.resid)), sigma, rtol=0.15)
    # fields are consistent
    np.testing.assert_allclose(r.fit, np.sum(np.asarray(r.par) * z, axis=1), rtol=1e-12)
    np.testing.assert_allclose(r.relative_error, 100 * np.linalg.norm(y - r.fit) / np.linalg.norm(y), rtol=1e-12)
    assert np.all(np.diff(np.asarray(r.x_sorted), axis=1) >= 0)
    np.testing.assert_allclose(np.sort(np.asarray(r.par_sorted[1])), np.sort(np.asarray(r.par[:, 1])))
    # standard errors describe the error of the tanh curve: most truth within 3 se
    assert np.mean(np.abs(np.asarray(r.par[:, 1]) - c2) < 3 * np.asarray(r.parse[:, 1])) > 0.9


def test_constant_coefficient_flagged():
    y, z, x, _, c2 = _synthetic(2000, 0.05, seed=1, constant=True)
    r = jaxsdp.sdp(y, z, x)
    assert float(r.nvr[0]) < 1e-6
    assert bool(r.constant[0]) and not bool(r.constant[1])
    np.testing.assert_allclose(np.asarray(r.par[:, 0]), 1.5, atol=0.01)


def test_ml_nvr_equals_dense_grid_minimiser():
    """One term: the first-sweep ML NVR minimises J of the sorted data over a dense log10 grid."""
    rng = np.random.default_rng(2)
    N = 1500
    x = rng.uniform(-2, 2, N)
    y = np.sin(2 * x) + 0.1 * rng.normal(size=N)
    z = np.ones((N, 1))
    r = jaxsdp.sdp(y, z, x[:, None], max_sweeps=1)
    order = np.argsort(x, kind="stable")
    step = 0.02
    grid = np.arange(-5.0, 0.0 + step / 2, step)
    J = [float(jaxsdp.dlr(y[order], z, model="RW", nvr=10.0**b).J) for b in grid]
    assert abs(np.log10(float(r.nvr[0])) - grid[int(np.argmin(J))]) <= step


def test_term_loglik_gradient_matches_finite_differences():
    y, z, x, _, _ = _synthetic(800, 0.1, seed=3)

    def ll(b):
        return jaxsdp.sdp(y, z, x, nvr=10.0**b, max_sweeps=4).term_loglik[1]

    b = jnp.array([-3.0, -2.0])
    g = jax.grad(ll)(b)
    h = 1e-5
    fd = np.array([(ll(b.at[i].add(h)) - ll(b.at[i].add(-h))) / (2 * h) for i in range(2)])
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_irw_terms_and_mixed_models():
    y, z, x, c1, c2 = _synthetic(1500, 0.05, seed=4)
    r = jaxsdp.sdp(y, z, x, model=["IRW", "RW"])
    assert np.sqrt(np.mean((np.asarray(r.par[:, 0]) - c1) ** 2)) < 0.025
    assert np.sqrt(np.mean((np.asarray(r.par[:, 1]) - c2) ** 2)) < 0.025


def test_vmap_over_data_sets_equals_loop():
    B, N = 8, 400
    data = [_synthetic(N, 0.1, seed=10 + i) for i in range(B)]
    ys = np.stack([d[0] for d in data])
    zs = np.stack([d[1] for d in data])
    xs = np.stack([d[2] for d in data])
    f = lambda y, z, x: jaxsdp.sdp(y, z, x, max_sweeps=5)
    rv = jax.vmap(f)(ys, zs, xs)
    # batched and single runs differ only by floating-point rounding inside the
    # ML search (XLA vectorises the batch), which the smoother passes on at ~1e-8
    for i in range(B):
        ri = f(ys[i], zs[i], xs[i])
        np.testing.assert_allclose(rv.par[i], ri.par, rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(rv.nvr[i], ri.nvr, rtol=1e-6)
        assert int(rv.sweeps[i]) == int(ri.sweeps)


def test_long_runs_of_tied_states_are_finite():
    rng = np.random.default_rng(5)
    N = 1200
    x = np.round(rng.uniform(-1, 1, N), 1)  # 21 distinct values, runs of ~60 ties
    x[:300] = 0.0  # and one very long run
    y = 2 * x**2 + 0.05 * rng.normal(size=N)
    r = jaxsdp.sdp(y, np.ones((N, 1)), x[:, None])
    assert np.all(np.isfinite(np.asarray(r.par))) and np.all(np.isfinite(np.asarray(r.parse)))
    # tied samples share one estimate
    for v in np.unique(x):
        vals = np.asarray(r.par[x == v, 0])
        assert np.ptp(vals) < 1e-9
    assert np.sqrt(np.mean((np.asarray(r.par[:, 0]) - 2 * x**2) ** 2)) < 0.03


def _tx40_like(N=5000, seed=0, sigma=0.3):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 60, N)
    K = 12
    f = rng.uniform(0.05, 0.6, K)
    ph = rng.uniform(0, 2 * np.pi, K)
    A = rng.uniform(0.1, 0.3, K) * 3 / np.sqrt(K)
    q = sum(a * np.sin(2 * np.pi * fi * t + p) for a, fi, p in zip(A, f, ph))
    dq = sum(a * 2 * np.pi * fi * np.cos(2 * np.pi * fi * t + p) for a, fi, p in zip(A, f, ph))
    ddq = -sum(a * (2 * np.pi * fi) ** 2 * np.sin(2 * np.pi * fi * t + p) for a, fi, p in zip(A, f, ph))
    MX, MY, Fv, Fc, ZZ = 2.8, 0.3, 5.68, 7.77, 1.6
    d1 = -G * MX * np.cos(q) + G * MY * np.sin(q)
    d2 = Fv * dq + Fc * np.sign(dq)
    y = ZZ * ddq + d1 + d2 + sigma * rng.normal(size=N)
    return y, q, dq, ddq, d1, d2, ZZ


def test_multi_sdp_separable_disturbance():
    y, q, dq, ddq, d1, d2, ZZ = _tx40_like()
    r = jaxsdp.multi_sdp(y, np.c_[q, dq], w=ddq, a=ZZ, tol=0.01)
    assert bool(r.converged) and int(r.iterations) <= 10
    hist = np.asarray(r.change_history)
    assert hist[int(r.iterations) - 1] <= 0.01
    # each shape recovered up to the offset it absorbs (only the sum of offsets is identified)
    D = np.asarray(r.d)
    c = np.mean(D[:, 0] - d1)
    assert np.sqrt(np.mean((D[:, 0] - c - d1) ** 2)) < 0.2
    assert np.sqrt(np.mean((D[:, 1] + c - d2) ** 2)) < 0.3
    np.testing.assert_allclose(np.sum(np.asarray(r.offsets)), np.mean(d1 + d2), atol=0.1)
    # parametric stage: the paper's regressions give the physical parameters back
    p1 = jaxsdp.parametric_stage(
        r.d[:, 0], np.c_[-G * np.cos(q), G * np.sin(q), np.ones_like(q)], names=["MX", "MY", "offset"]
    )
    p2 = jaxsdp.parametric_stage(r.d[:, 1], np.c_[dq, np.sign(dq), np.ones_like(q)], names=["Fv", "Fc", "offset"])
    np.testing.assert_allclose(p1.theta[:2], [2.8, 0.3], atol=0.06)
    np.testing.assert_allclose(p2.theta[:2], [5.68, 7.77], rtol=0.02)
    assert float(r.relative_error) < 1.5


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(x=np.c_[np.r_[np.nan, np.zeros(99)], np.linspace(0, 1, 100)]), r"`x`: contains NaN or inf"),
        (dict(x=np.c_[np.r_[np.inf, np.zeros(99)], np.linspace(0, 1, 100)]), r"`x`: contains NaN or inf"),
        (dict(z=np.c_[np.r_[np.nan, np.ones(99)], np.ones(100)]), r"`z`: contains NaN or inf"),
        (dict(x=np.c_[np.ones(100), np.linspace(0, 1, 100)]), r"`x`: a state column has \(almost\) no spread"),
        (dict(x=np.c_[np.r_[np.ones(99), 2.0], np.linspace(0, 1, 100)]), r"no spread"),
        (dict(y=np.ones(99)), r"same number of samples"),
        (dict(x=np.ones((100, 3))), r"one state column per regressor"),
        (dict(nvr=[1e-3, -1.0]), r"`nvr`: fixed NVRs must be non-negative"),
        (dict(model="LLT"), r"SDP terms must be RW, IRW or SRW"),
        (dict(optimise_on="never"), r"`optimise_on`"),
    ],
)
def test_sdp_bad_input(kwargs, match):
    N = 100
    rng = np.random.default_rng(0)
    args = dict(y=rng.normal(size=N), z=np.c_[rng.normal(size=N), np.ones(N)], x=rng.uniform(size=(N, 2)))
    args.update({k: v for k, v in kwargs.items() if k in args})
    opts = {k: v for k, v in kwargs.items() if k not in args}
    with pytest.raises(ValueError, match=match):
        if "optimise_on" in opts:
            opts = dict(nvr=jaxsdp.MLNVR(optimise_on=opts.pop("optimise_on")))
        jaxsdp.sdp(args["y"], args["z"], args["x"], **opts)


def test_sdp_too_few_samples():
    with pytest.raises(ValueError, match="samples"):
        jaxsdp.sdp(np.ones(4), np.ones((4, 2)), np.c_[np.arange(4.0), np.arange(4.0)])


def test_multi_sdp_bad_input():
    x = np.c_[np.linspace(0, 1, 50), np.linspace(1, 2, 50)]
    with pytest.raises(ValueError, match="`w` must have the shape of `y`"):
        jaxsdp.multi_sdp(np.ones(50), x, w=np.ones(49), a=1.0)
    with pytest.raises(ValueError, match="`tol`"):
        jaxsdp.multi_sdp(np.ones(50), x, tol=0.0)
    with pytest.raises(ValueError, match="one row per sample"):
        jaxsdp.multi_sdp(np.ones(51), x)
