"""Writing found effects into the model file: new entries and parameters, comments and layout kept.

The model file is edited as a TOML document with tomlkit (as ``symbolic identify --out`` does), so its
comments, order and formatting survive; effects add keys to the coordinate's ``[[friction]]`` or
``[[drive]]`` table (creating it at the end of the file if there is none), append ``[[force]]`` tables,
and add their parameters at the end of ``[parameters]``. Every added key, table and parameter carries a
comment saying what was found and on which evidence.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import tomlkit

from symbolic.errors import ModelError
from symbolic.description.names import unique
from symbolic.description.robot import Robot

_RESERVED = {"pi", "E", "I", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "sqrt",
             "exp", "log", "abs", "sign", "t"}


class Editor:
    """A model file's TOML document being patched (module docstring)."""

    def __init__(self, text: str, robot: Robot, source: str) -> None:
        self.document = tomlkit.parse(text)
        self.source = source
        if "parameters" not in self.document:
            self.document.add("parameters", tomlkit.table())
        self.taken = set(self.document["parameters"]) | set(robot.generalized_coordinates) | \
            set(robot.constrained_coordinates) | _RESERVED
        self.forces = {str(f["name"]) for f in self.document.get("force", []) if "name" in f}
        self.added = self.closed = False
        self.used_before = _referenced(self.document)

    def text(self) -> str:
        """The patched document (a blank line closes the parameters an effect added)."""
        table = self.document["parameters"]
        if self.added and not self.closed:
            table.add(tomlkit.nl())
            self.closed = True
        return tomlkit.dumps(self.document)

    # -- parameters ---------------------------------------------------------------------------------
    def note(self, comment: str) -> None:
        """A block comment at the end of ``[parameters]`` (before the parameters an effect adds next)."""
        table = self.document["parameters"]
        for line in _lines(comment):
            table.add(tomlkit.comment(line))

    def drop_unused(self) -> list[str]:
        """Remove the parameters the original file used and the patch no longer does (an ``Fv`` replaced
        by ``Fvp``/``Fvn``), each with a note; return their names. Parameters the original did not use
        are the user's and stay."""
        table = self.document["parameters"]
        gone = sorted((self.used_before - _referenced(self.document)) & set(table))
        for name in gone:
            del table[name]
        if gone:
            self.note(f"symbolic diagnose: removed {', '.join(gone)}, no longer used by the model after the "
                      "effects added above")
        return gone

    def parameter(self, stem: str, value: float, comment: str) -> str:
        """Add a parameter named ``stem`` (or ``stem_2``, ... if taken) with ``value``; return its name.

        An effect's coefficient on a coordinate is named by :func:`symbolic.description.names.coefficient_name`
        (``Fc_q``), the name the regressor gives the coefficient it becomes (docs/model-format.md)."""
        name = unique(re.sub(r"[^A-Za-z0-9_]", "_", stem), self.taken)
        self.taken.add(name)
        item = tomlkit.item(float(value))
        item.comment(comment)
        self.document["parameters"].add(name, item)
        self.added = True
        return name

    # -- entries ------------------------------------------------------------------------------------
    def _entry(self, kind: str, coordinate: str, create: bool, comment: str) -> Any:
        tables = self.document.get(kind)
        if tables is not None:
            for table in tables:
                if table.get("coordinate") == coordinate:
                    return table
        if not create:
            return None
        table = tomlkit.table()
        for line in _lines(comment):
            table.add(tomlkit.comment(line))
        table.add("coordinate", coordinate)
        if tables is None:
            tables = tomlkit.aot()
            self.document.add(kind, tables)
        tables.append(table)
        return table

    def _value(self, kind: str, coordinate: str, key: str) -> str | None:
        table = self._entry(kind, coordinate, False, "")
        if table is None or key not in table:
            return None
        value = table[key]
        if isinstance(value, Mapping):
            raise ModelError(self.source, f"[[{kind}]] {coordinate!r} {key}", "is a table; the effect cannot be added to it")
        return str(value) if isinstance(value, str) else repr(float(value))

    def _set(self, kind: str, coordinate: str, key: str, value: str | Mapping[str, str], comment: str) -> None:
        table = self._entry(kind, coordinate, True, comment)
        if isinstance(value, Mapping):
            item = tomlkit.inline_table()
            item.update(dict(value))
        else:
            item = tomlkit.item(value)
        if not isinstance(table, tomlkit.items.InlineTable):
            item.comment(comment)
        table[key] = item

    def friction_value(self, coordinate: str, key: str) -> str | None:
        """The expression written for ``key`` in the coordinate's [[friction]] table, or ``None``."""
        return self._value("friction", coordinate, key)

    def set_friction(self, coordinate: str, key: str, value: str | Mapping[str, str], comment: str) -> None:
        """Set ``key`` of the coordinate's [[friction]] table (created if missing)."""
        self._set("friction", coordinate, key, value, comment)

    def drive_value(self, coordinate: str, key: str) -> str | None:
        """The expression written for ``key`` in the coordinate's [[drive]] table, or ``None``."""
        return self._value("drive", coordinate, key)

    def set_drive(self, coordinate: str, key: str, value: str, comment: str) -> None:
        """Set ``key`` of the coordinate's [[drive]] table (created if missing)."""
        self._set("drive", coordinate, key, value, comment)

    def coordinate(self, stem: str, comment: str) -> str:
        """Append a generalized coordinate named ``stem`` (or ``stem_2``, ...) to ``coordinates``; return its name."""
        name = unique(re.sub(r"[^A-Za-z0-9_]", "_", stem), self.taken)
        self.taken.add(name)
        self.document["coordinates"].append(name)
        self.document["coordinates"].comment(comment)
        return name

    def frame_dh(self, frame: str) -> dict[str, str]:
        """The DH entries of ``[[frame]] frame`` as written (``"0"`` where omitted)."""
        for table in self.document.get("frame", []):
            if table.get("name") == frame:
                dh = table.get("dh", {})
                return {key: _text(dh.get(key, "0")) for key in ("theta", "d", "a", "alpha")}
        raise ModelError(self.source, f"[[frame]] {frame!r}", "not found in the file (this is a bug of the workflow)")

    def set_frame_dh(self, frame: str, key: str, value: str, comment: str) -> None:
        """Set one DH entry of ``[[frame]] frame`` (a joint that gains a deflection: θ = q + q_flex)."""
        for table in self.document.get("frame", []):
            if table.get("name") == frame:
                if "dh" not in table:
                    table["dh"] = tomlkit.inline_table()
                table["dh"][key] = value
                table["dh"].comment(comment)
                return
        raise ModelError(self.source, f"[[frame]] {frame!r}", "not found in the file (this is a bug of the workflow)")

    def _append(self, kind: str, entries: Mapping[str, Any], comment: str) -> None:
        table = tomlkit.table()
        for line in _lines(comment):
            table.add(tomlkit.comment(line))
        for key, value in entries.items():
            if isinstance(value, Mapping):
                item = tomlkit.inline_table()
                item.update(dict(value))
                value = item
            table.add(key, value)
        table.add(tomlkit.nl())
        tables = self.document.get(kind)
        if tables is None:
            tables = tomlkit.aot()
            self.document.add(kind, tables)
        tables.append(table)

    def add_frame(self, stem: str, parent: str, dh: Mapping[str, str], comment: str) -> str:
        """Append a ``[[frame]]``; return its (unique) name."""
        taken = {str(t.get("name")) for t in self.document.get("frame", [])}
        name = unique(stem, taken)
        self._append("frame", {"name": name, "parent": parent, "dh": dict(dh)}, comment)
        return name

    def add_body(self, stem: str, frame: str, mass: str, inertia: Mapping[str, str] | None, comment: str,
                 com: list[str] | None = None) -> str:
        """Append a ``[[body]]`` on ``frame`` (a point mass without ``inertia``); return its (unique) name."""
        taken = {str(t.get("name")) for t in self.document.get("body", [])}
        name = unique(stem, taken)
        entries: dict[str, Any] = {"name": name, "frame": frame, "mass": mass}
        if com is not None:
            entries["com"] = list(com)
        if inertia is not None:
            entries["inertia"] = dict(inertia)
        self._append("body", entries, comment)
        return name

    def add_force(self, stem: str, coordinate: str, expression: str, comment: str) -> str:
        """Append a [[force]] table; return its (unique) name."""
        name = unique(stem, self.forces)
        self.forces.add(name)
        table = tomlkit.table()
        for line in _lines(comment):
            table.add(tomlkit.comment(line))
        table.add("name", name)
        table.add("coordinate", coordinate)
        table.add("expression", expression)
        tables = self.document.get("force")
        if tables is None:
            tables = tomlkit.aot()
            self.document.add("force", tables)
        tables.append(table)
        return name


def _referenced(document: Any) -> set[str]:
    """Identifiers in the document's expressions (every string outside ``[parameters]``)."""
    found: set[str] = set()

    def walk(node: Any) -> None:
        if isinstance(node, str):
            found.update(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", node))
        elif isinstance(node, Mapping):
            for value in node.values():
                walk(value)
        elif isinstance(node, (list, tuple)):
            for value in node:
                walk(value)

    walk({k: v for k, v in document.unwrap().items() if k != "parameters"})
    return found


def _text(value: Any) -> str:
    return str(value) if isinstance(value, str) else repr(float(value)) if isinstance(value, float) else str(value)


def _lines(comment: str, width: int = 100) -> list[str]:
    """A comment wrapped into lines of at most ``width`` characters."""
    words, lines, line = comment.split(), [], ""
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
    if line:
        lines.append(line)
    return lines
