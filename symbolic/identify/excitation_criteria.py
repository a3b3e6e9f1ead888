"""Information criteria of an excitation design: the extension point of :mod:`symbolic.identify.excitation`.

A criterion is a function of the information matrix M = WᵀΣ⁻¹W of the base parameters (b × b, symmetric
positive definite) returning ``(value, G)``: the value to *minimise* and its gradient G = ∂value/∂M
(symmetric). The design differentiates M(x) exactly by CasADi's algorithmic differentiation of the base
regressor and chains G in (d value = tr(G·dM)), so a new criterion is one function added to
:data:`CRITERIA`, with its gradient in closed form:

* ``d`` (D-optimality, default): −log det M; G = −M⁻¹ (d log det M = tr(M⁻¹dM)). Maximising det M minimises
  the volume of the confidence ellipsoid of β̂, whose covariance is σ²M⁻¹, and is invariant to the units
  (scaling) of the parameters (Swevers, Ganseman, Tükel, De Schutter, Van Brussel, IEEE Trans. Robot. Autom.
  13(5), 1997).
* ``a`` (A-optimality): log tr(M⁻¹), the log of the sum of the parameters' variances; G = −M⁻²/tr(M⁻¹)
  (d tr(M⁻¹) = −tr(M⁻¹dM M⁻¹)). It depends on the parameters' units.
* ``condition``: log cond(Σ^(−1/2)W) = ½ log(λ_max/λ_min) of M, the criterion of Gautier and Khalil
  (IEEE Trans. Robot. Autom. 8(3), 1992, "Exciting trajectories for the identification of base inertial
  parameters of robots"); G = ½(v_max v_maxᵀ/λ_max − v_min v_minᵀ/λ_min) for the unit eigenvectors (the
  derivative of a simple eigenvalue, dλ = vᵀdM v; not differentiable where an extreme eigenvalue is double).
* ``ds`` (Ds-optimality, :func:`ds_optimal`, ``symbolic excite --separate A,B``): the information about a subset s
  of the parameters once the others r are estimated is the Schur complement M_s = M_ss − M_sr M_rr⁻¹ M_rs, whose
  inverse is the block (M⁻¹)_ss of their covariance; −log det M_s = −log det M + log det M_rr (the determinant of
  a partitioned matrix), G = −M⁻¹ + P_r M_rr⁻¹ P_rᵀ (P_r the columns of the identity on r). Maximising det M_s
  shrinks the confidence ellipse of β̂_s: det (M⁻¹)_ss = σ_a²σ_b²(1 − ρ_ab²) for a pair (Atkinson, Donev and
  Tobias, *Optimum Experimental Designs, with SAS*, Oxford 2007, §10.3).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

Criterion = Callable[[np.ndarray], tuple[float, np.ndarray]]


def d_optimal(M: np.ndarray) -> tuple[float, np.ndarray]:  # noqa: N803
    """−log det M and its gradient −M⁻¹ (by Cholesky: M = LLᵀ, log det M = 2 Σ log L_ii)."""
    L = np.linalg.cholesky(M)  # noqa: N806
    inverse = np.linalg.inv(M)
    return float(-2.0 * np.log(np.diag(L)).sum()), -0.5 * (inverse + inverse.T)


def a_optimal(M: np.ndarray) -> tuple[float, np.ndarray]:  # noqa: N803
    """log tr(M⁻¹) and its gradient −M⁻²/tr(M⁻¹)."""
    inverse = np.linalg.inv(M)
    trace = float(np.trace(inverse))
    square = inverse @ inverse
    return float(np.log(trace)), -0.5 * (square + square.T) / trace


def condition(M: np.ndarray) -> tuple[float, np.ndarray]:  # noqa: N803
    """½ log(λ_max/λ_min) of M (log of the condition number of the weighted W) and its gradient."""
    values, vectors = np.linalg.eigh(0.5 * (M + M.T))
    low, high = vectors[:, 0], vectors[:, -1]
    G = 0.5 * (np.outer(high, high) / values[-1] - np.outer(low, low) / values[0])  # noqa: N806
    return float(0.5 * np.log(values[-1] / values[0])), G


def ds_optimal(subset: Sequence[int]) -> Criterion:
    """The Ds criterion of the parameters ``subset`` (indices into M; module docstring): −log det of the Schur
    complement of M_rr, and its gradient. With ``subset`` every parameter it is D-optimality."""
    s = sorted({int(i) for i in subset})

    def criterion(M: np.ndarray) -> tuple[float, np.ndarray]:  # noqa: N803
        value, gradient = d_optimal(M)
        rest = [i for i in range(M.shape[0]) if i not in s]
        if rest:
            block = M[np.ix_(rest, rest)]
            L = np.linalg.cholesky(block)  # noqa: N806
            inverse = np.linalg.inv(block)
            value += float(2.0 * np.log(np.diag(L)).sum())
            gradient = gradient.copy()
            gradient[np.ix_(rest, rest)] += 0.5 * (inverse + inverse.T)
        return value, gradient

    return criterion


CRITERIA: dict[str, Criterion] = {"d": d_optimal, "a": a_optimal, "condition": condition}
"""Criterion name → function (module docstring); the names ``symbolic excite --criterion`` accepts."""

DESCRIPTIONS = {"d": "D-optimality, −log det M", "a": "A-optimality, log tr M⁻¹", "condition": "log cond",
                "ds": "Ds-optimality for the pair, −log det of the Schur complement M_ss − M_sr M_rr⁻¹ M_rs"}
"""Criterion name → what it minimises, in the reports' words."""


def positive_definite(M: np.ndarray) -> bool:  # noqa: N803
    """Whether M is numerically positive definite (a criterion is defined)."""
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return False
    values = np.linalg.eigvalsh(M)
    return bool(values[0] > values[-1] * 1e-14)
