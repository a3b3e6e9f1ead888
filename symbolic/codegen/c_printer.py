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
from sympy.printing.c import C99CodePrinter

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


def handle_unevaluated(expr: sp.Expr, handle) -> sp.Expr:
    """SymPy's code printers' first step, ``handle(expr)``, only where it can change something: it rebuilds
    ``expr`` bottom-up to take ``re(x)`` of a real ``UnevaluatedExpr`` x back to x (a fifth of printing a large
    program); an expression without ``re`` comes back as it is."""
    return handle(expr) if expr.has(sp.re) else expr


class CPrinter(C99CodePrinter):
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
