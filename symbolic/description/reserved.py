"""The names and number limits of the expression language, without SymPy (docs/model-format.md, "Limits").

What a caller needs to check a text or a number before anything is parsed — the reserved names (``pi`` and the
functions), the names a text uses as variables, the magnitude of a number — for the data layer, which reads
most experiment files without parsing an expression (a signal that is a column, a gain that is a number).
:mod:`symbolic.description.expressions` parses into SymPy and builds on these.
"""

from __future__ import annotations

import ast
import math
from fractions import Fraction

from symbolic.errors import ModelError

FUNCTION_ARITY: dict[str, int] = {
    "sin": 1, "cos": 1, "tan": 1, "asin": 1, "acos": 1, "atan": 1, "atan2": 2, "sinh": 1, "cosh": 1, "tanh": 1,
    "sqrt": 1, "exp": 1, "log": 1, "abs": 1, "sign": 1,
}
"""The functions allowed in expressions and their number of arguments (their SymPy functions:
:data:`symbolic.description.expressions.FUNCTIONS`)."""

CONSTANT_NAMES = frozenset({"pi"})
"""The named constants allowed in expressions."""

RESERVED_NAMES = frozenset(FUNCTION_ARITY) | CONSTANT_NAMES

MAGNITUDE_EXPONENT = 30
"""Numbers are 0 or between 10^-30 and 10^30 in magnitude (:data:`symbolic.description.expressions.MAX_MAGNITUDE`)."""


def variable_names(text: str) -> list[str]:
    """The names ``text`` uses as variables (not called, not ``pi`` or a function), in order of appearance.

    For messages that list what the caller could have meant; text that does not parse gives [] (the
    parser reports it).
    """
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, RecursionError, MemoryError, ValueError):
        return []
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    return [n.id for n in ast.walk(tree)
            if isinstance(n, ast.Name) and id(n) not in called and n.id not in CONSTANT_NAMES
            and n.id not in FUNCTION_ARITY]


def reserved_uses(text: str) -> list[str]:
    """The reserved names (:data:`RESERVED_NAMES`: ``pi`` and the functions) ``text`` uses, called or
    not, once each in order of appearance; text that does not parse gives [] (the parser reports it).

    For callers whose names come from elsewhere (a data file's columns): a name that is both theirs and
    reserved is ambiguous, and refused rather than read one way or the other.
    """
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, RecursionError, MemoryError, ValueError):
        return []
    names = [n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and n.id in RESERVED_NAMES]
    return list(dict.fromkeys(names))


def reserved_meaning(name: str) -> str:
    """What a reserved name means in an expression, for messages ("the constant pi (3.14159…)")."""
    return "the constant pi (3.14159…)" if name in CONSTANT_NAMES else f"the function {name}()"


def check_magnitude(value: float | int, source: str, key: str) -> None:
    """Refuse a number that is not finite, or not 0 and outside 1e-30 … 1e30 in magnitude (compared exactly:
    a float as the decimal it prints as, so 1e30 is 10**30)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise ModelError(source, key, f"expected a finite number, got {value!r}")
    exact = Fraction(repr(value)) if isinstance(value, float) else Fraction(value)
    bound = 10**MAGNITUDE_EXPONENT
    if value != 0 and not Fraction(1, bound) <= abs(exact) <= bound:
        text = f"{value:.3g}" if isinstance(value, float) else _integer_text(value)
        raise ModelError(source, key, f"number {text} is outside the allowed magnitudes 1e-30 to 1e30 (or 0)")


def _integer_text(value: int) -> str:
    """An integer for a message, without tripping Python's int-to-text digit limit."""
    if abs(value) < 10**30:
        return str(value)
    digits = int(abs(value).bit_length() * math.log10(2))  # exact, or one short (no int-to-text conversion)
    return f"with {digits + (abs(value) >= 10**digits)} digits"
