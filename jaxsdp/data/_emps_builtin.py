"""The built-in simulated EMPS: a data set like the benchmark's, with known truth.

The plant is `jaxsdp.plants.EMPSPlant` with asymmetric friction like the real
machine (`EMPS_BUILTIN_TRUTH`, the published asymmetric IDIM-LS values; offset 0,
since eq. 17 has no offset column), driven in closed loop by the benchmark's
controller along a bang-bang velocity reference with the benchmark's
plateaus and acceleration (measured from `qg` of DATA_EMPS.mat), with one
encoder count of white noise and quantisation on the measured position.
`jaxsdp emps` without `--data` analyses this data set.

**Offset 0.** Eq. (17) has no offset column: a constant force is
indistinguishable from a difference of the two Coulomb levels (offset o with
Coulomb levels c is the same law as Fc+ = c + o, Fc- = c - o), and the
published Fc+/Fc- already contain the machine's constant force (Fc+ - Fc- =
-0.49 N, i.e. offset -0.245 N around a symmetric 20.385 N). With offset 0 the
truth is exactly the published asymmetric model.

**Reference.** The benchmark's bang-bang velocity profile: plateaus of
0.04212, 0.08255 and 0.12467 m/s reached from rest at 0.8424 m/s^2, in both
directions, period 6.24 s, 24,841 samples at 1 kHz (the length of
DATA_EMPS.mat, so both share the compiled kernels). The controller reads the
position with white noise of one encoder count (5e-8 m) standard deviation,
seeded, then quantised to the encoder count. The recorded force is the drive
force acting on the plant, `gtau * vir` applied with the controller's
one-sample delay (what the benchmark's Simulink model logs), so
`vir = force / gtau`.
"""

import jax
import jax.numpy as jnp
import numpy as np

from .._runtime import x64
from ..plants._friction import AsymmetricFriction
from ..plants._trajectories import bang_bang_reference, encoder_quantum, white_noise
from ..plants.emps._plant import EMPSController, EMPSPlant, simulate_emps
from ._loaders import EMPSData

EMPS_BUILTIN_TRUTH = dict(M=95.15, Fv_pos=166.7, Fc_pos=20.14, Fv_neg=240.4, Fc_neg=20.63, offset=0.0)
#: Velocity plateaus (m/s), their durations (s) and the acceleration (m/s^2) of the
#: benchmark's reference, measured on DATA_EMPS.mat `qg`.
BUILTIN_LEVELS = (0.04212, 0.08255, 0.12467, 0.04212)
BUILTIN_PLATEAUS = (0.352, 0.688, 1.036, 0.352)
BUILTIN_ACCEL = 0.8424
BUILTIN_SAMPLES = 24841
BUILTIN_DT = 1e-3
BUILTIN_START = 0.05  # s at rest before the first move


@x64
def emps_builtin_reference(n=BUILTIN_SAMPLES, dt=BUILTIN_DT):
    """The benchmark-like bang-bang reference (`jaxsdp.plants.Trajectory`) on `n` samples.

    Each cycle: +V1, +V2, +V3 (each reached from rest), +V1, then directly
    -V1, -V2, -V3 (from rest), -V1, and directly back to +V1; velocity
    plateaus V = 0.04212, 0.08255, 0.12467 m/s held `BUILTIN_PLATEAUS` (s),
    reached at 0.8424 m/s^2 (`jaxsdp.plants.bang_bang_reference`; period
    6.24 s, as in DATA_EMPS.mat), starting at rest at q = 0 after 0.05 s.

    **Arguments:** `n` samples (default 24,841, the benchmark's length),
    `dt` sampling period (s, default 1e-3).

    **Returns:** a `Trajectory`: `q` (m), `dq` (m/s), `ddq` (m/s^2).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.data import emps_builtin_reference
        >>> ref = emps_builtin_reference(2000)  # the first 2 s
        >>> ref.q.shape, round(float(np.max(ref.dq)), 5)  # m/s, the fastest plateau
        ((2000,), 0.12467)
    """
    end = n * dt
    velocities, switches = [], []
    t, v = BUILTIN_START, 0.0
    while t < end:
        for sign in (1.0, -1.0):
            for i, (level, plateau) in enumerate(zip(BUILTIN_LEVELS, BUILTIN_PLATEAUS)):
                if i > 0 and v != 0.0:  # back to rest before the next level
                    velocities.append(0.0)
                    switches.append(t)
                    t, v = t + abs(v) / BUILTIN_ACCEL, 0.0
                target = sign * level
                velocities.append(target)
                switches.append(t)
                t, v = t + abs(target - v) / BUILTIN_ACCEL + plateau, target
    return bang_bang_reference(np.arange(n) * dt, velocities=velocities, switch_times=switches, accel=BUILTIN_ACCEL)


@x64
def emps_builtin_data(seed=0):
    r"""Simulate the built-in EMPS data set: a record like DATA_EMPS.mat with known truth.

    Plant: $M \ddot q = force - f(\dot q)$, `EMPSPlant` with the asymmetric friction
    of eq. (17), $f(\dot q) = F_v^+ \dot q + F_c^+$ ($\dot q > 0$), $F_v^- \dot q - F_c^-$
    ($\dot q < 0$), parameters `EMPS_BUILTIN_TRUTH` (M 95.15 kg, Fv_pos 166.7 and
    Fv_neg 240.4 N/(m/s), Fc_pos 20.14 and Fc_neg 20.63 N, offset 0), in
    closed loop with the benchmark's controller (`EMPSController`) along
    `emps_builtin_reference()`; the controller reads the position with white
    noise of one encoder count (5e-8 m) and quantised to that count.
    24,841 samples at 1 kHz.

    **Arguments:** `seed`: the measurement-noise seed (int).

    **Returns:** `(data, truth, description)`: an `EMPSData` (`qm` m, `qg` m,
    `vir` V, `force` N, `dt` s), the true parameters (the
    `EMPS_BUILTIN_TRUTH` dict plus `fv_ratio` = Fv_neg / Fv_pos), and a dict
    describing the plant, excitation, measurement, force and seed.

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> data, truth, description = emps_builtin_data(seed=0)
        >>> data.qm.shape, data.dt, truth["M"]  # samples, s, kg
        ((24841,), 0.001, 95.15)
    """
    n, dt = BUILTIN_SAMPLES, BUILTIN_DT
    tr = EMPS_BUILTIN_TRUTH
    ref = emps_builtin_reference(n, dt)
    quantum = encoder_quantum()
    noise = white_noise(jax.random.key(seed), n, sigma=quantum)
    plant = EMPSPlant(tr["M"], AsymmetricFriction(tr["Fv_pos"], tr["Fc_pos"], tr["Fv_neg"], tr["Fc_neg"], tr["offset"]))
    ctrl = EMPSController()
    sim = simulate_emps(ref.q, plant=plant, controller=ctrl, dt=dt, measurement_noise=noise, quantum=quantum)
    gtau = float(ctrl.gtau)
    with jax.enable_x64(True):
        data = EMPSData(
            t=jnp.asarray(sim.t),
            qm=sim.q_meas,
            qg=jnp.asarray(ref.q),
            vir=sim.force / gtau,
            force=sim.force,
            gtau=gtau,
            kp=float(ctrl.kp),
            kv=float(ctrl.kv),
            dt=dt,
        )
    truth = {**tr, "fv_ratio": tr["Fv_neg"] / tr["Fv_pos"]}
    desc = {
        "plant": "EMPSPlant with AsymmetricFriction (exact stick-slip), benchmark controller (kp 160.18, kv 243.45, "
        "gtau 35.15, one-sample delay)",
        "excitation": f"bang-bang velocity reference, plateaus {BUILTIN_LEVELS[:3]} m/s, acceleration "
        f"{BUILTIN_ACCEL} m/s^2, {n * dt:.2f} s",
        "measurement": f"position + N(0, ({quantum:.1e} m)^2) noise, quantised to {quantum:.1e} m (one encoder count)",
        "force": "drive force acting on the plant, gtau * vir delayed by one sample",
        "seed": int(seed),
    }
    return data, truth, desc
