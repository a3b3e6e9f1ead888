"""What a simulation and the data layer read of a robot description, as plain numbers and names (no SymPy).

A :class:`RobotNumbers` is taken from a validated :class:`~symbolic.description.robot.Robot` once
(:meth:`RobotNumbers.of`) and kept in the cache folder with the compiled closed loop
(:mod:`symbolic.simulation.simulator`, docs/simulation.md "The whole command"), so that a warm
``symbolic simulate`` neither parses the model file nor imports SymPy. It answers what
:func:`symbolic.data.load` and the simulation ask of a model — its name and file, its coordinates, their kinds
(hence units), its parameters' names and nominal values — and anything else (a drive signal's
``[[drive]] gain``, a controller gain that names parameters) from the description itself,
:meth:`RobotNumbers.robot`, read from the model file on first use.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import sympy as sp

    from symbolic.description.robot import Robot


@dataclass(frozen=True, eq=False)
class RobotNumbers:
    """A robot description's names and numbers (module docstring).

    Attributes
    ----------
    name, source
        The robot's name and model file (as :class:`~symbolic.description.robot.Robot` has them).
    generalized_coordinates, coordinates
        All the coordinates (frame coordinates, then modal ones) and the frame coordinates alone.
    beams
        The names of the beams (empty for a rigid model).
    kinds
        Each generalized coordinate's kind (:func:`symbolic.description.units.coordinate_kind`).
    parameter_names, parameter_values
        The parameters in model-file order and their nominal values.
    locator
        How to read the description again: ``(model file, root, tip)`` (:func:`symbolic.robots.resolve`).
    """

    name: str
    source: str
    generalized_coordinates: tuple[str, ...]
    coordinates: tuple[str, ...]
    beams: tuple[str, ...]
    kinds: Mapping[str, str]
    parameter_names: tuple[str, ...]
    parameter_values: tuple[float, ...]
    locator: tuple[str, str | None, str | None]
    _robot: list = field(default_factory=list, repr=False)
    """The description once read (not pickled: the live object of this process)."""

    @classmethod
    def of(cls, robot: Robot, locator: tuple[str, str | None, str | None]) -> RobotNumbers:
        """The names and numbers of ``robot``, read from the model file ``locator`` names."""
        from symbolic.description.units import coordinate_kind

        names = tuple(robot.generalized_coordinates)
        return cls(robot.name, str(robot.source), names, tuple(robot.coordinates), tuple(b.name for b in robot.beams),
                   {c: coordinate_kind(robot, c) for c in names}, tuple(p.name for p in robot.parameters),
                   tuple(float(v) for v in robot.parameter_vector.values), locator, [robot])

    def __reduce__(self) -> tuple:
        return _numbers, (self.name, self.source, self.generalized_coordinates, self.coordinates, self.beams,
                          dict(self.kinds), self.parameter_names, self.parameter_values, self.locator)

    def robot(self) -> Robot:
        """The validated robot itself (read from :attr:`locator` on first use: SymPy is imported then)."""
        if not self._robot:
            from symbolic import robots

            self._robot.append(robots.resolve(*self.locator))
        return self._robot[0]

    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        """The description's parameter symbols (:meth:`robot`)."""
        return self.robot().parameter_symbols


def _numbers(*fields: object) -> RobotNumbers:
    return RobotNumbers(*fields)  # type: ignore[arg-type]
