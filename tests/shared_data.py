"""Where the shared measured data are, for tests that need them (they are never copied into the repository).

The EMPS files live in ``shared/data/emps`` beside the checkout (``Path(repository root).parent``), or in a
folder named by ``SYMBOLIC_DATA_PATH``; tests skip with a message saying so when neither holds them.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EMPS_FILES = ("DATA_EMPS.mat", "DATA_EMPS_PULSES.mat")


def emps_folder() -> Path:
    """The folder holding the EMPS ``.mat`` files; skips the calling test when there is none."""
    candidates = [ROOT.parent / "shared" / "data" / "emps"]
    candidates += [Path(d) for d in os.environ.get("SYMBOLIC_DATA_PATH", "").split(os.pathsep) if d]
    for folder in candidates:
        if all((folder / name).is_file() for name in EMPS_FILES):
            return folder
    pytest.skip(
        f"EMPS data not found (looked in {', '.join(map(str, candidates))}): put DATA_EMPS.mat and "
        "DATA_EMPS_PULSES.mat in ../shared/data/emps beside the checkout or set SYMBOLIC_DATA_PATH"
    )


@pytest.fixture
def emps(monkeypatch: pytest.MonkeyPatch) -> Path:
    """The EMPS folder, also put on SYMBOLIC_DATA_PATH so that the shipped experiment files find it."""
    folder = emps_folder()
    monkeypatch.setenv("SYMBOLIC_DATA_PATH", str(folder))
    return folder
