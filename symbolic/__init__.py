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
from typing import TYPE_CHECKING

from symbolic.errors import (
    DataError, ExportError, IdentificationError, ModelError, ModelWarning, SimulationError, SymbolicError,
)
from symbolic import lazy
from symbolic.version import __version__

if TYPE_CHECKING:
    from symbolic import description, export, numeric, robots  # noqa: F401
    from symbolic.derivation import analysis  # noqa: F401
    from symbolic.derivation.dynamics import DynamicModel, derive  # noqa: F401
    from symbolic.description.modelfile import load, loads  # noqa: F401
    from symbolic.description.robot import Beam, Body, Constraint, EndEffector, Frame, Parameter, Robot  # noqa: F401
    from symbolic.description.validation import validate  # noqa: F401
    from symbolic.numeric import NumericModel, numeric_model  # noqa: F401

logging.getLogger(__name__).addHandler(logging.NullHandler())

_LAZY: dict[str, tuple[str, str | None]] = {
    # name: (module, attribute; None for the module itself). Imported on first use (PEP 562), so that
    # `symbolic --help` and the first line of any command do not wait for SymPy and NumPy.
    "analysis": ("symbolic.derivation.analysis", None),
    "DynamicModel": ("symbolic.derivation.dynamics", "DynamicModel"),
    "derive": ("symbolic.derivation.dynamics", "derive"),
    "load": ("symbolic.description.modelfile", "load"),
    "loads": ("symbolic.description.modelfile", "loads"),
    "validate": ("symbolic.description.validation", "validate"),
    "NumericModel": ("symbolic.numeric", "NumericModel"),
    "numeric_model": ("symbolic.numeric", "numeric_model"),
    **{name: ("symbolic.description.robot", name)
       for name in ("Beam", "Body", "Constraint", "EndEffector", "Frame", "Parameter", "Robot")},
}


def __getattr__(name: str) -> object:
    """The public names and the subpackages (``symbolic.robots``, ``symbolic.data``, ...), imported on first use."""
    return lazy.attribute(__name__, _LAZY, globals(), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


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
