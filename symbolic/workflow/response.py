"""The search judged on the response: name what the simulated closed loop shows and the inverse dynamics cannot.

docs/workflow.md, "Judged on the response". After the equation-error search and the patch, ``diagnose
--simulate`` simulates the patched model in the machine's own loop (the experiment's ``[controller]``) and
compares the simulated force and position with the log, per coordinate. Each candidate of the response
catalogue (:data:`~symbolic.workflow.effects.on_response.RESPONSE_EFFECTS`: a delay, a drive gain, a sensor
bias, a model file's stiffness or damping) frees its values, which are fitted by the output error on the
estimation data (:func:`symbolic.identify.output_error.output_error`, Levenberg–Marquardt with exact
sensitivities, Gautier, Janot, Vandanjon 2013), everything named before kept free with them. It is judged on
the **held-out** data, never on the data it was fitted on:

* ``gain``: the share of the held-out simulation error's power it removes on its coordinate, the mean over
  the signals compared (force and position under a feedback loop; position under torque replay) of
  1 − (e_after/e_before)², each signal's error relative to the measured spread; at least the effect size
  :data:`~symbolic.workflow.statistics.MIN_HELD_OUT_GAIN` (the equation-error search's);
* ``stacked_gain`` over every coordinate and signal: positive (no coordinate pays for another's gain);
* each freed value at least :data:`MIN_SIGMAS` standard deviations from its null value (delay 0, gain 1,
  bias 0, a parameter's value in the patched file) — the Jacobian's σ, a lower bound of the spread, so a
  necessary condition, not a sufficient one;
* the effect's physical check (a drive gain within 0.2–5, a stiffness positive).

Forward selection: of a round's candidates that pass, the one that lowers the held-out error over every
coordinate most (``stacked_gain``: candidates of one coordinate and of all compare on it) is named, its values
stay free in the next rounds, and the search ends when none passes. The truth of a synthetic case never enters here: the
candidates are the catalogue's, on every coordinate the log drives.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symbolic.data import DataError, Measurements, signal_layer
from symbolic.derivation.dynamics import DynamicModel
from symbolic.errors import IdentificationError, SimulationError
from symbolic.identify.output_error import (FittedParameter, OutputErrorFit, output_error, simulated,
                                            simulation_errors)
from symbolic.workflow import forked
from symbolic.workflow.effects.on_response import (PARAMETER, RESPONSE_EFFECTS, Key, ResponseCandidate, fixed_key,
                                                   ResponseEffect)
from symbolic.workflow.statistics import MIN_FORCE_SHARE, MIN_HELD_OUT_GAIN, MIN_SIGMAS, pooled_autocorrelation_time
from symbolic.workflow.terms import own_rows

log = logging.getLogger("symbolic")

MAX_ROUNDS = 6
"""At most this many effects are named by the response (each round refits everything named before)."""

MAX_ITERATIONS = 15
"""Levenberg–Marquardt iterations of the refit."""

CANDIDATE_ITERATIONS = 8
"""... and of one candidate's fit, which starts at the refit's optimum: what a candidate explains shows within a
few steps, and a model with poorly determined values (a payload the equation error named on a 2-link arm) spent
35 s per candidate going on to 15."""

TOLERANCE = 0.05
"""A candidate's fit stops when its Gauss–Newton step is below this many σ of every estimate: the search
compares fits by their held-out errors, which a twentieth of a σ does not move (identify --method didim
goes on to 1e-3 σ)."""

MAX_REFIT = 12
"""Where the data determine at most this many of the model's parameters, the refit frees them all and every
candidate is fitted with all of them free. Beyond (a 6-axis arm: tens of inertial combinations), the search is
*local* (:class:`Scope`): the refit frees only the values that act on one coordinate's force alone (its friction,
its rotor inertia, a spring of its own), and each candidate frees, beside its own values, those of its coordinate;
everything else stays at the refit's values. A refit of every value of a 6-axis arm took 12 min and moved friction
and rotor inertias by 30–200 % for an 11 % held-out gain (docs/workflow.md, "Where it runs")."""

MAX_LOCAL = 30
"""The local refit's limit (own-row values of every coordinate: three or four a joint)."""

Errors = dict[str, dict[str, float]]


@dataclass(frozen=True)
class Judged:
    """A candidate fitted and judged: its values, the errors (%) on the estimation and held-out data with it,
    its gains and the verdict (``None``: it passes)."""

    candidate: ResponseCandidate
    values: dict[Key, FittedParameter]
    estimation: Errors
    held_out: Errors
    gain: float
    stacked_gain: float
    sigmas: float
    roles: dict[str, float]
    converged: bool
    verdict: str | None
    fit: OutputErrorFit | None = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"effect": self.candidate.effect.identifier, "coordinate": self.candidate.coordinate,
                               "label": self.candidate.label(), "parameters": dict(self.roles),
                               "sigmas": {_name(k): v.sigma for k, v in self.values.items()},
                               "held_out_gain": self.gain, "stacked_held_out_gain": self.stacked_gain,
                               "distance_in_sigmas": self.sigmas if math.isfinite(self.sigmas) else None,
                               "converged": self.converged,
                               "errors": {"estimation": self.estimation, "held_out": self.held_out}}
        if self.verdict is not None:
            out["verdict"] = self.verdict
        else:
            out["written_as"] = self.candidate.effect.written_as(self.values)
        return out


@dataclass(frozen=True)
class ResponseSearch:
    """What the response search found (module docstring): the errors before (the patched model as written)
    and after (with every named value), each candidate of each round, the named ones."""

    signals: str
    before: dict[str, Errors]
    after: dict[str, Errors]
    rounds: tuple[tuple[Judged, ...], ...]
    named: tuple[Judged, ...]
    seconds: float
    notes: tuple[str, ...] = ()
    refit: dict[str, Any] | None = None
    """The model's own parameters fitted by the output error before any candidate (:func:`_refit`)."""
    values: dict[str, float] = field(default_factory=dict)
    """The model-file values the response sets (the last named candidate's fit, or the accepted refit's)."""
    corrections: tuple[dict[str, Any], ...] = ()
    """The values among :attr:`values` that the output error moves from IDIM-LS's by 3σ and 10 %, named as
    corrections (a stiffness the resonance shows and the noisy accelerations did not)."""
    local: bool = False
    """Whether the search was local (:data:`MAX_REFIT`): each fit freed its own coordinate's values only, and the
    last named candidate's fit does not hold every value named (the stand-in review does not run)."""

    def parameter_values(self) -> dict[str, float]:
        """The model-file values to write into the patched file (empty: IDIM-LS's stay)."""
        return dict(self.values)

    def layer_values(self) -> dict[Key, float]:
        """The signal-layer values named (for the experiment file)."""
        # every named one's: a scanned value is held fixed in later fits, which return only the free ones
        return {k: v.value for j in self.named for k, v in _all_values(j).items() if k[0] != PARAMETER}

    def experiment_lines(self) -> list[str]:
        """The TOML lines (``[sensors]``/``[drive]`` tables and their entries) that declare what was named."""
        by_signal: dict[tuple[str, str], list[str]] = {}
        for (table, signal, name), value in self.layer_values().items():
            by_signal.setdefault((table, signal), []).append(f"{name} = {value:.6g}")
        lines: list[str] = []
        for (table, signal), values in sorted(by_signal.items()):
            if f"[{table}]" not in lines:
                lines.append(f"[{table}]")
            lines.append(f"{signal} = {{ {', '.join(values)} }}")
        return lines

    def to_dict(self) -> dict[str, Any]:
        return {"signals": self.signals, "before": self.before, "after": self.after,
                "named": [j.to_dict() for j in self.named], "corrections": [dict(c) for c in self.corrections],
                "rounds": [[j.to_dict() for j in r] for r in self.rounds],
                "experiment_lines": self.experiment_lines(), "parameter_values": self.parameter_values(),
                "refit": None if self.refit is None else {k: v for k, v in self.refit.items()},
                "seconds": self.seconds, "notes": list(self.notes), "local": self.local}


def _all_values(judged: Judged) -> dict[Key, FittedParameter]:
    """Every value of ``judged``'s fit (the ones named before it included), by key; a scanned value, declared
    fixed in the fit, from the judgement (:func:`~symbolic.workflow.effects.on_response.fixed_key`)."""
    if judged.fit is None:
        return dict(judged.values)
    return {**_all_values_of(judged.fit), **{k: v for k, v in judged.values.items() if fixed_key(k)}}


def _name(key: Key) -> str:
    return key[1] if key[0] == PARAMETER else f"[{key[0]}] {key[1]} {key[2]}"


def search_response(model: DynamicModel, estimation: Measurements, held_out: Measurements, *,
                    held_from: int = 0, effects: Sequence[ResponseEffect] | None = None, fix: Sequence[str] = (),
                    min_gain: float = MIN_HELD_OUT_GAIN, determined: Sequence[str] | None = None,
                    corrected: Mapping[str, float] | None = None) -> ResponseSearch:
    """Forward selection over the response catalogue (module docstring) for ``model`` — the patched model, at
    the values it holds — on ``estimation`` (fits) and ``held_out`` (judgement), both experiments with the
    machine's ``[controller]``. ``held_from``: the held-out data are ``held_out``'s samples from there on (the
    whole record given, simulated from its start, and compared on its held-out tail). ``determined``: the
    parameters the data determine (the diagnosis's own re-identification); default: IDIM-LS's on ``estimation``.
    ``corrected``: the model file's values of the parameters the equation error corrected (``model`` holds the
    corrections), for the effects' further starts (:meth:`ResponseEffect.restarts`)."""
    started = time.perf_counter()
    controller = getattr(estimation, "controller", None)
    signals = "position" if controller is None or controller.kind == "torque" else "both"
    source = str(estimation.source)
    base = {"estimation": simulation_errors(model, estimation, signals=signals),
            "validation": simulation_errors(model, held_out, signals=signals, start=held_from)}
    floor = 100 * MIN_FORCE_SHARE
    if all(e < floor for errors in base["validation"].values() for e in errors.values()):
        return ResponseSearch(signals, base, base, (), (), time.perf_counter() - started,
                              (f"not run: the held-out simulation error is below {floor:g} % of every signal's "
                               "spread (the simulation's and the treatment's own: nothing to explain)",))
    scope = Scope.of(model, estimation, fix, determined)
    if scope.skipped:
        return ResponseSearch(signals, base, base, (), (), time.perf_counter() - started, (f"not run: {scope.skipped}",),
                              {"skipped": scope.skipped, "accepted": False, "moved": []})
    refit, last = _refit(model, estimation, (held_out, held_from), base, signals, fix, min_gain, scope)
    accepted: dict[Key, float] = {} if last is None else {(PARAMETER, n, ""): p.value for n, p in last.parameters.items()}
    fitted: dict[str, FittedParameter] = {} if last is None else dict(last.parameters)  # every parameter's latest fit
    homes = {k: scope.home(k[1]) for k in accepted}
    current = base if last is None else {"estimation": last.errors, "validation": refit["held_out"]}
    fixed = set(fix) | {p.name for p in model.robot.parameters if p.fixed} | {k[1] for k in accepted}
    chosen = list(RESPONSE_EFFECTS.values()) if effects is None else list(effects)
    remaining = [c for e in chosen for c in e.candidates(model, estimation, fixed)]
    own_corrections = _own_corrections(model, corrected or {})
    named: list[Judged] = []
    rounds: list[tuple[Judged, ...]] = []
    notes: list[str] = ([f"local search: the data determine more than {MAX_REFIT} of the model's parameters, so the "
                         f"refit freed the {len(scope.refitted)} that act on one coordinate's force alone and each "
                         "candidate its own coordinate's (docs/workflow.md, \"Where it runs\")"]
                        if scope.local is not None else [])
    for round_number in range(1, MAX_ROUNDS + 1):
        if not remaining:
            break
        log.info("diagnose %s: response round %d, %d candidate(s)", model.name, round_number, len(remaining))
        now = _now(model, estimation, accepted, last, source, scope)

        def judge(c: ResponseCandidate) -> Judged:
            began = time.perf_counter()
            out = _judge(model, c, scope.split(accepted, homes, c.coordinate), estimation, (held_out, held_from),
                         current, signals, min_gain, source, now,
                         c.effect.restarts(c, own_corrections.get(c.coordinate, {})))
            log.info("diagnose %s: %s judged in %.1f s: %s", model.name, c.label(), time.perf_counter() - began,
                     out.verdict or "passes")
            return out

        judged = _judge_all(remaining, judge)
        rounds.append(judged)
        passing = [j for j in judged if j.verdict is None]
        if not passing:
            break
        best = max(passing, key=lambda j: (j.stacked_gain, j.gain))  # over every coordinate: scopes differ
        named.append(best)
        kept = {k: v for k, v in accepted.items() if fixed_key(k) or scope.local is not None}  # the fits return
        accepted = {**kept, **{k: v.value for k, v in _all_values(best).items()}}  # only the values they free
        homes.update({k: best.candidate.coordinate for k in _all_values(best) if k not in homes})
        fitted.update(best.fit.parameters if best.fit is not None else {})
        last = best.fit
        current = {"estimation": best.estimation, "validation": best.held_out}
        remaining = [c for c in remaining if (c.effect, c.coordinate, c.frees) != (best.candidate.effect,
                                                                                    best.candidate.coordinate,
                                                                                    best.candidate.frees)]
    named, dropped = _still_named(model, named, 1.0 / float(estimation.sample_period))
    notes += [f"{j.candidate.label()} was named at round {_round_of(j, rounds)} and is not any more with what was named "
              f"after it free in the same fit: {verdict}; its value is left at the model file's" for j, verdict in dropped]
    if named:
        left = {k[1] for j, _ in dropped for k in j.values if k[0] == PARAMETER}
        final = fitted if scope.local is not None else named[-1].fit.parameters
        final = {n: p for n, p in final.items() if n not in left}
    elif refit is not None and refit["accepted"] and refit["moved"]:
        final = dict(last.parameters)
    else:  # nothing the response supports: the patched model as IDIM-LS identified it
        final, current = {}, base
    values = {n: p.value for n, p in final.items()}
    return ResponseSearch(signals, base, current, tuple(rounds), tuple(named), time.perf_counter() - started,
                          tuple(notes), refit, values, tuple(_corrections(model, final)), scope.local is not None)


@dataclass(frozen=True)
class Scope:
    """Which values the refit frees and which of the accepted ones each candidate's fit frees with its own
    (:data:`MAX_REFIT`). ``local`` is ``None`` where every accepted value is freed with every candidate; else it
    maps each refitted parameter to the one coordinate whose force it acts on, and a candidate frees the accepted
    values of its own coordinate only, the others held at their values. ``skipped``: why the search does not run."""

    refitted: tuple[str, ...]
    local: dict[str, str] | None = None
    skipped: str | None = None

    @classmethod
    def of(cls, model: DynamicModel, estimation: Measurements, fix: Sequence[str],
           determined: Sequence[str] | None) -> Scope:
        """The scope of ``model`` on ``estimation``: ``determined`` the parameters the data determine (default:
        IDIM-LS's on ``estimation``)."""
        from symbolic.identify.model import identify_model

        if determined is None:
            try:
                idim = identify_model(model, estimation, fix=fix)
            except IdentificationError:
                return cls(())
            determined = [n for n, p in idim.parameters.items() if math.isfinite(p.sigma)]
        names = [n for n in determined if n not in fix]
        if len(names) <= MAX_REFIT:
            return cls(tuple(names))
        own = own_rows(model, names)
        local = {n: own[n] for n in names if n in own}
        if len(local) > MAX_LOCAL:
            return cls((), local, f"the model has {len(local)} parameters acting on one coordinate's force alone, "
                                  f"more than the {MAX_LOCAL} the local output-error refit frees (speed)")
        return cls(tuple(local), local)

    def home(self, name: str) -> str:
        """The coordinate a refitted parameter belongs to ("" where the search is not local)."""
        return "" if self.local is None else self.local.get(name, "")

    def split(self, accepted: Mapping[Key, float], homes: Mapping[Key, str], coordinate: str
              ) -> tuple[dict[Key, float], dict[Key, float]]:
        """(the accepted values a candidate on ``coordinate`` frees, those held at their values)."""
        if self.local is None:
            return dict(accepted), {}
        free = {k: v for k, v in accepted.items() if homes.get(k, "") == coordinate}
        return free, {k: v for k, v in accepted.items() if k not in free}


def _own_corrections(model: DynamicModel, corrected: Mapping[str, float]) -> dict[str, dict[str, tuple[float, float]]]:
    """``{coordinate: {name: (model file's value, corrected value)}}`` of the corrected values that act on one
    coordinate's force alone (:func:`own_rows`)."""
    out: dict[str, dict[str, tuple[float, float]]] = {}
    if not corrected:  # own_rows reads the regressor: not for nothing
        return out
    for name, coordinate in own_rows(model, list(corrected)).items():
        out.setdefault(coordinate, {})[name] = (float(corrected[name]), _value(model, name))
    return out


def _still_named(model: DynamicModel, named: Sequence[Judged], rate: float
                 ) -> tuple[list[Judged], list[tuple[Judged, str]]]:
    """The named candidates judged again by their effect's own check at the last fit's values, where every one
    named is free together (forward selection's first choice may be a local minimum's stand-in: a damping named
    before the stiffness that then returns to the file's value). Those that fail it are dropped, with the reason;
    the others carry the last fit's values (a parameter's change measured from the model file's value)."""
    if len(named) < 2:
        return list(named), []
    last = _all_values(named[-1])
    kept: list[Judged] = []
    dropped: list[tuple[Judged, str]] = []
    for j in named:
        if not all(k in last for k in j.values):
            kept.append(j)
            continue
        values = {k: dataclasses.replace(last[k], start=_value(model, k[1])) if k[0] == PARAMETER else last[k]
                  for k in j.values}
        roles = j.candidate.effect.roles_of(values, rate)
        verdict = j.candidate.effect.check(roles)
        if verdict is None:
            kept.append(dataclasses.replace(j, values=values, roles=roles))
        else:
            dropped.append((j, verdict))
    return kept, dropped


def _round_of(judged: Judged, rounds: Sequence[Sequence[Judged]]) -> int:
    return next((k + 1 for k, r in enumerate(rounds) if any(x is judged for x in r)), 0)


def _judge_all(candidates: Sequence[ResponseCandidate], judge: Callable[[ResponseCandidate], Judged]
               ) -> tuple[Judged, ...]:
    """``judge`` of every candidate, in order: half of them in a forked copy of this process where two cores are
    usable (:mod:`symbolic.workflow.forked`; each candidate is an output-error fit of seconds, independent of the
    others). The candidates' effects stay here (a user's effect class need not be picklable)."""
    if len(candidates) < 2 or forked.usable_processes() < 2:
        return tuple(judge(c) for c in candidates)

    def work(part: Sequence[ResponseCandidate]) -> tuple[list[Judged], None]:
        return [dataclasses.replace(judge(c), candidate=None) for c in part], None

    out, _ = forked.interleaved(work, candidates)
    return tuple(dataclasses.replace(j, candidate=c) for j, c in zip(out, candidates))


def _corrections(model: DynamicModel, fitted: Mapping[str, FittedParameter]) -> list[dict[str, Any]]:
    """The model's values the output error moves from the patched model's (IDIM-LS's) by 3σ and 10 % at
    least: corrections found through the response, each with what it is (a stiffness, a damping, ...)."""
    from symbolic.workflow.corrections import parameter_kind
    from symbolic.workflow.effects.correction import force_coordinate

    out = []
    for name, p in fitted.items():
        before = _value(model, name)
        if abs(p.value - before) > max(3 * p.sigma, 0.1 * abs(before)):
            out.append({"effect": "correction", "parameter": name, "kind": parameter_kind(model.robot, name),
                        "coordinate": force_coordinate(model.robot, name), "label": f"correction({name})", "value": p.value,
                        "sigma": p.sigma, "idim_ls": before,
                        "relative_change": (p.value - before) / before if before else None})
    return out


def _refit(model: DynamicModel, estimation: Measurements, held_out: tuple[Measurements, int],
           base: Mapping[str, Errors], signals: str, fix: Sequence[str], min_gain: float,
           scope: Scope) -> tuple[dict[str, Any] | None, OutputErrorFit | None]:
    """The model's parameters that IDIM-LS determines (``scope.refitted``), fitted by the output error from the
    values the model holds (DIDIM): every candidate is then fitted with them free (those of its coordinate, where
    the scope is local) and compared with this fit, so that what a candidate gains is its own. Accepted as a
    correction of the model's values when it lowers the held-out simulation error over all coordinates by the
    effect size; the values it moves beyond 3σ and 10 % are listed, and only when some move so are the refitted
    values written (a polish within 10 % leaves IDIM-LS's)."""
    start = {n: _value(model, n) for n in scope.refitted}
    if not start:
        return None, None
    log.info("diagnose %s: response refit of %d value(s) by the output error", model.name, len(start))
    try:
        fit = output_error(model, estimation, start=start, signals=signals, fix=fix, max_iterations=MAX_ITERATIONS,
                           tolerance=TOLERANCE)
        held = simulation_errors(model, held_out[0], fit, signals=signals, start=held_out[1])
    except (DataError, IdentificationError, SimulationError, np.linalg.LinAlgError):
        return None, None
    gain = simulation_gain(base["validation"], held, None)
    moved = [{"parameter": n, "idim_ls": p.start, "output_error": p.value, "sigma": p.sigma}
             for n, p in fit.parameters.items()
             if abs(p.value - p.start) > max(3 * p.sigma, 0.1 * abs(p.start))]
    log.info("diagnose %s: response refit done in %d iteration(s), held-out gain %.3g %%", model.name, fit.iterations,
             100 * gain)
    return {"gain": gain, "accepted": bool(gain >= min_gain), "moved": moved, "held_out": held,
            "estimation": fit.errors, "converged": fit.converged}, fit


def _layered(measurements: Measurements, values: Mapping[Key, float | None], source: str,
             kept: Mapping[Key, float] | None = None) -> Measurements:
    """``measurements`` with the layer's ``values``: free where the output error can fit them, declared fixed
    where it cannot (:func:`~symbolic.workflow.effects.on_response.fixed_key`: a drive's delay in the loop);
    ``kept``: values declared fixed (another coordinate's, in a local search)."""
    free = {k: v for k, v in values.items() if k[0] != PARAMETER and not fixed_key(k)}
    held = {k: v for k, v in values.items() if k[0] != PARAMETER and fixed_key(k)}
    held.update({k: v for k, v in (kept or {}).items() if k[0] != PARAMETER})
    out = signal_layer.freed(measurements, free, source) if free else measurements
    return signal_layer.fixed(out, held, source) if held else out


def _judge(model: DynamicModel, candidate: ResponseCandidate, scoped: tuple[Mapping[Key, float], Mapping[Key, float]],
           estimation: Measurements, held_out: tuple[Measurements, int], current: Mapping[str, Errors], signals: str,
           min_gain: float, source: str, now: tuple[np.ndarray, list[str]],
           restarts: Sequence[Mapping[Key, float]] = ()) -> Judged:
    """Fit ``candidate``'s values with the accepted ones ``scoped`` = (freed, kept) — the first free too, the
    second held at their values — and judge it on ``held_out``;
    ``now``: the current model's simulation of the estimation data (where the fit starts); ``restarts``: further
    starts (the one that lowers the estimation data's simulation error most is judged). A scanned candidate
    (:attr:`~symbolic.workflow.effects.on_response.ResponseEffect.scan`) is fitted at its values in turn, until two
    past the best, and the one that lowers the estimation data's simulation error most is judged."""
    accepted, kept = scoped
    held_values = {k[1]: v for k, v in kept.items() if k[0] == PARAMETER}
    scanned = candidate.effect.scan
    trials = [{k: value for k in candidate.frees} for value in scanned] if scanned else \
        [{k: _start(candidate, k, estimation, now) for k in candidate.frees if k not in accepted}, *restarts]
    best: tuple[float, Any, Any, dict[Key, float | None]] | None = None
    problem = "no value fitted"
    since = 0  # trials since the best: a scan stops two values past it (the error rises away from the delay)
    for trial in trials:
        if scanned and best is not None and since >= 2:
            break
        since += 1
        frees = {**dict(accepted), **trial}
        start = {k[1]: (v if v is not None else float(_value(model, k[1]))) for k, v in frees.items()
                 if k[0] == PARAMETER}
        try:
            est, held = _layered(estimation, frees, source, kept), _layered(held_out[0], frees, source, kept)
            fit = output_error(model, est, start=start, signals=signals, max_iterations=CANDIDATE_ITERATIONS,
                               tolerance=TOLERANCE, evaluate_if_nothing_free=bool(scanned), held=held_values)
        except (DataError, IdentificationError, SimulationError, np.linalg.LinAlgError) as error:
            problem = getattr(error, "problem", None) or str(error)
            continue
        # compared by the estimation errors (% of each signal), not the costs: each fit weighs its columns by its
        # own start's residual, so costs of different trials are on different scales
        score = simulation_gain(current["estimation"], fit.errors, candidate.coordinate or None)
        if best is None or score > best[0]:
            best, since = (score, fit, held, trial), 0
    if best is None:
        return Judged(candidate, {}, {}, {}, -math.inf, -math.inf, 0.0, {}, False, f"not fitted: {problem}")
    _, fit, held, trial = best
    try:
        after_held = simulation_errors(model, _at(held, fit, source), fit, signals=signals, start=held_out[1])
    except (DataError, IdentificationError, SimulationError, np.linalg.LinAlgError) as error:
        problem = getattr(error, "problem", None) or str(error)
        return Judged(candidate, {}, {}, {}, -math.inf, -math.inf, 0.0, {}, False, f"not fitted: {problem}")
    values = {k: v for k, v in _all_values_of(fit).items() if k in candidate.frees}
    if scanned:  # held fixed in the fit: its value is the trial's, without a σ (module docstring of on_response)
        values = {k: FittedParameter(_name(k), float(v), 0.0, 0.0, 0.0, None) for k, v in trial.items()}
    gain = simulation_gain(current["validation"], after_held, candidate.coordinate or None)
    stacked = simulation_gain(current["validation"], after_held, None)
    # the Jacobian's σ assume a white residual; a simulation error is coloured (a slow drift spans many samples):
    # σ × √τ_int, as the equation-error search corrects its own (statistics.autocorrelation_time)
    colour = math.sqrt(pooled_autocorrelation_time(fit.residual)) if fit.residual is not None else 1.0
    sigmas = math.inf if scanned else \
        min((abs(v.value - null) / (v.sigma * colour) if v.sigma > 0 else math.inf)
            for (k, v), null in zip(sorted(values.items(), key=lambda kv: candidate.frees.index(kv[0])),
                                    candidate.null))
    roles = candidate.effect.roles_of(values, 1.0 / float(estimation.sample_period))
    verdict = candidate.effect.check(roles)
    if verdict is None and not gain >= min_gain:
        verdict = (f"removes {100 * gain:.3g} % of the held-out simulation error's power on its coordinate "
                   f"(the effect size is {100 * min_gain:.3g} %)")
    if verdict is None and (size := _removed(current["validation"], after_held, candidate.coordinate or None)) < \
            100 * MIN_FORCE_SHARE:
        verdict = (f"removes {size:.2g} % of the signals' spread from the held-out simulation error (at least "
                   f"{100 * MIN_FORCE_SHARE:g} %: below, the error is the simulation's and the treatment's own)")
    if verdict is None and not stacked > 0:
        verdict = f"worsens the held-out simulation error over all coordinates ({100 * stacked:.3g} %)"
    if verdict is None and not sigmas >= MIN_SIGMAS:
        verdict = f"its value is {sigmas:.3g} σ from nothing missing (at least {MIN_SIGMAS:g} needed)"
    return Judged(candidate, values, fit.errors, after_held, gain, stacked, sigmas, roles, fit.converged, verdict, fit)


def _now(model: DynamicModel, estimation: Measurements, accepted: Mapping[Key, float],
         last: OutputErrorFit | None, source: str, scope: Scope) -> tuple[np.ndarray, list[str]]:
    """The current model (``last`` fit's values; every accepted value, where the scope is local) simulated on
    the estimation data: (y, the model's coordinates)."""
    if scope.local is not None:
        held = {k[1]: float(v) for k, v in accepted.items() if k[0] == PARAMETER}
        y, _, _ = simulated(model, _layered(estimation, {}, source, accepted), held=held)
    else:
        y, _, _ = simulated(model, _layered(estimation, accepted, source), last)
    return y, list(model.robot.generalized_coordinates)


def _start(candidate: ResponseCandidate, key: Key, estimation: Measurements,
           now: tuple[np.ndarray, list[str]]) -> float | None:
    """The effect's start for ``key`` (:meth:`ResponseEffect.start`) from the current simulation and the log."""
    table, signal, _ = key
    if table == PARAMETER or not signal.startswith("tau_"):
        return None
    y, names = now
    coordinate = signal[len("tau_"):]
    n, j = len(names), names.index(coordinate)
    layer = estimation.signal_layer
    logged = layer.logged[signal] if signal in layer.logged else estimation.tau[:, estimation.coordinates.index(coordinate)]
    limit = signal_layer.delay_limit(estimation.samples)
    return candidate.effect.start(key, y[:, 3 * n + j], np.asarray(logged, float), limit)


def _all_values_of(fit: OutputErrorFit) -> dict[Key, FittedParameter]:
    """The fit's parameters and signal values (named ``[table] signal field``) by key."""
    out: dict[Key, FittedParameter] = {(PARAMETER, n, ""): p for n, p in fit.parameters.items()}
    for name, p in fit.signal_values.items():
        table, rest = name[1:].split("] ", 1)
        signal, value = rest.split(" ")
        out[(table, signal, value)] = p
    return out


def _at(held: Measurements, fit: OutputErrorFit, source: str) -> Measurements:
    """``held`` with its free layer values at the fit's (the loop's start), so the held-out simulation's
    initial state and inputs are those of the fitted values."""
    layer = held.signal_layer
    if not layer.free:
        return held
    values = {k: v.value for k, v in _all_values_of(fit).items() if k[0] != PARAMETER}
    return signal_layer.reapply(held, layer.with_values(values, source), source)


def _value(model: DynamicModel, name: str) -> float:
    return float(next(v for s, v in model.parameters.items() if s.name == name))


def _pairs(before: Errors, after: Errors, coordinate: str | None) -> list[tuple[float, float]]:
    """(e_before, e_after) of each signal of ``coordinate`` (all coordinates: ``None``) compared in both."""
    return [(before[s][c], after[s][c]) for s in before for c in before[s]
            if (coordinate is None or c == coordinate) and c in after.get(s, {})]


def _removed(before: Errors, after: Errors, coordinate: str | None) -> float:
    """√ of the mean over the signals of ``coordinate`` (all: ``None``) of e_before² − e_after², in % of each
    signal's spread: what the candidate removes from the error (statistics.MIN_FORCE_SHARE)."""
    drops = [b ** 2 - a ** 2 for b, a in _pairs(before, after, coordinate)]
    return math.sqrt(max(float(np.mean(drops)), 0.0)) if drops else 0.0


def simulation_gain(before: Errors, after: Errors, coordinate: str | None) -> float:
    """1 − the mean of (e_after/e_before)² over the signals of ``coordinate`` (all coordinates: ``None``)."""
    ratios = [(a / b) ** 2 for b, a in _pairs(before, after, coordinate) if b > 0]
    return 1.0 - float(np.mean(ratios)) if ratios else -math.inf
