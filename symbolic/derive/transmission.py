"""Closed kinematic loops solved explicitly (Janot V.A, equations (8)–(12)).

A constrained (passive) coordinate q_p = f_c(q_a) is substituted into the DH rows before
derivation, so the derived model is already the closed-loop one. Its torques relate to those of
the equivalent tree structure (constraints removed, :meth:`symbolic.spec.Robot.tree`) by
Janot (12): Γ_m = [I  Lᵀ] Γ_ar with L = ∂q_p/∂q_a.
"""

from __future__ import annotations

import sympy as sp

from symbolic.spec.robot import Robot


def constraint_jacobian(robot: Robot) -> sp.Matrix:
    """L = ∂q_p/∂q_a (passive coordinates in constraint order × active coordinates)."""
    active = robot.coordinate_symbols
    rows = [[sp.diff(c.expression, q) for q in active] for c in robot.constraints]
    return sp.Matrix(rows) if rows else sp.zeros(0, len(active))


def passive_state(robot: Robot, q, qd, qdd) -> tuple[list[float], list[float], list[float]]:
    """Passive positions, velocities and accelerations consistent with the constraints (numeric).

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


