"""Reading the cells of a CSV file with a header, shared by the measurement loader (`_loaders.load_measurements`)
and the series reader (`_series.read_series`): a UTF-8 byte-order mark skipped, the separator sniffed from the
header line, the header's names distinct, every row as wide as the header, each row's line in the file kept for
the messages."""

import csv
import pathlib
from typing import NamedTuple

#: Field separators tried, in this order, when `delimiter` is None.
DELIMITERS = (",", ";", "\t", "|")


def _sniff(header_line: str) -> str:
    """The separator of a CSV file from its header line: the first of `DELIMITERS` it contains, else ","."""
    return next((d for d in DELIMITERS if d in header_line), ",")


class CSVRows(NamedTuple):
    """The cells of a CSV file with a header (`read_csv_rows`): `header` (stripped names), `rows` (lists of
    cells), `lines` (each row's line number in the file, 1-based) and `sep` (the field separator)."""

    header: list
    rows: list
    lines: list
    sep: str


def read_csv_rows(
    path: pathlib.Path, delimiter: str | None, *, prefix: str = "`path`: ", name: str | None = None, blank_cells=False
) -> CSVRows:
    """The header and rows of a CSV file: a UTF-8 byte-order mark skipped, blank lines before the header, at the
    end and (unless `blank_cells`) inside skipped, the separator `delimiter` or sniffed from the header line
    (`_sniff`), the header's names distinct and every row as wide as the header. `blank_cells`: in a one-column
    file, a blank line inside is a row with one empty cell (a missing value). Messages start with `prefix` and
    name the file `name` (default: `path`) and the file's line numbers."""
    name = str(path) if name is None else name
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            text = f.read()
    except UnicodeDecodeError as e:
        raise ValueError(f"{prefix}could not read {name} as a text CSV file ({e})") from None
    lines = text.splitlines()
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None:
        raise ValueError(f"{prefix}CSV file {name} is empty")
    sep = _sniff(lines[first]) if delimiter is None else delimiter
    reader = csv.reader(lines[first:], delimiter=sep)
    header = [h.strip() for h in next(reader)]
    rows, numbers = [], []
    for row in reader:
        if not any(c.strip() for c in row):
            if not (blank_cells and len(header) == 1):
                continue
            row = [""]
        rows.append(row)
        numbers.append(first + reader.line_num)
    if blank_cells:  # blank lines at the end are no missing values
        while rows and not rows[-1][0].strip() and lines[numbers[-1] - 1].strip() == "":
            rows.pop()
            numbers.pop()
    if len(set(header)) != len(header):
        raise ValueError(f"{prefix}CSV header of {name} has duplicate column names: {header}")
    for row, line in zip(rows, numbers):
        if len(row) != len(header):
            raise ValueError(
                f"{prefix}CSV row {line} of {name} has {len(row)} fields, the header has {len(header)} "
                f"(fields separated by {sep!r})"
            )
    return CSVRows(header, rows, numbers, sep)


__all__ = ["DELIMITERS", "CSVRows", "read_csv_rows"]
