"""ROS bags of joint states (issue 42, item 1): `load_joint_bag` on ROS 2 (sqlite3, MCAP) and ROS 1 bags written
here with `rosbags`' own writers from known arrays, and `jaxsdp robot --bag`."""

import json

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore

from jaxsdp._cli import main
from jaxsdp.data import IrregularSamplingError, load_joint_bag, load_joint_logs

JOINT_STATE = "sensor_msgs/msg/JointState"
NAMES = ("shoulder_pan", "elbow")
FORMATS = ("sqlite3", "mcap", "ros1")
T0 = 1_700_000_000 * 10**9  # ns: an epoch stamp, as a robot writes it


def _store(fmt):
    return get_typestore(Stores.ROS1_NOETIC if fmt == "ros1" else Stores.ROS2_HUMBLE)


def _message(store, stamp, names, position, velocity, effort, seq):
    types = store.types
    header = dict(stamp=types["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id="")
    if "seq" in types["std_msgs/msg/Header"].__dataclass_fields__:  # ROS 1
        header["seq"] = seq
    return types[JOINT_STATE](
        header=types["std_msgs/msg/Header"](**header),
        name=list(names),
        position=np.asarray(position, dtype=np.float64),
        velocity=np.asarray(velocity, dtype=np.float64),
        effort=np.asarray(effort, dtype=np.float64),
    )


def write_bag(path, fmt, topics, *, received=None):
    """Write a bag: `topics` maps a topic to (stamps ns, names or a list of names per message, position, velocity,
    effort), rows per message (an empty (N, 0) array: empty fields); `received`: the receive times (ns)."""
    store = _store(fmt)
    if fmt == "ros1":
        writer = Ros1Writer(path.with_suffix(".bag"))
        serialize = store.serialize_ros1
    else:
        plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
        writer = Ros2Writer(path, version=9, storage_plugin=plugin)
        serialize = store.serialize_cdr
    with writer:
        for topic, (stamps, names, position, velocity, effort) in topics.items():
            if topic == "/chatter":
                connection = writer.add_connection(topic, "std_msgs/msg/String", typestore=store)
                for k, stamp in enumerate(stamps):
                    text = store.types["std_msgs/msg/String"](data=f"hello {k}")
                    writer.write(connection, int(stamp), serialize(text, "std_msgs/msg/String"))
                continue
            connection = writer.add_connection(topic, JOINT_STATE, typestore=store)
            for k, stamp in enumerate(stamps):
                listed = names[k] if isinstance(names[0], (list, tuple)) else names
                msg = _message(store, int(stamp), listed, position[k], velocity[k], effort[k], k)
                time = int(stamp) if received is None else int(received[k])
                writer.write(connection, time, serialize(msg, JOINT_STATE))
    return path.with_suffix(".bag") if fmt == "ros1" else path


def _data(n=300, dt_ns=10_000_000, jitter=0.0, seed=0):
    """Stamps (ns) at 100 Hz (each off by up to `jitter` of the period) and three joints' states in the order
    elbow, gripper, shoulder_pan."""
    rng = np.random.default_rng(seed)
    stamps = T0 + np.arange(n) * dt_ns + np.round(jitter * dt_ns * rng.uniform(-1, 1, n)).astype(np.int64)
    q, dq, tau = (rng.standard_normal((n, 3)) for _ in range(3))
    return stamps, ["elbow", "gripper", "shoulder_pan"], q, dq, tau


@pytest.mark.parametrize("fmt", FORMATS)
def test_bags_read_back_the_arrays_written(tmp_path, fmt):
    stamps, order, q, dq, tau = _data()
    bag = write_bag(tmp_path / "run1", fmt, {"/joint_states": (stamps, order, q, dq, tau)})
    logs = load_joint_bag(bag, names=NAMES)  # model order: shoulder_pan (column 2), elbow (column 0)
    assert logs.joints == (1, 2) and logs.resampled is None and logs.dt == pytest.approx(0.01, rel=1e-12)
    for got, want in ((logs.q, q), (logs.dq, dq), (logs.tau, tau)):
        np.testing.assert_allclose(np.asarray(got), want[:, [2, 0]], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.asarray(logs.t), np.arange(300) * 0.01, rtol=0, atol=1e-12)
    assert logs.source == f"{bag.name} /joint_states"
    assert logs.notes[0].endswith("300 messages, t = 0 at the first message's header.stamp (1700000000.000000000 s)")
    assert logs.notes[1].endswith("ignored joint(s) 'gripper' (not joints of the robot)")
    # without names: the messages' order, said in a note
    plain = load_joint_bag(bag, topic="joint_states")  # the leading slash may be left out
    np.testing.assert_allclose(np.asarray(plain.q), q, rtol=1e-12, atol=1e-12)
    assert "joints 1..3 are elbow, gripper, shoulder_pan (the messages' order)" in plain.notes[1]


def test_a_ros2_storage_file_reads_as_its_folder(tmp_path):
    stamps, order, q, dq, tau = _data(50)
    bag = write_bag(tmp_path / "run2", "sqlite3", {"/joint_states": (stamps, order, q, dq, tau)})
    (db3,) = bag.glob("*.db3")
    np.testing.assert_array_equal(np.asarray(load_joint_bag(db3).tau), np.asarray(load_joint_bag(bag).tau))


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_a_bag_and_the_equivalent_csv_pair_give_the_same_logs(tmp_path, fmt):
    stamps, order, q, dq, tau = _data(400, jitter=0.2, seed=3)  # jittered stamps: both resample alike
    bag = write_bag(tmp_path / "run", fmt, {"/joint_states": (stamps, order, q, dq, tau)})
    t = (stamps - stamps[0]) * 1e-9
    head = "time,elbow,gripper,shoulder_pan"
    for name, values in (("q", q), ("tau", tau), ("dq", dq)):
        np.savetxt(
            tmp_path / f"{name}.csv", np.column_stack([t, values]), delimiter=",", header=head, comments="", fmt="%.17g"
        )
    files = load_joint_logs(tmp_path / "q.csv", tmp_path / "tau.csv", velocities=tmp_path / "dq.csv", names=NAMES)
    logs = load_joint_bag(bag, names=NAMES)
    assert logs.resampled == files.resampled and logs.resampled.startswith("resampled 400 samples with jittered")
    assert logs.dt == files.dt
    for field in ("t", "q", "dq", "tau"):
        np.testing.assert_allclose(
            np.asarray(getattr(logs, field)), np.asarray(getattr(files, field)), rtol=1e-12, atol=1e-12
        )


def test_topic_choice(tmp_path):
    stamps, order, q, dq, tau = _data(20)
    topics = {
        "/arm/joint_states": (stamps, order, q, dq, tau),
        "/hand/joint_states": (stamps, order, q, dq, 2 * tau),
        "/chatter": (stamps, None, None, None, None),
    }
    bag = write_bag(tmp_path / "two", "mcap", topics)
    listed = r"/arm/joint_states, /hand/joint_states"
    with pytest.raises(
        ValueError,
        match=rf"bag two has 2 sensor_msgs/msg/JointState topics \({listed}; all topics: "
        r".*/chatter \(std_msgs/msg/String\).*name the one to read \(`topic`\)",
    ):
        load_joint_bag(bag)
    hand = load_joint_bag(bag, topic="/hand/joint_states")
    np.testing.assert_allclose(np.asarray(hand.tau), 2 * tau, rtol=1e-12)
    with pytest.raises(ValueError, match=rf"no sensor_msgs/msg/JointState topic '/nope'; .* topics: {listed}"):
        load_joint_bag(bag, topic="/nope")
    chatter = write_bag(tmp_path / "chat", "ros1", {"/chatter": (stamps, None, None, None, None)})
    with pytest.raises(ValueError, match=r"has no sensor_msgs/msg/JointState topics \(none; .*it holds no joint"):
        load_joint_bag(chatter)


def test_message_contents_are_checked(tmp_path):
    stamps, order, q, dq, tau = _data(30)
    renamed = [order] * 30
    renamed[17] = ["elbow", "shoulder_pan", "gripper"]
    bag = write_bag(tmp_path / "renamed", "sqlite3", {"/js": (stamps, renamed, q, dq, tau)})
    with pytest.raises(ValueError, match=r"topic /js: message 17 \(0-based\) lists the joints \['elbow', 'shoulder"):
        load_joint_bag(bag)
    none = np.empty((30, 0))
    no_velocity = load_joint_bag(write_bag(tmp_path / "nov", "sqlite3", {"/js": (stamps, order, q, none, tau)}))
    assert no_velocity.dq is None
    with pytest.raises(ValueError, match=r"messages hold no effort values \(empty `effort`\): the torques are needed"):
        load_joint_bag(write_bag(tmp_path / "noe", "ros1", {"/js": (stamps, order, q, dq, none)}))
    some = [v if k != 5 else [] for k, v in enumerate(dq)]
    with pytest.raises(ValueError, match=r"message 5 has no velocity values, message 0 3: every message must hold"):
        load_joint_bag(write_bag(tmp_path / "some", "mcap", {"/js": (stamps, order, q, some, tau)}))
    with pytest.raises(
        ValueError, match=r"no joint state for joint\(s\) 'wrist' of the robot's 3 \(.*\); the messages"
    ):
        load_joint_bag(bag.with_name("nov"), names=(*NAMES, "wrist"))
    with pytest.raises(ValueError, match=r"has 9 message\(s\); at least 10"):
        load_joint_bag(write_bag(tmp_path / "few", "mcap", {"/js": (stamps[:9], order, q, dq, tau)}))


def test_zero_stamps_fall_back_to_the_receive_time_and_gaps_are_refused(tmp_path):
    stamps, order, q, dq, tau = _data(40)
    bag = write_bag(tmp_path / "zero", "ros1", {"/js": (0 * stamps, order, q, dq, tau)}, received=stamps)
    logs = load_joint_bag(bag)
    assert logs.dt == pytest.approx(0.01, rel=1e-12)
    assert any("every header.stamp is zero; time is the bag's receive time" in note for note in logs.notes)
    gap = np.delete(np.arange(41), 20)
    bag = write_bag(tmp_path / "gap", "mcap", {"/js": (T0 + gap * 10**7, order, q, dq, tau)})
    with pytest.raises(IrregularSamplingError, match=r"bag gap, topic /js: time `t` has a gap: sample 20"):
        load_joint_bag(bag)
    assert load_joint_bag(bag, irregular="resample").q.shape == (41, 3)


def test_invalid_paths_and_options(tmp_path):
    (tmp_path / "notes.txt").write_text("not a bag")
    (tmp_path / "broken.bag").write_bytes(b"#ROSBAG V2.0\n garbage")
    cases = [
        (tmp_path / "notes.txt", {}, ValueError, "is not a ROS bag: give a ROS 1 .bag file, a ROS 2 bag folder"),
        (tmp_path, {}, ValueError, "is not a ROS bag"),
        (tmp_path / "nowhere.mcap", {}, FileNotFoundError, "no such file or folder"),
        (tmp_path / "broken.bag", {}, ValueError, "bag broken.bag: could not read it as a ROS bag"),
        (tmp_path / "broken.bag", {"topic": ""}, ValueError, "`topic` must be None or a topic name"),
        (tmp_path / "broken.bag", {"irregular": "fix"}, ValueError, "`irregular` must be one of"),
    ]
    for path, options, error, message in cases:
        with pytest.raises(error, match=message):
            load_joint_bag(path, **options)


def test_cli_bag_gives_the_summary_of_the_csv_logs(tmp_path, capsys):
    """The two-link arm of tests/test_joint_log_names.py, at 500 Hz with jittered stamps: the CSV pair written with the
    URDF's joint names and a ROS 2 bag of the same data give the same summary."""
    from test_joint_log_names import _arm

    urdf, pos, trq, (stamps, q, dq, tau) = _arm(tmp_path, seconds=6.0, jitter=0.2)
    ns = np.round(stamps * 1e9).astype(np.int64) + T0
    np.savetxt(
        pos,
        np.column_stack([(ns - ns[0]) * 1e-9, q]),
        delimiter=",",
        header="time,shoulder_pan,elbow",
        comments="",
        fmt="%.17g",
    )
    bag = write_bag(tmp_path / "arm", "mcap", {"/joint_states": (ns, list(NAMES), q, dq, tau)})
    summaries = []
    for logs in (["--positions", str(pos), "--torques", str(trq)], ["--bag", str(bag)]):
        out = tmp_path / logs[0].strip("-")
        assert main(["robot", "--urdf", str(urdf), *logs, "--no-sdp", "--quiet", "--out", str(out)]) == 0
        summaries.append(json.loads((out / "summary.json").read_text()))
    csv, ros = summaries
    for name in NAMES:
        assert ros["joints"][name]["relative_error"] == pytest.approx(csv["joints"][name]["relative_error"], rel=1e-9)
    np.testing.assert_allclose(
        [p["value"] for p in ros["base_parameters"]],
        [p["value"] for p in csv["base_parameters"]],
        rtol=1e-8,
        atol=1e-10,
    )
    assert ros["data"]["resampled"] == csv["data"]["resampled"]
