"""Applied generalized forces Q(Q, Q̇) of the [[force]] entries (docs/model-format.md, "Forces").

A [[force]] is exerted ON the system at its coordinate (a cable spring −k·(q − q₀), a damper
−d·q̇); it enters the equations of motion with a minus sign, τ = D q̈ + … + f − Q. Forces at a
constrained coordinate reach the generalized ones through Lᵀ (Janot (12)).
"""

from __future__ import annotations

import sympy as sp

from symbolic.derivation.transmission import map_to_generalized
from symbolic.description.robot import Robot


def applied_vector(robot: Robot) -> sp.Matrix:
    """Q over the generalized coordinates, summed over [[force]] entries."""
    names = robot.generalized_coordinates
    Q = sp.zeros(len(names), 1)
    for force in robot.forces:
        for coordinate, share in map_to_generalized(robot, force.coordinate, force.expression).items():
            Q[names.index(coordinate), 0] += share
    return Q
