"""Inverse dynamics τ = D Q̈ + (I⊗Q̇ᵀ)C Q̇ + g by a recursive Newton–Euler pass over the same frames.

This is the short route to code for τ (the Lagrangian quantities D, C, g stay available for
analysis); the test-suite checks that both routes agree. Velocities and accelerations are
propagated outwards in each frame's coordinates, wrenches inwards, and each coordinate's torque is
the projection of the wrench of every frame it moves on that frame's joint twist (virtual work),
which also covers frames whose DH entries combine several coordinates (Janot (8)–(11), Madill
Table 3.1).
"""

from __future__ import annotations

import sympy as sp

from symbolic.inertia import SpatialInertia
from symbolic.kinematics import ZERO3, Kinematics, cross
from symbolic.spec import BASE


def _rate(rates: dict[sp.Symbol, sp.Expr], values: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
    return sp.Add(*[k * values[q] for q, k in rates.items()])


def inverse_dynamics(
    kin: Kinematics,
    qd: dict[sp.Symbol, sp.Expr],
    qdd: dict[sp.Symbol, sp.Expr],
    gravity: bool = True,
) -> sp.Matrix:
    """Generalized forces for velocities ``qd`` and accelerations ``qdd`` (maps coordinate -> value).

    With ``qd = qdd = 0`` and ``gravity=True`` this is g(Q); with ``qdd = 0`` and
    ``gravity=False`` the Coriolis/centripetal vector.
    """
    sub = kin.sub
    add = sub.add
    state: dict[str, tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]] = {}
    g0 = -sp.Matrix(kin.robot.gravity) if gravity else ZERO3
    base = (ZERO3, ZERO3, ZERO3, g0)  # ω, ω̇, v, a of the base: a = −gravity models gravity
    wrench: dict[str, tuple[sp.Matrix, sp.Matrix]] = {}
    inertia: dict[str, SpatialInertia] = {name: SpatialInertia.zero() for name in kin.frames}
    for body in kin.robot.bodies:
        if body.frame != BASE:
            inertia[body.frame] = inertia[body.frame] + SpatialInertia.of_body(body)

    for name, fk in kin.frames.items():
        w_p, dw_p, v_p, a_p = base if fk.parent == BASE else state[fk.parent]
        th_d = add(_rate(fk.theta_rate, qd))
        d_d = add(_rate(fk.d_rate, qd))
        th_dd = add(_rate(fk.theta_rate, qdd) + _second_order(sub, fk.theta_rate, qd))
        d_dd = add(_rate(fk.d_rate, qdd) + _second_order(sub, fk.d_rate, qd))
        (u_t, l_t), (u_d, l_d) = fk.theta_twist, fk.d_twist
        w_rel = u_t * th_d + u_d * d_d
        v_rel = l_t * th_d + l_d * d_d
        w_pc = fk.to_child(w_p).applyfunc(add)
        dw_pc = fk.to_child(dw_p).applyfunc(add)
        w = (w_pc + w_rel).applyfunc(add)
        dw = (dw_pc + cross(w_pc, w_rel) + u_t * th_dd + u_d * d_dd).applyfunc(add)
        v = (fk.to_child(v_p) + cross(w_pc, fk.p_child) + v_rel).applyfunc(add)
        a = (
            fk.to_child(a_p)
            + cross(dw_pc, fk.p_child)
            + cross(w_pc, cross(w_pc, fk.p_child).applyfunc(add))
            + 2 * cross(w_pc, v_rel)
            + l_t * th_dd
            + l_d * d_dd
            + fk.theta_sq_accel * th_d**2
        ).applyfunc(add)
        state[name] = (w, dw, v, a)
        wrench[name] = _body_wrench(inertia[name], w, dw, a, add)

    tau = {q: [] for q in kin.coordinates}
    for name in reversed(list(kin.frames)):
        fk = kin.frames[name]
        n, f = (x.applyfunc(add) for x in wrench[name])
        for q in fk.coordinates:
            w_unit, v_unit = fk.joint_twist(q)
            tau[q].append((w_unit.T * n + v_unit.T * f)[0])
        if fk.parent != BASE:
            f_parent = fk.to_parent(f).applyfunc(add)
            n_parent = fk.to_parent(n).applyfunc(add) + cross(fk.p_parent, f_parent)
            pn, pf = wrench[fk.parent]
            wrench[fk.parent] = (pn + n_parent, pf + f_parent)
    return sp.Matrix([sp.Add(*tau[q]) for q in kin.coordinates])


def _second_order(sub, rates: dict[sp.Symbol, sp.Expr], qd: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
    """Σ_kl ∂(∂θ/∂Q_k)/∂Q_l Q̇_k Q̇_l: zero for DH entries affine in Q."""
    terms = []
    for qk, rate in rates.items():
        for ql in qd:
            dr = sub.diff(rate, ql)
            if dr != 0:
                terms.append(dr * qd[qk] * qd[ql])
    return sp.Add(*terms)


def _body_wrench(inertia: SpatialInertia, w, dw, a, add) -> tuple[sp.Matrix, sp.Matrix]:
    """Wrench (moment about the origin, force) needed to move the bodies of one frame.

    With first moment h = m c: f = m a + ω̇ × h + ω × (ω × h),
    n = I_o ω̇ + ω × I_o ω + h × a (all about the frame origin, frame axes).
    """
    if inertia.is_zero():
        return ZERO3, ZERO3
    h = inertia.moment.applyfunc(add)
    i_o = inertia.rotational.applyfunc(add)
    m = add(inertia.mass)
    f = m * a + cross(dw, h) + cross(w, cross(w, h).applyfunc(add))
    i_w = (i_o * w).applyfunc(add)
    n = i_o * dw + cross(w, i_w) + cross(h, a)
    return n, f
