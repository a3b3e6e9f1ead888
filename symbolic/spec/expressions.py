"""Safe parsing of user expressions into SymPy.

Model files carry expressions such as ``"q2 - pi"`` or ``"m3*l_c3"``. They are never handed to
``eval``, ``exec`` or ``sympify``: the text is parsed by :mod:`ast` (which only builds a syntax
tree and runs nothing) and the tree is translated node by node against a whitelist of numbers,
declared symbols, the operators ``+ - * / **``, parentheses, ``pi`` and the functions in
:data:`FUNCTIONS`. Anything else is refused with a message naming the source, key and text.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping

import sympy as sp

from symbolic.errors import ModelError

FUNCTIONS: dict[str, tuple[Callable[..., sp.Expr], int]] = {
    "sin": (sp.sin, 1),
    "cos": (sp.cos, 1),
    "tan": (sp.tan, 1),
    "asin": (sp.asin, 1),
    "acos": (sp.acos, 1),
    "atan": (sp.atan, 1),
    "atan2": (sp.atan2, 2),
    "sinh": (sp.sinh, 1),
    "cosh": (sp.cosh, 1),
    "tanh": (sp.tanh, 1),
    "sqrt": (sp.sqrt, 1),
    "exp": (sp.exp, 1),
    "log": (sp.log, 1),
    "abs": (sp.Abs, 1),
    "sign": (sp.sign, 1),
}
"""Functions allowed in expressions: name -> (SymPy function, number of arguments)."""

CONSTANTS: dict[str, sp.Expr] = {"pi": sp.pi}
"""Named constants allowed in expressions."""

RESERVED_NAMES = frozenset(FUNCTIONS) | frozenset(CONSTANTS)

_BINARY = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: lambda a, b: a**b,
}
_UNARY = {ast.USub: lambda a: -a, ast.UAdd: lambda a: a}

MAX_LENGTH = 10_000


def variable_names(text: str) -> list[str]:
    """The names ``text`` uses as variables (not called, not ``pi`` or a function), in order of appearance.

    For messages that list what the caller could have meant; text that does not parse gives [] (the
    parser reports it).
    """
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        return []
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    return [n.id for n in ast.walk(tree)
            if isinstance(n, ast.Name) and id(n) not in called and n.id not in CONSTANTS and n.id not in FUNCTIONS]


def number(value: float | int, source: str, key: str) -> sp.Expr:
    """Convert a TOML/Python number to an exact SymPy number (0.0825 -> 33/400).

    Decimal literals are kept exact so that derived expressions stay exact; code generators
    print them back as the same decimal.
    """
    if isinstance(value, bool):
        raise ModelError(source, key, f"expected a number, got the boolean {value!r}")
    if isinstance(value, int):
        return sp.Integer(value)
    if not math.isfinite(value):
        raise ModelError(source, key, f"expected a finite number, got {value!r}")
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
        For syntax errors, undeclared names, and any construct outside the whitelist
        (attribute access, lambda, subscripts, comparisons, keyword arguments, strings, ...).
    """
    if isinstance(text, (int, float)):
        return number(text, source, key)
    if not isinstance(text, str):
        raise ModelError(source, key, f"expected an expression string or a number, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ModelError(source, key, f"expression longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise ModelError(source, key, "empty expression")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ModelError(source, key, f"cannot parse expression {text!r}: {exc.msg}") from None
    return _Translator(symbols, source, key, text).visit(tree.body)


class _Translator:
    """Translate a whitelisted Python expression tree into SymPy."""

    def __init__(self, symbols: Mapping[str, sp.Symbol], source: str, key: str, text: str) -> None:
        self.symbols = symbols
        self.source = source
        self.key = key
        self.text = text

    def fail(self, what: str) -> ModelError:
        allowed = "numbers, declared symbols, + - * / **, parentheses, pi and " + ", ".join(sorted(FUNCTIONS))
        return ModelError(self.source, self.key, f"{what} in expression {self.text!r} (allowed: {allowed})")

    def visit(self, node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
                return number(node.value, self.source, self.key)
            raise self.fail(f"literal {node.value!r} is not a number")
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](self.visit(node.left), self.visit(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](self.visit(node.operand))
        if isinstance(node, ast.Call):
            return self.call(node)
        kind = {
            ast.Attribute: "attribute access",
            ast.Lambda: "lambda",
            ast.Subscript: "subscript",
            ast.Compare: "comparison",
            ast.BoolOp: "boolean operator",
            ast.IfExp: "conditional expression",
        }.get(type(node), f"construct '{type(node).__name__}'")
        raise self.fail(f"{kind} is not allowed")

    def name(self, name: str) -> sp.Expr:
        if name in self.symbols:
            return self.symbols[name]
        if name in CONSTANTS:
            return CONSTANTS[name]
        if name in FUNCTIONS:
            raise self.fail(f"function '{name}' used without a call")
        declared = ", ".join(sorted(self.symbols)) or "none"
        raise ModelError(
            self.source,
            self.key,
            f"undeclared symbol '{name}' in expression {self.text!r}; declare it under [parameters] "
            f"or in coordinates (declared: {declared})",
        )

    def call(self, node: ast.Call) -> sp.Expr:
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            what = ast.unparse(node.func)
            raise self.fail(f"call of '{what}' is not allowed")
        if node.keywords:
            raise self.fail("keyword arguments are not allowed")
        function, arity = FUNCTIONS[node.func.id]
        if len(node.args) != arity or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(f"'{node.func.id}' takes {arity} argument(s)")
        return function(*(self.visit(a) for a in node.args))
