"""The numeric layer: derived SymPy expressions turned into NumPy and CasADi callables.

:class:`NumericModel` evaluates a :class:`~symbolic.derive.DynamicModel` (inverse and forward
dynamics, state space, linearisation); :func:`numeric_model` returns the one cached per model.
:func:`simulate` runs a model against a measured log with the machine's controller.
"""

from __future__ import annotations

from symbolic.numeric.functions import compile_function
from symbolic.numeric.statespace import NumericModel, natural_frequencies, numeric_model

__all__ = ["NumericModel", "Simulation", "compile_function", "natural_frequencies", "numeric_model", "simulate"]


def __getattr__(name: str) -> object:
    """``simulate`` and ``Simulation`` on first use: they bring SciPy's signal processing (symbolic.data),
    which every other command would otherwise pay for at start-up (about 1 s)."""
    if name in ("simulate", "Simulation"):
        from symbolic.numeric import simulation

        return getattr(simulation, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
