"""C99 header and source, NAME.h and NAME.c (docs/contracts.md, "Generated C"); in single precision NAME_float.h
and NAME_float.c, the header stating the float functions' measured error against the double ones
(docs/contracts.md, "Single-precision C")."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from symbolic.derivation.dynamics import DynamicModel

SUMMARY = "C99 header and source (NAME.h, NAME.c): no allocation, only <math.h>"


def render(model: DynamicModel, head: str, figures: bool, precision: str = "double") -> dict[str, bytes]:
    """``{NAME.h, NAME.c}`` (double) or ``{NAME_float.h, NAME_float.c}`` (``precision="float"``)."""
    from symbolic.codegen.c_source import c_sources

    accuracy = None
    if precision == "float":
        from symbolic.codegen.c_accuracy import float_accuracy

        accuracy = float_accuracy(model).lines()
    return {name: text.encode() for name, text in c_sources(model, head, precision, accuracy).items()}
