"""The campaign's results: the cache of per-log results keyed by content, and the results table (docs/fleet.md,
"Results and the cache").

* :func:`job_key`: SHA-256 of what a log's result depends on — the model's validated description, the
  log's bytes (an experiment file's and its data file's; the robot's mapping experiment's), the task and
  its settings, and the package's version stamp (:func:`symbolic.cache.stamp`: version, a digest of its
  sources, Python, SymPy, NumPy). Renaming or moving a log keeps its result; changing a byte does not.
* :class:`Store`: ``DIR/cache/`` holds one JSON file per key (``ab/abcdef….json``), each written whole
  (:func:`symbolic.writing.replacing`) as its result arrives, so an interrupted campaign keeps what it had
  computed; and ``files.json``, the SHA-256 of each log by (path, size, modification time), so a rerun
  over thousands of unchanged logs reads none of them. The folder is the campaign's own: the output set
  (:mod:`symbolic.export.output`) never touches a sub-folder.
* :func:`table`: the results as CSV text, one row per log (module docstring of :mod:`symbolic.fleet.execution`).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import logging
import math
import os
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from symbolic.cache import stamp
from symbolic.data.experiment import resolve_data
from symbolic.data.errors import DataError
from symbolic.errors import ExportError
from symbolic.fleet.campaign import RobotEntry, Log
from symbolic.writing import replacing

log = logging.getLogger(__name__)

CACHE = "cache"
"""The sub-folder of ``--out`` holding the results kept between runs."""

FILES = "files.json"
FIXED_COLUMNS = ("robot", "log", "time", "task", "status", "error", "gap", "gap_before", "gap_after", "effects",
                 "events", "samples", "duration", "seconds")


class Store:
    """The cache folder ``DIR/cache`` (module docstring)."""

    def __init__(self, out: str | os.PathLike) -> None:
        self.folder = Path(out) / CACHE
        if os.path.lexists(self.folder) and not self.folder.is_dir():  # before any work, not at the first result
            raise ExportError(f"{self.folder} is not a folder: a campaign keeps its results between runs in the "
                              f"folder {CACHE}/ of its output folder (move the file away, or choose another --out)")
        self._digests: dict[str, list] = {}
        self._changed = False
        try:
            self._digests = json.loads((self.folder / FILES).read_text())
            if not isinstance(self._digests, dict):
                self._digests = {}
        except (OSError, ValueError):
            self._digests = {}

    def file_digest(self, path: Path) -> str:
        """SHA-256 of ``path``'s bytes, remembered by (resolved path, size, modification time); of a folder (a
        rosbag2 bag), of its files' names and bytes in name order, remembered by their total size and latest time."""
        members = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        infos = [m.stat() for m in members]
        size, modified = sum(i.st_size for i in infos), max((i.st_mtime_ns for i in infos), default=0)
        name = str(path.resolve())
        known = self._digests.get(name)
        if isinstance(known, list) and known[:2] == [size, modified]:
            return str(known[2])
        sha = hashlib.sha256()
        for member in members:
            if path.is_dir():
                sha.update(f"{member.relative_to(path).as_posix()}\0{member.stat().st_size}\0".encode())
            with open(member, "rb") as handle:
                for block in iter(lambda: handle.read(1 << 20), b""):
                    sha.update(block)
        self._digests[name] = [size, modified, sha.hexdigest()]
        self._changed = True
        return sha.hexdigest()

    def _entry(self, key: str) -> Path:
        return self.folder / key[:2] / f"{key}.json"

    def get(self, key: str) -> dict[str, Any] | None:
        """The kept result of ``key``, or None (absent, unreadable, or another key's)."""
        try:
            value = json.loads(self._entry(key).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        return value if isinstance(value, dict) and value.get("key") == key else None

    def put(self, key: str, result: Mapping[str, Any]) -> None:
        """Keep ``result`` under ``key`` (written whole: a reader sees the old entry or the new one)."""
        path = self._entry(key)
        path.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps({k: v for k, v in result.items() if k != "cacheable"}, sort_keys=True, allow_nan=True)
        with replacing(path) as temporary:
            temporary.write_text(text, encoding="utf-8")

    def save_digests(self) -> None:
        """Write the file digests (``files.json``) when they changed."""
        if not self._changed:
            return
        self.folder.mkdir(parents=True, exist_ok=True)
        with replacing(self.folder / FILES) as temporary:
            temporary.write_text(json.dumps(self._digests, sort_keys=True), encoding="utf-8")
        self._changed = False


def log_digest(store: Store, path: Path) -> str:
    """SHA-256 of a log: its bytes, and for an experiment file also its data file's (when it can be found)."""
    own = store.file_digest(path)
    if path.suffix.lower() != ".toml":
        return own
    try:
        spec = tomllib.loads(path.read_text(encoding="utf-8"))
        data = resolve_data(spec["data"], path) if isinstance(spec.get("data"), str) else None
    except (OSError, ValueError, DataError):
        data = None  # the worker reports what is wrong with the file; its bytes key the error
    return own if data is None else hashlib.sha256(f"{own} {store.file_digest(data)}".encode()).hexdigest()


def job_key(store: Store, robot: RobotEntry, entry: Log) -> str:
    """The cache key of one log's result (module docstring)."""
    parts = {
        "stamp": stamp(),
        "model": robot.model_digest,
        "task": robot.task.canonical(),
        "log": log_digest(store, entry.path),
        "experiment": None if robot.experiment is None else log_digest(store, robot.experiment),
        "time_column": robot.time_column,
    }  # a URDF chain (root, tip) is in the model's digest: the description of the chain it gives
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()


def _number(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    return str(value)


def parameter_names(rows: Iterable[Mapping[str, Any]]) -> list[str]:
    """The parameters of all rows, in the order first met."""
    names: dict[str, None] = {}
    for row in rows:
        for p in row.get("parameters") or []:
            names.setdefault(p["name"], None)
    return list(names)


def simulation_columns(rows: Iterable[Mapping[str, Any]]) -> list[tuple[str, str]]:
    """(coordinate, signal) pairs of the simulated rows, in the order first met."""
    pairs: dict[tuple[str, str], None] = {}
    for row in rows:
        for c, errors in (row.get("simulation") or {}).items():
            for signal in errors:
                pairs.setdefault((c, signal), None)
    return list(pairs)


def table(rows: Sequence[Mapping[str, Any]]) -> str:
    """The results as CSV text: the fixed columns, then ``value:P`` and ``sigma:P`` for every parameter P, then
    ``sim:C:SIGNAL`` (%) of simulated logs. Numbers are written with 17 significant digits (read back exactly)."""
    from symbolic.fleet.events import describe

    names = parameter_names(rows)
    simulated = simulation_columns(rows)
    header = [*FIXED_COLUMNS, *[f"{kind}:{n}" for n in names for kind in ("value", "sigma")],
              *[f"sim:{c}:{s}" for c, s in simulated]]
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        values = {p["name"]: p for p in row.get("parameters") or []}
        fixed = [row["robot"], row["log"], row.get("time") or "", row.get("task", ""), row["status"],
                 row.get("error") or "", *[_number(row.get(k)) for k in ("gap", "gap_before", "gap_after")],
                 "; ".join(f"{e['effect']} on {e['coordinate']}" for e in row.get("effects") or []),
                 "; ".join(describe(e) for e in row.get("events") or []),
                 *[_number(row.get(k)) for k in ("samples", "duration", "seconds")]]
        estimates = [_number(values[n][kind]) if n in values else "" for n in names for kind in ("value", "sigma")]
        sims = [_number((row.get("simulation") or {}).get(c, {}).get(s)) for c, s in simulated]
        writer.writerow([*fixed, *estimates, *sims])
    return buffer.getvalue()


def read_table(text: str) -> list[dict[str, str]]:
    """The rows of a results table as text fields (for a reader that does not want pandas)."""
    return list(csv.DictReader(io.StringIO(text)))
