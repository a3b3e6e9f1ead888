"""Compact, reviewer-readable forms of derived expressions.

Full ``simplify`` is slow and tends to fold terms into sin/cos of angle sums that are expensive to
evaluate; reviewers instead want each entry as a sum of configuration-dependent trigonometric
monomials with collected parameter coefficients — the way Madill writes (4.10):

    D₀₀ = α₁C₁² + α₂C₂² + 2α₃C₁C₂,   D₁₂ = α₃C₂₋₁.

:func:`compact` expands trigonometric functions of sums, collects by trigonometric monomial,
replaces sin² by 1 − cos² where that shortens the entry, and folds groups of monomials that share a
coefficient (e.g. C₁C₂ + S₁S₂ → cos(q₁ − q₂)). It is for reports and analysis; code generation uses
the un-simplified intermediate forms, which are already short after common-subexpression elimination.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp


def _split(term: sp.Expr, coordinates: frozenset[sp.Symbol]) -> tuple[sp.Expr, sp.Expr]:
    """(coefficient free of the coordinates, configuration-dependent factor) of a product."""
    coefficient, dependent = [], []
    for factor in sp.Mul.make_args(term):
        (dependent if factor.free_symbols & coordinates else coefficient).append(factor)
    return sp.Mul(*coefficient), sp.Mul(*dependent)


def collect_monomials(expr: sp.Expr, coordinates: Sequence[sp.Symbol]) -> dict[sp.Expr, sp.Expr]:
    """Map each configuration-dependent monomial of the expanded ``expr`` to its coefficient."""
    coords = frozenset(coordinates)
    out: dict[sp.Expr, sp.Expr] = {}
    for term in sp.Add.make_args(sp.expand(expr)):
        coefficient, monomial = _split(term, coords)
        out[monomial] = out.get(monomial, 0) + coefficient
    return {m: c for m, c in out.items() if c != 0}


def _pythagoras(expr: sp.Expr, coordinates: Sequence[sp.Symbol]) -> sp.Expr:
    """Replace sin(q)² by 1 − cos(q)² for each coordinate."""
    rule = {sp.sin(q) ** 2: 1 - sp.cos(q) ** 2 for q in coordinates}
    return sp.expand(expr.subs(rule))


def compact(expr: sp.Expr, coordinates: Sequence[sp.Symbol]) -> sp.Expr:
    """A collected form of ``expr``: Σ (parameter coefficient) × (trigonometric factor).

    Parameters
    ----------
    expr
        A SymPy expression in coordinates and parameters.
    coordinates
        The generalized coordinates (the symbols that make a factor configuration-dependent).
    """
    expanded = sp.expand(sp.expand_trig(sp.sympify(expr)))
    candidates = [expanded, _pythagoras(expanded, coordinates)]
    best = None
    for candidate in candidates:
        form = _assemble(collect_monomials(candidate, coordinates))
        if best is None or sp.count_ops(form) < sp.count_ops(best):
            best = form
    return best


def _assemble(monomials: dict[sp.Expr, sp.Expr]) -> sp.Expr:
    groups: dict[sp.Expr, list[sp.Expr]] = {}
    for monomial, coefficient in monomials.items():
        groups.setdefault(sp.expand(coefficient), []).append(monomial)
    # a group and its negative (e.g. α(C₁C₂) and −α(S₁S₂)) fold together too
    terms = []
    for coefficient, members in sorted(groups.items(), key=lambda kv: sp.default_sort_key(kv[0])):
        factor = sp.Add(*members)
        if len(members) > 1:
            factor = sp.trigsimp(factor)
        terms.append(sp.factor_terms(coefficient) * factor)
    return sp.Add(*terms)


def compact_matrix(matrix: sp.Matrix, coordinates: Sequence[sp.Symbol]) -> sp.Matrix:
    """:func:`compact` applied entry by entry."""
    return matrix.applyfunc(lambda e: compact(e, coordinates))


def trig_zero(expr: sp.Expr) -> bool:
    """Whether ``expr`` is identically zero as a trigonometric polynomial.

    Expands sin/cos of sums into products of sin/cos of single angles, writes them as polynomial
    variables s_a, c_a and reduces modulo s_a² + c_a² − 1 (the remainder is linear in each s_a,
    a canonical form), which decides the identity exactly — no numerical sampling.
    """
    expanded = sp.expand(sp.expand_trig(sp.expand(sp.sympify(expr))))
    angles = sorted({a.args[0] for a in expanded.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    if not angles:
        return sp.simplify(expanded) == 0
    names = {}
    for k, a in enumerate(angles):
        names[sp.sin(a)] = sp.Symbol(f"_s{k}")
        names[sp.cos(a)] = sp.Symbol(f"_c{k}")
    poly = sp.expand(expanded.xreplace(names))
    for k in range(len(angles)):
        s, c = sp.Symbol(f"_s{k}"), sp.Symbol(f"_c{k}")
        poly = sp.expand(sp.rem(poly, s**2 + c**2 - 1, s))
    return sp.simplify(poly) == 0
