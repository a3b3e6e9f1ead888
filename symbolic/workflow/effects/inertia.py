"""An inertia error on one coordinate (a rotor, a coupling)."""

from __future__ import annotations

from symbolic.description.names import ROTOR_STEM, coefficient_name
from symbolic.workflow.effects.base import Effect, drive_of, on_row, register


class Inertia(Effect):
    """An inertia error on one coordinate: ΔI·q̈ on its own row, written as a drive's rotor inertia."""

    name, roles, axis = "inertia", ("inertia",), "acceleration"
    summary = "inertia error on one coordinate (a rotor, a coupling): ΔI·q̈, as a [[drive]] rotor inertia"
    formula, regressors, written_as = 'ΔI·q̈', 'q̈', '`[[drive]] rotor_inertia` (ΔI/ratio²)'
    rank, units = 60, {"inertia": "{force}·s²/{position}"}

    def applicable(self, context, j):
        c = context.coordinates[j]
        if c in context.unactuated:
            # the equation's scale is held at one of its parameters (workflow/terms.py, hold_scales): an inertia
            # term on it only moves that scale again, and fits the errors-in-variables of its twice
            # differentiated positions (0.04 % of the link's inertia, p = 1e-47, on the flexible rig)
            return f"{c} has no actuator (τ = 0): an inertia on its equation only rescales it"
        return None if c in context.robot.coordinates else f"{c} is a modal coordinate"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [qdd[:, j]])

    def roles_of(self, c, value, reference):
        return {"inertia": float(c[0])}

    def check(self, roles, reference, context, j):
        rotor, ratio = drive_of(context, j)
        if rotor * ratio**2 + roles["inertia"] >= 0:
            return None
        return f"an inertia change of {roles['inertia']:.4g} would make the rotor inertia on {context.coordinates[j]} negative"

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        _, ratio = drive_of(context, j)
        name = editor.parameter(coefficient_name(ROTOR_STEM, coordinate), roles["inertia"] / ratio**2, comment)
        old = editor.drive_value(coordinate, "rotor_inertia")
        editor.set_drive(coordinate, "rotor_inertia", name if old is None else f"{old} + {name}", comment)
        return {name: roles["inertia"] / ratio**2}


register(Inertia())
