"""Loading the EMPS benchmark data set and generic measurement files.

Sampling: the identification assumes uniform sampling (one `dt`). Both
loaders measure every step of the time column against the median step and
refuse the file (`IrregularSamplingError`, a `ValueError` naming the first bad
sample) when a step deviates from it by more than `max_jitter` (relative,
default `MAX_JITTER` = 1e-3), unless asked to resample it explicitly
(`irregular="resample"`: linear interpolation onto a uniform grid at the
median step, recorded in the result's `resampled`). An irregular record is
never averaged into one mean `dt`. The joint-log loaders add a third mode and
make it their default, `irregular="jitter"`: time stamps whose every step lies
within 0.5 to 1.5 times the median step (a robot controller's logger
stamping samples of a fixed period late or early) are interpolated the same
way, with a note; a gap beyond that (a missing sample is twice the median
step) is still refused. A stamp that does not increase is refused in every
mode: no interpolation can order it.
"""

import math
import os
import pathlib
import re
from typing import Literal

import jax.numpy as jnp
import numpy as np

from .._records import EMPSData, Measurements
from .._runtime import x64
from ._csv import read_csv_rows

_EMPS_VECTORS = ("t", "qm", "qg", "vir")
_EMPS_SCALARS = ("gtau", "kp", "kv")

#: Default tolerance on each sampling step, relative to the median step. The
#: benchmark file DATA_EMPS.mat stores `t` rounded to single precision: its
#: steps are 0.99998 ms and 1.00002 ms, 4.0e-5 from the median; 1e-3 passes
#: that rounding 25 times over and still catches a clock slip of 1 us in a
#: 1 ms period (and any missing sample, a 100 % deviation).
MAX_JITTER = 1e-3

_IRREGULAR = ("error", "resample")
#: The modes of the joint-log loaders: `"jitter"` resamples stamping jitter (every step within `JITTER_BAND` of the
#: median step) and refuses gaps.
JOINT_IRREGULAR = ("jitter", "error", "resample")
#: Steps within these multiples of the median step are stamping jitter, beyond them a gap (or a doubled sample).
JITTER_BAND = (0.5, 1.5)


class IrregularSamplingError(ValueError):
    """A time column whose steps are not uniform within `max_jitter` of the median step.

    **Attributes:** `index` (0-based index of the first sample whose step
    from the previous one is out of tolerance), `time` (its time), `step`
    (that step), `median` (the median step), `count` (how many steps are out
    of tolerance), `detail` (the message without the advice on what to do).
    """

    def __init__(self, detail: str, advice: str, *, index: int, time: float, step: float, median: float, count: int):
        super().__init__(f"{detail}; {advice}")
        self.detail = detail
        self.index = index
        self.time = time
        self.step = step
        self.median = median
        self.count = count


_JOINT = re.compile(r"joint_(\d+)", re.IGNORECASE)
#: A joint velocity column: the joint's name (or `Joint_<k>`) with `_vel`, `_velocity` or `_dq` after it, or `dq_`
#: before it (any case).
_VELOCITY = re.compile(r"dq_(?P<a>.+)|(?P<b>.+?)(_vel|_velocity|_dq)", re.IGNORECASE)


def joint_of(label: str, names: tuple[str, ...] | None) -> int | None:
    """The 1-based joint number a column (or message) `label` names, or None: one of the robot's joint `names`
    (in model order; exact after stripping spaces, else ignoring case when that is unambiguous), else
    `Joint_<k>` (any case; with `names`, k up to their count)."""
    label = label.strip()
    if names is not None:
        for rule in (lambda s: s, str.casefold):
            hits = [i for i, name in enumerate(names) if rule(name.strip()) == rule(label)]
            if len(hits) == 1:
                return hits[0] + 1
    m = _JOINT.fullmatch(label)
    if m is None or int(m.group(1)) < 1 or (names is not None and int(m.group(1)) > len(names)):
        return None
    return int(m.group(1))


def velocity_of(label: str, names: tuple[str, ...] | None) -> int | None:
    """The joint number of a velocity column (`<joint>_vel`, `<joint>_velocity`, `<joint>_dq`, `dq_<joint>`)."""
    m = _VELOCITY.fullmatch(label.strip())
    return None if m is None else joint_of(m.group("a") or m.group("b"), names)


def check_names(names) -> tuple[str, ...] | None:
    """The robot's joint names (non-empty, distinct strings) as a tuple, or None."""
    if names is None:
        return None
    if isinstance(names, (str, bytes)) or not hasattr(names, "__iter__"):
        raise ValueError(f"`names` must be None or the robot's joint names in model order; got {names!r}")
    names = tuple(names)
    if not names or not all(isinstance(v, str) and v.strip() for v in names):
        raise ValueError(f"`names` must be non-empty strings, one per joint in model order; got {names!r}")
    twice = sorted({v for v in names if names.count(v) > 1})
    if twice:
        raise ValueError(f"`names` holds {twice} more than once: {names}")
    return names


def _check_path(path) -> pathlib.Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"`path` must be a str or os.PathLike; got {type(path).__name__}")
    path = pathlib.Path(path)
    if not path.exists():
        raise FileNotFoundError(f"`path`: no such file: {path}")
    if not path.is_file():
        raise ValueError(f"`path`: not a regular file: {path}")
    return path


def _read_mat(path: pathlib.Path) -> dict:
    import scipy.io

    try:
        contents = scipy.io.loadmat(path)
    except Exception as e:  # scipy raises many types for a corrupt file
        raise ValueError(f"`path`: could not read {path} as a MATLAB .mat file ({type(e).__name__}: {e})") from None
    return {k: v for k, v in contents.items() if not k.startswith("__")}


def _as_vector(source: str, name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{source}: variable `{name}` is not numeric") from None
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise ValueError(f"{source}: variable `{name}` must be a vector; got shape {tuple(np.shape(value))}")
    if arr.shape[0] < 2:
        raise ValueError(f"{source}: variable `{name}` needs at least 2 samples; got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.sum(~np.isfinite(arr)))
        raise ValueError(f"{source}: variable `{name}` contains {bad} NaN/inf value(s)")
    return arr


def stored_resolution(value) -> float:
    """The spacing of the stored numbers near their largest magnitude for single or half precision (a float32
    time stamp of 24.8 s is only known to 1.9e-6 s), 0 for double precision and integers."""
    arr = np.asarray(value)
    if arr.dtype.kind == "f" and arr.dtype.itemsize < 8 and arr.size:
        return float(np.spacing(np.max(np.abs(arr)).astype(arr.dtype)))
    return 0.0


def text_resolution(tokens) -> float:
    """The resolution of numbers written with a fixed number of decimals ("%.4f": 1e-4; "%.6e": the unit of
    the last digit of the largest), the coarsest last written digit; 0 when the number of decimals varies
    (shortest round-trip output, "0.1", "0.101": full double precision)."""
    worst, decimals = 0.0, set()
    for token in tokens:
        mantissa, _, exponent = token.strip().lower().partition("e")
        digits = len(mantissa.partition(".")[2]) if "." in mantissa else 0
        try:
            unit = 10.0 ** (int(exponent or 0) - digits)
        except ValueError:
            continue
        decimals.add(digits)
        worst = max(worst, unit)
    return worst if len(decimals) == 1 else 0.0


def _as_scalar(source: str, name: str, value) -> float:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{source}: variable `{name}` is not numeric") from None
    if arr.size != 1:
        raise ValueError(f"{source}: variable `{name}` must be a scalar; got shape {arr.shape}")
    out = float(arr.reshape(()))
    if not np.isfinite(out):
        raise ValueError(f"{source}: variable `{name}` is not finite ({out})")
    return out


def check_sampling_options(max_jitter, irregular, modes=_IRREGULAR) -> float:
    if isinstance(max_jitter, bool) or not isinstance(max_jitter, (int, float, np.floating, np.integer)):
        raise ValueError(f"`max_jitter` must be a positive number; got {max_jitter!r}")
    if not (math.isfinite(max_jitter) and max_jitter > 0):
        raise ValueError(f"`max_jitter` must be a positive finite number; got {max_jitter!r}")
    if irregular not in modes:
        raise ValueError(f"`irregular` must be one of {modes}; got {irregular!r}")
    return float(max_jitter)


def _check_columns(source: str, columns: dict[str, np.ndarray], time_name: str):
    """Equal lengths and strictly increasing time."""
    lengths = {k: v.shape[0] for k, v in columns.items()}
    if len(set(lengths.values())) != 1:
        desc = ", ".join(f"`{k}`: {n}" for k, n in lengths.items())
        raise ValueError(f"{source}: variables have different lengths ({desc})")
    t = columns[time_name]
    steps = np.diff(t)
    if not np.all(steps > 0):
        k = int(np.argmax(~(steps > 0)))
        raise ValueError(
            f"{source}: time `{time_name}` must be strictly increasing (t[{k + 1}] = {t[k + 1]} <= t[{k}] = {t[k]})"
        )


def off_step(steps: np.ndarray, median: float, max_jitter: float = MAX_JITTER, resolution: float = 0.0) -> np.ndarray:
    """(N-1,) bool: the sampling steps off the `median` step by more than `max_jitter` relative and 1.5 times the
    `resolution` the time values were stored at (never so loose that a missing sample, a step twice the median,
    passes)."""
    return np.abs(steps - median) > max(max_jitter * median, min(1.5 * resolution, 0.5 * median))


def uniform_sampling(
    source: str,
    columns: dict[str, np.ndarray],
    time_name: str,
    max_jitter: float,
    irregular: str,
    resolution: float = 0.0,
) -> tuple[dict[str, np.ndarray], float, str | None]:
    """Check uniform sampling against the median step; return (columns, dt, resampling description).

    Uniform within `max_jitter`: the columns unchanged and the mean step (for
    time stamps rounded to a few digits it is the most accurate period: the
    rounding errors of the two end points divided by N - 1). Otherwise an
    `IrregularSamplingError`, or with `irregular="resample"` every other
    column linearly interpolated onto `t[0] + k * median` (k = 0, 1, ... up
    to `t[-1]`). With `irregular="jitter"` the same interpolation when every
    step lies within `JITTER_BAND` (0.5 to 1.5) times the median step (time
    stamps that jitter about a fixed period), and an `IrregularSamplingError`
    naming the first step outside it (a gap: a missing sample is twice the
    median step). `resolution` (s): how finely the time values were stored
    (float32, or the digits of a text file); a step is judged irregular only
    beyond both `max_jitter` relative and 1.5 `resolution`, since two stamps
    rounded to that resolution differ from the true step by up to one unit
    (at most half the median step: a missing sample is always caught).
    """
    _check_columns(source, columns, time_name)
    t = columns[time_name]
    n = t.shape[0]
    steps = np.diff(t)
    median = float(np.median(steps))
    bad = off_step(steps, median, max_jitter, resolution)
    if not bad.any():
        return columns, float((t[-1] - t[0]) / (n - 1)), None
    k = int(np.argmax(bad))
    count = int(bad.sum())
    largest = float(steps.max())
    low, high = JITTER_BAND
    gap = (steps < low * median) | (steps > high * median)
    m = int(math.floor((t[-1] - t[0]) / median * (1 + 1e-12))) + 1
    grid = t[0] + np.arange(m) * median
    if irregular == "jitter" and gap.any():
        k, count = int(np.argmax(gap)), int(gap.sum())
        detail = (
            f"{source}: time `{time_name}` has a gap: sample {k + 1} (0-based, t = {t[k + 1]:.9g} s) comes "
            f"{steps[k]:.3g} s after sample {k}, {steps[k] / median:.3g} x the median step {median:.3g} s ({count} of "
            f"{n - 1} steps outside {low:g} to {high:g} x the median, the band taken as stamping jitter and "
            f"resampled; largest step {largest:.3g} s)"
        )
        advice = (
            "resample it explicitly (irregular='resample': linear interpolation onto a uniform grid, gaps bridged "
            "by straight lines) or split it into uniformly sampled records"
        )
        raise IrregularSamplingError(
            detail, advice, index=k + 1, time=float(t[k + 1]), step=float(steps[k]), median=median, count=count
        )
    if irregular == "jitter":
        out = {name: (grid if name == time_name else np.interp(grid, t, col)) for name, col in columns.items()}
        jitter = float(np.max(np.abs(steps - median)) / median)
        note = (
            f"resampled {n} samples with jittered time stamps (steps up to {100 * jitter:.3g} % off the median "
            f"step {median:.3g} s, {count} of {n - 1} beyond {max_jitter:g} relative) onto {m} samples at the "
            "median step by linear interpolation"
        )
        return out, median, note
    if irregular == "error":
        detail = (
            f"{source}: time `{time_name}` is not uniformly sampled: sample {k + 1} (0-based, t = {t[k + 1]:.9g} s) "
            f"comes {steps[k]:.6g} s after sample {k}, the median step is {median:.6g} s "
            f"({count} of {n - 1} steps deviate from it by more than max_jitter = {max_jitter:g} relative"
            + (f" and 1.5 x the {resolution:.3g} s resolution of the stored time values" if resolution else "")
            + f"; largest step {largest:.6g} s)"
        )
        advice = (
            "resample it explicitly (irregular='resample': linear interpolation onto a uniform grid) "
            "or split it into uniformly sampled records"
        )
        raise IrregularSamplingError(
            detail, advice, index=k + 1, time=float(t[k + 1]), step=float(steps[k]), median=median, count=count
        )
    out = {name: (grid if name == time_name else np.interp(grid, t, col)) for name, col in columns.items()}
    note = (
        f"resampled {n} irregular samples ({count} step(s) off the median by more than {max_jitter:g} relative, "
        f"first at sample {k + 1}, t = {t[k + 1]:.9g} s; largest step {largest:.6g} s) onto {m} samples at the "
        f"median step {median:.6g} s by linear interpolation (gaps bridged by straight lines)"
    )
    return out, median, note


@x64
def load_emps(
    path: str | os.PathLike,
    *,
    max_jitter: float = MAX_JITTER,
    irregular: Literal["error", "resample"] = "error",
    variables: dict | None = None,
) -> EMPSData:
    """Read the EMPS benchmark file `DATA_EMPS.mat` (MATLAB v5 format).

    Expects the column vectors `t`, `qm`, `qg`, `vir` (equal length, finite,
    `t` strictly increasing and uniformly sampled) and the scalars `gtau`,
    `kp`, `kv`. The applied force is `force = gtau * vir` (N).

    **Arguments:**

    - `path`: the file.
    - `max_jitter`: tolerance on each step `t[k+1] - t[k]`, relative to the
      median step (default 1e-3: the benchmark file's `t` is rounded to
      single precision, 4e-5 off the median; a missing sample is 100 % off).
    - `irregular`: what to do with a step out of tolerance: `"error"`
      (default) raises `IrregularSamplingError`; `"resample"` interpolates
      `qm`, `qg` and `vir` linearly onto the uniform grid
      `t[0] + k * median step` and records it in `resampled` (a gap is
      bridged by a straight line: meant for clock jitter, not missing data).
      Time stored in single precision is judged at its resolution (a float32
      stamp near 25 s is only known to 2e-6 s), not as jitter.
    - `variables`: the file's names for the benchmark's variables, e.g.
      `{"t": "time", "qm": "position"}` (the others keep their names).

    **Returns:** an `EMPSData`; `dt` is `(t[-1] - t[0]) / (N - 1)` for a
    uniform record (exactly 1 ms for the benchmark file), the median step for
    a resampled one.

    **Raises:** `FileNotFoundError` if `path` does not exist; `ValueError` if
    the file is not a readable .mat file, or a variable is missing, not
    numeric, of the wrong shape or length, or not finite, or for invalid
    options; `IrregularSamplingError` (a `ValueError`) for non-uniform time
    with `irregular="error"`, naming the first bad sample (0-based), its time
    and step.

    Example:
        >>> import os, tempfile
        >>> import numpy as np, scipy.io
        >>> from jaxsdp.data import load_emps
        >>> t = np.arange(100) * 1e-3  # s
        >>> path = os.path.join(tempfile.mkdtemp(), "DATA_EMPS.mat")
        >>> record = dict(t=t, qm=0.1 * t, qg=0.1 * t, vir=np.ones(100), gtau=35.15, kp=160.18, kv=243.45)
        >>> scipy.io.savemat(path, record)
        >>> data = load_emps(path)
        >>> data.t.shape, round(data.dt, 9), float(data.force[0])  # s, N = gtau * vir
        ((100,), 0.001, 35.15)
    """
    max_jitter = check_sampling_options(max_jitter, irregular)
    names = {k: k for k in _EMPS_VECTORS + _EMPS_SCALARS}
    if variables is not None:
        unknown = sorted(set(variables) - set(names)) if isinstance(variables, dict) else None
        if unknown is None or unknown or not all(isinstance(v, str) and v for v in variables.values()):
            raise ValueError(
                f"`variables` maps the benchmark's names {sorted(names)} to the file's (non-empty strings); "
                f"got {variables!r}"
            )
        names.update(variables)
    path = _check_path(path)
    contents = _read_mat(path)
    source = f"EMPS file {path.name}"
    missing = [f"{k}" + (f" (as {names[k]!r})" if names[k] != k else "") for k in names if names[k] not in contents]
    if missing:
        raise ValueError(
            f"{source} is not an EMPS data set: missing variable(s) {missing} (found {sorted(contents)}); "
            "map other names with `variables` (t=time, qm=pos, ...)"
        )
    vectors = {k: _as_vector(source, names[k], contents[names[k]]) for k in _EMPS_VECTORS}
    scalars = {k: _as_scalar(source, names[k], contents[names[k]]) for k in _EMPS_SCALARS}
    resolution = stored_resolution(contents[names["t"]])
    vectors, dt, resampled = uniform_sampling(source, vectors, "t", max_jitter, irregular, resolution)
    return EMPSData(
        t=jnp.asarray(vectors["t"]),
        qm=jnp.asarray(vectors["qm"]),
        qg=jnp.asarray(vectors["qg"]),
        vir=jnp.asarray(vectors["vir"]),
        force=jnp.asarray(scalars["gtau"] * vectors["vir"]),
        gtau=scalars["gtau"],
        kp=scalars["kp"],
        kv=scalars["kv"],
        dt=dt,
        resampled=resampled,
        path=str(path.resolve()),
    )


def _read_csv(path: pathlib.Path, delimiter: str | None) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """The columns of a CSV file with a header (`read_csv_rows`), and each column's text resolution
    (`text_resolution`)."""
    header, rows, lines, sep = read_csv_rows(path, delimiter)
    columns, resolution = {}, {}
    for j, name in enumerate(header):
        values = []
        for row, line in zip(rows, lines):
            try:
                values.append(float(row[j]))
            except ValueError:
                hint = "; the decimal separator must be a point" if "," in row[j] else ""
                raise ValueError(
                    f"`path`: CSV row {line}, column `{name}` of {path} is not a number: {row[j]!r} "
                    f"(fields separated by {sep!r}{hint})"
                ) from None
        columns[name] = np.asarray(values, dtype=np.float64)
        resolution[name] = text_resolution(row[j] for row in rows)
    return columns, resolution


def _check_scale(scale, roles: dict) -> dict[str, float]:
    """Each role's factor to SI units (1 where `scale` is silent); a `ValueError` for an unknown role or a
    factor that is not a finite non-zero number (a positive one for time)."""
    factors = dict.fromkeys(roles, 1.0)
    if scale is None:
        return factors
    if not isinstance(scale, dict) or set(scale) - set(roles):
        raise ValueError(f"`scale` maps roles {sorted(roles)} to factors to SI units; got {scale!r}")
    for role, f in scale.items():
        ok = isinstance(f, (int, float, np.integer, np.floating)) and not isinstance(f, bool)
        if not ok or not math.isfinite(f) or f == 0 or (role == "time" and f < 0):
            raise ValueError(
                f"`scale[{role!r}]` must be a finite non-zero number (positive for time), the factor to SI units; "
                f"got {f!r}"
            )
        factors[role] = float(f)
    return factors


@x64
def load_measurements(
    path: str | os.PathLike,
    *,
    time: str = "t",
    position: str = "q",
    force: str = "force",
    delimiter: str | None = None,
    max_jitter: float = MAX_JITTER,
    irregular: Literal["error", "resample"] = "error",
    scale: dict[str, float] | None = None,
) -> Measurements:
    """Read time, position and force from a CSV file or a .mat file.

    A `.csv` (or any non-`.mat`) file must have a header line naming the
    columns; a `.mat` file must hold vectors with these names.

    **Arguments:**

    - `path`: the file.
    - `time`, `position`, `force`: names of the time (s), position and force
      columns/variables.
    - `delimiter`: CSV field separator (None: the first of `,` `;` tab `|`
      found in the header line). A UTF-8 byte-order mark (spreadsheet
      export) is skipped.
    - `max_jitter`: tolerance on each step `t[k+1] - t[k]`, relative to the
      median step (default 1e-3: passes time stamps rounded to single
      precision or to a few digits, catches a missing sample or a clock slip).
    - `irregular`: what to do with a step out of tolerance: `"error"`
      (default) raises `IrregularSamplingError`; `"resample"` interpolates
      position and force linearly onto the uniform grid
      `t[0] + k * median step` (up to `t[-1]`) and records it in the
      result's `resampled` (a gap is bridged by a straight line: meant for
      clock jitter, not for missing data; split such a record instead).
    - `scale`: factors that bring the columns to SI units, by role:
      `{"time": 1e-3, "position": 1e-3, "force": 35.15}` reads a time in ms,
      a position in mm and a drive voltage with its gain (N/V). Roles not
      named keep factor 1. Applied before the sampling checks, so `dt` and
      every message are in seconds.

    **Returns:** a `Measurements`; `dt` is `(t[-1] - t[0]) / (N - 1)` for a
    uniform record (within `max_jitter` of the median step everywhere, this
    is the most accurate period for rounded time stamps), the median step
    for a resampled one. Non-uniform time is never averaged into `dt`.

    **Raises:** `FileNotFoundError` if `path` does not exist; `ValueError` for
    unreadable files, missing columns, non-numeric or non-finite values,
    unequal lengths, a time column that is not strictly increasing, or
    invalid options; `IrregularSamplingError` (a `ValueError`) for
    non-uniform time with `irregular="error"`, naming the first bad sample
    (0-based), its time and step.

    Example:
        >>> import os, tempfile
        >>> import numpy as np
        >>> from jaxsdp.data import load_measurements
        >>> t = np.arange(100) * 1e-3  # s
        >>> path = os.path.join(tempfile.mkdtemp(), "record.csv")
        >>> np.savetxt(path, np.c_[t, 0.1 * t, np.ones(100)], delimiter=",", header="t,q,force", comments="")
        >>> m = load_measurements(path)
        >>> m.q.shape, round(m.dt, 9), m.resampled
        ((100,), 0.001, None)
    """
    names = {"time": time, "position": position, "force": force}
    for arg, name in names.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"`{arg}` must be a non-empty column name; got {name!r}")
    max_jitter = check_sampling_options(max_jitter, irregular)
    path = _check_path(path)
    if path.suffix.lower() == ".mat":
        contents = _read_mat(path)
        resolution = stored_resolution(contents[time]) if time in contents else 0.0
        kind = "variable"
    else:
        contents, resolutions = _read_csv(path, delimiter)
        resolution = resolutions.get(time, 0.0)
        kind = "column"
    source = f"measurement file {path.name}"
    missing = [f"{name!r} ({arg})" for arg, name in names.items() if name not in contents]
    if missing:
        raise ValueError(
            f"{source}: missing {kind}(s) {', '.join(missing)}; found {sorted(contents)} "
            "(name them with `time`, `position`, `force`)"
        )
    factors = _check_scale(scale, names)
    columns = {name: _as_vector(source, name, contents[name]) * factors[arg] for arg, name in names.items()}
    resolution *= factors["time"]
    columns, dt, resampled = uniform_sampling(source, columns, time, max_jitter, irregular, resolution)
    return Measurements(
        t=jnp.asarray(columns[time]),
        q=jnp.asarray(columns[position]),
        force=jnp.asarray(columns[force]),
        dt=dt,
        resampled=resampled,
        path=str(path.resolve()),
    )


@x64
def load_record(data) -> tuple[EMPSData | Measurements, str]:
    """A position-force record and its name: a path (`.mat`: `load_emps`, else `load_measurements`), or an
    `EMPSData` / `Measurements` as given (named by its type).

    Example:
        >>> from jaxsdp.data import emps_builtin_data, load_record
        >>> record, name = load_record(emps_builtin_data(0)[0])
        >>> name, record.dt  # s
        ('EMPSData', 0.001)
    """
    if isinstance(data, (str, os.PathLike)):
        path = pathlib.Path(data)
        if path.suffix.lower() == ".mat":
            return load_emps(path), path.name
        return load_measurements(path), path.name
    if isinstance(data, (EMPSData, Measurements)):
        return data, type(data).__name__
    raise ValueError(f"`data` must be a path, an EMPSData or a Measurements; got {type(data).__name__}")
