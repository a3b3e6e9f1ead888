"""A design checked in the machine's own loop: the reference run through the experiment's ``[controller]`` by
:func:`symbolic.simulation.simulate` (the model at its nominal values), the tracking error and the peak force
against its limit reported, and saturation found (docs/data.md, "Checked in the loop").

A design saturates when a coordinate's controller output reaches its ``saturation`` (|u| ≥ saturation, u = τ/gain)
on any sample, or when the force the loop applies exceeds the declared torque limit: the reference is then not
what the robot would run, and :func:`refusal` says so and by how much to lower the limit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from symbolic.data import Experiment, Measurements
from symbolic.derivation.dynamics import DynamicModel
from symbolic.errors import IdentificationError
from symbolic.identify.excitation import FourierTrajectory, Limits, reference_samples

MARGIN = 0.95
"""The suggested torque limit of a refused design: the declared one scaled by limit/peak and this margin."""


@dataclass(frozen=True)
class LoopCheck:
    """Per coordinate of the design: the largest and RMS tracking error |q − r|, the peak |τ| of the loop, its
    limit, and whether the controller's output saturated; ``controller`` describes the loop."""

    coordinates: tuple[str, ...]
    tracking_max: np.ndarray
    tracking_rms: np.ndarray
    peak_torque: np.ndarray
    torque_limit: np.ndarray
    saturated: np.ndarray
    controller: str
    output_limit: np.ndarray
    """|gain|·saturation per coordinate: the largest force the controller can command (``inf``: no saturation)."""

    @property
    def over(self) -> np.ndarray:
        """Coordinates whose loop force exceeds the declared limit."""
        return self.peak_torque > self.torque_limit

    @property
    def refused(self) -> bool:
        return bool(self.saturated.any() or self.over.any())

    def to_dict(self) -> dict[str, Any]:
        return {"controller": self.controller, "refused": self.refused,
                "coordinates": {c: {"tracking_max": float(self.tracking_max[i]), "tracking_rms": float(self.tracking_rms[i]),
                                    "peak_torque": float(self.peak_torque[i]), "torque_limit": float(self.torque_limit[i]),
                                    "saturated": bool(self.saturated[i])} for i, c in enumerate(self.coordinates)}}

    def table(self) -> list[str]:
        lines = [f"In the loop ({self.controller}), the model at its nominal values:", "",
                 # ‖τ‖, not |τ|: a "|" would split the Markdown table's cell
                 "| coordinate | tracking error max | RMS | peak ‖τ‖ | limit | refused |", "|---|---|---|---|---|---|"]
        lines += [f"| {c} | {self.tracking_max[i]:.4g} | {self.tracking_rms[i]:.4g} | {self.peak_torque[i]:.4g} | "
                  f"{self.torque_limit[i]:g} | {self._verdict(i)} |" for i, c in enumerate(self.coordinates)]
        return lines

    def _verdict(self, i: int) -> str:
        """Why coordinate ``i`` refuses the design (the controller's output saturated, the force over its limit)."""
        reasons = [why for why, holds in (("saturated", self.saturated[i]), ("over the limit", self.over[i])) if holds]
        return ", ".join(reasons) or "no"


def check_in_loop(model: DynamicModel, trajectory: FourierTrajectory, rate: float, limits: Limits,
                  controller: Mapping[str, Any]) -> LoopCheck:
    """Run ``trajectory`` sampled at ``rate`` through ``controller`` (a ``[controller]`` table reading the
    reference as ``ref``, its velocity as ``refd_<c>``) and measure it (module docstring)."""
    from symbolic.simulation import simulate
    from symbolic.simulation.controller import drive_gains

    t, q, qd, _ = reference_samples(trajectory, rate)
    names = trajectory.coordinates
    log = Measurements.from_arrays(t, names, q, np.zeros_like(q), ref=q,
                                   extras={f"refd_{c}": qd[:, i] for i, c in enumerate(names)})
    run = simulate(model, Experiment.of(log, controller=dict(controller)))
    simulated = run.simulated
    index = [simulated.coordinates.index(c) for c in names]
    error = simulated.q[:, index] - q
    tau = simulated.tau[:, index]
    ctrl = run.controller
    gains = drive_gains(ctrl, model.parameter_vector.with_array(None).by_symbol())
    saturated, output = np.zeros(len(names), bool), np.full(len(names), np.inf)
    for k, c in enumerate(ctrl.coordinates):
        i = names.index(c)
        limit = ctrl.saturation[k]
        if np.isfinite(limit) and gains[k] != 0:
            output[i] = abs(gains[k]) * limit
            saturated[i] = bool(np.any(np.abs(tau[:, i] / gains[k]) >= limit * (1 - 1e-9)))
    return LoopCheck(names, np.abs(error).max(axis=0), np.sqrt(np.mean(error**2, axis=0)), np.abs(tau).max(axis=0),
                     limits.torque, saturated, ctrl.describe(), output)


def suggested(check: LoopCheck, i: int) -> float:
    """A torque limit for coordinate ``i`` that leaves the loop room: below the controller's output limit and the
    declared limit, scaled by the excess, times :data:`MARGIN`."""
    scale = min(1.0, check.torque_limit[i] / check.peak_torque[i]) if check.peak_torque[i] > 0 else 1.0
    return float(min(check.torque_limit[i] * scale, check.output_limit[i]) * MARGIN)


def refusal(check: LoopCheck) -> IdentificationError:
    """The one-line refusal of a design that saturates, with the torque limits that would leave a margin."""
    bad = [i for i, c in enumerate(check.coordinates) if check.saturated[i] or check.over[i]]
    parts = [f"{check.coordinates[i]} peak |τ| {check.peak_torque[i]:.4g} " + (
        f"reaches the controller's output limit {check.output_limit[i]:.4g} (|gain|·saturation)" if check.saturated[i]
        else f"exceeds the limit {check.torque_limit[i]:g}") for i in bad]
    suggestion = ",".join(f"{check.coordinates[i]}={suggested(check, i):.4g}" for i in bad)
    return IdentificationError(f"the design saturates in the loop of the experiment's [controller] ({check.controller}): "
                               f"{'; '.join(parts)}; it is not handed out: lower the torque limit (--torque {suggestion}) "
                               "or retune the controller, and design again")
