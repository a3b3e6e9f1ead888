"""Sensing with a flexible link (Madill 3.11 and Appendix C): strain gauges, tip deflection and the
force-from-strain approximation.

Amplified strains (difference of gauges on opposite faces, (C.1)–(C.4)):
ε_v(x) = h v''(x) = h φ''(x)ᵀν,  ε_w(x) = b w''(x) = b ψ''(x)ᵀη. With gauges at x₁ … x_n,
E_v = 𝒦_v ν (C.5), 𝒦_v = h [φ''(x₁)ᵀ; …; φ''(x_n)ᵀ]; when 𝒦_v is non-singular the strains serve as
coordinates and the tip deflection is v(l) = φ(l)ᵀ𝒦_v⁻¹E_v. For a force at the tip,
F_v(l) ≈ (EI_v/(h l)) ε_v(0) (3.115) — exact for a static tip load on an Euler–Bernoulli cantilever.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import sympy as sp

from symbolic.derivation.flexible import beam_jacobian, column, geometry
from symbolic.derivation.kinematics import Kinematics
from symbolic.derivation.mode_shapes import phi
from symbolic.description.robot import Beam

CONDITION_LIMIT = 1e12


def strain_matrix(beam: Beam, positions: Sequence[sp.Expr | float], thickness: sp.Expr | float, direction: str = "v") -> sp.Matrix:
    """𝒦 of (C.5): rows h φ''(xᵢ)ᵀ (direction "v") or b ψ''(xᵢ)ᵀ ("w")."""
    g = geometry(beam)
    shapes = g.v.shapes if direction == "v" else g.w.shapes
    if len(positions) != len(shapes):
        raise ValueError(f"{len(shapes)} modes in direction {direction} need {len(shapes)} gauge positions, got {len(positions)}")
    return sp.Matrix([[thickness * phi(s, sp.sympify(x), beam.length, 2) for s in shapes] for x in positions])


def check_strain_matrix(K: sp.Matrix, values: Mapping[sp.Symbol, float]) -> np.ndarray:
    """𝒦 evaluated at ``values``; raises ValueError when it is singular (gauges at nodes of the same
    curvature mode, or coinciding), since the modal coordinates cannot then be recovered (Appendix C)."""
    numeric = np.array(K.xreplace(values).evalf(), dtype=float)
    condition = np.linalg.cond(numeric)
    if not np.isfinite(condition) or condition > CONDITION_LIMIT:
        raise ValueError(f"strain-gauge matrix is singular (condition number {condition:.3g}); move the gauges apart or off curvature nodes")
    return numeric


def tip_deflection(beam: Beam) -> tuple[sp.Expr, sp.Expr]:
    """(v(l), w(l)) = (φ(l)ᵀν, ψ(l)ᵀη) (3.40)–(3.41) at x = l."""
    g = geometry(beam)
    tip = g.tip_point()
    return tip[1], tip[2]


def tip_deflection_from_strain(beam: Beam, K: sp.Matrix, direction: str = "v") -> sp.Matrix:
    """Row vector φ(l)ᵀ𝒦⁻¹ mapping measured strains E to the tip deflection (Appendix C)."""
    g = geometry(beam)
    tip = column(g.v.tip if direction == "v" else g.w.tip).T
    return tip * K.inv()


def force_from_root_strain(beam: Beam, thickness: sp.Expr, direction: str = "v") -> sp.Expr:
    """EI/(h l) of (3.115): tip force per unit amplified strain at the clamped end."""
    stiffness = beam.EI_v if direction == "v" else beam.EI_w
    return stiffness / (thickness * beam.length)


def generalized_force(kin: Kinematics, beam: Beam, x: sp.Expr, force: sp.Matrix, coordinates: tuple[sp.Symbol, ...]) -> sp.Matrix:
    """τ = J(Q, x)ᵀF (3.58) for a base-frame force F at x along the beam."""
    return beam_jacobian(kin, beam, x, coordinates).T * force
