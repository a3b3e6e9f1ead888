"""``sensor_bias``: a position sensor reads the coordinate plus a constant, judged on the response.

measured q(t) = q(t) + b, the signal layer's ``[sensors] q_<c> bias`` (docs/data.md): an encoder's index
set off by a homing error. The controller reads the biased position, so the machine holds a shifted pose;
where gravity or a spring acts at known parameters the response shows it. With every inertial parameter
of the links beyond free, a bias is a rotation of those links' frames and the data cannot tell it (the
search names nothing).

Under a quantising ``[controller]`` the fit adds the bias to the quantised reading (an index offset applied to the
counted position), where a declared fixed bias is quantised with the position: the two readings differ by less
than one count, the encoder's own rounding, and the bias's sensitivity through the loop is then exact (the
reference row, :mod:`symbolic.identify.output_error`).
"""

from __future__ import annotations

from collections.abc import Mapping

from symbolic.workflow.effects.on_response import Key, ResponseEffect, register_response


MIN_BIAS = 1e-4
"""A bias below this (rad or m: 0.006°, a tenth of a millimetre) is not named: no homing error is that small,
and where the simulation already follows the log to its floor (exact positions) a bias of 4e-5 rad still
"removed" 29 % of a held-out error of 0.003 %."""


class SensorBias(ResponseEffect):
    identifier = "sensor_bias"
    summary = "a position sensor reads the coordinate plus a constant (a homing or index offset)"
    rank = 130
    roles = {"bias": "coordinate"}
    guide = "declare it in the experiment's [sensors] (the lines below), or home the axis again"

    def frees(self, model, measurements, coordinate: str) -> dict[Key, float]:
        if getattr(measurements, "signal_layer", None) is None:
            return {}
        return {("sensors", f"q_{coordinate}", "bias"): 0.0}

    def roles_of(self, values: Mapping[Key, object], rate: float) -> dict[str, float]:
        (value,) = values.values()
        return {"bias": value.value}

    def check(self, roles: Mapping[str, float]) -> str | None:
        if not abs(roles["bias"]) >= MIN_BIAS:
            return f"a bias of {roles['bias']:.3g} is below {MIN_BIAS:g} (not named: module docstring)"
        return None


register_response(SensorBias())
