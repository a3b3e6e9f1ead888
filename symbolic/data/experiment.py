"""Experiment files, and the one loader of an experiment: :func:`load` builds an :class:`Experiment`.

An experiment file is TOML that names a data file, maps its variables onto the canonical signals by
expressions (``[signals]``, ``[constants]``), and declares the time window, the model, the data
treatment (``[identification]``) and the machine's controller (``[controller]``); its format is
written once, in docs/data.md ("Experiment files").

Inputs: a data file, an experiment file, or measurements, with the model they are used with and an
optional validation set. Output: an :class:`Experiment`. Every table is checked here, when the file is
read, the same way for every command (identify, simulate, diagnose, first-peak): unknown keys are
refused with the allowed ones and a "did you mean" (:mod:`symbolic.data.keys`), ``[identification]``
becomes :class:`~symbolic.data.settings.Settings`, ``[controller]`` a
:class:`~symbolic.data.controller.Controller`, drive signals ``u_<c>`` become forces by the model's
``[[drive]] gain``. Expressions are parsed by the model files' safe parser
(:func:`symbolic.description.expressions.parse_expression`; nothing is evaluated as Python) and
computed element-wise with NumPy.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from symbolic import robots
from symbolic.data import excitation, files, signal_layer
from symbolic.data.controller import Controller, parse
from symbolic.data.errors import DataError
from symbolic.data.keys import check_keys
from symbolic.data.measurements import (KINDS, MAX_MAGNITUDE, MAX_RATE, DriveGains, Measurements, Source, assemble,
                                       isfinite_number, split_name)
from symbolic.data.settings import Settings
from symbolic.data.signal_layer import SignalLayer
from symbolic.data.units import check_units
from symbolic.description.numbers import RobotNumbers
from symbolic.description.reserved import RESERVED_NAMES, reserved_meaning, reserved_uses, variable_names
from symbolic.errors import ModelError, listing, shorten

if TYPE_CHECKING:  # a model is a Robot, or a RobotNumbers (symbolic.description.numbers) read without SymPy
    import sympy as sp

    from symbolic.description.robot import Robot

DATA_PATH_VARIABLE = "SYMBOLIC_DATA_PATH"
"""Environment variable: folders (separated by ``os.pathsep``) searched for a data file by its name
when it is not found at the path the experiment file gives."""

TOP_KEYS = ("data", "model", "description", "rate", "resample", "columns", "signals", "constants", "window",
            "controller", "identification", "sensors", "drive", "excitation", "alignment")

WINDOW_KEYS = ("start", "stop")


@dataclass(frozen=True, eq=False)
class Experiment(Measurements):
    """Measurements with what their experiment declares, loaded and checked once (:func:`load`).

    An Experiment is :class:`~symbolic.data.measurements.Measurements` (its numbers, the time window
    already applied), so that everything that reads measurements reads it; identification, simulation,
    the workflow and the first-peak method read the rest from here and nowhere else.

    Attributes
    ----------
    model
        The experiment's ``model``: a built-in robot name, or a model file's absolute path; ``None``.
    settings
        The ``[identification]`` table, checked (unset fields ``None``: the rules).
    controller
        The ``[controller]`` table, checked; ``None`` when the experiment declares none.
    validation
        The held-out data set loaded with it (:func:`load`'s ``validation``), or ``None``.
    window
        The ``[window]`` applied, ``(start, stop)`` in seconds, or ``None``.
    drive_gains
        The ``[[drive]] gain`` that turned each drive signal ``u_<c>`` into ``tau_<c>``, by coordinate.
    signal_layer
        The ``[sensors]`` and ``[drive]`` tables (:mod:`symbolic.data.signal_layer`), already applied to the
        numbers; their free values and the signals as logged.
    alignment
        For a bag (:mod:`symbolic.data.bags`): how its topics were aligned onto one time base (the base, each
        topic's rate, gaps and dropped messages); ``None`` for other data files.
    """

    model: str | None = None
    settings: Settings = Settings()
    controller: Controller | None = None
    validation: Experiment | None = field(default=None, repr=False)
    window: tuple[float | None, float | None] | None = None
    drive_gains: Mapping[str, float] = field(default_factory=dict)
    signal_layer: SignalLayer = field(default_factory=SignalLayer)
    alignment: Any = field(default=None, repr=False)

    def slice(self, start: int, stop: int) -> Experiment:
        """Samples ``start:stop``, the signal layer's logs cut alike."""
        cut = super().slice(start, stop)
        return dataclasses.replace(cut, signal_layer=self.signal_layer.slice(start, stop))

    @classmethod
    def of(cls, measurements: Measurements, *, settings: Settings | None = None,
           controller: Controller | Mapping[str, Any] | None = None, **context: Any) -> Experiment:
        """``measurements`` as an experiment (an Experiment's own context kept unless given): data built
        in Python with a treatment or a controller (a table is checked as a file's would be, its gain
        names when a model uses it), or a signal layer: ``signal_layer={"sensors": {...}, "drive": {...}}``
        is checked and applied to the numbers as a file's ``[sensors]`` and ``[drive]``."""
        if isinstance(controller, Mapping):
            controller = parse(controller, measurements.coordinates, None, str(measurements.source),
                               columns=measurements.columns(), samples=measurements.samples)
        if isinstance(context.get("signal_layer"), Mapping):  # {"sensors": ..., "drive": ...}: applied as a file's
            if isinstance(measurements, Experiment) and measurements.signal_layer:  # it would act twice
                raise DataError(str(measurements.source), "signal_layer", "these data already have a signal layer "
                                                                          "applied: give other values by "
                                                                          "signal_layer.reapply and with_values")
            layer = signal_layer.parse(context["signal_layer"], str(measurements.source))
            measurements, context["signal_layer"] = signal_layer.apply(measurements, layer, str(measurements.source))
        given = {"settings": settings, "controller": controller, **context}
        given = {k: v for k, v in given.items() if v is not None}
        if isinstance(measurements, cls):
            return dataclasses.replace(measurements, **given)
        own = {f.name: getattr(measurements, f.name) for f in dataclasses.fields(Measurements)}
        return cls(**own, **given)


def load(
    data: str | Path | Measurements,
    coordinates: Sequence[str] | None = None,
    *,
    model: Robot | None = None,
    experiment: str | Path | None = None,
    validation: str | Path | Measurements | None = None,
    resample: bool = False,
) -> Experiment:
    """Load an experiment: a data file, an experiment file, or measurements, with its validation set.

    Parameters
    ----------
    data
        A ``.csv``, ``.npz`` or ``.mat`` data file with canonical columns, a ``.toml`` experiment file
        (a file without a known suffix is recognised by its content), or measurements (kept as they are).
    coordinates
        The model's generalized coordinates, in order (identification needs them all). Given, every
        coordinate must have its ``q_c`` and ``tau_c`` (or ``u_c``), and a signal for any other
        coordinate is refused; ``None`` takes those of the ``q_c`` columns in file order (a simulation
        may start the others from rest), each a coordinate of ``model`` when one is given.
    model
        The model the experiment is used with: its ``[[drive]] gain`` for drive signals ``u_<c>``, its
        parameters for a ``[controller] gain``, its coordinates for the checks. Without it, the
        experiment's own ``model`` is read when a drive signal or a gain needs it.
    experiment
        An experiment file whose mapping ([signals], [constants], [window], ...) is applied to the data
        file ``data`` instead of the file its ``data`` key names (``--experiment`` of the commands).
    validation
        A held-out data set (:attr:`Experiment.validation`): an experiment file as it is, a plain data
        file mapped by ``experiment`` too when one is given (the same logger's other run), or measurements.
    resample
        Interpolate linearly onto a uniform time grid (same first and last time, same number of
        samples) when the time steps vary by more than the tolerance; without it that is an error. An
        experiment file can ask for it with ``resample = true``.

    Raises
    ------
    DataError
        For any unusable content, with file, key or column, and what is allowed.
    """
    coordinates = None if coordinates is None else tuple(coordinates)
    if isinstance(data, Measurements):
        loaded = data if isinstance(data, Experiment) else Experiment.of(data)
        if coordinates is not None:  # arrays in any order: arranged as the model's (a missing one named)
            loaded = loaded.arranged(coordinates)
    elif experiment is not None:
        loaded = _read_experiment(Path(experiment), coordinates, model, resample, data=Path(data))
    elif files.kind(Path(data)) == "experiment":
        loaded = _read_experiment(Path(data), coordinates, model, resample)
    else:
        loaded = _read_data_file(Path(data), coordinates, model, resample)
    if validation is None:
        return loaded
    mapped = None if isinstance(validation, Measurements) or files.kind(Path(validation)) == "experiment" else experiment
    held = load(validation, coordinates, model=model, experiment=mapped, resample=resample)
    return dataclasses.replace(loaded, validation=held)


def _read_data_file(path: Path, coordinates: tuple[str, ...] | None, model: Robot | None, resample: bool) -> Experiment:
    """A data file with canonical columns (no experiment: no model, treatment or controller of its own)."""
    table = files.read(path)
    _refuse_unusable(table, path)
    drive = _Model(model, None, str(path))
    measurements = assemble(table.vectors, Source(str(path), lambda name: f"column '{name}'"),
                            coordinates=coordinates, resample=resample, drive=drive.drive(table.vectors),
                            model=_coordinates_of(model), source=path, data_file=path.resolve(), constants=table.scalars)
    if model is not None:
        check_units(measurements, model)
    return Experiment.of(measurements, drive_gains=drive.used())


def _read_experiment(path: Path, coordinates: tuple[str, ...] | None, model: Robot | None, resample: bool,
                     data: Path | None = None) -> Experiment:
    """Read an experiment file and the data file it names (or ``data`` instead); see the module docstring."""
    source = str(path)
    spec = files.read_toml(path, "experiment")
    check_keys(spec, TOP_KEYS, source)
    if data is not None:
        if not files.exists(data):
            raise DataError(str(data), "file", "data file not found")
        data_file = data.resolve()
    else:
        data_file = resolve_data(_string(spec, "data", source, required=True), path)
    signals_spec = _table(spec, "signals", source)
    written = dict(signals_spec)
    rate = sample_rate(spec, signals_spec, source)
    resample_key = spec.get("resample", False)
    if not isinstance(resample_key, bool):
        raise DataError(source, "resample", f"expected true or false, got {resample_key!r}")
    alignment = None
    if files.mapped(data_file):  # a bag: [signals] references topics, read and aligned by its reader
        if "rate" in spec:
            raise DataError(source, "rate", f"{data_file.name} is a bag, whose messages carry their time: give the time "
                                            "base's rate as [alignment] rate")
        table, signals_spec, alignment = files.read_mapped(data_file, files.kind(data_file), _columns(spec, source),
                                                           source, signals_spec, spec.get("alignment"),
                                                           resample or resample_key)
    else:
        if "alignment" in spec:
            raise DataError(source, "[alignment]", f"aligns the topics of a bag (.mcap, .db3, a rosbag2 folder); "
                                                   f"{data_file.name} is a data file with one time: leave it out")
        table = files.read(data_file, _columns(spec, source), source)
    constants = _constants(spec.get("constants", {}), table, source)
    if "signals" in spec or alignment is not None:
        evaluated = _signals(signals_spec, table, constants, source, written)
        origin = Source(source, lambda name: f"[signals] {name}", noun="signal", container="[signals]")
    else:  # canonical columns need no mapping: each is its own signal, as in a data file read directly
        evaluated = _canonical(table, data_file, source)
        origin = Source(str(data_file), lambda name: f"column '{name}'")
    if "t" not in evaluated and rate is None:
        raise DataError(source, "[signals]", "no time: give t = \"<time variable>\" or rate = <Hz>")
    settings = Settings.from_table(_table(spec, "identification", source) if "identification" in spec else None,
                                   source)
    named = _model(spec, path)
    layer = signal_layer.parse(spec, source)
    window = _window(spec.get("window"), source)
    used = _Model(model, named, source)
    measurements = assemble(
        evaluated,
        origin,
        coordinates=coordinates,
        rate=rate,
        resample=resample or resample_key,
        window=window,
        drive=used.drive(evaluated),
        model=_coordinates_of(model),
        data_file=data_file,
        source=path,
        constants={**table.scalars, **constants},
    )
    if model is not None:
        check_units(measurements, model)
    measurements, layer = signal_layer.apply(measurements, layer, source)
    if "excitation" in spec:  # checked here as every table is; symbolic excite reads it (symbolic.data.excitation)
        excitation.parse(spec["excitation"], coordinates or _coordinates_of(model) or measurements.coordinates, source)
    controller = None
    if "controller" in spec:
        controller_table = _table(spec, "controller", source)
        controller = parse(controller_table, measurements.coordinates, used.parameters(controller_table), source,
                           coordinates or _coordinates_of(model), measurements.columns(), measurements.samples)
    return Experiment.of(measurements, model=named, settings=settings, controller=controller, window=window,
                         drive_gains=used.used(), signal_layer=layer, alignment=alignment)


def _coordinates_of(model: Robot | None) -> tuple[str, ...] | None:
    return None if model is None else tuple(model.generalized_coordinates)


class _Model:
    """The model an experiment is read for: the one given, else the experiment's ``model``, loaded only
    when a drive signal or a controller's gain needs it (its ``[[drive]] gain``, its parameters)."""

    def __init__(self, given: Robot | None, named: str | None, source: str) -> None:
        self.given, self.named, self.source = given, named, source
        self._robot: Robot | None = given
        self._applied: dict[str, float] = {}

    def robot(self) -> Robot | None:
        if self._robot is None and self.named is not None:
            self._robot = robots.resolve(self.named, folder=Path(self.source).parent)  # as _model located it
        return self._robot

    def drive(self, signals: Mapping[str, Any]) -> DriveGains:
        """The drive gains (τ_c = gain·u_c), read from the model only when ``signals`` hold a drive signal."""
        driven = [split[1] for split in map(split_name, signals) if split is not None and split[0] == "u"]
        if not driven:
            return DriveGains()
        robot = self.robot()
        gains = DriveGains() if robot is None else drive_gains(robot)
        self._applied = {c: gains.gains[c] for c in driven if c in gains.gains}
        return gains

    def used(self) -> dict[str, float]:
        """The gains applied, by coordinate (those given by a drive signal)."""
        return dict(self._applied)

    def parameters(self, table: Mapping[str, Any]) -> tuple[sp.Symbol, ...] | None:
        """The model's parameter symbols when a ``gain`` of the controller ``table`` names any; else
        ``None`` (no model needed: numbers, or no model known, then checked when a model uses it)."""
        gain = table.get("gain") if isinstance(table, Mapping) else None
        texts = gain if isinstance(gain, list) else [gain]
        if not any(isinstance(g, str) and variable_names(g) for g in texts):
            return None
        robot = self.robot()
        return None if robot is None else robot.parameter_symbols


def drive_gains(robot: Robot) -> DriveGains:
    """The ``[[drive]] gain`` of each coordinate of ``robot`` that has one, at the nominal parameter values.

    Raises
    ------
    DataError
        For a gain that is not a finite non-zero number at those values.
    """
    import sympy as sp

    if isinstance(robot, RobotNumbers):  # the gains are expressions: read the description itself
        robot = robot.robot()
    values = robot.parameter_values
    gains = {}
    for d in robot.drives:
        if d.gain is None:
            continue
        value = float(sp.sympify(d.gain).xreplace(values))
        if not np.isfinite(value) or value == 0:
            raise DataError(str(robot.source), f"[[drive]] '{d.coordinate}' gain",
                            f"{d.gain} = {value:g} at the nominal parameters (allowed: a finite non-zero number)")
        gains[d.coordinate] = value
    return DriveGains(gains, robot.name)


def _canonical(table: files.Table, data_file: Path, source: str) -> dict[str, np.ndarray]:
    """The signals of an experiment without ``[signals]``: the data file's variables as they are, which
    must include canonical ones (``t``, ``q_<c>``, ``tau_<c>``, ...), as for a data file read directly."""
    _refuse_unusable(table, data_file)
    if not any(name == "t" or split_name(name) is not None for name in table.vectors):
        variables = listing([*table.vectors, *table.scalars]) or "none"
        canonical = ", ".join(["t", *(f"{kind}_<c>" for kind in KINDS)])
        raise DataError(source, "[signals]", f"missing table, and {data_file.name} has no canonical column ({canonical}; "
                                             f"its variables: {variables}): map them, e.g. [signals] q_x = \"<variable>\"")
    return dict(table.vectors)


def _refuse_unusable(table: files.Table, path: Path) -> None:
    """A canonical column of a data file that is not a signal (text, a single number) is an error, not dropped."""
    for name in (*table.unusable, *table.scalars):
        if name == "t" or split_name(name) is not None:
            what = table.unusable.get(name, "a single number (a signal needs at least 2 samples)")
            raise DataError(str(path), f"column '{name}'", f"is {what}")


def _signals(spec: Mapping[str, Any], table: files.Table, constants: Mapping[str, float],
             source: str, written: Mapping[str, Any] | None = None) -> dict[str, np.ndarray]:
    """The ``[signals]``, evaluated; a ``tau_<c>`` written as a number is that number at every sample.
    ``written``: the expressions as the file writes them, for messages (a bag's are rewritten over variables)."""
    written = written or {}
    evaluated = {name: _evaluate(name, text, table, constants, source, written.get(name, text))
                 for name, text in spec.items() if not (name == "rate" and isfinite_number(text))}
    lengths = [len(v) for v in evaluated.values() if isinstance(v, np.ndarray)]
    if not lengths:
        raise DataError(source, "[signals]", "no signal of the file (give t, q_<c>, ... as variables of the data file)")
    return {name: v if isinstance(v, np.ndarray) else np.full(lengths[0], v) for name, v in evaluated.items()}


def _columns(spec: Mapping[str, Any], source: str) -> list[str] | None:
    """``columns``: the names of a header-less CSV file's columns, in file order (distinct identifiers)."""
    if "columns" not in spec:
        return None
    value = spec["columns"]
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise DataError(source, "columns", f"expected a list of column names in file order, e.g. [\"t\", \"q1\"], "
                                           f"got {value!r}")
    for k, name in enumerate(value):
        if not name.isidentifier():
            raise DataError(source, f"columns[{k}]", f"{name!r} is not a usable name (a name of letters, digits "
                                                     "and _, not starting with a digit: expressions use it)")
        if name in RESERVED_NAMES:  # "pi" would read as 3.14159 in [signals], not as the column
            raise DataError(source, f"columns[{k}]", f"{name!r} is {reserved_meaning(name)} in expressions: rename "
                                                     f"the column (e.g. {name + '_'!r}; reserved: "
                                                     f"{', '.join(sorted(RESERVED_NAMES))})")
    seen = [n for k, n in enumerate(value) if n in value[:k]]
    if seen:
        raise DataError(source, "columns", f"{seen[0]!r} is named twice (each column needs its own name)")
    return value


def resolve_data(name: str, experiment: Path) -> Path:
    """The data file ``name`` of ``experiment``.

    Looked for, in order: ``name`` itself if absolute, else relative to the experiment file's folder;
    then a file of the same name (its last path component) in each folder of the environment variable
    ``SYMBOLIC_DATA_PATH``. So an experiment in a repository can point at data kept outside it (the
    shipped EMPS examples use ``../../../shared/data/emps/DATA_EMPS.mat``, the folder ``shared`` beside
    the checkout), and the same file works elsewhere (an installed package, another folder) with
    ``SYMBOLIC_DATA_PATH=/path/to/emps``. The error names both places looked at.
    """
    given = Path(name)
    # absolute, so that the message says where that is; not resolved: a relative path is read from the
    # experiment file's folder as the user sees it (a symlinked folder beside the checkout included)
    first = Path(os.path.normpath(given if given.is_absolute() else Path(os.path.abspath(experiment)).parent / given))
    candidates = [first]
    search = [Path(d) for d in os.environ.get(DATA_PATH_VARIABLE, "").split(os.pathsep) if d]
    candidates += [d / given.name for d in search]
    for candidate in candidates:
        if files.exists(candidate):
            return candidate.resolve()
    where = f"{DATA_PATH_VARIABLE}: {os.pathsep.join(map(str, search))}" if search else f"{DATA_PATH_VARIABLE} unset"
    raise DataError(
        str(experiment),
        "data",
        f"data file {name!r} not found (looked at {first} and, by name, in the folders of {where}); give a path "
        f"relative to the experiment file or set {DATA_PATH_VARIABLE} to the folder that holds {given.name}",
    )


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


def _model(spec: Mapping[str, Any], path: Path) -> str | None:
    """The experiment's ``model`` by the precedence of :func:`symbolic.robots.locate`, a relative path from the
    experiment file's folder: a model file, as its absolute path, or a built-in robot's name as written."""
    model = _string(spec, "model", str(path))
    if model is None:
        return None
    try:
        found = robots.locate(model, path.parent)
    except ModelError as error:
        raise DataError(str(path), "model", error.problem) from None
    if model in robots.names() and found == robots.path(model):
        return model
    resolved = found.resolve()
    if not resolved.is_file():
        raise DataError(str(path), "model", f"model file {model!r} not found (looked at {resolved})")
    return str(resolved)


def sample_rate(spec: Mapping[str, Any], signals: Mapping[str, Any], source: str) -> float | None:
    """The experiment's ``rate`` (or its ``[signals] rate``), checked; ``None`` when neither is given.

    Raises
    ------
    DataError
        Both given (or a rate beside a time signal), or a rate that is not a number within the allowed range.
    """
    given = [(key, value) for key, value in (("rate", spec.get("rate")), ("[signals] rate", signals.get("rate")))
             if value is not None and (key == "rate" or isfinite_number(value))]
    if not given:
        return None
    if len(given) > 1 or "t" in signals:
        other = "t in [signals]" if "t" in signals else "[signals] rate"
        raise DataError(source, given[0][0], f"give either the time ({other}) or a rate, not both")
    key, value = given[0]
    if not isfinite_number(value) or not 1.0 / MAX_MAGNITUDE <= value <= MAX_RATE:
        raise DataError(source, key, f"expected a sampling rate in Hz from {1.0 / MAX_MAGNITUDE:g} to {MAX_RATE:g}, "
                                     f"got {value!r}")
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
        if abs(value) > MAX_MAGNITUDE:
            raise DataError(source, key, f"{value:g} is beyond the magnitude {MAX_MAGNITUDE:g} of any measured value "
                                         "(allowed: numbers of magnitude at most 1e+30)")
        constants[name] = float(value)
    return constants


def _evaluate(name: str, text: Any, table: files.Table, constants: Mapping[str, float], source: str,
              written: Any = None) -> np.ndarray | float:
    """The values of signal ``name`` = expression ``text`` of the file's variables and the constants; a
    number for a ``tau_<c>`` written as a number (broadcast to every sample by :func:`_signals`). ``written``:
    the expression as the file writes it, for messages."""
    key = f"[signals] {name}"
    written = text if written is None else written
    if not name.isidentifier() or name in RESERVED_NAMES:
        raise DataError(source, key, "a signal name must be an identifier (t, q_<c>, tau_<c>, ... or an extra name) "
                                     f"other than {', '.join(sorted(RESERVED_NAMES))} (expressions reserve them)")
    if isinstance(text, str):
        _check_names(text, table, constants, source, key, written)
        if text.strip() in table.vectors:  # a column as it is (most signals): no expression to compile
            return np.array(table.vectors[text.strip()], dtype=float)
    import sympy as sp

    from symbolic.description.expressions import parse_expression

    usable = [*table.vectors, *table.scalars, *constants]
    symbols = {v: sp.Symbol(v) for v in usable if v.isidentifier() and v not in RESERVED_NAMES}
    try:
        expression = parse_expression(text, symbols, source, key)
    except ModelError as error:
        problem = error.problem.replace(repr(text), repr(written)) if written != text else error.problem
        raise DataError(error.source, error.key, problem) from None
    used = sorted(expression.free_symbols, key=lambda s: s.name)
    values = []
    for s in used:
        values.append(table.vectors.get(s.name, table.scalars.get(s.name, constants.get(s.name))))
    lengths = {s.name: len(v) for s, v in zip(used, values) if isinstance(v, np.ndarray)}
    if len(set(lengths.values())) > 1:
        detail = ", ".join(f"{v} has {n} samples" for v, n in lengths.items())
        raise DataError(source, key, f"length mismatch between the variables of {written!r}: {detail}")
    if not used and (split_name(name) or ("",))[0] == "tau":
        return float(expression)  # a number: tau_<c> = "0", a coordinate without an actuator
    if not lengths:
        raise DataError(source, key, f"{written!r} uses no signal of the file (a signal varies with the samples; "
                                     "only a generalized force tau_<c> may be a number, e.g. \"0\" without an actuator)")
    function = sp.lambdify(used, expression, modules="numpy", dummify=True)
    # NumPy numbers throughout: a scalar of 1e300 squared is inf (refused with the sample by the checks of
    # the signals), where a Python float would raise OverflowError
    arguments = [np.asarray(v, dtype=float) if isinstance(v, np.ndarray) else np.float64(v) for v in values]
    with np.errstate(all="ignore"):
        try:
            result = np.asarray(function(*arguments), dtype=float)
        except (OverflowError, ZeroDivisionError, ValueError) as exc:
            raise DataError(source, key, f"cannot compute {shorten(str(written))}: {exc}") from None
    return np.broadcast_to(result, (next(iter(lengths.values())),)).copy()


def _check_names(text: str, table: files.Table, constants: Mapping[str, float], source: str, key: str,
                 written: str | None = None) -> None:
    """Refuse names that are neither variables of the file nor constants, listing what there is, and
    a reserved name (``pi``, ``sin``) that is also a variable of the file: neither reading is chosen."""
    shown = text if written is None else written
    for name in reserved_uses(text):
        if name in table.vectors or name in table.scalars or name in table.unusable:
            raise DataError(source, key, f"{name!r} in {shown!r} is ambiguous: {Path(table.source).name} has a variable "
                                         f"{name!r} and expressions read {name!r} as {reserved_meaning(name)}; rename "
                                         "the variable (in columns = [...] for a CSV file without a header line, "
                                         "else in the file)")
    for name in variable_names(text):
        if name in table.unusable:
            raise DataError(source, key, f"variable {name!r} of {Path(table.source).name} is {table.unusable[name]}")
        if name not in table.vectors and name not in table.scalars and name not in constants:
            variables = ", ".join([*map(table.shown, table.vectors), *table.scalars]) or "none"
            raise DataError(
                source,
                key,
                f"unknown variable {name!r} in {shown!r} (variables of {Path(table.source).name}: {variables}; "
                f"[constants]: {', '.join(constants) or 'none'})",
            )


def _window(spec: Any, source: str) -> tuple[float | None, float | None] | None:
    if spec is None:
        return None
    if not isinstance(spec, Mapping):
        raise DataError(source, "[window]", f"expected a table with start and/or stop, got {type(spec).__name__}")
    check_keys(spec, WINDOW_KEYS, source, "[window]")
    bounds = []
    for k in ("start", "stop"):
        value = spec.get(k)
        if value is not None and not isfinite_number(value):
            raise DataError(source, f"[window] {k}", f"expected a time in seconds, got {value!r}")
        bounds.append(None if value is None else float(value))
    if bounds[0] is not None and bounds[1] is not None and bounds[0] >= bounds[1]:
        raise DataError(source, "[window]", f"start {bounds[0]:g} s is not before stop {bounds[1]:g} s")
    return bounds[0], bounds[1]
