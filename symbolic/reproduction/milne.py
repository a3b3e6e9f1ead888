"""Recomputed numbers of Milne et al. (see :mod:`symbolic.reproduction`).

Two parts, in the order of the paper: the sinusoidal steady-state identification and the inertia model
(sections 2.2 and 3.1, Tables 3–5 and 9), then the α-invariant model (sections 2.3–2.4 and 3.2–3.4,
Tables 6–8, 10 and 11).
"""

from __future__ import annotations

from symbolic.reproduction.item import Item


def items() -> list[Item]:
    """The Milne items, in the order of the paper."""
    return sine_identification_items() + alpha_invariant_items()


def sine_identification_items() -> list[Item]:
    """Tables 3, 4, 5 and 9 and the 3.4 Hz linear resonance (:mod:`symbolic.reproduction.milne_sine`)."""
    from symbolic.reproduction import milne_sine  # here, not at the top: the α-invariant part edits the imports

    found: list[Item] = milne_sine.items()
    return found


def alpha_invariant_items() -> list[Item]:
    """Tables 6–8, 10 and 11."""
    found: list[Item] = []
    return found
