"""Milne et al.'s minimal yaw-axis inertia model (6), obtained from a derived model's D(Q).

    I = I_base + I₁ cos²γ₁ + I₂ cos²a + I₃ cos γ₁ cos a,   a = π − γ₁ − γ₂ − γ_offs      Milne (6), (27)

:func:`inertia_form` brings the diagonal entry D[j, j] of any derived model into this form (a is the
elevation of link 2) and returns its four coefficients in the model's parameters (an
:class:`InertiaForm`); an entry of another form is refused with a :class:`~symbolic.errors.ModelError`
naming the offending terms. For the built-in ``omni`` (thin rods, Milne (5)): I₁ = m₁L₁²/3 + m₂L₁²,
I₂ = m₂L₂²/3, I₃ = m₂L₁L₂. How the form is recognised: docs/seeds.md, "Milne: sinusoidal identification
and the inertia model".
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.simplify import trig_monomials
from symbolic.errors import ModelError
from symbolic.errors import one_line as _one_line

LINK2_ELEVATION = sp.Symbol("a", real=True)
"""Milne's a = π − γ₁ − γ₂ − γ_offs, the elevation of link 2 (a fresh symbol in the extraction)."""


@dataclass(frozen=True)
class InertiaForm:
    """D[j, j] = I_base + I₁ cos²γ₁ + I₂ cos²a + I₃ cos γ₁ cos a with a = π − γ₁ − γ₂ − γ_offs (Milne (6)).

    Attributes
    ----------
    coordinate, gamma1, gamma2
        The coordinate j (the yaw axis) and the two arm angles.
    offset
        γ_offs: a parameter symbol of the model, or 0.
    base, i1, i2, i3
        I_base, I₁, I₂, I₃ as expressions of the model's parameters.
    """

    coordinate: sp.Symbol
    gamma1: sp.Symbol
    gamma2: sp.Symbol
    offset: sp.Expr
    base: sp.Expr
    i1: sp.Expr
    i2: sp.Expr
    i3: sp.Expr

    @property
    def coefficients(self) -> tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr]:
        """(I_base, I₁, I₂, I₃)."""
        return self.base, self.i1, self.i2, self.i3

    def link2_elevation(self) -> sp.Expr:
        """a = π − γ₁ − γ₂ − γ_offs (Milne (27))."""
        return sp.pi - self.gamma1 - self.gamma2 - self.offset

    def expression(self) -> sp.Expr:
        """The right-hand side of Milne (6) in γ₁, γ₂ and the parameters."""
        c1, ca = sp.cos(self.gamma1), sp.cos(self.link2_elevation())
        return self.base + self.i1 * c1**2 + self.i2 * ca**2 + self.i3 * c1 * ca

    def values(self, parameters: Mapping[sp.Symbol, float]) -> tuple[float, float, float, float]:
        """(I_base, I₁, I₂, I₃) at the parameter values (e.g. ``model.parameters``)."""
        return tuple(float(c.subs(dict(parameters))) for c in self.coefficients)  # type: ignore[return-value]


def inertia_form(model: DynamicModel, coordinate: str, gamma1: str, gamma2: str, offset: str | None = None) -> InertiaForm:
    """D[coordinate, coordinate] of ``model`` in Milne's form (6), coefficients as parameter expressions.

    Parameters
    ----------
    model
        A derived model (:func:`symbolic.derivation.derive`).
    coordinate
        The axis whose inertia is modelled (the Omni's yaw, ``theta``).
    gamma1, gamma2
        The coordinates γ₁ and γ₂ of Milne's Fig. 1.
    offset
        The model parameter that plays γ_offs (``gamma_offs`` in the built-in ``omni``), or None for 0.

    Raises
    ------
    ModelError
        An unknown coordinate or parameter, or a D[j, j] that is not of the form (6): the message lists
        the terms that are not (monomials and their coefficients) or the symbols left over.
    """
    names = [str(c) for c in model.coordinates]
    source, key = model.name, f"D[{coordinate}, {coordinate}]"
    for role, name in (("coordinate", coordinate), ("gamma1", gamma1), ("gamma2", gamma2)):
        if name not in names:
            raise ModelError(source, role, f"unknown coordinate {name!r} (the model's coordinates: {', '.join(names)})")
    if len({coordinate, gamma1, gamma2}) != 3:
        raise ModelError(source, "coordinates", f"coordinate, gamma1 and gamma2 must differ, got {coordinate!r}, "
                                                f"{gamma1!r}, {gamma2!r}")
    j = names.index(coordinate)
    q, g1, g2 = model.coordinates[j], model.coordinates[names.index(gamma1)], model.coordinates[names.index(gamma2)]
    off = _offset(model, offset)
    a = LINK2_ELEVATION
    entry = model.D[j, j].subs(g2, sp.pi - g1 - a - off)
    monomials = trig_monomials(entry, [g1, a])
    expected = {
        sp.Integer(1): "base",
        sp.cos(g1) ** 2: "i1",
        sp.cos(a) ** 2: "i2",
        sp.cos(g1) * sp.cos(a): "i3",
    }
    found = {name: sp.Integer(0) for name in expected.values()}
    stray = []
    for monomial, coefficient in monomials.items():
        coefficient = sp.expand(coefficient)
        if coefficient == 0:
            continue
        if monomial in expected:
            found[expected[monomial]] = coefficient
        else:
            stray.append(f"{monomial}·({shorten_text(str(coefficient))})")
    if stray:
        raise ModelError(source, key, f"not of Milne's form (6) I_base + I1 cos²{gamma1} + I2 cos²a + I3 cos {gamma1} "
                                      f"cos a with a = π − {gamma1} − {gamma2} − {offset or 0}: other terms "
                                      f"{'; '.join(sorted(stray)[:3])}{f' and {len(stray) - 3} more' if len(stray) > 3 else ''}")
    leftover = set().union(*(c.free_symbols for c in found.values())) & (set(model.coordinates) | {a, off} - {0})
    if leftover:
        raise ModelError(source, key, f"not of Milne's form (6): the coefficients depend on "
                                      f"{', '.join(sorted(map(str, leftover)))} (they must be constants)")
    return InertiaForm(q, g1, g2, off, found["base"], found["i1"], found["i2"], found["i3"])


def shorten_text(text: str, limit: int = 60) -> str:
    """``text`` cut to ``limit`` characters with an ellipsis (a coefficient in a one-line message)."""
    return _one_line(text) if len(text) <= limit else _one_line(text[:limit]) + "…"


def _offset(model: DynamicModel, offset: str | None) -> sp.Expr:
    if offset is None:
        return sp.Integer(0)
    by_name = {str(p): p for p in model.parameter_symbols}
    if offset not in by_name:
        raise ModelError(model.name, "offset", f"unknown parameter {offset!r} (the model's parameters: "
                                               f"{', '.join(by_name)})")
    return by_name[offset]
