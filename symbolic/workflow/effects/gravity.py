"""A mass moment the model lacks or has wrong about a revolute coordinate."""

from __future__ import annotations

import numpy as np

from symbolic.workflow.effects._sinusoid import Sinusoid
from symbolic.workflow.effects.base import on_row, register


class Gravity(Sinusoid):
    """An unbalanced or missing mass moment about a revolute coordinate: moment·sin(q + phase) on the τ side."""

    name, roles, axis = "gravity", ("moment", "phase"), "position"
    summary = "unbalanced or missing mass moment m·g·l about a revolute coordinate: moment·sin(q + phase)"
    formula, regressors, written_as = 'moment·sin(q + phase)', 'sin q, cos q', '`[[force]] -(Gs*sin(q) + Gc*cos(q))`'
    rank, units = 50, {"moment": "{force}", "phase": "rad"}

    def applicable(self, context, j):
        kind = context.kind(context.coordinates[j])
        return None if kind == "revolute" else f"{context.coordinates[j]} is {kind}, not revolute"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.sin(q[:, j]), np.cos(q[:, j])])

    def roles_of(self, c, value, reference):
        moment, phase = self.polar(c)
        return {"moment": moment, "phase": phase}

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        return self.write(editor, "gravity", coordinate, ("Gs", "Gc"), coordinate, c, comment, "moment")


register(Gravity())
