"""Bursts judged against the siblings' logs: a burst is an event only where its log differs from the same robot's
and the fleet's other logs at the same phase of the same cycle, or at the same state; what the logs share there
is a systematic misfit of the model, reported once (docs/fleet.md, "Events and systematic misfits").

Input: the campaign's rows, each with the bursts of its log and the profile of its residual
(:func:`symbolic.fleet.events.examine`, computed on the workers). Output: each row's events, and the misfits.

* **Siblings.** The logs of robots of the same model (the same validated description and coordinates). The
  *own* reference of a log is its robot's other logs, the *fleet* reference the other robots' logs, each at
  most :data:`REFERENCE`, the nearest in time.
* **The same phase.** Two logs *share a cycle* when their profiles have the same bins (to one) and their states
  agree bin by bin: the median over the bins of the largest difference of a position or velocity is below
  :data:`symbolic.fleet.events.RECUR` standard deviations (of the siblings' logs together). Then a burst's phase
  in the other log is the same time since the log's start; otherwise it is where the other log's state is
  nearest to the burst's (largest difference below RECUR standard deviations; a log that never comes that
  close is not compared).
* **The test.** Per coordinate j of the burst: x = ln ρ_j, the largest windowed RMS ratio of the log's profile
  over the burst (widened by a bin each side), against the same in each reference log at that phase, y_i
  (m of them). A sibling that shows the same there would fall within ȳ ± s·√(1 + 1/m) (a prediction
  interval; s the siblings' standard deviation, at least :data:`SPREAD_FLOOR`): T = (x − ȳ)/(s·√(1 + 1/m)),
  p one-sided (a burst is a surplus) from Student's t with m − 1 degrees of freedom. A reference is used with
  at least :data:`MIN_REFERENCE` logs. The burst differs when p is below the threshold against *both* the own
  and the fleet reference (the larger p: an intersection–union test, of level α without correction), so that
  what a robot repeats in every log of its own is not an event either.
* **The threshold** is α / (the tests of the campaign: every coordinate of every burst compared), Bonferroni:
  in a fleet whose logs at each phase are alike (a log-normal level across logs), an event is reported with
  probability at most α. A burst without a reference (no sibling log of the model comes near it) keeps the
  log's own verdict (docs/fleet.md, "Events").
* **Misfits.** The bursts that are not events — like their siblings, or recurring within their log — are
  grouped, each with the first of a group at its phase (a shared coordinate, and the same cycle time within a
  window in logs that share a cycle, or
  states within RECUR standard deviations): each group is one misfit of the model, with where (the time in
  the cycle, the state), how large (the bursts' RMS ratios) and how many logs and robots show it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symbolic.fleet.campaign import Events
from symbolic.fleet.events import RECUR, unpack

MIN_REFERENCE = 4
"""Logs a reference needs: 3 degrees of freedom for its Student's t."""
REFERENCE = 30
"""Logs of each reference (the robot's own, the fleet's) at most: those nearest in time to the judged log."""
SPREAD_FLOOR = 0.05
"""Smallest standard deviation of the siblings' ln ρ used: levels that agree to better than 5 % (float16 keeps
0.1 %) would make any difference significant."""


@dataclass(frozen=True, eq=False)
class Log:
    """One log's profile (:func:`symbolic.fleet.events.profile`), decoded, with what the judgement needs."""

    index: int
    robot: str
    group: tuple[str, tuple[str, ...]]
    days: float
    t0: float
    width: float
    levels: np.ndarray
    states: np.ndarray
    window: float
    shared: dict[int, bool] = field(default_factory=dict, repr=False)

    @functools.cached_property
    def columns(self) -> np.ndarray:
        """:attr:`states` transposed (a row per position or velocity), contiguous, read once :func:`_scale` has
        scaled them: the largest difference of a state over its few columns is then an elementwise maximum of
        rows, 7 times faster than NumPy's reduction along the short last axis of ``states``; the search for the
        nearest state was two thirds of the judgement's time (36 logs of 100 s, bench/fleet.py)."""
        return np.ascontiguousarray(self.states.T)


@dataclass(frozen=True)
class Verdict:
    """A burst's comparison with one reference: the reference's logs, their median level, and p."""

    logs: int
    median: float
    p_value: float

    def to_dict(self) -> dict[str, Any]:
        return {"logs": self.logs, "median_ratio": self.median, "p_value": self.p_value}


def judge(rows: Sequence[dict[str, Any]], robots: Mapping[str, tuple[str, Events]],
          alpha: float) -> tuple[list[list[dict[str, Any]] | None], list[dict[str, Any]]]:
    """Each row's events (None for a row without bursts) and the misfits of the campaign (module docstring).

    Parameters
    ----------
    rows
        The campaign's rows; those with ``bursts`` and ``profile`` are judged.
    robots
        Robot id → (its model's digest, its task's event settings).
    alpha
        The campaign's false-alarm probability.

    Returns
    -------
    tuple
        Per row, its events (each burst's dict with ``siblings``: the comparisons, per coordinate), and the
        misfits (dicts: :func:`misfit`).
    """
    logs = _logs(rows, robots)
    timelines = _timelines(logs)
    tested = {(i, k): _compare(logs, timelines, i, burst) for i in logs
              for k, burst in enumerate(rows[i]["bursts"]) if not burst.get("recurs")}
    tests = sum(len(v) for v in tested.values() if v is not None)
    threshold = alpha / max(1, tests)
    events: list[list[dict[str, Any]] | None] = [None] * len(rows)
    others: list[tuple[int, dict[str, Any]]] = []
    for i, row in enumerate(rows):
        if "bursts" not in row:
            continue
        events[i] = []
        for k, burst in enumerate(row["bursts"]):
            verdicts = tested.get((i, k))
            if burst.get("recurs") or (verdicts is not None and not _differs(verdicts, threshold)):
                others.append((i, burst))
                continue
            siblings = None if verdicts is None else {c: {name: v.to_dict() for name, v in pair.items()}
                                                      for c, pair in verdicts.items()}
            events[i].append({**_public(burst), "siblings": siblings, "threshold": threshold})
    return events, [misfit(rows, logs, group) for group in _groups(logs, others)]


def _public(burst: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in burst.items() if k not in ("recurs", "state")}


def _differs(verdicts: Mapping[str, Mapping[str, Verdict]], threshold: float) -> bool:
    """Whether some coordinate's larger p (own, fleet) is below the threshold."""
    return any(max(v.p_value for v in pair.values()) < threshold for pair in verdicts.values())


def _logs(rows: Sequence[dict[str, Any]], robots: Mapping[str, tuple[str, Events]]) -> dict[int, Log]:
    out = {}
    for i, row in enumerate(rows):
        shape = row.get("profile")
        if row.get("status") != "ok" or not shape or row["robot"] not in robots:
            continue
        digest, settings = robots[row["robot"]]
        levels = unpack(shape["levels"], shape["bins"])
        z = unpack(shape["states"], shape["bins"])
        states = z * np.where(np.asarray(shape["spread"]) > 0, shape["spread"], 1.0) + np.asarray(shape["mean"])
        out[i] = Log(i, row["robot"], (digest, tuple(shape["coordinates"])), row.get("days") or 0.0,
                     float(shape["t0"]), float(shape["bin"]), levels, states, settings.window)
    _scale(out)
    return out


def _scale(logs: Mapping[int, Log]) -> None:
    """Each log's states as z-scores of its group's pooled standard deviations, in place."""
    groups: dict[tuple, list[Log]] = {}
    for log in logs.values():
        groups.setdefault(log.group, []).append(log)
    for members in groups.values():
        every = np.vstack([m.states for m in members])
        spread = every.std(axis=0)
        spread = np.where(spread > 0, spread, 1.0)
        centre = every.mean(axis=0)
        for m in members:
            m.states[...] = (m.states - centre) / spread


def _compare(logs: Mapping[int, Log], timelines: Mapping[tuple, Sequence[Log]], i: int,
             burst: dict[str, Any]) -> dict[str, dict[str, Verdict]] | None:
    """Per coordinate of ``burst`` in log ``i``, its comparison with each reference that has enough logs at
    its phase; None when no reference has."""
    log = logs[i]
    span = _bins(log, burst)
    coordinates = log.group[1]
    own, fleet = _references(timelines, log)
    out: dict[str, dict[str, Verdict]] = {}
    for name in burst["coordinates"]:
        j = coordinates.index(name)
        x = float(log.levels[span, j].max())
        pair = {}
        for label, reference in (("own", own), ("fleet", fleet)):
            levels = [v for v in (_level_at(log, span, other, j) for other in reference) if v is not None]
            if len(levels) >= MIN_REFERENCE:
                pair[label] = verdict(x, np.asarray(levels))
        if pair:
            out[name] = pair
    return out or None


def verdict(x: float, levels: np.ndarray) -> Verdict:
    """The one-sided prediction-interval test of the level ``x`` against the siblings' ``levels`` (ratios;
    module docstring).

    Parameters
    ----------
    x
        The burst's level ρ (windowed RMS ratio) in its log.
    levels
        The reference logs' levels at the same phase.

    Returns
    -------
    Verdict
        The number of reference logs, their median level, and p.

    >>> round(verdict(40.0, np.array([1.0, 1.1, 0.9, 1.2, 1.05])).p_value, 6) < 1e-4
    True
    >>> verdict(1.1, np.array([1.0, 1.1, 0.9, 1.2, 1.05])).p_value > 0.3
    True
    """
    from scipy.special import stdtr  # Student's t CDF (as in drift)

    y = np.log(np.maximum(levels, 1e-3))
    m = len(y)
    spread = max(float(y.std(ddof=1)), SPREAD_FLOOR)
    t = (math.log(max(x, 1e-3)) - float(y.mean())) / (spread * math.sqrt(1 + 1 / m))
    return Verdict(m, float(np.median(levels)), float(stdtr(m - 1, -t)))


def _bins(log: Log, burst: dict[str, Any]) -> slice:
    """The profile's bins over the burst, widened by one each side."""
    first = int((burst["start"] - log.t0) // log.width) - 1
    last = int((burst["end"] - log.t0) // log.width) + 1
    bins = len(log.levels)
    return slice(min(max(first, 0), bins - 1), min(max(last, 0), bins - 1) + 1)


def _references(timelines: Mapping[tuple, Sequence[Log]], log: Log) -> tuple[list[Log], list[Log]]:
    """The robot's other logs and the other robots' logs of the same group, each the :data:`REFERENCE` nearest
    in time."""
    timeline = timelines[log.group]
    return (_nearest(timeline, log, lambda o: o.robot == log.robot),
            _nearest(timeline, log, lambda o: o.robot != log.robot))


def _timelines(logs: Mapping[int, Log]) -> dict[tuple, list[Log]]:
    """Each group's logs in time order."""
    out: dict[tuple, list[Log]] = {}
    for log in sorted(logs.values(), key=lambda o: (o.days, o.index)):
        out.setdefault(log.group, []).append(log)
    return out


def _nearest(timeline: Sequence[Log], log: Log, keep) -> list[Log]:
    """The :data:`REFERENCE` logs of ``timeline`` (time order) nearest in time to ``log`` that ``keep`` accepts,
    ``log`` itself left out: two pointers walking out from its place."""
    at = _place(timeline, log.days)
    before, after, out = at - 1, at, []
    while len(out) < REFERENCE and (before >= 0 or after < len(timeline)):
        earlier = timeline[before] if before >= 0 else None
        later = timeline[after] if after < len(timeline) else None
        if later is None or (earlier is not None and log.days - earlier.days <= later.days - log.days):
            chosen, before = earlier, before - 1
        else:
            chosen, after = later, after + 1
        if chosen.index != log.index and keep(chosen):
            out.append(chosen)
    return out


def _place(timeline: Sequence[Log], days: float) -> int:
    """The first position of ``timeline`` not before ``days``."""
    low, high = 0, len(timeline)
    while low < high:
        middle = (low + high) // 2
        if timeline[middle].days < days:
            low = middle + 1
        else:
            high = middle
    return low


def shares_cycle(a: Log, b: Log) -> bool:
    """Whether logs ``a`` and ``b`` run the same cycle from their starts (module docstring)."""
    known = a.shared.get(b.index)
    if known is None:
        same = abs(a.width - b.width) <= 1e-9 * max(a.width, b.width) and abs(len(a.states) - len(b.states)) <= 1
        if same:
            n = min(len(a.states), len(b.states))
            same = float(np.median(_largest(a.columns[:, :n] - b.columns[:, :n]))) < RECUR
        a.shared[b.index] = b.shared[a.index] = known = same
    return known


def _level_at(log: Log, span: slice, other: Log, j: int) -> float | None:
    """The largest level of coordinate ``j`` in ``other`` at the phase of ``log``'s bins ``span``: the same
    bins when they share a cycle, else the bins nearest in state (None when none is within RECUR)."""
    if shares_cycle(log, other):
        window = other.levels[span.start:span.stop, j]
        return float(window.max()) if window.size else None
    found = []
    for k in range(span.start, span.stop):
        distance = _largest(other.columns - log.states[k][:, None])
        nearest = int(np.argmin(distance))
        if distance[nearest] < RECUR:
            found.append(float(other.levels[nearest, j]))
    return max(found) if found else None


def _largest(differences: np.ndarray) -> np.ndarray:
    """The largest absolute difference of each column of ``differences`` (rows: the state's positions and
    velocities), the values of ``np.abs(...).max(axis=1)`` on the transpose."""
    return np.maximum.reduce(np.abs(differences), axis=0)


def _groups(logs: Mapping[int, Log], bursts: Sequence[tuple[int, dict[str, Any]]]) -> list[list[tuple[int, dict]]]:
    """The bursts that are not events, grouped by phase (module docstring): each joins the first group whose
    first burst is at its phase, else starts one (a misfit's group is one: a pass over the bursts per group)."""
    groups: list[list[tuple[int, dict]]] = []
    for item in bursts:
        for group in groups:
            if _same_phase(logs, group[0], item):
                group.append(item)
                break
        else:
            groups.append([item])
    return sorted(groups, key=lambda g: (-len({i for i, _ in g}), min(i for i, _ in g)))


def _same_phase(logs: Mapping[int, Log], a: tuple[int, dict], b: tuple[int, dict]) -> bool:
    (i, x), (k, y) = a, b
    if i not in logs or k not in logs or logs[i].group != logs[k].group:
        return False
    if not set(x["coordinates"]) & set(y["coordinates"]):
        return False
    one, two = logs[i], logs[k]
    if (i == k or shares_cycle(one, two)) and \
            abs((x["peak_time"] - one.t0) - (y["peak_time"] - two.t0)) <= max(one.window, 2 * one.width):
        return True
    return float(np.abs(_state(one, x) - _state(two, y)).max()) < RECUR


def _state(log: Log, burst: dict[str, Any]) -> np.ndarray:
    """The (pooled z-scored) state of ``log``'s profile at the burst's peak."""
    k = int((burst["peak_time"] - log.t0) // log.width)
    return log.states[min(max(k, 0), len(log.states) - 1)]


def misfit(rows: Sequence[dict[str, Any]], logs: Mapping[int, Log], group: Sequence[tuple[int, dict]]) -> dict[str, Any]:
    """One systematic misfit: where (the time in the cycle when its logs share one, the state at the peaks:
    medians), how large (the bursts' RMS ratios: median and range; the peak residual: median), and how many
    logs and robots show it among the logs of that model."""
    indices = sorted({i for i, _ in group})
    first = logs.get(indices[0])
    coordinates = sorted({c for _, b in group for c in b["coordinates"]},
                         key=lambda c: first.group[1].index(c) if first and c in first.group[1] else 0)
    ratios = [b["ratio"] for _, b in group]
    strongest = [max(b["size"].values(), key=lambda s: s["ratio"]) for _, b in group]
    cycle = first is not None and all(i in logs and (i == first.index or shares_cycle(first, logs[i])) for i in indices)
    states = np.array([b["state"] for _, b in group if b.get("state") is not None])
    names = first.group[1] if first else ()
    where = {}
    if states.size and len(names) * 2 == states.shape[1]:
        middle = np.median(states, axis=0)
        where = {**{f"q_{c}": float(v) for c, v in zip(names, middle[:len(names)])},
                 **{f"qd_{c}": float(v) for c, v in zip(names, middle[len(names):])}}
    compared = sum(1 for log in logs.values() if first and log.group == first.group)
    return {"robots": sorted({rows[i]["robot"] for i in indices}), "coordinates": coordinates,
            "cycle_time": float(np.median([b["peak_time"] - logs[i].t0 for i, b in group if i in logs])) if cycle
            else None, "state": where, "ratio": float(np.median(ratios)), "ratio_range": [min(ratios), max(ratios)],
            "peak": float(np.median([abs(s["peak"]) for s in strongest])), "bursts": len(group), "logs": len(indices),
            "of": compared, "examples": [rows[i]["log"] for i in indices[:3]]}
