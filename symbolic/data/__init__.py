"""Measured data: data files, experiment files, and the signal treatments of identification.

One entry point, :func:`load` (:mod:`symbolic.data.experiment`), takes either

* a **data file** with canonical columns — ``t`` and, for every coordinate ``c`` of the model,
  ``q_c`` and ``tau_c`` (or the drive signal ``u_c``, times the model's ``[[drive]] gain``),
  optionally ``qd_c``, ``qdd_c``, ``ref_c``; other columns are kept as extra signals — as CSV with a
  header line, NumPy ``.npz`` or MATLAB ``.mat`` (v5), or
* an **experiment file** (``.toml``) that maps any such file's variables onto those names by
  expressions, with constants, a time window, the model, the data treatment (``[identification]``)
  and the controller (``[controller]``) of the experiment,

and returns an :class:`Experiment` (:class:`Measurements` with the experiment's model, treatment
settings, controller and validation set), every table checked once. Problems are a
:class:`DataError` naming the file, the column or key, what is wrong and what is allowed: missing
column, a signal for a coordinate the model does not have, length mismatch, NaN or infinity (column
and sample), time not increasing or not uniform (the steps found; resampling only on request), an
empty window, unknown file type, a CSV file without a header line, unknown variable in an
expression, a constant that is also a variable of the file, an unknown key of any table.

:mod:`symbolic.data.filters` holds the zero-phase low-pass, central differences and decimation
used on such data.
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
