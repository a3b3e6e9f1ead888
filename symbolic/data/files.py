"""Reading and writing data files: CSV (with a header line, or without one when the experiment names the
columns), NumPy ``.npz``, MATLAB ``.mat`` (v5), and ROS 2 bags and MCAP files (:mod:`symbolic.data.bags`, whose
topics an experiment maps).

A file is read into a :class:`Table`: its vectors (one value per sample), its scalars (MATLAB's
1×1 variables such as ``gtau``, usable as constants) and the variables that are neither (kept by
name so that an expression using one gets a precise message).
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import os
import struct
import tomllib
import warnings
import zipfile
import zlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from symbolic.data import bags
from symbolic.data.errors import DataError
from symbolic.errors import SHOWN, listing, one_line, shorten
from symbolic.writing import replacing

EXCERPT = SHOWN
"""Characters of a data file's content (a line, a column name, a field) an error message quotes at most."""
MAT_MAGIC = b"MATLAB 5.0 MAT-file"
ZIP_MAGIC = b"PK\x03\x04"


@dataclass
class Table:
    """The variables of one data file, by name, in file order."""

    source: str
    vectors: dict[str, np.ndarray] = field(default_factory=dict)
    scalars: dict[str, float] = field(default_factory=dict)
    unusable: dict[str, str] = field(default_factory=dict)
    labels: dict[str, str] = field(default_factory=dict)
    """How a message names a variable when it is not its name (a bag's topic reference, by its variable)."""

    def names(self) -> list[str]:
        """Every variable name of the file (vectors, scalars, unusable)."""
        return [*self.vectors, *self.scalars, *self.unusable]

    def shown(self, name: str) -> str:
        """``name`` as the user wrote it (:attr:`labels`)."""
        return self.labels.get(name, name)


def excerpt(text: str) -> str:
    """A piece of a data file's content for an error message: stripped, quoted and escaped (``repr``), and past
    :data:`EXCERPT` characters its beginning and its length. An error says where and what is wrong; it does
    not copy the file, which may not be the one the user meant (a link to another file) and whose text would
    land in logs and reports."""
    return shorten(text.strip(), EXCERPT)


def kind(path: Path) -> str:
    """The reader of ``path`` (a key of :data:`READERS`) or ``"experiment"``: by suffix, else by the file's first
    bytes (:attr:`Reader.magic`).

    Raises
    ------
    DataError
        If neither the suffix nor the content tells.
    """
    suffix = path.suffix.lower()
    if path.is_dir():
        for name, reader in READERS.items():
            if reader.folder and (path / reader.folder).is_file():
                return name
        raise DataError(str(path), "file", "a folder, not a data file (allowed: a rosbag2 folder, which holds "
                                           f"{bags.METADATA}, or a data file)")
    for name, reader in READERS.items():
        if suffix in reader.suffixes:
            return name
    if suffix == ".toml":
        return "experiment"
    head = _head(path)
    for name, reader in READERS.items():
        if reader.magic and head.startswith(reader.magic):
            return name
    allowed = ", ".join(r.described for r in READERS.values())
    raise DataError(str(path), "file", f"unknown file type {suffix or '(no suffix)'!r} (allowed: data files {allowed}, "
                                       "or an experiment file .toml)")


def _head(path: Path) -> bytes:
    try:
        with path.open("rb") as f:
            return f.read(64)
    except OSError as exc:
        raise DataError(str(path), "file", f"cannot read: {exc.strerror}") from None


def exists(path: Path) -> bool:
    """Whether ``path`` is a data file or a data folder (a rosbag2 bag)."""
    return path.is_file() or bags.is_bag(path)


def mapped(path: Path) -> bool:
    """Whether ``path`` is read through an experiment's mapping (:attr:`Reader.mapped`: a bag)."""
    which = kind(path)
    return which in READERS and READERS[which].mapped


def read(path: Path, columns: Sequence[str] | None = None, named_by: str = "<python>",
         signals: Mapping[str, Any] | None = None, options: Any = None, resample: bool = False) -> Table:
    """Read a data file (``.csv``, ``.npz``, ``.mat``, a bag) into a :class:`Table`.

    ``columns`` names the columns of a CSV file without a header line (an experiment's ``columns``
    key; ``named_by`` is that experiment file, for messages); other files name their variables themselves.
    A reader that is :attr:`Reader.mapped` (bags) reads what the experiment's ``signals`` reference, aligned as
    its ``options`` (``[alignment]``) say: :func:`read_mapped`.
    """
    which = kind(path)
    if which not in READERS:
        suffixes = ", ".join(x for r in READERS.values() for x in r.suffixes)
        raise DataError(str(path), "file", f"expected a data file ({suffixes}), got an experiment file")
    if not exists(path):
        raise DataError(str(path), "file", "no such data file")
    if READERS[which].mapped:
        source = str(path) if named_by == "<python>" else named_by
        return read_mapped(path, which, columns, source, signals, options, resample)[0]
    if columns is not None:
        if which != "csv":
            raise DataError(named_by, "columns", f"names the columns of a CSV file without a header line; "
                                                 f"{path.name} is a .{which} file, whose variables have names "
                                                 "(leave out columns)")
        return read_csv(path, columns, named_by)
    return READERS[which].read(path)


BLOCK_CHARACTERS = 1 << 22
"""Characters of CSV text parsed at once (4 Mi, about 55 000 rows of four 17-digit numbers): the reader holds
one block of text besides its result, whatever the file's size."""


def read_csv(path: Path, columns: Sequence[str] | None = None, named_by: str = "<python>") -> Table:
    """CSV: lines starting with ``#`` before the header are comments; then a header line of names —
    or, when ``columns`` is given, no header line: every line is a row of numbers, named by ``columns``.

    A file whose first line is numbers and no ``columns`` is refused with a message saying so and how
    to name the columns (a numeric first line read as names would make names of numbers).

    The file is streamed: read in blocks of :data:`BLOCK_CHARACTERS`, each block's rows parsed by
    :func:`numpy.loadtxt` straight into one float64 array per column, whose length is known beforehand from
    the file's line count (bench/csv_load.py measures the peak memory: the result and a block). Lines are
    split as :meth:`str.splitlines` splits them; blank lines are skipped; a block that ``loadtxt`` cannot
    read is parsed field by field, which names the line and column of a bad cell. That is the whole
    file's reading of the reader that decoded it at once (tests/csv_reference.py), applied block by block,
    with one difference: rows of ``#`` comment lines only are no rows (that reader read a body of only
    comments field by field and refused it as a length mismatch; a header alone was 0 rows already).
    """
    source = str(path)
    try:
        with path.open(encoding="utf-8-sig", newline=None) as handle:
            blocks = _blocks(handle, source)
            header, body = _header(blocks, path, columns, named_by)
            _check_names(header, source)
            return _columns(header, body, _line_count(path), source)
    except OSError as exc:
        raise DataError(source, "file", f"cannot read: {exc.strerror}") from None


def _blocks(handle: io.TextIOBase, source: str) -> Iterator[tuple[int, list[str]]]:
    """(number of the first line, lines) of successive blocks of whole lines. The text is read with universal
    newlines (every line end is ``\\n``), cut after a block's last ``\\n`` and split by :meth:`str.splitlines`:
    the lines and their numbers are those of the whole text's :meth:`str.splitlines`."""
    number, carry = 1, ""
    while True:
        try:
            piece = handle.read(BLOCK_CHARACTERS)
        except UnicodeDecodeError:
            raise DataError(source, "file", "CSV file is not UTF-8 text") from None
        text = carry + piece
        if not piece:
            if text:
                yield number, text.splitlines()
            return
        cut = text.rfind("\n") + 1
        if cut == 0:  # no line end yet: a longer line, or one ended by another of splitlines' separators
            carry = text
            continue
        lines, carry = text[:cut].splitlines(), text[cut:]
        yield number, lines
        number += len(lines)


def _header(blocks: Iterator[tuple[int, list[str]]], path: Path, columns: Sequence[str] | None,
            named_by: str) -> tuple[list[str], Iterator[tuple[int, list[str]]]]:
    """The column names and the blocks of the rows after them: comments and blank lines before the first
    line are skipped, which is the header line, or with ``columns`` the first row."""
    source = str(path)
    for number, lines in blocks:
        first = next((i for i, line in enumerate(lines) if line.strip() and not line.lstrip().startswith("#")), None)
        if first is not None:
            break
    else:
        what = "no rows" if columns is not None else "no header line (expected comma-separated column names, e.g. t,q_q,tau_q)"
        raise DataError(source, "header" if columns is None else "rows", what)
    line = lines[first]
    fields = [name.strip() for name in next(csv.reader([line]))]
    if columns is None:
        if _numbers(fields):
            raise DataError(
                source, "header",
                f"the first line {excerpt(line)} is numbers: the file has no header line; name its "
                f"{len(fields)} columns in an experiment file, columns = [\"t\", \"q1\", ...] ({len(fields)} names, "
                "in file order; docs/data.md), or add a header line of names (e.g. t,q_q,tau_q)")
        header, start = fields, first + 1
    else:
        if not _numbers(fields):
            raise DataError(named_by, "columns", f"{path.name} has a header line ({excerpt(line)}); "
                                                 "columns is for a CSV file without one: leave out columns, or remove "
                                                 "the header line")
        if len(fields) != len(columns):
            raise DataError(named_by, "columns", f"names {len(columns)} column(s), but the lines of {path.name} have "
                                                 f"{len(fields)} field(s) (line {number + first}); give one name per column")
        header, start = list(columns), first
    return header, itertools.chain([(number + start, lines[start:])], blocks)


def _line_count(path: Path) -> int:
    """An upper bound of the rows: the file's ``\\n`` count + 1 (a file whose lines end otherwise grows its arrays)."""
    count = 1
    with path.open("rb") as f:
        while chunk := f.read(1 << 24):
            count += chunk.count(b"\n")
    return count


def _columns(header: list[str], body: Iterator[tuple[int, list[str]]], capacity: int, source: str) -> Table:
    """Parse the blocks of rows into one float64 vector per column (each its own array: a view kept of one
    column, as ``Measurements.t`` is, keeps no other column alive)."""
    out = [np.empty(capacity) for _ in header]
    rows = 0
    for number, lines in body:
        values = _parse_block(number, lines, header, source)
        if rows + len(values) > capacity:  # lines ended by \r or another separator: not counted
            capacity = max(2 * capacity, rows + len(values))
            out = [np.concatenate([column[:rows], np.empty(capacity - rows)]) for column in out]
        for column, v in zip(out, values.T):
            column[rows:rows + len(values)] = v
        rows += len(values)
    table = Table(source)
    for name, column in zip(header, out):
        # many blank or comment lines: do not keep their room
        table.vectors[name] = column[:rows].copy() if rows < 0.9 * capacity else column[:rows]
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
            raise DataError(source, "header", f"column name {excerpt(name)} appears twice")
        seen.add(name)


def _parse_block(number: int, lines: list[str], header: list[str], source: str) -> np.ndarray:
    """The rows of one block (rows × columns); ``number`` is the line number of ``lines[0]``."""
    body = [line for line in lines if line.strip()]
    if not body:
        return np.empty((0, len(header)))
    try:  # fast path; on any problem the slow path below says where
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # a block of comments only: "input contained no data"
            values = np.loadtxt(body, delimiter=",", ndmin=2)
        if values.shape[1] == len(header):
            return values
        if len(values) == 0:  # comment lines only: no rows (the reader of the whole file took them for a row)
            return np.empty((0, len(header)))
    except ValueError:
        pass
    numbered = [(number + i, line) for i, line in enumerate(lines) if line.strip()]
    values = np.empty((len(numbered), len(header)))
    for row, (lineno, fields) in enumerate(zip((n for n, _ in numbered), csv.reader(line for _, line in numbered))):
        if len(fields) != len(header):
            raise DataError(
                source,
                f"line {lineno}",
                f"length mismatch: {len(fields)} fields, the header has {len(header)} ({listing(header)})",
            )
        for j, text in enumerate(fields):
            try:
                values[row, j] = float(text)
            except ValueError:
                raise DataError(
                    source, f"line {lineno} column {excerpt(header[j])}", f"cannot read {excerpt(text)} as a number"
                ) from None
    return values


INFLATION_LIMIT = 100
"""Most bytes of numbers a compressed data file may hold per byte of file. Measured signals carry noise in
their low bits and compress by a few times at most (savez_compressed of EMPS's log: 1.3); a larger ratio
means long runs of identical bytes, no measurement, and a ratio of 1000 is a zip bomb's (1 MB that inflates
to 1 GB)."""

INFLATION_FLOOR = 256 * 2**20
"""Bytes of numbers any data file may hold whatever its compression (a short log of constants is fine)."""

MEMORY_SHARE = 4
"""A data file's numbers may take at most this share (1/4) of the memory available: the commands hold a few
copies of the data and the regressor besides."""


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux's MemAvailable, else free physical pages), or
    ``None`` when the system does not say."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def size(count: float) -> str:
    """A byte count for a message: ``8 TiB``, ``381 MiB``, ``64 B``."""
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if count >= scale:
            return f"{count / scale:.3g} {unit}"
    return f"{int(count)} B"


@dataclass
class _Budget:
    """The bytes of numbers a data file may inflate to (:data:`INFLATION_LIMIT`, :data:`MEMORY_SHARE`), and
    those claimed so far; :meth:`claim` refuses past it, naming the variable and the limit."""

    source: str
    file_size: int
    memory: int | None = field(default_factory=available_memory)
    used: int = 0

    def claim(self, name: str, nbytes: int, what: str) -> None:
        self.used += nbytes
        inflation = max(INFLATION_FLOOR, INFLATION_LIMIT * self.file_size)
        if self.used > inflation:
            raise DataError(self.source, f"{name}", f"{what}: the file's numbers would inflate to {size(self.used)} or "
                                                    f"more, {self.used / max(self.file_size, 1):.3g} times its {size(self.file_size)} "
                                                    f"(allowed: {INFLATION_LIMIT} times the file's size, or "
                                                    f"{size(INFLATION_FLOOR)}); a file that compresses that far holds "
                                                    "no measurement (a zip bomb?)")
        if self.memory is not None and self.used > self.memory / MEMORY_SHARE:
            raise DataError(self.source, f"{name}", f"{what}: {size(self.used)} of numbers, more than a "
                                                    f"{MEMORY_SHARE}th of the {size(self.memory)} of memory available")


NUMBER_KINDS = "biuf"
"""NumPy dtype kinds read as numbers: booleans, integers, floating point."""


def read_npz(path: Path) -> Table:
    """NumPy ``.npz`` (``numpy.savez``, ``savez_compressed``); pickled objects are never loaded.

    Every member's ``.npy`` header is read first and the bytes its shape claims are checked against the
    file's budget (:class:`_Budget`) before any array is allocated; the data are then read as exactly that
    many bytes, so a member cannot inflate past what its header claims however its zip entry lies.
    """
    source = str(path)
    table = Table(source)
    budget = _Budget(source, path.stat().st_size)
    try:
        archive = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile, ValueError) as exc:
        raise DataError(source, "file", f"cannot read as a NumPy .npz archive: {exc}") from None
    with archive:
        for info in archive.infolist():
            if info.is_dir():
                continue
            name = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
            try:
                _read_member(archive, info, name, table, budget)
            except DataError:
                raise
            except (OSError, ValueError, EOFError, zipfile.BadZipFile, NotImplementedError, RuntimeError) as exc:
                raise DataError(source, name, f"cannot read as a NumPy array (.npy): {exc}") from None
    return table


def _read_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, name: str, table: Table, budget: _Budget) -> None:
    """One ``.npy`` member of an archive into ``table`` (see :func:`read_npz`)."""
    fmt = np.lib.format
    with archive.open(info) as member:
        if not info.filename.endswith(".npy"):
            table.unusable[name] = "not a NumPy array (.npy)"
            return
        version = fmt.read_magic(member)
        reader = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
        shape, fortran, dtype = reader(member)
        if dtype.hasobject:
            table.unusable[name] = "an array of Python objects (not loaded)"
            return
        if dtype.kind not in NUMBER_KINDS or dtype.fields is not None:
            table.unusable[name] = f"of type {dtype} (not numbers)"
            return
        count = math.prod(shape)
        nbytes = count * dtype.itemsize
        budget.claim(name, nbytes, f"its header claims {count} values of {dtype} ({size(nbytes)})")
        data = member.read(nbytes)
        if len(data) != nbytes:
            raise DataError(budget.source, name, f"truncated: its header claims {count} values of {dtype} "
                                                 f"({size(nbytes)}), the archive holds {size(len(data))}")
        array = np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")
    _classify(table, name, array)


MAT_NUMBERS = ("double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "logical")
"""MATLAB classes read as numbers; the others (char, cell, struct, sparse, object, ...) are named, not loaded."""


def read_mat(path: Path) -> Table:
    """MATLAB ``.mat`` v5 (``save -v7`` or older) through :func:`scipy.io.loadmat`.

    The variables are listed first (:func:`scipy.io.whosmat` reads their headers only); the numeric ones
    are loaded when their sizes fit the file's budget (:class:`_Budget`), the others are named as unusable
    without being read."""
    import scipy.io

    source = str(path)
    table = Table(source)
    budget = _Budget(source, path.stat().st_size)
    try:
        listed = scipy.io.whosmat(str(path))
        numeric = []
        for name, shape, kind in listed:
            if name.startswith("__"):
                continue
            if kind not in MAT_NUMBERS:
                table.unusable[name] = f"a MATLAB {kind} (not numbers)"
                continue
            count = math.prod(shape)
            budget.claim(name, 8 * count, f"a {kind} array of {'×'.join(map(str, shape))} values ({size(8 * count)})")
            numeric.append(name)
        contents = scipy.io.loadmat(str(path), squeeze_me=False, variable_names=numeric) if numeric else {}
    except DataError:
        raise
    except NotImplementedError:
        raise DataError(
            source, "file", "MATLAB v7.3 (HDF5) files are not supported; save with -v7 or -v6 in MATLAB"
        ) from None
    except (OSError, ValueError, TypeError, EOFError, zlib.error, struct.error, IndexError, KeyError,
            AttributeError) as exc:
        raise DataError(source, "file", f"cannot read as a MATLAB v5 .mat file: {one_line(str(exc), 200)}") from None
    for name in numeric:
        if name in contents:
            _classify(table, name, contents[name])
    return table


def _classify(table: Table, name: str, value: object) -> None:
    array = np.asarray(value)
    if array.dtype.kind not in "biuf":
        table.unusable[name] = f"of type {array.dtype} (not numbers)"
    elif array.size == 1:
        table.scalars[name] = float(array.reshape(()))
    elif array.ndim == 1 or (array.ndim == 2 and 1 in array.shape):
        table.vectors[name] = array.astype(float).reshape(-1)
    else:
        table.unusable[name] = f"of shape {array.shape} (a signal is a vector, a constant a 1×1 scalar)"


def read_mapped(path: Path, which: str, columns: Sequence[str] | None, named_by: str,
                signals: Mapping[str, Any] | None, options: Any, resample: bool) -> tuple[Table, dict[str, Any], Any]:
    """A mapped reader's table (``t`` and one variable per reference), the ``[signals]`` rewritten over its
    variables, and its report (a bag's :class:`~symbolic.data.bags.Alignment`)."""
    if columns is not None:
        raise DataError(named_by, "columns", f"names the columns of a CSV file without a header line; {path.name} "
                                             "is a bag, whose topics [signals] maps (leave out columns)")
    result = READERS[which].read(path, signals, options, named_by, resample)
    return Table(str(path), result.vectors, labels=result.labels), result.signals, result.alignment


@dataclass(frozen=True)
class Reader:
    """A data-file format: the suffixes that name it, the first bytes that identify a file without one, the
    function that reads it into a :class:`Table`, and how error messages describe it. A new format is one reader
    function and one entry of :data:`READERS`.

    ``folder``: a folder holding a file of this name is of this format (rosbag2). ``mapped``: the reader needs
    the experiment's ``[signals]`` (a bag's topics are no columns): ``read(path, signals, options, source,
    resample)`` returns the variables, the rewritten signals and a report (:func:`read_mapped`)."""

    suffixes: tuple[str, ...]
    magic: bytes | None
    read: Any
    described: str
    folder: str | None = None
    mapped: bool = False


READERS: dict[str, Reader] = {
    "csv": Reader((".csv",), None, read_csv, ".csv with a header line"),
    "npz": Reader((".npz",), ZIP_MAGIC, read_npz, ".npz"),
    "mat": Reader((".mat",), MAT_MAGIC, read_mat, ".mat v5"),
    "bag": Reader((".mcap", ".db3"), bags.MCAP_MAGIC, bags.read, "ROS 2 bags (a rosbag2 folder, .db3, .mcap)",
                  folder=bags.METADATA, mapped=True),
}
"""Every data-file format the package reads, by name (:func:`kind`, :func:`read`)."""


def write(columns: Mapping[str, np.ndarray], path: str | Path) -> Path:
    """Write ``columns`` (name -> vector, in order) as ``.csv`` or ``.npz``, atomically.

    CSV numbers are printed with 17 significant digits (``%.17g``) so that reading them back gives
    the same doubles; the output is byte-identical for the same input.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".npz"):
        raise DataError(str(path), "file", f"cannot write {suffix or 'a file without suffix'!r} (allowed: .csv, .npz)")
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names]) if names else np.empty((0, 0))
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as temporary, open(temporary, "wb") as f:
        if suffix == ".csv":
            f.write((",".join(names) + "\n").encode())
            for row in data:
                f.write((",".join(_number(v) for v in row) + "\n").encode())
        else:
            _write_npz(f, names, data)
    return path


def _write_npz(f: io.BufferedIOBase, names: list[str], data: np.ndarray) -> None:
    # As numpy.savez, but with a fixed time stamp in the archive so that the bytes are reproducible.
    with zipfile.ZipFile(f, "w", compression=zipfile.ZIP_STORED) as archive:
        for j, name in enumerate(names):
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            with archive.open(info, "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.ascontiguousarray(data[:, j]), allow_pickle=False)


def _number(value: float) -> str:
    if math.isfinite(value) and value == int(value) and abs(value) < 2**53:
        return str(int(value))
    return "%.17g" % value


def read_toml(path: Path, kind: str) -> dict[str, Any]:
    """The tables of the TOML file ``path`` (an experiment or a campaign file: ``kind`` names it in the
    errors); an unreadable file, text that is not UTF-8, or a TOML syntax error is one :class:`DataError`."""
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as error:
        raise DataError(str(path), "file", f"cannot read {kind} file: {error.strerror}") from None
    except UnicodeDecodeError:
        raise DataError(str(path), "file", f"{kind} file is not UTF-8 text") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise DataError(str(path), "TOML syntax", str(error)) from None
