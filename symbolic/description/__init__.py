"""The description layer: frozen, validated descriptions of robots (:class:`Robot` and its entries), the safe
expression parser and TOML model files. The built-in robots' files are in :mod:`symbolic.robots`.

Nothing here derives anything: :mod:`symbolic.derive` turns a :class:`Robot` into equations.
"""

from __future__ import annotations

from symbolic.description.modelfile import load, loads
from symbolic.description.robot import (
    Beam, Body, Constraint, Directional, Drive, EndEffector, Force, Frame, Friction, Parameter, Robot, Stribeck,
)
from symbolic.description.validation import validate

__all__ = [
    "Beam", "Body", "Constraint", "Directional", "Drive", "EndEffector", "Force", "Frame", "Friction", "Parameter", "Robot",
    "Stribeck", "load", "loads", "validate",
]
