"""The physically consistent estimate (issue 45): optimistix's BFGS (the library's) against a Newton written for it.

The same cost (`jaxsdp.plants.robot._physical._Problem.cost`, in log-Cholesky coordinates) minimised from the
same start along the same path of weights, on the TX40's 58 base parameters (84 full ones): unconstrained
estimates drawn around the nominal TX40 with the IDIM-LS covariance of 2,000 random states (torque noise 0.5 N m),
and the real TX40 logs' IDIM-LS estimate when the shared data are there. Three solvers: the library's
(`PhysicalSolver()`: BFGS along the path of weights), a Newton with a modified Hessian along the same path, and BFGS
started at the final weight. Per case: the final cost, the steps, the seconds after compilation:

    python benchmarks/physical.py [--cases 5] [--json benchmarks/results/cpu/physical.json]
"""

import argparse
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _record import Recorder  # noqa: E402

from jaxsdp.plants import tx40_robot  # noqa: E402
from jaxsdp.plants.robot import PhysicalSolver, robot_model  # noqa: E402
from jaxsdp.plants.robot import _physical as ph  # noqa: E402
from jaxsdp.plants.robot._joint import random_states  # noqa: E402

WEIGHT = 1e-3


def _newton_stage(problem, z, beta, L, w, max_steps=500, tol=1e-8):
    """Newton steps at weight `w`: the Hessian made positive definite (`_solve_modified`), Armijo backtracking."""
    grad, hess = jax.grad(problem.cost), jax.hessian(problem.cost)

    def step(state):
        z, k, _ = state
        f, g, H = problem.cost(z, beta, L, w), grad(z, beta, L, w), hess(z, beta, L, w)
        d = -ph._solve_modified(H, g)
        dec = -g @ d

        def bad(t):
            fn = problem.cost(z + t * d, beta, L, w)
            return (~jnp.isfinite(fn) | (fn > f - 0.25 * t * dec)) & (t > 1e-12)

        t = jax.lax.while_loop(bad, lambda t: 0.5 * t, jnp.asarray(1.0))
        ok = jnp.isfinite(problem.cost(z + t * d, beta, L, w))
        return jnp.where(ok, z + t * d, z), k + 1, jnp.where(ok, dec, 0.0)

    def going(state):
        return (state[1] < max_steps) & (0.5 * state[2] > tol)

    z, k, _ = jax.lax.while_loop(going, step, (z, jnp.asarray(0), jnp.asarray(jnp.inf)))
    return z, k


def _newton(problem, beta, L, solver):
    z = problem.coordinates(problem.start)
    steps = 0
    for w in solver.weights(WEIGHT):
        z, k = _newton_stage(problem, z, beta, L, w)
        steps = steps + k
    return z, steps


def _bfgs_path(problem, beta, L, solver):
    out = ph._estimate(problem, beta, L @ L.T, solver.weights(WEIGHT), solver)
    return problem.coordinates(out["theta"]), out["steps"]


def _bfgs_final_only(problem, beta, L, solver):
    out = ph._estimate(problem, beta, L @ L.T, (WEIGHT,), solver)
    return problem.coordinates(out["theta"]), out["steps"]


def _cases(n: int):
    model = robot_model(tx40_robot())
    X = np.asarray(model.regressor(*random_states(6, 2000, 1))).reshape(-1, model.rank)
    R = np.linalg.qr(X, mode="r")
    Ri = np.linalg.solve(R, np.eye(model.rank))
    cov = 0.25 * Ri @ Ri.T
    for seed in range(n):
        beta = model.nominal + np.linalg.cholesky(cov) @ np.random.default_rng(seed).normal(size=model.rank)
        yield f"simulated-{seed}", model, beta, cov
    try:
        from jaxsdp.data import Drives, load_joint_logs
        from jaxsdp.plants import SerialRobot
        from jaxsdp.plants.robot import robot_idim_ls

        shared = ROOT.parent / "shared" / "data" / "tx40"
        robot = SerialRobot.from_urdf(shared / "tx40_mdh_modified.urdf")
        logs = load_joint_logs(shared / "pos_read_data.csv", shared / "curr_data.csv", dt=2e-4, names=robot.names)
        drives = Drives.builtin("tx40")
        real = robot_model(robot, transmission=drives.transmission)
        res = robot_idim_ls(drives.convert(logs), real, preprocessing=dict(cutoff_hz=100.0, decimate=10))
        yield "tx40-real", real, np.asarray(res.result.theta), np.asarray(res.result.cov)
    except (OSError, ValueError) as e:
        print(f"real TX40 logs skipped: {e}")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=5)
    p.add_argument("--json", type=pathlib.Path, default=None)
    args = p.parse_args()
    rec = Recorder("physical", args.json, cases=args.cases, weight=WEIGHT)
    solver = PhysicalSolver()
    for name, model, beta, cov in _cases(args.cases):
        problem, _ = ph._problem(model, beta)
        L = jnp.linalg.cholesky(jnp.asarray(cov))
        beta = jnp.asarray(beta)
        solvers = (("bfgs-path", _bfgs_path), ("newton-path", _newton), ("bfgs-final-weight", _bfgs_final_only))
        for label, fn in solvers:
            run = jax.jit(lambda b, fn=fn: fn(problem, b, L, solver))
            jax.block_until_ready(run(beta))
            t0 = time.perf_counter()
            z, steps = jax.block_until_ready(run(beta))
            seconds = time.perf_counter() - t0
            cost = float(problem.cost(z, beta, L, WEIGHT))
            rec.add(key=f"{name}-{label}", case=name, solver=label, cost=cost, steps=int(steps), seconds=seconds)
            print(f"{name:14s} {label:16s} cost {cost:.6f}  steps {int(steps):6d}  {seconds:.2f} s")


if __name__ == "__main__":
    main()
