"""∂τ/∂q and ∂τ/∂q̇ of the inverse dynamics, in intermediate symbols (docs/contracts.md, "Derivatives").

τ = D(q) q̈ + h(q, q̇) + g(q) + k(q) + f(q, q̇) − Q(q, q̇, t) (docs/architecture.md, "Equations of motion").

**∂τ/∂q̇** needs no differentiation of the Newton–Euler pass. Entry k of the Coriolis and centrifugal vector is
q̇ᵀ C_k q̇ with C_k the k-th block of the symmetric Christoffel matrix (Madill (3.82)), so

    ∂h_k/∂q̇ = 2 q̇ᵀ C_k = 2 · (row k of C(q, q̇)),    ∂τ/∂q̇ = 2 C(q, q̇) + ∂(f − Q)/∂q̇,          (2)

C(q, q̇) the Coriolis matrix of the Christoffel symbols (``coriolis_matrix``: Σᵢ c_ijk q̇ᵢ in row k, column j)
and only friction and the applied forces differentiated. This holds wherever the kinetic energy is ½ q̇ᵀD(q)q̇
— every model here: rigid links, rotors (on D's diagonal), beams (whose h is written as (3.82) itself); time
enters through applied forces only. C(q, q̇) has N² entries of N terms each, built from ∂D/∂q, where (1) for ∂τ/∂q̇
costs N directions through one Newton–Euler pass: (2) is the smaller program for short chains, (1) for long ones.
Both are exact, and the one whose program (with ∂τ/∂q's) counts fewer operations is taken: (2) for the Panda
(both Jacobians 5,928 operations after CSE against 7,274), the PUMA 560 and spatial chains up to 8 links; (1) for
planar chains from 8 links and spatial ones from 12 (∂τ/∂q̇ of 20 spatial links before CSE: 43,293 operations by (1),
76,012 by (2)).

**∂τ/∂q**: τ(q, q̇, q̈) is a straight-line program: each intermediate xₖ = φₖ(x₁ … xₖ₋₁, q, q̇, q̈) of the recursive
Newton–Euler pass (and of friction, the drives and the applied forces) is a short expression in earlier ones
(docs/architecture.md, "Intermediate symbols"). Its derivatives are taken by the chain rule through those
definitions, forward mode:

    ∂xₖ/∂v = ∂φₖ/∂v + Σₘ ∂φₖ/∂xₘ · ∂xₘ/∂v,    v ∈ {q₁ … q_N, q̇₁ … q̇_N},          (1)

each ∂xₘ/∂v registered as an intermediate in turn (memoized, zero where xₘ does not depend on v), so the
derivatives are again a straight-line program in the same intermediates as τ: a generated function computes
τ's intermediates once and the derivatives from them (tried instead: D's derivatives times q̈ plus (1) through the
bias alone, 6,569 operations for the Panda; through the Christoffel form of h, 7,529). Differentiating the expanded closed form of τ instead
would first build that form (tens of thousands of operations for a 7-axis arm) and then differentiate every
term of it. ∂τ/∂q̈ = D(q) needs no derivative. The derivative of sign(v) is taken as zero (its value away
from v = 0), as everywhere in the derivation.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.subexpressions import Subexpressions


@dataclass(frozen=True)
class InverseDynamicsDerivatives:
    """∂τ/∂q and ∂τ/∂q̇ as N×N row-major tuples, entry [i·N + j] = ∂τᵢ/∂x_j, in the intermediates of ``sub``.

    Attributes
    ----------
    sub : a copy of the model's intermediates extended by the derivatives of (1) (the model's own are untouched)
    dq : ∂τᵢ/∂q_j, row-major
    dqd : ∂τᵢ/∂q̇_j, row-major
    """

    sub: Subexpressions
    dq: tuple[sp.Expr, ...]
    dqd: tuple[sp.Expr, ...]


def inverse_dynamics_derivatives(model: DynamicModel) -> InverseDynamicsDerivatives:
    """∂τ/∂q of ``model.reduced.tau`` by the chain rule (1) through its intermediates, ∂τ/∂q̇ by (2) or (1),
    whichever program is smaller (module docstring).

    Parameters
    ----------
    model : the derived model

    Returns
    -------
    InverseDynamicsDerivatives
        The two Jacobians, row-major, in a copy of ``model.sub`` extended by the derivatives.
    """
    sub = model.sub.copy()
    forms = model.reduced
    n = len(model.velocities)
    dq = _jacobian(sub, list(forms.tau), model.coordinates)
    forces = _jacobian(sub, list(forms.friction - forms.applied), model.velocities)
    coriolis = tuple(2 * forms.coriolis_matrix[i, j] + forces[i * n + j] for i in range(n) for j in range(n))
    chained = _jacobian(sub, list(forms.tau), model.velocities)
    dqd = min((coriolis, chained), key=lambda d: sub.count_ops([*dq, *d]))  # equal counts: (2), the first
    return InverseDynamicsDerivatives(sub, dq, dqd)


def _jacobian(sub: Subexpressions, outputs: list[sp.Expr], variables: tuple[sp.Symbol, ...]) -> tuple[sp.Expr, ...]:
    """[∂outputᵢ/∂variable_j] row-major, each entry a short expression in intermediates (registered in ``sub``)."""
    return tuple(sub.diff(y, v) for y in outputs for v in variables)
