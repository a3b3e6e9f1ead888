"""Named intermediate expressions with chain-rule differentiation.

:class:`Subexpressions` registers each non-trivial quantity of a derivation (a rotated vector component,
a composite-inertia entry, a Jacobian column) under a fresh symbol ``_x<n>`` with its short definition,
sharing identical definitions; outputs are short expressions in these symbols, the definitions a
straight-line program that code generators print. Derivatives in coordinates and velocities are taken by
the chain rule through the definitions (forward mode, memoized; d sign(v)/dv = 0);
:meth:`Subexpressions.expand` gives the fully expanded SymPy form. Why: docs/architecture.md,
"Intermediate symbols".
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import sympy as sp
from sympy.core.exprtools import decompose_power
from sympy.core.function import _coeff_isneg
from sympy.core.operations import LatticeOp
from sympy.simplify.radsimp import fraction


def _is_trivial(expr: sp.Expr) -> bool:
    """Cheap enough to repeat inline: numbers, symbols and number·symbol."""
    if expr.is_Atom:
        return True
    if expr.is_Mul and len(expr.args) == 2 and expr.args[0].is_Number and expr.args[1].is_Atom:
        return True
    return False


def partial(expr: sp.Expr, symbol: sp.Symbol) -> sp.Expr:
    """``expr.diff(symbol)``: the same SymPy expression, built without SymPy's ``Derivative`` for sums and products.

    SymPy differentiates a sum term by term (``Add._eval_derivative``) and a product by Leibniz's rule
    (``Mul._eval_derivative_n_times`` with n = 1: one product per factor, that factor differentiated, summed
    with ``Add``); here the same products and sums are built from the same arguments, so the result is the
    same expression. What is saved is ``Derivative.__new__``, which SymPy runs at every node (checks,
    dispatch, a final ``replace`` over the result): about two thirds of differentiating the short definitions
    of a derivation (∂D/∂Q of a 20-axis chain: 15,000 intermediates). Other heads (sin, cos, powers, sign, …)
    are left to SymPy's ``diff``.
    """
    if symbol not in expr.free_symbols:
        return sp.S.Zero
    if expr.is_Symbol:  # the symbol itself: its free symbols hold it
        return sp.S.One
    if expr.is_Add:
        return sp.Add(*[partial(a, symbol) for a in expr.args])
    if expr.is_Mul and expr.is_commutative:
        args = expr.args
        return sp.Add(*[sp.Mul(*args[:i], partial(a, symbol), *args[i + 1:]) for i, a in enumerate(args)])
    return expr.diff(symbol)


def symbols_in(expr: sp.Basic) -> set[sp.Symbol]:
    """``expr.free_symbols``, collected by one walk instead of SymPy's union of sets at every node (sums, products,
    powers and functions hold no bound symbols; anything else answers for itself)."""
    out: set[sp.Symbol] = set()
    stack = [expr]
    while stack:
        node = stack.pop()
        if node.is_Symbol:
            out.add(node)
        elif node.is_Add or node.is_Mul or node.is_Pow or node.is_Function:
            stack.extend(node.args)
        elif not node.is_Atom:
            out |= node.free_symbols
    return out


def extracts_minus_sign(expr: sp.Expr) -> bool:
    """``expr.could_extract_minus_sign()``, the same answer, without building ``-expr`` and sort keys where it can.

    SymPy answers for a product by comparing it with its negation (``self == -self``, only ever true with a
    ``zoo`` or ``nan`` coefficient, which is not negative), so: whether its leading coefficient is a negative number.
    For a sum it counts the terms that could extract one; on a tie it compares the sort keys of the sum and its
    negation (``_could_extract_minus_sign``), which is what costs: a third of differentiating a chain's ∂D/∂Q.
    Those keys list the terms in the order of ``as_ordered_terms``, the greatest monomial first (lexicographic
    over the factors' bases in SymPy's default order), and negating a sum negates each term in place, so the two
    keys differ first at the leading term's coefficient c, compared with −c: the sum extracts a minus sign when
    c < 0. That holds when no term is a number and no factor is a number beyond the leading coefficient (SymPy
    orders such sums by a special case or folds the numbers into the coefficients) and the monomials are
    distinct (no tie left to the coefficients); anything else is left to SymPy.
    """
    if expr.is_Mul:
        c = expr.args[0]
        return bool(c.is_Number and c.is_extended_negative)
    if not expr.is_Add:
        return expr.could_extract_minus_sign()
    negative = 0
    for term in expr.args:
        if term.is_Mul:
            c = term.args[0]
            negative += bool(c.is_Number and c.is_extended_negative)
        elif not term.is_Symbol:
            negative += bool(term.could_extract_minus_sign())
    positive = len(expr.args) - negative
    if positive != negative:
        return negative > positive
    leading = _leading_coefficient(expr)
    if leading is None:
        return expr.could_extract_minus_sign()
    return bool(leading < 0)


def _leading_coefficient(expr: sp.Add) -> sp.Number | None:
    """The numeric coefficient of ``expr.as_ordered_terms()[0]`` where :func:`extracts_minus_sign` may use it."""
    monomials = []
    bases: set[sp.Expr] = set()
    for term in expr.args:
        if term.is_Number or term.is_NumberSymbol or not term.is_commutative:
            return None
        coeff, rest = term.as_coeff_Mul()
        powers = {}
        for factor in sp.Mul.make_args(rest):
            if factor.is_number or not factor.is_commutative:
                return None
            base, exponent = decompose_power(factor)
            powers[base] = exponent
            bases.add(base)
        monomials.append((coeff, powers))
    order = sorted(bases, key=sp.default_sort_key)
    keyed = [(tuple(powers.get(b, 0) for b in order), coeff) for coeff, powers in monomials]
    if len({k for k, _ in keyed}) != len(keyed):
        return None
    return max(keyed, key=lambda kc: kc[0])[1]


class Subexpressions:
    """An ordered registry of intermediate symbols and their definitions.

    Parameters
    ----------
    variables
        Symbols that derivatives may be taken with respect to (coordinates and velocities).
    prefix
        Name prefix of the intermediate symbols; it cannot clash with user names, which must
        start with a letter.
    """

    def __init__(self, variables: Iterable[sp.Symbol], prefix: str = "_x") -> None:
        self.variables = frozenset(variables)
        self.prefix = prefix
        self.symbols: list[sp.Symbol] = []
        self.definition: dict[sp.Symbol, sp.Expr] = {}
        self.depends: dict[sp.Symbol, frozenset[sp.Symbol]] = {}
        self._index: dict[sp.Expr, sp.Symbol] = {}
        self._derivatives: dict[tuple[sp.Symbol, sp.Symbol], sp.Expr] = {}
        self._expanded: dict[sp.Symbol, sp.Expr] = {}
        self._memo = _Memo()

    def __getstate__(self) -> dict:
        """Everything but the memo of partial derivatives and operation counts (rebuilt on use)."""
        state = dict(self.__dict__)
        state.pop("_memo", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._memo = _Memo()

    def __len__(self) -> int:
        return len(self.symbols)

    def copy(self) -> Subexpressions:
        """An independent registry with the same intermediates, numbering and memos (expressions are shared:
        SymPy's are immutable), which the copy may extend without changing this one."""
        other = Subexpressions(self.variables, self.prefix)
        other.symbols = list(self.symbols)
        other.definition = dict(self.definition)
        other.depends = dict(self.depends)
        other._index = dict(self._index)
        other._derivatives = dict(self._derivatives)
        other._expanded = dict(self._expanded)
        other._memo = self._memo  # facts about expressions, whichever registry holds them
        return other

    def __contains__(self, symbol: object) -> bool:
        return symbol in self.definition

    # -- registration --------------------------------------------------------------------
    def add(self, expr: sp.Expr | float | int) -> sp.Expr:
        """Return a symbol standing for ``expr`` (or ``expr`` itself when it is trivial)."""
        expr = sp.sympify(expr)
        if _is_trivial(expr):
            return expr
        if extracts_minus_sign(expr):
            # store −a·b as a·b used negated: the sign folds into the sums that use it for free
            return -self.add(-expr)
        existing = self._index.get(expr)
        if existing is not None:
            return existing
        symbol = sp.Symbol(f"{self.prefix}{len(self.symbols)}", real=True)
        self.symbols.append(symbol)
        self.definition[symbol] = expr
        self.depends[symbol] = self.dependencies(expr)
        self._index[expr] = symbol
        return symbol

    def dependencies(self, expr: sp.Expr) -> frozenset[sp.Symbol]:
        """The variables ``expr`` depends on, through intermediates."""
        out: set[sp.Symbol] = set()
        for s in self._memo.free(expr):
            if s in self.variables:
                out.add(s)
            elif s in self.depends:
                out |= self.depends[s]
        return frozenset(out)

    # -- differentiation -----------------------------------------------------------------
    def diff(self, expr: sp.Expr, variable: sp.Symbol) -> sp.Expr:
        """∂expr/∂variable by the chain rule through intermediate definitions."""
        expr = sp.sympify(expr)
        terms = []
        for s in self._memo.symbols(expr):
            if s == variable:
                ds: sp.Expr = sp.Integer(1)
            elif s in self.definition:
                ds = self.derivative(s, variable)
            else:
                continue
            if ds != 0:
                terms.append(self._memo.partial(expr, s) * ds)
        result = sp.Add(*terms)
        if result.has(sp.DiracDelta):
            # d sign(v)/dv = 2δ(v): friction laws are differentiated away from v = 0, where it vanishes
            result = result.replace(sp.DiracDelta, lambda *args: sp.Integer(0))
        return result

    def derivative(self, symbol: sp.Symbol, variable: sp.Symbol) -> sp.Expr:
        """∂symbol/∂variable for an intermediate ``symbol`` (memoized and registered)."""
        if variable not in self.depends[symbol]:
            return sp.Integer(0)
        key = (symbol, variable)
        if key not in self._derivatives:
            self._derivatives[key] = self.add(self.diff(self.definition[symbol], variable))
        return self._derivatives[key]

    # -- expansion and programs ----------------------------------------------------------
    def expand(self, expr: sp.Expr) -> sp.Expr:
        """Substitute all intermediates in ``expr`` by their full definitions."""
        expr = sp.sympify(expr)
        pending = [s for s in expr.free_symbols if s in self.definition and s not in self._expanded]
        if pending:
            for s in self.program_symbols(pending):
                if s not in self._expanded:
                    d = self.definition[s]
                    self._expanded[s] = d.xreplace({t: self._expanded[t] for t in d.free_symbols if t in self.definition})
        return expr.xreplace({s: self._expanded[s] for s in expr.free_symbols if s in self.definition})

    def program_symbols(self, roots: Iterable[sp.Symbol]) -> list[sp.Symbol]:
        """The intermediates needed to compute ``roots``, in definition order."""
        needed: set[sp.Symbol] = set()
        stack = [s for s in roots if s in self.definition]
        while stack:
            s = stack.pop()
            if s in needed:
                continue
            needed.add(s)
            stack.extend(t for t in self._memo.free(self.definition[s]) if t in self.definition and t not in needed)
        return sorted(needed, key=lambda s: int(s.name[len(self.prefix):]))

    def program(self, outputs: Sequence[sp.Expr]) -> list[tuple[sp.Symbol, sp.Expr]]:
        """The (symbol, definition) pairs needed to evaluate ``outputs``, in order."""
        roots: set[sp.Symbol] = set()
        for e in outputs:
            roots |= sp.sympify(e).free_symbols
        return [(s, self.definition[s]) for s in self.program_symbols(roots)]

    def count_ops(self, outputs: Sequence[sp.Expr]) -> int:
        """Arithmetic operations (SymPy's ``count_ops``, :func:`count_operations`) of the program computing ``outputs``."""
        total = sum(self._memo.operations(d) for _, d in self.program(outputs))
        return int(total + sum(count_operations(sp.sympify(e)) for e in outputs))


class _Memo:
    """What a derivation asks again and again of the same expressions: their free symbols in SymPy's order, their
    partial derivatives by one symbol, their operation counts. Each depends on the expression alone (SymPy's are
    immutable), so registries that share expressions share it (:meth:`Subexpressions.copy`).

    A definition is differentiated by up to 2N variables, each time by the chain rule through the same free
    symbols: the partial derivatives by those symbols are taken once (∂τ/∂(q, q̇) of a 20-axis chain asks for
    each about 20 times); ∂τ/∂q̇'s two forms are compared by the counts of programs that share most definitions.
    """

    def __init__(self) -> None:
        self._free: dict[sp.Expr, frozenset[sp.Symbol]] = {}
        self._symbols: dict[sp.Expr, list[sp.Symbol]] = {}
        self._partials: dict[tuple[sp.Expr, sp.Symbol], sp.Expr] = {}
        self._operations: dict[sp.Expr, int] = {}

    def free(self, expr: sp.Expr) -> frozenset[sp.Symbol]:
        """``expr.free_symbols`` (:func:`symbols_in`; SymPy's walks the whole expression each time it is asked)."""
        found = self._free.get(expr)
        if found is None:
            found = self._free[expr] = frozenset(symbols_in(expr))
        return found

    def symbols(self, expr: sp.Expr) -> list[sp.Symbol]:
        """``expr``'s free symbols sorted by SymPy's default sort key."""
        found = self._symbols.get(expr)
        if found is None:
            found = self._symbols[expr] = sorted(self.free(expr), key=sp.default_sort_key)
        return found

    def partial(self, expr: sp.Expr, symbol: sp.Symbol) -> sp.Expr:
        """:func:`partial` (``expr.diff(symbol)``)."""
        key = (expr, symbol)
        found = self._partials.get(key)
        if found is None:
            found = self._partials[key] = partial(expr, symbol)
        return found

    def operations(self, expr: sp.Expr) -> int:
        """:func:`count_operations`."""
        found = self._operations.get(expr)
        if found is None:
            found = self._operations[expr] = count_operations(expr)
        return found


def count_operations(expr: sp.Expr) -> int:
    """``sympy.count_ops(expr)``, the same number, counted in integers.

    SymPy's ``count_ops`` (visual=False) collects one symbol per operation (ADD, MUL, NEG, SIN, …), sums them
    symbolically and returns the sum of the coefficients; that sum is linear, so adding 1 per symbol as this
    walk (the same walk, branch for branch) meets it gives the same count without the symbolic arithmetic,
    which was a fifth of printing a large model's C. Expressions other than SymPy ``Expr`` go to SymPy.
    """
    if not isinstance(expr, sp.Expr) or expr.is_Relational:
        return int(sp.count_ops(expr))
    total = 0
    args = [expr]
    while args:
        a = args.pop()
        if a.is_Rational:
            if a is not sp.S.One:
                total += (a.p < 0) + (a.q != 1)  # NEG, DIV
                continue
        elif a.is_Mul:
            if _coeff_isneg(a):
                total += 1  # NEG
                a = a.as_two_terms()[1] if a.args[0] is sp.S.NegativeOne else -a
            n, d = _fraction(a)
            if n.is_Integer:
                total += 1 + bool(n < 0)  # DIV (and NEG)
                args.append(d)
                continue
            if d is not sp.S.One:
                if not d.is_Integer:
                    args.append(d)
                total += 1  # DIV
                args.append(n)
                continue
        elif a.is_Add:
            negatives = 0
            for ai in a.args:
                if _coeff_isneg(ai):
                    negatives += 1
                    args.append(-ai)
                else:
                    args.append(ai)
            # an ADD or SUB between terms; NEG when all are negative (a leading negative turns an ADD into a SUB)
            total += len(a.args) - 1 + (negatives == len(a.args))
            continue
        if a.is_Pow and a.exp is sp.S.NegativeOne:
            total += 1  # DIV
            args.append(a.base)
            continue
        if a == sp.S.Exp1:
            total += 1  # EXP
            continue
        if a.is_Pow and a.base == sp.S.Exp1:
            total += 1  # EXP
            args.append(a.exp)
            continue
        if a.is_Mul or isinstance(a, LatticeOp):
            total += len(a.args) - 1  # MUL (MAX, MIN)
        elif a.args and (a.is_Pow or a.is_Function or isinstance(a, (sp.Derivative, sp.Integral, sp.Sum))):
            total += 1  # POW, SIN, ...
        if not a.is_Symbol:
            args.extend(a.args)
    return total


def _fraction(expr: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
    """SymPy's ``fraction(expr)``, without its rebuilding of a product that has no denominator.

    ``fraction`` sorts every factor into numerator or denominator and multiplies each list again; a factor goes
    to the denominator only if it is a power (or ``exp``) or a non-integer rational, so a product without such a
    factor is its own numerator over 1 (``Mul(*expr.args)`` is ``expr``), the same answer without building it.
    """
    for term in (expr.args if expr.is_Mul else (expr,)):
        if term.is_Pow or isinstance(term, sp.exp) or (term.is_Rational and not term.is_Integer):
            return fraction(expr)
    return expr, sp.S.One
