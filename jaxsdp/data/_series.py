"""A time series: one value column of a CSV file (missing values as NaN), its optional time column (numbers,
ISO 8601 dates or compact YYYYMMDD / YYYYMM dates), and the sampling those time stamps imply (`TimeAxis`).

The time-variable models count time in samples; a time column only labels
the samples (and the forecasts beyond them) and says what a period of P
samples is in time. It must therefore be regular: numbers evenly spaced
(within `MAX_JITTER` of the median step, or the stored digits' rounding),
dates evenly spaced in time (milliseconds to weeks, at the stamps' own
precision) or on a calendar step of months (monthly, quarterly, yearly: the
same day of each month, or each month's last day). Stamps with a UTC offset
(`Z`, `+01:00`) must all carry the same one: it is kept aside (the labels
carry it again) and said in the axis' `offset`. A missing sample is a row
whose value is empty (or NA, NaN, null): it stays in the series as NaN. A
missing row is a gap in the time stamps, refused with the row that follows
it: the file should hold the row with an empty value. Every message names
the file's own line numbers.
"""

import math
import pathlib
import re
import warnings
from typing import NamedTuple

import numpy as np

from .._checks import OptionError
from ._csv import read_csv_rows
from ._loaders import MAX_JITTER, off_step, text_resolution
from ._log_tables import TIME

#: Cells that mark a missing value (any case, spaces stripped).
MISSING = frozenset({"", "na", "n/a", "nan", "null", "none", "missing"})
#: Column names taken as the time column when `time_column` is not given (any case): the joint logs' time names
#: (`_log_tables.TIME`: t, time, time_s, t_s, time (s)) and date, datetime, timestamp.
TIME_NAMES = re.compile(rf"{TIME.pattern}|\s*(date|datetime|timestamp)\s*", re.IGNORECASE)
#: Calendar names (any case) taken as the time column only when their stamps increase (a `month` column of 1..12
#: beside a `year` column is no time axis).
CALENDAR_NAMES = re.compile(r"\s*(year|month|quarter|week|day|year_?month|yyyymm|yyyymmdd)\s*", re.IGNORECASE)
_DAY = 86400.0
#: A stamp's UTC offset: Z or +hh[:mm] after a time of day.
_ZONED = re.compile(r"(.*[T ]\d\d(?::\d\d){0,2}(?:[.,]\d+)?)\s*(Z|UTC|[+-]\d\d(?::?\d\d)?)", re.IGNORECASE)
_UNITS = ("Y", "M", "W", "D", "h", "m", "s", "ms", "us", "ns")


def _label_unit(stamps: np.ndarray) -> str:
    """The coarsest of day, minute, second, ms, us, ns that writes every stamp exactly."""
    offset = stamps - stamps.astype("datetime64[D]")
    for unit in ("D", "m", "s", "ms", "us", "ns"):
        if not (offset % np.timedelta64(1, unit)).astype(np.int64).any():
            return unit
    return "ns"


def _duration(seconds: float, scale: float | None = None) -> str:
    """`seconds` in days, h, min or s: the largest unit not above `scale` (default: `seconds`)."""
    scale = seconds if scale is None else scale
    for size, unit in ((_DAY, "day"), (3600.0, "h"), (60.0, "min"), (1.0, "s")):
        if scale >= size or size == 1.0:
            v = seconds / size
            return f"{v:.6g} {unit}{'s' * (unit == 'day' and v != 1)}"
    raise AssertionError("unreachable")


class TimeAxis(NamedTuple):
    """The time of each sample of a regular series, and of the samples after it (forecasts).

    `stamps`: (N,) float64 numbers or datetime64 dates (to the second, or finer as the data's own precision),
    None for a series known by its sample numbers only; `step`: the step of numbers, or of dates in seconds
    (None for calendar months); `months`: a calendar step in months (dates only; 0 otherwise); `month_end`:
    each stamp is its month's last day; `name`: the time column (or "dt"); `offset`: the UTC offset the file's
    stamps carried ("+01:00", "Z"; "" without), written again after the labels' time of day.
    """

    stamps: np.ndarray | None
    step: float | None
    months: int = 0
    month_end: bool = False
    name: str = ""
    offset: str = ""

    @property
    def kind(self) -> str:
        """ "index" (no time), "number" or "date"."""
        if self.stamps is None:
            return "index"
        return "date" if np.issubdtype(self.stamps.dtype, np.datetime64) else "number"

    def at(self, k) -> np.ndarray | None:
        """The time of the samples `k` (sample numbers >= 0, past the data too), None without time."""
        k = np.asarray(k, dtype=np.int64)
        if self.stamps is None:
            return None
        n = self.stamps.shape[0]
        inside = np.clip(k, 0, n - 1)
        last, beyond = self.stamps[-1], k - (n - 1)
        if self.kind == "number":
            return np.where(k < n, self.stamps[inside], last + beyond * self.step)
        unit = self.stamps.dtype
        if self.months:
            month = last.astype("datetime64[M]") + beyond * self.months
            if self.month_end:
                ahead = (month + 1).astype(unit) - (last.astype("datetime64[M]") + 1).astype(unit)
            else:
                ahead = month.astype(unit) - last.astype("datetime64[M]").astype(unit)
            extended = last + ahead
        else:
            extended = last + beyond * (self.stamps[1] - self.stamps[0])  # the steps are equal: checked
        return np.where(k < n, self.stamps[inside], extended)

    def labels(self, values) -> list:
        """Time stamps as summary.json holds them: ISO 8601 dates (to the day, minute, second or the fraction
        of a second the data need, with the file's UTC offset), numbers, or None each without time."""
        values = np.atleast_1d(values)
        if self.stamps is None:
            return [None] * values.shape[0]
        if self.kind == "number":
            return [float(v) for v in values]
        unit = _label_unit(self.stamps)
        zone = self.offset if unit != "D" else ""
        return [str(v) + zone for v in np.datetime_as_string(values.astype(self.stamps.dtype), unit=unit)]

    def label(self, value) -> str | float | None:
        """One time stamp as `labels` writes it."""
        return self.labels([value])[0]

    def step_text(self) -> str:
        """The step in words: "1 month", "7 days", "0.1 s", "0.001 (units of t)", "1 sample"."""
        return "1 sample" if self.stamps is None else self.span(1.0)

    def span(self, samples: float) -> str:
        """`samples` samples in time: "12 months (1 year)", "7 days (1 week)", "0.012 (units of t)"."""
        if self.stamps is None:
            return f"{samples:g} samples"
        if self.kind == "number":
            return f"{samples * self.step:.6g} (units of {self.name})"
        if self.months:
            n = samples * self.months
            years = f" ({n / 12:g} year{'s' * (n != 12)})" if n % 12 == 0 else ""
            return f"{n:g} month{'s' * (n != 1)}{years}"
        text = _duration(samples * self.step, self.step)
        return text + (" (1 week)" if text == "7 days" else "")


def _parse_date(cell: str):
    """(datetime64, UTC offset text or None) of an ISO 8601 date, None if it is not one (numpy's own parsing
    of offsets, deprecated and silently shifting, never runs)."""
    text = cell.strip().replace(" ", "T", 1)
    m = _ZONED.fullmatch(text)
    zone = None
    if m is not None:
        text, zone = m.group(1), m.group(2).upper()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            return np.datetime64(text.replace(",", ".")), zone
    except (ValueError, Warning):
        return None


def _zone_minutes(zone: str | None) -> int | None:
    if zone is None:
        return None
    if zone in ("Z", "UTC"):
        return 0
    digits = zone[1:].replace(":", "")
    minutes = 60 * int(digits[:2]) + int(digits[2:] or 0)
    return minutes if zone[0] == "+" else -minutes


def _finest(dates) -> str:
    """The finest unit of datetime64 values, the second at least."""
    return _UNITS[max(_UNITS.index(np.datetime_data(d.dtype)[0]) for d in dates + [np.datetime64(0, "s")])]


def _dates(values) -> np.ndarray | None:
    """ISO 8601 date strings as datetime64 (seconds, or the data's finer unit), None if one does not parse as a
    date (offsets are checked by `_stamps`)."""
    parsed = [_parse_date(v) for v in values]
    if any(p is None for p in parsed):
        return None
    dates = [d for d, _ in parsed]
    return np.array(dates, dtype=f"datetime64[{_finest(dates)}]")


_COMPACT = {8: re.compile(r"(\d{4})(\d\d)(\d\d)"), 6: re.compile(r"(\d{4})(\d\d)")}


def _compact(cells) -> np.ndarray | None:
    """Compact dates, every cell YYYYMMDD (or every cell YYYYMM), a valid date of the years 1600 to 2399, as
    datetime64[s]; None otherwise."""
    width = {len(c.strip()) for c in cells}
    if len(width) != 1 or (n := width.pop()) not in _COMPACT:
        return None
    out = []
    for c in cells:
        m = _COMPACT[n].fullmatch(c.strip())
        if m is None or not 1600 <= int(m.group(1)) <= 2399:
            return None
        try:
            out.append(np.datetime64("-".join(m.groups()), "s"))
        except ValueError:  # month 13, day 31 of a 30-day month
            return None
    return np.array(out)


def _regular_numbers(t: np.ndarray) -> bool:
    steps = np.diff(t)
    return bool(np.all(steps > 0) and not off_step(steps, float(np.median(steps))).any())


class _Where(NamedTuple):
    """How messages name the stamps: a file's time column and its rows (their line numbers), or a Python
    argument and its samples (0-based)."""

    what: str
    rows: tuple | None

    def at(self, k: int) -> str:
        return f"row {self.rows[k]}" if self.rows is not None else f"sample {k}"


def _gap(where: _Where, k: int, what: str, usual: str, labels) -> ValueError:
    return ValueError(
        f"{where.what} is not regular: {where.at(k + 1)} ({labels[k + 1]}) comes {what} after {where.at(k)} "
        f"({labels[k]}), where the usual step is {usual}; the models count time in samples: if samples are missing, "
        "add them with an empty value (NaN), else resample the series onto a regular grid"
    )


def time_axis(stamps, *, name: str = "time", rows=None, resolution: float = 0.0) -> TimeAxis:
    """The `TimeAxis` of time stamps (numbers or datetime64), after checking they increase on a regular step.

    `name`: the argument (or, with `rows`, the file's time column) the messages name, with its samples (or
    `rows`: the file's line number of each stamp); `resolution`: how finely numeric stamps were stored (a step
    within 1.5 of it of the median is regular). ValueError naming the first irregular sample.
    """
    rows = None if rows is None else tuple(rows)
    where = _Where(f"time column {name!r}" if rows is not None else f"`{name}`", rows)
    t = np.asarray(stamps)
    if t.ndim != 1 or t.shape[0] < 2:
        raise ValueError(f"{where.what} must be one stamp per sample, at least 2; got shape {t.shape}")
    if np.issubdtype(t.dtype, np.datetime64):
        return _date_axis(t.astype(f"datetime64[{_finest([t[:1]])}]"), name, where)
    t = t.astype(np.float64)
    if not np.all(np.isfinite(t)):
        k = int(np.argmax(~np.isfinite(t)))
        raise ValueError(f"{where.what}: {where.at(k)} is not a finite number ({t[k]})")
    steps = np.diff(t)
    if not np.all(steps > 0):
        k = int(np.argmax(~(steps > 0)))
        raise ValueError(f"{where.what} must increase: {where.at(k + 1)} ({t[k + 1]:g}) <= {where.at(k)} ({t[k]:g})")
    median = float(np.median(steps))
    bad = off_step(steps, median, MAX_JITTER, resolution)
    if bad.any():
        k = int(np.argmax(bad))
        raise _gap(where, k, f"{steps[k]:.6g}", f"{median:.6g}", [f"{v:.9g}" for v in t])
    return TimeAxis(stamps=t, step=float((t[-1] - t[0]) / (t.shape[0] - 1)), name=name)


def _date_axis(t: np.ndarray, name: str, where: _Where) -> TimeAxis:
    labels = list(np.datetime_as_string(t, unit=_label_unit(t)))
    steps = np.diff(t)
    seconds = steps / np.timedelta64(1, "s")
    if not np.all(seconds > 0):
        k = int(np.argmax(~(seconds > 0)))
        raise ValueError(f"{where.what} must increase: {where.at(k + 1)} ({labels[k + 1]}) <= {where.at(k)}")
    if np.all(steps == steps[0]):
        return TimeAxis(stamps=t, step=float(seconds[0]), name=name)
    months = t.astype("datetime64[M]")
    month_steps = np.diff(months).astype(np.int64)
    start = t - months.astype(t.dtype)  # the offset into each month
    end = (months + 1).astype(t.dtype) - t  # and to the next month
    for offset, month_end in ((start, False), (end, True)):
        if np.all(offset == offset[0]) and np.all(month_steps == month_steps[0]) and month_steps[0] > 0:
            return TimeAxis(stamps=t, step=None, months=int(month_steps[0]), month_end=month_end, name=name)
    if np.all(start == start[0]) or np.all(end == end[0]):  # calendar months, one step off
        usual = int(np.median(month_steps))
        k = int(np.argmax(month_steps != usual))
        raise _gap(where, k, f"{month_steps[k]} month(s)", f"{usual} month(s)", labels)
    usual = float(np.median(seconds))
    k = int(np.argmax(seconds != usual))
    raise _gap(where, k, _duration(float(seconds[k]), usual), _duration(usual), labels)


class SeriesFile(NamedTuple):
    """A series read from a file (`read_series`): `y` (N,) values, NaN where missing; `axis` the `TimeAxis`
    (of the time column, or of sample numbers); `column`, `time_column` (None without one) their names;
    `columns` every column of the file; `path`; `notes`: how the time column was read, when it needed saying
    (compact dates, a UTC offset). An unnamed column is named `column k` (1-based) here."""

    y: np.ndarray
    axis: TimeAxis
    column: str
    time_column: str | None
    columns: tuple
    path: str
    notes: tuple = ()


def _number(cell: str) -> float | None:
    """A cell as a number (NaN when missing), None when it is not one."""
    if cell.strip().lower() in MISSING:
        return math.nan
    try:
        return float(cell)
    except ValueError:
        return None


def _read_rows(path: pathlib.Path, delimiter: str | None):
    """The header, the columns (lists of cells) and each row's line number in the file."""
    table = read_csv_rows(path, delimiter, prefix="", name=path.name, blank_cells=True)
    header, rows = table.header, table.rows
    if all(_number(c) is not None and c.strip() for c in header):
        raise ValueError(f"{path.name}: the first line must be a header naming the columns; got {header}")
    if len(rows) < 2:
        raise ValueError(f"{path.name}: {len(rows)} data row(s); a series needs more")
    return header, [[r[j] for r in rows] for j in range(len(header))], table.lines


def _is_text(cells) -> bool:
    """No cell is a number (or missing): a text column (labels, dates)."""
    return all(_number(c) is None for c in cells if c.strip().lower() not in MISSING)


def _is_row_index(name: str, cells) -> bool:
    """An unnamed column 0, 1, 2, ... (a spreadsheet's or pandas' row index)."""
    return not name and all(c.strip() == str(i) for i, c in enumerate(cells))


def _increasing(cells) -> bool:
    """Every cell a number (or a date) and the stamps strictly increasing: a column that can be a time axis."""
    if any(c.strip().lower() in MISSING for c in cells):
        return False
    numbers = [_number(c) for c in cells]
    if all(v is not None for v in numbers):
        t = _compact(cells)
        t = np.asarray(numbers) if t is None else t
    else:
        t = _dates(cells)
    if t is None:
        return False
    steps = np.diff(t)
    return bool(np.all(steps > steps.dtype.type(0)))


def _time_column(path, header, columns, time_column) -> int | None:
    found = ", ".join(repr(h) for h in header)
    if time_column is not None:
        if time_column not in header:
            raise OptionError(f"`time_column` {time_column!r} is not a column of {path.name} (columns: {found})")
        return header.index(time_column)
    named = [j for j, h in enumerate(header) if TIME_NAMES.fullmatch(h)]
    calendar = [j for j, h in enumerate(header) if CALENDAR_NAMES.fullmatch(h) and _increasing(columns[j])]
    dated = [j for j, c in enumerate(columns) if j not in named and _is_text(c) and _dates(c) is not None]
    candidates = named or calendar or dated
    if len(candidates) > 1:
        names = ", ".join(repr(header[j]) for j in candidates)
        raise OptionError(f"{path.name} has several time columns ({names}); name one with `time_column`")
    return candidates[0] if candidates else None


def _stamps(path, name: str, cells, lines) -> tuple[np.ndarray, list[str], str]:
    """The time column's stamps (numbers, or dates), what needs saying about how they were read, and their UTC
    offset ("" without)."""
    missing = [i for i, c in enumerate(cells) if c.strip().lower() in MISSING]
    if missing:
        raise ValueError(
            f"{path.name}: time column {name!r} is empty at row {lines[missing[0]]} "
            f"({cells[missing[0]].strip() or 'an empty cell'}): every row needs its time stamp; a missing sample "
            "is a row with its time and an empty value"
        )
    numbers = [_number(c) for c in cells]
    if all(v is not None and math.isfinite(v) for v in numbers):
        t = np.asarray(numbers, dtype=np.float64)
        compact = _compact(cells)
        if compact is not None and (not _regular_numbers(t) or "date" in name.lower()):
            width = "YYYYMMDD" if len(cells[0].strip()) == 8 else "YYYYMM"
            return compact, [f"time column {name!r} read as compact dates ({width})"], ""
        return t, [], ""
    parsed = [_parse_date(c) for c in cells]
    if any(p is None for p in parsed):
        i = next(i for i, (c, p) in enumerate(zip(cells, parsed)) if p is None and _number(c) is None)
        raise ValueError(
            f"{path.name}: time column {name!r} holds {cells[i].strip()!r} at row {lines[i]}, neither a number nor "
            "an ISO 8601 date (1958-03-01, 2020-01-31 06:00, 2020-01-31T06:00:00.250)"
        )
    zones = [_zone_minutes(z) for _, z in parsed]
    k = next((i for i, z in enumerate(zones) if z != zones[0]), None)
    if k is not None:
        said = [parsed[i][1] or "no UTC offset" for i in (0, k)]
        raise ValueError(
            f"{path.name}: time column {name!r}: row {lines[k]} has {said[1]}, row {lines[0]} {said[0]}: the stamps "
            "must share one UTC offset (a change of daylight saving time shifts the hour): write them all in UTC "
            "(Z) or all without an offset"
        )
    dates = [d for d, _ in parsed]
    stamps = np.array(dates, dtype=f"datetime64[{_finest(dates)}]")
    zone = parsed[0][1]
    if zone is None:
        return stamps, [], ""
    return stamps, [f"time stamps at UTC offset {zone}, read as the local times they write"], zone


def _value_column(path, header, columns, column, time) -> int:
    found = ", ".join(repr(h) for h in header)
    if column is not None:
        if column not in header:
            raise OptionError(f"`column` {column!r} is not a column of {path.name} (columns: {found})")
        j = header.index(column)
        if j == time:
            raise OptionError(f"`column` {column!r} is the time column of {path.name}; name the values' column")
        if _is_text(columns[j]):
            first = next((c for c in columns[j] if c.strip()), "")
            numeric = ", ".join(
                repr(h) for i, (h, c) in enumerate(zip(header, columns)) if i != time and not _is_text(c)
            )
            raise OptionError(
                f"`column` {column!r} of {path.name} holds no numbers (first value {first!r}); its numeric columns: "
                f"{numeric or 'none'}"
            )
        return j
    numeric = [
        j for j, (h, c) in enumerate(zip(header, columns)) if j != time and not _is_text(c) and not _is_row_index(h, c)
    ]
    if len(numeric) != 1:
        what = "no numeric column" if not numeric else "several numeric columns"
        names = ", ".join(repr(header[j]) for j in numeric)
        dated = [repr(header[j]) for j in numeric if time is None and _compact(columns[j]) is not None]
        hint = f"; {', '.join(dated)} may be the time (YYYYMMDD dates): name it with `time_column`" if dated else ""
        raise OptionError(
            f"{path.name} has {what}{f' ({names})' if numeric else ''} besides the time column; name the series "
            f"with `column` (columns: {found}){hint}"
        )
    return numeric[0]


def read_series(path, *, column: str | None = None, time_column: str | None = None, delimiter=None) -> SeriesFile:
    """One series of a CSV file with a header: its `column` (default: the only numeric column besides the time
    column), missing values (empty, NA, NaN, null) as NaN, and its time column (`time_column`, default the one
    named t, time, date, ..., an increasing year, month, ... column, or the one holding ISO dates) as a checked
    `TimeAxis`.

    ValueError (data) for an unreadable file, a cell that is not a number, a missing or irregular time stamp,
    each naming the file's line; `OptionError` for a `column` or `time_column` the file does not have or that
    does not fit (each lists the columns).
    """
    path = pathlib.Path(path)
    header, columns, lines = _read_rows(path, delimiter)
    time = _time_column(path, header, columns, time_column)
    j = _value_column(path, header, columns, column, time)
    name = header[j]
    values = []
    for line, cell in zip(lines, columns[j]):
        v = _number(cell)
        if v is None or math.isinf(v):
            raise ValueError(
                f"{path.name}: row {line}, column {name!r} is not a number: {cell.strip()!r} (a missing value is "
                "an empty cell, NA or NaN; the decimal separator a point)"
            )
        values.append(v)
    y = np.asarray(values, dtype=np.float64)
    time_name, notes = None, []
    if time is None:
        axis = TimeAxis(stamps=None, step=None)
    else:
        time_name = header[time] or f"column {time + 1}"  # pandas writes its index's column unnamed
        stamps, notes, zone = _stamps(path, time_name, columns[time], lines)
        resolution = text_resolution(columns[time]) if stamps.dtype == np.float64 else 0.0
        try:
            axis = time_axis(stamps, name=time_name, rows=lines, resolution=resolution)
        except ValueError as e:
            raise ValueError(f"{path.name}: {e}") from None
        if not header[time]:
            axis = axis._replace(name="date" if axis.kind == "date" else "time")
        axis = axis._replace(offset=zone)
    return SeriesFile(
        y=y,
        axis=axis,
        column=name,
        time_column=time_name,
        columns=tuple(header),
        path=str(path),
        notes=tuple(notes),
    )


__all__ = ["CALENDAR_NAMES", "MISSING", "TIME_NAMES", "SeriesFile", "TimeAxis", "read_series", "time_axis"]
