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

__all__ = ["EFFECTS", "NOT_SUPPORTED", "Context", "Diagnosis", "Effect", "Found", "SearchSettings", "Signals", "SimulatedSignals", "Simulator",
           "diagnose", "register", "simulated_path"]

_HOMES = {"diagnose": "diagnosis", "simulated_path": "diagnosis", "Diagnosis": "result", "Found": "result",
          "SimulatedSignals": "result", "Simulator": "result", "EFFECTS": "effects", "NOT_SUPPORTED": "effects",
          "Context": "effects", "Effect": "effects", "Signals": "effects", "register": "effects",
          "SearchSettings": "records"}


def __getattr__(name: str) -> object:
    """The names of :data:`__all__` on first use (PEP 562): importing one module of the workflow (the effect
    files' summaries for ``diagnose --help``) does not import the search, SciPy's statistics and SymPy."""
    if name in _HOMES:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
