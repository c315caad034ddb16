"""Physically consistent robot estimates (issue 45): the log-Cholesky map, the convex estimate, its standard errors,
its derivatives, and the robot it makes."""

import jax
import numpy as np
import pytest
import scipy.linalg

from jaxsdp.plants import SerialRobot, link_parameters, tx40_robot
from jaxsdp.plants.robot import PhysicalSolver, physical_estimate, pseudo_inertia, robot_model
from jaxsdp.plants.robot._inertia import link_body
from jaxsdp.plants.robot._physical import log_cholesky_to_standard, sources, standard_to_log_cholesky


def _arm():
    """A two-joint arm with fat links (physical well inside the set) and drives."""
    inertias = [
        (3.0, [0.2, 0.02, 0.01], [0.02, 0.001, 0.0, 0.03, 0.0, 0.04]),
        (2.0, [0.25, 0.0, 0.02], [0.01, 0.0, 0.001, 0.02, 0.0, 0.025]),
    ]
    table = [[0.0, 0.0, 0.0, 0.0], [-np.pi / 2, 0.0, 0.0, 0.0]]
    return SerialRobot.from_mdh(table, inertias=inertias, Ia=[0.3, 0.1], Fv=[2.0, 1.0], Fc=[1.0, 0.5])


def _cov(model, sigma=0.05, states=400, seed=1):
    """The IDIM-LS covariance sigma^2 (X^T X)^-1 of `model`'s base parameters on random states."""
    from jaxsdp.plants.robot._joint import random_states

    X = np.asarray(model.regressor(*random_states(model.robot.n, states, seed))).reshape(-1, model.rank)
    R = np.linalg.qr(X, mode="r")
    Ri = scipy.linalg.solve_triangular(R, np.eye(model.rank))
    return sigma**2 * Ri @ Ri.T


def test_log_cholesky_bodies_are_physical_and_round_trip():
    """Every z gives a body: mass > 0, inertia about the centre of mass positive definite, triangle inequalities;
    the coordinates of that body are z again; a link's parameters back from its coordinates."""
    z = np.random.default_rng(0).normal(scale=[1.0, 1, 1, 1, 0.5, 0.5, 0.5, 0.3, 0.3, 0.3], size=(50, 10))
    pi = np.asarray(log_cholesky_to_standard(z))
    assert np.all(np.linalg.eigvalsh(np.asarray(pseudo_inertia(pi))) > 0)
    for p in pi:
        J = np.sort(np.linalg.eigvalsh(link_body(p)[2]))
        assert p[9] > 0 and J[0] > 0 and J[0] + J[1] >= J[2] * (1 - 1e-12)
    np.testing.assert_allclose(np.asarray(standard_to_log_cholesky(pi)), z, rtol=1e-9, atol=1e-9)
    rod = link_parameters(2.0, [0.5, 0.1, 0.0], [0.011, 1e-4, 0, 0.05, 0, 0.06])
    m, c, J = link_body(rod)  # link_parameters' inverse
    np.testing.assert_allclose(link_parameters(m, c, J), rod, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.asarray(log_cholesky_to_standard(standard_to_log_cholesky(rod))), rod, rtol=1e-12)
    # a body whose principal moments break the triangle inequality is not one
    bad = link_parameters(1.0, [0.0, 0.0, 0.0], [0.01, 0, 0, 0.01, 0, 0.05])
    assert np.linalg.eigvalsh(np.asarray(pseudo_inertia(bad))).min() < 0


def test_physical_estimate_of_a_physical_estimate_is_itself():
    """An unconstrained estimate inside the physical set (the arm's own parameters): kept to well below its
    standard errors, with the same standard errors, and the description's values where the data do not look."""
    model = robot_model(_arm())
    cov = _cov(model)
    est = physical_estimate(dict(theta=model.nominal, cov=cov), model, prior_weight=1e-8)
    assert bool(est.converged)
    assert np.abs(np.asarray(est.shift)).max() < 1e-3
    np.testing.assert_allclose(np.asarray(est.base_std), np.sqrt(np.diag(cov)), rtol=1e-3)
    np.testing.assert_allclose(np.asarray(est.theta), np.r_[np.asarray(_arm().inertial).ravel(), 0.3, 2.0, 1.0,
                                                            0.1, 1.0, 0.5, 0.0, 0.0], rtol=1e-4, atol=1e-6)  # fmt: skip
    assert est.warnings() == ()
    assert set(est.source) <= {"data", "combined", "prior"} and "prior" in est.source


def test_physical_estimate_equals_an_independent_solver():
    """A noisy estimate with link 2's first moment pushed far out: the same minimiser as the convex problem in the
    full parameters written again in cvxpy (log_det and trace of each link's pseudo-inertia, the drives' log
    barrier) and solved by Clarabel's conic interior point; and a physical robot."""
    cp = pytest.importorskip("cvxpy")
    robot = _arm()
    model = robot_model(robot)
    cov = _cov(model, sigma=0.5)
    beta = model.nominal + np.linalg.cholesky(cov) @ np.random.default_rng(3).normal(size=model.rank)
    k = model.names.index("MX2")
    beta[k] = -beta[k] * 5  # far out
    w = 1e-2
    est = physical_estimate(dict(theta=beta, cov=cov), model, prior_weight=w)
    assert bool(est.converged)
    P = np.asarray(pseudo_inertia(est.links()))
    assert np.linalg.eigvalsh(P).min() > 0 and np.all(np.asarray(est.theta)[20:26] > 0)

    from jaxsdp.plants.robot._physical import base_map
    from jaxsdp.plants.robot._stacked import full_parameters

    B, full = base_map(model), full_parameters(robot)
    Li = np.linalg.inv(np.linalg.cholesky(cov))
    theta = cp.Variable(28)
    cost = 0.5 * cp.sum_squares(Li @ (B @ theta - beta))
    for i in range(2):
        t = theta[10 * i : 10 * i + 10]
        inertia = cp.bmat([[t[0], t[1], t[2]], [t[1], t[3], t[4]], [t[2], t[4], t[5]]])
        sigma = 0.5 * cp.trace(inertia) * np.eye(3) - inertia
        h = cp.reshape(t[6:9], (3, 1), order="F")
        Pi = cp.bmat([[sigma, h], [h.T, cp.reshape(t[9], (1, 1), order="F")]])
        P0inv = np.linalg.inv(np.asarray(pseudo_inertia(full[10 * i : 10 * i + 10])))
        cost += w * (cp.trace(P0inv @ Pi) - cp.log_det(0.5 * (Pi + Pi.T)))
    x0 = full[20:26]
    cost += w * (cp.sum(cp.multiply(1 / x0, theta[20:26])) - cp.sum(cp.log(theta[20:26])))
    cost += w * 0.5 * cp.sum_squares(theta[26:])
    cp.Problem(cp.Minimize(cost)).solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    np.testing.assert_allclose(np.asarray(est.theta), theta.value, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(np.asarray(est.base), B @ theta.value, rtol=1e-6, atol=1e-8)


def test_non_physical_tx40_estimate_is_made_physical_and_said():
    """The TX40 with a negative viscous friction and a negative mass moment beyond reach: physical afterwards,
    the friction on its bound, a warning naming the parameter that moved most."""
    model = robot_model(tx40_robot())
    beta = model.nominal.copy()
    beta[model.names.index("Fv2")] = -2.0
    cov = np.diag((0.01 * np.abs(model.nominal) + 1e-3) ** 2)
    est = physical_estimate(dict(theta=beta, cov=cov), model)
    assert bool(est.converged)
    assert np.linalg.eigvalsh(np.asarray(pseudo_inertia(est.links()))).min() > 0
    theta = dict(zip(est.names, np.asarray(est.theta)))
    assert 0 < theta["Fv2"] < 1e-3
    assert any("Fv2" in w and "not a physical robot" in w for w in est.warnings())


def test_physical_estimate_jits_vmaps_and_differentiates():
    """vmap over two estimates equals the loop; the derivative of a physical base parameter with respect to the
    unconstrained estimate (through the minimiser, optimistix's implicit adjoint) equals central finite
    differences (2e-6 of a derivative near 1: the minimiser's tolerance)."""
    model = robot_model(_arm())
    cov = _cov(model, sigma=0.5)
    rng = np.random.default_rng(5)
    betas = model.nominal + rng.normal(size=(2, model.rank)) @ np.linalg.cholesky(cov).T
    loop = [np.asarray(physical_estimate(dict(theta=b, cov=cov), model).base) for b in betas]
    batch = jax.vmap(lambda b: physical_estimate(dict(theta=b, cov=cov), model).base)(betas)
    np.testing.assert_allclose(np.asarray(batch), np.stack(loop), rtol=1e-8, atol=1e-10)

    i = model.names.index("ZZ2") if "ZZ2" in model.names else 0

    def f(b):
        return physical_estimate(dict(theta=b, cov=cov), model, prior_weight=1e-2).base[i]

    g = np.asarray(jax.grad(f)(betas[0]))
    h = 1e-2 * np.sqrt(np.diag(cov))  # a hundredth of a standard error: above the minimiser's tolerance
    fd = np.array([(float(f(betas[0] + h[k] * e)) - float(f(betas[0] - h[k] * e))) / (2 * h[k])
                   for k, e in enumerate(np.eye(model.rank))])  # fmt: skip
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=2e-6)


def test_identified_robot_reproduces_the_physical_base_torques():
    """`PhysicalEstimate.robot` is a robot whose drive torques are the model's regressor times the physical base
    parameters (the full parameters map to the base ones as `robot_model` says)."""
    robot = _arm()
    model = robot_model(robot)
    cov = _cov(model, sigma=0.5)
    beta = model.nominal + np.linalg.cholesky(cov) @ np.random.default_rng(7).normal(size=model.rank)
    est = physical_estimate(dict(theta=beta, cov=cov), model)
    q, dq, ddq = (np.random.default_rng(k).normal(size=(20, 2)) for k in range(3))
    tau = np.asarray(est.robot(robot).drive_torques(q, dq, ddq))
    np.testing.assert_allclose(tau, np.asarray(model.regressor(q, dq, ddq)) @ np.asarray(est.base), atol=1e-10)


def test_sources_and_option_errors():
    """Which full parameters the data identify; wrong inputs refused before any work."""
    B = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 1.0, 0.0]])
    assert sources(B) == ("data", "combined", "combined", "prior")
    model = robot_model(_arm())
    good = dict(theta=model.nominal, cov=np.eye(model.rank))
    with pytest.raises(ValueError, match="prior_weight"):
        physical_estimate(good, model, prior_weight=0.0)
    with pytest.raises(ValueError, match="`estimate`"):
        physical_estimate(dict(theta=model.nominal[:-1], cov=np.eye(model.rank)), model)
    with pytest.raises(ValueError, match="PhysicalSolver"):
        physical_estimate(good, model, solver="newton")
    with pytest.raises(ValueError, match="factor"):
        PhysicalSolver(factor=1.0)
    assert PhysicalSolver().weights(1e-4) == (1.0, 0.1, 0.01, 1e-3, 1e-4)
