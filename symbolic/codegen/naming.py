"""Names that reach generated code: C identifiers checked, comment text made safe."""

from __future__ import annotations

import re

from symbolic.errors import ModelError
from symbolic.codegen.c_printer import C_KEYWORDS

C_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def check_c_name(name: str, source: str) -> str:
    """The model name as a C prefix: an identifier that is not a C keyword."""
    if not C_IDENTIFIER.match(name):
        raise ModelError(source, "name", f"model name {name!r} is not a C identifier ([A-Za-z][A-Za-z0-9_]*)")
    if name in C_KEYWORDS:
        raise ModelError(source, "name", f"model name {name!r} is a C keyword; choose another name")
    return name


def comment_text(text: str) -> str:
    """Text safe inside a C block comment and on one line."""
    return " ".join(text.replace("*/", "* /").replace("/*", "/ *").split())
