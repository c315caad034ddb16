"""Timing of the EMPS closed-loop simulator (and, with the data, its accuracy).

    python benchmarks/simulation.py [--runs 1000] [--no-ident] [--json PATH]

1. one 25 s closed-loop run at 1 kHz: compile time and time after compile
   (target <= 0.5 s);
2. `vmap` of 1,000 runs with different plants and measurement-noise keys
   (target <= 60 s);
3. one reverse-mode gradient of a force-error loss w.r.t. (M, Fv, Fc, offset,
   kp, kv);
4. if DATA_EMPS.mat is found: the validation errors against the measurements
   and identification through the simulator (force and position output error,
   linear and asymmetric friction) started 30 % away from IDIM-LS.

`--json PATH` also writes every row (key `single-run`, `batch`, `gradient`,
`validation`, `validation-no-delay`, `ident-OUTPUT-FRICTION`, ...) with the
machine and the date (`benchmarks/_record.py`).
"""

import argparse
import os
import pathlib
import time

import jax
import jax.numpy as jnp
import numpy as np
from _record import Recorder

from jaxsdp.plants import (
    AsymmetricFriction,
    EMPSController,
    EMPSInitial,
    EMPSPlant,
    LinearFriction,
    bang_bang_reference,
    identify_emps_by_simulation,
    simulate_emps,
    white_noise,
)

IDIM_LS = np.array([95.1089, 203.5034, 20.3935, -3.1648])
IDIM_LS_ASYM = np.array([95.1540, 166.7061, 20.1440, 240.4236, 20.6277])
SHARED = pathlib.Path(
    os.environ.get("JAXSDP_SHARED", pathlib.Path(__file__).resolve().parents[1] / ".." / "shared")
).resolve()
EMPS_MAT = SHARED / "data" / "emps" / "DATA_EMPS.mat"


def _timeit(fn, repeat=5):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        best = min(best, time.perf_counter() - t0)
    return best


def _reference():
    """The measured reference if available, else a 25 s benchmark-like one."""
    if EMPS_MAT.exists():
        from jaxsdp.data import load_emps

        return np.asarray(load_emps(EMPS_MAT).qg), "DATA_EMPS.mat qg"
    t = np.arange(25_000) * 1e-3
    v = [0.042, 0.083, 0.0, 0.125, 0.042, -0.042, -0.083, 0.0, -0.125, -0.042, 0.0] * 4
    ts = np.concatenate(
        [np.array([0.0, 0.45, 1.25, 1.45, 2.5, 3.05, 3.55, 4.35, 4.55, 5.6, 6.1]) + 6.24 * i for i in range(4)]
    )
    return np.asarray(bang_bang_reference(t, velocities=v, switch_times=ts, accel=0.84).q), "synthetic"


def _plant(theta):
    return EMPSPlant(theta[0], LinearFriction(theta[1], theta[2], theta[3]))


def main(runs: int, ident: bool, rec: Recorder):
    with jax.enable_x64(True):
        qg, source = _reference()
        qg = jnp.asarray(qg)
        n = qg.shape[0]
        import jaxsdp

        status = getattr(jaxsdp, "fast_loops_status", lambda: "n/a")()
        print(
            f"reference: {source}, {n} samples at 1 kHz ({n / 1000:.2f} s); devices: {jax.devices()}; "
            f"XLA fast loops: {status}"
        )

        # 1. single run
        t0 = time.perf_counter()
        jax.block_until_ready(simulate_emps(qg))
        first = time.perf_counter() - t0
        single = _timeit(lambda: simulate_emps(qg))
        print(f"single run   : {single:.4f} s after compile (target <= 0.5 s)   compile+first run {first:.2f} s")
        rec.add(key="single-run", samples=n, seconds=single, ms=1e3 * single, first_s=first, target_s=0.5)

        # 2. vmap over plants and noise keys
        key_m, key_n = jax.random.split(jax.random.key(0))
        thetas = IDIM_LS * (1 + 0.2 * (jax.random.uniform(key_m, (runs, 4)) - 0.5))
        keys = jax.random.split(key_n, runs)

        @jax.jit
        def batch(thetas, keys):
            def one(theta, key):
                noise = white_noise(key, n, sigma=1e-6)
                return simulate_emps(qg, plant=_plant(theta), measurement_noise=noise).force

            return jax.vmap(one)(thetas, keys)

        t0 = time.perf_counter()
        jax.block_until_ready(batch(thetas, keys))
        first = time.perf_counter() - t0
        many = _timeit(lambda: batch(thetas, keys), repeat=2)
        print(f"{runs} runs    : {many:.2f} s after compile (target <= 60 s)   compile+first {first:.2f} s")
        rec.add(key="batch", runs=runs, seconds=many, first_s=first, target_s=60.0)

        # 3. gradient
        force_meas = simulate_emps(qg).force

        def loss(theta):
            ctrl = EMPSController(kp=theta[4], kv=theta[5])
            sim = simulate_emps(qg, plant=_plant(theta), controller=ctrl)
            return jnp.mean((sim.force - force_meas) ** 2)

        grad = jax.jit(jax.grad(loss))
        theta = jnp.asarray(np.r_[1.1 * IDIM_LS, 160.18, 243.45])
        t0 = time.perf_counter()
        jax.block_until_ready(grad(theta))
        first = time.perf_counter() - t0
        g = _timeit(lambda: grad(theta))
        print(f"gradient     : {g:.3f} s after compile (reverse mode, 6 parameters)   compile+first {first:.2f} s")
        rec.add(key="gradient", seconds=g, first_s=first)

        if not EMPS_MAT.exists():
            print(f"{EMPS_MAT} not found: skipping validation and identification")
            return
        _validation_and_identification(ident, rec)


def _rel(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return 100 * np.linalg.norm(a - b) / np.linalg.norm(a)


def _validation_and_identification(ident: bool, rec: Recorder):
    from jaxsdp import butter_derivatives
    from jaxsdp.data import load_emps

    d = load_emps(EMPS_MAT)
    meas = butter_derivatives(d.qm, 1e-3, cutoff_hz=100.0)
    k = slice(49, None)
    print("\nvalidation on DATA_EMPS.mat (IDIM-LS parameters, driven by measured qg; measured q/dq/ddq")
    print("from the standard 100 Hz Butterworth + central differences, simulated states used directly):")
    print("                      position  velocity  accel.   force")
    print("published Simulink     0.0138 %  0.229 %   8.60 %   5.85 %")
    for key, label, ctrl in [
        ("validation", "this simulator", EMPSController()),
        ("validation-no-delay", "(no delay variant)", EMPSController(delay=0)),
    ]:
        sim = simulate_emps(d.qg, plant=_plant(IDIM_LS), controller=ctrl, initial=EMPSInitial(q=d.qm[0]))
        errs = (
            _rel(meas.q[k], sim.q[k]),
            _rel(meas.dq[k], sim.dq[k]),
            _rel(meas.ddq[k], sim.ddq[k]),
            _rel(d.force[k], sim.force[k]),
        )
        print(f"{label:20s}   {errs[0]:.4f} %  {errs[1]:.3f} %   {errs[2]:.2f} %   {errs[3]:.2f} %")
        rec.add(key=key, position_pct=errs[0], velocity_pct=errs[1], acceleration_pct=errs[2], force_pct=errs[3])
    sim = simulate_emps(d.qg, plant=_plant(IDIM_LS), initial=EMPSInitial(q=d.qm[0]))
    vir_err = _rel(d.force[k], d.gtau * sim.vir[k])
    print(f"force as gtau * (controller output at t_k) instead of the force acting on the plant: {vir_err:.2f} %")
    rec.add(key="validation-controller-output", force_pct=vir_err)
    if not ident:
        return

    print("\nidentification through the simulator (Levenberg-Marquardt, exact forward-mode Jacobian),")
    print("full record, start 30 % above IDIM-LS:")
    for output, y in [("force", d.force), ("position", d.qm)]:
        for label, truth, p0 in [
            ("linear    ", IDIM_LS, _plant(1.3 * IDIM_LS)),
            (
                "asymmetric",
                IDIM_LS_ASYM,
                EMPSPlant(1.3 * IDIM_LS_ASYM[0], AsymmetricFriction(*(1.3 * IDIM_LS_ASYM[1:]))),
            ),
        ]:
            t0 = time.perf_counter()
            res = identify_emps_by_simulation(d.qg, y, plant0=p0, output=output, initial=EMPSInitial(q=d.qm[0]))
            est = np.array(res.estimates)
            dt = time.perf_counter() - t0
            sim = simulate_emps(d.qg, plant=res.plant, initial=EMPSInitial(q=d.qm[0]))
            force_err, pos_err = _rel(d.force[k], sim.force[k]), _rel(d.qm[k], sim.q[k])
            rec.add(
                key=f"ident-{output}-{label.strip()}",
                estimates=np.array2string(est, precision=4),
                max_abs_deviation_pct=float(np.max(np.abs(100 * (est - truth) / np.abs(truth)))),
                force_pct=force_err,
                position_pct=pos_err,
                steps=int(res.num_steps),
                seconds=dt,
            )
            print(
                f"  {output:8s} {label} estimates {np.array2string(est, precision=4)}  "
                f"vs IDIM-LS {np.array2string(100 * (est - truth) / np.abs(truth), precision=2)} %  "
                f"force err {force_err:.3f} %  pos err {pos_err:.5f} %  "
                f"({int(res.num_steps)} steps, {dt:.1f} s)"
            )
    for label, p in [
        ("IDIM-LS linear", _plant(IDIM_LS)),
        ("IDIM-LS asymmetric", EMPSPlant(IDIM_LS_ASYM[0], AsymmetricFriction(*IDIM_LS_ASYM[1:]))),
    ]:
        sim = simulate_emps(d.qg, plant=p, initial=EMPSInitial(q=d.qm[0]))
        force_err, pos_err = _rel(d.force[k], sim.force[k]), _rel(d.qm[k], sim.q[k])
        print(f"  {label:20s} force err {force_err:.3f} %  pos err {pos_err:.5f} %")
        rec.add(key=label.lower().replace(" ", "-"), force_pct=force_err, position_pct=pos_err)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--no-ident", action="store_true", help="skip identification through the simulator")
    parser.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = parser.parse_args()
    rec = Recorder("benchmarks/simulation.py", args.json, runs=args.runs, ident=not args.no_ident)
    main(args.runs, not args.no_ident, rec)
