"""What the search works with and returns (docs/workflow.md, "Name"): its settings, the grouped hypotheses,
the candidates and groups as judged, the accepted effects and the rounds. Plain records: the search
(:mod:`symbolic.workflow.search`) fills them, the diagnosis, the report and the JSON read them."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symbolic.workflow.effects import Effect
from symbolic.workflow.statistics import ALPHA, MIN_HELD_OUT_GAIN

TIE_TOLERANCE = 2.0
"""Two candidates tie when twice their log-likelihood difference is at most this: a difference of 2 on the
BIC scale is "not worth more than a bare mention" (Kass and Raftery 1995)."""
FOLDS = 5
"""Contiguous time blocks of the cross-validation (without validation data)."""

@dataclass(frozen=True)
class SearchSettings:
    """The search's thresholds (module docstring).

    ``groups``: named groups of coordinates (``{"wrist": ("q5", "q6", "q7")}``) on which the grouped
    hypotheses are offered besides every coordinate; ``grouped = False`` offers none.

    ``processes``: how many processes evaluate a round's candidates, 1 or 2. ``None`` chooses: two (this one
    and a forked copy, :mod:`symbolic.workflow.forked`) where the platform allows it and the search is large
    enough (:data:`symbolic.workflow.search.FORK_ROWS`), else one; 1 keeps everything in this process (a campaign's tasks: its workers
    use the cores already); 2 forks wherever the platform allows it. The results are the same either way."""

    alpha: float = ALPHA
    min_gain: float = MIN_HELD_OUT_GAIN
    tie: float = TIE_TOLERANCE
    folds: int = FOLDS
    max_effects: int = 12
    groups: Mapping[str, Sequence[str]] = field(default_factory=dict)
    grouped: bool = True
    processes: int | None = None

    def __post_init__(self) -> None:
        if self.processes is not None and (isinstance(self.processes, bool) or self.processes not in (1, 2)):
            raise ValueError(f"SearchSettings.processes: expected None (chosen), 1 or 2, got {self.processes!r}")


@dataclass(frozen=True)
class Group:
    """A grouped hypothesis: ``effects`` (registry keys) on each of ``coordinates``, one candidate;
    ``name`` is the named coordinate group's (``None``: every coordinate)."""

    effects: tuple[str, ...]
    coordinates: tuple[str, ...]
    name: str | None = None

    def label(self) -> str:
        """``viscous and coulomb on every coordinate``, ``coulomb on wrist``."""
        where = "every coordinate" if self.name is None else self.name
        return f"{' and '.join(self.effects)} on {where}"


@dataclass(eq=False)
class Judged:
    """The figures a candidate (or a grouped hypothesis) is judged by, per coordinate (module docstring).

    ``power0``/``power1`` are the weighted residual power per coordinate of the estimation data before and
    after it is added (before: the fit it is judged against), ``held0``/``held1`` the same on the held-out
    data; ``own`` the coordinates it is judged on; ``taus`` and ``p_by`` their autocorrelation times and
    p-values on their own."""

    status: str = "tested"
    """``tested``, ``not applicable``, ``in the model``, ``needs <term>`` (a group: ``reduced``)."""
    reason: str = ""
    own: tuple[int, ...] = ()
    power0: np.ndarray | None = field(default=None, repr=False)
    power1: np.ndarray | None = field(default=None, repr=False)
    held0: np.ndarray | None = field(default=None, repr=False)
    held1: np.ndarray | None = field(default=None, repr=False)
    taus: dict[int, float] = field(default_factory=dict)
    p_by: dict[int, float] = field(default_factory=dict)
    tau: float = 1.0
    F: float = 0.0
    p_value: float = 1.0
    delta_bic: float = 0.0
    """ΔBIC over every coordinate: what ranks the eligible candidates."""
    delta_bic_own: float = 0.0
    """ΔBIC on the own coordinates' rows: what must be negative."""
    added: int = 0
    trials: float = 1.0
    invalid: str | None = None
    failed: list[str] = field(default_factory=list)

    def _on(self, x: np.ndarray | None, own: bool = True) -> float:
        return 0.0 if x is None else float(np.sum(x[list(self.own)]) if own else np.sum(x))

    @property
    def rss0(self) -> float:
        return self._on(self.power0, own=False)

    @property
    def rss1(self) -> float:
        return self._on(self.power1, own=False)

    @property
    def held_out0(self) -> float:
        return self._on(self.held0, own=False)

    @property
    def held_out1(self) -> float:
        return self._on(self.held1, own=False)

    @property
    def explained(self) -> float:
        return self.rss0 - self.rss1

    @property
    def share(self) -> float:
        """Fraction of its own coordinates' (weighted) residual power that it explains."""
        before = self._on(self.power0)
        return 1.0 - self._on(self.power1) / before if before > 0 else 0.0

    @property
    def gain(self) -> float:
        """Fraction of its own coordinates' held-out residual power that it removes (0 when not measured: a
        group's member that failed on the estimation data already)."""
        before = self._on(self.held0)
        return 1.0 - self._on(self.held1) / before if before > 0 else 0.0

    @property
    def stacked_share(self) -> float:
        """Fraction of the stacked (all coordinates) residual power: reported, not judged."""
        return self.explained / self.rss0 if self.rss0 > 0 else 0.0

    @property
    def stacked_gain(self) -> float:
        """Fraction of the stacked held-out residual power: reported, not judged."""
        return 1.0 - self.held_out1 / self.held_out0 if self.held_out0 > 0 else 0.0

    @property
    def eligible(self) -> bool:
        return self.status == "tested" and not self.failed

    def by_coordinate(self, coordinates: Sequence[str]) -> dict[str, dict[str, float | None]]:
        """Per own coordinate: share of its residual power, held-out gain, p-value and τ_int on its rows."""
        out = {}
        for j in self.own:
            p0 = float(self.power0[j])
            h0 = None if self.held0 is None else float(self.held0[j])
            out[coordinates[j]] = {"explained_share": 1.0 - float(self.power1[j]) / p0 if p0 > 0 else 0.0,
                                   "held_out_gain": None if h0 is None else 1.0 - float(self.held1[j]) / h0 if h0 > 0 else 0.0,
                                   "p_value": self.p_by.get(j), "autocorrelation_time": self.taus.get(j)}
        return out

    def figures(self, coordinates: Sequence[str]) -> dict[str, Any]:
        """Plain data of the judgement for the report and the JSON."""
        return {"explained_share": self.share, "F": self.F, "p_value": self.p_value, "trials": self.trials,
                "autocorrelation_time": self.tau, "delta_bic": self.delta_bic, "delta_bic_own": self.delta_bic_own,
                "held_out_gain": self.gain, "coordinates": self.by_coordinate(coordinates),
                "stacked": {"explained_share": self.stacked_share, "held_out_gain": self.stacked_gain},
                "accepted_if": list(self.failed)}


@dataclass(eq=False, kw_only=True)
class Candidate(Judged):
    """One effect on one coordinate, fitted in one round (or as a member of a group)."""

    effect: Effect
    j: int
    coordinate: str
    value: float | tuple[float, ...] | None = None
    kept: tuple[int, ...] = ()
    width: int = 0
    coefficients: np.ndarray | None = field(default=None, repr=False)
    model_coefficients: np.ndarray | None = field(default=None, repr=False)
    reference: float | None = None
    reference_map: list[tuple[int, float]] | None = field(default=None, repr=False)
    roles: dict[str, float | None] = field(default_factory=dict)

    @property
    def size(self) -> int:
        """Parameters it names (roles): fewer wins a tie."""
        return len(self.effect.roles)

    def label(self) -> str:
        return f"{self.effect.label()} on {self.coordinate}"

    def summary(self, coordinates: Sequence[str]) -> dict[str, Any]:
        """Plain data for the report and the JSON (``coordinates``: the data's, for the per-coordinate figures)."""
        out: dict[str, Any] = {"effect": self.effect.identifier, **variant_of(self.effect), "coordinate": self.coordinate,
                               "status": self.status}
        if self.status != "tested":
            out["reason"] = self.reason
            return out
        out["parameters"] = dict(self.roles)
        out.update(self.figures(coordinates))
        return out


@dataclass(eq=False, kw_only=True)
class Grouped(Judged):
    """A grouped hypothesis fitted in one round: the members that earn their place and those dropped."""

    group: Group
    members: list[Candidate] = field(default_factory=list)
    dropped: list[tuple[Candidate, str]] = field(default_factory=list)

    @property
    def size(self) -> int:
        return sum(m.size for m in self.members)

    @property
    def effect(self) -> Effect:
        """The first member's effect (ties are broken by catalogue order last)."""
        return self.members[0].effect

    @property
    def coordinate(self) -> str:
        return ", ".join(dict.fromkeys(m.coordinate for m in self.members)) or "—"

    def label(self) -> str:
        return f"{self.group.label()} (kept on {self.coordinate})" if self.members else self.group.label()

    def summary(self, coordinates: Sequence[str]) -> dict[str, Any]:
        out: dict[str, Any] = {"group": self.group.label(), "effects": list(self.group.effects),
                               "coordinates": list(self.group.coordinates), "status": self.status}
        if self.status != "tested":
            out["reason"] = self.reason
        out["members"] = [m.summary(coordinates) for m in self.members]
        out["dropped"] = [{"effect": m.effect.identifier, **variant_of(m.effect), "coordinate": m.coordinate,
                           "reason": why} for m, why in self.dropped]
        if self.status == "tested":
            out.update(self.figures(coordinates))
        return out


def variant_of(effect: Effect) -> dict[str, str]:
    """``{"variant": ...}`` for the JSON of an effect that is one variant of its identifier, else empty."""
    return {"variant": effect.variant} if effect.variant else {}


@dataclass(eq=False)
class Accepted:
    """An accepted effect: the candidate as accepted, its columns, what tied with it, and the group it was
    accepted in (``None``: on its own)."""

    candidate: Candidate
    round: int
    columns: dict[str, np.ndarray] = field(repr=False)
    """Per data-set role, the reduced columns that were kept, ``samples × N × k``."""
    alternatives: list[Judged] = field(default_factory=list)
    threshold: float = 0.0
    group: Grouped | None = None

    @property
    def effect(self) -> Effect:
        return self.candidate.effect


@dataclass(eq=False)
class Round:
    """One round: every candidate and grouped hypothesis considered, the one chosen and what it added."""

    number: int
    candidates: list[Candidate]
    accepted: tuple[Accepted, ...]
    threshold: float
    groups: list[Grouped] = field(default_factory=list)
    chosen: Judged | None = None


def value_key(value: Any) -> Any:
    """A candidate's value as a cache key: itself when hashable (a number, a tuple), else its identity (a
    payload's structure, kept for the whole search)."""
    try:
        hash(value)
    except TypeError:
        return id(value)
    return value
