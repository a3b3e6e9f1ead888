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

The roots kᵢ are found by Brent's method on cos k + 1/cosh k = 0 (the same equation without overflow),
to machine precision; the closed forms above are checked against quadrature in the tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import sympy as sp
from scipy.optimize import brentq

from symbolic.spec.robot import BOUNDARIES


@lru_cache(maxsize=None)
def clamped_free_roots(n: int) -> tuple[float, ...]:
    """The first n roots kᵢ of cos k cosh k = −1 (B.9)."""
    roots = []
    for i in range(1, n + 1):
        centre = (2 * i - 1) * np.pi / 2
        roots.append(brentq(lambda k: np.cos(k) + 1.0 / np.cosh(k), centre - 1.0, centre + 1.0, xtol=1e-15, rtol=8.9e-16, maxiter=200))
    return tuple(roots)


@dataclass(frozen=True)
class ModeShape:
    """One normalised clamped-free mode: root k and coefficient σ (dimensionless, on ξ = x/l)."""

    k: float

    @property
    def sigma(self) -> float:
        k = self.k
        return (np.cosh(k) + np.cos(k)) / (np.sinh(k) + np.sin(k))

    def shape(self, xi, derivative: int = 0):
        """Φ^(d)(ξ) for ξ = x/l, numerically (numpy; the symbolic form below, compiled once)."""
        return _compiled(self.k, derivative)(np.asarray(xi, dtype=float))

    def symbolic(self, xi: sp.Expr, derivative: int = 0) -> sp.Expr:
        """Φ^(d)(ξ) as a SymPy expression (for evaluation at symbolic positions)."""
        k, s = sp.Float(self.k, 17), sp.Float(self.sigma, 17)
        kx = k * xi
        forms = {
            0: sp.cosh(kx) - sp.cos(kx) - s * (sp.sinh(kx) - sp.sin(kx)),
            1: k * (sp.sinh(kx) + sp.sin(kx) - s * (sp.cosh(kx) - sp.cos(kx))),
            2: k**2 * (sp.cosh(kx) + sp.cos(kx) - s * (sp.sinh(kx) + sp.sin(kx))),
            3: k**3 * (sp.sinh(kx) - sp.sin(kx) - s * (sp.cosh(kx) + sp.cos(kx))),
        }
        return forms[derivative]


@lru_cache(maxsize=None)
def _compiled(k: float, derivative: int):
    xi = sp.Symbol("xi", real=True)
    return sp.lambdify(xi, ModeShape(k).symbolic(xi, derivative), modules="numpy")


def modes(n: int, boundary: str = "clamped-free") -> list[ModeShape]:
    if boundary not in BOUNDARIES:
        raise ValueError(f"boundary {boundary!r} not supported (supported: {', '.join(BOUNDARIES)})")
    return [ModeShape(k) for k in clamped_free_roots(n)]


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
    alpha = tuple(root * sp.Float(2 * m.sigma / m.k, 17) for m in shapes)
    beta = tuple(length * root * sp.Float(2 / m.k**2, 17) for m in shapes)
    lam = tuple(sp.Float(m.k**4, 17) / length**4 for m in shapes)
    tip = tuple(sp.Integer(2 * (-1) ** i) / root for i in range(len(shapes)))  # Φᵢ(1) = ±2 exactly
    return ModalConstants(alpha, beta, lam, tip, tuple(shapes))


def phi(shape: ModeShape, x: sp.Expr, length: sp.Expr, derivative: int = 0) -> sp.Expr:
    """φ^(d)(x) = l^(−1/2−d) Φ^(d)(x/l) as a SymPy expression."""
    return shape.symbolic(x / length, derivative) / (sp.sqrt(length) * length**derivative)
