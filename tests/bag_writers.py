"""Writing ROS 2 bags and MCAP files for the tests, with the writers of the libraries the reader uses: rosbags'
rosbag2 ``Writer`` (sqlite3 or MCAP storage, messages serialized by rosbags' typestore) and ``mcap_ros2``'s
``Writer`` (MCAP with the ``ros2msg`` schema and CDR messages, serialized by mcap_ros2's own encoder — another
implementation than the reader's decoder).

A log to write is a list of :class:`Topic`: its name, type and messages, each message (log time in ns, fields as
a dict: ``{"header": {"stamp": ns}, "name": [...], "position": [...]}``; a ``stamp`` in ns is written as
``sec``/``nanosec``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest


@dataclass
class Topic:
    name: str
    msgtype: str
    messages: list[tuple[int, dict[str, Any]]] = field(default_factory=list)


def need(*modules: str) -> None:
    """Skip the calling test, naming the install command, when a writer's package is missing."""
    import importlib.util

    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        pytest.skip(f"{', '.join(missing)} not installed: pip install 'symbolic[bags]' mcap-ros2-support")


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": int(ns // 1_000_000_000), "nanosec": int(ns % 1_000_000_000)}


def _plain(fields: dict[str, Any]) -> dict[str, Any]:
    """The dict mcap_ros2 encodes: header stamps as sec/nanosec, arrays as lists."""
    out = {}
    for k, v in fields.items():
        if k == "header":
            out[k] = {"stamp": _stamp(v["stamp"]), "frame_id": v.get("frame_id", "")}
        elif isinstance(v, np.ndarray):
            out[k] = v.tolist()
        elif isinstance(v, dict):
            out[k] = _plain(v)
        else:
            out[k] = v
    return out


def _message(typestore: Any, msgtype: str, fields: dict[str, Any]) -> Any:
    """A rosbags message object of ``msgtype`` from ``fields`` (missing fields take their defaults)."""
    cls = typestore.types[msgtype]
    values = {}
    for name, (node, arg) in typestore.fielddefs[msgtype][1]:
        given = fields.get(name)
        if node == 2:  # a message
            if arg == "std_msgs/msg/Header":
                stamp = (given or {}).get("stamp", 0)
                values[name] = typestore.types[arg](stamp=typestore.types["builtin_interfaces/msg/Time"](**_stamp(stamp)),
                                                    frame_id=(given or {}).get("frame_id", ""))
            else:
                values[name] = _message(typestore, arg, given or {})
        elif node in (3, 4):
            element = arg[0]
            if element[0] == 1 and element[1][0] == "string":
                values[name] = list(given or [])
            elif element[0] == 1:
                dtype = {"float64": np.float64, "float32": np.float32, "int32": np.int32, "uint32": np.uint32,
                         "int64": np.int64, "uint8": np.uint8, "int8": np.int8}.get(element[1][0], np.float64)
                values[name] = np.ascontiguousarray(given if given is not None else [], dtype=dtype)
            else:
                values[name] = [_message(typestore, element[1], g) for g in (given or [])]
        else:
            default = "" if arg[0] == "string" else 0
            values[name] = given if given is not None else default
    return cls(**values)


def write_rosbag2(path: Path, topics: list[Topic], storage: str = "sqlite3") -> Path:
    """A rosbag2 folder at ``path`` (sqlite3 or mcap storage) written by rosbags' Writer."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    typestore = _typestore()
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    merged = sorted(((ns, k, fields) for k, topic in enumerate(topics) for ns, fields in topic.messages),
                    key=lambda x: (x[0], x[1]))
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        connections = [writer.add_connection(t.name, t.msgtype, typestore=typestore) for t in topics]
        for ns, k, fields in merged:
            message = _message(typestore, topics[k].msgtype, fields)
            writer.write(connections[k], ns, typestore.serialize_cdr(message, topics[k].msgtype))
    return path


def write_mcap(path: Path, topics: list[Topic], chunk_size: int = 1 << 20) -> Path:
    """An MCAP file written by mcap_ros2's Writer (ros2msg schemas from rosbags' definitions, CDR messages)."""
    from mcap_ros2.writer import Writer

    typestore = _typestore()
    merged = sorted(((ns, k, fields) for k, topic in enumerate(topics) for ns, fields in topic.messages),
                    key=lambda x: (x[0], x[1]))
    with path.open("wb") as f:
        writer = Writer(f, chunk_size=chunk_size)
        schemas = [writer.register_msgdef(t.msgtype, typestore.generate_msgdef(t.msgtype, ros_version=2)[0])
                   for t in topics]
        for ns, k, fields in merged:
            writer.write_message(topics[k].name, schemas[k], _plain(fields), log_time=ns, publish_time=ns)
        writer.finish()
    return path


def joint_states(stamps: np.ndarray, names: list[str], position: np.ndarray, effort: np.ndarray,
                 velocity: np.ndarray | None = None, latency: int = 300_000) -> Topic:
    """sensor_msgs/JointState messages stamped ``stamps`` (ns) and logged ``latency`` ns later."""
    topic = Topic("/joint_states", "sensor_msgs/msg/JointState")
    for k, ns in enumerate(stamps):
        fields = {"header": {"stamp": int(ns)}, "name": names, "position": position[k], "effort": effort[k]}
        if velocity is not None:
            fields["velocity"] = velocity[k]
        topic.messages.append((int(ns) + latency, fields))
    return topic


def commands(name: str, stamps: np.ndarray, values: np.ndarray) -> Topic:
    """std_msgs/Float64MultiArray messages (no header: their time is the log time) at ``stamps``."""
    topic = Topic(name, "std_msgs/msg/Float64MultiArray")
    for k, ns in enumerate(stamps):
        topic.messages.append((int(ns), {"data": values[k]}))
    return topic


def write(kind: str, path: Path, topics: list[Topic]) -> Path:
    """``kind``: "mcap" (an MCAP file, mcap_ros2), "sqlite3" or "rosbag2-mcap" (a rosbag2 folder, rosbags)."""
    if kind == "mcap":
        need("mcap", "mcap_ros2", "rosbags")
        return write_mcap(path.with_suffix(".mcap"), topics)
    need("mcap", "rosbags")
    return write_rosbag2(path, topics, "sqlite3" if kind == "sqlite3" else "mcap")
