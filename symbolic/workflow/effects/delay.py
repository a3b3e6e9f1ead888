"""``delay``: a time shift between a coordinate's position and its force, judged on the response.

The logged force lags the motion it belongs to by d samples (fractional allowed): measured τ(t) = τ(t − d·h),
the signal layer's ``[sensors] tau_<c> delay`` (docs/data.md, "The signal layer"). Under a feedback loop the
shift changes only what the simulated controller output is compared with; under torque replay the replayed
force is the log shifted back. A logging path, a bus or a filter in the drive's current measurement put it
there; the inverse dynamics reads it as a phase lead of the force — a negative inertia, a lead of friction —
and cannot name it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from symbolic.workflow.effects.on_response import Key, ResponseEffect, register_response


MAX_SCAN = 100
"""The longest delay (samples) the start scan tries; the fit itself may go on to the layer's limit."""


class Delay(ResponseEffect):
    identifier = "delay"
    summary = "a time shift of the logged force behind the position (a logging or drive delay), in samples"
    rank = 110
    roles = {"delay": "samples", "delay_s": "s"}
    guide = ("declare it in the experiment's [sensors] (the lines below); look for a filter or a bus between the "
             "drive's current and the log")

    def frees(self, model, measurements, coordinate: str) -> dict[Key, float]:
        signal = f"tau_{coordinate}"
        layer = getattr(measurements, "signal_layer", None)
        if layer is None or signal in layer.drive:  # the log is the drive's command: its timing is the drive's
            return {}
        return {("sensors", signal, "delay"): 0.0}

    def start(self, key: Key, simulated: np.ndarray, logged: np.ndarray, limit: float) -> float | None:
        """The whole number of samples d ≤ :data:`MAX_SCAN` that best lines up the simulated force delayed by d
        with the log: the cost of a fractional delay has local minima where a quantised encoder makes the force
        jitter from sample to sample (the interpolation smooths the jitter), so the fit starts at the global one."""
        longest = int(min(limit, MAX_SCAN, len(logged) // 4))
        costs = [float(np.sum((logged[longest:] - simulated[longest - d:len(simulated) - d]) ** 2))
                 for d in range(longest + 1)]
        return float(np.argmin(costs))

    def roles_of(self, values: Mapping[Key, object], rate: float) -> dict[str, float]:
        (value,) = values.values()
        return {"delay": value.value, "delay_s": value.value / rate}


register_response(Delay())
