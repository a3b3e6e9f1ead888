"""Read URDF files (ROS's Unified Robot Description Format) into a :class:`~symbolic.description.Robot`.

What becomes what — moving joints become general frames with coordinates, fixed joints are merged as
Pinocchio merges them, each ``<inertial>`` a body with parameters, ``<dynamics>`` friction — how the inertial
values are converted, how a chain is chosen from a tree and what is refused: docs/model-format.md, "URDF
import". XML is parsed by :mod:`defusedxml` with DTDs, entity declarations and external references refused
before any expansion (:func:`parse_xml`), so a hostile file costs nothing but a one-line
:class:`~symbolic.errors.ModelError`.
"""

from __future__ import annotations

import keyword
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import Element, ParseError

import numpy as np

from symbolic.description.robot import (
    BASE, C_KEYWORDS, IDENTIFIER, Body, Constraint, Frame, Friction, Joint, Parameter, Robot,
)
from symbolic.description.expressions import RESERVED_NAMES
from symbolic.description.names import unique
from symbolic.errors import ModelError, shown

MAX_BYTES = 20_000_000
"""Largest URDF read (real ones, meshes referenced by name, are below 1 MB; talos_full_v2 is 0.1 MB)."""

MAX_MERGED = 256
"""Most links whose ``<inertial>`` a fixed joint merges onto one frame. Each keeps its ten parameters, and
the equations of motion sum them symbolically: 300 such links took 26 s to derive, 1,000 failed (Python
cannot compile a sum of a few thousand terms). Real robots merge at most 12 (PR2; example-robot-data's
69 URDFs); the dynamics depend only on the links' total, so a file over the limit is refused with the
advice to combine them in one ``<inertial>``."""

RIGHT_ANGLE_TOLERANCE = 1e-15
"""An angle this close (rad) to a multiple of π/2 is that multiple, exactly: the double nearest π/2
(1.5707963267948966, as xacro writes ${pi/2}) is π/2 to within 1e-16, and a rotation by an exact right
angle costs nothing. A rounded angle (1.57079632679, 5e-12 off; 1.5708) is kept as written, as Pinocchio
keeps it: snapping it would move the dynamics by 1e-10 of their size."""

TINY = 1e-20
"""Magnitudes below this are read as 0 (exporters write 2.35e-33 for zero; the model format's numbers
stop at 1e-30)."""

NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
"""A URDF number: XML Schema's double in decimal form (sign, digits, fraction, exponent), ASCII digits
only. Python's ``float`` also takes ``1_000``, ``infinity`` and other scripts' digits (``١``): a URDF
parser (urdfdom, Pinocchio) reads none of them as that number."""

NOT_FINITE = re.compile(r"[+-]?(?:inf|infinity|nan)", re.IGNORECASE)
"""Spellings of infinity and NaN (XML Schema's ``INF``, ``NaN``, and C's): refused as not finite."""

XML_SPACE = re.compile(r"[ \t\r\n]+")
"""Whitespace between the numbers of an attribute, as XML defines it (not U+00A0 and the like)."""

MOVING = ("revolute", "continuous", "prismatic")
REFUSED = {"floating": "6 degrees of freedom", "planar": "3 degrees of freedom"}


def load(path: str | Path, root: str | None = None, tip: str | None = None, merge_fixed: bool = True) -> Robot:
    """Load and validate a URDF file (docs/model-format.md, "URDF import").

    ``root``/``tip`` choose a chain of a tree: the joints on the path from ``root`` to ``tip`` move, every other
    joint below ``root`` is locked at 0 (its links carried rigidly, as Pinocchio's ``buildReducedModel`` at the
    neutral configuration), links past ``tip`` are left out, and whatever is not below ``root`` is the fixed
    world. ``merge_fixed=False`` keeps fixed joints as frames with a fixed joint instead of merging their links
    (the dynamics are the same).

    Raises
    ------
    ModelError
        Naming the file, the element and the problem: malformed XML, a DTD or entity (XML attacks), a joint
        whose parent or child link is missing, a cycle, a floating base, a negative mass, an inertia that is
        not positive semidefinite, a number that is not finite, ...
    """
    path = Path(path)
    source = str(path)
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise ModelError(source, "file", f"URDF file of {size} bytes is larger than {MAX_BYTES} bytes")
        data = path.read_bytes()
    except OSError as exc:
        raise ModelError(source, "file", f"cannot read URDF file: {exc.strerror}") from None
    return loads(data, source, root=root, tip=tip, merge_fixed=merge_fixed)


def loads(data: str | bytes, source: str = "<urdf>", root: str | None = None, tip: str | None = None,
          merge_fixed: bool = True) -> Robot:
    """Parse URDF text (``source`` names it in messages); see :func:`load`."""
    if len(data) > MAX_BYTES:
        raise ModelError(source, "file", f"URDF text of {len(data)} characters is longer than {MAX_BYTES}")
    return _Importer(parse_xml(data, source), source, merge_fixed).robot(root, tip)


def parse_xml(data: str | bytes, source: str) -> Element:
    """The ``<robot>`` element, parsed by defusedxml with DTDs, entities and external references forbidden."""
    import defusedxml
    from defusedxml.ElementTree import fromstring

    try:
        element = fromstring(data, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except defusedxml.DTDForbidden:
        raise ModelError(source, "XML", "a DTD (<!DOCTYPE ...>) is not allowed in a URDF file (it can declare "
                                        "entities that expand without bound or read other files)") from None
    except defusedxml.EntitiesForbidden as exc:
        raise ModelError(source, "XML", f"entity declaration {shown(exc.name, 40)} is not allowed in a URDF file") from None
    except defusedxml.ExternalReferenceForbidden:
        raise ModelError(source, "XML", "external references are not allowed in a URDF file") from None
    except defusedxml.DefusedXmlException as exc:
        raise ModelError(source, "XML", f"refused: {type(exc).__name__}") from None
    except ParseError as exc:
        raise ModelError(source, "XML", f"not well-formed XML ({exc})") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise ModelError(source, "XML", f"not readable XML ({shown(str(exc), 80)})") from None
    if element.tag != "robot":
        raise ModelError(source, "XML", f"the root element is <{str(element.tag)[:40]}>, a URDF file has <robot>")
    return element


# -- rigid transforms in floats -------------------------------------------------------------------
def rpy_matrix(rpy) -> np.ndarray:
    """Rot(rpy) = Rz(yaw)·Ry(pitch)·Rx(roll) (URDF's fixed-axis roll, pitch, yaw)."""
    r, p, y = rpy
    cr, sr, cp, sp_, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([
        [cy * cp, cy * sp_ * sr - sy * cr, cy * sp_ * cr + sy * sr],
        [sy * cp, sy * sp_ * sr + cy * cr, sy * sp_ * cr - cy * sr],
        [-sp_, cp * sr, cp * cr],
    ])


def matrix_rpy(m: np.ndarray) -> tuple[float, float, float]:
    """The roll, pitch, yaw of a rotation matrix (inverse of :func:`rpy_matrix`; yaw = 0 at gimbal lock)."""
    pitch = math.atan2(-m[2, 0], math.hypot(m[0, 0], m[1, 0]))
    if math.hypot(m[0, 0], m[1, 0]) < 1e-12:
        return math.atan2(-m[1, 2], m[1, 1]), pitch, 0.0
    return math.atan2(m[2, 1], m[2, 2]), pitch, math.atan2(m[1, 0], m[0, 0])


def snap(angle: float) -> tuple[float, str]:
    """(value, expression text): a multiple of π/2 within :data:`RIGHT_ANGLE_TOLERANCE` exactly, else as read."""
    k = round(angle / (math.pi / 2))
    if abs(angle - k * math.pi / 2) <= RIGHT_ANGLE_TOLERANCE:
        k = (k + 2) % 4 - 2  # −π … π
        return k * math.pi / 2, {0: "0", 1: "pi/2", -1: "-pi/2", -2: "pi"}[k]
    return angle, repr(angle)


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    u = axis / np.linalg.norm(axis)
    s = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return math.cos(angle) * np.eye(3) + math.sin(angle) * s + (1 - math.cos(angle)) * np.outer(u, u)


@dataclass
class Placement:
    """A link's frame relative to the model frame that carries it: x_frame = R x_link + p."""

    frame: str
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    p: np.ndarray = field(default_factory=lambda: np.zeros(3))
    identity: bool = True

    def then(self, R: np.ndarray, p: np.ndarray) -> Placement:
        return Placement(self.frame, self.R @ R, self.p + self.R @ p, False)


@dataclass
class _Joint:
    name: str
    type: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]
    limits: dict[str, float]
    mimic: tuple[str, float, float] | None
    damping: float
    friction: float


class _Importer:
    def __init__(self, element: Element, source: str, merge_fixed: bool) -> None:
        self.xml = element
        self.source = source
        self.merge_fixed = merge_fixed
        self.links: dict[str, Element] = {}
        self.joints: dict[str, _Joint] = {}
        self.parent_joint: dict[str, _Joint] = {}
        self.children: dict[str, list[_Joint]] = {}
        self.names: dict[str, str] = {}  # identifiers handed out -> what they name
        self.extra_parameters: list[Parameter] = []  # friction parameters, after the bodies' ones

    def fail(self, key: str, problem: str) -> ModelError:
        return ModelError(self.source, key, problem)

    # -- reading -----------------------------------------------------------------------------
    def numbers(self, element: Element | None, attribute: str, key: str, count: int, default: tuple[float, ...]) -> tuple[float, ...]:
        if element is None or element.get(attribute) is None:
            return default
        text = element.get(attribute)
        parts = XML_SPACE.split(text.strip(" \t\r\n"))
        if len(parts) != count or not parts[0]:
            raise self.fail(f"{key} {attribute}", f"expected {count} number(s), got {shown(text, 60)}")
        out = []
        for part in parts:
            if NOT_FINITE.fullmatch(part):
                raise self.fail(f"{key} {attribute}", f"{shown(part, 40)} is not finite (NaN and infinity are refused)")
            if not NUMBER.fullmatch(part):
                raise self.fail(f"{key} {attribute}", f"{shown(part, 40)} is not a number (a URDF number is an optional "
                                                      "sign, digits, an optional fraction and exponent: 1000, -0.5, "
                                                      "1.2e-3; no _ or other characters)")
            value = float(part)
            if not math.isfinite(value):  # 1e999: the form of a number, beyond a double
                raise self.fail(f"{key} {attribute}", f"{shown(part, 40)} is not finite (beyond the largest double)")
            if abs(value) > 1e30:
                raise self.fail(f"{key} {attribute}", f"{shown(part, 40)} is out of range (magnitudes up to 1e30)")
            out.append(0.0 if abs(value) < TINY else value)
        return tuple(out)

    def number(self, element: Element | None, attribute: str, key: str, default: float | None = None) -> float | None:
        (value,) = self.numbers(element, attribute, key, 1, (default,))
        return value

    def read(self) -> None:
        for link in self.xml.findall("link"):
            name = link.get("name")
            if not name:
                raise self.fail("<link>", "a link needs a name")
            if name in self.links:
                raise self.fail(f"<link {name!r}>", "link defined twice")
            self.links[name] = link
        for element in self.xml.findall("joint"):
            joint = self.joint(element)
            self.joints[joint.name] = joint
        for joint in self.joints.values():
            for role in ("parent", "child"):
                link = getattr(joint, role)
                if link not in self.links:
                    raise self.fail(f"<joint {joint.name!r}> <{role}>", f"link {shown(link, 40)} does not exist "
                                                                       f"(links: {_listing(self.links)})")
            if joint.child in self.parent_joint:
                other = self.parent_joint[joint.child].name
                raise self.fail(f"<joint {joint.name!r}> <child>", f"link {joint.child!r} is already the child of joint "
                                                                   f"{other!r} (a URDF is a tree: one parent joint per link)")
            if joint.parent == joint.child:
                raise self.fail(f"<joint {joint.name!r}>", f"link {joint.child!r} is its own parent")
            self.parent_joint[joint.child] = joint
            self.children.setdefault(joint.parent, []).append(joint)

    def joint(self, element: Element) -> _Joint:
        name = element.get("name")
        if not name:
            raise self.fail("<joint>", "a joint needs a name")
        key = f"<joint {name!r}>"
        if name in self.joints:
            raise self.fail(key, "joint defined twice")
        kind = element.get("type")
        if kind in REFUSED:
            raise self.fail(f"{key} type", f"a {kind} joint ({REFUSED[kind]}) is not supported: symbolic models fixed-base "
                                           "robots with 1-DOF joints (choose the chain below it with --root)")
        if kind not in (*MOVING, "fixed"):
            raise self.fail(f"{key} type", f"unknown joint type {shown(kind, 40)} (allowed: revolute, continuous, prismatic, fixed)")
        links = {}
        for role in ("parent", "child"):
            tag = element.find(role)
            if tag is None or not tag.get("link"):
                raise self.fail(f"{key} <{role}>", f"missing <{role} link=\"...\"/>")
            links[role] = tag.get("link")
        origin = element.find("origin")
        xyz = self.numbers(origin, "xyz", f"{key} <origin>", 3, (0.0, 0.0, 0.0))
        rpy = self.numbers(origin, "rpy", f"{key} <origin>", 3, (0.0, 0.0, 0.0))
        axis = self.numbers(element.find("axis"), "xyz", f"{key} <axis>", 3, (1.0, 0.0, 0.0))
        if kind in MOVING and math.hypot(*axis) < 1e-9:
            raise self.fail(f"{key} <axis> xyz", f"the axis of a {kind} joint must not be zero")
        limits = {}
        limit = element.find("limit")
        for attribute in ("lower", "upper", "velocity", "effort"):
            value = self.number(limit, attribute, f"{key} <limit>")
            if value is not None and not (kind == "continuous" and attribute in ("lower", "upper")):
                limits[attribute] = value
        if limits.get("lower", -math.inf) > limits.get("upper", math.inf):
            raise self.fail(f"{key} <limit>", f"lower = {limits['lower']:g} is above upper = {limits['upper']:g}")
        mimic = None
        tag = element.find("mimic")
        if tag is not None and kind in MOVING:
            if not tag.get("joint"):
                raise self.fail(f"{key} <mimic>", "missing joint=\"...\"")
            mimic = (tag.get("joint"), self.number(tag, "multiplier", f"{key} <mimic>", 1.0),
                     self.number(tag, "offset", f"{key} <mimic>", 0.0))
        dynamics = element.find("dynamics")
        damping = self.number(dynamics, "damping", f"{key} <dynamics>", 0.0)
        friction = self.number(dynamics, "friction", f"{key} <dynamics>", 0.0)
        for what, value in (("damping", damping), ("friction", friction)):
            if value < 0:
                raise self.fail(f"{key} <dynamics> {what}", f"must be non-negative, got {value:g}")
        return _Joint(name, kind, links["parent"], links["child"], xyz, rpy, axis, limits, mimic, damping, friction)

    # -- the tree ------------------------------------------------------------------------------
    def root(self, root: str | None) -> str:
        if root is not None:
            if root not in self.links:
                raise self.fail("--root", f"link {shown(root, 40)} does not exist (links: {_listing(self.links)})")
            return root
        if not self.links:
            raise self.fail("<robot>", "no <link>: a URDF robot needs at least one link and one moving joint")
        roots = [name for name in self.links if name not in self.parent_joint]
        if not roots:
            raise self.fail("<joint>", f"the joints form a cycle: {self.cycle(next(iter(self.links)))}")
        if len(roots) > 1:
            raise self.fail("<link>", f"links {_listing(roots)} have no parent joint: the file holds several trees "
                                      "(choose one with --root)")
        return roots[0]

    def cycle(self, start: str) -> str:
        path, link = [start], start
        while link in self.parent_joint:
            link = self.parent_joint[link].parent
            if link in path:
                loop = path[path.index(link):] + [link]
                return " <- ".join(loop)
            path.append(link)
        return " <- ".join(path)

    def subtree(self, root: str, tip: str | None = None) -> list[_Joint]:
        """The joints below ``root`` (none below ``tip``), depth first in file order (Pinocchio's order)."""
        out: list[_Joint] = []
        stack = list(reversed(self.children.get(root, [])))
        seen = {root}
        while stack:
            joint = stack.pop()
            if joint.child in seen:
                raise self.fail(f"<joint {joint.name!r}>", f"the joints form a cycle: {self.cycle(joint.child)}")
            seen.add(joint.child)
            out.append(joint)
            if joint.child != tip:
                stack.extend(reversed(self.children.get(joint.child, [])))
        unreached = [j for j in self.joints.values() if j.child not in seen and self.below(j.child, root)
                     and not (tip is not None and self.below(j.child, tip))]
        if unreached:
            raise self.fail(f"<joint {unreached[0].name!r}>", f"the joints form a cycle: {self.cycle(unreached[0].child)}")
        return out

    def below(self, link: str, root: str) -> bool:
        seen = set()
        while link in self.parent_joint and link not in seen:
            seen.add(link)
            link = self.parent_joint[link].parent
            if link == root:
                return True
        return False

    def chain(self, root: str, tip: str | None, joints: list[_Joint]) -> set[str]:
        """Names of the joints that move: those on the path root → tip, or all moving joints below root."""
        if tip is None:
            return {j.name for j in joints if j.type in MOVING}
        if tip not in self.links:
            raise self.fail("--tip", f"link {shown(tip, 40)} does not exist (links: {_listing(self.links)})")
        path, link = set(), tip
        while link != root:
            if link not in self.parent_joint:
                raise self.fail("--tip", f"link {tip!r} is not below the root link {root!r}")
            joint = self.parent_joint[link]
            path.add(joint.name)
            link = joint.parent
        return {name for name in path if self.joints[name].type in MOVING}

    # -- names ---------------------------------------------------------------------------------
    def identifier(self, text: str, prefix: str, what: str) -> str:
        """A free identifier for ``text``: [A-Za-z][A-Za-z0-9_]*, no reserved name or suffix, no Python
        keyword (``_`` appended: joint ``lambda`` is coordinate ``lambda_``), unique."""
        name = prefix + re.sub(r"[^A-Za-z0-9_]", "_", text)
        if not IDENTIFIER.match(name):
            name = "q_" + name.lstrip("_")
        if name in RESERVED_NAMES or name == "t" or name.endswith(("_dot", "_ddot")) or keyword.iskeyword(name):
            name += "_"  # a Python keyword (lambda, class, if) cannot be parsed as a name in expressions
        if name.startswith(("qd_", "qdd_")):
            name = "j_" + name
        name = unique(name, self.names)
        self.names[name] = what
        return name

    def frame_name(self, link: str) -> str:
        name = re.sub(r"[^A-Za-z0-9_']", "_", link)
        return "base_" if name == BASE else name

    # -- building ------------------------------------------------------------------------------
    def robot(self, root: str | None, tip: str | None) -> Robot:
        self.read()
        root = self.root(root)
        moving = self.chain(root, tip, self.subtree(root))
        joints = self.subtree(root, tip)
        moving |= self.leaders_of(moving)
        moving |= self.mimics_of(moving, joints)
        past = sorted(moving - {j.name for j in joints})
        if past:
            raise self.fail("--tip", f"joint {past[0]!r} moves a joint of the chain (<mimic>) but lies past the tip {tip!r}")
        if not moving:
            raise self.fail("<joint>", f"no revolute, continuous or prismatic joint below link {root!r}: nothing moves")
        placement = {root: Placement(BASE)}
        frames, coordinates, constraints, frictions = [], [], [], []
        coordinate_of: dict[str, str] = {}
        used = {BASE}
        for joint in joints:
            parent = placement[joint.parent]
            rpy, rpy_text = zip(*(snap(a) for a in joint.rpy))
            R, p = rpy_matrix(rpy), np.array(joint.xyz)
            held = 0.0 if joint.name in moving else self.locked_value(joint)
            if held:
                R, p = R @ self.joint_rotation(joint, held), p + R @ self.joint_shift(joint, held)
            if joint.name not in moving and self.merge_fixed:
                placement[joint.child] = parent.then(R, p)
                continue
            if parent.identity and not held:
                xyz, rpy_out = tuple(joint.xyz), tuple(rpy_text)
            else:
                composed = parent.then(R, p)
                xyz, rpy_out = tuple(float(x) for x in composed.p), tuple(snap(a)[1] for a in matrix_rpy(composed.R))
            name = self.frame_name(joint.child)
            while name in used:
                name += "_"
            used.add(name)
            if joint.name in moving:
                c = self.identifier(joint.name, "", f"joint {joint.name!r}")
                coordinate_of[joint.name] = c
                if joint.mimic is None:
                    coordinates.append(c)
                variable = "d" if joint.type == "prismatic" else "theta"
                placed = Joint(joint.type, joint.axis, xyz, rpy_out, dict(joint.limits))
                frames.append(Frame(name, parent.frame, joint=placed, **{variable: c}))
                frictions += self.friction(joint, c)
            else:
                frames.append(Frame(name, parent.frame, joint=Joint("fixed", (0, 0, 1), xyz, rpy_out)))
            placement[joint.child] = Placement(name)
        for joint in joints:
            if joint.name in moving and joint.mimic is not None:
                constraints.append(Constraint(coordinate_of[joint.name], self.mimic_expression(joint, coordinate_of)))
        parameters, bodies = self.bodies(root, placement)
        name = re.sub(r"[^a-z0-9_]", "_", (self.xml.get("name") or "robot").lower())
        if not re.match(r"^[a-z]", name) or name in C_KEYWORDS:
            name = "robot_" + name
        from symbolic.description.validation import validate

        return validate(Robot(
            name=name,
            description=f"{self.xml.get('name') or name} (URDF {Path(self.source).name}"
                        + (f", chain {root} -> {tip}" if tip else "") + ")",
            convention="modified",
            coordinates=tuple(coordinates),
            parameters=tuple(parameters),
            frames=tuple(frames),
            bodies=tuple(bodies),
            constraints=tuple(constraints),
            frictions=tuple(frictions),
            source=self.source,
        ))

    def leaders_of(self, moving: set[str]) -> set[str]:
        """The joints that moving mimic joints follow (a mimic on the chain drags its leader along)."""
        out = set()
        for name in moving:
            joint, seen = self.joints[name], {name}
            while joint.mimic is not None:
                leader = joint.mimic[0]
                if leader not in self.joints:
                    raise self.fail(f"<joint {joint.name!r}> <mimic>", f"joint {shown(leader, 40)} does not exist")
                if leader in seen:
                    raise self.fail(f"<joint {name!r}> <mimic>", f"mimic joints form a cycle: {' -> '.join([*seen, leader])}")
                seen.add(leader)
                joint = self.joints[leader]
                if joint.type not in MOVING:
                    raise self.fail(f"<joint {name!r}> <mimic>", f"joint {leader!r} that it mimics is {joint.type}")
                out.add(leader)
        return out

    def mimics_of(self, moving: set[str], joints: list[_Joint]) -> set[str]:
        """Mimic joints following a moving joint move with it (as constrained coordinates)."""
        out, grown = set(moving), True
        while grown:
            grown = False
            for j in joints:
                if j.mimic is not None and j.name not in out and j.mimic[0] in out:
                    out.add(j.name)
                    grown = True
        for j in joints:
            if j.name in out and j.mimic is not None and j.mimic[0] not in self.joints:
                raise self.fail(f"<joint {j.name!r}> <mimic>", f"joint {shown(j.mimic[0], 40)} does not exist")
        return out - moving

    def locked_value(self, joint: _Joint) -> float:
        """The value a joint that does not move is held at: 0, a mimic's offset (its leader is locked too)."""
        return joint.mimic[2] if joint.mimic is not None else 0.0

    def joint_rotation(self, joint: _Joint, value: float) -> np.ndarray:
        if joint.type in ("revolute", "continuous") and value != 0:
            return axis_rotation(np.array(joint.axis), value)
        return np.eye(3)

    def joint_shift(self, joint: _Joint, value: float) -> np.ndarray:
        if joint.type == "prismatic" and value != 0:
            return np.array(joint.axis) / np.linalg.norm(joint.axis) * value
        return np.zeros(3)

    def mimic_expression(self, joint: _Joint, coordinate_of: dict[str, str]) -> str:
        """multiplier·q_leader + offset through a chain of mimics (cycles were refused by :meth:`leaders_of`)."""
        multiplier, offset, leader = 1.0, 0.0, joint
        while leader.mimic is not None:
            name, m, o = leader.mimic
            multiplier, offset = multiplier * m, offset + multiplier * o
            leader = self.joints[name]
        text = coordinate_of[leader.name] if multiplier == 1 else f"{multiplier!r}*{coordinate_of[leader.name]}"
        return text + (f" + {offset!r}" if offset > 0 else f" - {-offset!r}" if offset < 0 else "")

    def friction(self, joint: _Joint, coordinate: str) -> list[Friction]:
        if not (joint.damping or joint.friction):
            return []
        viscous = coulomb = None
        if joint.damping:
            viscous = self.identifier(joint.name, "fv_", f"viscous friction of {joint.name!r}")
            unit = "N*s/m" if joint.type == "prismatic" else "N*m*s/rad"
            self.extra_parameters.append(Parameter(viscous, joint.damping, unit, f"<joint {joint.name!r}> <dynamics damping>"))
        if joint.friction:
            coulomb = self.identifier(joint.name, "fc_", f"Coulomb friction of {joint.name!r}")
            unit = "N" if joint.type == "prismatic" else "N*m"
            self.extra_parameters.append(Parameter(coulomb, joint.friction, unit, f"<joint {joint.name!r}> <dynamics friction>"))
        return [Friction(coordinate, viscous=viscous, coulomb=coulomb)]

    def bodies(self, root: str, placement: dict[str, Placement]) -> tuple[list[Parameter], list[Body]]:
        parameters: list[Parameter] = []
        bodies: list[Body] = []
        body_names: set[str] = set()
        merged: dict[str, int] = {}  # frame -> links with an inertial on it
        for link, where in placement.items():
            if where.frame == BASE:
                continue  # carried by the fixed base: no effect on the dynamics
            inertial = self.links[link].find("inertial")
            if inertial is None:
                continue
            key = f"<link {link!r}> <inertial>"
            mass = self.number(inertial.find("mass"), "value", f"{key} <mass>")
            if mass is None:
                raise self.fail(f"{key} <mass>", "missing <mass value=\"...\"/>")
            if mass < 0:
                raise self.fail(f"{key} <mass> value", f"mass must be non-negative, got {mass:g}")
            origin = inertial.find("origin")
            xyz = np.array(self.numbers(origin, "xyz", f"{key} <origin>", 3, (0.0, 0.0, 0.0)))
            rpy = tuple(snap(a)[0] for a in self.numbers(origin, "rpy", f"{key} <origin>", 3, (0.0, 0.0, 0.0)))
            tag = inertial.find("inertia")
            entries = {k: self.number(tag, f"i{k}", f"{key} <inertia>", 0.0) for k in ("xx", "yy", "zz", "xy", "xz", "yz")}
            tensor = np.array([[entries["xx"], entries["xy"], entries["xz"]],
                               [entries["xy"], entries["yy"], entries["yz"]],
                               [entries["xz"], entries["yz"], entries["zz"]]])
            eigenvalues = np.linalg.eigvalsh(tensor)
            if eigenvalues.min() < -1e-12 * max(1.0, float(np.abs(tensor).max())):
                raise self.fail(f"{key} <inertia>", f"inertia tensor is not positive semidefinite (eigenvalues "
                                                    f"{eigenvalues.round(12).tolist()})")
            if mass == 0 and not tensor.any():
                continue
            merged[where.frame] = merged.get(where.frame, 0) + 1
            if merged[where.frame] > MAX_MERGED:
                raise self.fail(key, f"more than {MAX_MERGED} links with an <inertial> are merged through fixed joints "
                                     f"onto frame {where.frame!r}: each keeps its ten parameters and the derivation "
                                     "sums them symbolically, which past that number takes minutes or fails; the "
                                     "dynamics depend only on their total, so combine them in one <inertial>")
            R = where.R @ rpy_matrix(rpy)
            com = where.p + where.R @ xyz
            inertia = R @ tensor @ R.T
            inertia = (inertia + inertia.T) / 2  # symmetric to the last bit
            names = {k: self.identifier(link, f"{k}_", f"{k} of {link!r}") for k in
                     ("m", "cx", "cy", "cz", "xx", "yy", "zz", "xy", "xz", "yz")}
            values = {"m": mass, "cx": com[0], "cy": com[1], "cz": com[2], "xx": inertia[0, 0], "yy": inertia[1, 1],
                      "zz": inertia[2, 2], "xy": inertia[0, 1], "xz": inertia[0, 2], "yz": inertia[1, 2]}
            units = {"m": "kg", "cx": "m", "cy": "m", "cz": "m"}
            where_text = f"in the axes of frame {where.frame!r}" if link != where.frame else "in the link's axes"
            for k, name in names.items():
                value = float(values[k])
                value = 0.0 if abs(value) < TINY else value
                what = {"m": "mass", "cx": "centre of mass x", "cy": "centre of mass y", "cz": "centre of mass z"}.get(
                    k, f"inertia {k} about the centre of mass")
                parameters.append(Parameter(name, value, units.get(k, "kg*m^2"), f"{link}: {what} ({where_text})"))
            body = re.sub(r"[^A-Za-z0-9_]", "_", link)
            while body in body_names:
                body += "_"
            body_names.add(body)
            bodies.append(Body(
                name=body,
                frame=where.frame,
                mass=names["m"],
                com=(names["cx"], names["cy"], names["cz"]),
                inertia={k: names[k] for k in ("xx", "yy", "zz", "xy", "xz", "yz")},
            ))
        return parameters + self.extra_parameters, bodies


def _listing(names) -> str:
    names = list(names)
    shown_names = ", ".join(repr(n) for n in names[:12])
    return shown_names + (f", … ({len(names)} in all)" if len(names) > 12 else "")
