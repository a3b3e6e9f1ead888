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
* ``dc`` (D-optimality and the condition number, :func:`d_and_condition`): −(1/b) log det M + κ·s_p(M), b the
  number of base parameters, κ = :data:`WEIGHT` = 1. The first term is minus the mean of the log eigenvalues x_i =
  log λ_i of M (the D-criterion per parameter); the second, s_p(M) = ½(smax_p − smin_p)(x) with the soft maximum smax_p(x) = (1/p) log Σ_i exp(p·x_i) and
  smin_p(x) = −smax_p(−x), is a smooth upper bound of log cond(Σ^(−1/2)W) = ½(max x − min x):
  max x ≤ smax_p(x) ≤ max x + (log b)/p, so log cond ≤ s_p ≤ log cond + (log b)/p (:func:`soft_condition`,
  p = :data:`SOFTNESS`). With κ = 1 a condition number smaller by a factor e is worth a geometric-mean eigenvalue
  larger by e. D-optimality alone may spread the eigenvalues (a large det M, badly conditioned) and the
  condition number alone gives up information (a well-conditioned design with a smaller det M); combining the two is the proposal of Presse and Gautier ("New criteria of exciting
  trajectories for robot identification", IEEE ICRA 1993), here with the D-criterion of Swevers et al. 1997 in
  place of the smallest singular value. Unlike ½ log λ_max/λ_min, s_p is differentiable everywhere, double extreme
  eigenvalues included (a symmetric smooth function of the eigenvalues; Lewis, "Derivatives of spectral functions",
  Math. Oper. Res. 21(3), 1996): ∂s_p/∂M = V diag((w⁺_i − w⁻_i)/(2λ_i)) Vᵀ for M = V diag(λ) Vᵀ, with the weights
  w⁺ = softmax(p·x) and w⁻ = softmax(−p·x) (each summing to 1); G = −M⁻¹/b + κ·∂s_p/∂M.
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


SOFTNESS = 10.0
"""p of :func:`soft_condition`: the bound exceeds log cond by at most (log b)/p (0.4 for the Panda's 57 base
parameters with friction, a condition number 1.5 times too large at worst; less when few eigenvalues are near the
extremes)."""


def soft_condition(M: np.ndarray, p: float = SOFTNESS) -> tuple[float, np.ndarray]:  # noqa: N803
    """s_p(M) = ½(smax_p − smin_p)(log λ(M)), an upper bound of log cond(Σ^(−1/2)W) within (log b)/p, and its
    gradient (module docstring, ``dc``)."""
    values, vectors = np.linalg.eigh(0.5 * (M + M.T))
    x = np.log(values)
    high, low = _softmax(p * x), _softmax(-p * x)
    value = 0.5 * (_log_sum_exp(p * x) + _log_sum_exp(-p * x)) / p
    return float(value), (vectors * (0.5 * (high - low) / values)) @ vectors.T


def _log_sum_exp(y: np.ndarray) -> float:
    top = float(y.max())
    return top + float(np.log(np.exp(y - top).sum()))


def _softmax(y: np.ndarray) -> np.ndarray:
    e = np.exp(y - y.max())
    return e / e.sum()


WEIGHT = 1.0
"""κ of the ``dc`` criterion: the weight of the (soft) log condition number beside the mean log eigenvalue."""


def d_and_condition(M: np.ndarray, weight: float | None = None) -> tuple[float, np.ndarray]:  # noqa: N803
    """−(1/b) log det M + κ·s_p(M) (module docstring, ``dc``; κ = :data:`WEIGHT` by default) and its gradient."""
    weight = WEIGHT if weight is None else weight
    d, gd = d_optimal(M)
    c, gc = soft_condition(M, SOFTNESS)
    b = M.shape[0]
    return d / b + weight * c, gd / b + weight * gc


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


CRITERIA: dict[str, Criterion] = {"d": d_optimal, "a": a_optimal, "condition": condition, "dc": d_and_condition}
"""Criterion name → function (module docstring); the names ``symbolic excite --criterion`` accepts."""

DESCRIPTIONS = {"d": "D-optimality, −log det M", "a": "A-optimality, log tr M⁻¹", "condition": "log cond",
                "dc": "D-optimality and the condition number, −(1/b) log det M + soft log cond",
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
