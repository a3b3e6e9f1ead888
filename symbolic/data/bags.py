"""ROS 2 bags (rosbag2, sqlite3 or MCAP storage) and MCAP files as data files: the reader of
:data:`symbolic.data.files.READERS` for logs whose signals are topics (docs/data.md, "Bags and MCAP files").

A bag has no columns: an experiment file maps topics and fields onto the signals,
``q_shoulder = "/joint_states.position[shoulder]"``, and this module

1. rewrites each ``[signals]`` expression, replacing every topic reference by a variable name (the references
   are read by a strict grammar, :data:`REFERENCE`; the rest of the text is the experiment's usual safe
   expression, parsed by :func:`symbolic.description.expressions.parse_expression`, never evaluated as Python);
2. checks every reference against the message type its topic has in the bag (field names, arrays and their
   index, numbers) before any message is read;
3. streams the messages of the referenced topics one by one (:mod:`mcap` for MCAP files, :mod:`rosbags` for
   rosbag2 folders and ``.db3`` files), keeping of each only its time and the numbers referenced;
4. aligns the topics onto one time base (:func:`align`): linear interpolation of positions, velocities and
   forces, zero-order hold of commands (``ref_<c>``), and reports the rates found, the gaps and the messages
   dropped (:class:`Alignment`).

A message's time is its ``header.stamp`` when its type has a ``std_msgs/Header`` and the stamp is not zero,
else the time the recorder logged it (``[alignment] stamp = "log"`` uses the log time throughout).

The readers are optional (``pip install 'symbolic[bags]'``: the packages ``mcap`` and ``rosbags``); without
them reading a bag is one error naming that command.
"""

from __future__ import annotations

import logging
import math
import re
import sqlite3
import time
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from symbolic.data.errors import DataError
from symbolic.data.keys import check_keys
from symbolic.data.measurements import MAX_RATE, UNIFORM_TOLERANCE, duration, isfinite_number, split_name
from symbolic.errors import PROGRESS_EVERY, ModelWarning, listing, shorten, suggestion

log = logging.getLogger(__name__)

INSTALL = "pip install 'symbolic[bags]'"
"""The command that installs the optional readers (the packages mcap and rosbags)."""

MCAP_MAGIC = b"\x89MCAP0\r\n"
SQLITE_MAGIC = b"SQLite format 3\x00"
METADATA = "metadata.yaml"
"""The file that makes a folder a rosbag2 bag."""

ALIGNMENT_KEYS = ("rate", "clock", "stamp", "max_gap", "method")
METHODS = ("linear", "hold")
STAMPS = ("header", "log")
HOLD_KINDS = ("ref",)
"""Signal kinds aligned by zero-order hold by default: commands, held by the machine until the next one."""

GAP_FACTOR = 1.5
"""A step between two messages of a topic longer than this many of its median steps is a gap."""
MAX_GAP_SECONDS = 0.1
MAX_GAP_PERIODS = 10
"""Default longest gap bridged: 0.1 s, or 10 of the topic's periods when that is longer (a slow topic)."""

MAX_UPSAMPLING = 10
"""A time base at ``[alignment] rate`` may hold at most this many samples per message of the busiest topic (or a
million): more invents data, and a rate in the wrong unit would ask for terabytes."""
INITIAL_ROWS = 1 << 22
"""Messages a topic's arrays are sized for at most before the first is read (4 Mi: 70 minutes at 1 kHz); past it
they double as messages come, so a count the file misstates allocates nothing it does not hold."""

NAME_FIELDS = ("name", "names", "joint_names")
"""Fields holding the names a ``[name]`` index is looked up in (JointState's ``name``, a controller state's
``joint_names``): the nearest of the message levels that hold the array, innermost first."""

_IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
_INDEX = r"\[[^\]\s\[]+\]"
REFERENCE = re.compile(rf"/{_IDENT}(?:/{_IDENT})*\.{_IDENT}(?:{_INDEX})?(?:\.{_IDENT}(?:{_INDEX})?)*")
"""A topic reference: ``/topic/name`` then ``.field`` segments, each optionally indexed by ``[0]`` (a position in
an array) or ``[joint_name]`` (the array's entry of that name). Digits only are a position."""
_SEGMENT = re.compile(rf"\.({_IDENT})(?:\[([^\]\s\[]+)\])?")
NUMBER_TYPES = ("bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
                "float32", "float64", "octet")

# rosbags' node kinds (rosbags.interfaces.Nodetype): a base type, a message, an array, a sequence
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4


def _missing(path: Path, what: str) -> DataError:
    return DataError(str(path), "file", f"reading {what} needs the packages mcap and rosbags, which are not "
                                        f"installed (install them: {INSTALL})")


# ---------------------------------------------------------------------------------------------- references


@dataclass(frozen=True)
class Reference:
    """One topic reference of a ``[signals]`` expression: the topic and the field path (name, index or None)."""

    text: str
    topic: str
    path: tuple[tuple[str, int | str | None], ...]


def parse_reference(text: str) -> Reference:
    """A :data:`REFERENCE` already matched: its topic and segments."""
    dot = text.index(".")
    segments = tuple((m.group(1), _index(m.group(2))) for m in _SEGMENT.finditer(text, dot))
    return Reference(text, text[:dot], segments)


def _index(text: str | None) -> int | str | None:
    if text is None:
        return None
    return int(text) if text.isdigit() else text


@dataclass(frozen=True)
class Request:
    """A reference aligned by one method; ``variable`` is its name in the rewritten expressions, ``key`` the first
    signal that uses it (``[signals] q_x``, for messages)."""

    reference: Reference
    method: str
    variable: str
    key: str


def rewrite(signals: Mapping[str, Any], methods: Mapping[str, str], source: str) -> tuple[dict[str, Any], list[Request]]:
    """The ``[signals]`` with every topic reference replaced by a variable, and the references to read.

    ``methods``: the alignment of each signal (``[alignment] method``); by default ``hold`` for the kinds of
    :data:`HOLD_KINDS`, else ``linear``. Text outside references is left as it is for the expression parser.
    """
    requests: dict[tuple[str, str], Request] = {}
    out: dict[str, Any] = {}
    for name, text in signals.items():
        key = f"[signals] {name}"
        if name == "t":
            raise DataError(source, key, "a bag's time is its messages' (the header stamp, else the log time): leave "
                                         "out t (allowed: the signals q_<c>, tau_<c>, u_<c>, qd_<c>, qdd_<c>, ref_<c> "
                                         "and extras, as topic references; the time base's rate: [alignment] rate)")
        if name == "rate":
            raise DataError(source, key, "a bag's messages carry their time: give the time base's rate as "
                                         "[alignment] rate")
        if not isinstance(text, str):
            out[name] = text
            continue
        kind = (split_name(name) or ("",))[0]
        method = methods.get(name, "hold" if kind in HOLD_KINDS else "linear")
        pieces, position, expect_operand = [], 0, True
        while position < len(text):
            c = text[position]
            if c.isspace():
                pieces.append(c)
                position += 1
                continue
            if c == "/" and expect_operand:
                match = REFERENCE.match(text, position)
                if match is None:
                    raise DataError(source, key, f"cannot read a topic reference at character {position + 1} of "
                                                 f"{shorten(text)} (allowed: /topic.field, /topic.field[0], "
                                                 "/topic.field[joint_name], /topic.a.b[1].c; names of letters, digits "
                                                 "and _)")
                if text[match.end():match.end() + 1] in ("[", "."):
                    raise DataError(source, key, f"cannot read the topic reference at character {match.end() + 1} of "
                                                 f"{shorten(text)} (allowed: /topic.field, /topic.field[0], "
                                                 "/topic.field[joint_name], /topic.a.b[1].c; names of letters, digits "
                                                 "and _)")
                reference = parse_reference(match.group())
                request = requests.setdefault((reference.text, method),
                                              Request(reference, method, f"_bag{len(requests)}", key))
                pieces.append(f" {request.variable} ")
                position = match.end()
                expect_operand = False
                continue
            expect_operand = c in "+-*/(,"
            pieces.append(c)
            position += 1
        out[name] = "".join(pieces).strip()
    return out, list(requests.values())


# ------------------------------------------------------------------------------------------ the bag readers


@dataclass
class Topic:
    """A topic of a bag: its message type, the count the bag's index gives (None when it does not), and whether
    its messages can be decoded (CDR with a ROS 2 schema), else why not."""

    name: str
    msgtype: str
    count: int | None
    problem: str | None = None


class _Bag:
    """What the alignment needs of a bag: its topics, a typestore for their types, its messages by topic."""

    described = "bag"

    def __init__(self, path: Path) -> None:
        self.path = path
        self.topics: dict[str, Topic] = {}
        self.typestore: Any = None

    def messages(self, topics: list[str]) -> Iterator[tuple[str, int, Any]]:
        """(topic, log time in ns, message bytes), in the bag's order."""
        raise NotImplementedError

    def close(self) -> None:
        pass

    def listing(self, most: int = 8) -> str:
        """The topics with their types and counts, for a message (the first ``most``)."""
        shown = [f"{t.name} ({t.msgtype}{'' if t.count is None else f', {t.count} messages'})"
                 for t in sorted(self.topics.values(), key=lambda t: t.name)[:most]]
        more = f", and {len(self.topics) - most} more" if len(self.topics) > most else ""
        return ", ".join(shown) + more if shown else "none"


def _typestore(definitions: Mapping[str, tuple[str, str]], used: set[str], distro: str | None = None) -> Any:
    """A typestore of the types ``used`` (the topics') and those they contain: the bag's own definitions (name ->
    (format "msg" or "idl", text)), else the standard ROS 2 ones (of ``distro`` when the bag names a known one,
    else the latest)."""
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    store = next((s for s in Stores if distro and s.value == f"ros2_{distro}"), Stores.LATEST)
    types = dict(get_typestore(store).fielddefs)
    for msgtype, (form, text) in definitions.items():
        try:
            if form == "msg":
                types.update(get_types_from_msg(text, msgtype))
            else:
                sep = "=" * 80 + "\n"
                parts = [p.split("\n", 1)[1] for p in text.split(sep)[1:]] if text.startswith(f"{sep}IDL: ") else [text]
                for part in parts:
                    types.update(get_types_from_idl(part))
        except Exception:  # noqa: BLE001 - a definition rosbags cannot parse: the standard one (if any) is kept
            continue
    needed, pending = {}, [t for t in used if t in types]
    while pending:  # the closure of the used types (registering all of ROS 2's takes half a second)
        name = pending.pop()
        if name in needed:
            continue
        needed[name] = types[name]
        for _, (node, arg) in types[name][1]:
            inner = arg if node == _NAME else arg[0][1] if node in (_ARRAY, _SEQUENCE) and arg[0][0] == _NAME else None
            if inner is not None and inner in types and inner not in needed:
                pending.append(inner)
    typestore = get_typestore(Stores.EMPTY)
    typestore.register(needed)
    return typestore


class _Mcap(_Bag):
    """An MCAP file, read by the ``mcap`` package (its summary's index: channels, schemas, counts)."""

    described = "MCAP file"

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        try:
            from mcap.exceptions import McapError
            from mcap.reader import make_reader
        except ImportError:
            raise _missing(path, "MCAP files") from None
        self._errors = (McapError, OSError, ValueError, EOFError, KeyError, IndexError, AssertionError)
        _check_mcap_end(path)
        self._file = path.open("rb")
        try:
            self._reader = make_reader(self._file)
            summary = self._reader.get_summary()
        except self._errors as error:
            self.close()
            raise DataError(str(path), "file", f"cannot read as an MCAP file: {_why(error)} (allowed: a complete MCAP "
                                               "file; `mcap recover` rewrites what a damaged one still holds)") from None
        if summary is None:
            self.close()
            raise DataError(str(path), "file", "the MCAP file has no summary section (its index of channels and "
                                               "schemas; allowed: a file a recorder closed; `mcap recover` adds it)")
        counts = summary.statistics.channel_message_counts if summary.statistics else {}
        definitions: dict[str, tuple[str, str]] = {}
        for channel_id, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            name = schema.name if schema is not None else "(no schema)"
            problem = None
            if channel.message_encoding != "cdr":
                problem = f"its messages are encoded as {channel.message_encoding!r}"
            elif schema is None or schema.encoding not in ("ros2msg", "ros2idl"):
                problem = f"its schema is {'absent' if schema is None else repr(schema.encoding)}"
            else:
                definitions[name] = ("msg" if schema.encoding == "ros2msg" else "idl", schema.data.decode("utf-8", "replace"))
            previous = self.topics.get(channel.topic)
            count = counts.get(channel_id) if counts else None
            if previous is not None:  # several channels of one topic (publishers): one topic, counts summed
                count = None if previous.count is None or count is None else previous.count + count
                problem = previous.problem or problem or (f"its channels have types {previous.msgtype} and {name}"
                                                          if previous.msgtype != name else None)
            self.topics[channel.topic] = Topic(channel.topic, name, count, problem)
        self.typestore = _typestore(definitions, {t.msgtype for t in self.topics.values()})

    def messages(self, topics: list[str]) -> Iterator[tuple[str, int, Any]]:
        """The chunks that hold the topics, in file order, one at a time (their messages are sorted later, by
        topic). ``McapReader.iter_messages`` would either decompress every chunk before the first message (in file
        order) or order the messages of all chunks by a heap of Python comparisons (in log-time order, three
        times slower); without chunk indexes it is used, in log-time order."""
        try:  # the records' own readers (modules of the mcap package beside its reader)
            from mcap.data_stream import ReadDataStream
            from mcap.records import Chunk, Message
            from mcap.stream_reader import breakup_chunk
        except ImportError:  # another layout of the package: its reader, in log-time order
            ReadDataStream = None  # noqa: N806

        summary = self._reader.get_summary()
        wanted = {cid: channel.topic for cid, channel in summary.channels.items() if channel.topic in topics}
        try:
            if not summary.chunk_indexes or ReadDataStream is None:
                for _, channel, message in self._reader.iter_messages(topics=topics, log_time_order=True):
                    yield channel.topic, message.log_time, message.data
                return
            for index in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
                if index.message_index_offsets and not wanted.keys() & index.message_index_offsets.keys():
                    continue  # a chunk of other topics only (the index lists the channels of its messages)
                self._file.seek(index.chunk_start_offset + 1 + 8)  # past the record's opcode and length
                chunk = Chunk.read(ReadDataStream(self._file))
                for record in breakup_chunk(chunk, validate_crc=True):
                    if isinstance(record, Message) and record.channel_id in wanted:
                        yield wanted[record.channel_id], record.log_time, record.data
        except self._errors as error:
            raise DataError(str(self.path), "file", f"cannot read its messages: {_why(error)} (truncated or damaged? "
                                                    "allowed: a complete MCAP file)") from None

    def close(self) -> None:
        self._file.close()


def _check_mcap_end(path: Path) -> None:
    """A complete MCAP file ends with the magic bytes it starts with; a recording cut short does not."""
    try:
        with path.open("rb") as f:
            head = f.read(len(MCAP_MAGIC))
            f.seek(0, 2)
            size = f.tell()
            f.seek(max(size - len(MCAP_MAGIC), 0))
            tail = f.read()
    except OSError as error:
        raise DataError(str(path), "file", f"cannot read: {error.strerror}") from None
    if head != MCAP_MAGIC:
        raise DataError(str(path), "file", "not an MCAP file (it does not start with the MCAP magic bytes)")
    if size < 2 * len(MCAP_MAGIC) or tail != MCAP_MAGIC:
        raise DataError(str(path), "file", f"truncated: the MCAP file ({size} bytes) does not end with the MCAP magic "
                                           "bytes, as a complete one does (allowed: a recording the recorder closed; "
                                           "`mcap recover` rewrites what a truncated one still holds)")


def _check_sqlite(path: Path) -> None:
    """A SQLite database whose header claims more pages than the file holds is truncated."""
    try:
        with path.open("rb") as f:
            header = f.read(100)
        actual = path.stat().st_size
    except OSError as error:
        raise DataError(str(path), "file", f"cannot read: {error.strerror}") from None
    if len(header) < 100 or not header.startswith(SQLITE_MAGIC):
        raise DataError(str(path), "file", "not a SQLite database (a rosbag2 .db3 file is one)")
    page = int.from_bytes(header[16:18], "big")
    page = 65536 if page == 1 else page
    pages = int.from_bytes(header[28:32], "big")
    valid = header[92:96] == header[24:28]  # "version-valid-for" equals the change counter: the page count is current
    if valid and pages and pages * page > actual:
        raise DataError(str(path), "file", f"truncated: the SQLite database claims {pages * page} bytes, the file "
                                           f"holds {actual} (allowed: a complete rosbag2 .db3 file)")


class _Rosbag2(_Bag):
    """A rosbag2 bag (a folder with metadata.yaml, or one ``.db3`` storage file), read by ``rosbags``."""

    described = "rosbag2 bag"

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        try:
            from rosbags.interfaces import MessageDefinitionFormat
            from rosbags.rosbag2 import Reader, ReaderError
        except ImportError:
            raise _missing(path, "ROS 2 bags") from None
        self._errors = (ReaderError, OSError, ValueError, KeyError, IndexError, EOFError, AssertionError,
                        sqlite3.Error, *_apsw_errors())
        storage = sorted(path.iterdir()) if path.is_dir() else [path]
        for f in storage:
            if f.suffix == ".db3":
                _check_sqlite(f)
            elif f.suffix == ".mcap":
                _check_mcap_end(f)
        try:
            self._reader = Reader(path)
            self._reader.open()
        except self._errors as error:
            raise DataError(str(path), "file", f"cannot read as a rosbag2 bag: {_why(error)} (allowed: a rosbag2 "
                                               "folder with metadata.yaml, sqlite3 or MCAP storage)") from None
        definitions: dict[str, tuple[str, str]] = {}
        self._connections: dict[str, list[Any]] = {}
        distro = None
        try:
            distro = self._reader.ros_distro
        except Exception:  # noqa: BLE001 - older metadata: no distribution named
            distro = None
        for connection in self._reader.connections:
            problem = None if connection.ext.serialization_format == "cdr" else \
                f"its messages are serialized as {connection.ext.serialization_format!r}"
            if connection.msgdef.format == MessageDefinitionFormat.MSG and connection.msgdef.data:
                definitions[connection.msgtype] = ("msg", connection.msgdef.data)
            elif connection.msgdef.format == MessageDefinitionFormat.IDL and connection.msgdef.data:
                definitions[connection.msgtype] = ("idl", connection.msgdef.data)
            previous = self.topics.get(connection.topic)
            count = connection.msgcount
            if previous is not None:
                count = (previous.count or 0) + count
                problem = previous.problem or problem or (f"its connections have types {previous.msgtype} and "
                                                          f"{connection.msgtype}" if previous.msgtype != connection.msgtype
                                                          else None)
            self.topics[connection.topic] = Topic(connection.topic, connection.msgtype, count, problem)
            self._connections.setdefault(connection.topic, []).append(connection)
        self.typestore = _typestore(definitions, {t.msgtype for t in self.topics.values()}, distro)

    def messages(self, topics: list[str]) -> Iterator[tuple[str, int, Any]]:
        connections = [c for t in topics for c in self._connections[t]]
        try:
            for connection, timestamp, data in self._reader.messages(connections):
                yield connection.topic, timestamp, data
        except self._errors as error:
            raise DataError(str(self.path), "file", f"cannot read its messages: {_why(error)} (truncated or damaged? "
                                                    "allowed: a complete rosbag2 bag)") from None

    def close(self) -> None:
        try:
            self._reader.close()
        except Exception:  # noqa: BLE001 - closing after a failed read: nothing more to say
            pass


def _apsw_errors() -> tuple[type[BaseException], ...]:
    try:
        import apsw
    except ImportError:
        return ()
    return (apsw.Error,)


def _why(error: BaseException) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return shorten(text, 160).strip("'\"") if len(text) > 160 else text


def open_bag(path: Path) -> _Bag:
    """The reader of ``path``: a folder with metadata.yaml or a ``.db3`` file (rosbag2), else an MCAP file."""
    if path.is_dir() or path.suffix.lower() == ".db3":
        return _Rosbag2(path)
    return _Mcap(path)


def is_bag(path: Path) -> bool:
    """Whether ``path`` is a rosbag2 folder (it holds metadata.yaml)."""
    return path.is_dir() and (path / METADATA).is_file()


# ------------------------------------------------------------------------------ checking against the types


@dataclass
class _Accessor:
    """How to take one reference's number out of a decoded message."""

    steps: tuple[tuple[str, int | None], ...]  # attribute, then a position (or None)
    name: str | None  # a [name] index on the last array: looked up in the names field ...
    names_level: int  # ... of the message reached after this many steps
    names_field: str


def _accessor(request: Request, topic: Topic, typestore: Any, source: str, key: str) -> _Accessor:
    """Check ``request``'s field path against its topic's type; refuse with what the type has."""
    ref = request.reference
    fielddefs = typestore.fielddefs
    msgtype = topic.msgtype
    if msgtype not in fielddefs:
        raise DataError(source, key, f"topic {ref.topic} has type {msgtype}, whose definition the bag does not hold "
                                     "and which is not a standard ROS 2 type (allowed: messages with a definition)")
    current = msgtype
    steps: list[tuple[str, int | None]] = []
    levels = [msgtype]  # the message type after each step (levels[k]: before step k)
    name_index = None
    for k, (fieldname, index) in enumerate(ref.path):
        fields = dict(fielddefs[current][1])
        where = f"{ref.topic}{''.join(f'.{f}' + ('' if i is None else f'[{i}]') for f, i in ref.path[:k])}"
        if fieldname not in fields:
            raise DataError(source, key, f"{where} is a {current}, which has no field {fieldname!r} (its fields: "
                                         f"{', '.join(fields)}){suggestion(fieldname, fields)}")
        node, arg = fields[fieldname]
        last = k == len(ref.path) - 1
        shown = f"{where}.{fieldname}"
        if node == _BASE:
            if index is not None:
                raise DataError(source, key, f"{shown} is one {arg[0]}, not an array: leave out [{index}]")
            if not last:
                raise DataError(source, key, f"{shown} is a {arg[0]}, which has no fields")
            if arg[0] not in NUMBER_TYPES:
                raise DataError(source, key, f"{shown} is a {arg[0]} (allowed: a number field: "
                                             f"{', '.join(NUMBER_TYPES)})")
            steps.append((fieldname, None))
        elif node == _NAME:
            if index is not None:
                raise DataError(source, key, f"{shown} is a {arg}, not an array: leave out [{index}]")
            if last:
                inner = ", ".join(f for f, _ in fielddefs[arg][1]) if arg in fielddefs else "?"
                raise DataError(source, key, f"{shown} is a message {arg} (its fields: {inner}): name one of its "
                                             f"numbers, e.g. {shown}.{inner.split(', ')[0]}")
            steps.append((fieldname, None))
            current = arg
        else:  # an array or a sequence
            element, _ = arg
            if index is None:
                raise DataError(source, key, f"{shown} is an array: give a position, {shown}[0], or a name, "
                                             f"{shown}[joint_name]")
            if element[0] == _NAME:
                if isinstance(index, str):
                    raise DataError(source, key, f"{shown} is an array of {element[1]} messages: give a position "
                                                 f"([0]), not a name")
                if last:
                    raise DataError(source, key, f"{shown}[{index}] is a message {element[1]}: name one of its numbers")
                steps.append((fieldname, index))
                current = element[1]
            else:
                if element[0] != _BASE or element[1][0] not in NUMBER_TYPES:
                    what = element[1][0] if element[0] == _BASE else "arrays"
                    raise DataError(source, key, f"{shown} is an array of {what} (allowed: arrays of numbers)")
                if not last:
                    raise DataError(source, key, f"{shown}[{index}] is a number, which has no fields")
                if isinstance(index, int):
                    steps.append((fieldname, index))
                else:
                    steps.append((fieldname, None))
                    name_index = index
        levels.append(current)
    names_level, names_field = 0, ""
    if name_index is not None:
        for level in range(len(ref.path) - 1, -1, -1):  # the message holding the array, then outwards
            fields = dict(fielddefs[levels[level]][1])
            found = next((f for f in NAME_FIELDS if f in fields and fields[f][0] in (_ARRAY, _SEQUENCE)
                          and fields[f][1][0] == (_BASE, ("string", 0))), None)
            if found is not None:
                names_level, names_field = level, found
                break
        else:
            raise DataError(source, key, f"{ref.text}: a name index needs a field of names beside the array "
                                         f"({' or '.join(NAME_FIELDS)}, as sensor_msgs/JointState's name), and "
                                         f"{topic.msgtype} has none: give a position, [0]")
    return _Accessor(tuple(steps), name_index, names_level, names_field)


def _has_header(typestore: Any, msgtype: str) -> bool:
    fields = dict(typestore.fielddefs[msgtype][1])
    return fields.get("header") == (_NAME, "std_msgs/msg/Header")


# ----------------------------------------------------------------------------------------- reading, aligning


@dataclass
class TopicReport:
    """What the alignment found on one topic: messages read, their rate, gaps, and messages dropped."""

    topic: str
    msgtype: str
    messages: int
    rate: float
    stamps: str  # "header" or "log"
    methods: tuple[str, ...]
    gaps: tuple[tuple[float, float, int], ...] = ()  # (t from the time base's start in s, length in s, missing)
    repeated: int = 0  # messages with the stamp of the one before (the first kept)
    out_of_order: int = 0  # messages whose stamp is before the one before (sorted)
    before: int = 0  # messages before the time base's start
    after: int = 0  # after its end

    @property
    def dropped(self) -> int:
        return self.repeated + self.before + self.after


@dataclass
class Alignment:
    """How a bag's topics were put onto one time base: the base, and each topic's report."""

    file: str
    base: str  # what the time base is
    rate: float
    samples: int
    start_ns: int  # the time base's first instant (t = 0), in ns of the bag's clock
    topics: tuple[TopicReport, ...] = ()

    def lines(self) -> list[str]:
        """The report, one line per topic and one for the time base."""
        out = [f"{self.file}: time base: {self.base}, {self.samples} samples at {self.rate:.6g} Hz, t = 0 at "
               f"{self.start_ns / 1e9:.9f} s of the bag's clock"]
        for r in self.topics:
            gaps = (f"{len(r.gaps)} gap(s), {sum(g[2] for g in r.gaps)} message(s) missing, the longest "
                    f"{duration(max(g[1] for g in r.gaps))}" if r.gaps else "no gap")
            dropped = [f"{n} {what}" for n, what in ((r.before, "before the time base"), (r.after, "after it"),
                                                     (r.repeated, "with a repeated stamp")) if n]
            order = f", {r.out_of_order} out of order (sorted)" if r.out_of_order else ""
            out.append(f"{self.file}: {r.topic} ({r.msgtype}): {r.messages} messages at {r.rate:.6g} Hz ({r.stamps} "
                       f"time), {'/'.join(r.methods)}; {gaps}; dropped {', '.join(dropped) or 'none'}{order}")
        return out

    def to_dict(self) -> dict[str, Any]:
        """The report as the commands' ``--json`` hold it (``"alignment"``), which report.md
        (:func:`markdown_lines`) and the HTML page (:func:`symbolic.htmlpage.alignment`) are written from."""
        return {"file": self.file, "base": self.base, "rate": self.rate, "samples": self.samples, "start_ns": self.start_ns,
                "topics": [{"topic": r.topic, "type": r.msgtype, "messages": r.messages, "rate": r.rate,
                            "stamps": r.stamps, "methods": list(r.methods),
                            "gaps": [{"t": g[0], "length": g[1], "missing": g[2]} for g in r.gaps],
                            "dropped": {"before": r.before, "after": r.after, "repeated": r.repeated},
                            "out_of_order": r.out_of_order} for r in self.topics]}


def markdown_lines(report: Mapping[str, Any], role: str = "") -> list[str]:
    """report.md's section on one bag's alignment, from :meth:`Alignment.to_dict` (the JSON's ``"alignment"``, so
    that report.md, the JSON and the HTML page show the same numbers): the time base, a table of the topics, and
    each gap; ``role``: which data set it is (``"validation"``), said in the heading."""
    table = lambda header, rows: (["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]  # noqa: E731
                                  + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows])
    lines = [f"### The bag's topics aligned{f' ({role} data)' if role else ''}", "",
             f"`{Path(report['file']).name}`: time base {report['base']}, {report['samples']} samples at "
             f"{report['rate']:.6g} Hz, t = 0 at {report['start_ns'] / 1e9:.9f} s of the bag's clock "
             "(docs/data.md, \"Alignment\").", ""]
    lines += table(["topic", "type", "messages", "rate", "time", "method", "dropped before the time base", "after it",
                    "with a repeated stamp", "out of order (sorted)"],
                   [[f"`{t['topic']}`", t["type"], t["messages"], f"{t['rate']:.6g} Hz", t["stamps"], "/".join(t["methods"]),
                     t["dropped"]["before"], t["dropped"]["after"], t["dropped"]["repeated"], t["out_of_order"]]
                    for t in report["topics"]])
    gaps = [[f"`{t['topic']}`", f"{g['t']:.6g} s", f"{g['length']:.3g} s", g["missing"]]
            for t in report["topics"] for g in t["gaps"]]
    lines.append("")
    if gaps:
        lines += [f"Gaps (steps longer than {GAP_FACTOR:g} median steps), each bridged by its topic's method:", ""]
        lines += table(["topic", "at t", "length", "messages missing"], gaps) + [""]
    else:
        lines += ["No gap in any topic.", ""]
    return lines


def alignments(*data: Any) -> dict[str, dict[str, Any]] | None:
    """``{role: Alignment.to_dict()}`` of ``(role, measurements)`` pairs read from bags, each file once (the
    held-out tail of the estimation bag is not reported twice); ``None`` when none was a bag."""
    out: dict[str, dict[str, Any]] = {}
    seen: set[str] = set()
    for role, measurements in data:
        found = getattr(measurements, "alignment", None)
        if found is not None and found.file not in seen:
            seen.add(found.file)
            out[role] = found.to_dict()
    return out or None


@dataclass
class _Series:
    """One topic's times (ns) and the numbers of its references, growing as messages are read."""

    capacity: int
    width: int
    size: int = 0
    times: np.ndarray = field(init=False)
    values: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.times = np.empty(max(self.capacity, 16), dtype=np.int64)
        self.values = np.empty((max(self.capacity, 16), self.width))

    def append(self, stamp: int) -> np.ndarray:
        """A new row at time ``stamp``: its values, to fill."""
        if self.size == len(self.times):
            self.times = np.concatenate([self.times, np.empty(len(self.times), dtype=np.int64)])
            self.values = np.concatenate([self.values, np.empty((len(self.values), self.width))])
        self.times[self.size] = stamp
        self.size += 1
        return self.values[self.size - 1]


@dataclass
class Read:
    """What :func:`read` gives: the variables (``t`` and one per reference and method), the rewritten
    ``[signals]``, the references' texts by variable (for messages), and the alignment report."""

    vectors: dict[str, np.ndarray]
    signals: dict[str, Any]
    labels: dict[str, str]
    alignment: Alignment


def read(path: Path, signals: Mapping[str, Any] | None, options: Any, source: str, resample: bool = False) -> Read:
    """Read the topics the ``[signals]`` reference from the bag ``path`` and align them (module docstring).

    ``options`` is the experiment's ``[alignment]`` table (or None); ``resample`` the experiment's ``resample``
    (a time base's clock whose stamps are not uniform is then replaced by a uniform grid; it is anyway when
    they have gaps)."""
    settings = _options(options, signals or {}, source)
    bag = open_bag(path)
    try:
        if not signals:
            article = "an" if bag.described[0] in "AEIMOU" else "a"  # an MCAP file, a rosbag2 bag
            raise DataError(source, "[signals]", f"{article} {bag.described}'s topics are mapped onto the signals by an "
                                                 "experiment file's [signals], e.g. q_<joint> = "
                                                 "\"/joint_states.position[<joint>]\" (docs/data.md, \"Bags and MCAP "
                                                 f"files\"); the topics of {path.name}: {bag.listing()}")
        rewritten, requests = rewrite(signals, settings["method"], source)
        by_topic = _check(requests, bag, source)
        clock = settings["clock"] or _default_clock(signals, requests)
        if clock is not None and clock not in bag.topics:
            raise DataError(source, "[alignment] clock", f"no topic {clock!r} in {path.name} (its topics: "
                                                         f"{bag.listing()}){suggestion(clock, bag.topics)}")
        if clock is not None and clock not in by_topic:
            by_topic[clock] = []
        series, stamps_used = _stream(bag, by_topic, settings["stamp"], path, source)
    finally:
        bag.close()
    vectors, alignment = align(series, by_topic, stamps_used, clock, settings, bag, path, source, resample)
    labels = {r.variable: r.reference.text for rs in by_topic.values() for r, _ in rs}
    return Read(vectors, {**rewritten, "t": "t"}, labels, alignment)


def _options(options: Any, signals: Mapping[str, Any], source: str) -> dict[str, Any]:
    """The ``[alignment]`` table, checked."""
    if options is None:
        options = {}
    if not isinstance(options, Mapping):
        raise DataError(source, "[alignment]", f"expected a table, got {type(options).__name__}")
    check_keys(options, ALIGNMENT_KEYS, source, "[alignment]")
    out: dict[str, Any] = {"rate": None, "clock": None, "stamp": "header", "max_gap": None, "method": {}}
    rate = options.get("rate")
    if rate is not None:
        if not isfinite_number(rate) or not 1e-3 <= rate <= MAX_RATE:
            raise DataError(source, "[alignment] rate", f"expected the time base's rate in Hz, from 0.001 to "
                                                        f"{MAX_RATE:g}, got {rate!r}")
        out["rate"] = float(rate)
    clock = options.get("clock")
    if clock is not None:
        if not isinstance(clock, str) or not re.fullmatch(rf"/{_IDENT}(?:/{_IDENT})*", clock):
            raise DataError(source, "[alignment] clock", f"expected a topic name, e.g. \"/joint_states\", got {clock!r}")
        if rate is not None:
            raise DataError(source, "[alignment] clock", "give either a clock topic (its stamps are the time base) or "
                                                         "a rate (a uniform grid), not both")
        out["clock"] = clock
    stamp = options.get("stamp", "header")
    if stamp not in STAMPS:
        raise DataError(source, "[alignment] stamp", f"expected one of {', '.join(map(repr, STAMPS))} (the header "
                                                     f"stamp when a message has one, else the log time; or the log time "
                                                     f"always), got {stamp!r}")
    out["stamp"] = stamp
    gap = options.get("max_gap")
    if gap is not None:
        if not isfinite_number(gap) or gap <= 0:
            raise DataError(source, "[alignment] max_gap", f"expected the longest gap bridged, in seconds (> 0), "
                                                           f"got {gap!r}")
        out["max_gap"] = float(gap)
    methods = options.get("method", {})
    if not isinstance(methods, Mapping):
        raise DataError(source, "[alignment] method", f"expected a table of signal = \"linear\" or \"hold\", got "
                                                      f"{methods!r}")
    for name, method in methods.items():
        if name not in signals:
            raise DataError(source, f"[alignment] method {name}", f"no such signal in [signals] (its signals: "
                                                                  f"{listing(signals)}){suggestion(name, signals)}")
        if method not in METHODS:
            raise DataError(source, f"[alignment] method {name}", f"expected \"linear\" (interpolation between "
                                                                  "messages) or \"hold\" (the last message's value), "
                                                                  f"got {method!r}")
    out["method"] = dict(methods)
    return out


def _default_clock(signals: Mapping[str, Any], requests: list[Request]) -> str | None:
    """The topic of the first position signal's first reference (else of the first reference)."""
    for name, text in signals.items():
        if (split_name(name) or ("",))[0] == "q" and isinstance(text, str):
            match = REFERENCE.search(text)
            if match:
                return parse_reference(match.group()).topic
    return requests[0].reference.topic if requests else None


def _check(requests: list[Request], bag: _Bag, source: str) -> dict[str, list[tuple[Request, _Accessor]]]:
    """Every reference checked against its topic's type, grouped by topic."""
    by_topic: dict[str, list[tuple[Request, _Accessor]]] = {}
    for request in requests:
        ref, key = request.reference, request.key
        topic = bag.topics.get(ref.topic)
        if topic is None:
            raise DataError(source, key, f"no topic {ref.topic!r} in {bag.path.name} (its topics: {bag.listing()})"
                                         f"{suggestion(ref.topic, bag.topics)}")
        if topic.problem is not None:
            raise DataError(source, key, f"topic {ref.topic} ({topic.msgtype}) cannot be read: {topic.problem} "
                                         "(allowed: ROS 2 messages, CDR-encoded, with a ros2msg or ros2idl schema)")
        by_topic.setdefault(ref.topic, []).append((request, _accessor(request, topic, bag.typestore, source, key)))
    return by_topic


class _Progress:
    """``symbolic: run.mcap: read 12000 of 50000 messages (24 %), 2.0 s`` every :data:`PROGRESS_EVERY` seconds."""

    def __init__(self, path: Path, total: int | None) -> None:
        self.path, self.total = path, total
        self.start = time.perf_counter()
        self.next = self.start + PROGRESS_EVERY
        self.count = 0

    def tick(self) -> None:
        self.count += 1
        if self.count % 512 == 0:
            now = time.perf_counter()
            if now >= self.next:
                self.next = now + PROGRESS_EVERY
                of = f" of {self.total} messages ({100 * self.count / self.total:.0f} %)" if self.total else " messages"
                log.info("%s: read %d%s, %.1f s", self.path.name, self.count, of, now - self.start)

    def done(self) -> None:
        if time.perf_counter() - self.start >= PROGRESS_EVERY:
            log.info("%s: read %d messages, %.1f s", self.path.name, self.count, time.perf_counter() - self.start)


@dataclass
class _Group:
    """The references of one topic that read one array (JointState's ``position``: several joints) or one number:
    the array is reached once per message and indexed at the references' positions at once."""

    steps: tuple[tuple[str, int | None], ...]  # to the array (its own position left out), or to the number
    columns: list[int]  # the references' columns in the topic's values
    requests: list[Request]
    positions: list[int] = field(default_factory=list)  # a position per reference (position indices)
    names: list[str] = field(default_factory=list)  # a name per reference (name indices)
    names_level: int = 0
    names_field: str = ""
    array: bool = True


def _groups(requests: list[tuple[Request, _Accessor]]) -> list[_Group]:
    """The references of a topic grouped by the array they index (:class:`_Group`)."""
    groups: dict[tuple, _Group] = {}
    for column, (request, accessor) in enumerate(requests):
        last_field, last_index = accessor.steps[-1]
        array = accessor.name is not None or last_index is not None
        if not array:
            groups[("number", column)] = _Group(accessor.steps, [column], [request], array=False)
            continue
        steps = accessor.steps[:-1] + ((last_field, None),)
        named = accessor.name is not None
        group = groups.setdefault((steps, named), _Group(steps, [], [], names_level=accessor.names_level,
                                                         names_field=accessor.names_field))
        group.columns.append(column)
        group.requests.append(request)
        if named:
            group.names.append(accessor.name)
        else:
            group.positions.append(last_index)
    return list(groups.values())


def _stream(bag: _Bag, by_topic: dict[str, list[tuple[Request, _Accessor]]], stamp: str, path: Path,
            source: str) -> tuple[dict[str, _Series], dict[str, str]]:
    """Read the messages of the topics once, message by message, keeping each one's time and the numbers."""
    typestore = bag.typestore
    series: dict[str, _Series] = {}
    decoders: dict[str, Any] = {}
    stamps: dict[str, str] = {}
    header: dict[str, bool] = {}
    groups: dict[str, list[_Group]] = {}
    cache: dict[int, tuple[list[str], np.ndarray]] = {}
    for name, requests in by_topic.items():
        topic = bag.topics[name]
        # sized from the bag's count, up to INITIAL_ROWS (a count is the file's word: the arrays grow past it)
        series[name] = _Series(min(topic.count or 1024, INITIAL_ROWS), len(requests))
        header[name] = stamp == "header" and _has_header(typestore, topic.msgtype)
        stamps[name] = "log"
        decoders[name] = topic.msgtype
        groups[name] = _groups(requests)
    total = sum(bag.topics[t].count or 0 for t in by_topic) or None
    progress = _Progress(path, total)
    deserialize = typestore.deserialize_cdr
    for topic_name, log_time, data in bag.messages(list(by_topic)):
        held = series[topic_name]
        try:
            message = deserialize(data, decoders[topic_name])
        except Exception as error:  # noqa: BLE001 - the bytes do not decode as the declared type
            raise DataError(str(path), topic_name, f"message {held.size + 1} does not decode as "
                                                   f"{decoders[topic_name]}: {_why(error)} (allowed: CDR messages of "
                                                   "the topic's type)") from None
        when = log_time
        if header[topic_name]:  # the header stamp, unless the topic's first message leaves it unset (0)
            s = message.header.stamp
            given = int(s.sec) * 1_000_000_000 + int(s.nanosec)
            if held.size == 0:
                stamps[topic_name] = "header" if given else "log"
            if stamps[topic_name] == "header":
                if not given:
                    raise DataError(str(path), topic_name, f"message {held.size + 1} has no header stamp "
                                                           "(0) where the ones before have one: the topic's times "
                                                           "would mix two clocks (allowed: stamps throughout, or "
                                                           "[alignment] stamp = \"log\", the log time)")
                when = given
        row = held.append(when)
        for group in groups[topic_name]:
            _read_group(message, group, row, topic_name, held.size, cache, source)
        progress.tick()
    progress.done()
    return series, stamps


def _read_group(message: Any, group: _Group, row: np.ndarray, topic: str, number: int, cache: dict,
                source: str) -> None:
    """The numbers ``group`` references in a decoded ``message`` (the ``number``-th of ``topic``) into ``row``; a
    name is looked up in the message's names (the last names and positions kept in ``cache``, by group)."""
    obj = message
    levels = [message]
    for fieldname, index in group.steps:
        obj = getattr(obj, fieldname)
        if index is not None:
            if index >= len(obj):
                request = group.requests[0]
                raise DataError(source, request.key, f"{request.reference.text}: message {number} of {topic} has "
                                                     f"{len(obj)} value(s) in {fieldname}: no position {index} (allowed: "
                                                     f"0 to {len(obj) - 1})")
            obj = obj[index]
        levels.append(obj)
    if not group.array:
        row[group.columns[0]] = obj
        return
    if group.names:
        names = getattr(levels[group.names_level], group.names_field)
        known = cache.get(id(group))
        if known is not None and known[0] == names:
            positions = known[1]
        else:
            for name, request in zip(group.names, group.requests):
                if name not in names:
                    raise DataError(source, request.key, f"joint {name!r} is not among the names of {topic} (its "
                                                         f"{group.names_field}: {listing(names)})"
                                                         f"{suggestion(name, names)}; give a joint the topic names "
                                                         "(the URDF's joint names) or a position, [0]")
            positions = np.array([list(names).index(name) for name in group.names])
            cache[id(group)] = (list(names), positions)
        if len(obj) < len(names):
            request = group.requests[int(np.argmax(positions >= len(obj)))] if np.any(positions >= len(obj)) else None
            if request is not None:
                raise DataError(source, request.key, f"{request.reference.text}: message {number} of {topic} names "
                                                     f"{len(names)} joints but has {len(obj)} value(s) in "
                                                     f"{group.steps[-1][0]} (allowed: one per name)")
    else:
        positions = group.positions
        if max(positions) >= len(obj):
            k = int(np.argmax(np.asarray(positions) >= len(obj)))
            request = group.requests[k]
            raise DataError(source, request.key, f"{request.reference.text}: message {number} of {topic} has "
                                                 f"{len(obj)} value(s) in {group.steps[-1][0]}: no position "
                                                 f"{positions[k]} (allowed: 0 to {len(obj) - 1})")
    if isinstance(obj, np.ndarray):
        row[group.columns] = obj[positions]
    else:
        row[group.columns] = [obj[p] for p in positions]


def align(series: dict[str, _Series], by_topic: dict[str, list[tuple[Request, _Accessor]]], stamps: dict[str, str],
          clock: str | None, settings: dict, bag: _Bag, path: Path, source: str,
          resample: bool) -> tuple[dict[str, np.ndarray], Alignment]:
    """Sort each topic by time, find its rate and gaps, choose the time base and align every reference onto it."""
    prepared: dict[str, tuple[np.ndarray, np.ndarray, int, int, int]] = {}
    for name, s in series.items():
        times, values = s.times[:s.size], s.values[:s.size]
        if s.size < 2:
            raise DataError(str(path), name, f"{s.size} message(s) (at least 2 are needed to align a topic)")
        order = np.argsort(times, kind="stable")
        out_of_order = int(np.count_nonzero(np.diff(times) < 0))
        times, values = times[order], values[order]
        keep = np.concatenate([[True], np.diff(times) > 0])
        repeated = int(np.count_nonzero(~keep))
        times, values = times[keep], values[keep]
        if len(times) < 2:
            raise DataError(str(path), name, "every message has the same time stamp (at least 2 times are needed)")
        period = int(np.median(np.diff(times)))
        prepared[name] = (times, values, period, repeated, out_of_order)
    holds = {name: all(r.method == "hold" for r, _ in by_topic[name]) if by_topic[name] else False for name in prepared}
    start = max(p[0][0] for p in prepared.values())
    end = min(p[0][-1] + (p[2] if holds[name] else 0) for name, p in prepared.items())
    if end <= start:
        spans = ", ".join(f"{n} {(p[0][0]) / 1e9:.6f}–{p[0][-1] / 1e9:.6f} s" for n, p in prepared.items())
        raise DataError(str(path), "time", f"the topics do not overlap in time ({spans}; allowed: topics recorded "
                                           "together)")
    # the time base
    rate = settings["rate"]
    if rate is not None:
        step = 1e9 / rate
        count = int(math.floor((end - start) / step + 1e-9)) + 1
        busiest = max(len(p[0]) for p in prepared.values())
        if count > max(MAX_UPSAMPLING * busiest, 1_000_000):
            raise DataError(source, "[alignment] rate", f"{rate:g} Hz over the {(end - start) / 1e9:.6g} s the topics "
                                                        f"share makes {count} samples, more than {MAX_UPSAMPLING} times "
                                                        f"the {busiest} messages of the busiest topic (allowed: a rate "
                                                        "near the topics', in Hz)")
        grid = start + np.round(np.arange(count) * step).astype(np.int64)
        base = f"a uniform grid at [alignment] rate = {rate:g} Hz"
    else:
        times, _, period, _, _ = prepared[clock]
        inside = times[(times >= start) & (times <= end)]
        if len(inside) < 2:
            raise DataError(str(path), "[alignment] clock", f"{clock} has {len(inside)} message(s) where every topic "
                                                            "has messages (at least 2 are needed)")
        steps = np.diff(inside)
        mean = (inside[-1] - inside[0]) / (len(inside) - 1)
        uniform = np.max(np.abs(steps - mean)) <= UNIFORM_TOLERANCE * mean
        if uniform:
            grid = inside
            base = f"the stamps of {clock}"
        else:
            gapped = np.max(steps) > GAP_FACTOR * period
            if not gapped and not resample:
                worst = int(np.argmax(np.abs(steps - mean)))
                raise DataError(source, "[alignment]", f"the stamps of {clock}, the time base, vary from "
                                                       f"{duration(steps.min() / 1e9, mean / 1e9)} to "
                                                       f"{duration(steps.max() / 1e9, mean / 1e9)} (the largest deviation "
                                                       f"at message {worst + 1}); steps must be uniform to "
                                                       f"{UNIFORM_TOLERANCE:.1%} — give [alignment] rate = <Hz> (a "
                                                       "uniform grid) or resample = true")
            if gapped:  # a uniform grid at the clock's own rate, across the gap
                count = int(math.floor((inside[-1] - inside[0]) / period + 1e-9)) + 1
                grid = inside[0] + np.arange(count, dtype=np.int64) * period
                base = f"a uniform grid at the rate of {clock} ({1e9 / period:.6g} Hz; it has gaps)"
            else:  # resample: the same first and last instants and count
                grid = inside[0] + np.round(np.arange(len(inside)) * ((inside[-1] - inside[0]) / (len(inside) - 1))
                                            ).astype(np.int64)
                base = f"a uniform grid over the stamps of {clock} (resample = true)"
        rate = 1e9 * (len(grid) - 1) / (grid[-1] - grid[0])
    vectors: dict[str, np.ndarray] = {"t": (grid - grid[0]) / 1e9}
    reports = []
    for name, (times, values, period, repeated, out_of_order) in prepared.items():
        limit = settings["max_gap"] if settings["max_gap"] is not None else max(MAX_GAP_SECONDS,
                                                                                MAX_GAP_PERIODS * period / 1e9)
        steps = np.diff(times)
        at = np.flatnonzero((steps > GAP_FACTOR * period) & (times[1:] > grid[0]) & (times[:-1] < grid[-1]))
        gaps = tuple(((times[j] - grid[0]) / 1e9, steps[j] / 1e9, int(round(steps[j] / period)) - 1) for j in at)
        for t0, length, missing in gaps:
            if length > limit:
                raise DataError(str(path), name, f"a gap of {duration(length)} at t = {t0:.6g} s ({missing} messages "
                                                 f"missing at {1e9 / period:.6g} Hz) is longer than the "
                                                 f"{duration(limit)} allowed ([alignment] max_gap; default "
                                                 f"{MAX_GAP_SECONDS:g} s or {MAX_GAP_PERIODS} periods of the topic): "
                                                 "cut the log with [window], or raise max_gap")
        methods = tuple(sorted({r.method for r, _ in by_topic[name]}))
        for request, _ in by_topic[name]:
            column = values[:, [r for r, _ in by_topic[name]].index(request)]
            vectors[request.variable] = _hold(times, column, grid) if request.method == "hold" else \
                _linear(times, column, grid)
        # messages outside the time base are dropped, but for the one just before its start (held, or the first
        # end of an interpolation) and, for an interpolated topic, the one just after its end
        before = int(np.count_nonzero(times < grid[0]))
        after = int(np.count_nonzero(times > grid[-1]))
        if before and by_topic[name] and not np.any(times == grid[0]):
            before -= 1
        if after and "linear" in methods and not np.any(times == grid[-1]):
            after -= 1
        regular = steps[steps <= GAP_FACTOR * period]  # the rate between gaps
        mean_rate = 1e9 * len(regular) / float(np.sum(regular)) if len(regular) else 1e9 / period
        reports.append(TopicReport(name, bag.topics[name].msgtype, len(times) + repeated, mean_rate, stamps[name],
                                   methods or ("time base",), gaps, repeated, out_of_order, before, after))
    alignment = Alignment(str(path), base, float(rate), len(grid), int(grid[0]), tuple(reports))
    for line in alignment.lines():
        log.info("%s", line)
    for r in alignment.topics:
        if r.gaps:
            t0, length, missing = max(r.gaps, key=lambda g: g[1])
            how = "linear interpolation" if "linear" in r.methods else "holding the last message"
            warnings.warn(ModelWarning(
                f"{path}: {r.topic}: {len(r.gaps)} gap(s) in the messages, {sum(g[2] for g in r.gaps)} message(s) "
                f"missing at {r.rate:.6g} Hz; the longest {duration(length)} at t = {t0:.6g} s, bridged by {how}"
                f" (allowed: gaps up to [alignment] max_gap)"), stacklevel=2)
    return vectors, alignment


def _linear(times: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Linear interpolation at ``grid`` (ns), exact where an instant is a message's: its value unchanged."""
    k = np.searchsorted(times, grid, side="right") - 1
    k = np.clip(k, 0, len(times) - 1)
    out = values[k].copy()
    inner = k < len(times) - 1
    j = k[inner]
    offset = (grid[inner] - times[j]).astype(float)
    between = offset > 0
    span = (times[j + 1] - times[j]).astype(float)
    w = offset / span
    interpolated = values[j] + w * (values[j + 1] - values[j])
    out[inner] = np.where(between, interpolated, values[j])
    return out


def _hold(times: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Zero-order hold at ``grid`` (ns): the value of the last message at or before each instant."""
    k = np.clip(np.searchsorted(times, grid, side="right") - 1, 0, len(times) - 1)
    return values[k].copy()
