"""The catalogue of physical effects the workflow can name: one module per family in this folder.

Each effect is a named, parametrised term that a model file can hold (:class:`~symbolic.workflow.effects.base.Effect`):
on which coordinates it can act, its columns (linear in its coefficients, with at most a grid of nonlinear
values), its parameters by role with their units, whether they are physical, how it is written into the model
file, and what it excludes. The search, the report, the figures, ``symbolic diagnose --list-effects`` and
docs/workflow.md's table read everything from the effect.

Adding an effect: a module in this folder whose effect subclasses :class:`~symbolic.workflow.effects.base.Effect`
and ends with ``register(MyEffect())`` — that is all (docs/workflow.md, "Adding an effect", a complete example).
Every module of the folder is imported here, in name order; the catalogue's order is the effects' ``rank``.
"""

from __future__ import annotations

import importlib
import pkgutil

from symbolic.workflow.effects.base import (EFFECTS, NOT_SUPPORTED, Context, Effect, Roles, Signals, catalogue,
                                            check_effect, excluded, groups, listing, markdown_table, on_row,
                                            register, select)

for _module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if _module.name != "base" and not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")

from symbolic.workflow.effects.flexible_mode import FlexibleMode  # noqa: E402 - after discovery, for direct use
from symbolic.workflow.effects.friction import (AsymmetricCoulomb, AsymmetricViscous, Coulomb, Offset,  # noqa: E402
                                                Stribeck, Viscous)
from symbolic.workflow.effects.gravity import Gravity  # noqa: E402
from symbolic.workflow.effects.inertia import Inertia  # noqa: E402
from symbolic.workflow.effects.payload import Payload  # noqa: E402
from symbolic.workflow.effects.periodic import Periodic, PeriodicTime  # noqa: E402
from symbolic.workflow.effects.spring import Spring  # noqa: E402

__all__ = ["EFFECTS", "NOT_SUPPORTED", "AsymmetricCoulomb", "AsymmetricViscous", "Context", "Coulomb", "Effect",
           "FlexibleMode", "Gravity", "Inertia", "Offset", "Payload", "Periodic", "PeriodicTime", "Roles", "Signals",
           "Spring", "Stribeck", "Viscous", "catalogue", "check_effect", "excluded", "groups", "listing", "markdown_table", "on_row", "register",
           "select"]
