"""`jaxsdp._linalg`: LAPACK on one problem (bit for bit), LAPACK-free under `vmap` (no XLA-CPU deadlock), gradients
of the `lax` version (issue 44: two batched QRs in one program hung the process on a 2-thread pool)."""

import re
import subprocess
import sys
import textwrap

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
import pytest

from jaxsdp._idim.ls import idim_ls, linear_estimate, ls_estimate
from jaxsdp._linalg import (
    SEMINORMAL_COND,
    _lapack_lstsq_r,
    back_substitute,
    householder_lstsq,
    householder_qr,
    householder_r,
    lstsq,
    qr_r,
    qr_thin,
    solve_upper,
    tall_lstsq,
)

jax.config.update("jax_enable_x64", True)


def _problem(seed=0, n=600, p=5, batch=8):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((batch, n, p)) * np.logspace(0, 2, p)  # columns of different scales
    y = np.einsum("bnp,p->bn", X, np.arange(1.0, p + 1)) + 0.1 * rng.standard_normal((batch, n))
    return jnp.asarray(y), jnp.asarray(X)


def _lapack_calls(fn, *args):
    return sorted(set(re.findall(r'custom_call_target="([^"]*lapack[^"]*)"', jax.jit(fn).lower(*args).as_text())))


def test_one_problem_is_lapack_bit_for_bit():
    y, X = _problem()
    a = jnp.concatenate([X[0], y[0][:, None]], axis=1)
    r = qr_r(a)
    assert jnp.array_equal(r, jnp.linalg.qr(a, mode="r"))
    b = jnp.eye(r.shape[0])
    assert jnp.array_equal(solve_upper(r, b), jsl.solve_triangular(r, b, lower=False))
    assert jnp.array_equal(jax.jit(qr_r)(a), jax.jit(lambda m: jnp.linalg.qr(m, mode="r"))(a))
    for u, v in zip(qr_thin(a), jnp.linalg.qr(a, mode="reduced")):
        assert jnp.array_equal(u, v)


def test_the_lax_versions_equal_lapack_to_rounding():
    y, X = _problem()
    a = jnp.concatenate([X[0], y[0][:, None]], axis=1)
    r_lax, r_lapack = householder_r(a), jnp.linalg.qr(a, mode="r")
    assert float(jnp.max(jnp.abs(r_lax - r_lapack)) / jnp.max(jnp.abs(r_lapack))) < 1e-13  # same signs as LAPACK
    (q_lax, r2), (q_lapack, _) = householder_qr(a), jnp.linalg.qr(a, mode="reduced")
    # (Q to the rounding of a matrix of condition ~1e3: its last column is the residual direction)
    assert float(jnp.max(jnp.abs(q_lax - q_lapack))) < 1e-11 and jnp.array_equal(r2, r_lax)
    b = jnp.asarray(np.random.default_rng(1).standard_normal((r_lapack.shape[0], 3)))
    ref = jsl.solve_triangular(r_lapack, b, lower=False)
    assert float(jnp.max(jnp.abs(back_substitute(r_lapack, b) - ref) / jnp.max(jnp.abs(ref)))) < 1e-13


def test_vmap_has_no_lapack_call_and_equals_the_loop():
    y, X = _problem()
    one = lambda yy, XX: ls_estimate(yy, XX, jnp.nan)  # noqa: E731
    batched = jax.vmap(one)
    assert _lapack_calls(lambda yb, Xb: batched(yb, Xb)["theta"], y, X) == []
    out = batched(y, X)
    for i in range(y.shape[0]):
        ref = one(y[i], X[i])
        for field in ("theta", "std", "cov", "residuals"):
            # (residuals y - X theta: rounding relative to y's scale)
            scale = float(jnp.max(jnp.abs(y[i] if field == "residuals" else ref[field])))
            assert float(jnp.max(jnp.abs(out[field][i] - ref[field]))) <= 1e-12 * scale, field
        assert float(out["cond"][i]) == pytest.approx(float(ref["cond"]), rel=1e-12)


def test_least_squares_start_of_the_sdp():
    y, X = _problem(seed=5)
    assert jnp.array_equal(lstsq(X[0], y[0]), jnp.linalg.lstsq(X[0], y[0])[0])  # one problem: LAPACK
    assert _lapack_calls(jax.vmap(lstsq), X, y) == []
    batched, ref = jax.vmap(lstsq)(X, y), jnp.stack([jnp.linalg.lstsq(X[i], y[i])[0] for i in range(X.shape[0])])
    # (the lax version's tiny ridge: (lambda / sigma_min)^2 relative, 1e-12 here)
    assert float(jnp.max(jnp.abs(batched - ref))) <= 1e-10 * float(jnp.max(jnp.abs(ref)))
    # columns that add nothing (zero, or a copy of another): a finite solution with LAPACK's fit, not a division by 0
    for Xd in (X[0].at[:, 2].set(0.0), X[0].at[:, 2].set(X[0][:, 1])):
        x_lax, x_lapack = householder_lstsq(Xd, y[0]), jnp.linalg.lstsq(Xd, y[0])[0]
        assert bool(jnp.all(jnp.isfinite(x_lax))) and float(jnp.max(jnp.abs(x_lax))) < 10 * float(
            jnp.max(jnp.abs(x_lapack))
        )
        fit, ref_fit = Xd @ x_lax, Xd @ x_lapack
        assert float(jnp.max(jnp.abs(fit - ref_fit))) <= 1e-9 * float(jnp.max(jnp.abs(ref_fit)))


def test_instrumental_variables_under_vmap_equal_the_loop():
    y, X = _problem(seed=3)
    Z = X + 0.1 * jnp.asarray(np.random.default_rng(4).standard_normal(X.shape))  # instruments near X
    one = lambda yy, XX, ZZ: linear_estimate(yy, XX, ZZ, jnp.nan, cov="hac")  # noqa: E731
    assert _lapack_calls(lambda *a: jax.vmap(one)(*a)["theta"], y, X, Z) == []
    out = jax.vmap(one)(y, X, Z)
    for i in range(y.shape[0]):
        ref = one(y[i], X[i], Z[i])
        for field in ("theta", "std"):
            assert float(jnp.max(jnp.abs(out[field][i] - ref[field]))) <= 1e-11 * float(jnp.max(jnp.abs(ref[field])))


def test_gradients_match_finite_differences_and_need_no_batched_lapack():
    y, X = _problem(batch=4)

    def loss(yy, XX):
        out = ls_estimate(yy, XX, jnp.nan)
        return jnp.sum(out["theta"] ** 2) + jnp.sum(out["std"])

    g_y, g_X = jax.grad(loss, argnums=(0, 1))(y[0], X[0])
    rng = np.random.default_rng(2)
    dy, dX = jnp.asarray(rng.standard_normal(y[0].shape)), jnp.asarray(rng.standard_normal(X[0].shape))
    eps = 1e-6
    fd = (loss(y[0] + eps * dy, X[0] + eps * dX) - loss(y[0] - eps * dy, X[0] - eps * dX)) / (2 * eps)
    assert float(jnp.vdot(g_y, dy) + jnp.vdot(g_X, dX)) == pytest.approx(float(fd), rel=1e-6)
    per = jax.vmap(jax.grad(loss))(y, X)
    assert float(jnp.max(jnp.abs(per[0] - g_y))) <= 1e-10 * float(jnp.max(jnp.abs(g_y)))
    assert _lapack_calls(jax.vmap(jax.grad(loss)), y, X) == []
    whole = jax.grad(lambda yb: jnp.sum(jax.vmap(loss)(yb, X)))(y)
    assert jnp.allclose(whole, per, rtol=1e-10, atol=0)


def test_two_batched_least_squares_in_one_program_finish():
    # the program that hung jaxlib 0.10's XLA-CPU: two independent batched QRs (batch 64, 2,500 x 5) in flight
    script = textwrap.dedent(
        """
        import jax, jax.numpy as jnp, numpy as np
        jax.config.update("jax_enable_x64", True)
        from jaxsdp._idim.ls import ls_estimate
        rng = np.random.default_rng(0)
        X1, X2 = (jnp.asarray(rng.standard_normal((64, 2500, 5))) for _ in range(2))
        y1, y2 = (jnp.asarray(rng.standard_normal((64, 2500))) for _ in range(2))
        one = jax.vmap(lambda y, X: ls_estimate(y, X, jnp.nan)["theta"])
        both = jax.jit(lambda: (one(y1, X1), one(y2, X2)))
        for _ in range(3):
            jax.block_until_ready(both())
        print("done")
        """
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=240)
    assert out.returncode == 0 and "done" in out.stdout, out.stderr[-2000:]


def _conditioned(cond, seed=0, n=3000, p=8, noise=1e-2):
    """A tall X with singular values from 1 to 1/cond and columns scaled from 1e-3 to 1e3, y = X theta + e with e
    orthogonal to X's columns: theta is the least-squares solution (to the rounding of forming X)."""
    rng = np.random.default_rng(seed)
    U, _ = np.linalg.qr(rng.standard_normal((n, p + 1)))
    V, _ = np.linalg.qr(rng.standard_normal((p, p)))
    scale = np.logspace(-3, 3, p)
    X = (U[:, :p] * np.logspace(0, -np.log10(cond), p)) @ V.T * scale
    theta = rng.standard_normal(p) / scale
    return jnp.asarray(X @ theta + noise * U[:, p]), jnp.asarray(X), theta


def _error_and_bound(x, y, X, theta):
    """The error of `x` on the column-scaled problem and the first-order forward error bound of a backward-stable
    least-squares solver there, p eps (kappa + kappa^2 |r| / (|X| |z|)) (z the scaled solution; the dimension p as
    the constant, as in the textbook bounds: Higham, Accuracy and Stability, ch. 20)."""
    Xn, d = np.asarray(X), np.linalg.norm(np.asarray(X), axis=0)
    kappa = np.linalg.cond(Xn / d)
    z = theta * d
    resid = np.linalg.norm(np.asarray(y) - Xn @ theta)
    bound = np.finfo(float).eps * (kappa + kappa**2 * resid / (np.linalg.norm(Xn / d, 2) * np.linalg.norm(z)))
    return np.linalg.norm((np.asarray(x) - theta) * d) / np.linalg.norm(z), Xn.shape[1] * bound


@pytest.mark.parametrize(
    "cond, noise, n",
    [(c, e, 3000) for c in (1.0, 1e2, 1e3, 0.9 * SEMINORMAL_COND) for e in (1e-6, 1.0, 100.0)]
    + [(1.0, 1.0, 300_000), (0.9 * SEMINORMAL_COND, 1.0, 300_000)],  # the Gram matrix's rounding grows with N
)
def test_seminormal_least_squares_meets_the_error_bound_of_householder(cond, noise, n):
    # the semi-normal equations with one refinement step against the known solution: within the forward error
    # bound of a backward-stable solver, as the LAPACK Householder QR; R^T R = X^T X with a positive diagonal
    y, X, theta = _conditioned(cond, noise=noise, n=n)
    x, r = tall_lstsq(X, y)
    x_h, r_h = _lapack_lstsq_r(X, y)
    err, bound = _error_and_bound(x, y, X, theta)
    err_h, _ = _error_and_bound(x_h, y, X, theta)
    assert err <= bound and err_h <= bound, (err, err_h, bound)
    assert bool(jnp.all(jnp.diag(r) > 0))
    d = np.linalg.norm(np.asarray(X), axis=0)
    assert float(jnp.max(jnp.abs((r - r_h) / d))) <= 1e-13 * cond * float(jnp.max(jnp.abs(r_h / d)))
    assert not jnp.array_equal(x, x_h)  # (it did not fall back: the two differ in the last digits)


def test_seminormal_r_has_the_sign_and_derivative_of_the_batched_path():
    # unbatched (semi-normal), batched (Householder in lax) and differentiated: the same R, positive diagonal
    y, X = _problem(seed=7, batch=3)
    one = [tall_lstsq(X[i], y[i]) for i in range(3)]
    xb, rb = jax.vmap(tall_lstsq)(X, y)
    for i, (x, r) in enumerate(one):
        assert bool(jnp.all(jnp.diag(rb[i]) > 0))
        assert float(jnp.max(jnp.abs(rb[i] - r))) <= 1e-12 * float(jnp.max(jnp.abs(r)))
        assert float(jnp.max(jnp.abs(xb[i] - x))) <= 1e-12 * float(jnp.max(jnp.abs(x)))
    dX = jnp.asarray(np.random.default_rng(8).standard_normal(X[0].shape))
    _, (dx, dr) = jax.jvp(tall_lstsq, (X[0], y[0]), (dX, jnp.zeros_like(y[0])))
    eps = 1e-6
    (xp, rp), (xm, rm) = tall_lstsq(X[0] + eps * dX, y[0]), tall_lstsq(X[0] - eps * dX, y[0])
    np.testing.assert_allclose(dr, (rp - rm) / (2 * eps), rtol=1e-6, atol=1e-6 * float(jnp.max(jnp.abs(dr))))
    np.testing.assert_allclose(dx, (xp - xm) / (2 * eps), rtol=1e-6, atol=1e-6 * float(jnp.max(jnp.abs(dx))))


@pytest.mark.parametrize("case", ["ill-conditioned", "repeated column", "zero column", "subnormal column"])
def test_seminormal_least_squares_falls_back_to_householder(case):
    y, X, _ = _conditioned(10 * SEMINORMAL_COND if case == "ill-conditioned" else 10.0, seed=1)
    if case == "repeated column":
        X = X.at[:, 3].set(X[:, 2])
    elif case == "zero column":
        X = X.at[:, 3].set(0.0)
    elif case == "subnormal column":  # its squared norm underflows below the normal floats: the Gram matrix is inexact
        X = X.at[:, 3].multiply(1e-160)
    x, r = jax.jit(tall_lstsq)(X, y)
    x_h, r_h = jax.jit(_lapack_lstsq_r)(X, y)
    assert jnp.array_equal(x, x_h, equal_nan=True) and jnp.array_equal(r, r_h)
    if case in ("repeated column", "zero column"):  # and idim_ls still calls it unidentifiable
        with pytest.raises(ValueError, match="not identifiable"):
            idim_ls(y, X)


def test_seminormal_least_squares_in_idim_ls_matches_the_textbook_formulas():
    # theta, its covariance sigma^2 (X^T X)^-1 and the residuals against NumPy's lstsq and a direct inverse, compared
    # on the column-scaled problem (the columns span six decades)
    y, X, _ = _conditioned(50.0, seed=2, noise=1.0)
    res = idim_ls(y, X)
    Xn, yn = np.asarray(X), np.asarray(y)
    d = np.linalg.norm(Xn, axis=0)
    ref = np.linalg.lstsq(Xn / d, yn, rcond=None)[0] / d
    np.testing.assert_allclose(np.asarray(res.theta) * d, ref * d, rtol=0, atol=1e-12 * np.max(np.abs(ref * d)))
    e = yn - Xn @ ref
    cov_scaled = e @ e / (Xn.shape[0] - Xn.shape[1]) * np.linalg.inv((Xn / d).T @ (Xn / d))
    np.testing.assert_allclose(np.asarray(res.cov) * np.outer(d, d), cov_scaled, rtol=1e-10, atol=0)
    np.testing.assert_allclose(np.asarray(res.residuals), e, rtol=0, atol=1e-12 * np.max(np.abs(yn)))
