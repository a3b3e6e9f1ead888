"""Assumed-mode shapes of Euler–Bernoulli beams (Madill Appendix B) and their modal constants.

Clamped-free eigenfunctions (B.8)–(B.9), normalised on [0, l] ((B.20): ∫₀ˡ φᵢ² dx = 1):

    φᵢ(x) = l^(−1/2) Φᵢ(x/l),  Φᵢ(ξ) = cosh kᵢξ − cos kᵢξ − σᵢ (sinh kᵢξ − sin kᵢξ),
    σᵢ = (cosh kᵢ + cos kᵢ)/(sinh kᵢ + sin kᵢ),  cos kᵢ cosh kᵢ = −1  (kᵢ = pᵢ l).

Because Φᵢ does not depend on l, every modal constant is a number times a power of l, so the length
stays a runtime parameter:

    αᵢ = ∫φᵢ dx = l^(1/2) · 2σᵢ/kᵢ            (3.62)
    βᵢ = ∫x φᵢ dx = l^(3/2) · 2/kᵢ²            (3.69)–(3.70)
    Λᵢ = ∫(φᵢ'')² dx = kᵢ⁴ / l⁴               (3.80), (B.16)
    γ = ∫φψᵀ dx = I (identical shapes in both directions, orthonormal)   (3.71)

The roots kᵢ and every constant are computed with mpmath at :data:`PRECISION` decimal digits and kept
as SymPy Floats, never through numpy, scipy or the C library (docs/contracts.md, "generated/ and make
generate").
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import mpmath
import numpy as np
import sympy as sp

from symbolic.description.robot import BOUNDARIES

PRECISION = 50
"""Decimal digits of the mode-shape constants: a double's rounding needs 17; the margin makes a
constant within 10⁻⁴⁵ of a rounding boundary the only way two precisions could print differently
(tests/test_constants.py checks that they do not)."""


@dataclass(frozen=True)
class ModeShape:
    """One normalised clamped-free mode: root k and coefficient σ (dimensionless, on ξ = x/l), as SymPy
    Floats of PRECISION digits (``float()`` of either is the double nearest to it)."""

    k: sp.Float
    sigma: sp.Float

    def shape(self, xi, derivative: int = 0):
        """Φ^(d)(ξ) for ξ = x/l, numerically (numpy; the symbolic form below, compiled once)."""
        return _compiled(self, derivative)(np.asarray(xi, dtype=float))

    def symbolic(self, xi: sp.Expr, derivative: int = 0) -> sp.Expr:
        """Φ^(d)(ξ) as a SymPy expression (for evaluation at symbolic positions)."""
        k, s = self.k, self.sigma
        kx = k * xi
        forms = {
            0: sp.cosh(kx) - sp.cos(kx) - s * (sp.sinh(kx) - sp.sin(kx)),
            1: k * (sp.sinh(kx) + sp.sin(kx) - s * (sp.cosh(kx) - sp.cos(kx))),
            2: k**2 * (sp.cosh(kx) + sp.cos(kx) - s * (sp.sinh(kx) + sp.sin(kx))),
            3: k**3 * (sp.sinh(kx) - sp.sin(kx) - s * (sp.cosh(kx) + sp.cos(kx))),
        }
        return forms[derivative]


@lru_cache(maxsize=None)
def _compiled(shape: ModeShape, derivative: int):
    xi = sp.Symbol("xi", real=True)
    return sp.lambdify(xi, shape.symbolic(xi, derivative), modules="numpy")


@lru_cache(maxsize=None)
def exact_modes(n: int, digits: int) -> tuple[ModeShape, ...]:
    """The first n clamped-free modes, kᵢ the roots of cos k cosh k = −1 (B.9), to ``digits`` digits."""
    shapes = []
    with mpmath.workdps(digits):
        for i in range(1, n + 1):
            centre = (2 * i - 1) * mpmath.pi / 2  # kᵢ → (2i − 1)π/2; |kᵢ − centre| < 0.31 for all i
            k = mpmath.findroot(lambda k: mpmath.cos(k) + 1 / mpmath.cosh(k), (centre - 1, centre + 1), solver="anderson")
            sigma = (mpmath.cosh(k) + mpmath.cos(k)) / (mpmath.sinh(k) + mpmath.sin(k))
            shapes.append(ModeShape(sp.Float(k, digits), sp.Float(sigma, digits)))
    return tuple(shapes)


def clamped_free_roots(n: int) -> tuple[float, ...]:
    """The first n roots kᵢ of cos k cosh k = −1 (B.9), each the double nearest to the exact root."""
    return tuple(float(m.k) for m in exact_modes(n, PRECISION))


def modes(n: int, boundary: str = "clamped-free") -> list[ModeShape]:
    if boundary not in BOUNDARIES:
        raise ValueError(f"boundary {boundary!r} not supported (supported: {', '.join(BOUNDARIES)})")
    return list(exact_modes(n, PRECISION))


@dataclass(frozen=True)
class ModalConstants:
    """α (3.62), β (3.69), Λ diagonal (3.80) and tip values φ(l) of n modes, in the length l."""

    alpha: tuple[sp.Expr, ...]
    beta: tuple[sp.Expr, ...]
    lam: tuple[sp.Expr, ...]
    tip: tuple[sp.Expr, ...]
    shapes: tuple[ModeShape, ...]


def modal_constants(n: int, length: sp.Expr, boundary: str = "clamped-free") -> ModalConstants:
    shapes = modes(n, boundary)
    root = sp.sqrt(length)
    alpha = tuple(root * (2 * m.sigma / m.k) for m in shapes)  # Float arithmetic at the Floats' precision
    beta = tuple(length * root * (2 / m.k**2) for m in shapes)
    lam = tuple(m.k**4 / length**4 for m in shapes)
    tip = tuple(sp.Integer(2 * (-1) ** i) / root for i in range(len(shapes)))  # Φᵢ(1) = ±2 exactly
    return ModalConstants(alpha, beta, lam, tip, tuple(shapes))


def phi(shape: ModeShape, x: sp.Expr, length: sp.Expr, derivative: int = 0) -> sp.Expr:
    """φ^(d)(x) = l^(−1/2−d) Φ^(d)(x/l) as a SymPy expression."""
    return shape.symbolic(x / length, derivative) / (sp.sqrt(length) * length**derivative)
