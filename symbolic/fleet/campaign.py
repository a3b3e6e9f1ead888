"""Campaign files: which robots, which logs, when each was recorded, and what to do with each (docs/fleet.md).

Input: a TOML campaign file. Output: a frozen :class:`Campaign` whose robots have their model loaded and
validated, their logs found (a glob, or a ``[[robot.log]]`` list) and the way each log's time is read,
and the task (``identify``, ``diagnose`` or ``simulate``) with its settings checked. Every problem is one
line ``FILE: KEY: what is wrong (what is allowed)`` (a :class:`~symbolic.data.DataError`), raised before
any work starts; a log that cannot be read or timed is not a campaign error but a row of the results.
The format is written once, in docs/fleet.md ("Campaign files").
"""

from __future__ import annotations

import datetime as dt
import functools
import glob
import json
import math
import os
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from symbolic import robots
from symbolic.data.errors import DataError
from symbolic.data.files import exists, read_toml
from symbolic.data.keys import check_keys
from symbolic.data.settings import Settings
from symbolic.description.modelfile import loads
from symbolic.description.robot import Robot, digest
from symbolic.errors import ModelError, ModelWarning, listing, one_line, shown, suggestion
from symbolic.identify.known import unknown_parameters

KINDS = ("identify", "diagnose", "simulate")
"""What a campaign does with each log: the library functions of ``symbolic identify``, ``diagnose``, ``simulate``."""

TOP_KEYS = ("name", "description", "task", "analysis", "robot")
ROBOT_KEYS = ("id", "model", "root", "tip", "logs", "experiment", "time", "log", "task")
LOG_KEYS = ("file", "time")
TIME_KEYS = {"name": ("from", "pattern", "format"), "column": ("from", "column")}
EVENT_KEYS = ("window", "ratio")
ANALYSIS_KEYS = ("alpha", "min_change", "min_logs")
TASK_KEYS = {
    "identify": ("kind", "identification", "events", "method", "fix", "consistent"),
    "diagnose": ("kind", "identification", "events", "fix", "effects", "simulate"),
    "simulate": ("kind", "identification", "events", "method", "substeps", "friction_velocity"),
}
SIMULATION_METHODS = ("rk4", "Radau", "BDF", "LSODA")
ID_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
NOT_READ = "not read (a campaign reads only logs that are files, not links; name the file itself)"
"""What is said of a log that is a symbolic link (:func:`linked`)."""


@dataclass(frozen=True)
class Events:
    """How a log's residual bursts are found (:mod:`symbolic.fleet.events`).

    Attributes
    ----------
    window
        Length (s) of the moving window over which the residual's mean square is taken.
    ratio
        A burst is where that windowed RMS exceeds ``ratio`` times the log's own robust residual RMS.
    """

    window: float = 0.1
    ratio: float = 4.0


@dataclass(frozen=True)
class Task:
    """What is done with each log: ``kind`` and its settings (``options``: the keys of ``[task]`` besides
    kind, identification and events, as given), the data treatment and the event search."""

    kind: str = "identify"
    options: tuple[tuple[str, Any], ...] = ()
    identification: Settings = Settings()
    events: Events = Events()

    def option(self, key: str, default: Any = None) -> Any:
        return dict(self.options).get(key, default)

    def canonical(self) -> str:
        """A text that determines the task (JSON, keys sorted): part of each result's cache key."""
        return json.dumps({"kind": self.kind, "options": dict(self.options), "identification": self.identification.given(),
                           "events": {"window": self.events.window, "ratio": self.events.ratio}},
                          sort_keys=True, default=list)


@dataclass(frozen=True)
class Log:
    """One log of a robot: the file, its name as the results show it, and its time when known before reading it."""

    path: Path
    name: str
    time: dt.datetime | None = None
    """From the file name or the ``[[robot.log]]`` list (UTC); ``None``: read from a column, or not readable."""
    time_problem: str | None = None
    """Why the time could not be read from the file name (the log is then a row with this error)."""
    refused: str | None = None
    """Why the file is not read at all (a symbolic link: :func:`linked`); the log is then a row with this error."""


@dataclass(frozen=True, eq=False)
class RobotEntry:
    """A ``[[robot]]``: its id, the model (file path, text, validated description), its logs and task."""

    id: str
    model_source: str
    model_text: str = field(repr=False)
    robot: Robot = field(repr=False)
    logs: tuple[Log, ...]
    task: Task
    experiment: Path | None = None
    time_column: str | None = None
    chain: tuple[str | None, str | None] = (None, None)
    """``root``, ``tip``: the chain of a URDF model's tree."""

    @functools.cached_property
    def model_digest(self) -> str:
        """SHA-256 of the validated description (:func:`symbolic.description.robot.digest`), computed once: it walks
        every expression of the model (0.5 ms for the two-link arm), and a campaign asks for it per log (its rows,
        jobs and cache keys), 0.05 s of the client's serial planning for 36 logs (bench/fleet.py). The entry and
        its frozen description do not change."""
        return digest(self.robot)


@dataclass(frozen=True)
class Analysis:
    """Thresholds of what a fleet tells (docs/fleet.md, "What is flagged").

    Attributes
    ----------
    alpha
        Probability that a fleet without any drift, outlier or event gets one flagged (family-wise,
        Bonferroni over every test of the campaign).
    min_change
        Smallest relative change (drift) or difference (outlier) worth a flag, as a fraction.
    min_logs
        Logs a robot needs before a trend is tested.
    """

    alpha: float = 0.01
    min_change: float = 0.05
    min_logs: int = 4


@dataclass(frozen=True, eq=False)
class Campaign:
    """A checked campaign file (module docstring)."""

    path: Path
    name: str
    description: str
    robots: tuple[RobotEntry, ...]
    analysis: Analysis

    @property
    def logs(self) -> int:
        return sum(len(r.logs) for r in self.robots)


def load(path: str | Path) -> Campaign:
    """Read and check a campaign file; :class:`DataError` (one line: file, key, problem, what is allowed)."""
    path = Path(path)
    source = str(path)
    spec = read_toml(path, "campaign")
    check_keys(spec, TOP_KEYS, source)
    name = _text(spec, "name", source, path.stem)
    description = _text(spec, "description", source, "")
    task = _task(spec.get("task", {}), source, "[task]")
    analysis = _analysis(spec.get("analysis", {}), source)
    entries = spec.get("robot")
    if not isinstance(entries, list) or not entries or not all(isinstance(e, dict) for e in entries):
        raise DataError(source, "[[robot]]", "no robots: add at least one [[robot]] table with id, model and logs")
    models: dict[str, tuple[str, str, Robot]] = {}
    robots_: list[RobotEntry] = []
    for k, entry in enumerate(entries):
        robots_.append(_robot(entry, k, path, task, models))
    seen = [r.id for i, r in enumerate(robots_) if r.id in [s.id for s in robots_[:i]]]
    if seen:
        raise DataError(source, f"[[robot]] '{seen[0]}' id", "used twice (each robot needs its own id)")
    return Campaign(path, name, description, tuple(robots_), analysis)


def _text(spec: Mapping[str, Any], key: str, source: str, default: str) -> str:
    value = spec.get(key, default)
    if not isinstance(value, str):
        raise DataError(source, key, f"expected a string, got {shown(value)}")
    return value


def _table(value: Any, source: str, where: str) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise DataError(source, where, f"expected a table, got {shown(value)}")
    return value


def _number(value: Any, source: str, where: str, low: float, high: float = math.inf, integer: bool = False,
            low_open: bool = True) -> float:
    """A number in (low, high) (or [low, high) when not ``low_open``), refused otherwise with the range allowed."""
    kind = int if integer else (int, float)
    ok = isinstance(value, kind) and not isinstance(value, bool) and math.isfinite(value)
    ok = ok and (value > low if low_open else value >= low) and value < high
    if not ok:
        bracket = "(" if low_open else "["
        what = "an integer" if integer else "a number"
        upper = "∞" if high == math.inf else f"{high:g}"
        raise DataError(source, where, f"expected {what} in {bracket}{low:g}, {upper}), got {shown(value)}")
    return value


def _names(value: Any, source: str, where: str) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",") if v.strip()]
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise DataError(source, where, f"expected a list of names, e.g. [\"m1\", \"I1\"], got {shown(value)}")
    return tuple(value)


def _task(value: Any, source: str, where: str) -> Task:
    table = _table(value, source, where)
    kind = table.get("kind", "identify")
    if kind not in KINDS:
        raise DataError(source, f"{where} kind", f"unknown task {shown(kind)} (allowed: {', '.join(KINDS)})")
    check_keys(table, TASK_KEYS[kind], source, where)
    options: dict[str, Any] = {}
    if "method" in table:
        allowed = ("wls", "ols") if kind == "identify" else SIMULATION_METHODS
        if table["method"] not in allowed:
            raise DataError(source, f"{where} method", f"unknown method {shown(table['method'])} (allowed for "
                                                       f"{kind}: {', '.join(allowed)})")
        options["method"] = table["method"]
    if "fix" in table:
        options["fix"] = _names(table["fix"], source, f"{where} fix")
    for key in ("consistent", "simulate"):
        if key in table:
            if not isinstance(table[key], bool):
                raise DataError(source, f"{where} {key}", f"expected true or false, got {shown(table[key])}")
            options[key] = table[key]
    if "effects" in table:
        options["effects"] = _effects(table["effects"], source, f"{where} effects")
    if "substeps" in table:
        options["substeps"] = int(_number(table["substeps"], source, f"{where} substeps", 0, 10_000, integer=True))
    if "friction_velocity" in table:
        options["friction_velocity"] = float(_number(table["friction_velocity"], source, f"{where} friction_velocity", 0))
    settings = Settings()
    if "identification" in table:
        try:
            settings = Settings.from_table(_table(table["identification"], source, f"{where} identification"), source)
        except DataError as error:  # named as the campaign file has it: [task] identification bandwidth
            key = error.key.replace("[identification]", f"{where} identification", 1)
            raise DataError(source, key, error.problem) from None
    events = Events()
    if "events" in table:
        events_table = _table(table["events"], source, f"{where} events")
        check_keys(events_table, EVENT_KEYS, source, f"{where} events")
        events = Events(
            window=float(_number(events_table.get("window", events.window), source, f"{where} events window", 0, 3600)),
            ratio=float(_number(events_table.get("ratio", events.ratio), source, f"{where} events ratio", 1, 1e6)))
    return Task(kind, tuple(sorted(options.items())), settings, events)


def _effects(value: Any, source: str, where: str) -> tuple[str, ...]:
    from symbolic.workflow.effects import EFFECTS, select

    names = _names(value, source, where)
    try:
        select(names)
    except KeyError as error:
        raise DataError(source, where, f"unknown effect(s) {', '.join(error.args[0])} (catalogue: {', '.join(EFFECTS)})") \
            from None
    return names


def _analysis(value: Any, source: str) -> Analysis:
    table = _table(value, source, "[analysis]")
    check_keys(table, ANALYSIS_KEYS, source, "[analysis]")
    default = Analysis()
    return Analysis(
        alpha=float(_number(table.get("alpha", default.alpha), source, "[analysis] alpha", 0, 1)),
        min_change=float(_number(table.get("min_change", default.min_change), source, "[analysis] min_change", 0,
                                 low_open=False)),
        min_logs=int(_number(table.get("min_logs", default.min_logs), source, "[analysis] min_logs", 2, 10**9,
                             integer=True)),
    )


def _robot(entry: Mapping[str, Any], k: int, campaign: Path, task: Task, models: dict) -> RobotEntry:
    source = str(campaign)
    ident = entry.get("id")
    if not isinstance(ident, str) or not ID_PATTERN.fullmatch(ident):
        raise DataError(source, f"[[robot]] #{k + 1} id", f"expected an id of letters, digits, '_', '.', '-' (up to 64, "
                                                         f"not starting with '_', '.' or '-'), got {shown(ident)}")
    where = f"[[robot]] '{ident}'"
    check_keys(entry, ROBOT_KEYS, source, where)
    chain = tuple(_link(entry.get(key), source, f"{where} {key}") for key in ("root", "tip"))
    model_source, text, robot = _model(entry.get("model"), campaign, f"{where} model", models, chain)
    if "task" in entry:
        task = _task(entry["task"], source, f"{where} task")
    _check_fix(task, robot, source, f"{where} task fix" if "task" in entry else "[task] fix", entry["model"])
    experiment = None
    if "experiment" in entry:
        experiment = _existing(entry["experiment"], campaign, f"{where} experiment", "an experiment file",
                               "experiment file")
    reader, column = _time_reader(entry.get("time"), source, f"{where} time")
    logs = _listed_logs(entry.get("log", []), campaign, f"{where} log")
    if "logs" in entry:
        if reader is None and column is None:
            raise DataError(source, f"{where} time", "missing: say how each log's date and time is read: time = "
                                                     "{ from = \"name\", pattern = ..., format = ... } or { from = "
                                                     "\"column\", column = ... }, or list the logs as [[robot.log]] "
                                                     "with file and time")
        logs += _globbed_logs(entry["logs"], campaign, f"{where} logs", reader)
    elif "time" in entry and not logs:
        raise DataError(source, f"{where} logs", "missing: a glob of the robot's logs, e.g. logs = \"logs/r01_*.csv\"")
    if not logs:
        raise DataError(source, f"{where} logs", "missing: give logs = \"<glob>\" (relative to the campaign file) or "
                                                 "[[robot.log]] entries with file and time")
    _check_twice(logs, source, f"{where} logs")
    return RobotEntry(ident, model_source, text, robot, tuple(logs), task, experiment, column, chain)


def _check_fix(task: Task, robot: Robot, source: str, where: str, model: str) -> None:
    """Refuse a name of ``fix`` that is not a parameter of the robot's model, before any work: every log would
    otherwise be an error row (:func:`symbolic.identify.known.fixed_symbols` says so per log, for ``--fix``)."""
    unknown = unknown_parameters(robot, task.option("fix", ()))
    if unknown:
        names = [p.name for p in robot.parameters]
        raise DataError(source, where, f"unknown parameter(s) {listing(unknown)} of the model {model!r} (its parameters: "
                                       f"{listing(names)}){suggestion(unknown[0], names)}")


def _check_twice(logs: list[Log], source: str, where: str) -> None:
    """Refuse a file listed twice for a robot, under whatever names (``logs/x.csv``, ``logs/../logs/./x.csv``, a
    folder reached through a link): it would count twice in the robot's drift."""
    seen: dict[str, Log] = {}
    for log in logs:  # the folder resolved, not the file: a link is a log of its own, refused (linked)
        same = seen.setdefault(os.path.join(os.path.realpath(log.path.parent), log.path.name), log)
        if same is not log:
            named = "" if str(log.path) == str(same.path) else f" (as {str(log.path)!r} and {str(same.path)!r})"
            raise DataError(source, where, f"{same.name!r} is listed twice{named}: each log counts once")


def _link(value: Any, source: str, where: str) -> str | None:
    if value is not None and (not isinstance(value, str) or not value.strip()):
        raise DataError(source, where, f"expected the name of a link of the URDF model, got {shown(value)}")
    return value


def _existing(name: Any, campaign: Path, where: str, expected: str, found: str, data: bool = False) -> Path:
    """The file ``name`` names (relative to the campaign file), refused unless a name of an existing file:
    "expected {expected} name" or "{found} '...' not found". ``data``: a log, which may also be a rosbag2 folder."""
    if not isinstance(name, str) or not name.strip():
        raise DataError(str(campaign), where, f"expected {expected} name, got {shown(name)}")
    path = _relative(name, campaign)
    if not (exists(path) if data else path.is_file()):
        raise DataError(str(campaign), where, f"{found} {str(path)!r} not found (a path relative to the campaign file)")
    return path


def _relative(name: str, campaign: Path) -> Path:
    given = Path(name).expanduser()
    return given if given.is_absolute() else campaign.parent / given


def _model(value: Any, campaign: Path, where: str, models: dict,
           chain: tuple[str | None, str | None] = (None, None)) -> tuple[str, str, Robot]:
    """(file, text, validated robot) of a robot's model: a file (TOML, or URDF with the chain ``root``, ``tip``)
    relative to the campaign file, or a built-in name (the precedence of :func:`symbolic.robots.locate`)."""
    source = str(campaign)
    if not isinstance(value, str) or not value.strip():
        raise DataError(source, where, f"expected a model file (relative to the campaign file) or a built-in robot "
                                       f"name ({', '.join(robots.names())}), got {shown(value)}")
    try:
        path = robots.locate(os.path.expanduser(value), campaign.parent)
    except ModelError as error:
        raise DataError(source, where, error.problem) from None
    if not path.is_file():
        raise DataError(source, where, f"no model file {str(path)!r} (a path relative to the campaign file)")
    key = (str(path.resolve()), chain)
    if chain != (None, None) and path.suffix.lower() != ".urdf":
        raise DataError(source, where, "root and tip choose a chain of a URDF model (a .urdf file) only")
    if key not in models:
        try:
            text = path.read_bytes().decode("utf-8")
        except (OSError, UnicodeDecodeError) as error:
            raise DataError(source, where, f"cannot read model file {str(path)!r}: {one_line(str(error))}") from None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)  # the model's own warnings are for symbolic derive
            try:
                robot = read_model(str(path), text, chain)
            except ModelError as error:
                raise DataError(source, where, f"the model does not load: {error}") from None
        models[key] = (str(path), text, robot)
    return models[key]


def read_model(source: str, text: str, chain: tuple[str | None, str | None] = (None, None)) -> Robot:
    """The validated description of a model file's ``text`` (a URDF file is read from ``source``, its chain
    chosen by ``chain``): the one reading of a campaign's models, by the client and by every worker."""
    if source.lower().endswith(".urdf"):
        from symbolic.description.modelfile import load

        return load(source, root=chain[0], tip=chain[1])
    return loads(text, source)


def _time_reader(value: Any, source: str, where: str):
    """(reader of a file name's time or None, column name or None) from a robot's ``time`` table."""
    if value is None:
        return None, None
    table = _table(value, source, where)
    origin = table.get("from")
    if origin not in TIME_KEYS:
        raise DataError(source, f"{where} from", f"expected \"name\" (the file name) or \"column\" (a column of the "
                                                 f"log: UNIX seconds at its first sample), got {shown(origin)}")
    check_keys(table, TIME_KEYS[origin], source, where)
    if origin == "column":
        column = table.get("column")
        if not isinstance(column, str) or not column.strip():
            raise DataError(source, f"{where} column", f"expected the name of the log's column of UNIX time (s), got "
                                                       f"{shown(column)}")
        return None, column
    form = table.get("format")
    if not isinstance(form, str) or "%" not in form:
        raise DataError(source, f"{where} format", f"expected a strptime format of the date in the file name, e.g. "
                                                   f"\"%Y-%m-%d\" or \"%Y%m%dT%H%M\", got {shown(form)}")
    pattern = table.get("pattern")
    compiled = None
    if pattern is not None:
        if not isinstance(pattern, str):
            raise DataError(source, f"{where} pattern", f"expected a regular expression, got {shown(pattern)}")
        try:
            compiled = re.compile(pattern)
        except re.error as error:
            raise DataError(source, f"{where} pattern", f"not a regular expression ({error}): e.g. '(\\d{{8}})'") \
                from None

    search = compiled if compiled is not None else _format_pattern(form)

    def read(name: str) -> tuple[dt.datetime | None, str | None]:
        text = Path(name).stem
        if search is not None:
            found = search.search(Path(name).name)
            if found is None:
                what = f"the pattern {pattern!r}" if compiled is not None else f"the format {form!r}"
                return None, f"time: the file name does not match {what} of {where}"
            text = found.group(1) if found.groups() else found.group(0)
        try:
            return _utc(dt.datetime.strptime(text, form)), None
        except ValueError:
            return None, f"time: {text!r} of the file name does not read as {form!r} ({where})"

    return read, None


DIRECTIVES = {"Y": r"\d{4}", "m": r"\d{1,2}", "d": r"\d{1,2}", "H": r"\d{1,2}", "M": r"\d{1,2}", "S": r"\d{1,2}",
              "y": r"\d{2}", "j": r"\d{1,3}", "f": r"\d{1,6}", "b": r"[A-Za-z]{3}", "%": "%"}
"""Regular expressions of the strptime directives a date in a file name is found by (without a ``pattern``)."""


def _format_pattern(form: str) -> re.Pattern | None:
    """A regular expression finding ``form``'s date anywhere in a file name (``r07_2024-03-01.csv`` with
    ``%Y-%m-%d``), or None when the format has a directive not in :data:`DIRECTIVES` (the whole name is read)."""
    parts, k = [], 0
    while k < len(form):
        if form[k] == "%" and k + 1 < len(form):
            if form[k + 1] not in DIRECTIVES:
                return None
            parts.append(DIRECTIVES[form[k + 1]] if form[k + 1] != "%" else "%")
            k += 2
        else:
            parts.append(re.escape(form[k]))
            k += 1
    return re.compile("".join(parts))


def _utc(moment: dt.datetime) -> dt.datetime:
    """A time as UTC (a time without a zone is taken as UTC)."""
    return moment.replace(tzinfo=dt.timezone.utc) if moment.tzinfo is None else moment.astimezone(dt.timezone.utc)


def _listed_logs(value: Any, campaign: Path, where: str) -> list[Log]:
    source = str(campaign)
    if not isinstance(value, list) or not all(isinstance(e, dict) for e in value):
        raise DataError(source, f"{where}", "expected [[robot.log]] tables with file and time")
    out = []
    for k, entry in enumerate(value):
        check_keys(entry, LOG_KEYS, source, f"{where} #{k + 1}")
        moment = entry.get("time")
        path = _existing(entry.get("file"), campaign, f"{where} #{k + 1} file", "a log file", "log", data=True)
        if isinstance(moment, dt.datetime):
            moment = _utc(moment)
        elif isinstance(moment, dt.date):
            moment = dt.datetime(moment.year, moment.month, moment.day, tzinfo=dt.timezone.utc)
        else:
            raise DataError(source, f"{where} #{k + 1} time", f"expected a TOML date or date-time, e.g. "
                                                              f"2024-03-01T08:00:00Z, got {shown(moment)}")
        out.append(Log(path, _display(path, campaign), moment, refused=linked(path, path.parent)))
    return out


def _globbed_logs(pattern: Any, campaign: Path, where: str, reader) -> list[Log]:
    source = str(campaign)
    if not isinstance(pattern, str) or not pattern.strip():
        raise DataError(source, where, f"expected a glob of log files, e.g. \"logs/r01_*.csv\", got {shown(pattern)}")
    full = str(_relative(pattern, campaign))
    paths = sorted(Path(p) for p in glob.glob(full, recursive=True) if exists(Path(p)))  # files, rosbag2 folders
    if not paths:
        raise DataError(source, where, f"{pattern!r} matches no file (a glob relative to the campaign file: "
                                       f"looked for {full})")
    named = _literal(full)
    out = []
    for path in paths:
        moment, problem = reader(path.name) if reader is not None else (None, None)
        out.append(Log(path, _display(path, campaign), moment, problem, linked(path, named)))
    return out


def _literal(pattern: str) -> Path:
    """The folder a glob names literally: its parts before the first with a wildcard."""
    parts = Path(pattern).parts
    first = next((k for k, part in enumerate(parts) if glob.has_magic(part)), len(parts) - 1)
    return Path(*parts[:first])


def linked(path: Path, named: Path) -> str | None:
    """Why the log ``path`` is refused when it is a symbolic link or is reached through one below the folder
    ``named``, else None. The folders a campaign file names itself may be links (a log folder mounted
    elsewhere); what a wildcard finds may not: a link planted among the logs would otherwise have the
    campaign read, and quote in its errors, any file its user may read (docs/fleet.md, "Campaign files")."""
    try:
        below = path.relative_to(named).parts
    except ValueError:  # not under the folder named: the file itself is checked
        named, below = path.parent, (path.name,)
    for k in range(1, len(below) + 1):
        if os.path.islink(named.joinpath(*below[:k])):
            what = "is a symbolic link" if k == len(below) else f"is reached through the symbolic link {below[k - 1]!r}"
            return f"{what}: {NOT_READ}"
    return None


def _display(path: Path, campaign: Path) -> str:
    """The log's name in the results: its path relative to the campaign file's folder when inside it, as the
    campaign file names it (``logs/../logs/./x.csv`` is ``logs/x.csv``; a link is named, not followed)."""
    relative = Path(os.path.relpath(os.path.normpath(path), os.path.normpath(campaign.parent)))
    return str(path) if relative.parts[:1] == ("..",) else relative.as_posix()
