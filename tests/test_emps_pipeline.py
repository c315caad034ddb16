"""The EMPS identification pipeline as a pure Module (issue 44): the study's numbers, under jit, vmap and grad."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxsdp
from jaxsdp import IDIMIV, Backfitting, Butterworth, FixedNVR, NeweyWest, Preprocessing, Smoothing
from jaxsdp.data import EMPS_BUILTIN_TRUTH, emps_builtin_reference
from jaxsdp.plants.emps import (
    EMPS_ASYM_NAMES,
    EMPSExperiment,
    EMPSPipeline,
    emps_fits,
    emps_idim_iv,
    emps_preprocess,
    emps_regression,
)
from jaxsdp.plants.emps._sdp_stage import sdp_regression, weighted_mass
from jaxsdp.studies.emps._study import iv_result

TRUTH = np.array([EMPS_BUILTIN_TRUTH[k] for k in EMPS_ASYM_NAMES])


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.abs(b)))


def test_eager_pipeline_is_the_study_stages(emps_builtin):
    """Run eagerly, the pipeline calls the kernels the stages always called, on the same arrays: the same
    numbers, bit for bit, against those kernels called here directly (`idim_ls`, `sdp`, `parametric_stage`)."""
    data = emps_builtin[0]
    fit = EMPSPipeline()(data)
    inputs = emps_preprocess(data)
    lin, asym = (emps_regression(inputs, friction=f) for f in ("linear", "asymmetric"))
    for got, reg in ((fit.idim, lin), (fit.idim_asym, asym)):
        want = jaxsdp.idim_ls(reg.y, reg.X, names=reg.names)
        for field in ("theta", "std", "cov", "residuals", "relative_error", "cond"):
            np.testing.assert_array_equal(getattr(got, field), getattr(want, field), err_msg=field)
        assert got.names == want.names and got.dof == want.dof
    y, z, x = sdp_regression(inputs)
    res = jaxsdp.sdp(y, z, x, model="RW", nvr=jaxsdp.MLNVR(nvr0=1e-4, max_nvr=1.0), max_sweeps=10, tol=1e-3, P0=1e5)
    np.testing.assert_array_equal(fit.sdp.nvr, res.nvr)
    np.testing.assert_array_equal(fit.sdp.par, res.par)
    mass = weighted_mass(res.par[:, 0], inputs.ddq)
    assert float(fit.sdp_mass) == float(mass)
    curve = jaxsdp.parametric_stage(res.par[:, 1], asym.X[:, 1:], names=asym.names[1:])
    np.testing.assert_array_equal(fit.idim_sdp.theta, curve.theta)
    np.testing.assert_array_equal(fit.idim_sdp.std, curve.std)
    theta = jnp.concatenate([jnp.asarray([float(mass)]), curve.theta])
    rel = 100.0 * jnp.linalg.norm(asym.y - asym.X @ theta) / jnp.linalg.norm(asym.y)
    assert float(fit.idim_sdp_relative_error) == float(rel)
    # the study's host reading of the fit (emps_fits) gives the same objects
    ref = emps_fits(inputs)
    assert ref.sdp.mass == float(mass) and ref.idim_sdp.relative_error == float(rel)
    # the Newey-West covariance of the same estimate
    hac = jaxsdp.idim_ls(asym.y, asym.X, cov="hac")
    np.testing.assert_array_equal(fit.idim_asym_hac.theta, fit.idim_asym.theta)
    np.testing.assert_array_equal(fit.idim_asym_hac.std, hac.std)


def test_iv_equals_the_study_iv(emps_builtin):
    """The pipeline's IV (one traced while_loop) against `emps_idim_iv` (a host loop of the same steps).

    Same iterations; estimates equal to within the problem's own rounding: the loop body is compiled as a
    whole, so XLA fuses the closed-loop simulator's arithmetic differently from the eager study and the
    instruments' forces differ in their last bits, which the IV's fixed point amplifies. The bound is measured
    here, not chosen: twice the shift of `emps_idim_iv`'s estimate when every measured force changes by one
    unit in the last place (measured 5.3e-9 relative; the two paths differ by 3e-10 to 1.1e-9 as their checks
    change). The IV's standard errors go through Andrews' automatic lag, which moves with them (measured
    1.1e-7 relative, bound 1e-6)."""
    data = emps_builtin[0]
    fit = EMPSPipeline(sdp=None, iv=IDIMIV())(data)
    ref = emps_idim_iv(data, emps_preprocess(data))
    ulp = np.random.default_rng(0).choice([-1.0, 1.0], np.shape(data.force)) * 2.0**-52
    nudged = dataclasses.replace(data, force=jnp.asarray(np.asarray(data.force) * (1 + ulp)))
    rounding = _rel(emps_idim_iv(nudged, emps_preprocess(nudged)).theta, ref.theta)
    assert 0 < rounding < 1e-7, rounding  # the estimate is well conditioned, and rounding does reach it
    assert int(fit.idim_iv.iterations) == ref.iterations and bool(fit.idim_iv.converged) == ref.converged
    assert _rel(fit.idim_iv.result.theta, ref.theta) < 2 * rounding
    assert _rel(fit.idim_iv.result.std, ref.std) < 1e-6
    assert abs(float(fit.idim_iv.relative_error) - ref.measured_relative_error) < 1e-9
    np.testing.assert_array_equal(fit.idim_iv.start, fit.idim_asym.theta)
    plain = EMPSPipeline(sdp=None, iv=IDIMIV(compensate=False, max_iter=20))(data)
    ref_plain = emps_idim_iv(data, emps_preprocess(data), iv=IDIMIV(compensate=False))
    assert _rel(plain.idim_iv.result.theta, ref_plain.theta) < 2 * rounding


def test_the_study_reports_a_failed_iv_as_failed(emps_builtin):
    """An IV loop stopped by a diverged simulation (`IVFit.failed`, here set on a real fit) reaches the study's
    result and warnings as such, not as a plain "did not converge"."""
    fit = EMPSPipeline(sdp=None, iv=IDIMIV(max_iter=2))(emps_builtin[0])
    stopped = eqx.tree_at(lambda f: (f.idim_iv.failed, f.idim_iv.iterations), fit, (jnp.asarray(True), jnp.asarray(0)))
    result, warnings = iv_result(stopped, IDIMIV(max_iter=2))
    assert result.failed and not result.converged and result.iterations == 0
    assert len(warnings) == 1 and "diverged" in warnings[0] and "IDIM-LS regression of the start" in warnings[0]
    result, warnings = iv_result(fit, IDIMIV(max_iter=2))
    assert not result.failed


@pytest.fixture(scope="module")
def records():
    """Three noisy closed-loop records of the built-in plant (seeded), as one batch of `EMPSData`."""
    with jax.enable_x64(True):
        experiment = EMPSExperiment(jnp.asarray(emps_builtin_reference(24841, 1e-3).q), dt=1e-3)
        keys = jax.random.split(jax.random.key(0), 3)
        return jax.vmap(experiment, in_axes=(0, None))(keys, jnp.asarray(TRUTH))


def test_vmap_over_records_equals_the_loop(records):
    """`jax.vmap(pipeline)` over a batch of records against the pipeline on each (jitted).

    The batch runs Householder QR in `lax` where one record runs LAPACK (`jaxsdp._linalg`), and XLA fuses the
    batched filters differently; the positions' second differences (1/dt^2 = 1e6) carry the last bits into the
    acceleration, so the estimates agree to 1e-8 relative (measured 5e-10) and the standard errors to 1e-7
    (measured 9e-9), the ML NVRs to 1e-6 (the mass NVR, on a flat likelihood 1e-11, measured 2e-9)."""
    pipe = EMPSPipeline(iv=IDIMIV(max_iter=5))
    with jax.enable_x64(True):
        batch = jax.jit(jax.vmap(pipe))(records)
        one = jax.jit(pipe)
        for i in range(3):
            fit = one(jax.tree.map(lambda a: a[i], records))
            row = jax.tree.map(lambda a: a[i], batch)
            for name in ("idim", "idim_asym", "idim_asym_hac", "idim_sdp"):
                assert _rel(getattr(row, name).theta, getattr(fit, name).theta) < 1e-8, name
                assert _rel(getattr(row, name).std, getattr(fit, name).std) < 1e-7, name
            assert _rel(row.idim_iv.result.theta, fit.idim_iv.result.theta) < 1e-8
            assert int(row.idim_iv.iterations) == int(fit.idim_iv.iterations)
            assert _rel(row.sdp.nvr, fit.sdp.nvr) < 1e-6
            assert _rel(row.sdp_mass, fit.sdp_mass) < 1e-8
    # and what they estimate: the plant, M within 0.5 %
    assert np.all(np.abs(np.asarray(batch.idim_iv.result.theta[:, 0]) / TRUTH[0] - 1) < 5e-3)


def test_gradient_through_experiment_and_identification_matches_finite_differences():
    """d se(M) / d amplitude of the reference: closed-loop simulation, filtering, decimation and the least
    squares' covariance, differentiated end to end, against central differences (h = 1e-3: truncation
    ~h^2, rounding ~eps / h)."""
    base = jnp.asarray(emps_builtin_reference(6300, 1e-3).q)  # one period of the bang-bang reference
    pipe = EMPSPipeline(sdp=None)
    key = jax.random.key(1)

    def se_mass(a):
        record = EMPSExperiment(a * base, dt=1e-3, quantum=0.0)(key, jnp.asarray(TRUTH))
        return pipe(record).idim_asym.std[0]

    with jax.enable_x64(True):
        f = jax.jit(se_mass)
        g = float(jax.jit(jax.grad(se_mass))(1.0))
        h = 1e-3
        fd = float((f(1.0 + h) - f(1.0 - h)) / (2 * h))
    assert g < 0  # a larger motion, a smaller standard error
    assert abs(g - fd) < 1e-4 * abs(fd), (g, fd)


def test_options_are_checked_before_any_work():
    with pytest.raises(ValueError, match="derivatives"):
        Preprocessing(derivatives="butterworth")
    with pytest.raises(ValueError, match="decimate"):
        Preprocessing(decimate=0)
    with pytest.raises(ValueError, match="mode"):
        Preprocessing(mode="numpy")
    with pytest.raises(ValueError, match="cutoff_hz"):
        Butterworth(-1.0)
    with pytest.raises(ValueError, match="nvr"):
        Smoothing(nvr=-1e-6)
    with pytest.raises(ValueError, match="cov"):
        jaxsdp.IDIMLS(cov="hac")
    with pytest.raises(ValueError, match="lag"):
        NeweyWest(-1)
    with pytest.raises(ValueError, match="max_iter"):
        IDIMIV(max_iter=0)
    with pytest.raises(ValueError, match="nvr"):
        FixedNVR((-1.0, 1.0))
    with pytest.raises(ValueError, match="nvr"):
        Backfitting(nvr="ml")
    with pytest.raises(ValueError, match="iv"):
        EMPSPipeline(iv=True)
    with pytest.raises(ValueError, match="EMPSData"):
        EMPSPipeline()(np.zeros(10))


def test_preprocessing_is_preprocess(emps_builtin):
    data = emps_builtin[0]
    got = Preprocessing.emps()(data.qm, data.force, data.dt)
    want = emps_preprocess(data)
    np.testing.assert_array_equal(got.ddq, want.ddq)
    assert got.description == want.description
    smooth = Preprocessing(Smoothing(50.0), drop=49, decimate=10)(data.qm, data.force, data.dt)
    np.testing.assert_array_equal(smooth.dq, emps_preprocess(data, derivatives="smooth", cutoff_hz=50.0).dq)


def test_a_record_that_ends_in_motion_is_flagged(emps_builtin):
    """The zero-phase filter's end transient: cut mid-stroke, the last decimated residual is tens of sigmas and
    moves an estimate by more than a standard error without it: the fits say so, naming the parameter. The whole
    record's end samples move no estimate that far: no warning."""
    from jaxsdp.data import Measurements
    from jaxsdp.plants.emps._diagnosis import END_SHIFT, LS_LABELS, end_warnings

    data = emps_builtin[0]
    qm = np.asarray(data.qm)
    speed = np.gradient(qm, data.dt)
    k = 15000 + int(np.argmax(np.abs(speed[15000:20000])))  # the fastest sample of a stroke
    cut = Measurements(t=np.asarray(data.t)[:k], q=qm[:k], force=np.asarray(data.force)[:k], dt=data.dt)
    label = LS_LABELS["asymmetric"]
    fits = emps_fits(emps_preprocess(cut))
    (warning,) = end_warnings(fits.idim_asym, fits.regressions[label], label)
    assert warning.startswith(f"{label}: the residuals of the record's last 1 decimated sample(s) exceed 5 times")
    assert "Fv_neg moves by" in warning and "cut the record where the axis is at rest" in warning
    # the refit the warning reports, done independently: the last row removed
    reg = fits.regressions[label]
    theta = np.linalg.lstsq(np.asarray(reg.X)[:-1], np.asarray(reg.y)[:-1], rcond=None)[0]
    i = fits.idim_asym.names.index("Fv_neg")
    shift = abs(theta[i] - float(fits.idim_asym.theta[i])) / float(fits.idim_asym.std[i])
    assert shift > END_SHIFT and f"moves by {shift:.2g} standard errors" in warning
    whole = emps_fits(emps_preprocess(data))
    assert end_warnings(whole.idim_asym, whole.regressions[label], label) == []


def test_diagnose_is_fits_from_on_the_pipelines_options(emps_builtin):
    """`EMPSPipeline.diagnose(fit)`: the host-side reading of one fit with the pipeline's own SDP options, the same
    `EMPSFits` as `fits_from`; a batch and a pipeline without the SDP stage are refused."""
    from jaxsdp.plants.emps import fits_from

    data = emps_builtin[0]
    pipe = EMPSPipeline(sdp=Backfitting(nvr=jaxsdp.MLNVR(max_nvr=0.5)))
    fit = pipe(data)
    got, want = pipe.diagnose(fit), fits_from(fit, max_nvr=0.5)
    assert got.sdp.max_nvr == 0.5 and got.sdp.nvr_bound == want.sdp.nvr_bound
    np.testing.assert_array_equal(got.idim_asym.theta, want.idim_asym.theta)
    assert got.checks() == want.checks()
    with pytest.raises(ValueError, match="one EMPSFit"):
        pipe.diagnose(jax.tree.map(lambda x: jnp.asarray(x)[None], fit))
    with pytest.raises(ValueError, match="SDP stage"):
        EMPSPipeline(sdp=None).diagnose(fit)
