"""Measured data: data files, experiment files, and the signal treatments of identification.

:func:`load` reads a **data file** with the canonical columns (``t`` and, per coordinate ``c``, ``q_c``,
``tau_c`` or the drive signal ``u_c``, optionally ``qd_c``, ``qdd_c``, ``ref_c``; CSV, NumPy ``.npz`` or
MATLAB ``.mat`` v5) or an **experiment file** (``.toml``, :mod:`symbolic.data.experiment`; it may map the topics
of a ROS 2 bag or MCAP file, :mod:`symbolic.data.bags`) into an
:class:`Experiment` (:class:`Measurements` with the experiment's model, treatment settings, controller and
validation set), every table checked once; :func:`write` writes the canonical columns back. Each problem is
a one-line :class:`DataError` naming the file, the column or key, what is wrong and what is allowed.
:mod:`symbolic.data.filters` and :mod:`symbolic.data.treatment` hold the zero-phase low-pass, central
differences and decimation applied to such data. The formats, the checks and experiment files: docs/data.md.
"""

from __future__ import annotations

from pathlib import Path

from symbolic.data import filters
from symbolic.data.controller import Controller
from symbolic.data.errors import DataError
from symbolic.data.experiment import DATA_PATH_VARIABLE, Experiment, load, resolve_data
from symbolic.data.files import write as write_columns
from symbolic.data.measurements import UNIFORM_TOLERANCE, Measurements
from symbolic.data.settings import Settings

__all__ = [
    "DATA_PATH_VARIABLE",
    "UNIFORM_TOLERANCE",
    "Controller",
    "DataError",
    "Experiment",
    "Measurements",
    "Settings",
    "filters",
    "load",
    "resolve_data",
    "write",
]


def write(measurements: Measurements, path: str | Path) -> Path:
    """Write ``measurements`` as a canonical data file (``.csv`` or ``.npz``), atomically.

    :func:`load` reads it back to the same numbers (CSV keeps 17 significant digits).
    """
    return write_columns(measurements.columns(), path)
