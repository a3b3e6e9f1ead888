"""C99 header and source, NAME.h and NAME.c (docs/contracts.md, "Generated C")."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from symbolic.derivation.dynamics import DynamicModel

SUMMARY = "C99 header and source (NAME.h, NAME.c): no allocation, only <math.h>"


def render(model: DynamicModel, head: str, figures: bool) -> dict[str, bytes]:
    from symbolic.codegen.c_source import c_sources

    return {name: text.encode() for name, text in c_sources(model, head).items()}
