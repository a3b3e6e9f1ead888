"""Measured data: data files, experiment files, and the signal treatments of identification.

:func:`load` reads a **data file** with the canonical columns (``t`` and, per coordinate ``c``, ``q_c``,
``tau_c``, optionally ``qd_c``, ``qdd_c``, ``ref_c``; CSV, NumPy ``.npz`` or MATLAB ``.mat`` v5) or an
**experiment file** (``.toml``, :mod:`symbolic.data.experiment`: a data file's variables mapped onto those
names, constants, a window, the model and the controller) into a frozen :class:`Measurements`;
:func:`write` writes the canonical columns back. Each problem is a one-line :class:`DataError` naming the
file, the column or key, what is wrong and what is allowed. :mod:`symbolic.data.filters` and
:mod:`symbolic.data.treatment` hold the zero-phase low-pass, central differences and decimation applied
to such data. The formats, the checks and experiment files: docs/data.md.
"""

from __future__ import annotations

from pathlib import Path

from symbolic.data import filters
from symbolic.data.errors import DataError
from symbolic.data.experiment import DATA_PATH_VARIABLE, resolve_data
from symbolic.data.files import write as write_columns
from symbolic.data.measurements import UNIFORM_TOLERANCE, Measurements, Source, assemble, split_name

__all__ = [
    "DATA_PATH_VARIABLE",
    "UNIFORM_TOLERANCE",
    "DataError",
    "Measurements",
    "filters",
    "load",
    "resolve_data",
    "write",
]


def load(
    path: str | Path,
    coordinates: tuple[str, ...] | list[str] | None = None,
    *,
    resample: bool = False,
    experiment: str | Path | None = None,
) -> Measurements:
    """Load measurements from a data file or an experiment file.

    Parameters
    ----------
    path
        A ``.csv``, ``.npz`` or ``.mat`` data file with canonical columns, or a ``.toml`` experiment
        file (a file without a known suffix is recognised by its content).
    coordinates
        The model's generalized coordinates, in order. Given, every coordinate must have its ``q_c``
        and ``tau_c``, and a signal for any other coordinate is refused; ``None`` takes the
        coordinates from the ``q_c`` columns in file order.
    resample
        Interpolate linearly onto a uniform time grid (same first and last time, same number of
        samples) when the time steps vary by more than :data:`UNIFORM_TOLERANCE`; without it that is
        an error. An experiment file can ask for it with ``resample = true``.
    experiment
        An experiment file whose mapping ([signals], [constants], [window], ...) is applied to the data
        file ``path`` instead of the file its ``data`` key names (``--experiment`` of the commands).

    Raises
    ------
    DataError
        For any unusable content, with file, key or column, and what is allowed.
    """
    from symbolic.data import files
    from symbolic.data.experiment import load_experiment

    path = Path(path)
    coordinates = None if coordinates is None else tuple(coordinates)
    if experiment is not None:
        return load_experiment(Path(experiment), coordinates, resample, data=path)
    if files.kind(path) == "experiment":
        return load_experiment(path, coordinates, resample)
    table = files.read(path)
    for name in (*table.unusable, *table.scalars):
        if name == "t" or split_name(name) is not None:
            what = table.unusable.get(name, "a single number (a signal needs at least 2 samples)")
            raise DataError(str(path), f"column '{name}'", f"is {what}")
    return assemble(
        table.vectors,
        Source(str(path), lambda name: f"column '{name}'"),
        coordinates=coordinates,
        resample=resample,
        source=path,
        data_file=path.resolve(),
        constants=table.scalars,
    )


def write(measurements: Measurements, path: str | Path) -> Path:
    """Write ``measurements`` as a canonical data file (``.csv`` or ``.npz``), atomically.

    :func:`load` reads it back to the same numbers (CSV keeps 17 significant digits).
    """
    return write_columns(measurements.columns(), path)
