"""Effects judged on the response: what the machine hides in its simulated response, not in its inverse dynamics.

A delay between a coordinate's position and its force, a drive's gain, a position sensor's bias, a model
file's stiffness or damping that the noisy accelerations cannot correct: none is a column of the inverse
dynamics that IDIM-LS could fit, so the equation-error search (:class:`~symbolic.workflow.effects.base.Effect`)
cannot name them. A :class:`ResponseEffect` instead says which *values* it frees — of the experiment's signal
layer (:mod:`symbolic.data.signal_layer`) or of the model file's ``[parameters]`` — and the response search
(:mod:`symbolic.workflow.response`) fits them by the output error of the machine's own closed loop and names
the effect when its fit lowers the held-out simulation error (docs/workflow.md, "Judged on the response").

Adding one: a module in this folder whose effect subclasses :class:`ResponseEffect` and ends with
``register_response(MyEffect())``.

A value the output error cannot free (a drive's delay inside a feedback loop moves the loop by whole samples)
is scanned instead (:attr:`ResponseEffect.scan`) and declared fixed at its value (:func:`fixed_key`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:
    from symbolic.data.measurements import Measurements
    from symbolic.derivation.dynamics import DynamicModel
    from symbolic.identify.output_error import FittedParameter

PARAMETER = "parameter"
"""The table of a model-file value in a :data:`Key` (its signal is the parameter's name, its field empty)."""

Key = tuple[str, str, str]
"""A value a response effect frees: ``(table, signal, field)`` of the signal layer (``("sensors", "tau_q1",
"delay")``), or ``(PARAMETER, name, "")`` of the model file."""


@dataclass(frozen=True)
class ResponseCandidate:
    """One effect on one coordinate (or one model-file value): the values it frees, each with its null value
    (what "nothing missing" means: delay 0, gain 1, bias 0, a parameter's value now)."""

    effect: ResponseEffect
    coordinate: str
    frees: tuple[Key, ...]
    null: tuple[float, ...]

    def label(self) -> str:
        subject = self.frees[0][1] if self.frees[0][0] == PARAMETER else (self.coordinate or "all")
        return f"{self.effect.identifier}({subject})"


class ResponseEffect:
    """An effect the response search judges (module docstring).

    Attributes
    ----------
    identifier, summary
        The name (``diagnose --effects``, the JSON) and one line saying what it is.
    rank
        Order in the catalogue (after the equation-error effects).
    roles
        ``{role: unit}`` of what :meth:`roles_of` reports.
    guide
        Where to look when it is named (one sentence for the report).
    """

    identifier: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    scan: ClassVar[tuple[float, ...]] = ()
    """Values to try in turn instead of fitting (a value the output error cannot free: whole samples of a delay
    inside the loop); each is simulated with the accepted values refitted, the one that lowers the estimation
    data's simulation error most is judged, and it has no σ (the distance from nothing missing is not asked; the range's end is not located)."""
    rank: ClassVar[int] = 100
    roles: ClassVar[dict[str, str]] = {}
    guide: ClassVar[str] = ""

    def candidates(self, model: DynamicModel, measurements: Measurements, fixed: set[str]) -> list[ResponseCandidate]:
        """The candidates on these data: by default one per coordinate the loop drives that :meth:`frees`
        accepts; ``fixed``: parameter names kept at their values."""
        out = []
        for c in _driven(measurements):
            frees = self.frees(model, measurements, c)
            if frees:
                out.append(ResponseCandidate(self, c, tuple(frees), tuple(frees.values())))
        return out

    def frees(self, model: DynamicModel, measurements: Measurements, coordinate: str) -> dict[Key, float]:
        """``{key: null value}`` freed on ``coordinate``; empty where the effect cannot act there."""
        return {}

    def start(self, key: Key, simulated: np.ndarray, logged: np.ndarray, limit: float) -> float | None:
        """Where the fit of ``key`` starts, from the current model's ``simulated`` signal and the ``logged`` one
        (``None``: its null value). A value whose cost has several minima (a delay of a jittering force) scans
        here for the global one."""
        return None

    def restarts(self, candidate: ResponseCandidate, corrected: Mapping[str, tuple[float, float]]
                 ) -> list[dict[Key, float]]:
        """Further starts of ``candidate``'s fit, beside the current model's: where this effect is what the
        equation error's ``corrected`` values of the candidate's coordinate stand in for (``{name: (model file's
        value, corrected value)}``, the values acting on that coordinate's force alone), a start at the effect's
        value that explains them with those values back at the file's. The fit from there may reach a lower
        minimum than the one the corrections sit in; the best start on the estimation data is judged."""
        return []

    def roles_of(self, values: Mapping[Key, FittedParameter], rate: float) -> dict[str, float]:
        """What the report names: the fitted values by role."""
        return {key[2] or key[1]: v.value for key, v in values.items()}

    def check(self, roles: Mapping[str, float]) -> str | None:
        """Why the fitted values are not physical, or ``None``."""
        return None

    def written_as(self, values: Mapping[Key, FittedParameter]) -> list[str]:
        """The lines to write into the experiment file (the model file's values are patched by the workflow)."""
        lines = []
        for (table, signal, name), v in values.items():
            if table != PARAMETER:
                lines += [f"[{table}]", f"{signal} = {{ {name} = {v.value:.6g} }}"]
        return lines

    def describe(self) -> dict[str, Any]:
        return {"effect": self.identifier, "summary": self.summary, "judged_on": "response",
                "parameters": dict(self.roles)}


def fixed_key(key: Key) -> bool:
    """Whether ``key`` is declared fixed rather than free once accepted: a drive's delay (the loop delays its
    command by whole samples; the output error has no sensitivity to it)."""
    return key[0] == "drive" and key[2] == "delay"


def _driven(measurements: Measurements) -> Sequence[str]:
    """The coordinates whose force varies in the log (a coordinate without actuator has nothing to delay)."""
    tau = np.asarray(measurements.tau, float)
    return [c for j, c in enumerate(measurements.coordinates) if np.ptp(tau[:, j]) > 0]


RESPONSE_EFFECTS: dict[str, ResponseEffect] = {}
"""The registered response effects by identifier, in rank order."""


def register_response(effect: ResponseEffect) -> ResponseEffect:
    """Add ``effect`` to :data:`RESPONSE_EFFECTS` (refused: an identifier taken, or a summary missing)."""
    from symbolic.workflow.effects.base import EFFECTS

    if not effect.identifier or effect.identifier in RESPONSE_EFFECTS or effect.identifier in EFFECTS:
        raise ValueError(f"response effect {effect.identifier!r}: identifier empty or taken")
    if not effect.summary:
        raise ValueError(f"response effect {effect.identifier!r}: no summary")
    RESPONSE_EFFECTS[effect.identifier] = effect
    ordered = sorted(RESPONSE_EFFECTS.values(), key=lambda e: (e.rank, e.identifier))
    RESPONSE_EFFECTS.clear()
    RESPONSE_EFFECTS.update({e.identifier: e for e in ordered})
    return effect
