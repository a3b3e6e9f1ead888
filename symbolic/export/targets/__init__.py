"""The export targets: one module per target in this folder, found by listing it (docs/contracts.md, "Adding an
export target").

A target module holds ``SUMMARY`` (one line for ``--help``) and ``render(model, head, figures) -> {file name:
bytes}``: everything it writes, rendered in memory. Importing this package is cheap (no SymPy), so the command
line lists the targets in its help; a target imports what it needs inside ``render``.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

NAMES: tuple[str, ...] = tuple(sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")))
"""Every target, in a fixed order (by name): ``--targets`` accepts any subset, the default is all of them."""


def target(name: str) -> ModuleType:
    """The module of target ``name`` (one of :data:`NAMES`)."""
    if name not in NAMES:
        raise ValueError(f"unknown target {name!r} (allowed: {', '.join(NAMES)})")
    return importlib.import_module(f"{__name__}.{name}")
