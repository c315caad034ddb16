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

`write_joint_logs` is the inverse. The conversion is diagonal: the TX40's
wrist coupling (motor 6 turning with joint 5) and its joint-angle offsets
are a model matter, applied by the caller (see the reference notes on the
TX40).
"""

import math
import os
import pathlib
import re
import warnings
from typing import Literal, NamedTuple

import jax.numpy as jnp
import numpy as np

from .._checks import OptionError, positive_float
from .._records import JointLogs
from .._runtime import x64
from ._loaders import MAX_JITTER, check_sampling_options, stored_resolution, text_resolution, uniform_sampling

#: The least number of samples a joint log must hold.
MIN_ROWS = 10

_JOINT = re.compile(r"joint_(\d+)", re.IGNORECASE)
#: Names a time column (s) may have: `t`, `time`, `time_s`, `t_s`, `time (s)`, any case.
_TIME = re.compile(r"\s*(t|time)(_s|\s*\(s\))?\s*", re.IGNORECASE)


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


def _joint_number(label: str, name: str) -> int:
    m = _JOINT.fullmatch(name.strip())
    if m is None or int(m.group(1)) < 1:
        raise ValueError(f"{label}: column {name.strip()!r} is not named Joint_<k> (k = 1, 2, ...)")
    return int(m.group(1))


def _check_unique(label: str, names: list[str], numbers: list[int]):
    if len(set(numbers)) != len(numbers):
        twice = sorted({k for k in numbers if numbers.count(k) > 1})
        raise ValueError(f"{label}: joint(s) {twice} appear in more than one column ({', '.join(names)})")


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


class _Table(NamedTuple):
    """One file's joint columns, in file order: joint numbers and how to name them in a message."""

    label: str  # "positions file name.csv"
    joints: tuple[int, ...]
    names: tuple[str, ...]  # "column 3 (Joint_3)", "column 3", "column `Joint_3`", "column 3 of `data`"
    skip: int  # CSV: the lines before the data (blank lines, the header)
    values: np.ndarray | None  # .mat: the (N, n) values, read with the columns
    time: int | None = None  # CSV: the time column's index in the file; .mat: None
    t: np.ndarray | None = None  # .mat: the time vector (`t` or `time`), if any
    resolution: float = 0.0  # how finely the time values are stored (s)


def _csv_columns(label: str, path: pathlib.Path) -> _Table:
    """Read the first non-blank line: a `Joint_<k>` header, or the first data row of a headerless file."""
    try:
        with open(path, encoding="utf-8-sig", newline=None) as f:
            for lineno, line in enumerate(f, start=1):
                if line.strip():
                    break
            else:
                raise ValueError(f"{label} is empty (no data rows)")
    except UnicodeDecodeError as e:
        raise ValueError(f"{label}: could not read it as a text CSV file ({e})") from None
    cells = line.rstrip("\r\n").split(",")
    if all(_is_number(c) for c in cells):
        numbers = tuple(range(1, len(cells) + 1))
        return _Table(label, numbers, tuple(f"column {k}" for k in numbers), lineno - 1, None)
    times = [i for i, c in enumerate(cells) if _TIME.fullmatch(c)]
    if len(times) > 1:
        raise ValueError(f"{label}: more than one time column ({', '.join(cells[i].strip() for i in times)})")
    time = times[0] if times else None
    joint_cells = [(i, c) for i, c in enumerate(cells) if i != time]
    numbers = [_joint_number(label, c) for _, c in joint_cells]
    names = [c.strip() for _, c in joint_cells]
    _check_unique(label, names, numbers)
    described = tuple(f"column {i + 1} ({c.strip()})" for i, c in joint_cells)
    return _Table(label, tuple(numbers), described, lineno, None, time)


def _locate_bad_cell(table: _Table, path: pathlib.Path) -> str | None:
    """Scan the CSV row by row: the first row with a wrong field count or a non-numeric or non-finite cell."""
    n = len(table.joints) + (table.time is not None)
    names = list(table.names)
    if table.time is not None:
        names.insert(table.time, f"column {table.time + 1} (time)")
    with open(path, encoding="utf-8-sig", newline=None) as f:
        for lineno, line in enumerate(f, start=1):
            if lineno <= table.skip or not line.strip():
                continue
            cells = line.rstrip("\r\n").split(",")
            if len(cells) != n:
                return f"line {lineno} has {len(cells)} field(s), expected {n} (one per column of the header)"
            for i, cell in enumerate(cells):
                where = f"line {lineno}, {names[i]}"
                try:
                    value = float(cell)
                except ValueError:
                    return f"{where} is not a number: {cell.strip()!r}"
                if not math.isfinite(value):
                    return f"{where} is not finite: {cell.strip()!r}"
    return None


def _csv_values(table: _Table, path: pathlib.Path) -> np.ndarray:
    """All rows as an (N, n) float64 array (the time column included where there is one): `np.loadtxt`, and on
    failure a row-by-row scan naming the bad cell."""
    n = len(table.joints) + (table.time is not None)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": the row count says it
            values = np.loadtxt(
                path, dtype=np.float64, delimiter=",", skiprows=table.skip, comments=None, ndmin=2, encoding="utf-8-sig"
            )
    except ValueError as e:
        values, problem = None, str(e)
    else:
        if values.size == 0:
            return np.empty((0, n))
        problem = None if values.shape[1] == n and np.isfinite(values).all() else f"{values.shape[1]} columns or NaN"
    if problem is not None:
        located = _locate_bad_cell(table, path)
        raise ValueError(f"{table.label}: {located or f'could not be read as numbers ({problem})'}")
    return values


def _mat_table(label: str, path: pathlib.Path) -> _Table:
    """Variables `Joint_1`, ..., `Joint_n` (vectors), or exactly one 2-D numeric (N, n) array besides scalars."""
    import scipy.io

    try:
        contents = scipy.io.loadmat(path)
    except Exception as e:  # scipy raises many types for a corrupt file
        raise ValueError(f"{label}: could not read it as a MATLAB .mat file ({type(e).__name__}: {e})") from None
    contents = {k: np.asarray(v) for k, v in contents.items() if not k.startswith("__")}
    if not contents:
        raise ValueError(f"{label} is empty (no variables)")
    named = {k: v for k, v in contents.items() if _JOINT.fullmatch(k)}
    if named:
        names = sorted(named, key=lambda k: _joint_number(label, k))
        numbers = [_joint_number(label, k) for k in names]
        _check_unique(label, names, numbers)
        columns = []
        for k in names:
            v = named[k]
            if v.dtype.kind not in "iuf":
                raise ValueError(f"{label}: variable `{k}` is not numeric (MATLAB class {v.dtype})")
            if v.ndim != 2 or 1 not in v.shape:
                raise ValueError(f"{label}: variable `{k}` must be a vector; got shape {v.shape}")
            columns.append(v.reshape(-1).astype(np.float64))
        lengths = {k: c.shape[0] for k, c in zip(names, columns)}
        if len(set(lengths.values())) != 1:
            desc = ", ".join(f"`{k}`: {m}" for k, m in lengths.items())
            raise ValueError(f"{label}: the joint variables have different lengths ({desc})")
        times = [k for k in contents if _TIME.fullmatch(k)]
        if len(times) > 1:
            raise ValueError(f"{label}: more than one time variable ({', '.join(f'`{k}`' for k in times)})")
        t, resolution = None, 0.0
        if times:
            v = contents[times[0]]
            if v.dtype.kind not in "iuf" or v.ndim != 2 or 1 not in v.shape:
                raise ValueError(f"{label}: time variable `{times[0]}` must be a numeric vector; got {v.shape}")
            t, resolution = v.reshape(-1).astype(np.float64), stored_resolution(v)
            if t.shape[0] != columns[0].shape[0]:
                raise ValueError(f"{label}: time `{times[0]}` has {t.shape[0]} samples, joints {columns[0].shape[0]}")
        described = tuple(f"column `{k}`" for k in names)
        return _Table(label, tuple(numbers), described, 0, np.stack(columns, axis=1), None, t, resolution)
    arrays = [k for k, v in contents.items() if v.dtype.kind in "iuf" and v.ndim == 2 and v.size > 1]
    if len(arrays) != 1:
        found = ", ".join(f"`{k}` {v.shape} {v.dtype}" for k, v in contents.items())
        raise ValueError(
            f"{label}: expected variables Joint_1, ..., Joint_n (vectors) or exactly one 2-D numeric (N, n) "
            f"array; found {len(arrays)} such arrays among: {found}"
        )
    (name,) = arrays
    values = contents[name].astype(np.float64)
    numbers = tuple(range(1, values.shape[1] + 1))
    return _Table(label, numbers, tuple(f"column {k} of `{name}`" for k in numbers), 0, values)


def _finite_mat(table: _Table) -> tuple[np.ndarray, np.ndarray | None]:
    bad = ~np.isfinite(table.values)
    if bad.any():
        i, j = (int(x) for x in np.argwhere(bad)[0])
        raise ValueError(f"{table.label}: row {i + 1}, {table.names[j]} is not finite ({table.values[i, j]})")
    if table.t is not None and not np.isfinite(table.t).all():
        i = int(np.argmax(~np.isfinite(table.t)))
        raise ValueError(f"{table.label}: row {i + 1} of the time variable is not finite ({table.t[i]})")
    return table.values, table.t


def _csv_split(table: _Table, path: pathlib.Path) -> tuple[np.ndarray, np.ndarray | None, _Table]:
    """The joint columns, the time column (or None) and the table with the time values' text resolution."""
    values = _csv_values(table, path)
    if table.time is None:
        return values, None, table
    with open(path, encoding="utf-8-sig", newline=None) as f:
        lines = [line for k, line in enumerate(f, start=1) if k > table.skip and line.strip()]
    tokens = [line.split(",")[table.time] for line in lines[:1000] + lines[-1000:]]
    table = table._replace(resolution=text_resolution(tokens))
    return np.delete(values, table.time, axis=1), values[:, table.time], table


def _time_axis(tables, times, dt, *, max_jitter, irregular, arrays):
    """The sampling period, the arrays (resampled where asked) and the resampling note."""
    given = [(tables[k], times[k]) for k in tables if times[k] is not None]
    if not given:
        if dt is None:
            raise OptionError(
                f"{tables['positions'].label} and {tables['torques'].label} have no time column (`t` or `time`): "
                "give the sampling period `dt`"
            )
        return dt, arrays, None, 0.0
    (table, t), *rest = given
    for other, t2 in rest:
        tol = max(max_jitter * float(np.median(np.diff(t))), 1.5 * max(table.resolution, other.resolution))
        if t2.shape != t.shape or np.max(np.abs(t2 - t)) > tol:
            raise ValueError(f"{table.label} and {other.label} have different time columns; the samples must match")
    columns = {"t": t} | {f"{k}{i}": arrays[k][:, i] for k in arrays for i in range(arrays[k].shape[1])}
    columns, step, note = uniform_sampling(table.label, columns, "t", max_jitter, irregular, table.resolution)
    if dt is not None and abs(step - dt) > max(max_jitter * dt, 1.5 * table.resolution):
        raise OptionError(
            f"`dt` = {dt:g} s but the time column of {table.label} steps by {step:.6g} s; drop `dt` (the time column "
            "gives it) or correct it"
        )
    out = {k: np.stack([columns[f"{k}{i}"] for i in range(arrays[k].shape[1])], axis=1) for k in arrays}
    return step, out, note, float(columns["t"][0])


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
    irregular: Literal["error", "resample"] = "error",
    max_jitter: float = MAX_JITTER,
) -> JointLogs:
    """Read a positions file and a torques (or currents) file and convert them to joint-side angles and torques.

    **Files.** A CSV file (any suffix but `.mat`, comma-separated) has either
    one header line `Joint_1,Joint_2,...,Joint_n` (names matched ignoring
    case and surrounding spaces, any order), or no header (every cell of the
    first row numeric; the columns are joints 1, 2, ..., n). A `.mat` file
    holds either vectors `Joint_1`, ..., `Joint_n`, or exactly one 2-D
    numeric (N, n) array (1 x 1 scalars beside it are ignored). Both files
    must have the same joint columns and the same number of rows (at least
    10), every cell finite. Either file may also hold a time column (s)
    named `t` or `time` (`time_s`, `time (s)`; a .mat vector `t` or `time`);
    where both do, they must agree. Column `j` (joint number) is converted with
    gear ratio `N_j` and torque constant `Kt_j`:

        q_j = pos_j / N_j    (rad)
        tau_j = N_j * value_j    (N m; values are motor torques, N m)
        tau_j = N_j * Kt_j * value_j    (N m; values are motor currents, A)

    **Arguments:**

    - `positions`: the angles file: motor-side angles (rad), or joint-side
      ones with `ratios=None`.
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
    - `irregular`: a time column whose steps deviate from the median step by
      more than `max_jitter` (relative): `"error"` (default) raises
      `IrregularSamplingError` naming the first bad sample; `"resample"`
      interpolates every column linearly onto `t[0] + k * median step` and
      says so in the result's `resampled`.
    - `max_jitter`: that tolerance (default 1e-3).

    **Returns:** a `JointLogs` with `t = t[0] + k * dt` (`t[0] = 0` without a
    time column), the kept `joints`, the file names in `source`, the
    conversion in `converted` and the resampling, if any, in `resampled`.

    **Raises:** `FileNotFoundError` for a missing file; `ValueError` (naming
    the file) for an empty or unreadable file, a column not named
    `Joint_<k>`, different joint columns in the two files, a requested joint
    absent, different lengths, fewer than 10 rows, a row with a different
    number of fields, a non-numeric or NaN/inf cell (its file line and
    column), an ambiguous .mat file, or invalid options; `OptionError` (a
    `ValueError`: an option that does not fit the files) for `ratios` or
    `torque_constants` of another count than the files' joint columns, or a
    `dt` missing (no time column) or disagreeing with the time column.

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
    """
    dt = None if dt is None else positive_float("dt", dt)
    max_jitter = check_sampling_options(max_jitter, irregular)
    ratios = _per_joint("ratios", ratios, currents=False)
    constants = _per_joint("torque_constants", torque_constants, currents=True)
    keep = _check_joints(joints)
    paths = {"positions": _check_file("positions", positions), "torques": _check_file("torques", torques)}
    tables = {}
    for name, path in paths.items():
        label = f"{name} file {path.name}"
        tables[name] = _mat_table(label, path) if path.suffix.lower() == ".mat" else _csv_columns(label, path)
    pos, val = tables["positions"], tables["torques"]
    if set(pos.joints) != set(val.joints):
        raise ValueError(
            f"{pos.label} has joint columns {sorted(pos.joints)} but {val.label} has {sorted(val.joints)}: "
            "the two files must have the same joint columns"
        )
    available = tuple(sorted(pos.joints))
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
            values, times[name] = _finite_mat(table)
        else:
            values, times[name], tables[name] = _csv_split(table, paths[name])
        if values.shape[0] < MIN_ROWS:
            raise ValueError(f"{table.label} has {values.shape[0]} row(s); at least {MIN_ROWS} are needed")
        arrays[name] = values[:, [table.joints.index(j) for j in keep]]
    if arrays["positions"].shape[0] != arrays["torques"].shape[0]:
        raise ValueError(
            f"{pos.label} has {arrays['positions'].shape[0]} rows but {val.label} has "
            f"{arrays['torques'].shape[0]}: the two files must have the same length"
        )
    dt, arrays, resampled, t0 = _time_axis(tables, times, dt, max_jitter=max_jitter, irregular=irregular, arrays=arrays)
    index = [available.index(j) for j in keep]
    gear = np.ones(len(keep)) if ratios is None else ratios[index]
    factor = gear if constants is None else gear * constants[index]
    q = arrays["positions"] / gear
    tau = factor * arrays["torques"]
    n = q.shape[0]
    return JointLogs(
        q=jnp.asarray(q),
        tau=jnp.asarray(tau),
        t=t0 + jnp.arange(n, dtype=jnp.float64) * dt,
        dt=dt,
        joints=tuple(keep),
        source=f"{paths['positions'].name} + {paths['torques'].name}",
        converted=_describe(None if ratios is None else ratios[index], None if constants is None else constants[index]),
        resampled=resampled,
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


def _write(path: pathlib.Path, values: np.ndarray, header: bool, f):
    names = [f"Joint_{k}" for k in range(1, values.shape[1] + 1)]
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
                _write(path, values[name], header, f)
        for name, path in paths.items():
            os.replace(temporary[name], path)
    finally:
        for tmp in temporary.values():
            tmp.unlink(missing_ok=True)
