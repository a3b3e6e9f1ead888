"""The numeric layer: a derived model evaluated with numbers.

:class:`NumericModel` evaluates a :class:`~symbolic.derive.DynamicModel` (inverse and forward dynamics,
state space, linearisation, :mod:`.statespace`); :func:`numeric_model` returns the one cached per model.
Statics (:mod:`.statics`), quantities at the end effector (:mod:`.operational`), base parameters
(:mod:`.base_parameters`) and the stationary Kalman gain (:mod:`.estimator`) live beside it. Simulation
against logs is :mod:`symbolic.simulation`.
"""

from __future__ import annotations

from symbolic.numeric.statespace import NumericModel, natural_frequencies, numeric_model

__all__ = ["NumericModel", "natural_frequencies", "numeric_model"]
