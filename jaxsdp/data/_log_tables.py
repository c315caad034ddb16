"""The columns of a joint-log file (CSV or MATLAB .mat): which are joints, velocities, time or ignored, and their
values, checked cell by cell; the common time axis of several such files.

A column names a joint as `Joint_<k>` or, given the robot's joint names,
after its joint (`jaxsdp.data._loaders.joint_of`); a joint velocity as
`<joint>_vel`, `<joint>_velocity`, `<joint>_dq` or `dq_<joint>`; time as `t`
or `time` (`time_s`, `time (s)`). Used by `load_joint_logs`.
"""

import math
import pathlib
import re
import warnings
from typing import NamedTuple

import numpy as np

from .._checks import OptionError
from ._loaders import joint_of, stored_resolution, text_resolution, uniform_sampling, velocity_of

#: Names a time column (s) may have: `t`, `time`, `time_s`, `t_s`, `time (s)`, any case.
TIME = re.compile(r"\s*(t|time)(_s|\s*\(s\))?\s*", re.IGNORECASE)


def check_unique(label: str, names: list[str], numbers: list[int], what: str = "joint(s)"):
    if len(set(numbers)) != len(numbers):
        twice = sorted({k for k in numbers if numbers.count(k) > 1})
        raise ValueError(f"{label}: {what} {twice} appear in more than one column ({', '.join(names)})")


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


class Table(NamedTuple):
    """One file's columns: the joint numbers of its value columns, then of its velocity columns, and their names."""

    label: str  # "positions file name.csv"
    joints: tuple[int, ...]
    names: tuple[str, ...]  # "column 3 (Joint_3)", "column 3", "column `Joint_3`", "column 3 of `data`"
    skip: int  # CSV: the lines before the data (blank lines, the header)
    values: np.ndarray | None  # .mat: the (N, n + m) values then velocities, read with the columns
    time: int | None = None  # CSV: the time column's index in the file; .mat: None
    t: np.ndarray | None = None  # .mat: the time vector (`t` or `time`), if any
    resolution: float = 0.0  # how finely the time values are stored (s)
    velocities: tuple[int, ...] = ()  # the joint numbers of the velocity columns (after the value columns)
    columns: tuple[int, ...] = ()  # CSV: the file's index of each value, then velocity, column
    width: int = 0  # CSV: the fields of a row
    ignored: tuple[str, ...] = ()  # columns (variables) neither time, a joint nor a velocity
    found: tuple[str, ...] = ()  # every column's (variable's) name, for messages


def _classify(label: str, headers, names, *, strict: bool) -> tuple[list, list, list]:
    """(index, header, joint number) of the joint columns, of the velocity columns, and the ignored headers
    (`strict`: none may be ignored without the robot's joint `names`)."""
    joints, velocities, ignored = [], [], []
    for i, header in headers:
        k = joint_of(header, names)
        if k is not None:
            joints.append((i, header.strip(), k))
        elif (k := velocity_of(header, names)) is not None:
            velocities.append((i, header.strip(), k))
        elif names is None and strict:
            raise ValueError(
                f"{label}: column {header.strip()!r} is not named Joint_<k> (k = 1, 2, ...); columns named after "
                "the robot's joints need its joint names (`names`)"
            )
        else:
            ignored.append(header.strip())
    for what, found in (("joint(s)", joints), ("the velocity of joint(s)", velocities)):
        check_unique(label, [h for _, h, _ in found], [k for *_, k in found], what)
    return joints, velocities, ignored


def csv_table(label: str, path: pathlib.Path, names) -> Table:
    """Read the first non-blank line: a header, or the first data row of a headerless file."""
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
        described = tuple(f"column {k}" for k in numbers)
        return Table(label, numbers, described, lineno - 1, None, columns=tuple(range(len(cells))), width=len(cells))
    times = [i for i, c in enumerate(cells) if TIME.fullmatch(c)]
    if len(times) > 1:
        raise ValueError(f"{label}: more than one time column ({', '.join(cells[i].strip() for i in times)})")
    time = times[0] if times else None
    headers = [(i, c) for i, c in enumerate(cells) if i != time]
    joints, velocities, ignored = _classify(label, headers, names, strict=True)
    both = joints + velocities
    return Table(
        label,
        tuple(k for *_, k in joints),
        tuple(f"column {i + 1} ({c})" for i, c, _ in both),
        lineno,
        None,
        time,
        velocities=tuple(k for *_, k in velocities),
        columns=tuple(i for i, *_ in both),
        width=len(cells),
        ignored=tuple(ignored),
        found=tuple(c.strip() for c in cells),
    )


def _used(table: Table) -> list[int]:
    """The file columns read: the time column first (if any), then the value and velocity columns."""
    return ([table.time] if table.time is not None else []) + list(table.columns)


def _locate_bad_cell(table: Table, path: pathlib.Path) -> str | None:
    """Scan the CSV row by row: the first row with a wrong field count or a non-numeric or non-finite cell read."""
    names = dict(zip(table.columns, table.names))
    if table.time is not None:
        names[table.time] = f"column {table.time + 1} (time)"
    with open(path, encoding="utf-8-sig", newline=None) as f:
        for lineno, line in enumerate(f, start=1):
            if lineno <= table.skip or not line.strip():
                continue
            cells = line.rstrip("\r\n").split(",")
            if len(cells) != table.width:
                return f"line {lineno} has {len(cells)} field(s), expected {table.width} (one per column of the header)"
            for i in sorted(names):
                where = f"line {lineno}, {names[i]}"
                try:
                    value = float(cells[i])
                except ValueError:
                    return f"{where} is not a number: {cells[i].strip()!r}"
                if not math.isfinite(value):
                    return f"{where} is not finite: {cells[i].strip()!r}"
    return None


def _csv_values(table: Table, path: pathlib.Path) -> np.ndarray:
    """The columns read (`_used`), as an (N, m) float64 array: `np.loadtxt`, and on failure a row-by-row scan
    naming the bad cell. Ignored columns are not parsed (they may hold text)."""
    used = _used(table)
    usecols = sorted(used) if table.ignored else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": the row count says it
            values = np.loadtxt(
                path,
                dtype=np.float64,
                delimiter=",",
                skiprows=table.skip,
                comments=None,
                ndmin=2,
                encoding="utf-8-sig",
                usecols=usecols,
            )
    except ValueError as e:
        values, problem = None, str(e)
    else:
        if values.size == 0:
            return np.empty((0, len(used)))
        width = table.width if usecols is None else len(usecols)
        problem = (
            None if values.shape[1] == width and np.isfinite(values).all() else f"{values.shape[1]} columns or NaN"
        )
    if problem is not None:
        located = _locate_bad_cell(table, path)
        raise ValueError(f"{table.label}: {located or f'could not be read as numbers ({problem})'}")
    read = usecols or range(table.width)
    return values[:, [list(read).index(i) for i in used]]


def _mat_vector(label: str, k: str, v: np.ndarray) -> np.ndarray:
    if v.dtype.kind not in "iuf":
        raise ValueError(f"{label}: variable `{k}` is not numeric (MATLAB class {v.dtype})")
    if v.ndim != 2 or 1 not in v.shape:
        raise ValueError(f"{label}: variable `{k}` must be a vector; got shape {v.shape}")
    return v.reshape(-1).astype(np.float64)


def mat_table(label: str, path: pathlib.Path, names) -> Table:
    """Variables named after the joints (`Joint_<k>` or `names`) and their velocities (vectors), or exactly one
    2-D numeric (N, n) array; other variables are ignored."""
    import scipy.io

    try:
        contents = scipy.io.loadmat(path)
    except Exception as e:  # scipy raises many types for a corrupt file
        raise ValueError(f"{label}: could not read it as a MATLAB .mat file ({type(e).__name__}: {e})") from None
    contents = {k: np.asarray(v) for k, v in contents.items() if not k.startswith("__")}
    if not contents:
        raise ValueError(f"{label} is empty (no variables)")
    times = [k for k in contents if TIME.fullmatch(k)]
    joints, velocities, ignored = _classify(label, [(k, k) for k in contents if k not in times], names, strict=False)
    if joints:
        joints, velocities = sorted(joints, key=lambda c: c[2]), sorted(velocities, key=lambda c: c[2])
        both = joints + velocities
        columns = [_mat_vector(label, k, contents[k]) for k, *_ in both]
        lengths = {k: c.shape[0] for (k, *_), c in zip(both, columns)}
        if len(set(lengths.values())) != 1:
            desc = ", ".join(f"`{k}`: {m}" for k, m in lengths.items())
            raise ValueError(f"{label}: the joint variables have different lengths ({desc})")
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
        return Table(
            label,
            tuple(k for *_, k in joints),
            tuple(f"column `{k}`" for k, *_ in both),
            0,
            np.stack(columns, axis=1),
            None,
            t,
            resolution,
            velocities=tuple(k for *_, k in velocities),
            ignored=tuple(ignored),
            found=tuple(contents),
        )
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
    others = tuple(k for k in contents if k != name)
    described = tuple(f"column {k} of `{name}`" for k in numbers)
    return Table(label, numbers, described, 0, values, ignored=others, found=(name,))


def finite_mat(table: Table) -> tuple[np.ndarray, np.ndarray | None]:
    bad = ~np.isfinite(table.values)
    if bad.any():
        i, j = (int(x) for x in np.argwhere(bad)[0])
        raise ValueError(f"{table.label}: row {i + 1}, {table.names[j]} is not finite ({table.values[i, j]})")
    if table.t is not None and not np.isfinite(table.t).all():
        i = int(np.argmax(~np.isfinite(table.t)))
        raise ValueError(f"{table.label}: row {i + 1} of the time variable is not finite ({table.t[i]})")
    return table.values, table.t


def csv_split(table: Table, path: pathlib.Path) -> tuple[np.ndarray, np.ndarray | None, Table]:
    """The value and velocity columns, the time column (or None) and the table with the time values' text
    resolution."""
    values = _csv_values(table, path)
    if table.time is None:
        return values, None, table
    with open(path, encoding="utf-8-sig", newline=None) as f:
        lines = [line for k, line in enumerate(f, start=1) if k > table.skip and line.strip()]
    tokens = [line.split(",")[table.time] for line in lines[:1000] + lines[-1000:]]
    table = table._replace(resolution=text_resolution(tokens))
    return values[:, 1:], values[:, 0], table


class MissingJointsError(ValueError):
    """A log file without a column for some of the robot's joints (`missing`: their names, in the robot's order)."""

    def __init__(self, message: str, missing: tuple[str, ...]):
        super().__init__(message)
        self.missing = tuple(missing)


def require_joints(table: Table, names: tuple[str, ...]) -> None:
    """With the robot's joint names: every joint has a column (a headerless file or an array: exactly one each)."""
    n = len(names)
    missing = [name for k, name in enumerate(names, start=1) if k not in table.joints]
    if missing:
        found = ", ".join(repr(c) for c in table.found) if table.found else f"{len(table.joints)} unnamed"
        raise MissingJointsError(
            f"{table.label} has no column for joint(s) {', '.join(map(repr, missing))} of the robot's {n} "
            f"({', '.join(names)}); columns found: {found}. Name the columns after the robot's joints or Joint_1, "
            f"..., Joint_{n}",
            missing,
        )
    if len(table.joints) > n:
        raise ValueError(f"{table.label} has {len(table.joints)} unnamed joint columns; the robot has {n} joints")


def time_axis(tables, times, dt, *, max_jitter, irregular, arrays):
    """The sampling period, the arrays (resampled where asked) and the resampling note, the first time (s).

    `tables` and `times` map a role to a `Table`-like (`label`, `resolution`) and its time vector (or None)."""
    given = [(tables[k], times[k]) for k in tables if times[k] is not None]
    if not given:
        if dt is None:
            labels = [table.label for table in tables.values()]
            raise OptionError(
                f"{', '.join(labels[:-1])} and {labels[-1]} have no time column (`t` or `time`): "
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
