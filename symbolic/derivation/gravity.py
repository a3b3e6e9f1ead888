"""Gravitational potential energy V_g(Q) and the gravity vector g(Q) = ∂V_g/∂Qᵀ (Madill 3.8.1, 3.9.1).

V_g = −Σ_b m_b g₀ᵀ (R_b c_b + d_b), with g₀ the gravity vector in the base frame and R_b c_b + d_b the
body's centre of mass (3.43). g(Q) itself is computed by :func:`gravity_forces`, the static case of
the Newton–Euler pass reduced to first moments of mass; the tests check g = ∂V/∂Q and compare it with
Pinocchio's computeGeneralizedGravity.
"""

from __future__ import annotations

import sympy as sp

from symbolic.derivation.inertia import entrywise_sum
from symbolic.derivation.kinematics import ZERO3, Kinematics, cross
from symbolic.description.robot import BASE


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


def gravity_forces(kin: Kinematics) -> sp.Matrix:
    """g(Q) = ∂V_g/∂Qᵀ of the rigid bodies, by first moments of mass.

    With Q̇ = Q̈ = 0 the Newton–Euler wrench that frame j must transmit to hold everything it carries
    is f_j = −M_j g_j, n_j = −μ_j × g_j, with g_j the gravity vector in frame j's axes (rotated outwards
    once per frame), M_j the carried mass and μ_j = Σ m_b (c_b − o_j) its first moment about the origin
    o_j (accumulated inwards: μ_parent += R (μ_j + M_j p_child), or R μ_j + M_j p_parent where the
    offset is constant in the parent). Each coordinate takes the projection of (n_j, f_j) on its joint
    twist, as in :func:`symbolic.derivation.newton_euler.inverse_dynamics`. Carrying three first-moment components
    instead of a six-component wrench makes the generated gravity about a third cheaper.
    """
    add = kin.sub.add
    g0 = sp.Matrix(kin.robot.gravity)
    gravity_in: dict[str, sp.Matrix] = {}
    for name, fk in kin.frames.items():
        outer = g0 if fk.parent == BASE else gravity_in[fk.parent]
        gravity_in[name] = fk.to_child(outer).applyfunc(add)

    masses: dict[str, list[sp.Expr]] = {name: [] for name in kin.frames}
    moments: dict[str, list[sp.Matrix]] = {name: [ZERO3] for name in kin.frames}
    for body in kin.robot.bodies:
        if body.frame != BASE:
            masses[body.frame].append(body.mass)
            moments[body.frame].append(body.mass * sp.Matrix(body.com))
    # each frame's sums formed once: a running sum re-sorts its terms at every step (quadratic in the bodies)
    mass = {name: sp.Add(*terms) for name, terms in masses.items()}
    moment = {name: entrywise_sum(terms) for name, terms in moments.items()}

    tau: dict[sp.Symbol, list[sp.Expr]] = {q: [] for q in kin.coordinates}
    for name in reversed(list(kin.frames)):
        fk = kin.frames[name]
        m, mu, g = add(mass[name]), moment[name].applyfunc(add), gravity_in[name]
        for q in fk.coordinates:
            w_unit, v_unit = fk.joint_twist(q)
            tau[q].append(-(w_unit.T * cross(mu, g) + m * (v_unit.T * g))[0])
        if fk.parent != BASE and m != 0:
            if fk.shift_in_child:
                carried = fk.to_parent((mu + m * fk.p_child).applyfunc(add))
            else:
                carried = fk.to_parent(mu) + m * fk.p_parent
            mass[fk.parent] += m
            moment[fk.parent] = moment[fk.parent] + carried.applyfunc(add)
    return sp.Matrix([add(sp.Add(*tau[q])) for q in kin.coordinates])
