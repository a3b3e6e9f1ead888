"""The numeric layer: a derived model evaluated with numbers.

:class:`NumericModel` evaluates a :class:`~symbolic.derivation.DynamicModel` (inverse and forward dynamics,
state space, linearisation, :mod:`.statespace`); :func:`numeric_model` returns the one cached per model.
Statics (:mod:`.statics`), quantities at the end effector (:mod:`.operational`), base parameters
(:mod:`.base_parameters`) and the stationary Kalman gain (:mod:`.estimator`) live beside it. Simulation
against logs is :mod:`symbolic.simulation`.

>>> import symbolic
>>> model = symbolic.derive(symbolic.robots.load("emps"))      # τ = M q̈ + Fv q̇ + Fc sign(q̇) + offset
>>> num = symbolic.numeric_model(model)                       # parameters at their nominal values
>>> round(float(num.inverse_dynamics([0.0], [0.1], [2.0])[0]), 4)   # 95.1089·2 + 203.5034·0.1 + 20.3935 − 3.1648
227.7968
"""

from __future__ import annotations

from symbolic.numeric.base_parameters import model_base_parameters
from symbolic.numeric.statespace import NumericModel, natural_frequencies, numeric_model

__all__ = ["NumericModel", "model_base_parameters", "natural_frequencies", "numeric_model"]
