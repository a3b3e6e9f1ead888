"""The spec layer: frozen, validated descriptions of robots, model files and the built-in robots.

Nothing here derives anything: :mod:`symbolic.derive` turns a :class:`Robot` into equations.
"""

from __future__ import annotations

from symbolic.spec import robots
from symbolic.spec.modelfile import load, loads
from symbolic.spec.robot import (
    Beam, Body, Constraint, Directional, Drive, EndEffector, Force, Frame, Friction, Parameter, Robot, Stribeck,
)
from symbolic.spec.validation import validate

__all__ = [
    "Beam", "Body", "Constraint", "Directional", "Drive", "EndEffector", "Force", "Frame", "Friction", "Parameter", "Robot",
    "Stribeck", "load", "loads", "robots", "validate",
]
