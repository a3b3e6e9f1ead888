"""What :func:`symbolic.workflow.diagnosis.diagnose` returns: the fits, the effects found, the JSON contract.

Kept apart from the procedure so that the report and the figures (:mod:`.report`, :mod:`.figures`) read
a diagnosis without importing the code that makes one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from symbolic.data import Measurements
from symbolic.derivation.dynamics import DynamicModel
from symbolic.workflow.dataset import DataSet
from symbolic.workflow.effects import NOT_SUPPORTED
from symbolic.workflow.effects.base import labelled
from symbolic.workflow.records import Accepted, variant_of
from symbolic.workflow.search import Search
from symbolic.workflow.terms import NominalFit


@dataclass(frozen=True, eq=False)
class SimulatedSignals:
    """What a simulated path may return instead of τ alone: τ_model, q and q̇ (samples × the data's
    coordinates), so that the gap is also measured on position and velocity."""

    tau: np.ndarray
    q: np.ndarray
    qd: np.ndarray


Simulator = Callable[[DynamicModel, np.ndarray, Measurements], "np.ndarray | SimulatedSignals"]
"""``simulate(model, p, measurements) -> τ_model``: the model (parameter values ``p`` in the order of
``model.parameter_symbols``) run the way ``measurements`` were produced (their experiment's controller
and reference); returns the controller's output, ``samples × N`` at the measurements' samples."""


@dataclass(frozen=True)
class Found:
    """An accepted effect: role parameters (final joint fit) and σ, the model-file parameters written, evidence."""

    effect: str
    coordinate: str
    parameters: dict[str, float | None]
    sigmas: dict[str, float | None]
    model_parameters: dict[str, float]
    evidence: dict[str, Any]
    variant: str | None = None
    """Which variant of ``effect`` (``"position"`` or ``"time"`` for ``periodic``, ``"one_encoder"`` for
    ``joint_elasticity`` from the motor encoder alone); ``None`` for the others."""

    def label(self) -> str:
        """``periodic (in time)``, ``joint_elasticity (one encoder)``, ``coulomb``: the effect as the report names it."""
        return labelled(self.effect, self.variant)

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, **({"variant": self.variant} if self.variant else {}),
                "coordinate": self.coordinate, "parameters": dict(self.parameters),
                "model_parameters": dict(self.model_parameters), "evidence": {**self.evidence, "sigma": dict(self.sigmas)}}


@dataclass(frozen=True, eq=False)
class Fit:
    """A model identified on the estimation data and its gaps."""

    model: DynamicModel = field(repr=False)
    nominal: NominalFit = field(repr=False)
    predicted: dict[str, np.ndarray] = field(repr=False)
    gap: dict[str, float]
    detail: dict[str, dict[str, float]]
    motion: dict[str, dict[str, dict[str, float]]] | None = None
    """Per data set, ``{"position"|"velocity": {coordinate: %}}`` on the simulated path (None otherwise)."""


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """What :func:`diagnose` found (module docstring); :meth:`to_dict` is the ``--json`` contract."""

    model: DynamicModel = field(repr=False)
    sets: dict[str, DataSet] = field(repr=False)
    held_out: str
    before: Fit = field(repr=False)
    """The nominal model identified, the values named corrections held at the model file's (docs/workflow.md §5)."""
    where_before: dict[str, Any] = field(repr=False)
    search: Search = field(repr=False)
    found: tuple[Found, ...]
    patched_text: str | None = field(repr=False)
    patched_path: Path | None
    after: Fit = field(repr=False)
    where_after: dict[str, Any] = field(repr=False)
    simulated: bool = False
    seconds: dict[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    figures: tuple[Path, ...] = ()
    data_findings: tuple[dict[str, Any], ...] = ()
    """What the data's treatment, not the model, explains (:func:`symbolic.workflow.diagnosis.held_force_finding`)."""
    corrections: tuple[dict[str, Any], ...] = ()
    """Model-file values the data move beyond 3σ and 10 % (:mod:`symbolic.workflow.corrections`)."""
    changes: tuple[dict[str, Any], ...] = ()
    """Every model-file value the patch re-identified, removed, or kept because the fit is not physical."""
    modes: dict[str, Any] | None = None
    """Linearised modes before and after, for a model with elastic coordinates (``None`` otherwise)."""
    caveats: tuple[str, ...] = ()
    """Notes the terminal shows too: how the diagnosis departed from what was asked (nothing to re-identify, a
    simulated path that diverged and was replaced by the inverse model); also among :attr:`notes`."""
    response: Any = None
    """The search judged on the response (:class:`symbolic.workflow.response.ResponseSearch`) of a diagnosis
    on the simulated path with the machine's controller; ``None`` otherwise."""
    elasticity: tuple[Any, ...] = ()
    """The two-encoder tests of joint elasticity (:class:`symbolic.workflow.effects.joint_elasticity.Elasticity`),
    named or not, one per coordinate whose link-side position is logged."""
    cpu_seconds: dict[str, float] = field(default_factory=dict)
    """CPU time of each step, this process's and its finished children's (the search's forked half, a compiler):
    ``seconds`` is the wall time; on a shared machine only the CPU time repeats."""

    def alignment(self) -> dict[str, dict[str, Any]] | None:
        """How the bags read were aligned, by data set (:func:`symbolic.data.bags.alignments`); ``None`` when the
        data are no bag. The JSON's ``"alignment"``, which report.md and the HTML page are written from."""
        from symbolic.data.bags import alignments

        return alignments(*((role, self.sets[role].measurements) for role in ("estimation", "validation")
                            if role in self.sets))

    def to_dict(self) -> dict[str, Any]:
        """The JSON contract: model, found, gap_before, gap_after, gap_detail, patched_model (and more)."""
        def detail(fit: Fit) -> dict[str, Any]:
            motion = fit.motion or {}
            return {role: {"force": fit.detail[role], "position": motion.get(role, {}).get("position"),
                           "velocity": motion.get(role, {}).get("velocity")} for role in fit.detail}

        last = self.search.rounds[-1] if self.search.rounds else None
        return {
            "model": self.model.name,
            "found": [f.to_dict() for f in self.found],
            "gap_before": dict(self.before.gap),
            "gap_after": dict(self.after.gap),
            "gap_detail": {"before": detail(self.before), "after": detail(self.after),
                           "signals": "force" if not self.simulated else "force (simulated controller output)",
                           "note": None if self.before.motion else
                           "position and velocity gaps need the simulated path (--simulate with a declared "
                           "controller); the inverse model compares forces"},
            "patched_model": None if self.patched_path is None else str(self.patched_path),
            "held_out": self.held_out,
            "path": "simulated" if self.simulated else "inverse",
            "verdict": {"before": self.where_before["verdict"], "after": self.where_after["verdict"],
                        "left": self.where_after["left"]},
            "where": _plain(self.where_before),
            "rejected": [] if last is None else [c.summary(self.search.context.coordinates) for c in last.candidates
                                                 if c.status == "tested"],
            "rejected_groups": [] if last is None else [g.summary(self.search.context.coordinates) for g in last.groups],
            "not_identifiable": [] if last is None else [c.summary(self.search.context.coordinates) for c in last.candidates
                                                         if c.status == "not identifiable"],
            "removed": [{**_removed(a), "final_p_value": p, "explained_by": others}
                        for a, p, others in self.search.removed],
            "removed_at_lowered_band": [{**_removed(a), "lowered_band_p_value": p} for a, p in self.search.unconfirmed],
            "not_supported": dict(NOT_SUPPORTED),
            "data_findings": [dict(f) for f in self.data_findings],
            "corrections": _plain(list(self.corrections)),
            "parameter_changes": _plain(list(self.changes)),
            "modes": _plain(self.modes),
            "response": None if self.response is None else _plain(self.response.to_dict()),
            "joint_elasticity": [_plain(e.to_dict()) for e in self.elasticity],
            "alignment": self.alignment(),
            "notes": list(self.notes),
            "figures": [str(p) for p in self.figures],
        }


def _removed(a: Accepted) -> dict[str, Any]:
    """An accepted effect the search removed at the end, as the JSON lists it (with the test that removed it)."""
    c = a.candidate
    return {"effect": c.effect.identifier, **variant_of(c.effect), "coordinate": c.coordinate, "round": a.round,
            "parameters": dict(c.roles)}


def _plain(value: Any) -> Any:
    """JSON-ready copy: NumPy numbers to floats, bin edges and means kept."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
