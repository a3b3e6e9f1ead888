"""Read TOML model files (docs/model-format.md) into :class:`~symbolic.description.Robot`.

Parsing uses the standard library's :mod:`tomllib`; expressions are parsed by
:mod:`symbolic.description.expressions`. Unknown keys are refused so that a typo does not silently drop a body.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from symbolic.errors import ModelError, shown, suggestion
from symbolic.description.expressions import check_magnitude
from symbolic.description.validation import validate
from symbolic.description.robot import (
    DH_KEYS, INERTIA_KEYS, LIMIT_KEYS, Beam, Body, Constraint, Directional, Drive, EndEffector, Force, Frame, Friction,
    Joint, Parameter, Robot, Stribeck,
)

TOP_KEYS = {
    "name",
    "description",
    "convention",
    "coordinates",
    "gravity",
    "parameters",
    "frame",
    "body",
    "constraint",
    "end_effector",
    "beam",
    "friction",
    "drive",
    "force",
}


def load(path: str | Path, *, root: str | None = None, tip: str | None = None) -> Robot:
    """Load and validate a model file: TOML (docs/model-format.md), or URDF when the name ends in ``.urdf``.

    ``root``/``tip`` choose a chain of a URDF tree (:func:`symbolic.description.urdf.load`).

    Raises
    ------
    ModelError
        Naming the file, the key and the problem, for any invalid content.
    """
    path = Path(path)
    source = str(path)
    if path.suffix.lower() == ".urdf":
        from symbolic.description.urdf import load as load_urdf

        return load_urdf(path, root=root, tip=tip)
    if root is not None or tip is not None:
        raise ModelError(source, "--root/--tip", "choose a chain only in a URDF file (a .urdf model)")
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise ModelError(source, "file", f"cannot read model file: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise ModelError(source, "file", "model file is not UTF-8 text") from None
    return loads(text, source)


def loads(text: str, source: str = "<string>") -> Robot:
    """Parse model-file text; ``source`` names it in error messages."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(source, "TOML syntax", str(exc)) from None
    return _Reader(data, source).robot()


class _Reader:
    def __init__(self, data: Mapping[str, Any], source: str) -> None:
        self.data = data
        self.source = source

    def fail(self, key: str, problem: str) -> ModelError:
        return ModelError(self.source, key, problem)

    def table(self, value: Any, key: str, allowed: set[str], required: set[str] = frozenset()) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self.fail(key, f"expected a table, got {type(value).__name__}")
        extra = sorted(set(value) - allowed)
        if extra:
            raise self.fail(key, f"unknown key(s) {extra} (allowed: {', '.join(sorted(allowed))})"
                                 f"{suggestion(extra[0], allowed)}")
        missing = set(required) - set(value)
        if missing:
            raise self.fail(key, f"missing key(s) {sorted(missing)}")
        return value

    def array(self, value: Any, key: str) -> list[Any]:
        if not isinstance(value, list):
            raise self.fail(key, f"expected an array, got {type(value).__name__}")
        return value

    def string(self, value: Any, key: str) -> str:
        if not isinstance(value, str):
            raise self.fail(key, f"expected a string, got {type(value).__name__}")
        return value

    def robot(self) -> Robot:
        d = self.table(self.data, "top level", TOP_KEYS, {"name", "coordinates"})
        return validate(Robot(
            name=self.string(d["name"], "name"),
            description=self.string(d.get("description", ""), "description"),
            convention=self.string(d.get("convention", "standard"), "convention"),
            coordinates=tuple(self.string(c, "coordinates") for c in self.array(d["coordinates"], "coordinates")),
            gravity=tuple(self.array(d.get("gravity", [0, 0, "-9.81"]), "gravity")),
            parameters=self.parameters(d.get("parameters", {})),
            frames=tuple(self.frame(f, i) for i, f in enumerate(self.array(d.get("frame", []), "[[frame]]"))),
            bodies=tuple(self.body(b, i) for i, b in enumerate(self.array(d.get("body", []), "[[body]]"))),
            constraints=tuple(
                self.constraint(c, i) for i, c in enumerate(self.array(d.get("constraint", []), "[[constraint]]"))
            ),
            beams=tuple(self.beam(b, i) for i, b in enumerate(self.array(d.get("beam", []), "[[beam]]"))),
            end_effector=self.end_effector(d.get("end_effector")),
            frictions=tuple(self.friction(f, i) for i, f in enumerate(self.array(d.get("friction", []), "[[friction]]"))),
            drives=tuple(self.drive(x, i) for i, x in enumerate(self.array(d.get("drive", []), "[[drive]]"))),
            forces=tuple(self.force(x, i) for i, x in enumerate(self.array(d.get("force", []), "[[force]]"))),
            source=self.source,
        ))

    def parameters(self, table: Any) -> tuple[Parameter, ...]:
        if not isinstance(table, Mapping):
            raise self.fail("[parameters]", "expected a table of name = value")
        out = []
        for name, value in table.items():
            key = f"[parameters] {name}"
            v: Mapping[str, Any] = {"value": value}
            if isinstance(value, Mapping):
                v = self.table(value, key, {"value", "unit", "description", "fixed", "min", "max"}, {"value"})
            number = self.number(v["value"], key, "nominal value")
            fixed = v.get("fixed", False)
            if not isinstance(fixed, bool):
                raise self.fail(f"{key} fixed", f"expected true or false, got {shown(fixed, 40)}")
            bounds = [None if v.get(k) is None else self.number(v[k], f"{key} {k}", k) for k in ("min", "max")]
            out.append(Parameter(name, number, self.string(v.get("unit", ""), f"{key} unit"),
                                 self.string(v.get("description", ""), f"{key} description"), fixed, *bounds))
        return tuple(out)

    def number(self, value: Any, key: str, what: str) -> float:
        """A TOML number as a float (an integer too large for a float is refused by its magnitude)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(key, f"{what} must be a number, got {shown(value, 40)}")
        check_magnitude(value, self.source, key)
        return float(value)

    def frame(self, value: Any, index: int) -> Frame:
        key = f"[[frame]] #{index + 1}"
        f = self.table(value, key, {"name", "parent", "dh", "origin", "joint", "coordinate"}, {"name", "parent"})
        name = self.string(f["name"], f"{key} name")
        key = f"[[frame]] {name!r}"
        parent = self.string(f["parent"], f"{key} parent")
        general = {"origin", "joint", "coordinate"} & set(f)
        if "dh" in f:
            if general:
                raise self.fail(key, f"give either dh or origin/joint/coordinate, not both (found {', '.join(sorted(general))})")
            dh = self.table(f["dh"], f"{key} dh", set(DH_KEYS), set(DH_KEYS))
            return Frame(name=name, parent=parent, **{k: dh[k] for k in DH_KEYS})
        if not general:
            raise self.fail(key, "missing key(s) ['dh'] (or origin and joint, as a URDF joint)")
        return self.joint_frame(f, key, name, parent)

    def joint_frame(self, f: Mapping[str, Any], key: str, name: str, parent: str) -> Frame:
        """A frame given as a URDF joint is: origin = { xyz, rpy }, joint = { type, axis, limit }, coordinate."""
        origin = self.table(f.get("origin", {}), f"{key} origin", {"xyz", "rpy"})
        joint = self.table(f.get("joint", {"type": "fixed"}), f"{key} joint", {"type", "axis", "limit"}, {"type"})
        kind = self.string(joint["type"], f"{key} joint.type")
        limit = self.table(joint.get("limit", {}), f"{key} joint.limit", set(LIMIT_KEYS))
        placement = Joint(
            type=kind,
            axis=tuple(self.array(joint.get("axis", [0, 0, 1]), f"{key} joint.axis")),
            xyz=tuple(self.array(origin.get("xyz", [0, 0, 0]), f"{key} origin.xyz")),
            rpy=tuple(self.array(origin.get("rpy", [0, 0, 0]), f"{key} origin.rpy")),
            limits=dict(limit),
        )
        coordinate = f.get("coordinate", 0)
        if kind == "fixed" and "coordinate" in f:
            raise self.fail(f"{key} coordinate", "a fixed joint has no coordinate")
        if kind != "fixed" and "coordinate" not in f:
            raise self.fail(f"{key} coordinate", f"a {kind} joint needs a coordinate (e.g. coordinate = \"q1\")")
        variable = "d" if kind == "prismatic" else "theta"
        return Frame(name=name, parent=parent, joint=placement, **{variable: coordinate})

    def body(self, value: Any, index: int) -> Body:
        key = f"[[body]] #{index + 1}"
        b = self.table(value, key, {"name", "frame", "mass", "com", "inertia"}, {"name", "frame", "mass"})
        name = self.string(b["name"], f"{key} name")
        inertia = b.get("inertia")
        if inertia is not None:
            inertia = self.table(inertia, f"[[body]] {name!r} inertia", set(INERTIA_KEYS))
        return Body(
            name=name,
            frame=self.string(b["frame"], f"[[body]] {name!r} frame"),
            mass=b["mass"],
            com=tuple(self.array(b.get("com", [0, 0, 0]), f"[[body]] {name!r} com")),
            inertia=inertia,
        )

    def beam(self, value: Any, index: int) -> Beam:
        key = f"[[beam]] #{index + 1}"
        allowed = {"name", "frame", "length", "density", "EI_v", "EI_w", "modes_v", "modes_w", "boundary", "tip_mass"}
        b = self.table(value, key, allowed, {"name", "frame", "length", "density", "EI_v", "EI_w"})
        name = self.string(b["name"], f"{key} name")
        return Beam(
            name=name,
            frame=self.string(b["frame"], f"[[beam]] {name!r} frame"),
            length=b["length"],
            density=b["density"],
            EI_v=b["EI_v"],
            EI_w=b["EI_w"],
            modes_v=b.get("modes_v", 1),
            modes_w=b.get("modes_w", 1),
            boundary=self.string(b.get("boundary", "clamped-free"), f"[[beam]] {name!r} boundary"),
            tip_mass=b.get("tip_mass"),
        )

    def constraint(self, value: Any, index: int) -> Constraint:
        key = f"[[constraint]] #{index + 1}"
        c = self.table(value, key, {"coordinate", "expression"}, {"coordinate", "expression"})
        return Constraint(self.string(c["coordinate"], f"{key} coordinate"), c["expression"])

    def end_effector(self, value: Any) -> EndEffector | None:
        if value is None:
            return None
        e = self.table(value, "end_effector", {"frame", "point"}, {"frame"})
        return EndEffector(self.string(e["frame"], "end_effector frame"), tuple(self.array(e.get("point", [0, 0, 0]), "end_effector point")))

    def entry_key(self, kind: str, table: Mapping[str, Any], index: int) -> str:
        c = table.get("coordinate")
        return f"[[{kind}]] {c!r}" if isinstance(c, str) else f"[[{kind}]] #{index + 1}"

    def friction(self, value: Any, index: int) -> Friction:
        key = f"[[friction]] #{index + 1}"
        f = self.table(value, key, {"coordinate", "viscous", "coulomb", "offset", "stribeck"}, {"coordinate"})
        key = self.entry_key("friction", f, index)
        stribeck = f.get("stribeck")
        if stribeck is not None:
            t = self.table(stribeck, f"{key} stribeck", {"static", "velocity"}, {"static", "velocity"})
            stribeck = Stribeck(t["static"], t["velocity"])
        return Friction(
            coordinate=self.string(f["coordinate"], f"{key} coordinate"),
            viscous=self.directional(f.get("viscous"), f"{key} viscous"),
            coulomb=self.directional(f.get("coulomb"), f"{key} coulomb"),
            offset=f.get("offset"),
            stribeck=stribeck,
        )

    def directional(self, value: Any, key: str) -> Any:
        """An expression, or ``{ positive = ..., negative = ... }`` for a direction-dependent coefficient."""
        if isinstance(value, Mapping):
            t = self.table(value, key, {"positive", "negative"}, {"positive", "negative"})
            return Directional(t["positive"], t["negative"])
        return value

    def drive(self, value: Any, index: int) -> Drive:
        d = self.table(value, f"[[drive]] #{index + 1}", {"coordinate", "ratio", "rotor_inertia", "gain"}, {"coordinate"})
        key = self.entry_key("drive", d, index)
        return Drive(self.string(d["coordinate"], f"{key} coordinate"), d.get("ratio", 1), d.get("rotor_inertia", 0), d.get("gain"))

    def force(self, value: Any, index: int) -> Force:
        f = self.table(value, f"[[force]] #{index + 1}", {"name", "coordinate", "expression"}, {"name", "coordinate", "expression"})
        name = self.string(f["name"], f"[[force]] #{index + 1} name")
        return Force(name, self.string(f["coordinate"], f"[[force]] {name!r} coordinate"), f["expression"])


def with_parameter_values(text: str, values: Mapping[str, float], source: str = "<string>", provenance: str | None = None) -> str:
    """The model-file ``text`` with the nominal values of ``values`` replaced in ``[parameters]``.

    Comments, order and layout are kept (tomlkit edits the document in place); a parameter written as
    ``{ value = …, unit = … }`` keeps its unit. ``provenance`` (e.g. "identified by symbolic identify
    from DATA_EMPS.mat") says where the new values come from: it becomes the description of an inline
    table, the old description kept after "before:" (a description such as "published value" must not
    label an identified one), and the trailing comment of a plain number. Unknown names are refused.
    """
    import tomlkit

    document = tomlkit.parse(text)
    table = document.get("parameters")
    if table is None:
        raise ModelError(source, "[parameters]", "the model file has no [parameters] table to update")
    unknown = sorted(set(values) - set(table))
    if unknown:
        raise ModelError(source, "[parameters]", f"unknown parameter(s) {unknown}")
    for name, value in values.items():
        entry = table[name]
        number = tomlkit.float_(repr(float(value)))
        if isinstance(entry, Mapping):
            entry["value"] = number
            if provenance:
                before = entry.get("description")
                entry["description"] = provenance + (f"; before: {before}" if before else "")
        else:
            comment = f"# {provenance}" if provenance else entry.trivia.comment
            number.trivia.comment_ws, number.trivia.comment = (entry.trivia.comment_ws or "  "), comment
            number.trivia.trail = entry.trivia.trail
            table[name] = number
    return tomlkit.dumps(document)


def with_loadable_values(text: str, values: Mapping[str, float], source: str = "<string>",
                         provenance: str | None = None) -> tuple[str, dict[str, str]]:
    """:func:`with_parameter_values`, never returning text that :func:`loads` refuses.

    The text with all the new values is loaded; if the loader refuses it (a negative mass, an inertia
    tensor that is not positive semidefinite, a value outside its ``min``/``max``, ...), the values are
    tried one at a time in order, and each one the loader refuses together with those already accepted
    keeps its value in ``text``. Returns the text and {parameter: why its new value was not written}.
    ``text`` itself must load (it is the model the values were identified for).

    Raises
    ------
    ModelError
        When ``text`` itself does not load, or for a name that is not in ``[parameters]``.
    """
    import warnings

    from symbolic.errors import ModelWarning

    def refusal(candidate: Mapping[str, float]) -> tuple[str, str | None]:
        out = with_parameter_values(text, candidate, source, provenance)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)  # a warning is not a refusal; the user sees it on load
            try:
                loads(out, source)
            except ModelError as error:
                return out, f"{error.key}: {error.problem}"
        return out, None

    out, problem = refusal(values)
    if problem is None:
        return out, {}
    accepted: dict[str, float] = {}
    kept: dict[str, str] = {}
    for name, value in values.items():
        _, problem = refusal({**accepted, name: value})
        if problem is None:
            accepted[name] = value
        else:
            kept[name] = f"{float(value):.6g} would be refused ({problem})"
    out, problem = refusal(accepted)
    if problem is not None:
        raise ModelError(source, "file", f"the model file does not load before any value is changed ({problem})")
    return out, kept
