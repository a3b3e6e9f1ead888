"""The numeric layer: derived SymPy expressions turned into NumPy and CasADi callables.

:class:`NumericModel` evaluates a :class:`~symbolic.derive.DynamicModel` (inverse and forward
dynamics, state space, linearisation); :func:`numeric_model` returns the one cached per model.
:func:`simulate` runs a model against a measured log with the machine's controller.
"""

from __future__ import annotations

from symbolic.numeric.functions import compile_function
from symbolic.numeric.simulate import Simulation, simulate
from symbolic.numeric.statespace import NumericModel, natural_frequencies, numeric_model

__all__ = ["NumericModel", "Simulation", "compile_function", "natural_frequencies", "numeric_model", "simulate"]
