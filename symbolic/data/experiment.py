"""Experiment files: TOML that maps any data file onto the canonical signals.

::

    data = "DATA_EMPS.mat"        # the data file, relative to this file (see resolve_data)
    model = "emps"                # optional: a built-in robot name or a model file (relative to this file)
    description = "..."           # optional
    resample = false              # optional: interpolate onto a uniform time grid when steps vary
    rate = 1000.0                 # optional, Hz: when the file has no time (also accepted in [signals])

    [signals]                     # canonical name (or an extra signal's name) = expression of the file's variables
    t = "t"
    q_q = "qm"
    tau_q = "gtau*vir"
    ref_q = "qg"

    [constants]                   # numbers the expressions may use (not names of the file's variables)
    counts_per_m = 1.0

    [window]                      # optional: keep start <= t <= stop (seconds; either may be left out)
    start = 0.5

    [controller]                  # optional, kept as written for the simulation
    [identification]              # optional, kept as written for the identification (bandwidth, cutoff, ...)

Expressions are parsed by the model files' safe parser (:func:`symbolic.description.expressions.parse_expression`:
numbers, names, ``+ - * / **``, ``pi`` and a list of functions; nothing is evaluated as Python) and then
computed element-wise with NumPy. A variable of the file that is 1×1 (MATLAB's ``gtau``) is a number.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import sympy as sp

from symbolic.data import files
from symbolic.data.errors import DataError
from symbolic.data.measurements import Measurements, Source, assemble, isfinite_number
from symbolic.errors import ModelError
from symbolic.description.expressions import RESERVED_NAMES, parse_expression, variable_names

DATA_PATH_VARIABLE = "SYMBOLIC_DATA_PATH"
"""Environment variable: folders (separated by ``os.pathsep``) searched for a data file by its name
when it is not found at the path the experiment file gives."""

TOP_KEYS = ("data", "model", "description", "rate", "resample", "signals", "constants", "window", "controller",
            "identification")


def load_experiment(path: Path, coordinates: tuple[str, ...] | None, resample: bool, data: Path | None = None) -> Measurements:
    """Read an experiment file and the data file it names (or ``data`` instead); see the module docstring."""
    source = str(path)
    spec = _read_toml(path)
    unknown = [k for k in spec if k not in TOP_KEYS]
    if unknown:
        raise DataError(source, unknown[0], f"unknown key (allowed: {', '.join(TOP_KEYS)})")
    if data is not None:
        if not Path(data).is_file():
            raise DataError(str(data), "file", "data file not found")
        data_file = Path(data).resolve()
    else:
        data_file = resolve_data(_string(spec, "data", source, required=True), path)
    table = files.read(data_file)
    constants = _constants(spec.get("constants", {}), table, source)
    signals_spec = _table(spec, "signals", source, required=True)
    rate = _rate(spec, signals_spec, source)
    evaluated = {
        name: _evaluate(name, text, table, constants, source)
        for name, text in signals_spec.items()
        if not (name == "rate" and isfinite_number(text))
    }
    if "t" not in evaluated and rate is None:
        raise DataError(source, "[signals]", "no time: give t = \"<time variable>\" or rate = <Hz>")
    resample_key = spec.get("resample", False)
    if not isinstance(resample_key, bool):
        raise DataError(source, "resample", f"expected true or false, got {resample_key!r}")
    return assemble(
        evaluated,
        Source(source, lambda name: f"[signals] {name}", noun="signal", container="[signals]"),
        coordinates=coordinates,
        rate=rate,
        resample=resample or resample_key,
        window=_window(spec.get("window"), source),
        data_file=data_file,
        source=path,
        model=_model(spec, path),
        constants={**table.scalars, **constants},
        controller=_raw_table(spec, "controller", source),
        identification=_raw_table(spec, "identification", source),
    )


def resolve_data(name: str, experiment: Path) -> Path:
    """The data file ``name`` of ``experiment``.

    Looked for, in order: ``name`` itself if absolute, else relative to the experiment file's folder;
    then a file of the same name (its last path component) in each folder of the environment variable
    ``SYMBOLIC_DATA_PATH``. So an experiment in a repository can point at data kept outside it (the
    shipped EMPS examples use ``../../../../shared/data/emps/DATA_EMPS.mat``, the data folder beside
    the checkout), and the same file works elsewhere with ``SYMBOLIC_DATA_PATH=/path/to/emps``.
    """
    given = Path(name)
    first = Path(os.path.normpath(given if given.is_absolute() else experiment.parent / given))
    candidates = [first]
    search = [Path(d) for d in os.environ.get(DATA_PATH_VARIABLE, "").split(os.pathsep) if d]
    candidates += [d / given.name for d in search]
    for candidate in candidates:
        if candidate.is_file():
            return candidate.resolve()
    where = f"{DATA_PATH_VARIABLE}: {os.pathsep.join(map(str, search))}" if search else f"{DATA_PATH_VARIABLE} unset"
    raise DataError(
        str(experiment),
        "data",
        f"data file {name!r} not found (looked at {first} and, by name, in the folders of {where}); give a path "
        f"relative to the experiment file or set {DATA_PATH_VARIABLE} to the folder that holds {given.name}",
    )


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise DataError(str(path), "file", f"cannot read experiment file: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise DataError(str(path), "file", "experiment file is not UTF-8 text") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DataError(str(path), "TOML syntax", str(exc)) from None


def _string(spec: Mapping[str, Any], key: str, source: str, required: bool = False) -> str | None:
    if key not in spec:
        if required:
            raise DataError(source, key, "missing (the data file, relative to the experiment file)")
        return None
    value = spec[key]
    if not isinstance(value, str) or not value.strip():
        raise DataError(source, key, f"expected a non-empty string, got {value!r}")
    return value


def _table(spec: Mapping[str, Any], key: str, source: str, required: bool = False) -> Mapping[str, Any]:
    if key not in spec:
        if required:
            raise DataError(source, f"[{key}]", "missing table")
        return {}
    value = spec[key]
    if not isinstance(value, Mapping):
        raise DataError(source, f"[{key}]", f"expected a table, got {type(value).__name__}")
    return value


def _raw_table(spec: Mapping[str, Any], key: str, source: str) -> Mapping[str, Any] | None:
    return MappingProxyType(dict(_table(spec, key, source))) if key in spec else None


def _model(spec: Mapping[str, Any], path: Path) -> str | None:
    """A built-in name as written; a model file (``.toml`` or containing a path separator) resolved."""
    model = _string(spec, "model", str(path))
    if model is None or not (model.endswith(".toml") or "/" in model or os.sep in model):
        return model
    resolved = (path.parent / model).resolve()
    if not resolved.is_file():
        raise DataError(str(path), "model", f"model file {model!r} not found (looked at {resolved})")
    return str(resolved)


def _rate(spec: Mapping[str, Any], signals: Mapping[str, Any], source: str) -> float | None:
    given = [(key, value) for key, value in (("rate", spec.get("rate")), ("[signals] rate", signals.get("rate")))
             if value is not None and (key == "rate" or isfinite_number(value))]
    if not given:
        return None
    if len(given) > 1 or "t" in signals:
        other = "t in [signals]" if "t" in signals else "[signals] rate"
        raise DataError(source, given[0][0], f"give either the time ({other}) or a rate, not both")
    key, value = given[0]
    if not isfinite_number(value) or value <= 0:
        raise DataError(source, key, f"expected a positive sampling rate in Hz, got {value!r}")
    return float(value)


def _constants(spec: Any, table: files.Table, source: str) -> dict[str, float]:
    if not isinstance(spec, Mapping):
        raise DataError(source, "[constants]", f"expected a table, got {type(spec).__name__}")
    constants = {}
    for name, value in spec.items():
        key = f"[constants] {name}"
        if name in table.names():
            raise DataError(
                source, key, f"ambiguous: {name!r} is also a variable of {Path(table.source).name}; rename the constant"
            )
        if not name.isidentifier() or name in RESERVED_NAMES:
            raise DataError(source, key, f"not a usable name (a Python identifier other than {', '.join(sorted(RESERVED_NAMES))})")
        if not isfinite_number(value):
            raise DataError(source, key, f"expected a finite number, got {value!r}")
        constants[name] = float(value)
    return constants


def _evaluate(name: str, text: Any, table: files.Table, constants: Mapping[str, float], source: str) -> np.ndarray:
    """The values of signal ``name`` = expression ``text`` of the file's variables and the constants."""
    key = f"[signals] {name}"
    if not name.isidentifier():
        raise DataError(source, key, "a signal name must be an identifier (t, q_<c>, tau_<c>, ... or an extra name)")
    if isinstance(text, str):
        _check_names(text, table, constants, source, key)
    usable = [*table.vectors, *table.scalars, *constants]
    symbols = {v: sp.Symbol(v) for v in usable if v.isidentifier() and v not in RESERVED_NAMES}
    try:
        expression = parse_expression(text, symbols, source, key)
    except ModelError as error:
        raise DataError(error.source, error.key, error.problem) from None
    used = sorted(expression.free_symbols, key=lambda s: s.name)
    values = []
    for s in used:
        values.append(table.vectors.get(s.name, table.scalars.get(s.name, constants.get(s.name))))
    lengths = {s.name: len(v) for s, v in zip(used, values) if isinstance(v, np.ndarray)}
    if len(set(lengths.values())) > 1:
        detail = ", ".join(f"{v} has {n} samples" for v, n in lengths.items())
        raise DataError(source, key, f"length mismatch between the variables of {text!r}: {detail}")
    if not lengths:
        raise DataError(source, key, f"{text!r} uses no signal of the file (a signal varies with the samples)")
    function = sp.lambdify(used, expression, modules="numpy", dummify=True)
    with np.errstate(all="ignore"):
        result = np.asarray(function(*values), dtype=float)
    return np.broadcast_to(result, (next(iter(lengths.values())),)).copy()


def _check_names(text: str, table: files.Table, constants: Mapping[str, float], source: str, key: str) -> None:
    """Refuse names that are neither variables of the file nor constants, listing what there is."""
    for name in variable_names(text):
        if name in table.unusable:
            raise DataError(source, key, f"variable {name!r} of {Path(table.source).name} is {table.unusable[name]}")
        if name not in table.vectors and name not in table.scalars and name not in constants:
            variables = ", ".join([*table.vectors, *table.scalars]) or "none"
            raise DataError(
                source,
                key,
                f"unknown variable {name!r} in {text!r} (variables of {Path(table.source).name}: {variables}; "
                f"[constants]: {', '.join(constants) or 'none'})",
            )


def _window(spec: Any, source: str) -> tuple[float | None, float | None] | None:
    if spec is None:
        return None
    if not isinstance(spec, Mapping):
        raise DataError(source, "[window]", f"expected a table with start and/or stop, got {type(spec).__name__}")
    unknown = [k for k in spec if k not in ("start", "stop")]
    if unknown:
        raise DataError(source, f"[window] {unknown[0]}", "unknown key (allowed: start, stop; seconds)")
    bounds = []
    for k in ("start", "stop"):
        value = spec.get(k)
        if value is not None and not isfinite_number(value):
            raise DataError(source, f"[window] {k}", f"expected a time in seconds, got {value!r}")
        bounds.append(None if value is None else float(value))
    if bounds[0] is not None and bounds[1] is not None and bounds[0] >= bounds[1]:
        raise DataError(source, "[window]", f"start {bounds[0]:g} s is not before stop {bounds[1]:g} s")
    return bounds[0], bounds[1]
