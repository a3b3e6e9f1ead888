"""Safe parsing of user expressions into SymPy.

Model files carry expressions such as ``"q2 - pi"`` or ``"m3*l_c3"``. They are never handed to
``eval``, ``exec`` or ``sympify``: the text is parsed by :mod:`ast` (which only builds a syntax
tree and runs nothing) and the tree is translated node by node against a whitelist of numbers,
declared symbols, the operators ``+ - * / **``, parentheses, ``pi`` and the functions in
:data:`FUNCTIONS`. Anything else is refused with a message naming the source, key and text.

Size is bounded before anything is built — the text's length (:data:`MAX_LENGTH`), the nesting depth
(:data:`MAX_DEPTH`), every exponent (:data:`MAX_EXPONENT`) and number (:data:`MAX_MAGNITUDE`,
:data:`MAX_DIGITS`) — and each sub-expression is refused as soon as it is not finite or not real: the
limits, when each is checked and why: docs/model-format.md, "Limits".
"""

from __future__ import annotations

import ast
import re
from collections.abc import Callable, Mapping

import sympy as sp

from symbolic.description.reserved import (  # noqa: F401 (re-exported: the parser's names)
    FUNCTION_ARITY, RESERVED_NAMES, check_magnitude, reserved_meaning, reserved_uses, variable_names,
)
from symbolic.errors import ModelError, shorten, shown, suggestion

FUNCTIONS: dict[str, tuple[Callable[..., sp.Expr], int]] = {
    name: ({"abs": sp.Abs}.get(name) or getattr(sp, name), arity) for name, arity in FUNCTION_ARITY.items()
}
"""Functions allowed in expressions: name -> (SymPy function, number of arguments)."""

CONSTANTS: dict[str, sp.Expr] = {"pi": sp.pi}
"""Named constants allowed in expressions (their names: :data:`~symbolic.description.reserved.CONSTANT_NAMES`)."""


_ADDITIVE = (ast.Add, ast.Sub)
_MULTIPLICATIVE = (ast.Mult, ast.Div)
_UNARY = {ast.USub: lambda a: -a, ast.UAdd: lambda a: a}
_OPERATORS = {
    ast.Mod: "%", ast.FloorDiv: "//", ast.MatMult: "@", ast.BitAnd: "&", ast.BitOr: "|", ast.BitXor: "^",
    ast.LShift: "<<", ast.RShift: ">>", ast.Invert: "~", ast.Not: "not",
}
"""Operators Python parses and the whitelist refuses, by their spelling (for messages)."""

MAX_LENGTH = 2_000
"""Characters per expression. The longest in the built-in robots has 35; 2,000 is room for any
hand-written or generated closed-form expression, and keeps even one nesting level per character
(``"----q"``) far below the depth (about 3,000) at which Python's own parser fails."""

MAX_DEPTH = 50
"""Nesting levels of the syntax tree (a chain ``a + b - c`` or ``a*b/c`` counts as one level, so
long sums are fine). The built-in robots nest at most 7 deep."""

MAX_EXPONENT = 100
"""Largest magnitude of an exponent; exponents must be constants. Real models use 2, 3, 1/2, -1."""

MAX_MAGNITUDE = sp.Integer(10) ** 30
"""Numbers, literal or computed from literals (``10**-6``), are 0 or between 1e-30 and 1e30 in
magnitude: Young's modulus (2e11 Pa) and micro-scale lengths (1e-6 m) fit with room to spare."""

MAX_DIGITS = 100
"""Digits of the numerator and denominator of an exact number (decimals are kept exact, so 0.0825
is 33/400; (0.0825)**100 has a 261-digit denominator and is refused)."""

_DIGITS_BOUND = 10**MAX_DIGITS
_NOT_FINITE = (sp.zoo, sp.nan, sp.oo, -sp.oo)


def number(value: float | int, source: str, key: str) -> sp.Expr:
    """Convert a TOML/Python number to an exact SymPy number (0.0825 -> 33/400).

    Decimal literals are kept exact so that derived expressions stay exact; code generators
    print them back as the same decimal.

    Raises
    ------
    ModelError
        For booleans, non-finite values and magnitudes outside 1e-30 … 1e30 (:data:`MAX_MAGNITUDE`).
    """
    if isinstance(value, bool):
        raise ModelError(source, key, f"expected a number, got the boolean {value!r}")
    check_magnitude(value, source, key)
    if isinstance(value, int):
        return sp.Integer(value)
    return sp.Rational(repr(float(value)))


def parse_expression(
    text: str | float | int,
    symbols: Mapping[str, sp.Symbol],
    source: str,
    key: str,
) -> sp.Expr:
    """Parse ``text`` into a SymPy expression using only whitelisted constructs.

    Parameters
    ----------
    text
        The expression (a string), or a plain number.
    symbols
        The declared names (coordinates and parameters) and their SymPy symbols.
    source, key
        Where the text comes from, used in error messages.

    Raises
    ------
    ModelError
        For syntax errors, undeclared names, any construct outside the whitelist (attribute access,
        lambda, subscripts, comparisons, keyword arguments, strings, ...), the size limits of this
        module, and any part that is not finite or not real.
    """
    if isinstance(text, (int, float)):
        return number(text, source, key)
    if not isinstance(text, str):
        raise ModelError(source, key, f"expected an expression string or a number, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ModelError(source, key, f"expression {shorten(text)} is longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise ModelError(source, key, "empty expression")
    stripped = text.strip()
    try:
        tree = ast.parse(stripped, mode="eval")
    except SyntaxError as exc:
        raise ModelError(source, key, f"cannot parse expression {shorten(text)}: {exc.msg}") from None
    except (RecursionError, MemoryError):
        # Python's parser has its own depth limit; MAX_LENGTH keeps us below it, this is the safety net
        raise ModelError(source, key, f"expression {shorten(text)} is nested too deeply to parse (at most {MAX_DEPTH} levels)") from None
    except ValueError as exc:  # e.g. a hexadecimal literal over Python's int-digit limit, a NUL character
        raise ModelError(source, key, f"cannot parse expression {shorten(text)}: {str(exc).split(';')[0]}") from None
    try:
        return _Translator(symbols, source, key, stripped).visit(tree.body, 0)
    except ArithmeticError as exc:  # SymPy's exact evaluation overflowing (sinh(1E20): decimal.InvalidOperation)
        raise ModelError(source, key, f"expression {shorten(text)} cannot be evaluated exactly "
                                      f"({type(exc).__name__}): a value out of range") from None


def check_value(expr: sp.Expr, source: str, key: str, what: str | Callable[[], str]) -> sp.Expr:
    """``expr`` if it is finite and real as far as can be seen without values; else a ModelError.

    Infinity, NaN and the imaginary unit anywhere in ``expr`` are refused; an expression free of
    symbols is evaluated (mpmath, 30 digits) and must be real and at most 1e30 in magnitude.
    ``what`` names the offending text in the message (a callable is called only for a message).
    """
    try:
        return _check_value(expr)
    except _Refused as refused:
        raise ModelError(source, key, f"{what() if callable(what) else what} {refused}") from None


class _Refused(Exception):
    """What is wrong with a value, before the message names where it is."""


def _check_value(expr: sp.Expr) -> sp.Expr:
    if expr.has(*_NOT_FINITE):
        raise _Refused("is not finite (division by zero, log(0), …)")
    if expr.has(sp.I):
        raise _Refused("is not real")
    if not isinstance(expr, sp.Expr):
        return expr
    if expr.is_Rational:
        _check_number(expr, whole=True)
        return expr
    # SymPy folds constants into coefficients and powers: 2.0*2.0*…*l2 is 2**495*l2, (q**100)**100 is q**10000
    for number in sorted(expr.atoms(sp.Rational), key=abs, reverse=True):
        _check_number(number, whole=False)
    for power in expr.atoms(sp.Pow):
        if power.exp.is_Number and abs(power.exp) > MAX_EXPONENT:
            raise _Refused(f"has an exponent of {_number_text(power.exp)}, larger than {MAX_EXPONENT} in magnitude")
    if expr.free_symbols:
        return expr
    value = expr.evalf(30)
    real, imag = value.as_real_imag()
    if not (real.is_finite and imag.is_finite) or value.has(*_NOT_FINITE):
        raise _Refused("is not finite")
    if imag.is_Number and abs(imag) > 1e-20 * max(1, abs(real)):
        raise _Refused(f"is not real (≈ {complex(value):.6g})")
    if real.is_Number and abs(real) > MAX_MAGNITUDE:
        raise _Refused(f"is larger than 1e30 in magnitude (≈ {sp.N(real, 3)})")
    return expr


def _check_number(number: sp.Rational, whole: bool) -> None:
    """Refuse an exact number outside the magnitudes or digits allowed; ``whole``: it is the whole
    (sub)expression, else a number it holds."""
    if number != 0 and not 1 / MAX_MAGNITUDE <= abs(number) <= MAX_MAGNITUDE:
        held = "" if whole else f"holds the number {_number_text(number)} which "
        raise _Refused(f"{held}is outside the allowed magnitudes 1e-30 to 1e30 (or 0)")
    if abs(number.p) >= _DIGITS_BOUND or number.q >= _DIGITS_BOUND:
        held = "has" if whole else "holds a number with"
        raise _Refused(f"{held} more than {MAX_DIGITS} digits as an exact fraction")


def _number_text(number: sp.Rational) -> str:
    """A short rendering of an exact number for messages (never its thousands of digits)."""
    if abs(number.p) < 10**15 and number.q < 10**15:
        return str(number)
    return f"≈ {sp.N(number, 3)}"


class _Translator:
    """Translate a whitelisted Python expression tree into SymPy, checking limits node by node."""

    def __init__(self, symbols: Mapping[str, sp.Symbol], source: str, key: str, text: str) -> None:
        self.symbols = symbols
        self.source = source
        self.key = key
        self.text = text
        self.lines = [line.encode() for line in re.split(r"(?<=\r\n)|(?<=\n)|(?<=\r)(?!\n)", text)]

    def fail(self, what: str) -> ModelError:
        allowed = "numbers, declared symbols, + - * / **, parentheses, pi and " + ", ".join(sorted(FUNCTIONS))
        return ModelError(self.source, self.key, f"{what} in expression {shorten(self.text)} (allowed: {allowed})")

    def refuse_part(self, node: ast.AST, problem: str, what: str = "") -> ModelError:
        """``node`` (and the expression it is part of) with what is wrong with it."""
        return ModelError(self.source, self.key, f"{what}{self.where(node)} {problem}")

    def refuse(self, what: str) -> ModelError:
        """A limit or value problem: what is wrong, in the expression."""
        return ModelError(self.source, self.key, f"{what} in expression {shorten(self.text)}")

    def segment(self, node: ast.AST) -> str:
        """The source text of ``node``. (:func:`ast.get_source_segment` splits the whole text into
        lines on every call, which made a 1,000-factor product take seconds.)"""
        if node.lineno == node.end_lineno:
            return self.lines[node.lineno - 1][node.col_offset:node.end_col_offset].decode()
        first = self.lines[node.lineno - 1][node.col_offset:]
        last = self.lines[node.end_lineno - 1][:node.end_col_offset]
        return b"".join([first, *self.lines[node.lineno:node.end_lineno - 1], last]).decode()

    def part(self, node: ast.AST) -> str:
        """The source text of ``node``, quoted and shortened, for messages."""
        return shorten(self.segment(node), 40)

    def where(self, node: ast.AST) -> str:
        """``node``'s text, and the whole expression when ``node`` is only part of it."""
        if self.segment(node) == self.text:
            return self.part(node)
        return f"{self.part(node)} in expression {shorten(self.text)}"

    def visit(self, node: ast.AST, depth: int) -> sp.Expr:
        if depth >= MAX_DEPTH:
            raise self.refuse(f"nesting deeper than {MAX_DEPTH} levels")
        expr = self.translate(node, depth + 1)
        if isinstance(node, (ast.Name, ast.Constant)) and expr.is_Atom and not expr.is_Number:
            return expr  # a symbol or pi: nothing to check
        return check_value(expr, self.source, self.key, lambda: self.where(node))

    def translate(self, node: ast.AST, depth: int) -> sp.Expr:
        if isinstance(node, ast.Constant):
            return self.constant(node)
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.BinOp) and isinstance(node.op, _ADDITIVE):
            # a long sum is a left-leaning chain: walk it in a loop so its length costs no depth
            terms = [(self.visit(operand, depth), op) for operand, op in self.chain(node, _ADDITIVE)]
            return sp.Add(*(t if isinstance(op, ast.Add) else -t for t, op in terms))
        if isinstance(node, ast.BinOp) and isinstance(node.op, _MULTIPLICATIVE):
            factors = [(self.visit(operand, depth), op) for operand, op in self.chain(node, _MULTIPLICATIVE)]
            return sp.Mul(*(f if isinstance(op, ast.Mult) else sp.Pow(f, -1) for f, op in factors))
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            return self.power(node, depth)
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](self.visit(node.operand, depth))
        if isinstance(node, ast.Call):
            return self.call(node, depth)
        if isinstance(node, (ast.BinOp, ast.UnaryOp)):
            raise self.fail(f"operator '{_OPERATORS.get(type(node.op), type(node.op).__name__)}' is not allowed")
        kind = {
            ast.Attribute: "attribute access",
            ast.Lambda: "lambda",
            ast.Subscript: "subscript",
            ast.Compare: "comparison",
            ast.BoolOp: "boolean operator",
            ast.IfExp: "conditional expression",
        }.get(type(node), f"construct '{type(node).__name__}'")
        raise self.fail(f"{kind} is not allowed")

    @staticmethod
    def chain(node: ast.BinOp, ops: tuple[type, ...]) -> list[tuple[ast.AST, ast.operator]]:
        """The operands of a left-leaning chain of ``ops`` (``a - b + c``), each with its operator;
        the first operand counts as added (multiplied)."""
        out = []
        while isinstance(node, ast.BinOp) and isinstance(node.op, ops):
            out.append((node.right, node.op))
            node = node.left
        out.append((node, ast.Add() if ops is _ADDITIVE else ast.Mult()))
        return out[::-1]

    def constant(self, node: ast.Constant) -> sp.Expr:
        value = node.value
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise self.fail(f"literal {shown(value, 40)} is not a number")
        segment = self.segment(node)
        if value == 0 and any(c in "123456789" for c in segment.lower().split("e")[0]):
            raise self.refuse(f"number {shorten(segment, 40)} underflows to 0 (allowed magnitudes: 1e-30 to 1e30, or 0)")
        return number(value, self.source, self.key)

    def power(self, node: ast.BinOp, depth: int) -> sp.Expr:
        base = self.visit(node.left, depth)
        exponent = self.visit(node.right, depth)
        if exponent.free_symbols:
            names = ", ".join(sorted(s.name for s in exponent.free_symbols))
            raise self.refuse_part(node.right, f"depends on {names}; exponents must be constant numbers", "exponent ")
        size = abs(exponent) if exponent.is_Number else abs(exponent.evalf(30))
        if size > MAX_EXPONENT:
            raise self.refuse_part(node.right, f"is larger than {MAX_EXPONENT} in magnitude", "exponent ")
        if base == 0 and exponent.is_negative:
            raise self.refuse_part(node, "divides by zero")
        return sp.Pow(base, exponent)

    def ambiguous(self, name: str) -> ModelError:
        """A declared name that is also reserved: neither reading is chosen silently."""
        return ModelError(self.source, self.key, f"{name!r} in expression {shorten(self.text)} is ambiguous: it is "
                                                 f"declared here and is also {reserved_meaning(name)} of expressions; "
                                                 f"rename the declared {name!r}")

    def name(self, name: str) -> sp.Expr:
        if name in self.symbols:
            if name in RESERVED_NAMES:
                raise self.ambiguous(name)
            return self.symbols[name]
        if name in CONSTANTS:
            return CONSTANTS[name]
        if name in FUNCTIONS:
            raise self.fail(f"function '{name}' used without a call")
        declared = ", ".join(sorted(self.symbols)) or "none"
        raise ModelError(
            self.source,
            self.key,
            f"undeclared symbol {shorten(name, 40)} in expression {shorten(self.text)}; declare it under [parameters] "
            f"or in coordinates (declared: {declared}){suggestion(name, self.symbols)}",
        )

    def call(self, node: ast.Call, depth: int) -> sp.Expr:
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            what = self.segment(node.func)
            raise self.fail(f"call of '{what}' is not allowed" if len(what) <= 40 else f"call of {shorten(what, 40)} is not allowed")
        if node.func.id in self.symbols:
            raise self.ambiguous(node.func.id)
        if node.keywords:
            raise self.fail("keyword arguments are not allowed")
        function, arity = FUNCTIONS[node.func.id]
        if len(node.args) != arity or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(f"'{node.func.id}' takes {arity} argument(s)")
        return function(*(self.visit(a, depth) for a in node.args))
