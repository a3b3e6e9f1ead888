"""Where the shared measured data are, for tests that need them (they are never copied into the repository).

The EMPS files live in ``shared/data/emps`` beside the checkout (``Path(repository root).parent``), the Franka
Panda's in ``shared/data/franka_panda``, or either in a folder named by ``SYMBOLIC_DATA_PATH``; tests skip with
a message saying so when none holds them.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EMPS_FILES = ("DATA_EMPS.mat", "DATA_EMPS_PULSES.mat")
PANDA_FILES = ("exciting_traj_time.txt", "exciting_traj_positions.txt", "exciting_traj_torques.txt")
"""Gaz et al. 2019's exciting trajectory (GPL-3.0: read from the shared folder, never copied)."""
PANDA_COMMANDED = ("gen_q0.txt", "gen_dq.txt")
"""The commanded trajectory of that log: the initial positions and the velocity every 1 ms."""


def data_folder(name: str, files: tuple[str, ...], how: str) -> Path:
    """The folder ``../shared/data/<name>`` (or one on SYMBOLIC_DATA_PATH) holding ``files``; skips the calling
    test, saying where it looked and ``how`` to provide them, when there is none."""
    candidates = [ROOT.parent / "shared" / "data" / name]
    candidates += [Path(d) for d in os.environ.get("SYMBOLIC_DATA_PATH", "").split(os.pathsep) if d]
    for folder in candidates:
        if all((folder / f).is_file() for f in files):
            return folder
    pytest.skip(f"{how} not found (looked in {', '.join(map(str, candidates))}): put {', '.join(files)} in "
                f"../shared/data/{name} beside the checkout or set SYMBOLIC_DATA_PATH")


def emps_folder() -> Path:
    """The folder holding the EMPS ``.mat`` files; skips the calling test when there is none."""
    return data_folder("emps", EMPS_FILES, "EMPS data")


@pytest.fixture
def emps(monkeypatch: pytest.MonkeyPatch) -> Path:
    """The EMPS folder, also put on SYMBOLIC_DATA_PATH so that the shipped experiment files find it."""
    folder = emps_folder()
    monkeypatch.setenv("SYMBOLIC_DATA_PATH", str(folder))
    return folder


def panda_folder() -> Path:
    """The folder holding the Franka Panda log (:data:`PANDA_FILES`); skips the calling test when there is none."""
    return data_folder("franka_panda", PANDA_FILES, "Franka Panda data (Gaz et al. 2019, "
                       "marcocognetti/FrankaEmikaPandaDynModel, Exciting_Traj/Trajectory_1)")


def panda_measurements(folder: Path):
    """The Panda's measured positions and link-side torques (one number per line, 7 lines a sample: README of
    the folder) on the built-in ``panda``'s coordinates, resampled onto a uniform grid (the time stamps
    jitter by up to 8.8 ms); the logged velocities are not used (the treatment differentiates the positions)."""
    import numpy as np

    from symbolic.data import Measurements

    t = np.loadtxt(folder / PANDA_FILES[0])
    q, tau = (np.loadtxt(folder / name).reshape(len(t), 7) for name in PANDA_FILES[1:])
    return Measurements.from_arrays(t, tuple(f"q{j}" for j in range(1, 8)), q, tau, resample=True)


def panda_commanded():
    """Gaz et al.'s exciting trajectory as commanded (the folder's README): t every 1 ms, q = ``gen_dq.txt``
    integrated from ``gen_q0.txt`` (trapezoidal rule), q̇ = ``gen_dq.txt``, q̈ its central differences; skips the
    calling test when the files are absent."""
    import numpy as np
    import scipy.integrate

    folder = data_folder("franka_panda", PANDA_COMMANDED, "Franka Panda commanded trajectory (Gaz et al. 2019, "
                         "marcocognetti/FrankaEmikaPandaDynModel, Exciting_Traj/Trajectory_1)")
    qd = np.loadtxt(folder / PANDA_COMMANDED[1]).reshape(-1, 7)
    t = np.arange(len(qd)) * 1e-3
    q = np.loadtxt(folder / PANDA_COMMANDED[0]) + scipy.integrate.cumulative_trapezoid(qd, t, axis=0, initial=0.0)
    return t, q, qd, np.gradient(qd, t, axis=0)
