"""Simulation of a model against a measured log with the machine's controller (docs/simulation.md).

The loop (:mod:`.simulator`: :func:`simulate`, :class:`Simulation`), the controllers of an experiment's
``[controller]`` table (:mod:`.controller`), the comparison of simulated and measured signals
(:mod:`.comparison`) and its figures (:mod:`.figures`).
"""

from __future__ import annotations

__all__ = ["Simulation", "simulate"]


def __getattr__(name: str) -> object:
    """``simulate`` and ``Simulation`` on first use: they bring SciPy's signal processing (symbolic.data),
    which every other command would otherwise pay for at start-up (about 1 s)."""
    if name in ("simulate", "Simulation"):
        from symbolic.simulation import simulator

        return getattr(simulator, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
