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


def reduce_pythagoras(expr: sp.Expr, eliminate: str = "sin", only: Sequence[sp.Symbol] | None = None) -> sp.Expr:
    """Canonical trigonometric polynomial: sin/cos of sums expanded, then reduced modulo
    sin² + cos² − 1 so that every angle's ``eliminate`` function appears at most linearly.
    With ``only``, just the angles that involve those symbols are reduced."""
    expanded = sp.expand(sp.expand_trig(sp.expand(sp.sympify(expr))))
    angles = {a.args[0] for a in expanded.atoms(sp.sin, sp.cos)}
    if only is not None:
        angles = {a for a in angles if a.free_symbols & set(only)}
    angles = sorted(angles, key=sp.default_sort_key)
    if not angles:
        return expanded
    names, back = {}, {}
    for k, a in enumerate(angles):
        s_k, c_k = sp.Symbol(f"_s{k}"), sp.Symbol(f"_c{k}")
        names[sp.sin(a)], names[sp.cos(a)] = s_k, c_k
        back[s_k], back[c_k] = sp.sin(a), sp.cos(a)
    poly = sp.expand(expanded.xreplace(names))
    for k in range(len(angles)):
        s_k, c_k = sp.Symbol(f"_s{k}"), sp.Symbol(f"_c{k}")
        poly = sp.expand(sp.rem(poly, s_k**2 + c_k**2 - 1, s_k if eliminate == "sin" else c_k))
    return sp.expand(poly.xreplace(back))


def compact(expr: sp.Expr, coordinates: Sequence[sp.Symbol]) -> sp.Expr:
    """A collected form of ``expr``: Σ (parameter coefficient) × (trigonometric factor).

    Parameters
    ----------
    expr
        A SymPy expression in coordinates and parameters.
    coordinates
        The generalized coordinates (the symbols that make a factor configuration-dependent).
    """
    best = None
    for eliminate in ("sin", "cos"):
        form = _assemble(collect_monomials(reduce_pythagoras(expr, eliminate), coordinates))
        if best is None or sp.count_ops(form) < sp.count_ops(best):
            best = form
    return best


def fold_angle_sum(expr: sp.Expr) -> sp.Expr:
    """k·(C_aC_b ∓ S_aS_b) → k·cos(a ± b) and k·(S_aC_b ± C_aS_b) → k·sin(a ± b); anything else unchanged.

    A targeted replacement for ``trigsimp`` (which takes a fifth of a second per call)."""
    common, rest = sp.factor_terms(expr).as_coeff_Mul()
    parts = sp.Mul.make_args(rest)
    total = [x for x in parts if x.is_Add]
    if len(total) != 1:
        return expr
    inner = total[0]
    outer = common * sp.Mul(*[x for x in parts if not x.is_Add])
    angles = sorted({a.args[0] for a in inner.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    if len(angles) != 2 or len(inner.args) != 2:
        return expr
    a, b = angles
    for candidate in (sp.cos(a - b), sp.cos(a + b), sp.sin(a + b), sp.sin(a - b)):
        identity = sp.expand(sp.expand_trig(candidate))
        if sp.expand(identity - inner) == 0:
            return outer * candidate
        if sp.expand(identity + inner) == 0:
            return -outer * candidate
    return expr


def _assemble(monomials: dict[sp.Expr, sp.Expr]) -> sp.Expr:
    """Σ coefficient × (sum of monomials sharing it up to sign), each sum folded by trigsimp
    (C₁C₂ + S₁S₂ → cos(q₁ − q₂), S₁C₂ − C₁S₂ → sin(q₁ − q₂)). Coefficients keep the sign they
    come with, so α₃ = m₃l_c3l₂ − m_r l_cr l₁ stays recognisable."""
    groups: dict[sp.Expr, list[tuple[sp.Expr, sp.Expr]]] = {}
    for monomial, coefficient in monomials.items():
        coefficient = sp.expand(coefficient)
        key = -coefficient if coefficient.could_extract_minus_sign() else coefficient
        groups.setdefault(key, []).append((monomial, coefficient))
    terms = []
    for _, members in sorted(groups.items(), key=lambda kv: sp.default_sort_key(kv[0])):
        lead = members[0][1]
        factor = sp.Add(*[m * sp.cancel(c / lead) for m, c in members])
        if len(members) == 2:
            factor = fold_angle_sum(factor)
        terms.append(sp.factor_terms(lead) * factor)
    return sp.Add(*terms)


def trig_zero(expr: sp.Expr) -> bool:
    """Whether ``expr`` is identically zero as a trigonometric polynomial.

    The canonical form of :func:`reduce_pythagoras` (linear in each sine) is zero exactly when the
    expression is — an exact decision, no numerical sampling.
    """
    return sp.simplify(reduce_pythagoras(expr)) == 0
