"""The description layer: frozen, validated descriptions of robots (:class:`Robot` and its entries), the safe
expression parser, TOML model files and URDF files (:mod:`symbolic.description.urdf`). The built-in robots' files are in :mod:`symbolic.robots`.

Nothing here derives anything: :mod:`symbolic.derivation` turns a :class:`Robot` into equations.

>>> from symbolic.description import loads
>>> robot = loads('''
... name = "pendulum"
... coordinates = ["q1"]
... gravity = ["0", "-9.81", "0"]
... [parameters]
... m = { value = 1.0, unit = "kg" }
... l = { value = 0.5, unit = "m" }
... [[frame]]
... name = "link"
... parent = "base"
... dh = { theta = "q1", d = "0", a = "l", alpha = "0" }
... [[body]]
... name = "bob"
... frame = "link"
... mass = "m"
... ''', "pendulum.toml")
>>> robot.generalized_coordinates, [p.name for p in robot.parameters]
(('q1',), ['m', 'l'])
>>> loads('colour = 1', "x.toml")                # one line: file, key, what is wrong, what is allowed
Traceback (most recent call last):
symbolic.errors.ModelError: x.toml: top level: unknown key(s) ['colour'] (allowed: beam, body, ...)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from symbolic import lazy

if TYPE_CHECKING:
    from symbolic.description.modelfile import load, loads  # noqa: F401
    from symbolic.description.parameters import ParameterVector  # noqa: F401
    from symbolic.description.robot import (  # noqa: F401
        Beam, Body, Constraint, Directional, Drive, EndEffector, Force, Frame, Friction, Joint, Parameter, Robot,
        Stribeck,
    )
    from symbolic.description.validation import validate  # noqa: F401

_LAZY: dict[str, tuple[str, str | None]] = {
    # name: module. Imported on first use (PEP 562): a module of this layer that needs no SymPy
    # (symbolic.description.reserved, numbers) is imported without the parser and SymPy behind it.
    "load": ("symbolic.description.modelfile", "load"),
    "loads": ("symbolic.description.modelfile", "loads"),
    "ParameterVector": ("symbolic.description.parameters", "ParameterVector"),
    "validate": ("symbolic.description.validation", "validate"),
    **{name: ("symbolic.description.robot", name) for name in (
        "Beam", "Body", "Constraint", "Directional", "Drive", "EndEffector", "Force", "Frame", "Friction", "Joint",
        "Parameter", "Robot", "Stribeck")},
}

__all__ = [
    "Beam", "Body", "Constraint", "Directional", "Drive", "EndEffector", "Force", "Frame", "Friction", "Joint",
    "Parameter", "ParameterVector", "Robot", "Stribeck", "load", "loads", "validate",
]


def __getattr__(name: str) -> object:
    """The names of :data:`__all__` and the submodules (``symbolic.description.robot``), imported on first use."""
    return lazy.attribute(__name__, _LAZY, globals(), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
