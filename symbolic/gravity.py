"""Gravitational potential energy V_g(Q) and the gravity vector g(Q) = ∂V_g/∂Qᵀ (Madill 3.8.1, 3.9.1).

V_g = −Σ_b m_b g₀ᵀ (R_b c_b + d_b), with g₀ the gravity vector in the base frame and R_b c_b + d_b the
body's centre of mass (3.43). g(Q) itself is computed by the Newton–Euler pass with Q̇ = Q̈ = 0
(:func:`symbolic.newton_euler.inverse_dynamics`); the tests check g = ∂V/∂Q.
"""

from __future__ import annotations

import sympy as sp

from symbolic.kinematics import Kinematics


def potential_energy(kin: Kinematics) -> sp.Expr:
    """V_g(Q) in intermediates of ``kin.sub``."""
    g0 = sp.Matrix(kin.robot.gravity)
    terms = []
    for body in kin.robot.bodies:
        if body.mass == 0:
            continue
        com = kin.point_position(body.frame, sp.Matrix(body.com))
        terms.append(-body.mass * (g0.T * com)[0])
    return kin.sub.add(sp.Add(*terms))
