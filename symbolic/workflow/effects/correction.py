"""``correction``: a model file's stiffness or damping corrected by the output error, judged on the response.

IDIM-LS corrects a model-file value from the inverse dynamics at the measured accelerations; an elastic
coordinate read by a coarse, noisy sensor (a strain gauge at 12 bits) has accelerations too noisy for that,
while its resonance sits plainly in the closed loop's response. The candidate frees one ``[parameters]``
value that is a stiffness or a damping (:func:`symbolic.workflow.corrections.parameter_kind`) and fits it by
the output error; the workflow writes the fitted value into the patched model file.
"""

from __future__ import annotations

from collections.abc import Mapping

from symbolic.workflow.effects.on_response import PARAMETER, Key, ResponseCandidate, ResponseEffect, register_response

KINDS = ("stiffness", "damping")

MIN_CHANGE = 0.10
"""A correction moves a model-file value by this share at least (symbolic.workflow.corrections' rule)."""


class Correction(ResponseEffect):
    identifier = "correction"
    summary = "a model file's stiffness or damping whose value the response corrects (output error)"
    rank = 140
    roles = {"value": "the parameter's", "file_value": "the parameter's", "relative_change": "1"}
    guide = "the patched model file holds the corrected value; compare the modes before and after"

    def candidates(self, model, measurements, fixed: set[str]) -> list[ResponseCandidate]:
        from symbolic.workflow.corrections import parameter_kind

        robot = model.robot
        out = []
        for parameter in robot.parameters:
            if parameter.name in fixed or getattr(parameter, "fixed", False):
                continue
            if parameter_kind(robot, parameter.name) not in KINDS:
                continue
            coordinate = force_coordinate(robot, parameter.name)
            if coordinate not in measurements.coordinates:  # a coordinate the data lack (a second mass's
                coordinate = ""  # deflection): judged where the data compare, on every coordinate they hold
            value = float(model.parameters[parameter.symbol])
            out.append(ResponseCandidate(self, coordinate, ((PARAMETER, parameter.name, ""),), (value,)))
        return out

    def roles_of(self, values: Mapping[Key, object], rate: float) -> dict[str, float]:
        (value,) = values.values()
        change = (value.value - value.start) / value.start if value.start else float("nan")
        return {"value": value.value, "file_value": value.start, "relative_change": change}

    def check(self, roles: Mapping[str, float]) -> str | None:
        if roles["value"] <= 0:
            return f"the fitted value {roles['value']:.4g} is not positive"
        if not abs(roles["relative_change"]) >= MIN_CHANGE:
            return (f"moves the value by {100 * roles['relative_change']:.3g} % (a correction moves it by "
                    f"{100 * MIN_CHANGE:g} % at least, as IDIM-LS's corrections)")
        return None


def force_coordinate(robot, name: str) -> str:
    """The coordinate of the ``[[force]]`` whose expression holds parameter ``name`` ("" for none: a beam's
    stiffness acts on the beam's modes)."""
    import sympy as sp

    symbol = next(p.symbol for p in robot.parameters if p.name == name)
    return next((f.coordinate for f in robot.forces if symbol in sp.sympify(f.expression).free_symbols), "")


register_response(Correction())
