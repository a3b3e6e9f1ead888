"""symbolic — symbolic dynamic models of rigid and flexible robots and haptic devices.

>>> import symbolic
>>> robot = symbolic.robots.load("fivebar")          # or symbolic.load("model.toml")
>>> model = symbolic.derive(robot)
>>> model.D.shape
(3, 3)
"""

from __future__ import annotations

import logging

from symbolic import emit, numeric, spec
from symbolic.derive import analysis
from symbolic.derive.dynamics import DynamicModel, derive
from symbolic.errors import ModelError, ModelWarning
from symbolic.numeric import NumericModel, numeric_model
from symbolic.spec import robots
from symbolic.spec.modelfile import load, loads
from symbolic.spec.robot import Beam, Body, Constraint, EndEffector, Frame, Parameter, Robot
from symbolic.spec.validation import validate
from symbolic.version import __version__

export = emit  # the name earlier callers use: symbolic.export.generate(model, "out/")

logging.getLogger(__name__).addHandler(logging.NullHandler())

__all__ = [
    "Beam",
    "Body",
    "Constraint",
    "DynamicModel",
    "NumericModel",
    "EndEffector",
    "Frame",
    "ModelError",
    "ModelWarning",
    "Parameter",
    "Robot",
    "analysis",
    "derive",
    "emit",
    "export",
    "load",
    "loads",
    "numeric",
    "numeric_model",
    "robots",
    "spec",
    "validate",
]
