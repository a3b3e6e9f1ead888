"""The discrepancy workflow: where a model and measurements disagree, which physical effect is missing,
the model file patched with it, and the gap before and after (docs/workflow.md).

>>> from symbolic.workflow import EFFECTS, diagnose
>>> {"coulomb", "stribeck", "flexible_mode", "payload"} <= set(EFFECTS)     # the catalogue
True

With a model file and a measured log (the EMPS data are not shipped: ``../shared/data/emps/``)::

    result = diagnose("emps", "emps_estimation.experiment.toml", out="diagnosis")
    [(f.effect, f.coordinate, f.parameters) for f in result.found]      # [('coulomb', 'q', {...}), ...]

:func:`register` adds an effect to the catalogue (:class:`Effect`).
"""

from __future__ import annotations

from symbolic.workflow.diagnosis import diagnose, simulated_path
from symbolic.workflow.result import Diagnosis, Found, SimulatedSignals, Simulator
from symbolic.workflow.effects import EFFECTS, NOT_SUPPORTED, Context, Effect, Signals, register
from symbolic.workflow.records import SearchSettings

__all__ = ["EFFECTS", "NOT_SUPPORTED", "Context", "Diagnosis", "Effect", "Found", "SearchSettings", "Signals", "SimulatedSignals", "Simulator",
           "diagnose", "register", "simulated_path"]
