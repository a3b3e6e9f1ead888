"""symbolic — symbolic dynamic models of rigid and flexible robots and haptic devices.

>>> import symbolic
>>> robot = symbolic.robots.load("fivebar")          # or symbolic.load("model.toml")
>>> model = symbolic.derive(robot)
>>> model.D.shape
(3, 3)
"""

from __future__ import annotations

import logging

from symbolic import analysis, export, robots
from symbolic.dynamics import DynamicModel, derive
from symbolic.errors import ModelError, ModelWarning
from symbolic.modelfile import load, loads
from symbolic.spec import Beam, Body, Constraint, EndEffector, Frame, Parameter, Robot

__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())

__all__ = [
    "Beam",
    "Body",
    "Constraint",
    "DynamicModel",
    "EndEffector",
    "Frame",
    "ModelError",
    "ModelWarning",
    "Parameter",
    "Robot",
    "analysis",
    "derive",
    "export",
    "load",
    "loads",
    "robots",
]
