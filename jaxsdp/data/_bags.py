"""Joint logs from ROS bags: the `sensor_msgs/msg/JointState` messages of one topic, read without ROS.

A JointState message holds, per joint listed in its `name` field, a
`position` (rad, or m for a prismatic joint), a `velocity` (rad/s or m/s)
and an `effort` (N m or N), all joint side, and a `header.stamp`.
`load_joint_bag` reads them from a ROS 2 bag (a folder with
`metadata.yaml`, or its `.db3` (sqlite3) or `.mcap` file) or a ROS 1 `.bag`
file with the pure-Python `rosbags` package, and returns the same
`JointLogs` as `load_joint_logs` would from the equivalent CSV files:

    q[k, j] = position_j,   dq[k, j] = velocity_j,   tau[k, j] = effort_j   (message k)
    t_k = stamp_k - stamp_0   (s; the bag's receive time when every stamp is zero)

The columns follow the robot's joint order when `names` is given (each
message name mapped to a joint as a CSV header is), else the messages'.
"""

import os
import pathlib
from typing import Literal

import jax.numpy as jnp
import numpy as np

from .._records import JointLogs
from .._runtime import x64
from ._joint_logs import MIN_ROWS
from ._loaders import JOINT_IRREGULAR, MAX_JITTER, check_names, check_sampling_options, joint_of, uniform_sampling
from ._log_tables import MissingJointsError

#: The message type read (as `rosbags` names it for ROS 1 and ROS 2 alike).
JOINT_STATE = "sensor_msgs/msg/JointState"
_ROS2_FILES = (".db3", ".mcap")


def _bag_path(path) -> pathlib.Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"`path` must be a str or os.PathLike; got {type(path).__name__}")
    path = pathlib.Path(path)
    if not path.exists():
        raise FileNotFoundError(f"`path`: no such file or folder: {path}")
    ros2_folder = path.is_dir() and (path / "metadata.yaml").is_file()
    if not (ros2_folder or (path.is_file() and path.suffix.lower() in (".bag", *_ROS2_FILES))):
        raise ValueError(
            f"`path`: {path} is not a ROS bag: give a ROS 1 .bag file, a ROS 2 bag folder (with metadata.yaml) "
            "or its .db3 or .mcap file"
        )
    return path


def _topic(label: str, reader, topic) -> str:
    """The JointState topic to read: `topic` (with or without its leading slash), or the only one."""
    found = sorted(name for name, info in reader.topics.items() if info.msgtype == JOINT_STATE)
    listed = ", ".join(found) or "none"
    if topic is None:
        if len(found) == 1:
            return found[0]
        others = ", ".join(f"{k} ({v.msgtype})" for k, v in sorted(reader.topics.items())) or "none"
        what = "no" if not found else f"{len(found)}"
        raise ValueError(
            f"{label} has {what} {JOINT_STATE} topics ({listed}; all topics: {others}): "
            + ("name the one to read (`topic`)" if found else "it holds no joint states")
        )
    for name in (topic, "/" + topic.lstrip("/")):
        if name in found:
            return name
    raise ValueError(f"{label} has no {JOINT_STATE} topic {topic!r}; its {JOINT_STATE} topics: {listed}")


def _read(label: str, reader, topic: str):
    """Stamps (ns), receive times (ns), joint names and the position, velocity and effort rows of every message."""
    connections = [c for c in reader.connections if c.topic == topic]
    stamps, received, rows = [], [], {"position": [], "velocity": [], "effort": []}
    first = None
    for k, (connection, time, raw) in enumerate(reader.messages(connections=connections)):
        msg = reader.deserialize(raw, connection.msgtype)
        names = tuple(msg.name)
        if first is None:
            first = names
            if len(set(names)) != len(names):
                raise ValueError(f"{label}, message 0: joint names {list(names)} name a joint more than once")
        elif names != first:
            raise ValueError(
                f"{label}: message {k} (0-based) lists the joints {list(names)}, message 0 {list(first)}: every "
                "message must list the same joints in the same order"
            )
        for field, out in rows.items():
            values = np.asarray(getattr(msg, field), dtype=np.float64)
            if values.size not in (0, len(names)):
                raise ValueError(f"{label}: message {k} has {values.size} {field} values for {len(names)} joints")
            if out and (values.size == 0) != (out[0].size == 0):
                raise ValueError(
                    f"{label}: message {k} has {'no' if values.size == 0 else len(names)} {field} values, "
                    f"message 0 {out[0].size}: every message must hold them or none"
                )
            out.append(values)
        stamps.append(int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec))
        received.append(int(time))
    return np.array(stamps, dtype=np.int64), np.array(received, dtype=np.int64), first or (), rows


@x64
def load_joint_bag(
    path: str | os.PathLike,
    *,
    topic: str | None = None,
    names=None,
    irregular: Literal["jitter", "error", "resample"] = "jitter",
    max_jitter: float = MAX_JITTER,
) -> JointLogs:
    """Read the joint states of a ROS 1 or ROS 2 bag as joint logs (positions, velocities, efforts).

    Message k gives row k: `q = position`, `dq = velocity` (None when every
    message's velocity is empty), `tau = effort` (N m, or N for a prismatic
    joint), at `t_k = stamp_k - stamp_0` (s) from `header.stamp` (the bag's
    receive time when every stamp is zero, with a note), checked and
    resampled as `load_joint_logs` does its time column.

    **Arguments:**

    - `path`: a ROS 1 `.bag` file, a ROS 2 bag folder (with `metadata.yaml`),
      or a ROS 2 `.db3` (sqlite3) or `.mcap` file.
    - `topic`: the `sensor_msgs/msg/JointState` topic to read (the leading
      slash may be left out); `None`: the bag's only one.
    - `names`: the robot's joint names in model order (`SerialRobot.names`):
      the columns follow them, each message name matched as a CSV header is
      (`Joint_<k>` too); other names (a gripper's) are ignored with a note.
      `None`: the columns follow the messages' `name` field.
    - `irregular`, `max_jitter`: as for `load_joint_logs` (default
      `"jitter"`: stamps within 0.5 to 1.5 times the median step are
      interpolated onto a uniform grid, gaps refused).

    **Returns:** a `JointLogs` (joints 1..n, `source` "bag-name topic",
    the time base, the topic and ignored joints in `notes`).

    **Raises:** `FileNotFoundError` for a missing path; `ValueError` for a
    path that is not a bag or cannot be read, no JointState topic (or
    several, with `topic=None`, or not the one named: the ones found are
    listed), messages whose `name` lists differ from the first (the first
    such message named), arrays of the wrong length, no effort values, a
    joint of `names` no message lists, fewer than 10 messages, or invalid
    options; `IrregularSamplingError` (a `ValueError`) as `irregular` says.

    Example:
        >>> import os, tempfile
        >>> import numpy as np
        >>> from rosbags.rosbag2 import Writer
        >>> from rosbags.typesys import Stores, get_typestore
        >>> from jaxsdp.data import load_joint_bag
        >>> store = get_typestore(Stores.ROS2_HUMBLE)
        >>> JointState, Header = store.types["sensor_msgs/msg/JointState"], store.types["std_msgs/msg/Header"]
        >>> Time = store.types["builtin_interfaces/msg/Time"]
        >>> bag = os.path.join(tempfile.mkdtemp(), "run1")
        >>> with Writer(bag, version=9) as writer:
        ...     topic = writer.add_connection("/joint_states", JointState.__msgtype__, typestore=store)
        ...     for k in range(20):  # 100 Hz
        ...         stamp = 10**9 + k * 10**7  # ns
        ...         msg = JointState(header=Header(stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=""),
        ...                          name=["elbow", "shoulder"], position=np.array([0.01 * k, 0.0]),
        ...                          velocity=np.array([1.0, 0.0]), effort=np.array([2.0, 3.0]))
        ...         writer.write(topic, stamp, store.serialize_cdr(msg, JointState.__msgtype__))
        >>> logs = load_joint_bag(bag, names=("shoulder", "elbow"))
        >>> logs.q.shape, logs.fs, [float(v) for v in logs.tau[0]], [float(v) for v in logs.dq[0]]
        ((20, 2), 100.0, [3.0, 2.0], [0.0, 1.0])
    """
    max_jitter = check_sampling_options(max_jitter, irregular, JOINT_IRREGULAR)
    names = check_names(names)
    if topic is not None and (not isinstance(topic, str) or not topic.strip("/ ")):
        raise ValueError(f"`topic` must be None or a topic name such as '/joint_states'; got {topic!r}")
    path = _bag_path(path)
    label = f"bag {path.name}"
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:  # a dependency of jaxsdp: only a broken installation lacks it
        raise ValueError("reading ROS bags needs the `rosbags` package: pip install rosbags") from None
    ros1 = path.suffix.lower() == ".bag"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)  # for bags without definitions
    try:
        with AnyReader([path], default_typestore=store) as reader:
            topic = _topic(label, reader, topic)
            label = f"{label}, topic {topic}"
            stamps, received, found, rows = _read(label, reader, topic)
    except (ValueError, FileNotFoundError):
        raise
    except Exception as e:  # rosbags raises its own types for a damaged or foreign file
        raise ValueError(f"{label}: could not read it as a ROS bag ({type(e).__name__}: {e})") from None
    if len(stamps) < MIN_ROWS:
        raise ValueError(f"{label} has {len(stamps)} message(s); at least {MIN_ROWS} are needed")
    if not rows["effort"][0].size:
        raise ValueError(f"{label}: the messages hold no effort values (empty `effort`): the torques are needed")
    if not rows["position"][0].size:
        raise ValueError(f"{label}: the messages hold no position values (empty `position`)")
    notes = []
    if names is None:
        order = list(range(len(found)))
        notes.append(f"{label}: joints 1..{len(found)} are {', '.join(found)} (the messages' order)")
    else:
        number = {i: joint_of(name, names) for i, name in enumerate(found)}
        missing = [name for k, name in enumerate(names, start=1) if k not in number.values()]
        if missing:
            raise MissingJointsError(
                f"{label}: no joint state for joint(s) {', '.join(map(repr, missing))} of the robot's {len(names)} "
                f"({', '.join(names)}); the messages list {', '.join(map(repr, found))}",
                missing,
            )
        twice = sorted({k for k in number.values() if k is not None and list(number.values()).count(k) > 1})
        if twice:
            both = [[found[i] for i, k in number.items() if k == j] for j in twice]
            raise ValueError(f"{label}: joint(s) {[names[j - 1] for j in twice]} named more than once ({both})")
        order = [next(i for i, k in number.items() if k == j) for j in range(1, len(names) + 1)]
        extra = [found[i] for i, k in number.items() if k is None]
        if extra:
            notes.append(f"{label}: ignored joint(s) {', '.join(map(repr, extra))} (not joints of the robot)")
    base = stamps
    if not stamps.any():
        base = received
        notes.append(f"{label}: every header.stamp is zero; time is the bag's receive time")
    t = (base - base[0]) * 1e-9
    what = "receive time" if base is received else "header.stamp"
    notes.insert(0, f"{label}: {len(t)} messages, t = 0 at the first message's {what} ({base[0] * 1e-9:.9f} s)")
    columns = {"t": t}
    for field, out in rows.items():
        if out[0].size:
            values = np.stack(out)[:, order]
            columns |= {f"{field}{i}": values[:, i] for i in range(len(order))}
    columns, dt, resampled = uniform_sampling(label, columns, "t", max_jitter, irregular, 1e-9)
    stacked = {
        field: np.stack([columns[f"{field}{i}"] for i in range(len(order))], axis=1)
        for field in rows
        if f"{field}0" in columns
    }
    n = stacked["position"].shape[0]
    return JointLogs(
        q=jnp.asarray(stacked["position"]),
        tau=jnp.asarray(stacked["effort"]),
        t=float(columns["t"][0]) + jnp.arange(n, dtype=jnp.float64) * dt,
        dt=dt,
        joints=tuple(range(1, len(order) + 1)),
        source=f"{path.name} {topic}",
        converted="none: JointState is joint side (position rad or m, velocity rad/s or m/s, effort N m or N)",
        resampled=resampled,
        dq=jnp.asarray(stacked["velocity"]) if "velocity" in stacked else None,
        notes=tuple(notes),
    )
