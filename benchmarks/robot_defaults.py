"""Measurement: the robot study's processing defaults (issue 42, item 2) at 100 Hz, 500 Hz, 1 kHz and 5 kHz.

A three-joint arm (the UR5's shoulder pan, shoulder lift and elbow from
example-robot-data, or a planar modified-DH arm without it) follows a smooth
multi-sine (0.1-2 Hz per joint); its drive torques (`drive_torques`: rigid
body, motor inertia, viscous and Coulomb friction, offsets) get 1 % white
noise (of each joint's rms torque), its angles an encoder quantisation of
1e-5 rad. At each rate `robot_study` (IDIM-LS, no SDP) runs with the
defaults (`processing_defaults`) and a few alternatives; the table gives per
joint the relative error in motion, beside the truth's own on the same rows
(the noise floor: the ratio is 1 when the estimate fits as well as the
truth), and the base parameters' errors against the truth (the well-excited
ones: relative standard deviation below 5 %).

Usage: python benchmarks/robot_defaults.py [--seconds 30] [--rates 100 500 1000 5000]
"""

import argparse
import pathlib
import sys
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

from jaxsdp._checks import OptionError  # noqa: E402
from jaxsdp.data import JointLogs  # noqa: E402
from jaxsdp.plants import SerialRobot  # noqa: E402
from jaxsdp.plants.robot import RobotProcessing  # noqa: E402
from jaxsdp.plants.robot._defaults import processing_defaults  # noqa: E402
from jaxsdp.studies.robot import robot_study  # noqa: E402

FREQS = np.array([[0.11, 0.47, 1.3, 1.9], [0.17, 0.61, 1.1, 1.7], [0.13, 0.53, 0.9, 2.0]])  # Hz, per joint
AMPS = np.array([[0.6, 0.25, 0.08, 0.04], [0.4, 0.2, 0.07, 0.04], [0.5, 0.25, 0.1, 0.05]])  # rad
QUANT = 1e-5  # rad
NOISE = 0.01  # of each joint's rms torque
WELL_EXCITED = 5.0  # %: relative standard deviation


def arm() -> SerialRobot:
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
    from helpers import EXAMPLE_ROBOTS

    if EXAMPLE_ROBOTS is not None:
        urdf = EXAMPLE_ROBOTS / "ur_description" / "urdf" / "ur5_robot.urdf"
        robot = SerialRobot.from_urdf(urdf, base_link="base_link", tip_link="forearm_link")
    else:
        robot = SerialRobot.from_mdh(
            [[0.0, 0.0, 0.0, 0.0], [np.pi / 2, 0.0, 0.0, 0.0], [0.0, 0.42, 0.0, 0.0]],
            inertias=[
                (3.7, [0.0, 0.0, 0.0], [0.01, 0, 0, 0.01, 0, 0.007]),
                (8.4, [0.2, 0.0, 0.0], [0.02, 0, 0, 0.2, 0, 0.2]),
                (2.3, [0.2, 0.0, 0.0], [0.005, 0, 0, 0.05, 0, 0.05]),
            ],
        )
    drives = (jnp.array([0.4, 0.4, 0.2]), jnp.array([6.0, 5.0, 3.0]), jnp.array([4.0, 3.5, 2.0]))
    return eqx.tree_at(lambda r: (r.Ia, r.Fv, r.Fc, r.offset), robot, (*drives, jnp.array([0.5, -0.3, 0.2])))


def motion(t):
    w = 2 * np.pi * FREQS
    ph = np.random.default_rng(1).uniform(0, 2 * np.pi, FREQS.shape)
    arg = w[None] * t[:, None, None] + ph[None]
    q = np.sum(AMPS * np.sin(arg), -1)
    dq = np.sum(AMPS * w * np.cos(arg), -1)
    ddq = -np.sum(AMPS * w**2 * np.sin(arg), -1)
    return q, dq, ddq


def logs_at(robot, fs, seconds, quant=QUANT, seed=0):
    t = np.arange(0.0, seconds, 1.0 / fs)
    q, dq, ddq = motion(t)
    tau = np.asarray(robot.drive_torques(q, dq, ddq))
    rng = np.random.default_rng(seed)
    tau = tau + NOISE * tau.std(axis=0) * rng.standard_normal(tau.shape)
    qm = np.round(q / quant) * quant
    logs = JointLogs(
        q=jnp.asarray(qm),
        tau=jnp.asarray(tau),
        t=jnp.asarray(t),
        dt=1.0 / fs,
        joints=(1, 2, 3),
        source=f"simulated at {fs:g} Hz",
        converted="none",
    )
    return logs


def scores(study):
    idim = study.idim
    y, X, mov = np.asarray(idim.y), np.asarray(idim.X), np.asarray(idim.moving)
    truth = np.einsum("mjp,p->mj", X, np.asarray(idim.model.nominal))
    floor = [100 * np.linalg.norm((y - truth)[mov[:, i], i]) / np.linalg.norm(y[mov[:, i], i]) for i in range(3)]
    rel = [idim.relative_error[j] for j in (1, 2, 3)]
    est, nom = np.asarray(idim.result.theta), np.asarray(idim.model.nominal)
    rsd = np.asarray(idim.result.rel_std)
    good = (rsd < WELL_EXCITED) & (np.abs(nom) > 1e-6)
    err = 100 * np.abs(est - nom)[good] / np.abs(nom[good])
    z = np.abs(est - nom)[good] / (np.abs(nom[good]) * rsd[good] / 100)
    return rel, floor, err, int(good.sum()), idim.model.rank, z


def variants(default):
    fc, d = default.cutoff_hz, default.decimate
    out = [("defaults", {})]
    out.append(("TX40 100 Hz/10/100", dict(cutoff_hz=100.0, decimate=10, drop=100)))
    out.append(("cut-off / 2", dict(cutoff_hz=fc / 2)))
    out.append(("cut-off x 2", dict(cutoff_hz=2 * fc)))
    out.append(("noise_limited=True", dict(noise_limited=True)))
    if d > 1:
        out.append(("no decimation", dict(decimate=1)))
    else:
        out.append(("decimation 2", dict(decimate=2)))
    out.append(("drop 0", dict(drop=0)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--rates", type=float, nargs="+", default=[100.0, 500.0, 1000.0, 5000.0])
    ap.add_argument("--quantisation", type=float, default=QUANT, help="rad (default 1e-5)")
    args = ap.parse_args()
    robot = arm()
    print(
        f"{robot.n}-joint arm {robot.names}, {args.seconds:g} s multi-sine 0.1-2 Hz, 1 % torque noise, "
        f"quantisation {args.quantisation:g} rad; relative error % in motion (truth's on the same rows)"
    )
    head = f"{'rate':>6} {'processing':<20} {'fc/D/drop':<14} {'relative error % (truth)':<42} "
    print(head + f"{'base params |err| % med/max (n/rank)':<36} {'max z':>6} {'s':>5}")
    for fs in args.rates:
        logs = logs_at(robot, fs, args.seconds, args.quantisation)
        default = processing_defaults(logs.dt, logs.q)
        noise = default.noise_cutoff_hz
        print(f"-- {fs:g} Hz: " + "; ".join(default.reasons.values()) + f" (noise-limited cut-off {noise:.3g} Hz)")
        for label, given in variants(default):
            try:
                p = processing_defaults(logs.dt, logs.q, **given)
            except OptionError as e:
                print(f"{fs:>6g} {label:<20} refused: {e}")
                continue
            t0 = time.perf_counter()
            s = robot_study(logs, robot=robot, sdp=False, processing=RobotProcessing(**p.preprocessing))
            sec = time.perf_counter() - t0
            rel, floor, err, n, rank, z = scores(s)
            rels = ", ".join(f"{a:.2f} ({b:.2f})" for a, b in zip(rel, floor))
            setting = f"{p.cutoff_hz:g}/{p.decimate}/{p.drop}"
            errs = f"{np.median(err):.2f}/{np.max(err):.2f} ({n}/{rank})"
            print(f"{fs:>6g} {label:<20} {setting:<14} {rels:<42} {errs:<36} {np.max(z):>6.2f} {sec:>5.1f}")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
