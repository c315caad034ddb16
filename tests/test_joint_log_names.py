"""Joint logs as robots write them (issue 42, item 1): columns named after the URDF's joints, velocities, jittered
time stamps, and `jaxsdp robot` reading them (and bags) with no option."""

import json

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import ARM_URDF
from jaxsdp._cli import main
from jaxsdp.data import Drives, IrregularSamplingError, JointLogs, load_joint_logs, write_joint_logs
from jaxsdp.plants import SerialRobot
from jaxsdp.studies.robot._example import example_motion

NAMES = ("shoulder_pan", "elbow")
#: The tests' two-joint arm with named joints.
URDF = ARM_URDF.replace('"joint1"', '"shoulder_pan"').replace('"joint2"', '"elbow"')
#: A second branch below the base: not a serial chain unless --tip-link picks one.
BRANCH = """  <link name="l3"/>
  <joint name="camera_pan" type="revolute"><parent link="base"/><child link="l3"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" velocity="2" effort="100"/></joint>
</robot>
"""


def _write(path, header, columns, fmt="%.17g"):
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=",".join(header), comments="", fmt=fmt)
    return path


def _states(n=200, seed=0):
    rng = np.random.default_rng(seed)
    q = np.cumsum(rng.standard_normal((n, 2)), axis=0) * 1e-2
    return q, rng.standard_normal((n, 2)), rng.standard_normal((n, 2)) * 5.0  # q (rad), dq (rad/s), tau (N m)


def _jittered(n, dt, seed=1, amplitude=0.2):
    """Time stamps of a fixed period `dt`, each late or early by up to `amplitude` dt (uniform): steps within
    (1 +- 2 amplitude) dt."""
    return np.arange(n) * dt + amplitude * dt * np.random.default_rng(seed).uniform(-1.0, 1.0, n)


# ---------------------------------------------------------------------------------------------- the loader


def test_columns_named_after_the_joints_in_any_order(tmp_path):
    q, dq, tau = _states()
    t = np.arange(200) * 1e-3
    # other case and spaces, a velocity column per joint, two columns the robot does not know (one of them text)
    pos = tmp_path / "pos.csv"
    lines = [" ELBOW ,time,shoulder_pan,status,elbow_vel,dq_shoulder_pan,temperature"]
    cells = np.column_stack([q[:, 1], t, q[:, 0], dq[:, 1], dq[:, 0]])
    lines += [
        ",".join(f"{v:.17g}" for v in row[:3]) + ",ok," + ",".join(f"{v:.17g}" for v in row[3:]) + f",{20 + k}"
        for k, row in enumerate(cells)
    ]
    pos.write_text("\n".join(lines) + "\n")
    trq = _write(tmp_path / "tau.csv", ["elbow", "Joint_1"], [tau[:, 1], tau[:, 0]])  # Joint_<k> still accepted
    logs = load_joint_logs(pos, trq, names=NAMES, ratios=(2.0, -4.0))
    assert logs.joints == (1, 2) and logs.dt == pytest.approx(1e-3, rel=1e-12) and logs.resampled is None
    np.testing.assert_allclose(np.asarray(logs.q), q / [2.0, -4.0], rtol=1e-15)
    np.testing.assert_allclose(np.asarray(logs.dq), dq / [2.0, -4.0], rtol=1e-15)
    np.testing.assert_allclose(np.asarray(logs.tau), tau * [2.0, -4.0], rtol=1e-15)
    assert logs.notes == (
        "positions file pos.csv: ignored column(s) 'status', 'temperature' (neither time, one of "
        "the robot's joints nor a joint velocity)",
    )
    # joints selected by number, in model order
    two = load_joint_logs(pos, trq, names=NAMES, joints=(2,))
    np.testing.assert_array_equal(np.asarray(two.q[:, 0]), q[:, 1])
    np.testing.assert_array_equal(np.asarray(two.dq[:, 0]), dq[:, 1])


def test_a_name_matches_exactly_before_ignoring_case_and_before_joint_k(tmp_path):
    q, _, tau = _states(30)
    names = ("joint_2", "Joint_1", "wrist")  # a URDF whose names look like Joint_<k>, one of them in another case
    pos = _write(tmp_path / "p.csv", ["Joint_1", "joint_2", "WRIST"], [q[:, 0], q[:, 1], tau[:, 0]])
    logs = load_joint_logs(pos, pos, dt=1e-3, names=names)
    np.testing.assert_array_equal(np.asarray(logs.q), np.column_stack([q[:, 1], q[:, 0], tau[:, 0]]))


def test_missing_joint_and_unknown_column_messages(tmp_path):
    q, _, tau = _states(30)
    pos = _write(tmp_path / "p.csv", ["t", "shoulder_pan", "gripper"], [np.arange(30) * 1e-2, q[:, 0], q[:, 1]])
    trq = _write(tmp_path / "tau.csv", NAMES, [tau[:, 0], tau[:, 1]])
    missing = (
        r"positions file p.csv has no column for joint\(s\) 'elbow' of the robot's 2 \(shoulder_pan, elbow\); "
        r"columns found: 't', 'shoulder_pan', 'gripper'"
    )
    with pytest.raises(ValueError, match=missing):
        load_joint_logs(pos, trq, names=NAMES)
    # without the names, a column named after a joint is refused, the way to map it named
    with pytest.raises(ValueError, match=r"column 'shoulder_pan' is not named Joint_<k> .*\(`names`\)"):
        load_joint_logs(pos, trq)
    twice = _write(tmp_path / "twice.csv", ["elbow", "Elbow", "shoulder_pan"], [q[:, 0], q[:, 1], q[:, 1]])
    with pytest.raises(ValueError, match=r"twice.csv: joint\(s\) \[2\] appear in more than one column"):
        load_joint_logs(twice, trq, dt=1e-2, names=NAMES)
    for bad, message in (("elbow", "`names` must be None or"), ((), "`names` must be non-empty"), (("a", "a"), "once")):
        with pytest.raises(ValueError, match=message):
            load_joint_logs(trq, trq, dt=1e-2, names=bad)


def test_velocities_file_and_partial_velocity_columns(tmp_path):
    q, dq, tau = _states(50)
    pos = _write(tmp_path / "p.csv", NAMES, [q[:, 0], q[:, 1]])
    trq = _write(tmp_path / "tau.csv", NAMES, [tau[:, 0], tau[:, 1]])
    vel = _write(tmp_path / "v.csv", ["elbow", "shoulder_pan_velocity"], [dq[:, 1], dq[:, 0]])
    logs = load_joint_logs(pos, trq, dt=1e-3, names=NAMES, velocities=vel, ratios=(10.0, 20.0))
    np.testing.assert_allclose(np.asarray(logs.dq), dq / [10.0, 20.0], rtol=1e-15)
    assert logs.source == "p.csv + tau.csv + v.csv"
    assert load_joint_logs(pos, trq, dt=1e-3, names=NAMES).dq is None
    half = _write(tmp_path / "half.csv", [*NAMES, "elbow_vel"], [q[:, 0], q[:, 1], dq[:, 1]])
    with pytest.raises(ValueError, match=r"half.csv has velocity columns for joints \[2\] only: add \[1\]"):
        load_joint_logs(half, trq, dt=1e-3, names=NAMES)
    short = _write(tmp_path / "short.csv", NAMES, [dq[:40, 0], dq[:40, 1]])
    with pytest.raises(ValueError, match="p.csv has 50 rows but velocities file short.csv has 40"):
        load_joint_logs(pos, trq, dt=1e-3, names=NAMES, velocities=short)


def test_mat_variables_named_after_the_joints(tmp_path):
    import scipy.io

    q, dq, tau = _states(40)
    scipy.io.savemat(
        tmp_path / "p.mat",
        {
            "elbow": q[:, 1],
            "shoulder_pan": q[:, 0],
            "elbow_vel": dq[:, 1],
            "shoulder_pan_vel": dq[:, 0],
            "t": np.arange(40) * 1e-2,
            "info": 3.0,
        },
    )
    scipy.io.savemat(tmp_path / "tau.mat", {"Joint_2": tau[:, 1], "Joint_1": tau[:, 0]})
    logs = load_joint_logs(tmp_path / "p.mat", tmp_path / "tau.mat", names=NAMES)
    np.testing.assert_array_equal(np.asarray(logs.q), q)
    np.testing.assert_array_equal(np.asarray(logs.dq), dq)
    assert logs.dt == pytest.approx(1e-2) and logs.notes[0].endswith(
        "ignored column(s) 'info' (neither time, one of the robot's joints nor a joint velocity)"
    )


def test_jittered_stamps_are_resampled_and_gaps_refused(tmp_path):
    dt, n = 1e-2, 400  # 100 Hz
    stamps = _jittered(n, dt)
    exact = np.column_stack([np.sin(2 * np.pi * 0.5 * stamps), 0.1 * stamps])  # the second joint moves linearly
    pos = _write(tmp_path / "p.csv", ["time", *NAMES], [stamps, exact[:, 0], exact[:, 1]])
    trq = _write(tmp_path / "tau.csv", NAMES, [exact[:, 0], exact[:, 1]])
    logs = load_joint_logs(pos, trq, names=NAMES)  # the default: jitter
    assert logs.resampled.startswith(f"resampled {n} samples with jittered time stamps (steps up to ")
    jitter = np.max(np.abs(np.diff(stamps) - np.median(np.diff(stamps)))) / np.median(np.diff(stamps))
    assert f"{100 * jitter:.3g} % off the median step" in logs.resampled
    grid = np.asarray(logs.t)
    np.testing.assert_allclose(np.diff(grid), logs.dt, rtol=1e-9)
    assert float(grid[0]) == stamps[0] and logs.dt == pytest.approx(np.median(np.diff(stamps)), rel=1e-12)
    np.testing.assert_allclose(np.asarray(logs.q[:, 1]), 0.1 * grid, rtol=1e-12, atol=1e-15)  # linear: exact
    np.testing.assert_allclose(np.asarray(logs.q[:, 0]), np.sin(np.pi * grid), atol=3e-3)  # interpolation error
    with pytest.raises(IrregularSamplingError, match="is not uniformly sampled"):
        load_joint_logs(pos, trq, names=NAMES, irregular="error")
    # a gap (a missing sample) is not jitter
    gap = np.delete(np.column_stack([stamps, exact]), 200, axis=0)
    pos2 = _write(tmp_path / "gap.csv", ["time", *NAMES], [gap[:, 0], gap[:, 1], gap[:, 2]])
    trq2 = _write(tmp_path / "gap_tau.csv", NAMES, [gap[:, 1], gap[:, 2]])
    with pytest.raises(IrregularSamplingError, match=r"has a gap: sample 200 \(0-based, .* x the median step") as e:
        load_joint_logs(pos2, trq2, names=NAMES)
    assert e.value.index == 200 and e.value.count == 1
    assert load_joint_logs(pos2, trq2, names=NAMES, irregular="resample").resampled.startswith("resampled 399 irreg")
    # a stamp that does not increase cannot be resampled
    back = stamps.copy()
    back[100] = back[99]
    pos3 = _write(tmp_path / "back.csv", ["time", *NAMES], [back, exact[:, 0], exact[:, 1]])
    for mode in ("jitter", "resample"):
        with pytest.raises(ValueError, match=r"must be strictly increasing \(t\[100\]"):
            load_joint_logs(pos3, trq, names=NAMES, irregular=mode)


def test_drives_convert_velocities_without_offsets():
    rng = np.random.default_rng(4)
    q, dq, tau = (rng.standard_normal((20, 6)) for _ in range(3))
    logs = JointLogs(
        q=jnp.asarray(q),
        tau=jnp.asarray(tau),
        t=jnp.arange(20) * 1e-3,
        dt=1e-3,
        joints=tuple(range(1, 7)),
        source="s",
        converted="none",
        dq=jnp.asarray(dq),
        notes=("a note",),
    )
    drives = Drives.builtin("tx40")
    out = drives.convert(logs)
    # the velocity of the model's angles: d/dt joint_positions(pos) = its linear part applied to dpos
    eps = 1e-6
    numeric = (drives.joint_positions(q + eps * dq) - drives.joint_positions(q - eps * dq)) / (2 * eps)
    np.testing.assert_allclose(np.asarray(out.dq), numeric, rtol=1e-7, atol=1e-9)
    assert out.notes == ("a note",)
    plain = JointLogs(q=logs.q, tau=logs.tau, t=logs.t, dt=1e-3, joints=logs.joints, source="s", converted="c")
    assert plain.dq is None and plain.notes == () and drives.convert(plain).dq is None
    with pytest.raises(ValueError, match=r"`dq` must have the shape of `q` \(20, 6\); got \(20, 5\)"):
        JointLogs(
            q=logs.q, tau=logs.tau, t=logs.t, dt=1e-3, joints=logs.joints, source="s", converted="c", dq=logs.dq[:, :5]
        )


# ---------------------------------------------------------------------------------------------- the command


def _arm(tmp_path, *, fs=500.0, seconds=12.0, jitter=0.0):
    """The two-link arm's URDF and joint-side logs with the URDF's joint names, stamps jittered by `jitter` dt."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(URDF)
    arm = SerialRobot.from_urdf(urdf)
    arm = eqx.tree_at(lambda r: (r.Ia, r.Fv, r.Fc), arm, (jnp.full(2, 0.1), jnp.array([2.0, 1.0]), jnp.ones(2)))
    dt = 1.0 / fs
    stamps = _jittered(int(seconds * fs), dt, amplitude=jitter) if jitter else np.arange(int(seconds * fs)) * dt
    q, dq, ddq = example_motion(stamps)
    tau = np.asarray(arm.drive_torques(q, dq, ddq)) + 0.2 * np.random.default_rng(0).standard_normal(q.shape)
    header = ["time", "elbow", "shoulder_pan", "elbow_vel", "shoulder_pan_vel", "status"]
    pos = _write(tmp_path / "q.csv", header, [stamps, q[:, 1], q[:, 0], dq[:, 1], dq[:, 0], 0 * stamps])
    trq = _write(tmp_path / "tau.csv", ["shoulder_pan", "elbow"], [tau[:, 0], tau[:, 1]])
    return urdf, pos, trq, (stamps, q, dq, tau)


def test_cli_reads_urdf_named_jittered_logs_with_no_option(tmp_path, capsys):
    urdf, pos, trq, _ = _arm(tmp_path, seconds=6.0, jitter=0.2)
    out = tmp_path / "out"
    argv = ["robot", "--urdf", str(urdf), "--positions", str(pos), "--torques", str(trq), "--no-sdp", "--out", str(out)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "note: resampled 3000 samples with jittered time stamps" in err
    assert "note: positions file q.csv: ignored column(s) 'status' (neither time, one of the robot's joints nor" in err
    s = json.loads((out / "summary.json").read_text())
    assert list(s["joints"]) == list(NAMES) and s["data"]["resampled"].startswith("resampled 3000 samples")
    assert all(j["relative_error"] < 10 for j in s["joints"].values()), s["joints"]


def test_cli_gap_names_resample_and_options_are_checked(tmp_path, capsys):
    urdf, pos, trq, (stamps, q, dq, tau) = _arm(tmp_path, fs=200.0, seconds=2.0)
    lines = pos.read_text().splitlines()
    del lines[100]  # a missing sample
    pos.write_text("\n".join(lines) + "\n")
    trq.write_text("\n".join(trq.read_text().splitlines()[:100] + trq.read_text().splitlines()[101:]) + "\n")
    base = ["robot", "--urdf", str(urdf), "--out", str(tmp_path / "o"), "--quiet"]
    assert main([*base, "--positions", str(pos), "--torques", str(trq)]) == 1
    err = capsys.readouterr().err
    assert "has a gap: sample 99" in err and "pass --resample" in err and "irregular=" not in err
    usage = {
        "--bag and --positions": ([*base, "--bag", str(pos), "--positions", str(pos)], "--bag holds the logs"),
        "--topic without --bag": ([*base, "--positions", str(pos), "--torques", str(trq), "--topic", "/js"], "--topic"),
        "--bag with --dt": ([*base, "--bag", str(pos), "--dt", "0.01"], "drop --dt"),
        "no logs": ([*base, "--velocities", str(pos)], "--positions and --torques required, or --bag FILE"),
        "--excite with --bag": (["robot", "--urdf", str(urdf), "--excite", "--bag", str(pos)], "drop --bag"),
    }
    for case, (argv, fragment) in usage.items():
        assert main(argv) == 2, case
        assert fragment in capsys.readouterr().err, case
    assert main([*base, "--bag", str(tmp_path / "nowhere")]) == 1
    assert "--bag " + str(tmp_path / "nowhere") + ": no such file or folder" in capsys.readouterr().err


def test_cli_not_a_chain_names_tip_link_not_python_arguments(tmp_path, capsys):
    urdf = tmp_path / "branch.urdf"
    urdf.write_text(URDF.replace("</robot>\n", BRANCH))
    assert main(["robot", "--urdf", str(urdf), "--excite", "--out", str(tmp_path / "o"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "pass --tip-link 'base' (the chain up to where the branches part" in err and "--tip-link 'l2'" in err, err
    assert "joints=" not in err and "tip_link" not in err
    assert main(["robot", "--urdf", str(urdf), "--excite", "--tip-link", "nolink", "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert "--tip-link 'nolink' is not a link" in err and "tip_link" not in err


def test_writer_names_the_columns_and_writes_the_stamps(tmp_path):
    q, _, tau = _states(60)
    stamps = _jittered(60, 1e-2)
    for suffix in (".csv", ".mat"):
        pos, trq = tmp_path / f"p{suffix}", tmp_path / f"t{suffix}"
        write_joint_logs(pos, trq, q, tau, names=NAMES, t=stamps, ratios=(2.0, 3.0))
        if suffix == ".csv":
            assert pos.read_text().splitlines()[0] == "time,shoulder_pan,elbow"
        logs = load_joint_logs(pos, trq, names=NAMES, ratios=(2.0, 3.0), irregular="resample")
        assert logs.resampled.startswith("resampled 60 irregular samples")  # irregular="resample": gaps too
        same = load_joint_logs(pos, trq, names=NAMES, ratios=(2.0, 3.0))
        assert same.resampled.startswith("resampled 60 samples with jittered time stamps"), suffix
        np.testing.assert_allclose(np.asarray(same.t)[[0, -1]], [stamps[0], stamps[0] + 59 * same.dt], rtol=1e-15)
    with pytest.raises(ValueError, match=r"`names` has 3 entries but `q` and `tau` have 2"):
        write_joint_logs(pos, trq, q, tau, names=(*NAMES, "wrist"))
    with pytest.raises(ValueError, match=r"`t` must be 60 finite time stamps"):
        write_joint_logs(pos, trq, q, tau, t=stamps[:50])
