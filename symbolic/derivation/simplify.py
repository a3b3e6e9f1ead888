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

import math
from collections.abc import Iterable, Sequence

import sympy as sp
from sympy.polys.rings import PolyRing


def _split(term: sp.Expr, coordinates: frozenset[sp.Symbol]) -> tuple[sp.Expr, sp.Expr]:
    """(coefficient free of the coordinates, configuration-dependent factor) of a product."""
    coefficient, dependent = [], []
    for factor in sp.Mul.make_args(term):
        (dependent if factor.free_symbols & coordinates else coefficient).append(factor)
    return sp.Mul(*coefficient), sp.Mul(*dependent)


def collect_monomials(expr: sp.Expr, coordinates: Sequence[sp.Symbol]) -> dict[sp.Expr, sp.Expr]:
    """Map each configuration-dependent monomial of the expanded ``expr`` to its coefficient."""
    return _collect(sp.Add.make_args(sp.expand(expr)), coordinates)


def _collect(terms: Iterable[sp.Expr], coordinates: Sequence[sp.Symbol]) -> dict[sp.Expr, sp.Expr]:
    coords = frozenset(coordinates)
    out: dict[sp.Expr, sp.Expr] = {}
    for term in terms:
        coefficient, monomial = _split(term, coords)
        out[monomial] = out.get(monomial, 0) + coefficient
    return {m: c for m, c in out.items() if c != 0}


def reduce_pythagoras(expr: sp.Expr, eliminate: str = "sin", only: Sequence[sp.Symbol] | None = None) -> sp.Expr:
    """Canonical trigonometric polynomial: sin/cos of sums expanded, then reduced modulo
    sin² + cos² − 1 so that every angle's ``eliminate`` function appears at most linearly.
    With ``only``, just the angles that involve those symbols are reduced."""
    return sp.Add(*_reduced_terms(expr, (eliminate,), only)[0])


def trig_monomials(expr: sp.Expr, coordinates: Sequence[sp.Symbol], eliminate: str = "sin") -> dict[sp.Expr, sp.Expr]:
    """``collect_monomials(reduce_pythagoras(expr, eliminate), coordinates)``, without expanding twice."""
    return _collect(_reduced_terms(expr, (eliminate,))[0], coordinates)


def _reduced_terms(expr: sp.Expr, eliminations: Sequence[str], only: Sequence[sp.Symbol] | None = None) -> list[list[sp.Expr]]:
    """The terms of the reduced form of ``expr`` for each of ``eliminations`` ("sin" or "cos").

    The remainder modulo s² + c² − 1 (monic in s) is what replacing s^(2k+r) by s^r·(1 − c²)^k
    gives, term by term. Expressions that are polynomials over the rationals in symbols, sin/cos
    and radicals of symbols (every rigid robot's D, C, g) are expanded in a sparse polynomial ring,
    converting each shared subexpression once: the Panda's D(Q) then takes seconds where
    ``sympy.expand`` and ``sympy.rem`` took hours. Anything else (floats, other functions) takes the
    slower route through ``sympy.expand``; both give the same SymPy expression.
    """
    expr = sp.sympify(expr)
    try:
        generators, terms = _trig_polynomial(expr)
    except _NotPolynomial:
        expanded = sp.expand(sp.expand_trig(sp.expand(expr)))
        return [_reduce_expanded(expanded, eliminate, only) for eliminate in eliminations]
    out = []
    for eliminate in eliminations:
        reduced = _reduce_polynomial(generators, terms, eliminate, only)
        products = [sp.Mul(sp.QQ.to_sympy(c), *[g**k for g, k in zip(generators, m) if k]) for m, c in reduced.items()]
        out.append(list(sp.Add.make_args(sp.Add(*products))))  # canonical order: compact's groups depend on it
    return out


def _reduce_expanded(expanded: sp.Expr, eliminate: str, only: Sequence[sp.Symbol] | None) -> list[sp.Expr]:
    """:func:`_reduced_terms` on an expanded SymPy sum."""
    angles = {a.args[0] for a in expanded.atoms(sp.sin, sp.cos)}
    if only is not None:
        angles = {a for a in angles if a.free_symbols & set(only)}
    removed, kept = (sp.sin, sp.cos) if eliminate == "sin" else (sp.cos, sp.sin)
    partner = {removed(a): kept(a) for a in angles}
    terms: list[sp.Expr] = []
    for term in sp.Add.make_args(expanded):
        rest, squares = [], []
        for factor in sp.Mul.make_args(term):
            base, exponent = factor.as_base_exp()
            if base in partner and exponent.is_Integer and exponent > 1:
                half, odd = divmod(int(exponent), 2)
                squares.append((partner[base], half))
                rest.append(base**odd)
            else:
                rest.append(factor)
        products = [sp.Mul(*rest)] if squares else [term]
        for other, half in squares:  # (1 − other²)^half by the binomial theorem
            products = [p * (-1) ** i * sp.binomial(half, i) * other ** (2 * i) for p in products for i in range(half + 1)]
        terms.extend(products)
    return list(sp.Add.make_args(sp.Add(*terms)))


class _NotPolynomial(Exception):
    """The expression is outside what :func:`_trig_polynomial` handles."""


def _trig_polynomial(expr: sp.Expr) -> tuple[list[sp.Expr], dict[tuple[int, ...], object]]:
    """(generators, {exponents: rational coefficient}) of ``expr`` expanded, with sin/cos of sums
    and multiples expanded as ``sympy.expand_trig`` does. Generators are symbols, number symbols,
    sin/cos atoms (each with its partner) and b**(±1/q) for a symbol or positive integer b."""
    generators: dict[sp.Expr, None] = {}
    rewrites: dict[sp.Expr, sp.Expr] = {}
    seen: set[sp.Expr] = set()
    stack = [expr]
    while stack:
        e = stack.pop()
        if e in seen:
            continue
        seen.add(e)
        if e.is_Add or e.is_Mul:
            stack.extend(e.args)
        elif e.is_Pow:
            base, exponent = e.args
            if exponent.is_Integer and exponent > 0:
                stack.append(base)
            elif exponent.is_Rational and (base.is_Symbol or (base.is_Integer and base > 0)):
                generators[_radical(base, exponent)] = None
            else:
                raise _NotPolynomial
        elif e.is_Symbol or e.is_NumberSymbol:
            generators[e] = None
        elif isinstance(e, (sp.sin, sp.cos)):
            expanded = sp.expand(sp.expand_trig(sp.expand(e)))
            if expanded == e:
                generators[sp.sin(e.args[0])] = generators[sp.cos(e.args[0])] = None
            else:
                rewrites[e] = expanded
                stack.append(expanded)
        elif not e.is_Rational:
            raise _NotPolynomial
    ordered = sorted(generators, key=sp.default_sort_key)
    ring = PolyRing(ordered, sp.QQ)
    element = dict(zip(ordered, ring.gens))
    memo: dict[sp.Expr, object] = {}

    def convert(e: sp.Expr):
        done = memo.get(e)
        if done is not None:
            return done
        if e in element:
            out = element[e]
        elif e in rewrites:
            out = convert(rewrites[e])
        elif e.is_Add:
            out = ring.zero
            for a in e.args:
                out += convert(a)
        elif e.is_Mul:
            out = ring.one
            for a in e.args:
                out *= convert(a)
        elif e.is_Pow and e.args[1].is_Integer and e.args[1] > 0:
            out = convert(e.args[0]) ** int(e.args[1])
        elif e.is_Pow:
            out = element[_radical(*e.args)] ** abs(int(e.args[1].p))
        else:
            out = ring(sp.QQ.from_sympy(e))
        memo[e] = out
        return out

    return ordered, dict(convert(expr))


def _radical(base: sp.Expr, exponent: sp.Rational) -> sp.Expr:
    """The generator b**(±1/q) whose |p|-th power is b**(p/q)."""
    return sp.Pow(base, sp.Rational(1 if exponent > 0 else -1, exponent.q))


def _reduce_polynomial(generators: list[sp.Expr], terms: dict, eliminate: str, only: Sequence[sp.Symbol] | None) -> dict:
    """Replace s^(2k+r) by s^r·(1 − c²)^k for every angle's eliminated function s and partner c."""
    index = {g: k for k, g in enumerate(generators)}
    removed, kept = (sp.sin, sp.cos) if eliminate == "sin" else (sp.cos, sp.sin)
    pairs = []
    for g in generators:
        if isinstance(g, removed) and (only is None or g.args[0].free_symbols & set(only)):
            pairs.append((index[g], index[kept(g.args[0])]))
    out: dict[tuple[int, ...], object] = {}
    for monomial, coefficient in terms.items():
        expansion = [(list(monomial), coefficient)]
        for s, c in pairs:
            half, odd = divmod(monomial[s], 2)
            if not half:
                continue
            grown = []
            for exponents, value in expansion:
                for i in range(half + 1):
                    e = list(exponents)
                    e[s], e[c] = odd, e[c] + 2 * i
                    grown.append((e, value * (-1) ** i * math.comb(half, i)))
            expansion = grown
        for exponents, value in expansion:
            key = tuple(exponents)
            total = out.get(key, 0) + value
            if total:
                out[key] = total
            else:
                out.pop(key, None)
    return out


SIZE_LIMIT = 40_000
"""Expanded entries larger than this (:func:`tree_size`) are not compacted or analysed by the command
line: the largest of the Panda's D(Q) (16,169) takes seconds, one of its Coriolis rows (57,000–274,000)
minutes and gigabytes."""


def tree_size(expr: sp.Expr) -> int:
    """Nodes of the expression tree, a shared subexpression counted at every use: what expanding
    costs. Linear in the distinct subexpressions (SymPy's ``count_ops`` walks every use)."""
    memo: dict[sp.Expr, int] = {}

    def size(e: sp.Expr) -> int:
        done = memo.get(e)
        if done is None:
            done = memo[e] = 1 + sum(size(a) for a in e.args)
        return done

    return size(sp.sympify(expr))


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
    for terms in _reduced_terms(expr, ("sin", "cos")):
        form = _assemble(_collect(terms, coordinates))
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
