"""C99 printing of generated expressions (a subclass of SymPy's C99CodePrinter).

Coordinates, velocities, accelerations, torques and parameters print as array slots by table
(``q[0]``, ``p[5]``); exact decimals print as the same decimal (33/400 → ``0.0825``); small integer
powers print as products (``x*x``), never ``pow``, which compilers do not always expand.
"""

from __future__ import annotations

from collections.abc import Mapping

import sympy as sp
from sympy.printing.c import C99CodePrinter

from symbolic.description.robot import C_KEYWORDS  # noqa: F401  (defined by the spec, which refuses them as model names)


def c_double(value: sp.Rational | int) -> str:
    """A C double literal for an exact rational: the terminating decimal if there is one."""
    r = sp.Rational(value)
    p, q = int(r.p), int(r.q)
    for k in range(0, 40):
        if (10**k) % q == 0:
            digits = str(abs(p) * (10**k // q)).rjust(k + 1, "0")
            text = digits[: len(digits) - k] + "." + (digits[len(digits) - k :] or "0")
            return ("-" if p < 0 else "") + text
    return repr(float(r))


class CPrinter(C99CodePrinter):
    """C99 printer with array-slot symbols and cheap powers."""

    def __init__(self, slots: Mapping[sp.Symbol, str], settings: dict | None = None) -> None:
        super().__init__(settings or {})
        self.slots = dict(slots)

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        if expr in self.slots:
            return self.slots[expr]
        return super()._print_Symbol(expr)

    def _print_Rational(self, expr: sp.Rational) -> str:
        return c_double(expr)

    def _print_Integer(self, expr: sp.Integer) -> str:
        return f"{int(expr)}.0"

    def _print_Float(self, expr: sp.Float) -> str:
        return repr(float(expr))

    def _print_Pi(self, expr: sp.Expr) -> str:
        # M_PI is POSIX, not C99 (-std=c99 -pedantic does not define it): the double nearest π, as a literal
        return repr(float(sp.pi))

    def _print_Pow(self, expr: sp.Pow) -> str:
        base, exp = expr.base, expr.exp
        if exp.is_Integer and 1 < int(exp) <= 4:
            factor = self.parenthesize(base, sp.printing.precedence.PRECEDENCE["Mul"])
            # parenthesised: the printer treats a Pow as binding tighter than '/', so a/x**4 must not
            # become a/x*x*x*x
            return "(" + "*".join([factor] * int(exp)) + ")"
        if exp.is_Integer and int(exp) < 0:
            return f"1.0/({self._print(sp.Pow(base, -exp))})"
        if exp == sp.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        return super()._print_Pow(expr)
