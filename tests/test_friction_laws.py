"""Friction laws beyond viscous + Coulomb (issue 45, item 4): the fits against scipy's least squares, the choice by
BIC on data of each law, the held-out errors, the errors for what cannot be fitted."""

import jax
import numpy as np
import pytest
import scipy.optimize

from jaxsdp.plants import (
    AsymmetricCoulomb,
    SmoothCoulomb,
    Stribeck,
    ViscousCoulomb,
    cross_validate_friction,
    fit_friction,
    select_friction,
)

jax.config.update("jax_enable_x64", True)

TRUE = {
    "ViscousCoulomb": (ViscousCoulomb(), lambda v: 3.0 * v + 2.0 * np.sign(v)),
    "AsymmetricCoulomb": (AsymmetricCoulomb(), lambda v: np.where(v > 0, 3.0 * v + 2.5, 1.5 * v - 1.5)),
    "SmoothCoulomb": (SmoothCoulomb(), lambda v: 2.0 * np.tanh(v / 0.05) + 3.0 * v),
    "Stribeck": (Stribeck(), lambda v: np.sign(v) * (2.0 + 1.5 * np.exp(-((v / 0.08) ** 2))) + 3.0 * v),
}


def _data(law_name, n=3000, noise=0.05, seed=0):
    """An axis of mass 2 kg with an offset of 0.3 N on a two-sine motion, friction by `law_name`, white noise."""
    t = np.linspace(0, 30, n)
    v = 0.6 * np.sin(0.7 * t) + 0.3 * np.sin(2.3 * t + 1.0)
    a = 0.42 * np.cos(0.7 * t) + 0.69 * np.cos(2.3 * t + 1.0)
    y = 2.0 * a + 0.3 + TRUE[law_name][1](v) + noise * np.random.default_rng(seed).normal(size=n)
    return y, np.c_[a, np.ones(n)], v


@pytest.mark.parametrize("name", sorted(TRUE))
def test_fit_equals_scipy_least_squares(name):
    """The same minimum and standard errors as scipy's `least_squares` (trust region reflective) on the same residual,
    written again here, from the same start."""
    law = TRUE[name][0]
    y, X, v = _data(name)
    fit = fit_friction(y, X, v, law, names=("M", "offset"))
    assert bool(fit.converged)

    def residual(z):
        return y - X @ z[:2] - np.asarray(law(jax.numpy.asarray(v), jax.numpy.asarray(z[2:])))

    start = np.r_[np.asarray(fit.theta), np.asarray(fit.raw)] * (1 + 0.05 * np.arange(2 + len(law.names)) / 10)
    ref = scipy.optimize.least_squares(residual, start, xtol=1e-15, ftol=1e-15, gtol=1e-15)
    np.testing.assert_allclose(np.r_[np.asarray(fit.theta), np.asarray(fit.raw)], ref.x, rtol=1e-6, atol=1e-9)
    J = ref.jac
    sigma2 = ref.fun @ ref.fun / (len(y) - len(ref.x))
    se_raw = np.sqrt(sigma2 * np.diag(np.linalg.inv(J.T @ J)))
    values = np.r_[np.asarray(fit.theta), np.asarray(fit.p)]
    raw = np.r_[np.asarray(fit.theta), np.asarray(fit.raw)]
    dvalues = np.where(np.isclose(values, raw), 1.0, values)  # d exp(u) / du = exp(u) for the log scales
    np.testing.assert_allclose(np.asarray(fit.std), se_raw * np.abs(dvalues), rtol=1e-5)
    assert fit.as_dict()["M"] == pytest.approx(2.0, abs=5 * float(fit.std[0]) + 1e-3)


@pytest.mark.parametrize("name", sorted(TRUE))
def test_bic_chooses_the_law_of_the_data(name):
    chosen, fits = select_friction(*_data(name, seed=1))
    assert chosen == name, {f.law: float(f.bic) for f in fits}
    assert {f.law for f in fits} == set(TRUE)


def test_stribeck_parameters_recovered_and_held_out_error_lower():
    y, X, v = _data("Stribeck", seed=2)
    fit = fit_friction(y, X, v, Stribeck(), names=("M", "offset"))
    got = fit.as_dict()
    for k, want in dict(M=2.0, offset=0.3, Fv=3.0, Fc=2.0, Fs=3.5, vs=0.08).items():
        i = fit.names.index(k)
        assert abs(got[k] - want) <= 4 * float(fit.std[i]) + 1e-6, (k, got[k], want, float(fit.std[i]))
    linear = cross_validate_friction(y, X, v, AsymmetricCoulomb())
    assert cross_validate_friction(y, X, v, Stribeck()) < 0.8 * linear


def test_errors_before_any_work():
    y, X, v = _data("ViscousCoulomb", n=200)
    with pytest.raises(ValueError, match="FrictionLaw"):
        fit_friction(y, X, v, "stribeck")
    with pytest.raises(ValueError, match="must agree"):
        fit_friction(y, X, v[:-1])
    with pytest.raises(ValueError, match="`names`"):
        fit_friction(y, X, v, names=("M",))
    with pytest.raises(ValueError, match="`folds`"):
        cross_validate_friction(y, X, v, ViscousCoulomb(), folds=1)
