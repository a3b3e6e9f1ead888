"""Fit of Milne et al.'s inertia and damping model (6)–(8), (27)–(29) to per-configuration linear models.

Input: per configuration (γ₁, γ₂) the C_linear and β̃_linear of :mod:`symbolic.reproduction.milne.sine`.
Output: I_base, I₁, I₂, I₃, γ_offs and C̄₀ of

    I = I_base + I₁ cos²γ₁ + I₂ cos²a + I₃ cos γ₁ cos a,  a = π − γ₁ − γ₂ − γ_offs     Milne (27)
    β̃_linear = 1/I                                                                 Milne (28)
    C_linear = 1/(C̄₀ I)                                                            Milne (29)

by bounded nonlinear least squares on relative residuals (:func:`fit_inertia_model`, an
:class:`InertiaFit`), and Milne's C̄₀ of Table 3 by regression through the origin (:func:`damping_ratio`).
The objective, the bounds and the start: docs/seeds.md, "Milne: sinusoidal identification and the
inertia model".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, nnls

from symbolic.data import DataError

OFFSET_GRID_DEGREES = np.arange(-90.0, 90.0, 1.0)
"""γ_offs values scanned for the start of the nonlinear fit (degrees)."""


@dataclass(frozen=True)
class InertiaModel:
    """I_base, I₁, I₂, I₃ (kg·m², or whatever unit makes β̃ = 1/I), γ_offs (rad) and C̄₀ of Milne (6)–(8)."""

    base: float
    i1: float
    i2: float
    i3: float
    offset: float
    c0: float

    @property
    def coefficients(self) -> tuple[float, float, float, float]:
        """(I_base, I₁, I₂, I₃)."""
        return self.base, self.i1, self.i2, self.i3

    @property
    def valid(self) -> bool:
        """Milne's validity condition: I_base, I₁, I₂, I₃ all non-negative."""
        return min(self.coefficients) >= 0.0

    def inertia(self, gamma1: np.ndarray | float, gamma2: np.ndarray | float) -> np.ndarray:
        """I(γ₁, γ₂) of Milne (27) (angles in rad)."""
        return inertia(self.coefficients, self.offset, gamma1, gamma2)

    def beta_tilde(self, gamma1: np.ndarray | float, gamma2: np.ndarray | float) -> np.ndarray:
        """β̃_linear = 1/I (Milne (28))."""
        return 1.0 / self.inertia(gamma1, gamma2)

    def damping(self, gamma1: np.ndarray | float, gamma2: np.ndarray | float) -> np.ndarray:
        """C_linear = 1/(C̄₀ I) (Milne (29))."""
        return 1.0 / (self.c0 * self.inertia(gamma1, gamma2))


@dataclass(frozen=True)
class InertiaFit:
    """Result of :func:`fit_inertia_model`.

    Attributes
    ----------
    model
        The fitted :class:`InertiaModel`.
    residuals
        Relative residuals: β̃_model/β̃ − 1 for each configuration, then C_model/C − 1.
    cost
        ½ Σ residuals².
    """

    model: InertiaModel
    residuals: np.ndarray
    cost: float

    @property
    def worst_relative_error(self) -> float:
        """max |residual|."""
        return float(np.max(np.abs(self.residuals)))


def inertia(coefficients: Sequence[float], offset: float, gamma1: np.ndarray | float,
            gamma2: np.ndarray | float) -> np.ndarray:
    """I_base + I₁ cos²γ₁ + I₂ cos²a + I₃ cos γ₁ cos a, a = π − γ₁ − γ₂ − γ_offs (Milne (6), (27); rad)."""
    base, i1, i2, i3 = coefficients
    c1 = np.cos(gamma1)
    ca = np.cos(np.pi - np.asarray(gamma1) - np.asarray(gamma2) - offset)
    return base + i1 * c1**2 + i2 * ca**2 + i3 * c1 * ca


def damping_ratio(C: Sequence[float] | np.ndarray, beta_tilde: Sequence[float] | np.ndarray) -> float:
    """Milne's C̄₀ (Table 3): least squares of β̃ = C̄₀·C through the origin, Σ C β̃ / Σ C²."""
    C = np.asarray(C, dtype=float).reshape(-1)
    b = np.asarray(beta_tilde, dtype=float).reshape(-1)
    if C.size == 0 or C.size != b.size:
        raise DataError("<arrays>", "C, beta_tilde", f"{C.size} and {b.size} values (one pair per configuration, "
                                                     "at least one)")
    return float(C @ b / (C @ C))


def fit_inertia_model(
    gamma1: Sequence[float] | np.ndarray,
    gamma2: Sequence[float] | np.ndarray,
    C: Sequence[float] | np.ndarray,
    beta_tilde: Sequence[float] | np.ndarray,
) -> InertiaFit:
    """I_base, I₁, I₂, I₃, γ_offs, C̄₀ from per-configuration C_linear and β̃_linear (Milne (27)–(29)).

    Parameters
    ----------
    gamma1, gamma2
        The measured ("true") arm angles of each configuration (rad).
    C, beta_tilde
        C_linear and β̃_linear of each configuration (positive).

    Raises
    ------
    DataError
        Lengths that differ, fewer than 6 configurations (6 unknowns), non-finite or non-positive C or β̃.
    """
    g1, g2, c, b = (np.asarray(x, dtype=float).reshape(-1) for x in (gamma1, gamma2, C, beta_tilde))
    if not (g1.size == g2.size == c.size == b.size):
        raise DataError("<arrays>", "gamma1, gamma2, C, beta_tilde",
                        f"lengths {g1.size}, {g2.size}, {c.size}, {b.size} (one value each per configuration)")
    if g1.size < 6:
        raise DataError("<arrays>", "configurations", f"{g1.size} given; the six unknowns of (27)–(29) need at least "
                                                      "6 (Milne uses 9, Table 1)")
    for name, values in (("gamma1", g1), ("gamma2", g2), ("C", c), ("beta_tilde", b)):
        if not np.all(np.isfinite(values)):
            raise DataError("<arrays>", name, "holds NaN or infinity (allowed: finite numbers)")
    for name, values in (("C", c), ("beta_tilde", b)):
        if np.any(values <= 0):
            raise DataError("<arrays>", name, "must be positive in every configuration (Milne's rule excludes the others)")

    def residuals(p: np.ndarray) -> np.ndarray:
        i = inertia(p[:4], p[4], g1, g2)
        return np.concatenate([1.0 / (i * b) - 1.0, 1.0 / (p[5] * i * c) - 1.0])

    start = _start(g1, g2, c, b)
    scale = max(float(np.mean(1.0 / b)), np.finfo(float).tiny)
    lower = [0.0, 0.0, 0.0, 0.0, -math.pi, 0.0]
    upper = [np.inf, np.inf, np.inf, np.inf, math.pi, np.inf]
    solution = least_squares(residuals, start, bounds=(lower, upper), x_scale=[scale] * 4 + [0.1, start[5]],
                             xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=10000)
    p = solution.x
    model = InertiaModel(*(float(v) for v in p))
    r = residuals(p)
    return InertiaFit(model, r, float(0.5 * r @ r))


def _start(g1: np.ndarray, g2: np.ndarray, c: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The best γ_offs of a one-degree grid with the inertias by non-negative least squares on I = 1/β̃."""
    best: tuple[float, np.ndarray, float] | None = None
    for degrees in OFFSET_GRID_DEGREES:
        offset = math.radians(degrees)
        ca = np.cos(np.pi - g1 - g2 - offset)
        c1 = np.cos(g1)
        # rows weighted by β̃ so that the residual is relative, as in the nonlinear fit
        A = np.column_stack([np.ones_like(g1), c1**2, ca**2, c1 * ca]) * b[:, None]
        coefficients, norm = nnls(A, np.ones_like(b))
        if best is None or norm < best[2]:
            best = (offset, coefficients, norm)
    assert best is not None
    offset, coefficients, _ = best
    return np.concatenate([np.maximum(coefficients, 0.0), [offset, damping_ratio(c, b)]])
