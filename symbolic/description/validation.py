"""Validation of a :class:`~symbolic.description.robot.Robot`: :func:`validate` returns a new, frozen copy.

Every expression field of the copy is a SymPy expression in declared symbols (strings are parsed
by :func:`symbolic.description.expressions.parse_expression`, never evaluated), frames are ordered parents
first, and every refusal is a :class:`~symbolic.errors.ModelError` naming the file, the key and the
problem. The input is never modified.
"""

from __future__ import annotations

import dataclasses
import keyword
import re
import warnings
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import sympy as sp

from symbolic.errors import ModelError, ModelWarning, listing, shorten, shown, suggestion
from symbolic.description.expressions import (
    MAX_LENGTH, RESERVED_NAMES, check_magnitude, check_value, parse_expression, variable_names,
)
from symbolic.description.robot import (
    BASE, BOUNDARIES, C_KEYWORDS, CONVENTIONS, DH_KEYS, FRAME_NAME, IDENTIFIER, INERTIA_KEYS, JOINT_TYPES, LIMIT_KEYS,
    MODEL_NAME, TIME, TIME_NAME, Beam, Body, Constraint, Directional, Drive, EndEffector, Force, Frame, Friction, Joint,
    Robot, Stribeck,
    coordinate_symbol, velocity_name, velocity_symbol,
)


_STANDALONE_TIME = re.compile(rf"(?<![A-Za-z0-9_]){TIME_NAME}(?![A-Za-z0-9_])")
"""Time written as a name of its own (a cheap test before parsing for it: most expressions have none)."""

MAX_MODES = 6
"""Assumed modes per beam direction (:mod:`symbolic.derivation.mode_shapes` is accurate up to 6)."""


def _modes_ok(beam: Beam) -> bool:
    return all(isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= MAX_MODES for n in (beam.modes_v, beam.modes_w))


def validate(robot: Robot) -> Robot:
    """The validated copy of ``robot`` (``robot`` itself when it is already validated).

    Raises
    ------
    ModelError
        On the first problem found, naming the file, the key and what is allowed.
    """
    if robot.validated:
        return robot
    return _Validator(robot).run()


class _Validator:
    """Check a :class:`Robot` and build its validated copy field by field (the input stays as it was)."""

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.source = robot.source

    def fail(self, key: str, problem: str) -> ModelError:
        return ModelError(self.source, self.robot.keys.get(key, key), problem)

    def set(self, name: str, value: Any) -> None:
        self.robot = dataclasses.replace(self.robot, **{name: value})

    def run(self) -> Robot:
        r = self.robot
        self.check_name()
        if r.convention not in CONVENTIONS:
            raise self.fail("convention", f"unknown DH convention {shown(r.convention, 40)} (allowed: {', '.join(CONVENTIONS)})"
                                         f"{suggestion(r.convention, CONVENTIONS)}")
        self.set("coordinates", tuple(r.coordinates))
        self.set("parameters", tuple(r.parameters))
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
        self.check_frictions()
        self.check_drives()
        self.check_forces()
        return dataclasses.replace(self.robot, validated=True)

    def expr(self, value: Any, key: str, allowed: Iterable[str] | None = None) -> sp.Expr:
        if isinstance(value, sp.Basic):
            expr = sp.sympify(value)  # already a SymPy object built by the caller, not user text
            unknown = {s.name for s in expr.free_symbols} - set(self.symbols)
            if unknown:
                raise self.fail(key, f"undeclared symbol(s) {listing(sorted(map(str, unknown)))}")
            check_value(expr, self.source, self.robot.keys.get(key, key), shorten(str(expr)))
        else:
            if isinstance(value, str) and len(value) <= MAX_LENGTH and _STANDALONE_TIME.search(value) \
                    and TIME_NAME in variable_names(value):
                raise self.fail(key, f"time {TIME_NAME!r} is allowed only in [[force]] expressions, not here "
                                     "(coordinates, parameters, numbers and functions of them)")
            expr = parse_expression(value, self.symbols, self.source, self.robot.keys.get(key, key))
        if allowed is not None:
            bad = {s.name for s in expr.free_symbols if s.name not in allowed}
            if bad:
                raise self.fail(key, f"may not depend on {listing(sorted(bad))} (only on {listing(sorted(allowed)) or 'numbers'})")
        if expr.free_symbols <= self.values.keys():  # no set(...) copy per call: quadratic
            self.nominal(expr, key)  # constant at given parameters: finite and real, or refused here
        kinks = sorted((a for a in expr.atoms(sp.Abs, sp.sign) if not a.free_symbols <= self.values.keys()), key=str)
        if kinks:
            raise self.fail(key, f"{shorten(str(kinks[0]), 40)} depends on a coordinate; abs and sign are not differentiable at 0 "
                                 "and the equations of motion differentiate coordinate expressions twice (use them on parameters only)")
        return expr

    def nominal(self, expr: sp.Expr, key: str) -> float:
        """The value of ``expr`` at the nominal parameters; refused unless finite and real."""
        value = sp.N(expr.xreplace(self.values), 30)
        real, imag = value.as_real_imag()
        if value.has(sp.zoo, sp.nan, sp.oo, -sp.oo) or not (real.is_Number and imag.is_Number) or not real.is_finite:
            raise self.fail(key, f"{shorten(str(expr))} is not finite at the nominal parameter values")
        if abs(imag) > 1e-20 * max(1, abs(real)):
            raise self.fail(key, f"{shorten(str(expr))} is not real at the nominal parameter values (≈ {complex(value):.6g})")
        return float(real)

    def check_name(self) -> None:
        if not isinstance(self.robot.name, str) or not MODEL_NAME.match(self.robot.name):
            raise self.fail(
                "name", f"model name {shown(self.robot.name, 40)} is not a lower-case identifier ([a-z][a-z0-9_]*)"
            )
        if self.robot.name in C_KEYWORDS:
            raise self.fail("name", f"model name {shown(self.robot.name, 40)} is a C keyword (it prefixes the generated C names); choose another name")

    def check_names(self) -> None:
        r = self.robot
        if not r.coordinates:
            raise self.fail("coordinates", "at least one generalized coordinate is required")
        seen: dict[str, str] = {}
        names = [(c, "coordinates") for c in r.coordinates]
        names += [(c.coordinate, "[[constraint]] coordinate") for c in r.constraints]
        names += [(p.name, "[parameters]") for p in r.parameters]
        # beams with a bad number of modes are reported by check_beams; their names cannot be listed
        names += [(n, f"[[beam]] {b.name!r} modal coordinate") for b in r.beams if _modes_ok(b) for n in (b.nu + b.eta)]
        for name, key in names:
            if not isinstance(name, str) or not IDENTIFIER.match(name):
                raise self.fail(key, f"{shown(name, 40)} is not an identifier ([A-Za-z][A-Za-z0-9_]*)")
            if name in RESERVED_NAMES:
                raise self.fail(key, f"{shown(name, 40)} is reserved (a function or constant name)")
            if keyword.iskeyword(name):
                raise self.fail(key, f"{name!r} is a Python keyword, which expressions cannot use as a name; choose "
                                     f"another (e.g. {name + '_'!r})")
            if name == TIME_NAME:
                raise self.fail(key, f"{TIME_NAME!r} is reserved for time in [[force]] expressions; choose another name")
            if name.endswith("_dot") or name.endswith("_ddot"):
                raise self.fail(key, f"{shown(name, 40)}: names ending in _dot/_ddot are reserved for velocities")
            if name.startswith("qd_") or name.startswith("qdd_"):
                raise self.fail(key, f"{shown(name, 40)}: names starting with qd_/qdd_ are reserved for velocities and accelerations")
            if name in seen:
                raise self.fail(key, f"{shown(name, 40)} is declared twice (also in {seen[name]})")
            seen[name] = key
        for p in r.parameters:
            key = f"[parameters] {p.name}"
            if isinstance(p.value, int) and not isinstance(p.value, bool):
                check_magnitude(p.value, self.source, self.robot.keys.get(key, key))  # before float() overflows
            try:
                value = float(p.value)
            except (TypeError, ValueError):
                raise self.fail(key, f"nominal value {shown(p.value, 40)} is not a number") from None
            if not np.isfinite(value):
                raise self.fail(key, f"nominal value {shown(p.value, 40)} is not finite")
            check_magnitude(value, self.source, self.robot.keys.get(key, key))
            self.check_bounds(p, key, value)

    def check_bounds(self, p: Any, key: str, value: float) -> None:
        """``fixed`` is a boolean; ``min``/``max`` finite numbers, min < max, and the value between them."""
        if not isinstance(p.fixed, bool):
            raise self.fail(f"{key} fixed", f"expected true or false, got {shown(p.fixed, 40)}")
        bounds = {}
        for what, bound in (("min", p.minimum), ("max", p.maximum)):
            if bound is None:
                continue
            if isinstance(bound, bool) or not isinstance(bound, (int, float)) or not np.isfinite(float(bound)):
                raise self.fail(f"{key} {what}", f"must be a finite number, got {shown(bound, 40)}")
            check_magnitude(bound, self.source, self.robot.keys.get(f"{key} {what}", f"{key} {what}"))
            bounds[what] = float(bound)
        if bounds.get("min", -np.inf) >= bounds.get("max", np.inf):
            raise self.fail(key, f"min = {bounds['min']:g} is not below max = {bounds['max']:g} "
                                 "(to keep a value, write fixed = true)")
        if value < bounds.get("min", -np.inf) or value > bounds.get("max", np.inf):
            side = "below min" if value < bounds.get("min", -np.inf) else "above max"
            raise self.fail(key, f"value {value:g} is {side} = {bounds['min' if side == 'below min' else 'max']:g} "
                                 "(the value must lie within its bounds)")

    def check_constraints(self) -> None:
        allowed = set(self.robot.coordinates) | {p.name for p in self.robot.parameters}
        out = []
        for c in self.robot.constraints:
            key = f"[[constraint]] {c.coordinate} expression"
            out.append(Constraint(c.coordinate, self.expr(c.expression, key, allowed)))
        self.set("constraints", tuple(out))

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
            if f.parent == f.name:
                raise self.fail(f"{key} parent", f"frame {shown(f.name, 40)} is its own parent")
            if f.parent != BASE and f.parent not in names:
                raise self.fail(f"{key} parent", f"parent frame {shown(f.parent, 40)} does not exist (frames: {listing([BASE, *names])})")
            if f.joint is not None:
                converted[f.name] = self.joint_frame(f, key, coordinates, parameters)
                continue
            values = {}
            for k in DH_KEYS:
                allowed = coordinates | parameters if k in ("theta", "d") else parameters
                values[k] = self.expr(getattr(f, k), f"{key} dh.{k}", allowed)
            converted[f.name] = Frame(f.name, f.parent, **values)
        self.set("frames", tuple(converted[n] for n in self.toposort(converted)))

    def joint_frame(self, f: Frame, key: str, coordinates: set[str], parameters: set[str]) -> Frame:
        """A general frame (docs/model-format.md, "General frames"): origin, joint type, unit axis, limits.

        The axis is normalised (u/|u|, exact for numbers); the joint variable sits in ``theta`` (revolute,
        continuous) or ``d`` (prismatic), and every other DH entry must be 0.
        """
        j = f.joint
        if not isinstance(j, Joint):
            raise self.fail(f"{key} joint", f"expected a Joint, got {type(j).__name__}")
        if j.type not in JOINT_TYPES:
            raise self.fail(f"{key} joint.type", f"unknown joint type {shown(j.type, 40)} (allowed: {', '.join(JOINT_TYPES)})"
                                                 f"{suggestion(j.type, JOINT_TYPES)}")
        vectors = {}
        for name in ("xyz", "rpy", "axis"):
            where = f"{key} {'joint.axis' if name == 'axis' else 'origin.' + name}"
            value = tuple(getattr(j, name))
            if len(value) != 3:
                raise self.fail(where, f"needs 3 entries, got {len(value)}")
            vectors[name] = tuple(self.expr(x, f"{where}[{i}]", parameters) for i, x in enumerate(value))
        axis = sp.Matrix(vectors["axis"])
        length = self.nominal(sp.sqrt((axis.T * axis)[0]), f"{key} joint.axis")
        if j.type != "fixed" and not length > 1e-9:
            raise self.fail(f"{key} joint.axis", f"the axis of a {j.type} joint must not be zero (nominal length {length:g})")
        if j.type != "fixed":
            norm = sp.sqrt(sp.Add(*[x**2 for x in axis]))
            vectors["axis"] = tuple(x / norm for x in axis)
        moving = {"revolute": "theta", "continuous": "theta", "prismatic": "d"}.get(j.type)
        values = {}
        for k in DH_KEYS:
            allowed = coordinates | parameters if k == moving else set()
            what = "coordinate" if k == moving else f"dh.{k}"
            values[k] = self.expr(getattr(f, k), f"{key} {what}", allowed)
            if k != moving and values[k] != 0:
                raise self.fail(f"{key} {what}", f"a frame with a {j.type} joint has no {k} (it is given by origin and joint)")
        if moving is not None and not values[moving].free_symbols & {coordinate_symbol(c) for c in coordinates}:
            raise self.fail(f"{key} coordinate", f"a {j.type} joint needs a coordinate (e.g. coordinate = \"q1\")")
        limits = self.limits(j.limits, f"{key} joint")
        joint = Joint(j.type, vectors["axis"], vectors["xyz"], vectors["rpy"], limits)
        return Frame(f.name, f.parent, joint=joint, **values)

    def limits(self, limits: Any, key: str) -> dict[str, float]:
        """URDF limits: finite numbers among lower, upper, velocity, effort; lower <= upper."""
        if not isinstance(limits, Mapping):
            raise self.fail(f"{key} limits", f"expected a table of {', '.join(LIMIT_KEYS)}")
        extra = set(limits) - set(LIMIT_KEYS)
        if extra:
            raise self.fail(f"{key} limits", f"unknown entries {sorted(extra)} (allowed: {', '.join(LIMIT_KEYS)})"
                                             f"{suggestion(sorted(extra)[0], LIMIT_KEYS)}")
        out = {}
        for k in LIMIT_KEYS:
            if k in limits:
                v = limits[k]
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(float(v)):
                    raise self.fail(f"{key} {k}", f"must be a finite number, got {shown(v, 40)}")
                out[k] = float(v)
        if out.get("lower", -np.inf) > out.get("upper", np.inf):
            raise self.fail(f"{key} lower", f"lower = {out['lower']:g} is above upper = {out['upper']:g}")
        return out

    def toposort(self, frames: Mapping[str, Frame]) -> list[str]:
        order: list[str] = []
        placed = {BASE}
        pending = list(frames)
        while pending:
            ready = [n for n in pending if frames[n].parent in placed]
            if not ready:
                cycle = listing(pending, " -> ")
                raise self.fail(f"[[frame]] {shown(pending[0], 40)} parent", f"frames form a cycle: {cycle}")
            order.append(ready[0])  # one at a time: the file's order is kept wherever parents come first
            placed.add(ready[0])
            pending.remove(ready[0])
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
                raise self.fail(f"{key} frame", f"frame {shown(b.frame, 40)} does not exist (frames: {listing(sorted(frames))})")
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
                raise self.fail(f"{key} inertia", f"unknown entries {sorted(extra)} (allowed: {', '.join(INERTIA_KEYS)})"
                                                     f"{suggestion(sorted(extra)[0], INERTIA_KEYS)}")
            inertia = {k: self.expr(inertia.get(k, 0), f"{key} inertia.{k}", parameters) for k in INERTIA_KEYS}
            self.check_inertia(inertia, f"{key} inertia")
            out.append(Body(b.name, b.frame, mass, com, inertia))
        self.set("bodies", tuple(out))

    def check_beams(self) -> None:
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
                raise self.fail(f"{key} frame", f"frame {shown(b.frame, 40)} does not exist (frames: {listing(sorted(frames))})")
            for attr in ("modes_v", "modes_w"):
                n = getattr(b, attr)
                if isinstance(n, bool) or not isinstance(n, int) or n < 0:
                    raise self.fail(f"{key} {attr}", f"number of modes must be an integer >= 0, got {shown(n, 40)}")
                if n > MAX_MODES:
                    raise self.fail(f"{key} {attr}", f"at most {MAX_MODES} modes per direction are supported (the mode shapes lose precision beyond), got {n}")
            if b.modes_v + b.modes_w == 0:
                raise self.fail(f"{key} modes_v", "a beam needs at least one mode (modes_v + modes_w >= 1; 0 in one "
                                                  "direction for a beam that bends in one plane)")
            if b.boundary not in BOUNDARIES:
                raise self.fail(f"{key} boundary", f"boundary {shown(b.boundary, 40)} is not supported (supported: {', '.join(BOUNDARIES)})")
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
        self.set("beams", tuple(out))

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
        planar = abs(a) <= tol and abs(b) <= tol  # only the moment about one axis given: a planar model's body
        if a + b < c - tol and not planar:
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
        self.set("gravity", tuple(self.expr(x, f"gravity[{i}]", params) for i, x in enumerate(g)))

    def check_end_effector(self) -> None:
        ee = self.robot.end_effector
        if ee is None:
            return
        frames = {f.name for f in self.robot.frames} | {BASE}
        if ee.frame not in frames:
            raise self.fail("end_effector frame", f"frame {shown(ee.frame, 40)} does not exist")
        params = {p.name for p in self.robot.parameters}
        point = tuple(self.expr(x, f"end_effector point[{i}]", params) for i, x in enumerate(ee.point))
        if len(point) != 3:
            raise self.fail("end_effector point", "point needs 3 entries")
        self.set("end_effector", EndEffector(ee.frame, point))

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
                    "coordinates", f"coordinate {shown(c, 40)} is not used by any frame (every coordinate must move a frame)"
                )
        for c in r.constraints:
            if not any(coordinate_symbol(c.coordinate) in getattr(f, k).free_symbols for f in r.frames for k in ("theta", "d")):
                raise self.fail(f"[[constraint]] {c.coordinate}", f"constrained coordinate {shown(c.coordinate, 40)} is not used by any frame")

    # -- friction, drives and applied forces (docs/model-format.md) -------------------------
    def actuated_coordinates(self) -> dict[str, str]:
        """Coordinates a friction or force entry may act on -> what they are (for messages)."""
        r = self.robot
        kinds = {c: "coordinate" for c in r.generalized_coordinates}
        kinds.update({c.coordinate: "constrained coordinate" for c in r.constraints})
        return kinds

    def coordinate_of(self, entry: str, coordinate: Any, allowed: Mapping[str, str]) -> str:
        if not isinstance(coordinate, str) or coordinate not in allowed:
            raise self.fail(f"{entry} coordinate", f"unknown coordinate {shown(coordinate, 40)} (coordinates: {listing(allowed)})"
                                                      f"{suggestion(coordinate, allowed)}")
        return coordinate

    def coefficient(self, value: Any, key: str, minimum: float | None = 0.0, strict: bool = False) -> sp.Expr:
        """A parameter expression whose nominal value is >= minimum (> when strict)."""
        expr = self.expr(value, key, {p.name for p in self.robot.parameters})
        if minimum is not None:
            v = self.nominal(expr, key)
            if v < minimum or (strict and v == minimum):
                relation = ">" if strict else ">="
                raise self.fail(key, f"must be {relation} {minimum:g} at the nominal parameters, got {v:g}")
        return expr

    def directional(self, value: Any, key: str) -> sp.Expr | Directional | None:
        if value is None:
            return None
        if isinstance(value, Directional):
            return Directional(self.coefficient(value.positive, f"{key}.positive"), self.coefficient(value.negative, f"{key}.negative"))
        return self.coefficient(value, key)

    def check_frictions(self) -> None:
        allowed = self.actuated_coordinates()
        out, seen = [], set()
        for f in self.robot.frictions:
            entry = f"[[friction]] {f.coordinate!r}" if isinstance(f.coordinate, str) else "[[friction]]"
            c = self.coordinate_of(entry, f.coordinate, allowed)
            if c in seen:
                raise self.fail(f"{entry} coordinate", f"coordinate {c!r} has two [[friction]] tables (one per coordinate; combine them)")
            seen.add(c)
            stribeck = None
            if f.stribeck is not None:
                stribeck = Stribeck(
                    self.coefficient(f.stribeck.static, f"{entry} stribeck.static"),
                    self.coefficient(f.stribeck.velocity, f"{entry} stribeck.velocity", strict=True),
                )
            offset = None if f.offset is None else self.coefficient(f.offset, f"{entry} offset", minimum=None)
            out.append(Friction(c, self.directional(f.viscous, f"{entry} viscous"), self.directional(f.coulomb, f"{entry} coulomb"), offset, stribeck))
        self.set("frictions", tuple(out))

    def check_drives(self) -> None:
        allowed = {c: "coordinate" for c in self.robot.coordinates}
        out, seen = [], set()
        for d in self.robot.drives:
            entry = f"[[drive]] {d.coordinate!r}" if isinstance(d.coordinate, str) else "[[drive]]"
            c = self.coordinate_of(entry, d.coordinate, allowed)
            if c in seen:
                raise self.fail(f"{entry} coordinate", f"coordinate {c!r} has two [[drive]] tables")
            seen.add(c)
            ratio = self.coefficient(d.ratio, f"{entry} ratio", minimum=None)
            if self.nominal(ratio, f"{entry} ratio") == 0:
                raise self.fail(f"{entry} ratio", "transmission ratio must not be zero")
            inertia = self.coefficient(d.rotor_inertia, f"{entry} rotor_inertia")
            gain = None if d.gain is None else self.coefficient(d.gain, f"{entry} gain", minimum=None)
            if gain is not None and self.nominal(gain, f"{entry} gain") == 0:
                raise self.fail(f"{entry} gain", "drive gain must not be zero")
            out.append(Drive(c, ratio, inertia, gain))
        self.set("drives", tuple(out))

    def check_forces(self) -> None:
        allowed = self.actuated_coordinates()
        velocities = {velocity_name(c): velocity_symbol(c) for c in self.robot.generalized_coordinates}
        modal = {c: coordinate_symbol(c) for c in self.robot.generalized_coordinates}
        symbols = self.symbols | modal | velocities | {TIME_NAME: TIME}
        out, names = [], set()
        for f in self.robot.forces:
            entry = f"[[force]] {f.name!r}"
            if not isinstance(f.name, str) or not f.name.strip():
                raise self.fail("[[force]] name", "a force needs a non-empty name")
            if f.name in names:
                raise self.fail(entry, "force defined twice")
            names.add(f.name)
            c = self.coordinate_of(entry, f.coordinate, allowed)
            key = f"{entry} expression"
            if isinstance(f.expression, sp.Basic):
                expr = sp.sympify(f.expression)
                unknown = {x.name for x in expr.free_symbols} - {x.name for x in symbols.values()}
                if unknown:
                    raise self.fail(key, f"undeclared symbol(s) {listing(sorted(map(str, unknown)))}")
                check_value(expr, self.source, self.robot.keys.get(key, key), shorten(str(expr)))
            else:
                expr = parse_expression(f.expression, symbols, self.source, self.robot.keys.get(key, key))
            out.append(Force(f.name, c, expr))
        self.set("forces", tuple(out))


def with_parameters(robot: Robot, **values: float) -> Robot:
    """A validated copy of ``robot`` with some nominal parameter values replaced (by name)."""
    unknown = set(values) - {p.name for p in robot.parameters}
    if unknown:
        raise ModelError(robot.source, "[parameters]", f"unknown parameter(s) {sorted(unknown)}")
    params = tuple(dataclasses.replace(p, value=float(values[p.name])) if p.name in values else p for p in robot.parameters)
    return validate(dataclasses.replace(robot, parameters=params, validated=False))
