"""Write a model as an MJCF file (docs/model-format.md, "MJCF export"), for MuJoCo.

The values are the model's parameters (nominal, or identified ones passed as ``values``). Each frame becomes a
``<body>`` nested in its parent's, placed at the frame's pose at Q = 0 (``pos``, ``quat``), with one
``<inertial>`` combining the bodies it carries (total mass, centre of mass, full inertia about it in the
frame's axes, Huygens–Steiner, as the URDF exporter combines them) and the joint of the coordinate that moves it:

* a general frame (URDF joint): a ``hinge`` or ``slide`` about or along ±axis at the body's origin, its
  ``range`` the joint's ``limit`` on θ = ±q + offset as bounds of q (MuJoCo's qpos);
* a modified-DH frame ``Rx(α)·Tx(a)·Rz(θ)·Tz(d)``: placed at ``Rx(α)·Tx(a)·Rz(θ₀)·Tz(d₀)``, joint about or along
  ±z at its origin;
* a standard-DH frame ``Rz(θ)·Tz(d)·Tx(a)·Rx(α)``: placed at ``Rz(θ₀)·Tz(d₀)·Tx(a)·Rx(α)``, joint about or along
  the parent's ±z through the parent's origin, written in the body's axes (MJCF's joint ``pos`` and ``axis``), so
  one body per frame, as in the model.

The drive and friction of a coordinate go on its joint: ``armature`` = rotor inertia × ratio² (the term
:func:`symbolic.derivation.drives.rotor_inertia` adds to D), ``damping`` = viscous friction Fv (MuJoCo's passive
force −d·q̇), ``frictionloss`` = Coulomb friction Fc (MuJoCo's friction-loss constraint); every coordinate gets a
``<motor>`` with ``gear`` = the drive's ratio (1 without a ``[[drive]]``), so ``ctrl`` is the motor torque τ/ratio.
Gravity is ``<option gravity>``; ``<compiler angle="radian">`` keeps the numbers as the model has them.

What MJCF cannot hold is refused (:class:`~symbolic.errors.ExportError`, naming the file and the key): beams and
their modal coordinates, closed loops and coupled coordinates (``[[constraint]]``: MuJoCo's equality constraints
are soft and add degrees of freedom), Stribeck friction (``frictionloss`` is one level), a frame moved by several
coordinates or by another multiple than ±1 of one, a coordinate moving several frames, and a moving body whose
mass or inertia MuJoCo's compiler rejects. What leaves the rigid dynamics exact is left out with a
:class:`~symbolic.errors.ModelWarning` and an XML comment, as the URDF exporter does: friction offsets,
``[[force]]`` entries (time-varying ones among them); direction-dependent friction is written as the mean of its
two values. The text is a function of the model and the values only: elements and attributes in a fixed order,
every number ``repr``-exact (the shortest text that reads back as the same double), and every number computed
(placements, quaternions, combined inertias) with mpmath at :data:`DIGITS` digits and rounded once to a double, so
no processor's C library or BLAS can change a last digit (the generated code's rule, README "Generated code").
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import PurePath

import mpmath
import numpy as np
import sympy as sp

from symbolic.description.robot import BASE, TIME, Directional, Frame, Robot
from symbolic.description.validation import validate
from symbolic.errors import ExportError, ModelWarning, suggestion

DIGITS = 40
"""Decimal digits of the computation of every written number (each rounded once to the nearest double)."""

MJMINVAL = 1e-15
"""MuJoCo's ``mjMINVAL``: its compiler refuses a moving body whose mass or principal inertia is below it."""

TRANSLATION_ONLY_RADIUS = 1e-3
"""m: a point mass that only translates is written with the inertia m·r² of this radius on each axis (it does
not enter its dynamics, and MuJoCo refuses zero)."""


@dataclass(frozen=True)
class Placement:
    """A frame at Q = 0 in its parent's axes, and its joint in its own axes (``kind`` None: welded)."""

    rotation: np.ndarray
    position: np.ndarray
    kind: str | None = None
    coordinate: str = ""
    axis: np.ndarray | None = None
    anchor: np.ndarray | None = None
    limits: Mapping[str, float] | None = None
    """The coordinate's ``lower`` and ``upper`` (MuJoCo's joint range), when the joint declares both."""


def _number(x) -> str:
    """``repr`` of the nearest double: the shortest text that reads back exactly (0 for both zeros)."""
    x = float(x)
    return repr(x) if x != 0 else "0"


def _numbers(values) -> str:
    return " ".join(_number(x) for x in values)


def _matrix(rows) -> np.ndarray:
    """An array of mpmath numbers (object dtype: NumPy's arithmetic on them is Python's, no BLAS)."""
    return np.array([[mpmath.mpf(x) for x in row] for row in rows], dtype=object)


def _vector(values) -> np.ndarray:
    return np.array([mpmath.mpf(x) for x in values], dtype=object)


def _identity() -> np.ndarray:
    return _matrix([[1, 0, 0], [0, 1, 0], [0, 0, 1]])


def _mp(x: sp.Expr) -> mpmath.mpf:
    """An exact real SymPy number to :data:`DIGITS` digits (SymPy's own evaluation: cos(π/2) is 0 exactly)."""
    return mpmath.mpf(str(sp.N(x, DIGITS)))


def _cos_sin(angle: sp.Expr) -> tuple[mpmath.mpf, mpmath.mpf]:
    return _mp(sp.cos(angle)), _mp(sp.sin(angle))


def _rx(a: sp.Expr) -> np.ndarray:
    c, s = _cos_sin(a)
    return _matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: sp.Expr) -> np.ndarray:
    c, s = _cos_sin(a)
    return _matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: sp.Expr) -> np.ndarray:
    c, s = _cos_sin(a)
    return _matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _axis_rotation(u: np.ndarray, angle: sp.Expr) -> np.ndarray:
    """Rotation by ``angle`` about the unit axis ``u`` (Rodrigues: c·E + s·S(u) + (1 − c)·u·uᵀ)."""
    c, s = _cos_sin(angle)
    cross = _matrix([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return c * _identity() + s * cross + (1 - c) * np.outer(u, u)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / mpmath.sqrt(sum(x * x for x in v))


def _moments(inertia: np.ndarray) -> np.ndarray:
    """Principal moments, ascending (in doubles: they decide a refusal, they are not written)."""
    return np.sort(np.linalg.eigvalsh(inertia.astype(float)))


def quaternion(R: np.ndarray) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of rotation matrix ``R``, w ≥ 0 (Shepperd's method: the largest of the
    four squared components is taken by square root, the others from it, which keeps every digit)."""
    R = _matrix(R)
    trace = R[0, 0] + R[1, 1] + R[2, 2]
    candidates = [trace, R[0, 0], R[1, 1], R[2, 2]]
    k = max(range(4), key=lambda i: candidates[i])
    q = _vector([0, 0, 0, 0])
    if k == 0:
        s = 2 * mpmath.sqrt(1 + trace)
        q[:] = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    else:
        i, j, l = k - 1, k % 3, (k + 1) % 3
        s = 2 * mpmath.sqrt(1 + R[i, i] - R[j, j] - R[l, l])
        q[0] = (R[l, j] - R[j, l]) / s
        q[1 + i] = s / 4
        q[1 + j] = (R[j, i] + R[i, j]) / s
        q[1 + l] = (R[l, i] + R[i, l]) / s
    return -q if q[0] < 0 else q


def _combined(masses: list, coms: list[np.ndarray], tensors: list[np.ndarray]) -> tuple:
    """Total mass, centre of mass and inertia about it of rigidly joined bodies (Huygens–Steiner); one body's
    own numbers as they are."""
    if len(masses) == 1:
        return masses[0], coms[0], tensors[0]
    total = sum(masses)
    centre = sum(m * c for m, c in zip(masses, coms)) / total if total > 0 else _vector([0, 0, 0])
    inertia = _matrix([[0, 0, 0]] * 3)
    for m, c, tensor in zip(masses, coms, tensors):
        r = c - centre
        inertia = inertia + tensor + m * (sum(x * x for x in r) * _identity() - np.outer(r, r))
    return total, centre, inertia


def _coordinate_range(limits: Mapping[str, float] | None, sign: int, offset: mpmath.mpf) -> dict[str, mpmath.mpf]:
    """The joint's ``lower``/``upper`` (bounds of its variable θ = sign·q + offset) as bounds of the coordinate q,
    MuJoCo's qpos: q = sign·(θ − offset); empty without both."""
    if not limits or "lower" not in limits or "upper" not in limits:
        return {}
    ends = sorted(sign * (mpmath.mpf(limits[k]) - offset) for k in ("lower", "upper"))
    return {"lower": ends[0], "upper": ends[1]}


class _Writer:
    """One export: the robot, its parameter values, and what is left out (warned) or noted (comments only)."""

    def __init__(self, robot: Robot, values: Mapping[str, float] | None) -> None:
        self.robot = robot
        self.values = {p.symbol: sp.Rational(float(values.get(p.name, p.value) if values else p.value))
                       for p in robot.parameters}
        self.dropped: list[str] = []
        self.notes: list[str] = []

    # -- values ----------------------------------------------------------------------------------
    def fail(self, key: str, problem: str) -> ExportError:
        """The one-line error for ``key``: file, key, what MJCF cannot hold."""
        return ExportError(f"{self.robot.source}: {key}: cannot be written as MJCF: {problem}")

    def exact(self, expr: sp.Expr | str | float, key: str) -> sp.Expr:
        """``expr`` at the parameter values (each the exact binary value of its double), kept exact; an error naming
        ``key`` if that is not a finite real number."""
        x = sp.sympify(expr).xreplace(self.values)  # a validated robot's Expr, or a number
        x = x.xreplace({f: sp.Rational(f) for f in x.atoms(sp.Float)})  # a literal 1.5708 as its double, exactly
        if x.free_symbols:
            raise self.fail(key, f"{x} depends on {sorted(map(str, x.free_symbols))}")
        number = sp.N(x, DIGITS)
        if not (number.is_Number and number.is_finite):
            raise self.fail(key, f"{expr} is not a finite real number at the parameter values")
        return x

    def value(self, expr: sp.Expr | str | float, key: str) -> mpmath.mpf:
        """:meth:`exact` to :data:`DIGITS` digits."""
        return _mp(self.exact(expr, key))

    def motion(self, f: Frame, which: str) -> tuple[str, int, sp.Expr] | None:
        """(coordinate, sign, exact offset) of the frame's ``theta``/``d`` = ±q + offset, or None if constant."""
        key = f"[[frame]] {f.name!r} {which}"
        expr = sp.sympify(getattr(f, which))
        coordinates = [s for s in expr.free_symbols if s.name in self.robot.coordinates]
        if not coordinates:
            return None
        if len(coordinates) > 1:
            raise self.fail(key, f"moved by several coordinates ({expr}); an MJCF joint is one degree of freedom")
        (q,) = coordinates
        slope = sp.diff(expr, q)
        if slope not in (1, -1):
            raise self.fail(key, f"{expr} is not ±{q} + a constant (MJCF joints have no gearing)")
        return q.name, int(slope), self.exact(expr - slope * q, key)

    # -- placements --------------------------------------------------------------------------------
    def placement(self, f: Frame) -> Placement:
        """Where a DH frame sits at Q = 0 and its joint (module docstring); general frames by :meth:`general`."""
        if f.joint is not None:
            return self.general(f)
        turning, sliding = self.motion(f, "theta"), self.motion(f, "d")
        if turning and sliding:
            raise self.fail(f"[[frame]] {f.name!r}", "both θ and d move (a cylindrical joint: two MJCF joints would "
                                                     "need two bodies)")
        key = f"[[frame]] {f.name!r}"
        theta = turning[2] if turning else self.exact(f.theta, f"{key} theta")
        d = _mp(sliding[2]) if sliding else self.value(f.d, f"{key} d")
        a, alpha = self.value(f.a, f"{key} a"), self.exact(f.alpha, f"{key} alpha")
        moving = turning or sliding
        kind = None if moving is None else ("hinge" if turning else "slide")
        z = _vector([0, 0, 1])
        if self.robot.convention == "modified":
            R, p = _rx(alpha) @ _rz(theta), _vector([a, 0, 0]) + _rx(alpha) @ (d * z)
            axis, anchor = z, _vector([0, 0, 0])
        else:
            R = _rz(theta) @ _rx(alpha)
            p = d * z + _rz(theta) @ _vector([a, 0, 0])
            axis, anchor = R.T @ z, -(R.T @ p)  # the parent's z through its origin
        if moving is None:
            return Placement(R, p)
        return Placement(R, p, kind, moving[0], moving[1] * axis, anchor)

    def general(self, f: Frame) -> Placement:
        """A general frame: origin ``Trans(xyz)·Rot(rpy)`` with the joint's constant offset, joint about or along
        ±axis at the origin (:class:`~symbolic.description.robot.Joint`)."""
        j, key = f.joint, f"[[frame]] {f.name!r}"
        xyz = _vector([self.value(x, f"{key} origin.xyz") for x in j.xyz])
        r, p, y = (self.exact(x, f"{key} origin.rpy") for x in j.rpy)
        R = _rz(y) @ _ry(p) @ _rx(r)
        if j.type == "fixed":
            return Placement(R, xyz)
        axis = _unit(_vector([self.value(x, f"{key} joint.axis") for x in j.axis]))
        prismatic = j.type == "prismatic"
        coordinate, sign, offset = self.motion(f, "d" if prismatic else "theta")
        if offset != 0 and prismatic:
            xyz = xyz + R @ axis * _mp(offset)
        elif offset != 0:
            R = R @ _axis_rotation(axis, offset)
        limits = _coordinate_range(j.limits, sign, _mp(offset)) if j.type != "continuous" else None
        return Placement(R, xyz, "slide" if prismatic else "hinge", coordinate, sign * axis, _vector([0, 0, 0]), limits)

    # -- elements ----------------------------------------------------------------------------------
    def inertial(self, frame: str, moving: bool, rotates: bool = True) -> ET.Element | None:
        """The bodies of ``frame`` as one ``<inertial>``: total mass, centre of mass, inertia about it.

        A body that only translates (no hinge between it and the base) has dynamics without its inertia tensor;
        where MuJoCo would refuse the model's one (a point mass), m·r² about each axis (r =
        :data:`TRANSLATION_ONLY_RADIUS`) is written, noted in a comment.
        """
        bodies = [b for b in self.robot.bodies if b.frame == frame]
        if not bodies:
            return None
        key = f"[[body]] on frame {frame!r}"
        masses = [self.value(b.mass, key) for b in bodies]
        coms = [_vector([self.value(c, key) for c in b.com]) for b in bodies]
        tensors = [_matrix([[self.value(e, key) for e in row] for row in b.inertia_tensor.tolist()]) for b in bodies]
        total, centre, inertia = _combined(masses, coms, tensors)
        if moving and not rotates and total >= MJMINVAL and _moments(inertia)[0] < MJMINVAL:
            inertia = total * mpmath.mpf(TRANSLATION_ONLY_RADIUS) ** 2 * _identity()
            self.notes.append(f"{key}: only translates, so its inertia tensor does not enter the dynamics; MuJoCo "
                              f"needs a positive one: {_number(inertia[0, 0])} kg m^2 on each axis is written")
        self.check_inertia(key, total, inertia, moving)
        element = ET.Element("inertial")
        element.set("pos", _numbers(centre))
        element.set("mass", _number(total))
        element.set("fullinertia", _numbers(inertia[i, j] for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))))
        return element

    def check_inertia(self, key: str, mass: mpmath.mpf, inertia: np.ndarray, moving: bool) -> None:
        """What MuJoCo's compiler refuses: principal moments that break A + B ≥ C, and (on a body a joint moves)
        a mass or principal moment below mjMINVAL."""
        moments = _moments(inertia)
        if moments[0] + moments[1] < moments[2] - 1e-12 * max(moments[2], MJMINVAL):
            raise self.fail(key, f"principal inertias {_numbers(moments)} break A + B >= C (no rigid body has them; "
                                 "MuJoCo refuses them)")
        if moving and (mass < MJMINVAL or moments[0] < MJMINVAL):
            raise self.fail(key, f"mass {_number(mass)} and principal inertias {_numbers(moments)}: MuJoCo requires "
                                 f"a mass and principal inertias above {MJMINVAL} on a body a joint moves")

    def joint(self, place: Placement) -> ET.Element:
        """The ``<joint>`` of a moving frame, with its range, armature, damping and friction loss."""
        element = ET.Element("joint")
        element.set("name", place.coordinate)
        element.set("type", place.kind)
        element.set("pos", _numbers(place.anchor))
        element.set("axis", _numbers(place.axis))
        limits = place.limits or {}
        if "lower" in limits and "upper" in limits:
            element.set("limited", "true")
            element.set("range", _numbers((limits["lower"], limits["upper"])))
        for attribute, number in self.joint_dynamics(place.coordinate).items():
            element.set(attribute, _number(number))
        return element

    def joint_dynamics(self, coordinate: str) -> dict[str, mpmath.mpf]:
        """``armature`` from the drive, ``damping`` and ``frictionloss`` from the friction (those present, non-zero)."""
        out: dict[str, mpmath.mpf] = {}
        drive = next((d for d in self.robot.drives if d.coordinate == coordinate), None)
        if drive is not None:
            key = f"[[drive]] {coordinate!r}"
            out["armature"] = self.value(drive.rotor_inertia, key) * self.value(drive.ratio, key) ** 2
        friction = next((f for f in self.robot.frictions if f.coordinate == coordinate), None)
        if friction is not None:
            key = f"[[friction]] {coordinate!r}"
            if friction.stribeck is not None:
                raise self.fail(f"{key} stribeck", "MuJoCo's frictionloss is one level; a Coulomb level rising to a "
                                                   "static one at rest (Stribeck) has no MJCF form")
            for attribute, coefficient in (("damping", friction.viscous), ("frictionloss", friction.coulomb)):
                if coefficient is not None:
                    out[attribute] = self.coefficient(coefficient, key, attribute)
            if friction.offset is not None:
                self.dropped.append(f"{key}: the offset (a constant force; MJCF joints have none)")
        return {k: v for k, v in out.items() if v != 0}

    def coefficient(self, coefficient: sp.Expr | Directional, key: str, attribute: str) -> mpmath.mpf:
        """A friction coefficient's value; a direction-dependent one's mean, noted as left out."""
        if isinstance(coefficient, Directional):
            self.dropped.append(f"{key}: direction-dependent {attribute} (MJCF has one value; their mean is written)")
            return (self.value(coefficient.positive, key) + self.value(coefficient.negative, key)) / 2
        return self.value(coefficient, key)

    # -- the tree ----------------------------------------------------------------------------------
    def body(self, f: Frame, parent: ET.Element, rotates: bool = False) -> None:
        """``f`` as a ``<body>`` in ``parent``, then its child frames in it; ``rotates``: a hinge lies above."""
        place = self.placement(f)
        rotates = rotates or place.kind == "hinge"
        element = ET.SubElement(parent, "body")
        element.set("name", f.name)
        element.set("pos", _numbers(place.position))
        element.set("quat", _numbers(quaternion(place.rotation)))
        moving_alone = place.kind is not None and not self.carried(f)  # a joint moves it, no welded frame's mass
        inertial = self.inertial(f.name, moving=moving_alone, rotates=rotates)
        if inertial is not None:
            element.append(inertial)
        elif moving_alone:
            raise self.fail(f"[[frame]] {f.name!r}", f"no body: MuJoCo requires a mass and inertia above {MJMINVAL} on "
                                                     "a body a joint moves (or on a body welded to it)")
        if place.kind is not None:
            element.append(self.joint(place))
        for child in self.robot.frames:
            if child.parent == f.name:
                self.body(child, element, rotates)

    def carried(self, f: Frame) -> bool:
        """Whether a frame welded to ``f`` (no joint, recursively) carries a body: MuJoCo counts its mass with f's."""
        for child in self.robot.frames:
            if child.parent == f.name and self.placement(child).kind is None:
                if any(b.frame == child.name for b in self.robot.bodies) or self.carried(child):
                    return True
        return False

    def check(self) -> None:
        """Refuse what MJCF cannot hold; note what is left out."""
        r = self.robot
        if r.beams:
            raise self.fail(f"[[beam]] {r.beams[0].name!r}", "flexible links and their modal coordinates have no MJCF form")
        if r.constraints:
            raise self.fail(f"[[constraint]] {r.constraints[0].coordinate!r}",
                            "closed loops and coupled coordinates: MuJoCo's equality constraints are soft and add "
                            "degrees of freedom, so its dynamics would not be this model's")
        moved: dict[str, list[str]] = {}
        for f in r.frames:
            for s in sp.sympify(f.theta).free_symbols | sp.sympify(f.d).free_symbols:
                if s.name in r.coordinates:
                    moved.setdefault(s.name, []).append(f.name)
        for coordinate, frames in moved.items():
            if len(frames) > 1:
                raise self.fail(f"coordinate {coordinate!r}", f"moves frames {', '.join(map(repr, frames))}; an MJCF "
                                                              "joint moves one body (its subtree)")
        for force in r.forces:
            kind = "a time-varying" if sp.sympify(force.expression).has(TIME) else "an"
            self.dropped.append(f"[[force]] {force.name!r}: {kind} applied force (MJCF has no such term)")

    def write(self) -> str:
        """The document: compiler and option, the body tree under ``base``, a motor per coordinate."""
        self.check()
        r = self.robot
        root = ET.Element("mujoco")
        root.set("model", r.name)
        ET.SubElement(root, "compiler", {"angle": "radian"})
        ET.SubElement(root, "option", {"gravity": _numbers(self.value(g, "gravity") for g in r.gravity)})
        world = ET.SubElement(root, "worldbody")
        base = ET.SubElement(world, "body", {"name": BASE})
        inertial = self.inertial(BASE, moving=False)
        if inertial is not None:
            base.append(inertial)
        for f in r.frames:
            if f.parent == BASE:
                self.body(f, base)
        actuators = ET.SubElement(root, "actuator")
        for coordinate in r.coordinates:
            drive = next((d for d in r.drives if d.coordinate == coordinate), None)
            gear = 1 if drive is None else self.value(drive.ratio, f"[[drive]] {coordinate!r} ratio")
            ET.SubElement(actuators, "motor", {"name": coordinate, "joint": coordinate, "gear": _number(gear)})
        return self.text(root)

    def text(self, root: ET.Element) -> str:
        """The document's text, with the comments on what is left out (each also a ModelWarning) and noted."""
        r = self.robot
        comments = [f"written by symbolic export-mjcf from {PurePath(r.source).name}: inertials, armature, damping and "
                    "frictionloss are the model's parameter values"]
        comments += [f"not in this file: {d}" for d in self.dropped] + [f"note: {n}" for n in self.notes]
        for i, text in enumerate(comments):
            root.insert(i, ET.Comment(f" {text.replace('--', '- -')} "))  # "--" would end an XML comment
        for d in self.dropped:
            warnings.warn(f"{r.source}: MJCF export leaves out {d}", ModelWarning, stacklevel=4)
        ET.indent(root, space="  ")
        return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def mjcf(robot: Robot, values: Mapping[str, float] | None = None) -> str:
    """The MJCF text of ``robot`` with its parameter values (``values`` replaces some, by name).

    Parameters
    ----------
    robot
        A validated robot (``symbolic.load``, ``symbolic.robots.load``).
    values
        Parameter values by name (identified ones) replacing the nominal ones.

    Returns
    -------
    str
        The MJCF document (module docstring): bodies, joints, inertials, armature (rotor inertia × ratio², as
        :func:`symbolic.derivation.drives.rotor_inertia`), damping (Fv) and frictionloss (Fc) of Janot (15),
        one ``<motor>`` per coordinate with the drive's ratio as gear, gravity.

    Raises
    ------
    ExportError
        For what MJCF cannot hold (module docstring), naming the model file and entry; for unknown or non-finite
        ``values``.

    References
    ----------
    MuJoCo's XML reference (``body``, ``inertial`` ``fullinertia``, ``joint`` ``armature``/``damping``/
    ``frictionloss``/``range``, ``motor`` ``gear``, ``compiler`` ``angle``) and its computation chapter (armature
    added to the joint-space inertia, damping a passive force, friction loss a constraint); Janot, Gautier and
    Brunot (2019) (15) for the friction law f = Fv·q̇ + Fc·sign(q̇) + offset whose terms are written.
    """
    robot = validate(robot)  # expressions parsed by the safe parser, never sympify's evaluation of text
    names = [p.name for p in robot.parameters]
    unknown = sorted(set(values or {}) - set(names))
    if unknown:
        raise ExportError(f"{robot.source}: unknown parameter(s) {unknown}: values are given by the names of the model "
                          f"file's [parameters]{suggestion(unknown[0], names)}")
    infinite = sorted(name for name, value in (values or {}).items() if not math.isfinite(float(value)))
    if infinite:
        raise ExportError(f"{robot.source}: parameter value(s) not finite: {', '.join(infinite)}")
    with mpmath.workdps(DIGITS):
        return _Writer(robot, values).write()
