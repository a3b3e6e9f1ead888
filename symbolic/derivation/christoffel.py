"""The Christoffel matrix C(Q) = Z·∂D/∂Qᵀ and the Coriolis/centripetal terms (Madill 3.9.1).

Madill (3.81): C(Q) = Z D'(Q)ᵀ with D' = ∂D/∂Q = [∂D/∂Q_1 … ∂D/∂Q_N] (N×N², (3.9)) and
Z = T_NN − ½ I_{N²}, T_NN the permutation of (3.2). C is N²×N, partitioned into N×N blocks C_k; the
centripetal/Coriolis vector is (I_N ⊗ Q̇ᵀ) C Q̇ (3.82), whose k-th entry is Q̇ᵀ C_k Q̇.

The symmetric form c_ijk = ½(∂d_kj/∂Q_i + ∂d_ki/∂Q_j − ∂d_ij/∂Q_k) is stored and the literal Z D'ᵀ kept
for comparison: they give the same (3.82) (why both: docs/contracts.md, "Python API").

The Coriolis matrix C(Q,Q̇)_kj = Σ_i c_ijk Q̇_i satisfies C(Q,Q̇)Q̇ = (I⊗Q̇ᵀ)CQ̇ and makes Ḋ − 2C(Q,Q̇)
skew-symmetric.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from symbolic.derivation.subexpressions import Subexpressions


def inertia_derivatives(D: sp.Matrix, coordinates: Sequence[sp.Symbol], sub: Subexpressions) -> list[sp.Matrix]:
    """[∂D/∂Q_1, …, ∂D/∂Q_N], each symmetric, by the chain rule through ``sub``."""
    n = D.shape[0]
    out = []
    for q in coordinates:
        dD = sp.zeros(n, n)
        for i in range(n):
            for j in range(i, n):
                dD[i, j] = dD[j, i] = sub.add(sub.diff(D[i, j], q))
        out.append(dD)
    return out


def permutation_T(u: int, v: int) -> sp.Matrix:
    """T_uv of Madill (3.2): rows [I_v ⊗ e_1ᵀ; …; I_v ⊗ e_uᵀ], e_i ∈ ℝᵘ."""
    blocks = []
    for i in range(u):
        e = sp.zeros(1, u)
        e[0, i] = 1
        blocks.append(sp.kronecker_product(sp.eye(v), e))
    return sp.Matrix.vstack(*blocks)


def christoffel_literal(dD: Sequence[sp.Matrix]) -> sp.Matrix:
    """C = Z D'ᵀ exactly as written in Madill (3.81) (N²×N; blocks need not be symmetric)."""
    n = len(dD)
    d_prime = sp.Matrix.hstack(*dD)  # N × N², (3.9)
    z = permutation_T(n, n) - sp.Rational(1, 2) * sp.eye(n * n)
    return z * d_prime.T


def christoffel_symbols(dD: Sequence[sp.Matrix], sub: Subexpressions | None = None) -> sp.Matrix:
    """The symmetric Christoffel matrix: block k (rows kN…kN+N−1) holds c_ijk, N²×N."""
    n = len(dD)
    add = sub.add if sub is not None else (lambda e: e)
    C = sp.zeros(n * n, n)
    for k in range(n):
        for i in range(n):
            for j in range(i, n):
                c = add(sp.Rational(1, 2) * (dD[i][k, j] + dD[j][k, i] - dD[k][i, j]))
                C[k * n + i, j] = C[k * n + j, i] = c
    return C


def block(C: sp.Matrix, k: int) -> sp.Matrix:
    """C_k, the k-th N×N block of an N²×N Christoffel matrix."""
    n = C.shape[1]
    return C[k * n : (k + 1) * n, :]


def coriolis_vector(C: sp.Matrix, qd: Sequence[sp.Symbol], matrix: sp.Matrix | None = None) -> sp.Matrix:
    """(I_N ⊗ Q̇ᵀ) C Q̇ of (3.82): entry k is Q̇ᵀ C_k Q̇, (Q̇ᵀ C_k) Q̇ with Q̇ᵀ C_k row k of the Coriolis matrix
    (:func:`coriolis_matrix`; given as ``matrix``, its rows are not multiplied out again)."""
    n = C.shape[1]
    v = sp.Matrix(qd)
    rows = [matrix[k, :] if matrix is not None else v.T * block(C, k) for k in range(n)]
    return sp.Matrix([(row * v)[0] for row in rows])


def coriolis_matrix(C: sp.Matrix, qd: Sequence[sp.Symbol]) -> sp.Matrix:
    """C(Q,Q̇) with entries Σ_i c_ijk Q̇_i (row k, column j) from the symmetric Christoffel matrix."""
    n = C.shape[1]
    v = sp.Matrix(qd)
    return sp.Matrix.vstack(*[(v.T * block(C, k)) for k in range(n)])
