"""The discrepancy workflow: where a model and measurements disagree, which physical effect is missing,
the model file patched with it, and the gap before and after (docs/workflow.md).

>>> from symbolic.workflow import diagnose
>>> result = diagnose("axis.toml", "log.csv", out="diagnosis")      # doctest: +SKIP
>>> [(f.effect, f.coordinate, f.parameters) for f in result.found]  # doctest: +SKIP
[('coulomb', 'q', {'coulomb': 20.39})]

The catalogue of effects is :data:`EFFECTS`; :func:`register` adds one (:class:`Effect`).
"""

from __future__ import annotations

from symbolic.workflow.diagnose import diagnose, simulated_path
from symbolic.workflow.result import Diagnosis, Found, SimulatedSignals, Simulator
from symbolic.workflow.effects import EFFECTS, NOT_SUPPORTED, Context, Effect, Signals, register
from symbolic.workflow.search import SearchSettings

__all__ = ["EFFECTS", "NOT_SUPPORTED", "Context", "Diagnosis", "Effect", "Found", "SearchSettings", "Signals", "SimulatedSignals", "Simulator",
           "diagnose", "register", "simulated_path"]
