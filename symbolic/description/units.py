"""The SI units of a model's coordinates and generalized forces, from its frames, for figures and tables.

A coordinate is ``revolute`` when it enters a frame's DH θ (after the constraints are substituted): its
position is in rad and its generalized force is a torque in N·m. Another frame coordinate is
``prismatic`` (it enters a DH d): m and N. A beam's modal coordinate ν or η (docs/model-format.md,
``[[beam]]``: v(x) = Σ φᵢ(x)·νᵢ with ∫₀ˡ φᵢ² dx = 1, so φᵢ is in m^(−1/2)) is in m^(3/2), and the
force that does work on it in N·m^(−1/2). Velocities and accelerations follow (per s, per s²), and time is
in s: the data's contract (docs/data.md).

>>> import symbolic
>>> units = coordinate_units(symbolic.robots.load("emps"))
>>> units["q"].kind, units["q"].position, units["q"].velocity, units["q"].force
('prismatic', 'm', 'm/s', 'N')
>>> units["q"].label("velocity", "velocity of q")
'velocity of q (m/s)'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from symbolic.description.robot import Robot

TIME = "s"
"""The unit of the data's time stamps."""

_KINDS = {
    "revolute": ("rad", "N·m"),
    "prismatic": ("m", "N"),
    "modal": ("m^(3/2)", "N·m^(−1/2)"),
}


@dataclass(frozen=True)
class CoordinateUnits:
    """The units of one coordinate's signals; empty strings when unknown (a coordinate without a model).

    Attributes
    ----------
    kind
        ``"revolute"``, ``"prismatic"``, ``"modal"`` or ``""`` (unknown).
    position, velocity, acceleration
        The coordinate's units: rad, rad/s, rad/s² (revolute); m, m/s, m/s² (prismatic).
    force
        The generalized force's: N·m (revolute), N (prismatic).
    """

    kind: str = ""
    position: str = ""
    velocity: str = ""
    acceleration: str = ""
    force: str = ""

    @classmethod
    def of_kind(cls, kind: str) -> CoordinateUnits:
        """The units of a ``revolute``, ``prismatic`` or ``modal`` coordinate."""
        position, force = _KINDS[kind]
        return cls(kind, position, f"{position}/s", f"{position}/s²", force)

    def unit(self, signal: str) -> str:
        """The unit of ``signal``: position, velocity, acceleration, force, or time."""
        return TIME if signal == "time" else getattr(self, signal)

    def label(self, signal: str, text: str) -> str:
        """``text (unit)``, or ``text`` alone when the unit is unknown."""
        unit = self.unit(signal)
        return f"{text} ({unit})" if unit else text

    def compose(self, template: str) -> str:
        """A unit written from this coordinate's: ``{force}·s/{position}`` is N·m·s/rad for a revolute one
        (a viscous coefficient); ``""`` when a unit it needs is unknown."""
        if ("{" in template and not self.kind) or not template:
            return ""
        return template.format(position=self.position, force=self.force)


UNKNOWN = CoordinateUnits()
"""For a coordinate of no known model: the axes then name the quantity alone."""


def coordinate_kind(robot: Robot, coordinate: str) -> str:
    """``"revolute"`` (the coordinate enters a DH θ), ``"prismatic"`` (another frame coordinate) or
    ``"modal"`` (a beam's modal coordinate). Raises ``KeyError`` for a name the robot does not have.

    ``robot`` may also be a :class:`~symbolic.description.numbers.RobotNumbers`, which holds the kinds."""
    if coordinate not in robot.generalized_coordinates:
        raise KeyError(coordinate)
    kinds = getattr(robot, "kinds", None)  # RobotNumbers: taken from the description when it was read
    if kinds is not None:
        return kinds[coordinate]
    import sympy as sp

    from symbolic.description.robot import coordinate_symbol

    if coordinate not in robot.coordinates:
        return "modal"
    symbol = coordinate_symbol(coordinate)
    substitution = robot.constraint_substitution
    for frame in robot.frames:
        if symbol in sp.sympify(frame.theta).xreplace(substitution).free_symbols:
            return "revolute"
    return "prismatic"


def coordinate_units(robot: Robot) -> dict[str, CoordinateUnits]:
    """The units of every generalized coordinate of ``robot``, by name."""
    return {c: CoordinateUnits.of_kind(coordinate_kind(robot, c)) for c in robot.generalized_coordinates}


def units_for(units: Mapping[str, CoordinateUnits] | None, coordinate: str) -> CoordinateUnits:
    """``units[coordinate]``, or :data:`UNKNOWN` when no units or not this coordinate's are given."""
    return (units or {}).get(coordinate, UNKNOWN)
