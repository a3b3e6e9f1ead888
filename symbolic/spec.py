"""Deprecated alias of :mod:`symbolic.description` (the description layer was called ``spec`` in 0.1).

``import symbolic.spec``, ``from symbolic.spec.robot import Robot`` and ``symbolic.spec.robots`` keep working
for one release, with a :class:`DeprecationWarning`; new code imports :mod:`symbolic.description`.
"""

from __future__ import annotations

import sys
import warnings

from symbolic import description as _description
from symbolic import robots
from symbolic.description import *  # noqa: F403 - the alias re-exports the description layer's API
from symbolic.description import __all__, expressions, modelfile, robot, validation  # noqa: F401

warnings.warn("symbolic.spec is deprecated: import symbolic.description (and symbolic.robots)", DeprecationWarning,
              stacklevel=2)
for _name, _module in {"expressions": expressions, "modelfile": modelfile, "robot": robot,
                       "validation": validation, "robots": robots}.items():
    sys.modules[f"{__name__}.{_name}"] = _module
del _description
