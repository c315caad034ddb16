"""Loading the EMPS benchmark data set and generic measurement files."""

import csv
import os
import pathlib

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._runtime import x64

_EMPS_VECTORS = ("t", "qm", "qg", "vir")
_EMPS_SCALARS = ("gtau", "kp", "kv")


class EMPSData(eqx.Module):
    """The EMPS estimation data set (Janot, Gautier & Brunot, 2019).

    **Fields:**

    - `t`: time (s), shape `(N,)`, strictly increasing.
    - `qm`: measured motor position on the load side (m).
    - `qg`: reference position of the closed loop (m).
    - `vir`: controller output voltage (V).
    - `force`: applied force `gtau * vir` (N).
    - `gtau`: drive gain (N/V).
    - `kp`: outer position-loop gain (1/s).
    - `kv`: inner velocity-loop gain (V/(m/s)).
    - `dt`: sampling period (s), `(t[-1] - t[0]) / (N - 1)`.
    """

    t: Float[Array, " N"]
    qm: Float[Array, " N"]
    qg: Float[Array, " N"]
    vir: Float[Array, " N"]
    force: Float[Array, " N"]
    gtau: float
    kp: float
    kv: float
    dt: float


class Measurements(eqx.Module):
    """Sampled position and force measurements read by `load_measurements`.

    **Fields:** `t` time (s), `q` position, `force` force/torque, all shape
    `(N,)`; `dt` the mean sampling period `(t[-1] - t[0]) / (N - 1)` (s).
    """

    t: Float[Array, " N"]
    q: Float[Array, " N"]
    force: Float[Array, " N"]
    dt: float


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


def _check_columns(source: str, columns: dict[str, np.ndarray], time_name: str) -> float:
    """Equal lengths and strictly increasing time; return the mean step."""
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
    return float((t[-1] - t[0]) / (t.shape[0] - 1))


@x64
def load_emps(path: str | os.PathLike) -> EMPSData:
    """Read the EMPS benchmark file `DATA_EMPS.mat` (MATLAB v5 format).

    Expects the column vectors `t`, `qm`, `qg`, `vir` (equal length, finite,
    `t` strictly increasing) and the scalars `gtau`, `kp`, `kv`. The applied
    force is `force = gtau * vir` (N).

    **Returns:** an `EMPSData`.

    **Raises:** `FileNotFoundError` if `path` does not exist; `ValueError` if
    the file is not a readable .mat file, or a variable is missing, not
    numeric, of the wrong shape or length, or not finite.
    """
    path = _check_path(path)
    contents = _read_mat(path)
    source = f"EMPS file {path.name}"
    missing = [k for k in _EMPS_VECTORS + _EMPS_SCALARS if k not in contents]
    if missing:
        raise ValueError(f"{source} is not an EMPS data set: missing variable(s) {missing} (found {sorted(contents)})")
    vectors = {k: _as_vector(source, k, contents[k]) for k in _EMPS_VECTORS}
    scalars = {k: _as_scalar(source, k, contents[k]) for k in _EMPS_SCALARS}
    dt = _check_columns(source, vectors, "t")
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
    )


def _read_csv(path: pathlib.Path, delimiter: str) -> dict[str, np.ndarray]:
    try:
        with open(path, newline="") as f:
            reader = csv.reader(f, delimiter=delimiter)
            try:
                header = next(reader)
            except StopIteration:
                raise ValueError(f"`path`: CSV file {path} is empty") from None
            rows = [row for row in reader if row and any(c.strip() for c in row)]
    except UnicodeDecodeError as e:
        raise ValueError(f"`path`: could not read {path} as a text CSV file ({e})") from None
    header = [h.strip() for h in header]
    if len(set(header)) != len(header):
        raise ValueError(f"`path`: CSV header of {path} has duplicate column names: {header}")
    for i, row in enumerate(rows):
        if len(row) != len(header):
            raise ValueError(f"`path`: CSV row {i + 2} of {path} has {len(row)} fields, the header has {len(header)}")
    columns = {}
    for j, name in enumerate(header):
        values = []
        for i, row in enumerate(rows):
            try:
                values.append(float(row[j]))
            except ValueError:
                raise ValueError(
                    f"`path`: CSV row {i + 2}, column `{name}` of {path} is not a number: {row[j]!r}"
                ) from None
        columns[name] = np.asarray(values, dtype=np.float64)
    return columns


@x64
def load_measurements(
    path: str | os.PathLike,
    *,
    time: str = "t",
    position: str = "q",
    force: str = "force",
    delimiter: str = ",",
) -> Measurements:
    """Read time, position and force from a CSV file or a .mat file.

    A `.csv` (or any non-`.mat`) file must have a header line naming the
    columns; a `.mat` file must hold vectors with these names.

    **Arguments:**

    - `path`: the file.
    - `time`, `position`, `force`: names of the time (s), position and force
      columns/variables.
    - `delimiter`: CSV field separator.

    **Returns:** a `Measurements` (`dt` is the mean sampling period).

    **Raises:** `FileNotFoundError` if `path` does not exist; `ValueError` for
    unreadable files, missing columns, non-numeric or non-finite values,
    unequal lengths, or a time column that is not strictly increasing.
    """
    names = {"time": time, "position": position, "force": force}
    for arg, name in names.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"`{arg}` must be a non-empty column name; got {name!r}")
    path = _check_path(path)
    if path.suffix.lower() == ".mat":
        contents = _read_mat(path)
        kind = "variable"
    else:
        contents = _read_csv(path, delimiter)
        kind = "column"
    source = f"measurement file {path.name}"
    missing = [f"{name!r} ({arg})" for arg, name in names.items() if name not in contents]
    if missing:
        raise ValueError(f"{source}: missing {kind}(s) {', '.join(missing)}; found {sorted(contents)}")
    columns = {name: _as_vector(source, name, contents[name]) for name in names.values()}
    dt = _check_columns(source, columns, time)
    return Measurements(
        t=jnp.asarray(columns[time]),
        q=jnp.asarray(columns[position]),
        force=jnp.asarray(columns[force]),
        dt=dt,
    )
