"""A package's names imported on first use (PEP 562's module ``__getattr__``): the commands that need no SymPy
(``symbolic --help``, a warm ``symbolic simulate``) do not import it through a package's ``__init__``."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any


def attribute(package: str, names: Mapping[str, tuple[str, str | None]], namespace: dict[str, Any], name: str) -> Any:
    """``name`` of ``package`` for its ``__getattr__``: from ``names`` (name: (module, attribute; ``None`` for the
    module itself)), else the subpackage or submodule ``package.name``; kept in ``namespace`` (the package's
    globals) so that later lookups find it directly."""
    if name in names:
        module, inside = names[name]
        value = importlib.import_module(module)
        value = value if inside is None else getattr(value, inside)
    elif not name.startswith("_"):
        try:
            value = importlib.import_module(f"{package}.{name}")
        except ModuleNotFoundError as missing:
            if missing.name != f"{package}.{name}":
                raise
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
    else:
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    namespace[name] = value
    return value
