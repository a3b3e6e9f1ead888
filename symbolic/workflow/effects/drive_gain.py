"""``drive_gain``: the force a drive applies is its logged command times a gain other than 1, judged on the response.

applied(t) = g·command(t), the signal layer's ``[drive] tau_<c> gain`` (docs/data.md). A wrong torque
constant, a current sensor's scale, a gear ratio off by a tooth put it there. On one joint of an arm the
other joints' equations fix the scale of the shared parameters, so the response shows the one joint's gain;
on a single axis whose every parameter is free a gain is the same as scaling them all (the data cannot tell,
and the search names nothing): it needs one known value (a fixed mass or inertia).
"""

from __future__ import annotations

import statistics
from collections.abc import Mapping

from symbolic.workflow.effects.on_response import PARAMETER, Key, ResponseCandidate, ResponseEffect, register_response

PLAUSIBLE = (0.2, 5.0)
"""A drive gain outside this range is a unit or a sign error, not a gain: refused as not physical."""

MIN_CHANGE = 0.02
"""A gain within this share of 1 is not named: a drive's torque constant is known to a few per cent, and a fit
that moves it by less is absorbing something else (a 2-link arm's joint 2 logged late moved joint 1's by 5e-5)."""


class DriveGain(ResponseEffect):
    identifier = "drive_gain"
    summary = "the drive applies its logged command times a gain (a wrong torque constant or current scale)"
    rank = 120
    roles = {"gain": "1"}
    guide = "declare it in the experiment's [drive] (the lines below); check the drive's torque constant and gear ratio"

    def frees(self, model, measurements, coordinate: str) -> dict[Key, float]:
        signal = f"tau_{coordinate}"
        layer = getattr(measurements, "signal_layer", None)
        if layer is None or signal in layer.sensors:  # the log is a force sensor's reading, not a command
            return {}
        return {("drive", signal, "gain"): 1.0}

    def restarts(self, candidate: ResponseCandidate, corrected: Mapping[str, tuple[float, float]]
                 ) -> list[dict[Key, float]]:
        """IDIM-LS fits a joint's own values (those acting on its force alone: friction, rotor inertia) as
        θ/g where its drive applies g × the command: the file's values over the corrected ones are g, and the
        start there — gain at their median, the values at the file's — is where the fit finds the gain when the
        other values are free too (a wrist's force is mostly its own values': from the corrected model the fit
        stays at gain 1, a local minimum)."""
        ratios = [file / now for file, now in corrected.values() if now != 0.0 and file / now > 0.0]
        if not ratios:
            return []
        gain = statistics.median(ratios)
        low, high = PLAUSIBLE
        if not low <= gain <= high or abs(gain - 1.0) < MIN_CHANGE:
            return []
        return [{candidate.frees[0]: gain, **{(PARAMETER, name, ""): file for name, (file, _) in corrected.items()}}]

    def roles_of(self, values: Mapping[Key, object], rate: float) -> dict[str, float]:
        (value,) = values.values()
        return {"gain": value.value}

    def check(self, roles: Mapping[str, float]) -> str | None:
        low, high = PLAUSIBLE
        if not low <= roles["gain"] <= high:
            return f"a gain of {roles['gain']:.4g} is outside {low:g}–{high:g} (a unit or sign, not a gain)"
        if not abs(roles["gain"] - 1.0) >= MIN_CHANGE:
            return f"a gain of {roles['gain']:.5g} is within {100 * MIN_CHANGE:g} % of 1 (not named: module docstring)"
        return None


register_response(DriveGain())
