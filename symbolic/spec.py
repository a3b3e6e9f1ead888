"""Immutable, validated descriptions of a robot (the spec layer).

A :class:`Robot` holds coordinates, parameters with nominal values, a tree of frames given by
Denavit–Hartenberg parameters, rigid bodies and point masses, closed-loop constraints and the
gravity vector. It is built either from a TOML model file (:mod:`symbolic.modelfile`) or directly
in Python; both routes validate on construction, so a ``Robot`` that exists is a usable one.

Expressions may be given as strings (parsed by :func:`symbolic.expressions.parse_expression`,
never evaluated), numbers, or SymPy expressions built by the caller.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from symbolic.errors import ModelError, ModelWarning
from symbolic.expressions import RESERVED_NAMES, parse_expression

IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
MODEL_NAME = re.compile(r"^[a-z][a-z0-9_]*$")
FRAME_NAME = re.compile(r"^[A-Za-z0-9_']+$")
CONVENTIONS = ("standard", "modified")
INERTIA_KEYS = ("xx", "yy", "zz", "xy", "xz", "yz")
DH_KEYS = ("theta", "d", "a", "alpha")
BASE = "base"

ExprLike = str | int | float | sp.Expr


def coordinate_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of generalized coordinate ``name``."""
    return sp.Symbol(name, real=True)


def velocity_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of the velocity of coordinate ``name`` (``<name>_dot``)."""
    return sp.Symbol(f"{name}_dot", real=True)


def acceleration_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of the acceleration of coordinate ``name`` (``<name>_ddot``)."""
    return sp.Symbol(f"{name}_ddot", real=True)


def parameter_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of parameter ``name``."""
    return sp.Symbol(name, real=True)


@dataclass(frozen=True)
class Parameter:
    """A model parameter: a symbol with a nominal value, unit and description."""

    name: str
    value: float
    unit: str = ""
    description: str = ""

    @property
    def symbol(self) -> sp.Symbol:
        return parameter_symbol(self.name)


@dataclass(frozen=True)
class Frame:
    """A frame placed relative to ``parent`` by Denavit–Hartenberg parameters.

    Standard convention: ``T = Rz(theta)·Tz(d)·Tx(a)·Rx(alpha)`` (Madill's A(θ,d,a,α), Table 3.1).
    Modified (Khalil–Kleinfinger / Craig): ``T = Rx(alpha)·Tx(a)·Rz(theta)·Tz(d)`` (Janot Table 1:
    alpha = α_j, a = d_j, theta = θ_j, d = r_j).
    """

    name: str
    parent: str
    theta: ExprLike = 0
    d: ExprLike = 0
    a: ExprLike = 0
    alpha: ExprLike = 0


@dataclass(frozen=True)
class Body:
    """A rigid body attached to a frame (a point mass when the inertia is omitted).

    ``com`` is the centre of mass in frame coordinates; ``inertia`` maps xx, yy, zz, xy, xz, yz to
    the entries of the inertia tensor about the centre of mass in frame axes (xy is the tensor's
    (x, y) entry, i.e. −∫xy dm).
    """

    name: str
    frame: str
    mass: ExprLike
    com: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, 0)
    inertia: Mapping[str, ExprLike] | None = None

    @property
    def inertia_tensor(self) -> sp.Matrix:
        """The 3×3 inertia tensor about the centre of mass, in frame axes (validated bodies only)."""
        i = self.inertia
        return sp.Matrix([[i["xx"], i["xy"], i["xz"]], [i["xy"], i["yy"], i["yz"]], [i["xz"], i["yz"], i["zz"]]])


@dataclass(frozen=True)
class Constraint:
    """A closed-loop constraint solved explicitly: ``coordinate = expression`` of the others.

    The constrained coordinate is not a generalized coordinate; it may appear in DH expressions
    and is substituted before derivation (Janot (8)–(11)).
    """

    coordinate: str
    expression: ExprLike


@dataclass(frozen=True)
class Beam:
    """An Euler–Bernoulli beam clamped to ``frame``, undeformed along its x axis (Madill 3.4).

    ``EI_v``/``EI_w`` are the bending stiffnesses for deflection along frame y (v) and z (w);
    ``modes_v``/``modes_w`` the numbers of assumed modes; ``tip_mass`` an optional point payload at
    x = length. Modal coordinates ``<name>_nu<i>`` and ``<name>_eta<i>`` are appended to the
    generalized coordinates.
    """

    name: str
    frame: str
    length: ExprLike
    density: ExprLike
    EI_v: ExprLike
    EI_w: ExprLike
    modes_v: int = 1
    modes_w: int = 1
    boundary: str = "clamped-free"
    tip_mass: ExprLike | None = None

    @property
    def nu(self) -> tuple[str, ...]:
        return tuple(f"{self.name}_nu{i}" for i in range(1, self.modes_v + 1))

    @property
    def eta(self) -> tuple[str, ...]:
        return tuple(f"{self.name}_eta{i}" for i in range(1, self.modes_w + 1))


@dataclass(frozen=True)
class EndEffector:
    """A point fixed in a frame whose Jacobian J maps Q̇ to its velocity (Madill (3.57))."""

    frame: str
    point: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, 0)


@dataclass(frozen=True)
class Robot:
    """A validated, immutable robot description.

    After construction every expression field holds a SymPy expression in the symbols of
    :attr:`coordinates`, constrained coordinates and :attr:`parameters`; frames are ordered
    parents first.
    """

    name: str
    coordinates: tuple[str, ...]
    parameters: tuple[Parameter, ...] = ()
    frames: tuple[Frame, ...] = ()
    bodies: tuple[Body, ...] = ()
    constraints: tuple[Constraint, ...] = ()
    beams: tuple[Beam, ...] = ()
    gravity: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, "-9.81")
    convention: str = "standard"
    description: str = ""
    end_effector: EndEffector | None = None
    source: str = field(default="<python>", compare=False)
    keys: Mapping[str, str] = field(default_factory=dict, compare=False, repr=False)
    """Optional map from an internal location to the file's own key spelling (for messages)."""

    def __post_init__(self) -> None:
        _Validator(self).run()

    # -- symbols -------------------------------------------------------------------------
    @property
    def coordinate_symbols(self) -> tuple[sp.Symbol, ...]:
        """The rigid (frame) coordinates."""
        return tuple(coordinate_symbol(c) for c in self.coordinates)

    @property
    def generalized_coordinates(self) -> tuple[str, ...]:
        """Q: the coordinates, then every beam's modal coordinates ν, η (Madill (3.55))."""
        modal = tuple(name for b in self.beams for name in b.nu + b.eta)
        return tuple(self.coordinates) + modal

    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(p.symbol for p in self.parameters)

    @property
    def parameter_values(self) -> dict[sp.Symbol, float]:
        return {p.symbol: p.value for p in self.parameters}

    @property
    def constraint_substitution(self) -> dict[sp.Symbol, sp.Expr]:
        """Constrained coordinate -> its expression in the generalized coordinates."""
        return {coordinate_symbol(c.coordinate): c.expression for c in self.constraints}

    def frame(self, name: str) -> Frame:
        for f in self.frames:
            if f.name == name:
                return f
        raise KeyError(name)

    def tree(self) -> Robot:
        """The equivalent tree structure: constraints removed, their coordinates appended.

        This is Janot's "equivalent tree structure" whose joint torques Γ_ar enter (12).
        """
        return dataclasses.replace(
            self,
            name=f"{self.name}_tree",
            coordinates=self.coordinates + tuple(c.coordinate for c in self.constraints),
            constraints=(),
            description=f"equivalent tree structure of {self.name}",
        )

    def with_parameters(self, **values: float) -> Robot:
        """A copy with some nominal parameter values replaced."""
        unknown = set(values) - {p.name for p in self.parameters}
        if unknown:
            raise ModelError(self.source, "[parameters]", f"unknown parameter(s) {sorted(unknown)}")
        params = tuple(
            Parameter(p.name, float(values.get(p.name, p.value)), p.unit, p.description) for p in self.parameters
        )
        return dataclasses.replace(self, parameters=params)


class _Validator:
    """Check a :class:`Robot` and convert its expression fields to SymPy in place."""

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.source = robot.source

    def fail(self, key: str, problem: str) -> ModelError:
        return ModelError(self.source, self.robot.keys.get(key, key), problem)

    def set(self, obj: Any, name: str, value: Any) -> None:
        object.__setattr__(obj, name, value)

    def run(self) -> None:
        r = self.robot
        self.check_name()
        if r.convention not in CONVENTIONS:
            raise self.fail("convention", f"unknown DH convention {r.convention!r} (allowed: {', '.join(CONVENTIONS)})")
        self.set(r, "coordinates", tuple(r.coordinates))
        self.set(r, "parameters", tuple(r.parameters))
        self.check_names()
        self.symbols = {c: coordinate_symbol(c) for c in r.coordinates}
        self.symbols.update({c.coordinate: coordinate_symbol(c.coordinate) for c in r.constraints})
        self.symbols.update({p.name: p.symbol for p in r.parameters})
        self.values = {p.symbol: p.value for p in r.parameters}
        self.check_constraints()
        self.check_frames()
        self.check_bodies()
        self.check_beams()
        self.check_gravity()
        self.check_end_effector()
        self.check_coordinates_used()

    def expr(self, value: Any, key: str, allowed: Iterable[str] | None = None) -> sp.Expr:
        if isinstance(value, sp.Basic):
            expr = sp.sympify(value)  # already a SymPy object built by the caller, not user text
            unknown = {s.name for s in expr.free_symbols} - set(self.symbols)
            if unknown:
                raise self.fail(key, f"undeclared symbol(s) {sorted(unknown)}")
        else:
            expr = parse_expression(value, self.symbols, self.source, self.robot.keys.get(key, key))
        if allowed is not None:
            bad = {s.name for s in expr.free_symbols} - set(allowed)
            if bad:
                raise self.fail(key, f"may not depend on {sorted(bad)} (only on {', '.join(sorted(allowed)) or 'numbers'})")
        return expr

    def nominal(self, expr: sp.Expr, key: str) -> float:
        value = expr.xreplace(self.values)
        try:
            return float(value)
        except TypeError:
            raise self.fail(key, f"cannot evaluate {expr} at the nominal parameter values") from None

    def check_name(self) -> None:
        if not isinstance(self.robot.name, str) or not MODEL_NAME.match(self.robot.name):
            raise self.fail(
                "name", f"model name {self.robot.name!r} is not a lower-case identifier ([a-z][a-z0-9_]*)"
            )

    def check_names(self) -> None:
        r = self.robot
        if not r.coordinates:
            raise self.fail("coordinates", "at least one generalized coordinate is required")
        seen: dict[str, str] = {}
        names = [(c, "coordinates") for c in r.coordinates]
        names += [(c.coordinate, "[[constraint]] coordinate") for c in r.constraints]
        names += [(p.name, "[parameters]") for p in r.parameters]
        names += [(n, f"[[beam]] {b.name!r} modal coordinate") for b in r.beams for n in (b.nu + b.eta)
                  if isinstance(b.modes_v, int) and isinstance(b.modes_w, int)]
        for name, key in names:
            if not isinstance(name, str) or not IDENTIFIER.match(name):
                raise self.fail(key, f"{name!r} is not an identifier ([A-Za-z][A-Za-z0-9_]*)")
            if name in RESERVED_NAMES:
                raise self.fail(key, f"{name!r} is reserved (a function or constant name)")
            if name.endswith("_dot") or name.endswith("_ddot"):
                raise self.fail(key, f"{name!r}: names ending in _dot/_ddot are reserved for velocities")
            if name in seen:
                raise self.fail(key, f"{name!r} is declared twice (also in {seen[name]})")
            seen[name] = key
        for p in r.parameters:
            try:
                value = float(p.value)
            except (TypeError, ValueError):
                raise self.fail(f"[parameters] {p.name}", f"nominal value {p.value!r} is not a number") from None
            if not np.isfinite(value):
                raise self.fail(f"[parameters] {p.name}", f"nominal value {p.value!r} is not finite")

    def check_constraints(self) -> None:
        allowed = set(self.robot.coordinates) | {p.name for p in self.robot.parameters}
        out = []
        for c in self.robot.constraints:
            key = f"[[constraint]] {c.coordinate} expression"
            out.append(Constraint(c.coordinate, self.expr(c.expression, key, allowed)))
        self.set(self.robot, "constraints", tuple(out))

    def check_frames(self) -> None:
        r = self.robot
        names = [f.name for f in r.frames]
        coordinates = set(r.coordinates) | {c.coordinate for c in r.constraints}
        parameters = {p.name for p in r.parameters}
        converted = {}
        for f in r.frames:
            key = f"[[frame]] {f.name!r}"
            if not isinstance(f.name, str) or not FRAME_NAME.match(f.name):
                raise self.fail(key, "frame name must be letters, digits, _ or '")
            if f.name == BASE:
                raise self.fail(key, f"'{BASE}' is the root frame and cannot be redefined")
            if names.count(f.name) > 1:
                raise self.fail(key, "frame defined twice")
            if f.parent != BASE and f.parent not in names:
                raise self.fail(f"{key} parent", f"parent frame {f.parent!r} does not exist (frames: {BASE}, {', '.join(names)})")
            values = {}
            for k in DH_KEYS:
                allowed = coordinates | parameters if k in ("theta", "d") else parameters
                values[k] = self.expr(getattr(f, k), f"{key} dh.{k}", allowed)
            converted[f.name] = Frame(f.name, f.parent, **values)
        self.set(r, "frames", tuple(converted[n] for n in self.toposort(converted)))

    def toposort(self, frames: Mapping[str, Frame]) -> list[str]:
        order: list[str] = []
        placed = {BASE}
        pending = list(frames)
        while pending:
            ready = [n for n in pending if frames[n].parent in placed]
            if not ready:
                cycle = " -> ".join(pending)
                raise self.fail(f"[[frame]] {pending[0]!r} parent", f"frames form a cycle: {cycle}")
            for n in ready:
                order.append(n)
                placed.add(n)
            pending = [n for n in pending if n not in placed]
        return order

    def check_bodies(self) -> None:
        r = self.robot
        frames = {f.name for f in r.frames} | {BASE}
        parameters = {p.name for p in r.parameters}
        out, names = [], set()
        for b in r.bodies:
            key = f"[[body]] {b.name!r}"
            if b.name in names:
                raise self.fail(key, "body defined twice")
            names.add(b.name)
            if b.frame not in frames:
                raise self.fail(f"{key} frame", f"frame {b.frame!r} does not exist (frames: {', '.join(sorted(frames))})")
            mass = self.expr(b.mass, f"{key} mass", parameters)
            m = self.nominal(mass, f"{key} mass")
            if m < 0:
                raise self.fail(f"{key} mass", f"mass must be non-negative, nominal value is {m:g}")
            com = tuple(b.com)
            if len(com) != 3:
                raise self.fail(f"{key} com", f"centre of mass needs 3 entries, got {len(com)}")
            com = tuple(self.expr(c, f"{key} com[{i}]", parameters) for i, c in enumerate(com))
            inertia = dict(b.inertia) if b.inertia is not None else {k: 0 for k in INERTIA_KEYS}
            extra = set(inertia) - set(INERTIA_KEYS)
            if extra:
                raise self.fail(f"{key} inertia", f"unknown entries {sorted(extra)} (allowed: {', '.join(INERTIA_KEYS)})")
            inertia = {k: self.expr(inertia.get(k, 0), f"{key} inertia.{k}", parameters) for k in INERTIA_KEYS}
            self.check_inertia(inertia, f"{key} inertia")
            out.append(Body(b.name, b.frame, mass, com, inertia))
        self.set(r, "bodies", tuple(out))

    def check_beams(self) -> None:
        from symbolic.mode_shapes import BOUNDARIES

        r = self.robot
        frames = {f.name for f in r.frames} | {BASE}
        parameters = {p.name for p in r.parameters}
        out, names = [], set()
        for b in r.beams:
            key = f"[[beam]] {b.name!r}"
            if not isinstance(b.name, str) or not IDENTIFIER.match(b.name):
                raise self.fail(key, "beam name must be an identifier ([A-Za-z][A-Za-z0-9_]*)")
            if b.name in names:
                raise self.fail(key, "beam defined twice")
            names.add(b.name)
            if b.frame not in frames:
                raise self.fail(f"{key} frame", f"frame {b.frame!r} does not exist (frames: {', '.join(sorted(frames))})")
            for attr in ("modes_v", "modes_w"):
                n = getattr(b, attr)
                if isinstance(n, bool) or not isinstance(n, int) or n < 1:
                    raise self.fail(f"{key} {attr}", f"number of modes must be an integer >= 1, got {n!r}")
                if n > 6:
                    raise self.fail(f"{key} {attr}", f"at most 6 modes per direction are supported (the mode shapes lose precision beyond), got {n}")
            if b.boundary not in BOUNDARIES:
                raise self.fail(f"{key} boundary", f"boundary {b.boundary!r} is not supported (supported: {', '.join(BOUNDARIES)})")
            values = {}
            for attr in ("length", "density", "EI_v", "EI_w"):
                expr = self.expr(getattr(b, attr), f"{key} {attr}", parameters)
                if self.nominal(expr, f"{key} {attr}") <= 0:
                    raise self.fail(f"{key} {attr}", f"{attr} must be positive, nominal value is {self.nominal(expr, f'{key} {attr}'):g}")
                values[attr] = expr
            tip = None
            if b.tip_mass is not None:
                tip = self.expr(b.tip_mass, f"{key} tip_mass", parameters)
                if self.nominal(tip, f"{key} tip_mass") < 0:
                    raise self.fail(f"{key} tip_mass", "tip mass must be non-negative")
            out.append(Beam(b.name, b.frame, modes_v=b.modes_v, modes_w=b.modes_w, boundary=b.boundary, tip_mass=tip, **values))
        self.set(r, "beams", tuple(out))

    def check_inertia(self, inertia: Mapping[str, sp.Expr], key: str) -> None:
        v = {k: self.nominal(e, f"{key}.{k}") for k, e in inertia.items()}
        matrix = np.array([[v["xx"], v["xy"], v["xz"]], [v["xy"], v["yy"], v["yz"]], [v["xz"], v["yz"], v["zz"]]])
        eig = np.linalg.eigvalsh(matrix)
        tol = 1e-12 * max(1.0, float(np.abs(matrix).max()))
        if eig.min() < -tol:
            raise self.fail(
                key,
                f"inertia tensor is not positive semidefinite at the nominal values (eigenvalues {eig.round(12).tolist()})",
            )
        a, b, c = eig
        if a + b < c - tol:
            warnings.warn(
                f"{self.source}: {key}: principal moments {eig.round(12).tolist()} violate the triangle inequality "
                "(no physical body has them); accepted as given",
                ModelWarning,
                stacklevel=5,
            )

    def check_gravity(self) -> None:
        g = tuple(self.robot.gravity)
        if len(g) != 3:
            raise self.fail("gravity", f"gravity vector needs 3 entries, got {len(g)}")
        params = {p.name for p in self.robot.parameters}
        self.set(self.robot, "gravity", tuple(self.expr(x, f"gravity[{i}]", params) for i, x in enumerate(g)))

    def check_end_effector(self) -> None:
        ee = self.robot.end_effector
        if ee is None:
            return
        frames = {f.name for f in self.robot.frames} | {BASE}
        if ee.frame not in frames:
            raise self.fail("end_effector frame", f"frame {ee.frame!r} does not exist")
        params = {p.name for p in self.robot.parameters}
        point = tuple(self.expr(x, f"end_effector point[{i}]", params) for i, x in enumerate(ee.point))
        if len(point) != 3:
            raise self.fail("end_effector point", "point needs 3 entries")
        self.set(self.robot, "end_effector", EndEffector(ee.frame, point))

    def check_coordinates_used(self) -> None:
        r = self.robot
        subs = {coordinate_symbol(c.coordinate): c.expression for c in r.constraints}
        used: set[sp.Symbol] = set()
        for f in r.frames:
            for k in ("theta", "d"):
                used |= getattr(f, k).xreplace(subs).free_symbols
        for c in r.coordinates:
            if coordinate_symbol(c) not in used:
                raise self.fail(
                    "coordinates", f"coordinate {c!r} is not used by any frame (every coordinate must move a frame)"
                )
        for c in r.constraints:
            if not any(coordinate_symbol(c.coordinate) in getattr(f, k).free_symbols for f in r.frames for k in ("theta", "d")):
                raise self.fail(f"[[constraint]] {c.coordinate}", f"constrained coordinate {c.coordinate!r} is not used by any frame")
