"""The equation error's findings judged again once the response has named what the machine hides.

The equation-error search runs first and sees a force logged late, or a drive's gain, only through what its
catalogue can fit: on the two-link arm whose joint 2 logs its force 3 samples late, it names an ``inertia`` on
joint 2 (or, without that effect, an ``offset``) — a stand-in — and the response search then names the
``delay`` with the stand-in still in the model, which biases the delay too. Forward selection never looks back;
this does, on the response's own terms (docs/workflow.md, "Judged on the response"): each equation-error finding
is removed from the patched model (its written values set to what "nothing missing" means,
:meth:`~symbolic.workflow.effects.base.Effect.null_values`), the response's last fit is refitted without it
(every value it freed, the named signal-layer values included, by the output error on the estimation data), and
the finding stays only where it still removes the effect size (10 %) of the **held-out** simulation error's power
on its coordinate — and at least :data:`~symbolic.workflow.statistics.MIN_FORCE_SHARE` of the signals' spread.
The weakest that fails is dropped first and the others judged again without it, until every one left passes.

Only findings of a search whose response named something are judged so: without one, nothing has changed
since the equation error judged them on its own held-out data. A finding whose null values do not load (a
Stribeck law without its velocity) or whose refit fails is kept, with a note.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from symbolic.data import DataError, Measurements
from symbolic.derivation.dynamics import derive
from symbolic.description.modelfile import loads, with_parameter_values
from symbolic.errors import IdentificationError, ModelError, SimulationError
from symbolic.identify.output_error import OutputErrorFit, output_error, simulation_errors
from symbolic.workflow.effects.on_response import fixed_key
from symbolic.workflow.response import (MAX_ITERATIONS, TOLERANCE, Errors, ResponseSearch, _all_values_of, _at,
                                        _layered, _removed, simulation_gain)
from symbolic.workflow.statistics import MIN_FORCE_SHARE, MIN_HELD_OUT_GAIN

log = logging.getLogger("symbolic")


@dataclass(frozen=True)
class Finding:
    """An equation-error finding as patched: its label, its coordinate and the values it wrote with their null
    values (the effect's :meth:`~symbolic.workflow.effects.base.Effect.null_values`)."""

    label: str
    coordinate: str
    null: dict[str, float]


@dataclass(frozen=True)
class Review:
    """What the review keeps: the indices of the findings dropped (in the order given), a note for each
    dropped or unjudged one, and the response search as it stands without the dropped (its last fit's values
    and held-out errors replaced by the refit's)."""

    dropped: tuple[int, ...]
    notes: tuple[str, ...]
    response: ResponseSearch


def review(text: str, source: str, findings: Sequence[Finding], response: ResponseSearch, estimation: Measurements,
           held_out: Measurements, held_from: int, min_gain: float = MIN_HELD_OUT_GAIN) -> Review:
    """Judge ``findings`` (the equation error's, patched into ``text``) again with the response's named values
    (module docstring); ``held_out``'s samples from ``held_from`` on are the held-out data."""
    if not response.named or not findings or response.named[-1].fit is None:
        return Review((), (), response)
    if response.local:  # its last fit frees one coordinate's values: no refit of the whole to judge them by
        return Review((), ("the equation error's findings are not judged again with the response's named values: the "
                           "response search was local (docs/workflow.md, \"Where it runs\")",), response)
    last = response.named[-1].fit
    current = response.after["validation"]
    accepted = response.layer_values()
    dropped: list[int] = []
    notes: list[str] = []
    unjudged: set[int] = set()
    nulls: dict[str, float] = {}
    while True:
        trials = []
        for i, finding in enumerate(findings):
            if i in dropped or i in unjudged:
                continue
            if not finding.null:
                unjudged.add(i)
                notes.append(f"{finding.label} was not judged again on the response (its effect has no values at "
                             "which it is absent alone); it is kept")
                continue
            tried = _without(text, source, {**nulls, **finding.null}, last, accepted, estimation, held_out,
                             held_from, response.signals)
            if isinstance(tried, str):
                unjudged.add(i)
                notes.append(f"{finding.label} was not judged again on the response ({tried}); it is kept")
                continue
            fit, held = tried
            gain = simulation_gain(held, current, finding.coordinate)
            size = _removed(held, current, finding.coordinate)
            log.info("stand-ins: %s removes %.3g %% of the held-out simulation error's power (%.2g %% of the spread)",
                     finding.label, 100 * gain, size)
            if not (gain >= min_gain and size >= 100 * MIN_FORCE_SHARE):
                trials.append((gain, i, fit, held, size))
        if not trials:
            break
        gain, i, fit, held, size = min(trials, key=lambda t: t[0])
        finding = findings[i]
        names = ", ".join(j.candidate.label() for j in response.named)
        what = (f"removes only {100 * gain:.3g} % of the held-out simulation error's power on {finding.coordinate} "
                f"({size:.2g} % of the signals' spread; the effect size is {100 * min_gain:.3g} %)" if gain > 0 else
                f"raises the held-out simulation error's power on {finding.coordinate} by {-100 * gain:.3g} %")
        notes.append(f"{finding.label} was named by the equation error and is not any more with {names} named on the "
                     f"response: refitted with those, it {what} — a stand-in for them, not written")
        dropped.append(i)
        nulls.update(finding.null)
        last, current = fit, held
        response = _refitted(response, fit, held, 1.0 / float(estimation.sample_period))
        accepted = response.layer_values()
    return Review(tuple(dropped), tuple(notes), response)


def _without(text: str, source: str, null: Mapping[str, float], last: OutputErrorFit, accepted: Mapping,
             estimation: Measurements, held_out: Measurements, held_from: int, signals: str
             ) -> tuple[OutputErrorFit, Errors] | str:
    """The response's last fit refitted on the patched model with ``null`` written: (fit, held-out errors), or
    why it could not be."""
    try:
        model = derive(loads(with_parameter_values(text, null, source), source))
    except ModelError as error:
        return f"its values at nothing missing do not load: {error}"
    start = {n: p.value for n, p in last.parameters.items() if n not in null}
    try:
        est, held = _layered(estimation, accepted, source), _layered(held_out, accepted, source)
        fit = output_error(model, est, start=start, signals=signals, max_iterations=MAX_ITERATIONS,
                           tolerance=TOLERANCE, evaluate_if_nothing_free=True)
        errors = simulation_errors(model, _at(held, fit, source), fit, signals=signals, start=held_from)
    except (DataError, IdentificationError, SimulationError, ArithmeticError) as error:
        return f"the refit without it failed: {getattr(error, 'problem', None) or error}"
    if not all(math.isfinite(e) for signal in errors.values() for e in signal.values()):
        return "the refit without it does not simulate"
    return fit, errors


def _refitted(response: ResponseSearch, fit: OutputErrorFit, held: Errors, rate: float) -> ResponseSearch:
    """``response`` with its named values, model-file values and held-out errors from ``fit`` (the refit
    without a dropped stand-in); a scanned value (held fixed) keeps its own."""
    refit = _all_values_of(fit)
    named = []
    for j in response.named:
        values = {k: (v if fixed_key(k) or k not in refit else refit[k]) for k, v in j.values.items()}
        roles = j.candidate.effect.roles_of(values, rate)
        named.append(replace(j, values=values, roles=roles, held_out=held, fit=fit))
    values = {n: p.value for n, p in fit.parameters.items()} if response.values else {}
    return replace(response, named=tuple(named), after={**response.after, "estimation": fit.errors, "validation": held},
                   values=values)

