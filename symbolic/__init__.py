"""symbolic — symbolic dynamic models of rigid and flexible robots and haptic devices.

>>> import symbolic
>>> robot = symbolic.robots.load("fivebar")          # or symbolic.load("model.toml")
>>> model = symbolic.derive(robot)
>>> model.D.shape
(3, 3)

The public API is :data:`__all__`, documented in docs/api.md.
"""

from __future__ import annotations

import logging

from symbolic import description, export, numeric, robots
from symbolic.derive import analysis
from symbolic.derive.dynamics import DynamicModel, derive
from symbolic.description.modelfile import load, loads
from symbolic.description.robot import Beam, Body, Constraint, EndEffector, Frame, Parameter, Robot
from symbolic.description.validation import validate
from symbolic.errors import (
    DataError, ExportError, IdentificationError, ModelError, ModelWarning, SimulationError, SymbolicError,
)
from symbolic.numeric import NumericModel, numeric_model
from symbolic.version import __version__

logging.getLogger(__name__).addHandler(logging.NullHandler())

__all__ = [
    "Beam",
    "Body",
    "Constraint",
    "DataError",
    "DynamicModel",
    "EndEffector",
    "ExportError",
    "Frame",
    "IdentificationError",
    "ModelError",
    "ModelWarning",
    "NumericModel",
    "Parameter",
    "Robot",
    "SimulationError",
    "SymbolicError",
    "__version__",
    "analysis",
    "derive",
    "description",
    "export",
    "load",
    "loads",
    "numeric",
    "numeric_model",
    "robots",
    "validate",
]
