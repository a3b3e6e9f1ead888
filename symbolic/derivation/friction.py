"""Friction laws: the generalized friction force f(q̇) of each [[friction]] entry (Janot (15)–(17)).

Per coordinate (docs/model-format.md, "Friction, drives and applied forces"), entering τ = D q̈ + … + f:

    f = Fv·q̇ + Fc·sign(q̇) + offset                                   Janot (15) and its offset (1)
    Coulomb with Stribeck:  (Fc + (Fs − Fc)·exp(−(q̇/vs)²))·sign(q̇)
    direction-dependent:    Fv⁺, Fc⁺ for q̇ > 0 and Fv⁻, Fc⁻ for q̇ < 0

:func:`friction_force` gives f of one entry, :func:`friction_vector` the vector of a robot, with friction
at a constrained coordinate mapped through Janot (12) (:mod:`symbolic.derivation.transmission`).
"""

from __future__ import annotations

import sympy as sp

from symbolic.derivation.transmission import map_to_generalized
from symbolic.description.robot import Directional, Friction, Robot, velocity_symbol


def positive_part(s: sp.Expr) -> sp.Expr:
    """[q̇ > 0] from s = sign(q̇), as the polynomial (s² + s)/2.

    Direction-dependent terms are written as polynomials in s (this and :func:`negative_part`) so that
    the law stays linear in its coefficients (for the regressor) and prints as plain arithmetic in C and
    CasADi.
    """
    return (s**2 + s) / 2


def negative_part(s: sp.Expr) -> sp.Expr:
    """[q̇ < 0] from s = sign(q̇), as the polynomial (s² − s)/2."""
    return (s**2 - s) / 2


def level(coefficient: sp.Expr | Directional, s: sp.Expr) -> sp.Expr:
    """The coefficient for the current direction of motion."""
    if isinstance(coefficient, Directional):
        return coefficient.positive * positive_part(s) + coefficient.negative * negative_part(s)
    return coefficient


def friction_force(entry: Friction, velocity: sp.Expr) -> sp.Expr:
    """f(q̇) of one validated [[friction]] entry at joint velocity ``velocity``."""
    s = sp.sign(velocity)
    f = sp.Integer(0)
    if entry.viscous is not None:
        f += level(entry.viscous, s) * velocity
    coulomb = sp.Integer(0) if entry.coulomb is None else level(entry.coulomb, s)
    if entry.stribeck is not None:
        fs, vs = entry.stribeck.static, entry.stribeck.velocity
        coulomb = coulomb + (fs - coulomb) * sp.exp(-((velocity / vs) ** 2))
    f += coulomb * s
    if entry.offset is not None:
        f += entry.offset
    return f


def friction_vector(robot: Robot) -> sp.Matrix:
    """f(Q, Q̇) over the generalized coordinates: every [[friction]] entry at its own coordinate, entries
    at constrained coordinates spread by Lᵀ (Janot (12); this gives Γ_fc of (16)–(17))."""
    names = robot.generalized_coordinates
    f = sp.zeros(len(names), 1)
    for entry in robot.frictions:
        force = friction_force(entry, velocity_symbol(entry.coordinate))
        for coordinate, share in map_to_generalized(robot, entry.coordinate, force).items():
            f[names.index(coordinate), 0] += share
    return f
