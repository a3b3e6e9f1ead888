"""The limits a model file declares for its generalized coordinates (``joint.limit``, a URDF's ``<limit>``).

A joint's limits bound its *variable*: the frame's θ (a rotation) or d (a translation). Where that variable is
θ = s·q + c of one coordinate q (s = ±1, c free of every coordinate: a sign flip, a zero offset), its
``lower``/``upper`` bound q over sorted(s·(lower − c), s·(upper − c)) and its ``velocity`` and ``effort`` carry
over unchanged (|s| = 1). A variable of any other form (two coordinates, a scale, a closed loop's expression)
declares nothing for its coordinates: a bound on it is not a box on them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sp

from symbolic.description.robot import Robot


@dataclass(frozen=True)
class CoordinateLimits:
    """The declared limits of one coordinate (``None``: not declared), and the kind of joint it moves."""

    kind: str
    lower: float | None = None
    upper: float | None = None
    velocity: float | None = None
    effort: float | None = None


def coordinate_limits(robot: Robot, values: Mapping[sp.Symbol, float] | None = None) -> dict[str, CoordinateLimits]:
    """Per coordinate a frame moves, the kind of its joint and its declared limits (module docstring; a DH frame
    declares none, and the first frame to move a coordinate is its joint); ``values``: the parameter values an
    offset may hold (default: the model file's)."""
    values = robot.parameter_values if values is None else values
    coordinates = {sp.Symbol(c, real=True): c for c in robot.generalized_coordinates}
    out: dict[str, CoordinateLimits] = {}
    for frame in robot.frames:
        joint = frame.joint
        if joint is not None and joint.type == "fixed":
            continue
        if joint is None:  # a DH frame: the kind of each coordinate it moves, no limits
            for kind, value in (("prismatic", frame.d), ("revolute", frame.theta)):
                for q in sorted(sp.sympify(value).free_symbols & coordinates.keys(), key=str):
                    out.setdefault(coordinates[q], CoordinateLimits(kind))
            continue
        kind = "prismatic" if joint.type == "prismatic" else "revolute"
        variable = sp.sympify(frame.d if kind == "prismatic" else frame.theta)
        affine = _unit_affine(variable, coordinates, values)
        if affine is None:  # not a box on its coordinates: their kind only
            for q in sorted(variable.free_symbols & coordinates.keys(), key=str):
                out.setdefault(coordinates[q], CoordinateLimits(kind))
            continue
        name, sign, offset = affine
        limits = joint.limits or {}
        lower = upper = None
        if "lower" in limits and "upper" in limits and joint.type != "continuous":
            lower, upper = sorted(sign * (float(limits[k]) - offset) for k in ("lower", "upper"))
        out.setdefault(name, CoordinateLimits(kind, lower, upper, _given(limits, "velocity"), _given(limits, "effort")))
    return out


def _given(limits: Mapping[str, float], key: str) -> float | None:
    return float(limits[key]) if key in limits else None


def _unit_affine(variable: sp.Expr, coordinates: Mapping[sp.Symbol, str], values: Mapping[sp.Symbol, float]
                 ) -> tuple[str, int, float] | None:
    """(coordinate, s, c) where ``variable`` = s·q + c with s = ±1 and c a number at ``values``; else ``None``."""
    moving = [s for s in variable.free_symbols if s in coordinates]
    if len(moving) != 1:
        return None
    (q,) = moving
    slope = sp.diff(variable, q)
    if slope not in (sp.Integer(1), sp.Integer(-1)):
        return None
    offset = sp.sympify((variable - slope * q).xreplace(dict(values)))
    if offset.free_symbols or not offset.is_real:
        return None
    return coordinates[q], int(slope), float(offset)
