"""Closed kinematic loops and how forces at constrained coordinates reach the actuated ones (Janot V.A, (8)–(12)).

A constrained (passive) coordinate q_p = f_c(q_a) is substituted into the DH rows before derivation
(:class:`~symbolic.derivation.kinematics.Kinematics`), so the derived model is already the closed-loop one.
Torques of the equivalent tree structure (constraints removed, :func:`equivalent_tree`) relate to the
closed-loop generalized forces by Janot (12):

    Γ_m = [I  Lᵀ] Γ_ar,   L = ∂q_p/∂q_a.

The same virtual-work argument maps a generalized force acting at a passive joint (its friction,
a spring in it) onto the active coordinates: Q_a += Lᵀ[:, p]·Q_p (:func:`map_to_generalized`); this
is how the passive-joint friction Γ_fc enters Janot (16)–(17).
"""

from __future__ import annotations

import dataclasses

import sympy as sp

from symbolic.description.robot import Robot, velocity_symbol
from symbolic.description.validation import validate


def constraint_jacobian(robot: Robot) -> sp.Matrix:
    """L = ∂q_p/∂q_a (passive coordinates in constraint order × active coordinates), Janot (12)."""
    active = robot.coordinate_symbols
    rows = [[sp.diff(c.expression, q) for q in active] for c in robot.constraints]
    return sp.Matrix(rows) if rows else sp.zeros(0, len(active))


def constrained_velocities(robot: Robot) -> dict[sp.Symbol, sp.Expr]:
    """q̇_p = L q̇_a for every constrained coordinate, keyed by its velocity symbol."""
    L = constraint_jacobian(robot)
    qd = sp.Matrix([velocity_symbol(c) for c in robot.coordinates])
    return {velocity_symbol(c.coordinate): sp.expand((L[i, :] * qd)[0, 0]) for i, c in enumerate(robot.constraints)}


def closed_loop_substitution(robot: Robot) -> dict[sp.Symbol, sp.Expr]:
    """Constrained positions and velocities in terms of the generalized ones (for expressions of both)."""
    return robot.constraint_substitution | constrained_velocities(robot)


def map_to_generalized(robot: Robot, coordinate: str, force: sp.Expr) -> dict[str, sp.Expr]:
    """{generalized coordinate: its share of a generalized force ``force`` acting at ``coordinate``}.

    At a generalized coordinate the force stays where it is; at a constrained one it is spread by
    the column Lᵀ[:, p] of Janot (12), with the constraint substituted into both.
    """
    names = [c.coordinate for c in robot.constraints]
    force = force.xreplace(closed_loop_substitution(robot))
    if coordinate not in names:
        return {coordinate: force}
    row = constraint_jacobian(robot)[names.index(coordinate), :].xreplace(robot.constraint_substitution)
    return {c: row[0, k] * force for k, c in enumerate(robot.coordinates) if row[0, k] != 0}


def equivalent_tree(robot: Robot) -> Robot:
    """Janot's equivalent tree structure: constraints removed, their coordinates appended in order.

    Its joint torques are the Γ_ar of (12).
    """
    return validate(dataclasses.replace(
        robot,
        validated=False,
        name=f"{robot.name}_tree",
        coordinates=robot.coordinates + robot.constrained_coordinates,
        constraints=(),
        description=f"equivalent tree structure of {robot.name}",
    ))


def passive_state(robot: Robot, q, qd, qdd) -> tuple[list[float], list[float], list[float]]:
    """Passive positions, velocities and accelerations consistent with the constraints (numbers).

    q_p = f_c(q_a), q̇_p = L q̇_a, q̈_p = L q̈_a + L̇ q̇_a.
    """
    active = robot.coordinate_symbols
    values = dict(zip(active, q)) | robot.parameter_values
    L = constraint_jacobian(robot)
    qp = [float(c.expression.xreplace(values)) for c in robot.constraints]
    Ln = sp.matrix2numpy(L.xreplace(values), dtype=float)
    Ldot = sum(
        (sp.matrix2numpy(sp.diff(L, x).xreplace(values), dtype=float) * v for x, v in zip(active, qd)),
        start=0 * Ln,
    )
    return qp, list(Ln @ qd), list(Ln @ qdd + Ldot @ qd)


__all__ = ["closed_loop_substitution", "constrained_velocities", "constraint_jacobian",
           "equivalent_tree", "map_to_generalized", "passive_state"]
