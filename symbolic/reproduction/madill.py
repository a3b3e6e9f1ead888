"""Recomputed numbers of the Madill seed (see :mod:`symbolic.reproduction`)."""

from __future__ import annotations

from symbolic.reproduction.item import Item


def items() -> list[Item]:
    """The Madill items, in the order of the source."""
    found: list[Item] = []
    return found
