"""The CSV reader as it was before it streamed (symbolic.data.files.read_csv up to issue 22, item 20): the whole
file decoded, split into lines and parsed at once. Kept verbatim as the reference the streaming reader must equal
(tests/test_csv_streaming.py) and as the "before" of bench/csv_load.py. Not used by the package.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from symbolic.data.errors import DataError
from symbolic.data.files import Table
from symbolic.errors import shorten


def read_csv(path: Path, columns: Sequence[str] | None = None, named_by: str = "<python>") -> Table:
    """CSV: lines starting with ``#`` before the header are comments; then a header line of names —
    or, when ``columns`` is given, no header line: every line is a row of numbers, named by ``columns``.

    A file whose first line is numbers and no ``columns`` is refused with a message saying so and how
    to name the columns (a numeric first line read as names would make names of numbers)."""
    source = str(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise DataError(source, "file", f"cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise DataError(source, "file", "CSV file is not UTF-8 text") from None
    lines = text.splitlines()
    first = next((i for i, line in enumerate(lines) if line.strip() and not line.lstrip().startswith("#")), None)
    if first is None:
        what = "no rows" if columns is not None else "no header line (expected comma-separated column names, e.g. t,q_q,tau_q)"
        raise DataError(source, "header" if columns is None else "rows", what)
    fields = [name.strip() for name in next(csv.reader([lines[first]]))]
    if columns is None:
        if _numbers(fields):
            raise DataError(
                source, "header",
                f"the first line {shorten(lines[first].strip(), 60)} is numbers: the file has no header line; name its "
                f"{len(fields)} columns in an experiment file, columns = [\"t\", \"q1\", ...] ({len(fields)} names, "
                "in file order; docs/data.md), or add a header line of names (e.g. t,q_q,tau_q)")
        header, start = fields, first + 1
    else:
        if not _numbers(fields):
            raise DataError(named_by, "columns", f"{path.name} has a header line ({shorten(lines[first].strip(), 60)}); "
                                                 "columns is for a CSV file without one: leave out columns, or remove "
                                                 "the header line")
        if len(fields) != len(columns):
            raise DataError(named_by, "columns", f"names {len(columns)} column(s), but the lines of {path.name} have "
                                                 f"{len(fields)} field(s) (line {first + 1}); give one name per column")
        header, start = list(columns), first
    _check_names(header, source)
    body = [(i + 1, line) for i, line in enumerate(lines[start:], start=start) if line.strip()]
    values = _parse_rows(body, header, source)
    table = Table(source)
    for j, name in enumerate(header):
        table.vectors[name] = values[:, j]
    return table


def _numbers(fields: list[str]) -> bool:
    """Whether a line's fields are a row of numbers (empty fields aside: a trailing comma), not names."""
    given = [f for f in fields if f]
    try:
        [float(f) for f in given]
    except ValueError:
        return False
    return bool(given)


def _check_names(header: list[str], source: str) -> None:
    seen = set()
    for j, name in enumerate(header):
        if not name:
            raise DataError(source, "header", f"column {j + 1} has no name")
        if name in seen:
            raise DataError(source, "header", f"column name {name!r} appears twice")
        seen.add(name)


def _parse_rows(body: list[tuple[int, str]], header: list[str], source: str) -> np.ndarray:
    if not body:
        return np.empty((0, len(header)))
    try:  # fast path; on any problem the slow path below says where
        values = np.loadtxt(io.StringIO("\n".join(line for _, line in body)), delimiter=",", ndmin=2)
        if values.shape[1] == len(header):
            return values
    except ValueError:
        pass
    values = np.empty((len(body), len(header)))
    for row, (lineno, fields) in enumerate(zip((n for n, _ in body), csv.reader(line for _, line in body))):
        if len(fields) != len(header):
            raise DataError(
                source,
                f"line {lineno}",
                f"length mismatch: {len(fields)} fields, the header has {len(header)} ({', '.join(header)})",
            )
        for j, text in enumerate(fields):
            try:
                values[row, j] = float(text)
            except ValueError:
                raise DataError(
                    source, f"line {lineno} column {header[j]!r}", f"cannot read {text.strip()!r} as a number"
                ) from None
    return values
