"""C99 printing of generated expressions (a subclass of SymPy's C99CodePrinter).

Coordinates, velocities, accelerations, torques and parameters print as array slots by table
(``q[0]``, ``p[5]``); exact decimals print as the same decimal (33/400 → ``0.0825``); small integer
powers print as products (``x*x``), never ``pow``, which compilers do not always expand.

In single precision (``precision="float"``, ``symbolic generate --precision float``) every literal is a
``float`` with the ``f`` suffix, rounded once from the exact value, and every math function is its C99
``float`` form (``sinf``, ``sqrtf``, ``powf``, ...), so that nothing is promoted to ``double``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from fractions import Fraction

import numpy as np
import sympy as sp
from sympy.codegen.ast import float32, real
from sympy.core.mul import _keep_coeff
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE, PRECEDENCE_FUNCTIONS, PRECEDENCE_VALUES
from sympy.printing.precedence import precedence as sympy_precedence

from symbolic.derivation.subexpressions import extracts_minus_sign
from symbolic.description.robot import C_KEYWORDS  # noqa: F401  (defined by the spec, which refuses them as model names)


def c_double(value: sp.Rational | int) -> str:
    """A C double literal for an exact rational: the terminating decimal if there is one."""
    r = sp.Rational(value)
    return _terminating_decimal(r) or repr(float(r))


def _terminating_decimal(r: sp.Rational) -> str | None:
    """``r`` exactly as a decimal of at most 40 fractional digits (33/400 → ``0.0825``), else None."""
    p, q = int(r.p), int(r.q)
    for k in range(0, 40):
        if (10**k) % q == 0:
            digits = str(abs(p) * (10**k // q)).rjust(k + 1, "0")
            text = digits[: len(digits) - k] + "." + (digits[len(digits) - k :] or "0")
            return ("-" if p < 0 else "") + text
    return None


PRECISIONS = ("double", "float")
"""The floating-point types generated C can compute in (``symbolic generate --precision``)."""


def check_precision(precision: object) -> str:
    """``precision`` if it is one of :data:`PRECISIONS`, else a :class:`ValueError` naming the allowed ones.

    Parameters
    ----------
    precision : the value given (by the API's caller; the command line restricts it to the choices)

    Returns
    -------
    str
        ``"double"`` or ``"float"``.
    """
    if not isinstance(precision, str) or precision not in PRECISIONS:
        raise ValueError(f"precision must be 'double' or 'float', not {precision!r}")
    return precision


FLOAT_MAX = Fraction(2**24 - 1) * Fraction(2) ** 104
"""The largest finite IEEE binary32 value, (2 − 2⁻²³)·2¹²⁷."""


def nearest_float32(value: sp.Rational | sp.Float | int) -> np.float32:
    """The IEEE binary32 nearest the exact ``value`` (ties to even), rounded once.

    Rounding the double nearest ``value`` to float instead could round twice (a value just beside a float
    midpoint lands on it as a double, then goes the wrong way); exact integer arithmetic avoids that.

    Raises
    ------
    ValueError
        When ``value`` rounds beyond the largest float (a constant float C cannot hold).
    """
    r = sp.Rational(value)
    x = Fraction(int(r.p), int(r.q))
    if x == 0:
        return np.float32(0.0)
    sign, x = (-1 if x < 0 else 1), abs(x)
    exponent = x.numerator.bit_length() - x.denominator.bit_length()  # 2**exponent <= x < 2**(exponent + 2)
    if Fraction(2) ** (exponent + 1) <= x:
        exponent += 1
    exponent = max(exponent, -126)  # below the normal range the spacing stays that of 2**-126 (subnormals)
    rounded = Fraction(round(x / Fraction(2) ** (exponent - 23))) * Fraction(2) ** (exponent - 23)  # half to even
    if rounded > FLOAT_MAX:
        raise ValueError(f"the constant {float(r):.6g} is beyond the range of float (at most 3.4028235e38)")
    return np.float32(sign * float(rounded))  # 24 significant bits: exact in a double, then in a float


def c_float(value: sp.Rational | sp.Float | int) -> str:
    """A C ``float`` literal (``f`` suffix) of the float nearest the exact ``value``.

    A terminating decimal prints as itself (33/400 → ``0.0825f``: the compiler rounds the exact value
    once, to that float); any other value as the shortest decimal that reads back as that float.
    """
    r = sp.Rational(value)
    exact = _terminating_decimal(r)
    if exact is not None and len(exact) <= 24:
        return exact + "f"
    nearest = nearest_float32(r)
    if nearest == 0 or 1e-4 <= abs(nearest) < 1e7:
        text = np.format_float_positional(nearest, unique=True, trim="0")
    else:
        text = np.format_float_scientific(nearest, unique=True, trim="0").replace("e+", "e")
    return text + "f"


_FIXED_PRECEDENCE: dict[type, int] = {}
_MUL, _ADD = PRECEDENCE["Mul"], PRECEDENCE["Add"]


def precedence(item: object) -> int:
    """SymPy's ``precedence(item)``, the same value, found faster where printing asks it most.

    SymPy's walks the item's class hierarchy on every call, and for a product asks ``could_extract_minus_sign``,
    which builds the negated product to compare (a third of printing a large program). Here: for a product, the
    same test of its factors, then the derivation's sign test (:func:`~symbolic.derivation.subexpressions.extracts_minus_sign`:
    whether its leading coefficient is a negative number); for a class whose precedence does not depend on the item, SymPy's answer kept per class.
    """
    kind = type(item)
    if kind is sp.Mul:
        if any(hasattr(arg, "precedence") and isinstance(arg, sp.Function) and arg.precedence < _MUL for arg in item.args):
            return _MUL
        return _ADD if extracts_minus_sign(item) else _MUL
    fixed = _FIXED_PRECEDENCE.get(kind)
    if fixed is not None:
        return fixed
    value = sympy_precedence(item)
    if not hasattr(item, "precedence") and _fixed_by_class(kind):
        _FIXED_PRECEDENCE[kind] = value
    return value


def _fixed_by_class(kind: type) -> bool:
    """Whether SymPy's ``precedence`` of every instance of ``kind`` is one value (a table entry, not a function)."""
    for cls in kind.mro():
        if cls.__name__ in PRECEDENCE_FUNCTIONS:
            return False
        if cls.__name__ in PRECEDENCE_VALUES:
            return True
    return True


class FastPrecedence:
    """``parenthesize`` and ``_print_Add`` of SymPy's ``StrPrinter`` and ``_print_Mul`` of its ``CodePrinter`` (which
    the C and Python code printers use), the same text, with :func:`precedence`."""

    def parenthesize(self, item, level, strict=False):
        value = precedence(item)
        if value < level or (not strict and value <= level):
            return "(%s)" % self._print(item)
        return self._print(item)

    def _print_Add(self, expr, order=None):
        terms = self._as_ordered_terms(expr, order=order)
        prec = precedence(expr)
        out = []
        for term in terms:
            t = self._print(term)
            if t.startswith("-") and not term.is_Add:
                sign = "-"
                t = t[1:]
            else:
                sign = "+"
            if precedence(term) < prec or term.is_Add:
                out.extend([sign, "(%s)" % t])
            else:
                out.extend([sign, t])
        sign = out.pop(0)
        if sign == "+":
            sign = ""
        return sign + " ".join(out)

    def _fast_print_Mul(self, expr):
        """SymPy's ``CodePrinter._print_Mul``, the same text, with :func:`precedence`."""
        prec = precedence(expr)
        c, e = expr.as_coeff_Mul()
        if c.is_extended_negative:  # SymPy's c < 0 for the number c, without sympifying 0 and building a relation
            expr = _keep_coeff(-c, e)
            sign = "-"
        else:
            sign = ""
        a = []  # items in the numerator
        b = []  # items that are in the denominator (if any)
        pow_paren = []  # all powers with more than one base element and exponent -1
        if self.order not in ("old", "none"):
            args = expr.as_ordered_factors()
        else:
            args = sp.Mul.make_args(expr)  # in case expr was something like -x -> x
        for item in args:
            if item.is_commutative and item.is_Pow and item.exp.is_Rational and item.exp.is_negative:
                if item.exp != -1:
                    b.append(sp.Pow(item.base, -item.exp, evaluate=False))
                else:
                    if len(item.args[0].args) != 1 and isinstance(item.base, sp.Mul):  # SymPy's #14160
                        pow_paren.append(item)
                    b.append(sp.Pow(item.base, -item.exp))
            else:
                a.append(item)
        a = a or [sp.S.One]
        if len(a) == 1 and sign == "-":
            # unary minus: between multiplication and exponentiation
            a_str = [self.parenthesize(a[0], 0.5 * (PRECEDENCE["Pow"] + PRECEDENCE["Mul"]))]
        else:
            a_str = [self.parenthesize(x, prec) for x in a]
        b_str = [self.parenthesize(x, prec) for x in b]
        for item in pow_paren:
            if item.base in b:
                b_str[b.index(item.base)] = "(%s)" % b_str[b.index(item.base)]
        if not b:
            return sign + "*".join(a_str)
        if len(b) == 1:
            return sign + "*".join(a_str) + "/" + b_str[0]
        return sign + "*".join(a_str) + "/(%s)" % "*".join(b_str)


def handle_unevaluated(expr: sp.Expr, handle) -> sp.Expr:
    """SymPy's code printers' first step, ``handle(expr)``, only where it can change something: it rebuilds
    ``expr`` bottom-up to take ``re(x)`` of a real ``UnevaluatedExpr`` x back to x (a fifth of printing a large
    program); an expression without ``re`` comes back as it is."""
    stack = [expr]
    while stack:
        node = stack.pop()
        if isinstance(node, sp.re):
            return handle(expr)
        stack.extend(node.args)
    return expr


class CPrinter(FastPrecedence, C99CodePrinter):
    """C99 printer with array-slot symbols and cheap powers, in double or single precision.

    Parameters
    ----------
    slots : symbol → the C text standing for it (``q[0]``)
    settings : SymPy printer settings
    precision : ``"double"`` (default) or ``"float"`` (``f`` literals, ``sinf``-style functions)
    """

    def __init__(self, slots: Mapping[sp.Symbol, str], settings: dict | None = None, precision: str = "double") -> None:
        self.single = check_precision(precision) == "float"
        settings = dict(settings or {})
        if self.single:  # SymPy's own float32 alias: sinf, sqrtf, powf, fabsf, atan2f, ...
            settings["type_aliases"] = {real: float32}
        super().__init__(settings)
        self.slots = dict(slots)

    def literal(self, value: sp.Rational | sp.Float | int) -> str:
        """``value`` as a literal of the printer's type, rounded once from the exact value."""
        return c_float(value) if self.single else c_double(value)

    def _handle_UnevaluatedExpr(self, expr: sp.Expr) -> sp.Expr:
        return handle_unevaluated(expr, super()._handle_UnevaluatedExpr)

    def _print_Mul(self, expr: sp.Mul, **kwargs) -> str:
        if expr in self.math_macros:  # C89CodePrinter's: a constant of <math.h>
            return super()._print_Mul(expr, **kwargs)
        return self._fast_print_Mul(expr)

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        if expr in self.slots:
            return self.slots[expr]
        return super()._print_Symbol(expr)

    def _print_Rational(self, expr: sp.Rational) -> str:
        return self.literal(expr)

    def _print_Integer(self, expr: sp.Integer) -> str:
        return f"{int(expr)}.0f" if self.single else f"{int(expr)}.0"

    def _print_Float(self, expr: sp.Float) -> str:
        # single: the exact binary value of the (50-digit) Float, rounded once to a float
        return self.literal(sp.Rational(expr)) if self.single else repr(float(expr))

    def _print_Pi(self, expr: sp.Expr) -> str:
        # M_PI is POSIX, not C99 (-std=c99 -pedantic does not define it): the double nearest π, as a literal
        return self.literal(sp.Rational(sp.pi.evalf(60))) if self.single else repr(float(sp.pi))

    def _print_Exp1(self, expr: sp.Expr) -> str:
        # M_E is POSIX, not C99, as M_PI: the double nearest e, as a literal
        return self.literal(sp.Rational(sp.E.evalf(60))) if self.single else repr(float(sp.E))

    def _print_Pow(self, expr: sp.Pow) -> str:
        base, exp = expr.base, expr.exp
        if exp.is_Integer and 1 < int(exp) <= 4:
            factor = self.parenthesize(base, sp.printing.precedence.PRECEDENCE["Mul"])
            # parenthesised: the printer treats a Pow as binding tighter than '/', so a/x**4 must not
            # become a/x*x*x*x
            return "(" + "*".join([factor] * int(exp)) + ")"
        if exp.is_Integer and int(exp) < 0:
            return f"{self._print(sp.Integer(1))}/({self._print(sp.Pow(base, -exp))})"
        if exp == sp.Rational(1, 2):
            return f"{'sqrtf' if self.single else 'sqrt'}({self._print(base)})"
        return super()._print_Pow(expr)
