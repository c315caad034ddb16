"""A gradient through the whole identification, used to design an experiment (issue 44): the log-determinant of
IDIM-LS's relative covariance of the EMPS's parameters as a function of the reference's amplitude and frequency,
differentiated through the closed-loop simulation, the processing and the least squares, against central
differences; then a few BFGS steps on it give a design whose estimates, over fresh noise, spread less (the product
of their spreads).
notebooks/experiment_design.ipynb is the long form."""

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from jaxsdp.data import EMPS_BUILTIN_TRUTH
from jaxsdp.plants.emps import EMPS_ASYM_NAMES, EMPSExperiment, EMPSPipeline

NOMINAL = jnp.array([EMPS_BUILTIN_TRUTH[k] for k in EMPS_ASYM_NAMES])
DT, N = 1e-3, 2500
STROKE, DRIVE_LIMIT = 0.2, 8.0  # m; V (the drive saturates at 10 V)
PIPELINE = EMPSPipeline(sdp=None)


def _design(u):
    return STROKE * jax.nn.sigmoid(u[0]), jnp.exp(u[1])  # amplitude (m) within the stroke, frequency (Hz)


def _experiment(u):
    amplitude, f = _design(u)
    t = jnp.arange(N) * DT
    return EMPSExperiment(0.5 * amplitude * (1 - jnp.cos(2 * jnp.pi * f * t)), dt=DT, quantum=0.0)


def _objective(u, key):
    """log det of the estimates' relative covariance per unit noise variance, (X^T X)^-1 / (theta theta^T) (the
    D-optimal design), plus a penalty on the drive signal above its limit."""
    record = _experiment(u)(key, NOMINAL)
    fit = PIPELINE(record).idim_asym
    rel = fit.cov / fit.sigma**2 / jnp.outer(NOMINAL, NOMINAL)
    logdet = 2 * jnp.sum(jnp.log(jnp.diag(jnp.linalg.cholesky(0.5 * (rel + rel.T)))))
    return logdet + 10.0 * jax.nn.softplus((jnp.max(jnp.abs(record.vir)) - DRIVE_LIMIT) / 0.1) ** 2


def test_design_gradient_matches_finite_differences_and_gives_a_better_experiment():
    key = jax.random.key(0)
    u0 = jnp.array([np.log(0.1 / 0.9), np.log(1.0)])  # 2 cm at 1 Hz: a timid experiment
    with jax.enable_x64(True):
        f = jax.jit(_objective)
        g = np.asarray(jax.jit(jax.grad(_objective))(u0, key))
        # the objective is piecewise smooth: a sample whose speed changes sign switches the asymmetric model's
        # Coulomb columns, a step; jax.grad is the derivative between the steps, and the step h is small enough
        # that no sample crosses (a zero crossing moves by h t, microseconds; truncation ~h^2, rounding ~eps / h)
        h = 1e-6
        fd = np.array([(f(u0 + h * e, key) - f(u0 - h * e, key)) / (2 * h) for e in jnp.eye(2)])
        np.testing.assert_allclose(g, fd, rtol=1e-4)
        assert g[0] < 0 and g[1] < 0  # a larger, faster motion determines the parameters better
        sol = optx.minimise(_objective, optx.BFGS(rtol=1e-3, atol=1e-3), u0, args=key, max_steps=15, throw=False)
        u1 = sol.value
        assert float(f(u1, key)) < float(f(u0, key)) - 1.0
        peak = float(jnp.max(jnp.abs(_experiment(u1)(key, NOMINAL).vir)))
        assert peak < DRIVE_LIMIT + 0.5, peak  # the drive limit held (a penalty: slightly above at most)
        # fresh noise: the estimates of the designed experiment spread less, parameter by parameter
        keys = jax.random.split(jax.random.key(7), 16)

        def spread(u):
            theta = jax.vmap(lambda k: PIPELINE(_experiment(u)(k, NOMINAL)).idim_asym.theta)(keys)
            return np.asarray(jnp.std(theta / NOMINAL, axis=0))

        before, after = spread(u0), spread(u1)
        # the criterion is the volume of the confidence ellipsoid: the product of the spreads falls (a D-optimal
        # design may trade one parameter for the others)
        assert np.sum(np.log(after)) < np.sum(np.log(before)) - 1.0, (before, after)
