"""Write a model as a URDF file (docs/model-format.md, "URDF export"), for Pinocchio, MoveIt and simulators.

The values are the model's parameters (nominal, or identified ones passed as ``values``): each frame becomes
a link whose ``<inertial>`` is the combination of the bodies it carries (total mass, centre of mass and
inertia about it, Huygens–Steiner, in the frame's axes, so ``rpy = 0``), and each frame's placement a joint:

* a general frame (URDF joint) as it is, origin and axis evaluated;
* a modified-DH frame ``Rx(α)·Tx(a)·Rz(θ)·Tz(d)`` as one joint with origin ``Rx(α)·Tx(a)·Rz(θ₀)·Tz(d₀)`` and
  axis ±z (θ = ±q + θ₀, or d = ±q + d₀ for a prismatic one);
* a standard-DH frame ``Rz(θ)·Tz(d)·Tx(a)·Rx(α)`` as a joint about ±z of the parent (origin Rz(θ₀), link
  ``<frame>_joint``) followed by a fixed joint ``Tz(d)·Tx(a)·Rx(α)`` to the frame's link (importers merge it);
* a constrained coordinate c = m·q + o as ``<mimic joint="q" multiplier="m" offset="o"/>``;
* ``[[friction]]`` viscous and Coulomb coefficients as ``<dynamics damping friction>``, joint limits as
  ``<limit>``.

What URDF cannot hold is refused (:class:`~symbolic.errors.ExportError`: beams, a frame moved by several
coordinates or by a multiple other than ±1 of one, a closed loop that is not a mimic) or, when the rigid
dynamics stay exact, left out with a warning and an XML comment saying so (rotor inertias, Stribeck,
direction-dependent friction and offsets, applied forces, a gravity other than URDF's implied (0, 0, −9.81)).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from xml.sax.saxutils import quoteattr

import numpy as np
import sympy as sp

from symbolic.description.urdf import axis_rotation
from symbolic.description.robot import BASE, Directional, Frame, Robot, coordinate_symbol
from symbolic.errors import ExportError, ModelWarning

UNLIMITED = 1e9
"""Written for the effort, velocity and position limits URDF requires of a prismatic joint the model gives none for."""


def _rpy(m: np.ndarray) -> tuple[float, float, float]:
    pitch = math.atan2(-m[2, 0], math.hypot(m[0, 0], m[1, 0]))
    if math.hypot(m[0, 0], m[1, 0]) < 1e-12:
        return math.atan2(-m[1, 2], m[1, 1]), pitch, 0.0
    return math.atan2(m[2, 1], m[2, 2]), pitch, math.atan2(m[1, 0], m[0, 0])


def _rx(a: float) -> np.ndarray:
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def _rz(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def _number(x: float) -> str:
    return repr(float(x)) if x != 0 else "0"


def _triple(v) -> str:
    return " ".join(_number(x) for x in v)


class _Writer:
    def __init__(self, robot: Robot, values: Mapping[str, float] | None) -> None:
        self.robot = robot
        self.values = {p.symbol: float(values.get(p.name, p.value)) if values else p.value for p in robot.parameters}
        self.constraint = robot.constraint_substitution
        self.lines: list[str] = []
        self.dropped: list[str] = []

    def fail(self, key: str, problem: str) -> ExportError:
        return ExportError(f"{self.robot.source}: {key}: cannot be written as URDF: {problem}")

    def value(self, expr, key: str) -> float:
        x = sp.sympify(sp.sympify(expr).xreplace(self.values))
        if x.free_symbols:
            raise self.fail(key, f"{x} depends on {sorted(map(str, x.free_symbols))}")
        return float(x)

    def motion(self, f: Frame, which: str) -> tuple[str, float, float] | None:
        """(joint coordinate, sign, offset) of the frame's ``theta``/``d`` = ±q + offset, or None if constant."""
        expr = sp.sympify(getattr(f, which))
        coordinates = [s for s in expr.free_symbols if s.name in self.robot.coordinates or s.name in self.robot.constrained_coordinates]
        if not coordinates:
            return None
        if len(coordinates) > 1:
            raise self.fail(f"[[frame]] {f.name!r} {which}", f"moved by several coordinates ({expr}); URDF joints have one")
        (q,) = coordinates
        slope = sp.diff(expr, q)
        if slope not in (1, -1):
            raise self.fail(f"[[frame]] {f.name!r} {which}", f"{expr} is not ±{q} + a constant")
        return q.name, int(slope), self.value(expr - slope * q, f"[[frame]] {f.name!r} {which}")

    # -- elements ------------------------------------------------------------------------------
    def joint(self, name: str, kind: str, parent: str, child: str, R: np.ndarray, p: np.ndarray,
              axis=None, limits: Mapping[str, float] | None = None, coordinate: str | None = None) -> None:
        out = self.lines
        out.append(f"  <joint name={quoteattr(name)} type={quoteattr(kind)}>")
        out.append(f"    <parent link={quoteattr(parent)}/>")
        out.append(f"    <child link={quoteattr(child)}/>")
        out.append(f"    <origin xyz=\"{_triple(p)}\" rpy=\"{_triple(_rpy(R))}\"/>")
        if kind != "fixed":
            out.append(f"    <axis xyz=\"{_triple(axis)}\"/>")
            limits = dict(limits or {})
            if kind == "revolute" and not {"lower", "upper"} <= set(limits):
                limits = {**{"lower": -UNLIMITED, "upper": UNLIMITED}, **limits}
            if kind in ("revolute", "prismatic") or limits:
                attributes = {"lower": -UNLIMITED, "upper": UNLIMITED, "effort": UNLIMITED, "velocity": UNLIMITED}
                attributes.update(limits)
                if kind == "continuous":
                    attributes = {k: v for k, v in attributes.items() if k in ("effort", "velocity")}
                out.append("    <limit " + " ".join(f"{k}=\"{_number(v)}\"" for k, v in attributes.items()) + "/>")
            self.dynamics(coordinate)
            self.mimic(coordinate, name)
        out.append("  </joint>")

    def dynamics(self, coordinate: str | None) -> None:
        friction = next((f for f in self.robot.frictions if f.coordinate == coordinate), None)
        if friction is None:
            return
        key = f"[[friction]] {coordinate!r}"
        parts = {}
        for attribute, coefficient in (("damping", friction.viscous), ("friction", friction.coulomb)):
            if isinstance(coefficient, Directional):
                self.dropped.append(f"{key}: direction-dependent {attribute} (URDF has one value; their mean is written)")
                parts[attribute] = (self.value(coefficient.positive, key) + self.value(coefficient.negative, key)) / 2
            elif coefficient is not None:
                parts[attribute] = self.value(coefficient, key)
        if friction.stribeck is not None:
            self.dropped.append(f"{key}: the Stribeck rise")
        if friction.offset is not None:
            self.dropped.append(f"{key}: the offset")
        if parts:
            self.lines.append("    <dynamics " + " ".join(f"{k}=\"{_number(v)}\"" for k, v in parts.items()) + "/>")

    def mimic(self, coordinate: str | None, joint: str) -> None:
        if coordinate not in self.robot.constrained_coordinates:
            return
        expr = self.constraint[coordinate_symbol(coordinate)]
        leaders = [s for s in expr.free_symbols if s.name in self.robot.coordinates]
        if len(leaders) != 1 or sp.diff(expr, leaders[0], 2) != 0:
            raise self.fail(f"[[constraint]] {coordinate}", f"{expr} is not a multiple of one coordinate plus a constant "
                                                            "(URDF's <mimic>); closed loops cannot be written")
        (leader,) = leaders
        multiplier = self.value(sp.diff(expr, leader), f"[[constraint]] {coordinate}")
        offset = self.value(expr.xreplace({leader: 0}), f"[[constraint]] {coordinate}")
        self.lines.append(f"    <mimic joint={quoteattr(leader.name)} multiplier=\"{_number(multiplier)}\" offset=\"{_number(offset)}\"/>")

    def inertial(self, frame: str) -> None:
        """The bodies of ``frame`` as one inertial: total mass, centre of mass, inertia about it (frame axes)."""
        bodies = [b for b in self.robot.bodies if b.frame == frame]
        self.lines.append(f"  <link name={quoteattr(frame)}>")
        if bodies:
            key = f"[[body]] on frame {frame!r}"
            masses = [self.value(b.mass, key) for b in bodies]
            coms = [np.array([self.value(c, key) for c in b.com]) for b in bodies]
            tensors = [np.array([[self.value(e, key) for e in row] for row in b.inertia_tensor.tolist()]) for b in bodies]
            total = sum(masses)
            centre = sum(m * c for m, c in zip(masses, coms)) / total if total > 0 else np.zeros(3)
            inertia = np.zeros((3, 3))
            for m, c, tensor in zip(masses, coms, tensors):
                r = c - centre
                inertia += tensor + m * (r @ r * np.eye(3) - np.outer(r, r))  # Huygens–Steiner
            self.lines += [
                "    <inertial>",
                f"      <origin xyz=\"{_triple(centre)}\" rpy=\"0 0 0\"/>",
                f"      <mass value=\"{_number(total)}\"/>",
                "      <inertia " + " ".join(f"i{k}=\"{_number(inertia[i, j])}\"" for k, (i, j) in
                                             (("xx", (0, 0)), ("xy", (0, 1)), ("xz", (0, 2)), ("yy", (1, 1)), ("yz", (1, 2)), ("zz", (2, 2)))) + "/>",
                "    </inertial>",
            ]
        self.lines.append("  </link>")

    # -- frames --------------------------------------------------------------------------------
    def frame(self, f: Frame) -> None:
        if f.joint is not None:
            self.general(f)
        elif self.robot.convention == "modified":
            self.modified(f)
        else:
            self.standard(f)

    def general(self, f: Frame) -> None:
        j, key = f.joint, f"[[frame]] {f.name!r}"
        xyz = np.array([self.value(x, f"{key} origin.xyz") for x in j.xyz])
        r, p, y = (self.value(x, f"{key} origin.rpy") for x in j.rpy)
        R = _rz(y) @ np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]]) @ _rx(r)
        axis = np.array([self.value(x, f"{key} joint.axis") for x in j.axis])
        self.inertial(f.name)
        if j.type == "fixed":
            self.joint(f"{f.name}_fixed", "fixed", f.parent, f.name, R, xyz)
            return
        which = "d" if j.type == "prismatic" else "theta"
        coordinate, sign, offset = self.motion(f, which)
        if offset:
            if j.type == "prismatic":
                xyz = xyz + R @ axis * offset
            else:
                R = R @ axis_rotation(axis, offset)
        self.joint(coordinate, j.type, f.parent, f.name, R, xyz, sign * axis, j.limits, coordinate)

    def dh_motion(self, f: Frame) -> tuple[str, str, int, float, float, float]:
        """(coordinate, type, sign, θ₀, d₀): which DH entry moves, and the constant parts."""
        key = f"[[frame]] {f.name!r}"
        turning, sliding = self.motion(f, "theta"), self.motion(f, "d")
        if turning and sliding:
            raise self.fail(key, "both θ and d move (a cylindrical joint: two URDF joints would be needed)")
        if not (turning or sliding):
            return "", "fixed", 1, self.value(f.theta, key), self.value(f.d, key)
        if turning:
            q, sign, theta0 = turning
            return q, "continuous", sign, theta0, self.value(f.d, key)
        q, sign, d0 = sliding
        return q, "prismatic", sign, self.value(f.theta, key), d0

    def modified(self, f: Frame) -> None:
        """Rx(α)·Tx(a)·Rz(θ)·Tz(d): one joint about or along ±z with origin Rx(α)·Tx(a)·Rz(θ₀)·Tz(d₀)."""
        key = f"[[frame]] {f.name!r}"
        a, alpha = self.value(f.a, key), self.value(f.alpha, key)
        q, kind, sign, theta0, d0 = self.dh_motion(f)
        R = _rx(alpha) @ _rz(theta0)
        p = np.array([a, 0.0, 0.0]) + _rx(alpha) @ np.array([0.0, 0.0, d0])
        self.inertial(f.name)
        if kind == "fixed":
            self.joint(f"{f.name}_fixed", "fixed", f.parent, f.name, R, p)
        else:
            self.joint(q, kind, f.parent, f.name, R, p, (0, 0, sign), None, q)

    def standard(self, f: Frame) -> None:
        """Rz(θ)·Tz(d)·Tx(a)·Rx(α): the joint about or along ±z of the parent, then a fixed joint for the rest."""
        key = f"[[frame]] {f.name!r}"
        a, alpha = self.value(f.a, key), self.value(f.alpha, key)
        q, kind, sign, theta0, d0 = self.dh_motion(f)
        moving = f"{f.name}_joint"
        self.lines.append(f"  <link name={quoteattr(moving)}/>")
        if kind == "fixed":
            self.joint(f"{moving}_fixed", "fixed", f.parent, moving, _rz(theta0), np.zeros(3))
        else:
            self.joint(q, kind, f.parent, moving, _rz(theta0), np.zeros(3), (0, 0, sign), None, q)
        self.inertial(f.name)
        self.joint(f"{f.name}_fixed", "fixed", moving, f.name, _rx(alpha), np.array([a, 0.0, d0]))

    def write(self) -> str:
        r = self.robot
        if r.beams:
            raise self.fail("[[beam]]", "flexible links have no URDF form")
        for d in r.drives:
            if self.value(d.rotor_inertia, f"[[drive]] {d.coordinate!r}") != 0:
                self.dropped.append(f"[[drive]] {d.coordinate!r}: the rotor inertia (URDF has none; Pinocchio's armature is not in URDF)")
        self.dropped += [f"[[force]] {f.name!r}" for f in r.forces]
        gravity = [self.value(g, "gravity") for g in r.gravity]
        if not np.allclose(gravity, [0, 0, -9.81], rtol=0, atol=1e-12):
            self.dropped.append(f"gravity = {gravity} (URDF readers assume (0, 0, -9.81))")
        body = self.lines
        body.append(f"  <link name={quoteattr(BASE)}/>")
        frames = [f for f in r.frames]
        inertial_on_base = [b for b in r.bodies if b.frame == BASE]
        if inertial_on_base:
            body.pop()
            self.inertial(BASE)
        for f in frames:
            self.frame(f)
        head = ['<?xml version="1.0"?>',
                f"<!-- written by symbolic export-urdf from {r.source.rsplit('/', 1)[-1]}: inertial values and "
                "friction are the model's parameter values -->"]
        head += [f"<!-- not in this file: {d} -->" for d in self.dropped]
        for d in self.dropped:
            warnings.warn(f"{r.source}: URDF export leaves out {d}", ModelWarning, stacklevel=3)
        return "\n".join(head + [f"<robot name={quoteattr(r.name)}>"] + body + ["</robot>", ""])


def urdf(robot: Robot, values: Mapping[str, float] | None = None) -> str:
    """The URDF text of ``robot`` with its parameter values (``values`` replaces some, by name).

    Raises
    ------
    ExportError
        For what URDF cannot hold (module docstring), naming the model entry.
    """
    unknown = set(values or {}) - {p.name for p in robot.parameters}
    if unknown:
        raise ExportError(f"{robot.source}: unknown parameter(s) {sorted(unknown)}")
    return _Writer(robot, values).write()
