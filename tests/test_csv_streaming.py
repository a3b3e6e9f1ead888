"""The streaming CSV reader (symbolic.data.files.read_csv) equals the reader that decoded the whole file at once
(tests/csv_reference.py): the same vectors, bit for bit, or the same one-line error (file, line, column).

Each file is read whole (one block) and in blocks of a few characters, which cuts it between, and
inside, lines and numbers: the blocks' seams must not show. Peak memory and time on a 5-million-row file are
measured by bench/csv_load.py, not here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import csv_reference

pytestmark = pytest.mark.filterwarnings("ignore:loadtxt. input contained no data:UserWarning")
from symbolic.data import DataError, files

HEADER = "t,q_q,tau_q\n"
ROWS = "0,0.5,1\n0.001,0.25,-2e-3\n0.002,1.5e10,3\n"

CASES = {
    "plain": HEADER + ROWS,
    "no final line end": HEADER + ROWS.rstrip("\n"),
    "comments and blank lines before the header": "# logger v2\n\n  # rate 1 kHz\n   \n" + HEADER + ROWS,
    "blank and white lines between rows": HEADER + "0,0.5,1\n\n   \n\t\n0.001,0.25,-2e-3\n\n",
    "comment lines and inline comments in the rows": HEADER + "0,0.5,1\n# pause\n0.001,0.25,-2e-3 # note\n",
    "comment lines only after the header": HEADER + "# nothing logged\n",
    "CRLF": (HEADER + ROWS).replace("\n", "\r\n"),
    "CR only": (HEADER + ROWS).replace("\n", "\r"),
    "mixed line ends and a form feed": "t,q_q,tau_q\r\n0,0.5,1\r0.001,0.25,-2e-3\x0c0.002,1,3\n",
    "byte order mark": "\ufeff" + HEADER + ROWS,
    "spaces around names and numbers": " t , q_q ,tau_q \n 0 , 0.5 , 1 \n0.001,0.25 ,-2e-3\n",
    "quoted numbers": HEADER + '"0","0.5",1\n0.001,0.25,-2e-3\n',
    "nan and inf": HEADER + "0,nan,inf\n0.001,-Infinity,1e400\n",
    "digits with underscores": HEADER + "0,1_000,1\n0.001,2,3\n",
    "header only": HEADER,
    "trailing comma on a row": HEADER + "0,0.5,1,\n0.001,0.25,-2e-3\n",
    "trailing commas on every row": HEADER + "0,0.5,1,\n0.001,0.25,-2e-3,\n",
    "trailing comma on the header": "t,q_q,tau_q,\n0,0.5,1\n",
    "bad cell": HEADER + "0,0.5,1\n0.001,abc,-2e-3\n0.002,1,3\n",
    "bad cell after a blank line": HEADER + "0,0.5,1\n\n\n0.001,0.25,1..2\n",
    "empty cell": HEADER + "0,,1\n",
    "too few fields": HEADER + "0,0.5,1\n0.001,0.25\n",
    "too many fields": HEADER + "0,0.5,1\n0.001,0.25,1,2\n",
    "comment line, then a bad cell": HEADER + "0,0.5,1\n# pause\n0.001,x,1\n",
    "numbers for a header": "0,0.5,1\n0.001,0.25,-2e-3\n",
    "a column without a name": "t,,tau_q\n0,0.5,1\n",
    "a name twice": "t,q_q,q_q\n0,0.5,1\n",
    "empty file": "",
    "comments only": "# nothing\n\n",
    "one column": "t\n0\n0.001\n0.002\n",
}

HEADERLESS = {
    "headerless": ("0,0.5,1\n0.001,0.25,-2e-3\n", ["t", "q_q", "tau_q"]),
    "headerless after comments": ("# raw log\n\n0,0.5,1\n0.001,0.25,-2e-3\n", ["t", "q_q", "tau_q"]),
    "headerless with a trailing comma": ("0,0.5,1,\n", ["t", "q_q", "tau_q"]),
    "headerless, too few names": ("0,0.5,1\n", ["t", "q_q"]),
    "headerless, but a header": (HEADER + ROWS, ["t", "q_q", "tau_q"]),
    "headerless, bad cell": ("0,0.5,1\n0.001,-,1\n", ["t", "q_q", "tau_q"]),
    "headerless, no rows": ("# only a comment\n", ["t", "q_q", "tau_q"]),
}


def outcome(reader, path: Path, columns=None) -> tuple[str, object]:
    """("table", {name: bytes of the float64 vector}) or ("error", the message)."""
    try:
        table = reader(path, columns, "run.experiment.toml") if columns is not None else reader(path)
    except DataError as error:
        return "error", str(error)
    assert not table.scalars and not table.unusable
    return "table", {name: np.ascontiguousarray(v, dtype=np.float64).tobytes() for name, v in table.vectors.items()}


def both(path: Path, columns=None) -> tuple[tuple[str, object], tuple[str, object]]:
    return outcome(csv_reference.read_csv, path, columns), outcome(files.read_csv, path, columns)


@pytest.mark.parametrize("block", [None, 1, 5, 13])
@pytest.mark.parametrize("name", list(CASES))
def test_streaming_equals_the_whole_file_reader(name: str, block: int | None, tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes(CASES[name].encode("utf-8"))
    if block is not None:
        monkeypatch.setattr(files, "BLOCK_CHARACTERS", block)
    expected, got = both(path)
    if name == "comment lines only after the header":  # the one difference: no rows, as a header alone
        assert expected[0] == "error" and "length mismatch" in expected[1]
        path.write_text(HEADER)
        expected = outcome(csv_reference.read_csv, path)
    if name == "comment line, then a bad cell" and block is not None:
        # The reference parsed the whole file field by field when any row failed, and refused the comment line
        # first; a block that loadtxt read (its comment lines skipped) is not read again, and the bad cell is
        # named. Blocks of one line each keep them apart; longer ones may hold both, as the whole file did.
        assert expected == ("error", f"{path}: line 3: length mismatch: 1 fields, the header has 3 (t, q_q, tau_q)")
        cell = ("error", f"{path}: line 4 column 'q_q': cannot read 'x' as a number")
        assert got == cell if block == 1 else got in (expected, cell)
        return
    assert got == expected


@pytest.mark.parametrize("block", [None, 3])
@pytest.mark.parametrize("name", list(HEADERLESS))
def test_headerless_streaming_equals_the_whole_file_reader(name: str, block: int | None, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    text, columns = HEADERLESS[name]
    path = tmp_path / "raw.csv"
    path.write_bytes(text.encode("utf-8"))
    if block is not None:
        monkeypatch.setattr(files, "BLOCK_CHARACTERS", block)
    expected, got = both(path, columns)
    assert got == expected


def test_the_cases_cover_both_outcomes(tmp_path: Path) -> None:
    """The table above is not all refusals: the reference accepts some cases and refuses others, and the
    refusals name the line and column of a bad cell."""
    kinds = {}
    for name, text in CASES.items():
        path = tmp_path / f"{len(kinds)}.csv"
        path.write_bytes(text.encode("utf-8"))
        kinds[name] = outcome(csv_reference.read_csv, path)
    assert sum(kind == "table" for kind, _ in kinds.values()) >= 12
    assert kinds["bad cell"] == ("error", f"{tmp_path / '18.csv'}: line 3 column 'q_q': cannot read 'abc' as a number")
    assert kinds["trailing comma on a row"][0] == "error"  # refused before the streaming reader, refused now


def test_not_utf8_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes(HEADER.encode() + b"0,\xff,1\n")
    assert both(path) == (("error", f"{path}: file: CSV file is not UTF-8 text"),) * 2


@pytest.mark.parametrize("seed", range(6))
def test_random_files_read_alike_in_any_blocks(seed: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Random numbers as the writer and as people write them (17 digits, short, exponents, signs), blank and
    white lines, CRLF or LF, comments before the header, read in random block sizes."""
    rng = np.random.default_rng(seed)
    rows = int(rng.integers(1, 400))
    values = rng.normal(0, 10.0 ** rng.integers(-8, 8, (rows, 4)), (rows, 4))
    formats = ["%.17g", "%g", "%.3e", "%+.6f"]
    lines = ["# made by test", "", "t,q_a,tau_a,extra"]
    for row in values:
        lines.append(",".join(formats[int(rng.integers(4))] % v for v in row))
        if rng.random() < 0.1:
            lines.append(" " * int(rng.integers(0, 3)))
    end = "\r\n" if seed % 2 else "\n"
    path = tmp_path / "log.csv"
    path.write_bytes(end.join(lines).encode() + (end.encode() if rng.random() < 0.5 else b""))
    reference = outcome(csv_reference.read_csv, path)
    assert reference[0] == "table"
    for block in (None, *rng.integers(1, 200, 3)):
        monkeypatch.setattr(files, "BLOCK_CHARACTERS", int(block) if block is not None else 1 << 22)
        assert outcome(files.read_csv, path) == reference, block


def test_vectors_are_contiguous_and_sized_to_their_rows(tmp_path: Path) -> None:
    """Each column is its own contiguous float64 vector (what the arrays downstream slice and stack)."""
    path = tmp_path / "log.csv"
    path.write_text(HEADER + ROWS)
    table = files.read_csv(path)
    for vector in table.vectors.values():
        assert vector.flags.c_contiguous and vector.dtype == np.float64 and vector.shape == (3,)
    np.testing.assert_array_equal(table.vectors["q_q"], [0.5, 0.25, 1.5e10])
