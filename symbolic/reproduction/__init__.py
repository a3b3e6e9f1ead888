"""Every checkable number of the seed documents, recomputed (``symbolic reproduce``).

Each seed has one subpackage (:mod:`.madill`, :mod:`.milne`, :mod:`.janot`) holding the paper's own methods
beside its ``items`` module, whose ``items()`` returns its :class:`~symbolic.reproduction.item.Item` list,
each computed through the package's public code path;
:func:`table` collects them in that order and :mod:`.render` writes the JSON and ``docs/reproduction.md``.
"""

from __future__ import annotations

import importlib
import logging
import time

from symbolic.reproduction.item import SOURCES, Item, compare, not_reproducible, printed_tolerance

log = logging.getLogger(__name__)

__all__ = ["Item", "SOURCES", "compare", "not_reproducible", "printed_tolerance", "table"]


def table(sources: tuple[str, ...] = SOURCES) -> list[Item]:
    """The items of ``sources`` (default: all seeds), in source order then each module's order."""
    items: list[Item] = []
    for source in sources:
        if source not in SOURCES:
            raise ValueError(f"unknown source {source!r} (one of {', '.join(SOURCES)})")
        start = time.perf_counter()
        module = importlib.import_module(f"symbolic.reproduction.{source}.items")
        found = module.items()
        log.info("reproduced %d items of %s in %.1f s", len(found), source, time.perf_counter() - start)
        items += found
    return items
