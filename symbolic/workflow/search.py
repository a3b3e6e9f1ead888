"""Forward selection of catalogue effects, each judged on its own coordinate's rows (docs/workflow.md,
"3. Name: the search and its statistics" and "Grouped hypotheses": the rounds, the tests and their thresholds,
ties, grouped hypotheses, backward elimination).

:class:`Search` runs the rounds. Every candidate — one effect on one coordinate, or a :class:`Group` — is fitted
jointly with the current model (:class:`CurrentModel`) and judged on the rows of the coordinates its columns act
on: its share of their residual power, the F-test of its added parameters (a nonlinear parameter counts as one;
:func:`symbolic.workflow.statistics.combined_f_test`), the held-out error, ΔBIC and its physical checks; among
the eligible, the lowest ΔBIC over every coordinate wins. A column in the model's span on these data only is
reported "not identifiable" (:mod:`symbolic.workflow.separability`).
"""

from __future__ import annotations

import dataclasses
import math
import mmap
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
import scipy.linalg
import scipy.optimize

from symbolic.data import DataError
from symbolic.errors import ModelError
from symbolic.identify.least_squares import Identification, RankDeficient
from symbolic.workflow import forked
from symbolic.workflow.bandwidth import lowered_settings
from symbolic.workflow.dataset import DataSet, position_steps, treat
from symbolic.workflow.effects import EFFECTS, Context, Effect, Signals, excluded, groups
from symbolic.workflow.effects.joint_elasticity import ELASTIC_ROW
from symbolic.workflow.separability import Separability
from symbolic.workflow.records import Accepted, Candidate, Group, Grouped, Judged, Round, SearchSettings
from symbolic.workflow.statistics import (MIN_FORCE_SHARE, autocorrelation_time, combined_f_test,
                                         pooled_autocorrelation_time, score_inflation)
from symbolic.workflow.terms import ModelTerms, solve_normal, wls

COLLINEAR = 1e-6
"""A column whose part outside the current model's span is below this fraction of its norm is in the model."""
REFERENCE = 1e-9
"""A model column equal to an effect's reference column up to this relative difference holds its coefficient."""
T = TypeVar("T")
J = TypeVar("J", bound=Judged)

KEPT_AT_LOWER_BAND = 0.5
"""An accepted effect is asked to hold at half the bandwidth (:meth:`Search.confirm`) when its columns keep at least
this fraction of their power per sample there: below, what it models lies above the lowered band."""

FORK_ROWS = 5_000
"""Stacked estimation rows (samples × coordinates) from which a round is split between two processes: below,
a round takes well under a second and forking the search would cost a noticeable part of it."""
@dataclass(eq=False)
class CurrentModel:
    """The current model on both data sets: columns (unweighted, reduced), the weights and the fit."""

    terms: ModelTerms
    sets: dict[str, DataSet]
    accepted: list[Accepted]
    columns: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    known: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    identification: Identification | None = None
    weights: np.ndarray | None = None
    _stacked: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        free = self.terms.free
        for role, data in self.sets.items():
            parts = [self.terms.columns(data)[:, :, free]] + [a.columns[role] for a in self.accepted]
            self.columns[role] = np.concatenate(parts, axis=2)
            self.known[role] = self.terms.known(data)
        names = list(self.terms.free_names) + [f"{a.effect.name}:{a.candidate.coordinate}:{k}"
                                               for a in self.accepted for k in range(a.columns["estimation"].shape[2])]
        self.identification = wls(self.sets["estimation"], self.columns["estimation"], self.known["estimation"], names)
        self.weights = 1.0 / np.asarray(self.identification.coordinate_sigmas)

    @property
    def size(self) -> int:
        return self.columns["estimation"].shape[2]

    def stacked(self) -> np.ndarray:
        """The estimation columns stacked (unweighted), computed once."""
        if self._stacked is None:
            self._stacked = self.sets["estimation"].stack(self.columns["estimation"])
        return self._stacked

    def predicted(self, role: str) -> np.ndarray:
        """τ of the current model on a data set (fixed terms included), ``samples × N``."""
        data = self.sets[role]
        return data.tau - self.known[role] + self.columns[role] @ self.identification.values

    def weighted(self, role: str, x: np.ndarray) -> np.ndarray:
        """``samples × N [× k]`` weighted by coordinate and stacked."""
        data = self.sets[role]
        w = self.weights.reshape((1, -1) + (1,) * (x.ndim - 2))
        return data.stack(x * w)


class Search:
    """Forward selection over ``effects`` (module docstring)."""

    def __init__(self, terms: ModelTerms, estimation: DataSet, validation: DataSet, *, cross_validate: bool,
                 effects: Sequence[Effect] | None = None, settings: SearchSettings | None = None,
                 elastic: Iterable[str] = ()) -> None:
        self.terms = terms
        self.sets = {"estimation": estimation, "validation": validation}
        self.cross_validate = cross_validate
        self.effects = list(EFFECTS.values()) if effects is None else list(effects)
        self.settings = settings or SearchSettings()
        s = estimation.states
        p = s.processing
        inner = slice(p.border[0], len(s.q) - p.border[1])
        passband = 0.4 * p.rate / p.decimation
        if p.cutoff is not None:
            passband = min(passband, p.cutoff)
        self.context = Context(terms.model.robot, estimation.coordinates, s.q[inner], s.qd[inner], s.qdd[inner], passband,
                               p.decimation / p.rate, float(estimation.t[-1] - estimation.t[0]), float(p.rate), terms.model,
                               frozenset(c for c, column in zip(estimation.coordinates, np.asarray(estimation.tau).T)
                                         if not np.any(column)), terms=terms, elastic=frozenset(elastic),
                               position_step=position_steps(estimation.measurements.q))
        self.hypotheses = self._hypotheses()
        self.rounds: list[Round] = []
        self.accepted: list[Accepted] = []
        self.removed: list[tuple[Accepted, float, str]] = []
        self.unconfirmed: list[tuple[Accepted, float]] = []
        """Accepted units removed because they do not hold at half the bandwidth, with their p there (:meth:`confirm`)."""
        self._reduced: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self._final: _Partial | None = None
        self._signals: dict[str, Signals] = {}
        self._references: dict[tuple[str, int], tuple | None] = {}
        self.separability = Separability(self)
        self._floors: list[np.ndarray] | None = None

    def quantisation_floor(self, j: int) -> np.ndarray | None:
        """The encoders' rounding in the estimation residual's spectrum on coordinate ``j``, in force units
        (:func:`~symbolic.workflow.where.quantisation_floor`), computed once."""
        if self._floors is None:
            from symbolic.numeric import numeric_model
            from symbolic.workflow.where import quantisation_floor

            self._floors = quantisation_floor(self.sets["estimation"], self.context.position_step,
                                              numeric_model(self.terms.model).inertia) or []
        return self._floors[j] if self._floors else None

    def _hypotheses(self) -> list[Group]:
        """The grouped hypotheses offered every round: each groupable effect, and those declared together
        (:attr:`~symbolic.workflow.effects.base.Effect.together`), on every
        coordinate and on each named group (at least two coordinates each)."""
        coordinates = tuple(self.context.coordinates)
        open_rows = tuple(c for c in coordinates if c not in self.context.elastic)
        sets: list[tuple[str | None, tuple[str, ...]]] = [(None, open_rows)]
        for name, members in self.settings.groups.items():
            unknown = [c for c in members if c not in coordinates]
            if unknown:
                raise ModelError(str(self.context.robot.source), f"group {name!r}",
                                 f"unknown coordinate(s) {', '.join(unknown)} (allowed: the data's {', '.join(coordinates)})")
            sets.append((name, tuple(c for c in dict.fromkeys(members) if c not in self.context.elastic)))
        if not self.settings.grouped:
            return []
        groupable = [e for e in self.effects if e.groupable and e.nonlinear is None]
        effect_sets = [(e.name,) for e in groupable] + groups(groupable)
        return [Group(effects, members, name) for name, members in sets if len(members) >= 2 for effects in effect_sets]

    # -- the loop -----------------------------------------------------------------------------
    def run(self) -> list[Accepted]:
        """Rounds until no candidate is eligible (or ``max_effects`` are accepted), then backward
        elimination of the accepted effects that later ones made insignificant."""
        while len(self.accepted) < self.settings.max_effects:
            design = CurrentModel(self.terms, self.sets, self.accepted)
            chosen = self.round(design)
            if not chosen:
                break
            self.accepted.extend(chosen)
        self.eliminate()
        if self.confirm():
            self.eliminate()
        if self._final is None:  # nothing accepted: the elimination built no joint fit
            self._final = _Partial(self, CurrentModel(self.terms, self.sets, self.accepted))
        self.final = self._final.design
        return self.accepted

    def round(self, design: CurrentModel) -> tuple[Accepted, ...]:
        """One round (module docstring): the accepted effects, several when a group is chosen."""
        number = len(self.rounds) + 1
        state = _RoundState(self, design)
        candidates = self.evaluate_all(state, [(e, j) for e in self.effects for j in range(len(self.context.coordinates))])
        tested = [c for c in candidates if c.status == "tested"]
        effective = state.effective(tested)
        offered, seen = [], set()
        for hypothesis in self.hypotheses:  # one group per set of members (friction together = Coulomb alone, ...)
            pool = state.pool(hypothesis, candidates)
            members = frozenset((c.effect.name, c.j) for c in pool)
            if len(pool) >= 2 and members not in seen:
                seen.add(members)
                offered.append((hypothesis, pool))
        # the largest groups first (a group's evaluation grows with its members: the Panda's 14-member one took 40 % of
        # its round's), so that the two processes of :meth:`shared` finish together; the results in the offered order
        order = sorted(range(len(offered)), key=lambda k: -len(offered[k][1]))
        done = self.shared(lambda offer: state.evaluate_group(*offer, effective), [offered[k] for k in order])
        groups: list[Grouped] = [None] * len(offered)  # type: ignore[list-item]
        for k, g in zip(order, done):
            groups[k] = g
        judged: list[Judged] = tested + [g for g in groups if g.status == "tested"]
        threshold = self.settings.alpha / max(sum(c.trials for c in judged), 1.0)
        for c in judged:
            state.score(c, effective)
            state.judge(c, threshold)
        pool = [c for c in judged if c.eligible]
        if not pool:
            self.rounds.append(Round(number, candidates, (), threshold, groups))
            return ()
        best = min(pool, key=lambda c: c.delta_bic)
        ties = [c for c in judged if c is not best and c.invalid is None
                and abs(float(effective @ np.log(np.maximum(c.power1, 1e-300) / np.maximum(best.power1, 1e-300))))
                <= self.settings.tie]
        order = {e.name: k for k, e in enumerate(self.effects)}
        group = [best] + [c for c in ties if c.eligible]
        chosen = min(group, key=lambda c: (c.size, c.delta_bic, order.get(c.effect.name, 0)))
        alternatives = [c for c in [best] + ties if c is not chosen]
        members = chosen.members if isinstance(chosen, Grouped) else [chosen]
        accepted = tuple(Accepted(m, number, {role: state.columns(m.effect, m.j, m.value, role)[:, :, list(m.kept)]
                                              for role in self.sets}, alternatives, threshold,
                                  chosen if isinstance(chosen, Grouped) else None) for m in members)
        self.rounds.append(Round(number, candidates, accepted, threshold, groups, chosen))
        return accepted

    def evaluate_all(self, state: _RoundState, pairs: Sequence[tuple[Effect, int]]) -> list[Candidate]:
        """The candidates of ``pairs`` (effect, coordinate index), in order (:meth:`shared`: the scans of the
        nonlinear effects, most of a round's work, taken first, so that the two processes finish within one small
        candidate of each other)."""
        order = sorted(range(len(pairs)), key=lambda k: (pairs[k][0].nonlinear is None, k))
        done = self.shared(lambda pair: state.evaluate(*pair), [pairs[k] for k in order])
        out: list[Candidate] = [None] * len(pairs)  # type: ignore[list-item]
        for k, c in zip(order, done):
            out[k] = c
        return out

    def shared(self, evaluate: Callable[[T], J], items: Sequence[T]) -> list[J]:
        """``evaluate`` of each item (a candidate's or a group's evaluation), in order; shared with a forked process
        as they come (:func:`~symbolic.workflow.forked.shared`, :attr:`SearchSettings.processes`), whose treated
        columns then join this search's store. The effect objects stay here (a user's effect class need not be
        picklable): the results travel with their effects' names."""
        wanted = self.settings.processes
        if wanted is None:
            wanted = 2 if self.sets["estimation"].samples * len(self.context.coordinates) >= FORK_ROWS else 1
        if min(wanted, forked.usable_processes()) < 2 or len(items) < 2:
            return [evaluate(item) for item in items]

        parent, arena = os.getpid(), _arena()

        def work(part: Iterable[T]) -> tuple[list[J], tuple | None]:
            known = set(self._reduced)
            done = [_named_effects(evaluate(item)) for item in part]
            if os.getpid() == parent:  # this process's columns are in its store already: packing them is waste
                return done, None
            return done, _packed({k: v for k, v in self._reduced.items() if k not in known}, arena)

        done, (_, treated) = forked.shared(work, items)
        if treated is not None:  # None when the child failed and its share was evaluated here
            for key, value in _unpacked(*treated, arena=arena).items():
                self._reduced.setdefault(key, value)
        effects = {e.name: e for e in self.effects}
        return [_with_effects(c, effects) for c in done]

    def units(self) -> list[list[int]]:
        """The accepted effects by what was accepted together: a group's members form one unit."""
        units: dict[int, list[int]] = {}
        for k, a in enumerate(self.accepted):
            units.setdefault(id(a.group) if a.group is not None else -1 - k, []).append(k)
        return list(units.values())

    def eliminate(self) -> None:
        """Remove, one at a time, the accepted unit (an effect, or a group's members) least significant in
        the joint fit of all of them while its partial F-test's p is not below ``alpha`` / (number of units)."""
        while self.accepted:
            partial = self._final = _Partial(self, CurrentModel(self.terms, self.sets, self.accepted))
            units = self.units()
            tests = [partial.p_value(unit) for unit in units]
            worst = int(np.argmax(tests))
            if tests[worst] < self.settings.alpha / len(units):
                return
            self._final = None
            gone = [self.accepted[k] for k in units[worst]]
            self.accepted = [a for k, a in enumerate(self.accepted) if k not in units[worst]]
            others = ", ".join(a.candidate.label() for a in self.accepted) or "nothing else"
            self.removed += [(a, tests[worst], others) for a in gone]

    def confirm(self) -> bool:
        """Remove, one at a time, the accepted unit furthest from significance in the joint fit of all of them on
        the estimation data treated at half the bandwidth (:mod:`symbolic.workflow.bandwidth`) while its p there is
        not below the threshold of the round that accepted it (the same test, repeated at the lowered band); a unit
        whose columns keep less than :data:`KEPT_AT_LOWER_BAND` of their power per sample there (a resonance above
        the lowered band) is not asked. Why: the 2-link arm with nothing missing behind a 12-bit encoder named a
        gravity term on q2 that removed 19.5 % of the held-out residual at p = 3.9e-7 (threshold 4.5e-7), fitted
        to the rounding's errors in q̈ and in the loop's force, which the held-out blocks share; at half the band
        p = 0.0025. Returns whether anything was removed (:attr:`unconfirmed`)."""
        if not self.accepted:
            return False
        data = self.sets["estimation"]
        try:
            low = treat(data.measurements, "estimation", lowered_settings(data.states.processing))
            lowered = Search(self.terms, low, low, cross_validate=True, effects=self.effects, settings=self.settings,
                             elastic=self.context.elastic)
        except (DataError, ValueError):  # too few samples for the longer border: nothing to ask
            return False
        lowered.accepted = [dataclasses.replace(a, columns={"estimation": lowered.columns(
            a.effect, a.candidate.j, a.candidate.value, "estimation")[:, :, list(a.candidate.kept)]}) for a in self.accepted]
        asked = [_power(b.columns["estimation"]) >= KEPT_AT_LOWER_BAND * _power(a.columns["estimation"])
                 for a, b in zip(self.accepted, lowered.accepted)]
        removed = False
        while lowered.accepted:
            try:
                partial = _Partial(lowered, CurrentModel(self.terms, {"estimation": low}, lowered.accepted))
            except RankDeficient:  # what the full band separates may not be separable there: nothing to ask
                break
            units = [u for u in lowered.units() if all(asked[k] for k in u)]
            if not units:
                break
            tests = [partial.p_value(unit) for unit in units]
            thresholds = [min(lowered.accepted[k].threshold for k in unit) for unit in units]
            worst = int(np.argmax([p / t for p, t in zip(tests, thresholds)]))
            if tests[worst] < thresholds[worst]:
                break
            gone = set(units[worst])
            self.unconfirmed += [(self.accepted[k], tests[worst]) for k in sorted(gone)]
            self.accepted, lowered.accepted, asked = ([x for k, x in enumerate(xs) if k not in gone]
                                                      for xs in (self.accepted, lowered.accepted, asked))
            self._final, removed = None, True
        return removed

    def block(self, k: int) -> list[int]:
        """Columns of accepted effect ``k`` in the design."""
        start = len(self.terms.free_names) + sum(a.columns["estimation"].shape[2] for a in self.accepted[:k])
        return list(range(start, start + self.accepted[k].columns["estimation"].shape[2]))

    # -- the final model ----------------------------------------------------------------------
    def final_effects(self) -> list[dict[str, Any]]:
        """For each accepted effect: roles and σ from the final joint fit, its partial test there on its own
        rows (``own_p_value``) and that of the unit it was accepted in (``p_value``: a group's, or its own)."""
        partial = self._final  # the elimination's last joint fit: the final model's
        design = partial.design
        ident = design.identification
        unit_p = {k: p for unit in self.units() for p in [partial.p_value(unit)] for k in unit}
        tau = pooled_autocorrelation_time(partial.residual.reshape(len(design.weights), -1).T)
        out = []
        for k, a in enumerate(self.accepted):
            c = a.candidate
            block = self.block(k)
            reference_map = _reference_map(self, design, c.effect, c.j)
            roles, sigmas = _roles_with_sigma(c, ident.values, ident.covariance * tau, block, reference_map)
            out.append({"roles": roles, "sigmas": sigmas, "coefficients_full": _expand(c, ident.values[block]),
                        "p_value": unit_p[k], "own_p_value": partial.p_value([k]),
                        "reference": _reference_value(reference_map, ident.values)})
        return out

    # -- the effects' columns, reduced once per search ----------------------------------------
    def reference(self, effect: Effect, j: int) -> tuple[np.ndarray, np.ndarray, list[tuple[int, float]]] | None:
        """:func:`_reference` of the effect on coordinate ``j``, computed once per search (it does not depend on the
        round, and every round's candidate asks for it)."""
        key = (effect.name, j)
        if key not in self._references:
            self._references[key] = _reference(self, effect, j)
        return self._references[key]

    def signals(self, role: str) -> Signals:
        """The data set's filtered states at every sample, with time and rate (for :meth:`Effect.columns_at`)."""
        if role not in self._signals:
            data = self.sets[role]
            record = None if data.record is None else self._signals_of(data.record)
            self._signals[role] = self._signals_of(data, record)
        return self._signals[role]

    def _signals_of(self, data: DataSet, record: Signals | None = None) -> Signals:
        s = data.states
        return Signals(s.q, s.qd, s.qdd, np.asarray(data.measurements.t), float(s.processing.rate),
                       self.context.robot, record, data.start, self.context.model, self.context.coordinates)

    def reduced(self, effect: Effect, j: int, values: Sequence[Any], role: str) -> list[tuple[np.ndarray, np.ndarray]]:
        """The effect's columns at ``values`` on a data set, treated like the regressor, as (rows, columns on
        those rows: ``samples × len(rows) × k``); the missing ones filtered in one pass. Columns do not depend
        on the round: they are computed once per search (compact: only the rows they act on are kept)."""
        store = self._reduced
        keys = [(effect.name, j, v, role) for v in values]
        missing = list(dict.fromkeys(k for k in keys if k not in store))
        if missing:
            if effect.own_row:
                store.update(zip(missing, self._reduced_on_row(effect, j, [k[2] for k in missing], role)))
            else:
                signals = self.signals(role)
                raw = [effect.columns_at(signals, j, k[2]) for k in missing]
                rows = _acting(raw)
                if rows.size == 0:
                    rows = np.array([j])
                widths = [r.shape[2] for r in raw]
                reduced = self.sets[role].reduce(np.concatenate([r[:, rows, :] for r in raw], axis=2))
                for key, part in zip(missing, np.split(reduced, np.cumsum(widths)[:-1], axis=2)):
                    store[key] = (rows, part)
        return [store[k] for k in keys]

    def columns(self, effect: Effect, j: int, value: Any, role: str) -> np.ndarray:
        """The effect's full columns at ``value`` on a data set (``samples × N × k``; :meth:`reduced`'s, expanded)."""
        return _expanded(*self.reduced(effect, j, [value], role)[0], len(self.context.coordinates))

    def _reduced_on_row(self, effect: Effect, j: int, values: Sequence[Any], role: str) -> list[tuple[np.ndarray, np.ndarray]]:
        """:meth:`reduced` of an :attr:`~symbolic.workflow.effects.base.Effect.own_row` effect: its columns on row
        ``j`` alone. Gathered column by column (``columns × samples``: copying each contiguous column into a
        ``samples × columns`` array is a strided write, three times slower) and treated as that array's transpose."""
        signals = self.signals(role)
        raw = [effect.row_columns_at(signals, j, v).T for v in values]
        reduced = self.sets[role].reduce(np.concatenate(raw, axis=0).T)
        widths = np.cumsum([r.shape[0] for r in raw])[:-1]
        return [(np.array([j]), part[:, None, :]) for part in np.split(reduced, widths, axis=1)]


def _expanded(rows: np.ndarray, part: np.ndarray, n: int) -> np.ndarray:
    """Columns kept on ``rows`` only (``samples × len(rows) × k``) as the full ``samples × n × k``."""
    out = np.zeros((part.shape[0], n, part.shape[2]))
    out[:, rows, :] = part
    return out


def _power(columns: np.ndarray) -> float:
    """Mean power per sample of an effect's columns (``samples × N × k``)."""
    return float(np.sum(columns**2)) / max(columns.shape[0], 1)


def _candidates_in(c: Judged) -> list[Candidate]:
    """The candidates ``c`` holds: itself, or a group's members and those it dropped."""
    return [*c.members, *(m for m, _ in c.dropped)] if isinstance(c, Grouped) else [c]  # type: ignore[list-item]


def _named_effects(c: J) -> J:
    """``c`` with its candidates' effects replaced by their names (for sending from the forked process)."""
    for m in _candidates_in(c):
        m.effect = m.effect.name  # type: ignore[assignment]
    return c


def _with_effects(c: J, effects: Mapping[str, Effect]) -> J:
    """``c`` with its candidates' effects named by :func:`_named_effects` put back."""
    for m in _candidates_in(c):
        m.effect = effects[m.effect]  # type: ignore[index]
    return c


ARENA = 1 << 30
"""Bytes of the memory shared with a forked child for its treated columns (:func:`_arena`): an address range only,
the pages the child writes alone are used (the Panda's first round: 52 MB)."""


def _arena() -> mmap.mmap | None:
    """Memory shared with the forked child to come (an anonymous shared mapping, made before the fork): the child
    writes its treated columns' numbers there and the parent reads them in place, where a pipe made four copies of
    them between the two processes (0.3 s of the Panda's search). ``None`` where it cannot be had (the columns
    then travel through the pipe)."""
    try:
        return mmap.mmap(-1, ARENA)
    except (OSError, ValueError, OverflowError):
        return None


def _packed(store: Mapping[tuple, tuple[np.ndarray, np.ndarray]],
            arena: mmap.mmap | None = None) -> tuple[list[tuple], list[tuple], np.ndarray | int]:
    """Treated columns (:meth:`Search.reduced`'s store) as their keys, (rows, shape) and one array of all their
    numbers: sent from the forked child in one piece (some 40 MB in thousands of small arrays took 0.2 s to
    pickle one by one). With an ``arena`` (:func:`_arena`) they fit in, the numbers are written there and only
    their count is returned."""
    parts = [part.reshape(-1) for _, part in store.values()]
    layout = [(tuple(int(r) for r in rows), part.shape) for rows, part in store.values()]
    total = sum(p.size for p in parts)
    if arena is not None and total * 8 <= len(arena):
        if parts:
            np.concatenate(parts, out=np.frombuffer(arena, dtype=float, count=total))
        return list(store), layout, total
    numbers = np.concatenate(parts) if parts else np.zeros(0)
    return list(store), layout, numbers


def _unpacked(keys: list[tuple], layout: list[tuple], numbers: np.ndarray | int,
              arena: mmap.mmap | None = None) -> dict[tuple, tuple[np.ndarray, np.ndarray]]:
    """The store :func:`_packed` packed (each part a view of ``numbers``, or of the ``arena`` they were written to)."""
    if isinstance(numbers, int):
        numbers = np.frombuffer(arena, dtype=float, count=numbers)
    sizes = np.cumsum([math.prod(shape) for _, shape in layout])[:-1]
    return {key: (np.array(rows, dtype=np.int64), part.reshape(shape))
            for key, (rows, shape), part in zip(keys, layout, np.split(numbers, sizes))}


FOLD_SUPPORT = 1e-6
"""A candidate's column with less than this share of its power on a fold's training blocks is not fitted there
(coefficient 0): the training data cannot tell its coefficient (a transient at the record's start, such as the free
motion of ``joint_elasticity`` (one encoder), lives in the first block alone; scaled to unit norm, its coefficient
on the other blocks was noise blown up a millionfold)."""


def _fold_solve(gram: np.ndarray, right: np.ndarray, p: int, power: np.ndarray) -> np.ndarray:
    """Coefficients of a cross-validation fold's training fit: the model's ``p`` columns, then the candidate's, of
    whole power ``power``; a candidate column the training blocks hardly hold (:data:`FOLD_SUPPORT`) gets 0."""
    weak = np.diag(gram)[p:] <= FOLD_SUPPORT * power
    if not weak.any():
        return solve_normal(gram, right)
    keep = np.concatenate([np.ones(p, bool), ~weak])
    coef = np.zeros(len(right))
    coef[keep] = solve_normal(gram[np.ix_(keep, keep)], right[keep])
    return coef


def _acting(raw: Sequence[np.ndarray]) -> np.ndarray:
    """The coordinates (axis 1) on which any of the ``samples × N × k`` arrays ``raw`` is non-zero. A
    coordinate found acting is not looked at again (``ndarray.any`` stops at the first non-zero); only
    those still zero are scanned: far cheaper than reducing over axes 0 and 2 at once."""
    acting = np.zeros(raw[0].shape[1], bool)
    for r in raw:
        for i in np.flatnonzero(~acting):
            acting[i] = r[:, i, :].any()
    return np.flatnonzero(acting)


def _roles_with_sigma(c: Candidate, values: np.ndarray, covariance: np.ndarray, block: list[int],
                      reference_map: list[tuple[int, float]] | None) -> tuple[dict, dict]:
    """Roles at ``values`` and their σ by the delta method (numerical Jacobian over the coefficients)."""
    def roles(v: np.ndarray) -> dict[str, float | None]:
        coefficients = _expand(c, v[block])
        return c.effect.roles_of(coefficients, c.value, _reference_value(reference_map, v))

    centre = roles(values)
    involved = sorted(set(block) | {i for i, _ in (reference_map or [])})
    sigmas: dict[str, float | None] = {}
    jac = {name: np.zeros(len(values)) for name in centre}
    for i in involved:
        step = 1e-6 * max(abs(values[i]), 1e-12) + 1e-12
        shifted = values.copy()
        shifted[i] += step
        moved = roles(shifted)
        for name in centre:
            if centre[name] is not None and moved[name] is not None:
                jac[name][i] = (moved[name] - centre[name]) / step
    for name, value in centre.items():
        sigmas[name] = None if value is None else float(np.sqrt(max(jac[name] @ covariance @ jac[name], 0.0)))
    return centre, sigmas


def _expand(c: Candidate, kept_values: np.ndarray) -> np.ndarray:
    """The effect's coefficient vector with NaN for the columns it did not keep."""
    full = np.full(c.width, np.nan)
    full[list(c.kept)] = kept_values
    return full


def _reference_value(reference_map: list[tuple[int, float]] | None, values: np.ndarray) -> float | None:
    if reference_map is None:
        return None
    return float(sum(values[i] * scale if i >= 0 else scale for i, scale in reference_map))


def _reference_map(search: Search, design: CurrentModel, effect: Effect, j: int) -> list[tuple[int, float]] | None:
    """How the effect's reference coefficient follows from the design's coefficients: pairs (column,
    factor); a fixed column contributes (−1, its fixed value × factor). ``None`` when no column matches."""
    reference = search.reference(effect, j)
    if reference is None:
        return None
    r, support, fixed = reference
    pairs = _proportional(design.stacked(), r, support) + fixed
    return pairs or None


def _reference(search: Search, effect: Effect, j: int) -> tuple[np.ndarray, np.ndarray, list[tuple[int, float]]] | None:
    """The effect's reference column on the estimation data, reduced and stacked, where it is non-zero, and its
    pairs with the fixed terms (:func:`_reference_map`); ``None`` when it has none or it vanishes. Only the
    coordinates it acts on are filtered (a column's treatment does not depend on the others filtered with it)."""
    data = search.sets["estimation"]
    s = data.states
    column = effect.reference_column(s.q, s.qd, s.qdd, j)
    if column is None:
        return None
    column = np.asarray(column, dtype=float)
    acting = np.flatnonzero(np.any(column != 0, axis=0))
    reduced = np.zeros((data.samples, column.shape[1]))
    if acting.size:
        reduced[:, acting] = data.reduce(column[:, acting])
    r = data.stack(reduced)
    support = r != 0
    if not support.any():
        return None
    terms = search.terms
    fixed = np.flatnonzero(~terms.free)
    pairs: list[tuple[int, float]] = []
    if fixed.size:
        F = data.stack(terms.columns(data)[:, :, fixed])
        pairs = [(-1, factor * terms.nominal[fixed[k]]) for k, factor in _proportional(F, r, support)]
    return r, support, pairs


def _proportional(X: np.ndarray, r: np.ndarray, support: np.ndarray) -> list[tuple[int, float]]:
    """(i, α) for the columns of X equal to α·r (to :data:`REFERENCE`); only columns that vanish where r
    does are compared in full."""
    norms = np.sqrt(np.einsum("ij,ij->j", X, X))
    outside = np.sqrt(np.einsum("ij,ij->j", X[~support], X[~support]))
    rr = float(r @ r)
    out = []
    for i in np.flatnonzero((norms > 0) & (outside <= REFERENCE * norms)):
        x = X[support, i]
        alpha = float(x @ r[support]) / rr
        if np.linalg.norm(x - alpha * r[support]) <= REFERENCE * norms[i]:
            out.append((int(i), alpha))
    return out


def _parts(pieces: Sequence[tuple[tuple[int, ...], int, int]], power0: np.ndarray, power1: np.ndarray,
           leverage: np.ndarray, taus: Mapping[tuple[int, ...], float], samples: int,
           held: bool) -> list[tuple[tuple[int, ...], tuple[float, float, float, float, int, float]]]:
    """The parts of :func:`~symbolic.workflow.statistics.combined_f_test` for columns added on their own
    coordinates: ``pieces`` are (coordinates, columns, parameters added); pieces on one coordinate are
    merged, a piece on several (a payload) pools them. The model's parameters count by their leverage on
    those rows (``held``: the leverage is that of a fit holding the added columns, which are taken off).
    Returns (coordinates, part) pairs."""
    merged: dict[tuple[int, ...], list[int]] = {}
    for coordinates, columns, added in pieces:
        entry = merged.setdefault(coordinates, [0, 0])
        entry[0] += columns
        entry[1] += added
    parts = []
    for coordinates, (columns, added) in merged.items():
        rows = list(coordinates)
        parameters = float(np.sum(leverage[rows])) - (columns if held else 0)
        parts.append((coordinates, (float(np.sum(power0[rows])), float(np.sum(power1[rows])), float(samples * len(rows)),
                                    max(parameters, 0.0), added, taus[coordinates])))
    return parts


def _tau(residual: np.ndarray, coordinates: tuple[int, ...]) -> float:
    """τ_int of a ``N × samples`` residual on some coordinates (pooled by power when several)."""
    if len(coordinates) == 1:
        return autocorrelation_time(residual[coordinates[0]])
    return pooled_autocorrelation_time(residual[list(coordinates)].T)


class _Partial:
    """Partial F-tests of accepted effects in a joint fit (elimination, the final model), each on its own rows."""

    def __init__(self, search: Search, design: CurrentModel) -> None:
        self.search, self.design = search, design
        self.y = design.weighted("estimation", design.known["estimation"])
        self.X = design.weighted("estimation", design.columns["estimation"])
        self.residual = self.y - self.X @ design.identification.values
        self.n, self.samples = len(design.weights), design.sets["estimation"].samples
        Q = np.linalg.qr(self.X)[0]
        self.leverage = np.einsum("ij,ij->i", Q, Q).reshape(self.n, -1).sum(axis=1)
        self.power = (self.residual**2).reshape(self.n, -1).sum(axis=1)
        self.gram, self.right = self.X.T @ self.X, self.X.T @ self.y
        self._taus: dict[tuple[int, ...], float] = {}

    def tau(self, coordinates: tuple[int, ...]) -> float:
        if coordinates not in self._taus:
            self._taus[coordinates] = _tau(self.residual.reshape(self.n, -1), coordinates)
        return self._taus[coordinates]

    def p_value(self, unit: Sequence[int]) -> float:
        """p of removing the accepted effects ``unit`` (indices into ``search.accepted``) together."""
        search = self.search
        columns = {i for k in unit for i in search.block(k)}
        rest = [i for i in range(self.X.shape[1]) if i not in columns]
        coef = solve_normal(self.gram[np.ix_(rest, rest)], self.right[rest])
        without = self.y - self.X[:, rest] @ coef
        power0 = (without**2).reshape(self.n, -1).sum(axis=1)
        pieces = []
        for k in unit:
            a = search.accepted[k]
            own = tuple(int(j) for j in np.flatnonzero(np.any(a.columns["estimation"] != 0, axis=(0, 2))))
            width = a.columns["estimation"].shape[2]
            pieces.append((own, width, width + (1 if a.effect.nonlinear else 0)))
        taus = {own: self.tau(own) for own, _, _ in pieces}
        parts = _parts(pieces, power0, self.power, self.leverage, taus, self.samples, held=True)
        return combined_f_test([part for _, part in parts])[1]


@dataclass(frozen=True, eq=False)
class _Fit:
    """A candidate's columns (or a subset of a group's) fitted with the current model: residual power per
    coordinate on the estimation and held-out data, the coefficients (model's first), the residual."""

    power: np.ndarray
    held: np.ndarray | None
    coef: np.ndarray
    residual: np.ndarray


class _Joint:
    """Columns added to the current model together (a candidate's, or a group's members'), non-zero on
    ``rows`` of the stacked system only, and the fit of any subset of them (products on those rows; the
    model's part through the round's orthonormal basis Q and its Gram matrices)."""

    def __init__(self, state: _RoundState, rows: np.ndarray, Zr: np.ndarray, Zv: np.ndarray | None) -> None:
        self.state, self.rows, self.Zr, self.Zv = state, rows, Zr, Zv
        self.a = state.Q[rows].T @ Zr
        self.zz = Zr.T @ Zr
        self.G = self.zz - self.a.T @ self.a
        self.b = Zr.T @ state.r0[rows]
        self.cross = state.X[rows].T @ Zr
        self.zy = Zr.T @ state.y[rows]

    def outside(self, subset: Sequence[int]) -> dict[int, np.ndarray]:
        """Per coordinate, the part of the columns ``subset`` outside the model's span on its rows
        (``samples × k``; only the columns that act there)."""
        st = self.state
        s = list(subset)
        perp = self.Zr[:, s] - st.Q[self.rows] @ self.a[:, s]
        coordinate = self.rows // st.n_samples
        out = {}
        for j in np.unique(coordinate):
            mine = coordinate == j
            acting = [i for i in range(len(s)) if np.any(self.Zr[mine, s[i]] != 0)]
            if not acting:
                continue
            z = np.zeros((st.n_samples, len(acting)))
            z[self.rows[mine] - j * st.n_samples] = perp[np.ix_(mine, acting)]
            out[int(j)] = z
        return out

    def fit(self, subset: Sequence[int], held: bool = True) -> _Fit:
        """The current model with the columns ``subset``; ``held=False`` leaves the held-out error out (``None``)."""
        st = self.state
        s = list(subset)
        if not s:
            return _Fit(st.power0, st.held0, st.coef, st.r0)
        try:
            step = np.linalg.solve(self.G[np.ix_(s, s)], self.b[s])
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(self.G[np.ix_(s, s)], self.b[s], rcond=None)[0]
        residual = st.r0 + st.Q @ (self.a[:, s] @ step)
        residual[self.rows] -= self.Zr[:, s] @ step
        cross = self.cross[:, s]
        coef = solve_normal(np.block([[st.gram, cross], [cross.T, self.zz[np.ix_(s, s)]]]), np.concatenate([st.right, self.zy[s]]))
        if not held:
            return _Fit(st.by(residual * residual), None, coef, residual)
        if st.search.cross_validate:
            out = st.cross_validated((self.rows, self.Zr[:, s]))
        else:
            e = st.yv - np.concatenate([st.Xv, self.Zv[:, s]], axis=1) @ coef
            out = st.by(e * e)
        return _Fit(st.by(residual * residual), out, coef, residual)


class _RoundState:
    """The weighted arrays of one round and the evaluation of its candidates.

    A candidate's columns act on few rows of the stacked system (those of its coordinate), so every
    product with them is taken on those rows only; the model's part is handled through the
    orthonormal basis Q of its columns (``r0 ⊥ Q``) and small Gram matrices.
    """

    CHUNK = 64
    """Grid values whose columns are filtered together."""

    def __init__(self, search: Search, design: CurrentModel) -> None:
        self.search = search
        self.design = design
        self.y = design.weighted("estimation", design.known["estimation"])
        self.X = design.weighted("estimation", design.columns["estimation"])
        self.coef = np.asarray(design.identification.values)
        self.r0 = self.y - self.X @ self.coef
        self.Q = np.linalg.qr(self.X)[0]
        self.gram, self.right = self.X.T @ self.X, self.X.T @ self.y
        data = design.sets["estimation"]
        self.n_samples, self.n = data.samples, len(data.coordinates)
        self.power0 = self.by(self.r0 * self.r0)
        self.rss0 = float(self.power0.sum())
        self.leverage = self.by(np.einsum("ij,ij->i", self.Q, self.Q))
        if search.cross_validate:
            blocks = np.array_split(np.arange(self.n_samples), search.settings.folds)
            self.fold_of = np.empty(len(self.y), int)
            for f, b in enumerate(blocks):
                for j in range(self.n):
                    self.fold_of[j * self.n_samples + b] = f
            self.folds = [np.flatnonzero(self.fold_of == f) for f in range(len(blocks))]
            # each fold's rows of X and y, gathered once a round: every candidate predicts every fold with them
            self.fold_X = [self.X[rows] for rows in self.folds]
            self.fold_y = [self.y[rows] for rows in self.folds]
            self.fold_gram = [(X.T @ X, X.T @ self.y[rows]) for X, rows in zip(self.fold_X, self.folds)]
            self.held0 = self.cross_validated(None)
        else:
            self.yv = design.weighted("validation", design.known["validation"])
            self.Xv = design.weighted("validation", design.columns["validation"])
            self.held0 = self.by((self.yv - self.Xv @ self.coef) ** 2)
        self.held_out0 = float(self.held0.sum())
        held = design.sets["estimation" if search.cross_validate else "validation"]
        spread = held.tau - held.tau.mean(axis=0)
        self.force_power = self.by(design.weighted("estimation" if search.cross_validate else "validation", spread) ** 2)
        self._spectra: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def by(self, x: np.ndarray) -> np.ndarray:
        """Per-coordinate sums of a stacked vector (``N``)."""
        return x.reshape(self.n, -1).sum(axis=1)

    def effective(self, tested: Sequence[Candidate]) -> np.ndarray:
        """n_eff per coordinate for the round: n/τ of the residual of the candidate explaining most there
        (one per coordinate: BIC compares models of the same data, and a candidate that leaves a coloured
        residual must not gain by it); τ of the round's residual where no candidate acts."""
        out = np.empty(self.n)
        for j in range(self.n):
            on = [c for c in tested if j in c.taus]
            tau = min(on, key=lambda c: c.power1[j]).taus[j] if on else \
                autocorrelation_time(self.r0.reshape(self.n, -1)[j])
            out[j] = self.n_samples / tau
        return out

    # columns of an effect on one data set, reduced (samples × N × k)
    def columns(self, effect: Effect, j: int, value: Any, role: str) -> np.ndarray:
        """Full columns (``samples × N × k``), kept for the whole search: a refinement that starts from the
        same grid value in a later round mostly visits the same values again."""
        return self.search.columns(effect, j, value, role)

    def batch(self, effect: Effect, j: int, values: Sequence[Any], role: str) -> list[tuple[np.ndarray, np.ndarray]]:
        """Columns of a grid of values as (rows, columns on those rows), kept for the whole search."""
        return self.search.reduced(effect, j, values, role)

    def expand(self, rows: np.ndarray, part: np.ndarray) -> np.ndarray:
        return _expanded(rows, part, self.n)

    def cross_validated(self, extra: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
        """Residual power of the held-out blocks per coordinate, each block predicted by the fit on the others
        (normal equations: a fold only subtracts its own small Gram blocks). ``extra`` = (rows, Z[rows]) adds
        a candidate's columns, non-zero on ``rows`` only."""
        total = np.zeros(self.n)
        if extra is not None:
            rows, Zr = extra
            cross, zz, zy = self.X[rows].T @ Zr, Zr.T @ Zr, Zr.T @ self.y[rows]
            gram = np.block([[self.gram, cross], [cross.T, zz]])
            right = np.concatenate([self.right, zy])
            of = self.fold_of[rows]
        for f, fold in enumerate(self.folds):
            g, b = self.fold_gram[f]
            if extra is None:
                coef = solve_normal(self.gram - g, self.right - b)
                e = self.fold_y[f] - self.fold_X[f] @ coef
            else:
                mine = of == f
                inside, Zf = rows[mine], Zr[mine]
                cf = self.X[inside].T @ Zf
                gf = np.block([[g, cf], [cf.T, Zf.T @ Zf]])
                bf = np.concatenate([b, Zf.T @ self.y[inside]])
                p = self.X.shape[1]
                coef = _fold_solve(gram - gf, right - bf, p, np.diag(zz))
                e = self.fold_y[f] - self.fold_X[f] @ coef[:p]
                position = np.searchsorted(fold, inside)
                e[position] -= Zf @ coef[p:]
            total += np.bincount(fold // self.n_samples, weights=e * e, minlength=self.n)
        return total

    def project(self, Z: np.ndarray, optional: tuple[int, ...]):
        """The candidate's columns outside the model's span: ((rows, kept columns, a = QᵀZ, G = Z⊥ᵀZ⊥,
        b = Zᵀr0) on the kept columns, "", None), or (None, reason, failed) when a required column is already
        in the model; ``failed`` = (that column, the columns kept before it) when it is in the model's span,
        ``None`` when it vanishes."""
        rows = np.flatnonzero(np.any(Z != 0, axis=1))
        Zr = Z[rows]
        a = self.Q[rows].T @ Zr
        G = Zr.T @ Zr - a.T @ a
        norms = np.einsum("ij,ij->j", Zr, Zr)
        kept: list[int] = []
        for i in range(Z.shape[1]):
            rest = G[i, i]
            if kept and norms[i] > 0:
                g = G[i, kept]
                rest -= g @ np.linalg.solve(G[np.ix_(kept, kept)], g)
            if norms[i] == 0 or rest <= COLLINEAR**2 * norms[i]:
                if i in optional:
                    continue
                if norms[i] == 0:
                    return None, "its column vanishes on these data", None
                return None, "the model already holds it (its column is in the span of the model's terms)", (i, tuple(kept))
            kept.append(i)
        if not kept:
            return None, "the model already holds it", None
        return (rows, tuple(kept), a[:, kept], G[np.ix_(kept, kept)], Zr[:, kept].T @ self.r0[rows]), "", None

    def explained(self, effect: Effect, j: int, value: Any, columns: np.ndarray | None = None) -> float:
        """Residual power the effect explains at ``value`` (jointly with the model's terms)."""
        if columns is None:
            columns = self.columns(effect, j, value, "estimation")
        parts, _, _ = self.project(self.design.weighted("estimation", columns), effect.optional)
        if parts is None:
            return 0.0
        _, _, _, G, b = parts
        return float(b @ np.linalg.solve(G, b))

    def explained_on_row(self, j: int, blocks: Sequence[np.ndarray] | np.ndarray) -> list[float]:
        """:meth:`explained` for many column sets at once, each acting on coordinate ``j`` only (``samples × k``
        there; ``blocks`` a list of them or a ``sets × samples × k`` array) and none optional (a grid of
        values): the same quantities b = Zᵀr0 and G = ZᵀZ − (QᵀZ)ᵀ(QᵀZ) on coordinate j's rows, for every set
        in one matrix product. A set with a column in the model's span (its part outside below
        :data:`COLLINEAR` of its norm) explains 0, as :meth:`project` has it."""
        rows = slice(j * self.n_samples, (j + 1) * self.n_samples)
        Z = (blocks if isinstance(blocks, np.ndarray) else np.stack(blocks, axis=0)) * self.design.weights[j]
        k = Z.shape[2]  # sets × samples × k
        a = np.matmul(self.Q[rows].T, Z)  # sets × p × k (matrix products: BLAS, unlike einsum)
        b = np.matmul(self.r0[rows], Z)  # sets × k
        zz = np.matmul(Z.transpose(0, 2, 1), Z)
        G = zz - np.matmul(a.transpose(0, 2, 1), a)
        diagonal = np.einsum("mkk->mk", G)
        norms = np.einsum("mkk->mk", zz)
        fine = np.all((norms > 0) & (diagonal > COLLINEAR**2 * norms), axis=1) if k else np.zeros(len(Z), bool)
        out = np.zeros(len(Z))
        if fine.any():
            out[fine] = np.einsum("mk,mk->m", b[fine], np.linalg.solve(G[fine], b[fine][:, :, None])[:, :, 0])
        return [float(x) for x in out]

    def explained_grid(self, effect: Effect, j: int, values: Sequence[Any],
                       quick: Sequence[np.ndarray] | np.ndarray | None = None) -> list[float]:
        """:meth:`explained` at each of ``values``: by :meth:`explained_on_row` when the columns (``quick``: the
        effect's shortcut columns, a list or a ``values × samples × N × k`` array; else the treated ones) act
        on coordinate ``j`` only and none is optional."""
        if quick is not None:
            stacked = quick if isinstance(quick, np.ndarray) else np.stack(quick)
            if stacked.ndim == 3:  # the compact form, on coordinate j only (Effect.scan_columns)
                if not effect.optional:
                    return self.explained_on_row(j, stacked)
                wide = np.zeros(stacked.shape[:2] + (self.n,) + stacked.shape[2:])
                wide[:, :, j, :] = stacked
                stacked = wide
            acting = (stacked != 0).any(axis=(0, 1)).any(axis=-1)  # per coordinate (contiguous reductions first)
            if not effect.optional and not np.delete(acting, j).any():
                return self.explained_on_row(j, stacked[:, :, j, :])
            return [self.explained(effect, j, v, z) for v, z in zip(values, stacked)]
        compact = self.batch(effect, j, values, "estimation")
        if not effect.optional and all(len(rows) == 1 and rows[0] == j for rows, _ in compact):
            return self.explained_on_row(j, [part[:, 0, :] for _, part in compact])
        return [self.explained(effect, j, v, self.expand(*c)) for v, c in zip(values, compact)]

    def evaluate(self, effect: Effect, j: int) -> Candidate:
        search = self.search
        coordinate = search.context.coordinates[j]
        c = Candidate(effect=effect, j=j, coordinate=coordinate)
        taken = [a for a in search.accepted if a.candidate.j == j]
        if any(a.effect.name == effect.name for a in taken) and not effect.repeatable:
            c.status, c.reason = "in the model", "accepted in an earlier round"
            return c
        clash = [a.effect.name for a in taken if a.effect.name in excluded(effect, search.effects)]
        if clash:
            c.status, c.reason = "not applicable", f"{clash[0]} was accepted on {coordinate}"
            return c
        reason = ELASTIC_ROW if coordinate in search.context.elastic else effect.applicable(search.context, j)
        if reason:
            c.status, c.reason = "not applicable", reason
            return c
        c.reference_map = _reference_map(search, self.design, effect, j)
        if effect.refines and c.reference_map is None:
            c.status, c.reason = f"needs {effect.refines}", f"the model has no {effect.refines} friction on {coordinate}"
            return c
        scanned = None
        if effect.nonlinear:
            grid = effect.grid(search.context, j)
            if grid is None:
                c.status, c.reason = "not applicable", f"the data give no range for its {effect.nonlinear}"
                return c
            values, c.trials = grid
            c.value = self.scan(effect, j, values)
            scanned = self._scanned if np.ndim(values) == 1 else None
        else:
            c.value = effect.setting(search.context, j)
        Z = self.design.weighted("estimation", self.columns(effect, j, c.value, "estimation"))
        parts, why, failed = self.project(Z, effect.optional)
        if parts is None:
            c.status, c.reason = "in the model", why
            limited = None if failed is None else search.separability.why(self, c, Z, *failed)
            if limited is not None:  # in the model's span on these data only: another motion would separate it
                c.status, c.reason = "not identifiable", limited
            return c
        rows, kept, _, _, _ = parts
        c.kept, c.width = kept, Z.shape[1]
        c.added = len(kept) + (1 if effect.nonlinear else 0)
        Zv = None if search.cross_validate else \
            self.design.weighted("validation", self.columns(effect, j, c.value, "validation"))[:, list(kept)]
        joint = _Joint(self, rows, Z[np.ix_(rows, kept)], Zv)
        fit = joint.fit(range(len(kept)))
        own = tuple(int(i) for i in np.unique(rows // self.n_samples))
        self.record(c, fit, [(own, len(kept), c.added)], outside=joint.outside(range(len(kept))) if len(own) == 1 else None)
        c.model_coefficients = fit.coef
        c.coefficients = _expand(c, fit.coef[self.X.shape[1]:])
        c.reference = _reference_value(c.reference_map, fit.coef)
        c.roles = effect.roles_of(c.coefficients, c.value, c.reference)
        # the share of the whole (stacked) residual: a resonance exempt from showing a spectral peak must
        # dominate it; on its own coordinate the 14-bit arm's null fit explained 55 % of q1's residual, the
        # 14-bit axis's real 8 Hz load 59 % (docs/workflow.md, "Name")
        c.invalid = effect.check(c.roles, c.reference, search.context, j) or \
            effect.check_residual(c.roles, *self.residual_spectrum(j), c.stacked_share, floor=self.residual_floor(j))
        if c.invalid is None and effect.nonlinear and scanned is not None:
            c.invalid = effect.scan_verdict(*scanned, search.context)
        return c

    def record(self, c: Judged, fit: _Fit, pieces: list[tuple[tuple[int, ...], int, int]], before: _Fit | None = None,
               beside: Sequence[tuple[tuple[int, ...], int]] = (), outside: Mapping[int, np.ndarray] | None = None) -> None:
        """Set ``c``'s per-coordinate figures from ``fit`` against ``before`` (default: the round's model);
        ``pieces`` (coordinates, columns, parameters added) say what it adds where (:func:`_parts`);
        ``beside`` (coordinates, columns): what both fits hold besides the model (a group's other members);
        ``outside``: per coordinate, the added columns' part outside the model's span on its rows, whose
        score's variance inflation is used where it exceeds τ_int (:func:`~symbolic.workflow.statistics.score_inflation`)."""
        before = before or _Fit(self.power0, self.held0, self.coef, self.r0)
        c.power0, c.power1, c.held0, c.held1 = before.power, fit.power, before.held, fit.held
        c.own = tuple(sorted({j for own, _, _ in pieces for j in own}))
        residual = fit.residual.reshape(self.n, -1)
        c.taus = {j: autocorrelation_time(residual[j]) for j in c.own}
        for j, z in (outside or {}).items():  # the more conservative of the two variance corrections
            b = z.T @ before.residual.reshape(self.n, -1)[j]
            c.taus[j] = max(c.taus[j], score_inflation(z, residual[j], b))
        taus = {own: (c.taus[own[0]] if len(own) == 1 else _tau(residual, own)) for own, _, _ in pieces}
        c.tau = c.taus[c.own[0]] if len(c.own) == 1 else _tau(residual, c.own)
        leverage = self.leverage.copy()
        for own, columns in beside:
            leverage[list(own)] += columns / len(own)
        parts = _parts(pieces, before.power, fit.power, leverage, taus, self.n_samples, held=False)
        c.F, c.p_value = combined_f_test([part for _, part in parts])
        c.p_by = {}
        for own, (p0, p1, _, _, added, _) in parts:  # each coordinate on its own rows
            for j in own:
                c.p_by[j] = combined_f_test([(float(before.power[j]), float(fit.power[j]), float(self.n_samples),
                                              float(leverage[j]), added, c.taus[j])])[1]

    @staticmethod
    def pool(group: Group, candidates: Sequence[Candidate]) -> list[Candidate]:
        """The round's single candidates that are members of ``group``: its effects, tested on its coordinates."""
        return [c for c in candidates if c.status == "tested" and c.effect.name in group.effects
                and c.coordinate in group.coordinates and c.own == (c.j,) and not c.effect.nonlinear]

    def evaluate_group(self, group: Group, pool: Sequence[Candidate], effective: np.ndarray) -> Grouped:
        """The grouped hypothesis ``group`` of the single candidates ``pool`` (module docstring): members
        refitted together, those that do not earn their place on their own coordinate dropped (the worst per
        coordinate, then the rest refitted)."""
        g = Grouped(group=group)
        blocks, index, start = [], [], 0
        for c in pool:
            blocks.append([self.design.weighted(role, self.columns(c.effect, c.j, None, role))[:, list(c.kept)]
                           for role in (("estimation",) if self.search.cross_validate else ("estimation", "validation"))])
            index.append(list(range(start, start + len(c.kept))))
            start += len(c.kept)
        Z = np.concatenate([b[0] for b in blocks], axis=1)
        rows = np.flatnonzero(np.any(Z != 0, axis=1))
        Zv = None if self.search.cross_validate else np.concatenate([b[1] for b in blocks], axis=1)
        joint = _Joint(self, rows, Z[rows], Zv)
        alive = list(range(len(pool)))
        while True:
            columns = [i for m in alive for i in index[m]]
            full = joint.fit(columns)
            verdicts = {m: self.member(pool[m], joint, full, columns, index[m],
                                       [((pool[o].j,), len(index[o])) for o in alive if o != m], effective) for m in alive}
            failing = [m for m in alive if verdicts[m].failed]
            if not failing:
                break
            for j in sorted({pool[m].j for m in failing}):
                worst = max((m for m in failing if pool[m].j == j),
                            key=lambda m: (verdicts[m].invalid is not None, verdicts[m].delta_bic_own))
                alive.remove(worst)
                g.dropped.append((verdicts[worst], "; ".join(verdicts[worst].failed)))
            if len(alive) < 2:
                break
        g.members = [verdicts[m] for m in alive]
        if len(alive) < 2:
            g.status = "reduced"
            g.reason = "no member earns its place" if not alive else \
                f"only {g.members[0].label()} earns its place: that is its single candidate"
            return g
        g.added = sum(pool[m].added for m in alive)
        self.record(g, full, [((pool[m].j,), len(index[m]), pool[m].added) for m in alive], outside=joint.outside(columns))
        return g

    def member(self, single: Candidate, joint: _Joint, full: _Fit, columns: list[int], mine: list[int],
               beside: list[tuple[tuple[int, ...], int]], effective: np.ndarray) -> Candidate:
        """A group's member judged on its own coordinate: the group's fit (of ``columns``) against the fit
        without its columns ``mine``; ``beside``: the other members (coordinates, columns)."""
        j = single.j
        rest = [i for i in columns if i not in mine]
        without = joint.fit(rest, held=False)  # the held-out error only for a member that passes the rest
        m = dataclasses.replace(single, failed=[], taus={}, p_by={})
        self.record(m, full, [((j,), len(mine), single.added)], before=without, beside=beside)
        ratio = math.log(max(float(full.power[j]), 1e-300) / max(float(without.power[j]), 1e-300))
        m.delta_bic = m.delta_bic_own = effective[j] * ratio + single.added * math.log(effective[j])
        positions = [columns.index(i) for i in mine]
        p = self.X.shape[1]
        m.model_coefficients = full.coef
        m.coefficients = _expand(m, full.coef[p + np.asarray(positions)])
        m.reference = _reference_value(m.reference_map, full.coef)
        m.roles = m.effect.roles_of(m.coefficients, m.value, m.reference)
        m.invalid = m.effect.check(m.roles, m.reference, self.search.context, j)
        s = self.search.settings
        if m.invalid:
            m.failed.append(f"physical: {m.invalid}")
        if not m.delta_bic_own < 0:
            m.failed.append(f"BIC: ΔBIC = {m.delta_bic_own:.3g} on {m.coordinate}'s rows is not negative")
        if not m.failed:
            m.held0 = joint.fit(rest).held
            if m.gain < s.min_gain:
                m.failed.append(f"held-out: removes {100 * m.gain:.3g} % of {m.coordinate}'s held-out residual power "
                                f"left without it (at least {100 * s.min_gain:g} % needed)")
            elif (size := self.force_size(m)) < MIN_FORCE_SHARE:
                m.failed.append(f"size: removes {100 * size:.2g} % of {m.coordinate}'s force spread from the held-out "
                                f"residual (at least {100 * MIN_FORCE_SHARE:g} %)")
        return m

    def force_size(self, c: Judged) -> float:
        """What ``c`` removes from its own coordinates' held-out residual, as a fraction of their measured
        force's spread (RMS; :data:`~symbolic.workflow.statistics.MIN_FORCE_SHARE`)."""
        own = list(c.own)
        removed = float(np.sum(c.held0[own]) - np.sum(c.held1[own]))
        force = float(np.sum(self.force_power[own]))
        return math.sqrt(max(removed, 0.0) / force) if force > 0 else math.inf

    def score(self, c: Judged, effective: np.ndarray) -> None:
        """ΔBIC over every coordinate (ranking) and on the own coordinates (which must be negative)."""
        ratio = np.log(np.maximum(c.power1, 1e-300) / np.maximum(c.power0, 1e-300))
        own = list(c.own)
        if isinstance(c, Grouped):
            penalty = sum(m.added * math.log(effective[m.j]) for m in c.members)
        else:
            penalty = c.added * math.log(float(effective[own].sum()))
        c.delta_bic = float(effective @ ratio) + penalty
        c.delta_bic_own = float(effective[own] @ ratio[own]) + penalty

    def where(self, c: Judged) -> str:
        names = self.search.context.coordinates
        if len(c.own) == len(names) > 1:
            return "every coordinate's"
        return ", ".join(names[j] for j in c.own) + "'s"

    def judge(self, c: Judged, threshold: float) -> None:
        s = self.search.settings
        where = self.where(c)
        if c.invalid:
            c.failed.append(f"physical: {c.invalid}")
        if not c.p_value < threshold:
            c.failed.append(f"significance: p = {c.p_value:.3g} on {where} rows is not below {threshold:.3g}")
        if c.gain < s.min_gain:
            c.failed.append(f"held-out: removes {100 * c.gain:.3g} % of {where} held-out residual power "
                            f"(at least {100 * s.min_gain:g} % needed)")
        elif (size := self.force_size(c)) < MIN_FORCE_SHARE:
            c.failed.append(f"size: removes {100 * size:.2g} % of {where} force spread from the held-out residual "
                            f"(at least {100 * MIN_FORCE_SHARE:g} %: below, the residual is the treatment's own)")
        if not c.delta_bic_own < 0:
            c.failed.append(f"BIC: ΔBIC = {c.delta_bic_own:.3g} on {where} rows is not negative")

    def residual_spectrum(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Welch spectrum of the round's residual on coordinate ``j`` (at the kept samples' rate)."""
        if j not in self._spectra:
            from symbolic.workflow.where import spectrum

            p = self.design.sets["estimation"].states.processing
            residual = self.r0.reshape(self.n, self.n_samples)[j]
            self._spectra[j] = spectrum(residual, p.rate / p.decimation)
        return self._spectra[j]

    def residual_floor(self, j: int) -> np.ndarray | None:
        """The encoders' rounding in the residual's spectrum on coordinate ``j``, weighted as the residual is
        (:meth:`Search.quantisation_floor`); ``None`` where there is none."""
        floor = self.search.quantisation_floor(j)
        return None if floor is None else floor * float(self.design.weights[j]) ** 2

    def scan(self, effect: Effect, j: int, values: np.ndarray) -> float | tuple[float, ...]:
        """The nonlinear parameter explaining most: the best grid value, refined between its neighbours
        (several parameters: the best grid row, refined by a simplex search within the grid's box)."""
        if np.ndim(values) == 2:
            return self.scan_several(effect, j, np.asarray(values, float))
        explained: list[float] = []
        kept = self.design.sets["estimation"].t

        def at(v: float) -> float:  # one value, by the grid's own route (the effect's shortcut, if it has one)
            return self.explained_grid(effect, j, [v], effect.scan_columns(kept, self.n, j, [v]))[0]

        for chunk in np.array_split(values, max(1, math.ceil(len(values) / self.CHUNK))):
            points = [float(v) for v in chunk]
            explained += self.explained_grid(effect, j, points, effect.scan_columns(kept, self.n, j, points))
        self._scanned = (np.asarray(values, float), np.asarray(explained))
        best = int(np.argmax(explained))
        low, high = values[max(best - 1, 0)], values[min(best + 1, len(values) - 1)]
        if high <= low:
            return float(values[best])
        result = scipy.optimize.minimize_scalar(
            lambda x: -at(float(math.exp(x))),
            bounds=(math.log(low), math.log(high)), method="bounded", options={"xatol": effect.refinement})
        return float(math.exp(result.x)) if -result.fun >= explained[best] else float(values[best])

    def scan_several(self, effect: Effect, j: int, values: np.ndarray) -> tuple[float, ...]:
        rows = [tuple(float(x) for x in row) for row in values]
        explained: list[float] = []
        for start in range(0, len(rows), self.CHUNK):
            explained += self.explained_grid(effect, j, rows[start:start + self.CHUNK])
        best = int(np.argmax(explained))
        low, high = np.log(values.min(axis=0)), np.log(values.max(axis=0))

        def loss(x: np.ndarray) -> float:
            if np.any(x < low) or np.any(x > high):
                return 0.0
            return -self.explained_grid(effect, j, [tuple(float(v) for v in np.exp(x))])[0]

        start = np.log(np.asarray(rows[best]))
        steps = np.diag(np.maximum((high - low) / max(len(rows) ** (1 / values.shape[1]), 1.0), 1e-3))
        result = scipy.optimize.minimize(loss, start, method="Nelder-Mead",
                                         options={"initial_simplex": np.vstack([start, start + steps]),
                                                  "xatol": 1e-4, "fatol": 1e-9 * max(explained[best], 1e-300),
                                                  "maxfev": 120})
        if -result.fun >= explained[best]:
            return tuple(float(v) for v in np.exp(result.x))
        return rows[best]
