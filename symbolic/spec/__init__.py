"""The spec layer: frozen, validated descriptions of robots, model files and the built-in robots.

Nothing here derives anything: :mod:`symbolic.derive` turns a :class:`Robot` into equations.
"""

from __future__ import annotations

from symbolic.spec import robots
from symbolic.spec.modelfile import load, loads
from symbolic.spec.robot import Beam, Body, Constraint, EndEffector, Frame, Parameter, Robot
from symbolic.spec.validation import validate

__all__ = ["Beam", "Body", "Constraint", "EndEffector", "Frame", "Parameter", "Robot", "load", "loads", "robots", "validate"]
