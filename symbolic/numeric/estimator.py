"""The stationary Kalman filter gain of a linearised model (Madill 6.3, the state estimator (6.6)).

For ẋ = A x + B u + G w, y = C x + v with white noises of covariances Q = E(wwᵀ) and R = E(vvᵀ), the
stationary error covariance P solves the filter Riccati equation

    A P + P Aᵀ − P Cᵀ R⁻¹ C P + G Q Gᵀ = 0

and the gain is L = P Cᵀ R⁻¹, so that the estimator x̂' = A x̂ + B u + L (y − C x̂) has the stable error
dynamics A − L C. Madill designs his axial joint's estimator this way (Q = diag(1, 41.6), R = 0.1,
G = diag(1, 1/J)) and prints L = [14.4; 99.2].
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_continuous_are


def kalman_gain(A, C, Q, R, G=None) -> np.ndarray:
    """L = P Cᵀ R⁻¹ with P the stabilising solution of the filter Riccati equation (module docstring).

    Parameters
    ----------
    A, C
        State and output matrices (n × n, m × n), e.g. from :meth:`NumericModel.linearize`.
    Q, R
        Process-noise (k × k) and measurement-noise (m × m) covariances; scalars are 1 × 1.
    G
        Process-noise input (n × k); default the identity (k = n).

    Raises
    ------
    ValueError
        For inconsistent shapes, or when (A, C) is not detectable / the equation has no stabilising solution.
    """
    A, C = np.atleast_2d(np.asarray(A, float)), np.atleast_2d(np.asarray(C, float))
    Q, R = np.atleast_2d(np.asarray(Q, float)), np.atleast_2d(np.asarray(R, float))
    n = A.shape[0]
    G = np.eye(n) if G is None else np.atleast_2d(np.asarray(G, float))
    if A.shape != (n, n) or C.shape[1] != n or G.shape != (n, Q.shape[0]) or R.shape != (C.shape[0],) * 2:
        raise ValueError(f"shapes do not fit: A {A.shape}, C {C.shape}, G {G.shape}, Q {Q.shape}, R {R.shape}")
    try:
        P = solve_continuous_are(A.T, C.T, G @ Q @ G.T, R)
    except (np.linalg.LinAlgError, ValueError) as error:
        raise ValueError(f"the filter Riccati equation has no stabilising solution: {error}") from None
    return P @ C.T @ np.linalg.inv(R)
