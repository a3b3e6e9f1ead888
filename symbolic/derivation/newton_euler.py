"""Inverse dynamics τ = D Q̈ + (I⊗Q̇ᵀ)C Q̇ + g by a recursive Newton–Euler pass over the same frames.

This is the short route to code for τ (the Lagrangian quantities D, C, g stay available for
analysis); the test-suite checks that both routes agree. Velocities and accelerations are
propagated outwards in each frame's coordinates, wrenches inwards, and each coordinate's torque is
the projection of the wrench of every frame it moves on that frame's joint twist (virtual work),
which also covers frames whose DH entries combine several coordinates (Janot (8)–(11), Madill
Table 3.1).
"""

from __future__ import annotations

from collections.abc import Callable

import sympy as sp

from symbolic.derivation.inertia import entrywise_sum
from symbolic.derivation.kinematics import ZERO3, Kinematics, cross
from symbolic.description.robot import BASE


def _rate(rates: dict[sp.Symbol, sp.Expr], values: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
    return sp.Add(*[k * values[q] for q, k in rates.items()])


def inverse_dynamics(
    kin: Kinematics,
    qd: dict[sp.Symbol, sp.Expr],
    qdd: dict[sp.Symbol, sp.Expr],
    gravity: bool = True,
    frame_wrench: Callable | None = None,
) -> sp.Matrix:
    """Generalized forces for velocities ``qd`` and accelerations ``qdd`` (maps coordinate -> value).

    With ``qd = qdd = 0`` and ``gravity=True`` this is g(Q); with ``qdd = 0`` and
    ``gravity=False`` the Coriolis/centripetal vector. ``frame_wrench(frame, ω, ω̇, a, U, add)``
    replaces the bodies' wrench at each frame (the regressor passes the standard-parameter form).
    """
    sub = kin.sub
    add = sub.add
    state: dict[str, tuple[sp.Matrix, sp.Matrix, sp.Matrix]] = {}
    g0 = -sp.Matrix(kin.robot.gravity) if gravity else ZERO3
    base = (ZERO3, ZERO3, g0)  # ω, ω̇, a of the base: a = −gravity models gravity
    wrench: dict[str, tuple[sp.Matrix, sp.Matrix]] = {}
    tangent: dict[str, sp.Matrix] = {}
    bodies: dict[str, list] = {name: [] for name in kin.frames}
    for body in kin.robot.bodies:
        if body.frame != BASE:
            bodies[body.frame].append(body)

    for name, fk in kin.frames.items():
        w_p, dw_p, a_p = base if fk.parent == BASE else state[fk.parent]
        th_d = add(_rate(fk.theta_rate, qd))
        d_d = add(_rate(fk.d_rate, qd))
        th_dd = add(_rate(fk.theta_rate, qdd) + _second_order(sub, fk.theta_rate, qd))
        d_dd = add(_rate(fk.d_rate, qdd) + _second_order(sub, fk.d_rate, qd))
        (u_t, l_t), (u_d, l_d) = fk.theta_twist, fk.d_twist
        w_rel = u_t * th_d + u_d * d_d
        v_rel = l_t * th_d + l_d * d_d
        w_pc = fk.to_child(w_p).applyfunc(add)
        dw_pc = fk.to_child(dw_p).applyfunc(add)
        a_pc = _transported_acceleration(fk, w_p, w_pc, dw_p, dw_pc, a_p, tangent.get(fk.parent), add)
        w = (w_pc + w_rel).applyfunc(add)
        dw = (dw_pc + cross(w_pc, w_rel) + u_t * th_dd + u_d * d_dd).applyfunc(add)
        a = (a_pc + 2 * cross(w_pc, v_rel) + l_t * th_dd + l_d * d_dd + fk.theta_sq_accel * th_d**2).applyfunc(add)
        state[name] = (w, dw, a)
        tangent[name] = _tangent_operator(w, dw, add)
        if frame_wrench is None:
            wrench[name] = _bodies_wrench(bodies[name], w, dw, a, tangent[name], add)
        else:
            wrench[name] = frame_wrench(name, w, dw, a, tangent[name], add)

    tau = {q: [] for q in kin.coordinates}
    for name in reversed(list(kin.frames)):
        fk = kin.frames[name]
        n, f = (x.applyfunc(add) for x in wrench[name])
        for q in fk.coordinates:
            w_unit, v_unit = fk.joint_twist(q)
            tau[q].append((w_unit.T * n + v_unit.T * f)[0])
        if fk.parent != BASE and not (n.is_zero_matrix and f.is_zero_matrix):
            n_parent, f_parent = fk.force_to_parent(n, f, add)
            pn, pf = wrench[fk.parent]
            wrench[fk.parent] = (pn + n_parent, pf + f_parent)
    return sp.Matrix([sp.Add(*tau[q]) for q in kin.coordinates])


def _transported_acceleration(fk, w_p, w_pc, dw_p, dw_pc, a_p, tangent_p, add) -> sp.Matrix:
    """Rᵀ(a_p + ω̇_p × p + ω_p × (ω_p × p)): the parent's acceleration field at this origin.

    Evaluated in whichever frame the offset p is constant (see ``FrameKinematics.shift_in_child``);
    in the parent's frame the operator U_p = S(ω̇_p) + S(ω_p)² is shared with the parent's bodies.
    """
    if fk.shift_in_child:
        p = fk.p_child
        return (fk.to_child(a_p) + cross(dw_pc, p) + cross(w_pc, cross(w_pc, p).applyfunc(add))).applyfunc(add)
    p = fk.p_parent
    field = tangent_p * p if tangent_p is not None else cross(dw_p, p) + cross(w_p, cross(w_p, p))
    return fk.to_child((a_p + field).applyfunc(add)).applyfunc(add)


def _tangent_operator(w: sp.Matrix, dw: sp.Matrix, add) -> sp.Matrix:
    """U = S(ω̇) + S(ω)² = S(ω̇) + ωωᵀ − |ω|²E, so that ω̇ × x + ω × (ω × x) = U x (Khalil's U matrix).

    Entries are registered lazily by use: only those a body or child needs are counted in programs.
    """
    sq = [add(w[i] * w[i]) for i in range(3)]
    xy, xz, yz = add(w[0] * w[1]), add(w[0] * w[2]), add(w[1] * w[2])
    return sp.Matrix(
        [
            [-(sq[1] + sq[2]), xy - dw[2], xz + dw[1]],
            [xy + dw[2], -(sq[0] + sq[2]), yz - dw[0]],
            [xz - dw[1], yz + dw[0], -(sq[0] + sq[1])],
        ]
    ).applyfunc(add)


def _second_order(sub, rates: dict[sp.Symbol, sp.Expr], qd: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
    """Σ_kl ∂(∂θ/∂Q_k)/∂Q_l Q̇_k Q̇_l: zero for DH entries affine in Q."""
    terms = []
    for qk, rate in rates.items():
        for ql in qd:
            dr = sub.diff(rate, ql)
            if dr != 0:
                terms.append(dr * qd[qk] * qd[ql])
    return sp.Add(*terms)


def _bodies_wrench(bodies, w, dw, a, tangent, add) -> tuple[sp.Matrix, sp.Matrix]:
    """Wrench (moment about the frame origin, force) needed to move the bodies of one frame.

    Per body, at its centre of mass c: a_c = a + ω̇ × c + ω × (ω × c) = a + U c, f = m a_c,
    n = I_c ω̇ + ω × I_c ω + c × f (Euler's equation about the centre of mass, moved to the origin).
    Working at the centre of mass avoids the parallel-axis conversion of the inertia.
    """
    n_terms, f_terms = [ZERO3], [ZERO3]  # summed once at the end: a running sum is quadratic in the bodies
    for body in bodies:
        c = sp.Matrix(body.com)
        inertia = body.inertia_tensor
        a_c = (a + tangent * c).applyfunc(add)
        f = (body.mass * a_c).applyfunc(add)
        i_w = (inertia * w).applyfunc(add)
        n = inertia * dw + cross(w, i_w) + cross(c, f)
        n_terms.append(n)
        f_terms.append(f)
    return entrywise_sum(n_terms), entrywise_sum(f_terms)
