"""Joint logs of a multi-joint robot: a positions file and a torques (or currents) file, one column per joint.

**Format.** The public Stäubli TX40 identification logs are two CSV files with
one header line `Joint_1,Joint_2,...,Joint_6` and one row per sample (5 kHz,
about 45,000 rows): motor-side angles (rad) and motor torques (N m). Other
logs give motor currents (A) instead of torques. `load_joint_logs` reads a
pair of such files (CSV with or without the header line, or MATLAB .mat) and
converts them to the joint side with one gear ratio `N_j` (motor / joint) and
optionally one torque constant `Kt_j` (N m/A) per joint:

    q_j = pos_j / N_j,    tau_j = N_j * value_j    (values are torques)
                          tau_j = N_j * Kt_j * value_j    (values are currents)

Logs as other robots write them name their columns after the robot's
joints (`names=`, e.g. `SerialRobot.names` of its URDF; any order, other
columns ignored with a note), may hold velocity columns (or a velocities
file), and stamp samples with jitter (interpolated onto a uniform grid by
default, gaps refused); `jaxsdp.data.load_joint_bag` reads ROS bags into the
same record. `write_joint_logs` is the inverse. The conversion is diagonal: the TX40's
wrist coupling (motor 6 turning with joint 5) and its joint-angle offsets
are a model matter, applied by the caller (see the reference notes on the
TX40).
"""

import os
import pathlib
from typing import Literal

import jax.numpy as jnp
import numpy as np

from .._checks import OptionError, positive_float
from .._records import JointLogs
from .._runtime import x64
from ._loaders import JOINT_IRREGULAR, MAX_JITTER, check_names, check_sampling_options
from ._log_tables import check_unique, csv_split, csv_table, finite_mat, mat_table, require_joints, time_axis

#: The least number of samples a joint log must hold.
MIN_ROWS = 10


def _check_file(name: str, path) -> pathlib.Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"`{name}` must be a str or os.PathLike; got {type(path).__name__}")
    path = pathlib.Path(path)
    if not path.exists():
        raise FileNotFoundError(f"`{name}`: no such file: {path}")
    if not path.is_file():
        raise ValueError(f"`{name}`: not a regular file: {path}")
    if path.stat().st_size == 0:
        raise ValueError(f"{name} file {path.name} is empty")
    return path


def _per_joint(name: str, values, *, currents: bool) -> np.ndarray | None:
    """Gear ratios (finite, non-zero) or torque constants (finite, positive), one per joint column; or None."""
    if values is None:
        return None
    what = "torque constants (N m/A)" if currents else "gear ratios (motor / joint)"
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if isinstance(values, (str, bytes)) or arr is None or arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"`{name}` must be a sequence of {what}, one per joint column of the files; got {values!r}")
    bad = ~np.isfinite(arr) | ((arr <= 0) if currents else (arr == 0))
    if bad.any():
        i = int(np.argmax(bad))
        rule = "finite and positive" if currents else "finite and non-zero (a negative ratio reverses the joint)"
        raise ValueError(f"`{name}`: entry {i} ({arr[i]:g}) must be {rule}")
    return arr


def _check_joints(joints) -> tuple[int, ...] | None:
    if joints is None:
        return None
    if isinstance(joints, (str, bytes)) or not hasattr(joints, "__iter__"):
        raise ValueError(f"`joints` must be None or a sequence of 1-based joint numbers; got {joints!r}")
    joints = list(joints)
    for j in joints:
        if isinstance(j, bool) or not isinstance(j, (int, np.integer)) or j < 1:
            raise ValueError(f"`joints` must hold 1-based joint numbers (int >= 1); got {j!r} in {joints!r}")
    joints = tuple(int(j) for j in joints)
    if not joints:
        raise ValueError("`joints` is empty; use None for all the joints of the files")
    if len(set(joints)) != len(joints):
        twice = sorted({j for j in joints if joints.count(j) > 1})
        raise ValueError(f"`joints` names joint(s) {twice} more than once: {joints}")
    return joints


def join_numbers(values) -> str:
    return ", ".join(f"{float(v):g}" for v in values)


def _describe(ratios, constants) -> str:
    if ratios is None and constants is None:
        return "none: the files are joint-side (q = pos, tau = value); values are torques"
    parts = []
    if ratios is None:
        parts.append("joint-side angles (q = pos); values are currents: tau = Kt * value")
    else:
        law = "tau = N * value" if constants is None else "tau = N * Kt * value"
        parts.append(f"motor-side to joint-side (q = pos / N, {law}): ratios {join_numbers(ratios)}")
        if constants is None:
            parts.append("values are torques")
    if constants is not None:
        parts.append(f"values are currents, torque constants {join_numbers(constants)} N m/A")
    return "; ".join(parts)


@x64
def load_joint_logs(
    positions: str | os.PathLike,
    torques: str | os.PathLike,
    *,
    dt: float | None = None,
    ratios=None,
    torque_constants=None,
    joints=None,
    names=None,
    velocities: str | os.PathLike | None = None,
    irregular: Literal["jitter", "error", "resample"] = "jitter",
    max_jitter: float = MAX_JITTER,
) -> JointLogs:
    """Read a positions file and a torques (or currents) file and convert them to joint-side angles and torques.

    **Files.** A CSV file (any suffix but `.mat`, comma-separated) has either
    one header line naming its columns, or no header (every cell of the first
    row numeric; the columns are joints 1, 2, ..., n). A joint's column is
    named `Joint_<k>` (any case, surrounding spaces ignored, any order) or,
    with `names`, after the robot's joint (exact after stripping spaces, else
    ignoring case); a joint's velocity column is its name followed by `_vel`,
    `_velocity` or `_dq`, or preceded by `dq_`. Without `names` every other
    column is refused; with them it is ignored and listed in the result's
    `notes`, and every joint of `names` must have a column. A `.mat` file
    holds either such vectors, or exactly one 2-D numeric (N, n) array
    (other variables are ignored, with a note). All files must have the same
    joint columns and the same number of rows (at least 10), every cell read
    finite. Any file may also hold a time column (s) named `t` or `time`
    (`time_s`, `time (s)`; a .mat vector `t` or `time`); where several do,
    they must agree. Column `j` (joint number) is converted with gear ratio
    `N_j` and torque constant `Kt_j`:

        q_j = pos_j / N_j    (rad; m for a prismatic joint)
        dq_j = vel_j / N_j    (rad/s; m/s)
        tau_j = N_j * value_j    (N m; N; values are motor torques)
        tau_j = N_j * Kt_j * value_j    (N m; values are motor currents, A)

    **Arguments:**

    - `positions`: the angles file: motor-side angles (rad), or joint-side
      ones with `ratios=None`; it may hold velocity columns.
    - `torques`: the torques file: motor torques (N m), currents (A) with
      `torque_constants`, or joint-side torques with neither option.
    - `dt`: sampling period (s), finite and positive (0.2 ms for the TX40
      logs); required when the files have no time column, checked against
      it when they do (`None`: the time column's mean step).
    - `ratios`: gear ratios `N_j` (motor / joint), finite and non-zero (a
      negative ratio reverses the joint; the TX40's are 32, 32, 45, -48, 45,
      32), one per joint column of the files in increasing joint number (all
      of them, whatever `joints` keeps); `None`: 1 (joint-side files).
    - `torque_constants`: `Kt_j` (N m/A), finite and positive, one per joint
      column as for `ratios`; `None`: the values are torques.
    - `joints`: the 1-based joint numbers to keep, in the order of the
      result's columns; `None`: all, in increasing joint number.
    - `names`: the robot's joint names in model order (`SerialRobot.names`):
      joint `k` is `names[k - 1]`; `None`: columns named `Joint_<k>` only.
    - `velocities`: a velocities file (same column rules; motor side like
      `positions`), for the result's `dq`; `None`: the positions file's
      velocity columns, if any, else `dq = None`.
    - `irregular`: a time column whose steps deviate from the median step by
      more than `max_jitter` (relative): `"jitter"` (default) interpolates
      every column linearly onto `t[0] + k * median step` when every step
      lies within 0.5 to 1.5 times the median (stamping jitter), with a note
      in `resampled`, and raises `IrregularSamplingError` naming the first
      step outside it (a gap); `"error"` raises it for any step off;
      `"resample"` interpolates in every case (gaps bridged by straight
      lines). Time that does not increase is refused in every mode.
    - `max_jitter`: that tolerance (default 1e-3).

    **Returns:** a `JointLogs` with `t = t[0] + k * dt` (`t[0] = 0` without a
    time column), the kept `joints`, the velocities `dq` (or None), the file
    names in `source`, the conversion in `converted`, the resampling, if any,
    in `resampled` and the columns ignored in `notes`.

    **Raises:** `FileNotFoundError` for a missing file; `ValueError` (naming
    the file) for an empty or unreadable file, a column not named
    `Joint_<k>` (without `names`), a joint of `names` without a column
    (naming them and the columns found), different joint columns in the
    files, velocity columns for only some joints, a requested joint absent,
    different lengths, fewer than 10 rows, a row with a different number of
    fields, a non-numeric or NaN/inf cell (its file line and column), an
    ambiguous .mat file, or invalid options; `IrregularSamplingError` (a
    `ValueError`) as `irregular` says; `OptionError` (a `ValueError`: an
    option that does not fit the files) for `ratios` or `torque_constants`
    of another count than the files' joint columns, or a `dt` missing (no
    time column) or disagreeing with the time column.

    Example:
        >>> import os, tempfile
        >>> import numpy as np
        >>> from jaxsdp.data import load_joint_logs
        >>> folder = tempfile.mkdtemp()
        >>> pos, cur = os.path.join(folder, "positions.csv"), os.path.join(folder, "torques.csv")
        >>> ratios = np.array([32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
        >>> q = 0.01 * np.arange(50)[:, None] * np.ones(6)  # rad, joint side
        >>> header = "Joint_1,Joint_2,Joint_3,Joint_4,Joint_5,Joint_6"
        >>> np.savetxt(pos, q * ratios, delimiter=",", header=header, comments="")  # motor-side angles
        >>> np.savetxt(cur, np.ones((50, 6)), delimiter=",", header=header, comments="")  # motor torques
        >>> logs = load_joint_logs(pos, cur, dt=2e-4, ratios=ratios)
        >>> logs.q.shape, logs.fs, logs.joints  # (N, n), Hz
        ((50, 6), 5000.0, (1, 2, 3, 4, 5, 6))
        >>> [float(v) for v in logs.tau[0]]  # N m: N_j * 1
        [32.0, 32.0, 45.0, -48.0, 45.0, 32.0]
        >>> q4, tau4 = logs.joint(4)
        >>> bool(np.allclose(q4, q[:, 3], rtol=1e-15))
        True

    Columns named after the robot's joints, in any order, beside others:

        >>> np.savetxt(pos, np.column_stack([q[:, 1], q[:, 0], q[:, 0]]), delimiter=",", comments="",
        ...            header="time_ms,elbow,shoulder", fmt="%.17g")
        >>> np.savetxt(cur, np.ones((50, 2)), delimiter=",", header="shoulder,elbow", comments="")
        >>> logs = load_joint_logs(pos, cur, dt=1e-2, names=("shoulder", "elbow"))
        >>> logs.q.shape, logs.notes[0].split(": ")[1]
        ((50, 2), "ignored column(s) 'time_ms' (neither time, one of the robot's joints nor a joint velocity)")
    """
    dt = None if dt is None else positive_float("dt", dt)
    max_jitter = check_sampling_options(max_jitter, irregular, JOINT_IRREGULAR)
    names = check_names(names)
    ratios = _per_joint("ratios", ratios, currents=False)
    constants = _per_joint("torque_constants", torque_constants, currents=True)
    keep = _check_joints(joints)
    paths = {"positions": _check_file("positions", positions), "torques": _check_file("torques", torques)}
    if velocities is not None:
        paths["velocities"] = _check_file("velocities", velocities)
    tables = {}
    for name, path in paths.items():
        label = f"{name} file {path.name}"
        read = mat_table if path.suffix.lower() == ".mat" else csv_table
        tables[name] = read(label, path, names)
    if "velocities" in tables:  # a velocities file: its joint columns and velocity columns alike are velocities
        vel = tables["velocities"]
        check_unique(vel.label, list(vel.names), list(vel.joints + vel.velocities))
        tables["velocities"] = vel._replace(joints=vel.joints + vel.velocities, velocities=())
        if tables["positions"].velocities:
            raise ValueError(f"{tables['positions'].label} has velocity columns and `velocities` is given: give one")
    if names is not None:
        for table in tables.values():
            require_joints(table, names)
    pos, val = tables["positions"], tables["torques"]
    for other in [val] + [tables[k] for k in ("velocities",) if k in tables]:
        if set(pos.joints) != set(other.joints):
            raise ValueError(
                f"{pos.label} has joint columns {sorted(pos.joints)} but {other.label} has {sorted(other.joints)}: "
                f"the {len(tables)} files must have the same joint columns"
            )
    available = tuple(sorted(pos.joints))
    if pos.velocities and set(pos.velocities) != set(available):
        lacking = sorted(set(available) - set(pos.velocities))
        raise ValueError(f"{pos.label} has velocity columns for joints {sorted(pos.velocities)} only: add {lacking}")
    for name, arr in (("ratios", ratios), ("torque_constants", constants)):
        if arr is not None and arr.size != len(available):  # known from the files' headers: an option error
            raise OptionError(
                f"`{name}` has {arr.size} entries but {pos.label} and {val.label} have {len(available)} joint "
                f"column(s) (joints {', '.join(map(str, available))}): give one per joint column"
            )
    if keep is not None:
        missing = [j for j in keep if j not in available]
        if missing:
            raise ValueError(
                f"`joints`: joint(s) {missing} not in {pos.label} / {val.label}; available joints: "
                f"{', '.join(map(str, available))}"
            )
    keep = available if keep is None else keep
    arrays, times = {}, {}
    for name, table in tables.items():
        if table.values is not None:
            values, times[name] = finite_mat(table)
        else:
            values, times[name], tables[name] = csv_split(table, paths[name])
        if values.shape[0] < MIN_ROWS:
            raise ValueError(f"{table.label} has {values.shape[0]} row(s); at least {MIN_ROWS} are needed")
        if values.shape[0] != arrays.get("positions", values).shape[0]:
            raise ValueError(
                f"{pos.label} has {arrays['positions'].shape[0]} rows but {table.label} has {values.shape[0]}: "
                f"the {len(tables)} files must have the same length"
            )
        arrays[name] = values[:, [table.joints.index(j) for j in keep]]
        if name == "positions" and table.velocities:
            arrays["velocities"] = values[:, [len(table.joints) + table.velocities.index(j) for j in keep]]
    notes = [
        f"{table.label}: ignored column(s) {', '.join(map(repr, table.ignored))} (neither time, "
        + ("one of the robot's joints" if names is not None else "a joint")
        + " nor a joint velocity)"
        for table in tables.values()
        if table.ignored
    ]
    if val.velocities:
        notes.append(f"{val.label}: velocity column(s) ignored (velocities are read from the positions file)")
    dt, arrays, resampled, t0 = time_axis(tables, times, dt, max_jitter=max_jitter, irregular=irregular, arrays=arrays)
    index = [available.index(j) for j in keep]
    gear = np.ones(len(keep)) if ratios is None else ratios[index]
    factor = gear if constants is None else gear * constants[index]
    n = arrays["positions"].shape[0]
    return JointLogs(
        q=jnp.asarray(arrays["positions"] / gear),
        tau=jnp.asarray(factor * arrays["torques"]),
        t=t0 + jnp.arange(n, dtype=jnp.float64) * dt,
        dt=dt,
        joints=tuple(keep),
        source=" + ".join(path.name for path in paths.values()),
        converted=_describe(None if ratios is None else ratios[index], None if constants is None else constants[index]),
        resampled=resampled,
        dq=jnp.asarray(arrays["velocities"] / gear) if "velocities" in arrays else None,
        notes=tuple(notes),
    )


def _joint_array(name: str, x) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a numeric (N, n) array; got {type(x).__name__}") from None
    if arr.ndim != 2 or 0 in arr.shape:
        raise ValueError(f"`{name}` must be a non-empty 2-D (N, n) array, one column per joint; got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i, j = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(f"`{name}`: row {i + 1}, joint {j + 1} is not finite ({arr[i, j]})")
    return arr


def _target(name: str, path) -> pathlib.Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"`{name}` must be a str or os.PathLike; got {type(path).__name__}")
    path = pathlib.Path(path)
    if not path.parent.is_dir():
        raise ValueError(f"`{name}`: cannot write {path}: no such folder {path.parent}")
    if path.is_dir():
        raise ValueError(f"`{name}`: cannot write {path}: it is a folder")
    return path


def _write(path: pathlib.Path, values: np.ndarray, header: bool, f, names, t):
    names = list(names or [f"Joint_{k}" for k in range(1, values.shape[1] + 1)])
    if t is not None:
        names, values = ["time", *names], np.column_stack([t, values])
    if path.suffix.lower() == ".mat":
        import scipy.io

        scipy.io.savemat(f, {k: values[:, i : i + 1] for i, k in enumerate(names)})
    else:
        np.savetxt(f, values, fmt="%.17g", delimiter=",", header=",".join(names) if header else "", comments="")


@x64
def write_joint_logs(
    positions: str | os.PathLike,
    torques: str | os.PathLike,
    q,
    tau,
    *,
    ratios=None,
    torque_constants=None,
    header: bool = True,
    names=None,
    t=None,
) -> None:
    """Write joint-side angles and torques as a positions file and a torques (or currents) file.

    The inverse of `load_joint_logs`, column `j` with gear ratio `N_j` and
    torque constant `Kt_j`:

        pos_j = N_j * q_j    (rad, motor side)
        value_j = tau_j / N_j    (N m, motor torques), or tau_j / (N_j * Kt_j)    (A, currents)

    A `.mat` suffix writes the column vectors `Joint_1`, ..., `Joint_n`;
    any other writes CSV with the header line `Joint_1,...,Joint_n` (none
    with `header=False`) and every value as `%.17g`, so reading the files
    back gives `q` and `tau` to about 1e-16 relative. Everything is
    checked before either file is written; each is written to a temporary
    file first, then both are renamed into place.

    **Arguments:**

    - `positions`, `torques`: the two files to write (replaced if present).
    - `q`: joint angles (rad), shape `(N, n)` (numpy or JAX), finite.
    - `tau`: joint torques (N m), same shape, finite.
    - `ratios`, `torque_constants`: as for `load_joint_logs`, one per column
      (`None`: 1, and values written as torques).
    - `header`: CSV only: write the header line.
    - `names`: the columns' names (the robot's joint names, read back with
      `load_joint_logs(..., names=names)`); `None`: `Joint_1`, ..., `Joint_n`.
    - `t`: time stamps (s), shape `(N,)`, finite: written as a first column
      `time` of both files; `None`: none (the reader then needs `dt`).

    **Raises:** `ValueError` for arrays of the wrong shape or with NaN/inf,
    invalid options, the same path twice, or a folder that does not exist.

    Example:
        >>> import os, tempfile
        >>> import numpy as np
        >>> from jaxsdp.data import load_joint_logs, write_joint_logs
        >>> folder = tempfile.mkdtemp()
        >>> pos, cur = os.path.join(folder, "positions.csv"), os.path.join(folder, "torques.csv")
        >>> q = np.linspace(0.0, 1.0, 20)[:, None] * np.ones(2)  # rad
        >>> tau = np.ones((20, 2))  # N m
        >>> write_joint_logs(pos, cur, q, tau, ratios=(32, -48))
        >>> open(pos).readline().strip(), open(cur).readline().strip()
        ('Joint_1,Joint_2', 'Joint_1,Joint_2')
        >>> logs = load_joint_logs(pos, cur, dt=1e-3, ratios=(32, -48))
        >>> bool(np.allclose(logs.q, q, rtol=1e-15)), [float(v) for v in logs.tau[0]]
        (True, [1.0, 1.0])
    """
    q = _joint_array("q", q)
    tau = _joint_array("tau", tau)
    if q.shape != tau.shape:
        raise ValueError(f"`q` and `tau` must have the same shape (N, n); got {q.shape} and {tau.shape}")
    n = q.shape[1]
    ratios = _per_joint("ratios", ratios, currents=False)
    constants = _per_joint("torque_constants", torque_constants, currents=True)
    for name, arr in (("ratios", ratios), ("torque_constants", constants)):
        if arr is not None and arr.size != n:
            raise ValueError(f"`{name}` has {arr.size} entries but `q` and `tau` have {n} joint column(s)")
    if not isinstance(header, bool):
        raise ValueError(f"`header` must be True or False; got {header!r}")
    names = check_names(names)
    if names is not None and len(names) != n:
        raise ValueError(f"`names` has {len(names)} entries but `q` and `tau` have {n} joint column(s)")
    if t is not None:
        t = np.asarray(t, dtype=np.float64)
        if t.shape != (q.shape[0],) or not np.isfinite(t).all():
            raise ValueError(f"`t` must be {q.shape[0]} finite time stamps (s), one per row of `q`; got {t.shape}")
    paths = {"positions": _target("positions", positions), "torques": _target("torques", torques)}
    if paths["positions"].resolve() == paths["torques"].resolve():
        raise ValueError(f"`positions` and `torques` are the same file: {paths['positions']}")
    gear = np.ones(n) if ratios is None else ratios
    factor = gear if constants is None else gear * constants
    with np.errstate(over="ignore"):
        values = {"positions": gear * q, "torques": tau / factor}
    for name, arr in values.items():
        if not np.isfinite(arr).all():
            raise ValueError(f"{name} file {paths[name].name}: the converted values overflow (inf)")
    temporary = {name: path.with_name(f".{path.name}.{os.getpid()}.tmp") for name, path in paths.items()}
    try:
        for name, path in paths.items():
            with open(temporary[name], "wb") as f:
                _write(path, values[name], header, f, names, t)
        for name, path in paths.items():
            os.replace(temporary[name], path)
    finally:
        for tmp in temporary.values():
            tmp.unlink(missing_ok=True)
