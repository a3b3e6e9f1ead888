"""Data-file formats are registered in one place (symbolic.data.files.READERS): suffix, first bytes, reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from symbolic.data import DataError
from symbolic.data import files


def test_each_reader_is_found_by_suffix_and_by_its_first_bytes(tmp_path: Path) -> None:
    columns = {"t": np.arange(4) * 0.01, "q_q": np.array([0.0, 0.1, 0.2, 0.3])}
    for name in ("csv", "npz"):
        written = files.write(columns, tmp_path / f"log.{name}")
        assert files.kind(written) == name
        bare = tmp_path / f"log_{name}_without_suffix"
        bare.write_bytes(written.read_bytes())
        if files.READERS[name].magic is not None:
            assert files.kind(bare) == name
            assert files.read(bare).vectors["q_q"].tolist() == columns["q_q"].tolist()


def test_an_unknown_file_names_every_registered_format(tmp_path: Path) -> None:
    path = tmp_path / "log.bin"
    path.write_bytes(b"\x00\x01")
    with pytest.raises(DataError) as caught:
        files.kind(path)
    for reader in files.READERS.values():
        assert reader.described in str(caught.value)
