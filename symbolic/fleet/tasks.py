"""One log's work, as a Dask worker runs it: :func:`run_log` (docs/fleet.md, "Tasks").

Input: a :class:`Job` (plain data: the robot's model file text and path, the log, the task). Output: a
JSON-ready dict, the computed part of a results row: the parameters with σ, the gap, the named effects,
the residual's bursts and its profile (which the campaign judges against the siblings' logs:
:mod:`symbolic.fleet.siblings`), the run time; or the error of a log that could not be processed (``status = "error"``),
never an exception, so that one bad log never stops a campaign.

It calls the package's library functions — :func:`symbolic.identify.model.identify_model`,
:func:`symbolic.workflow.diagnose`, :func:`symbolic.simulation.simulate` — and keeps each derived model
in the worker process (:func:`model_for`, keyed by the description's digest), so a worker derives a model
once and reuses it, with its compiled C, for every log of that model.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import os
import time
import traceback
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from symbolic.cache import stamp
from symbolic.data import DataError, Experiment, load
from symbolic.data.treatment import settings_for, states
from symbolic.derivation.dynamics import DynamicModel, derive
from symbolic.description.robot import digest
from symbolic.errors import ModelWarning, SymbolicError, listing, one_line
from symbolic.fleet.campaign import NOT_READ, Task, read_model
from symbolic.fleet.events import examine

MODELS_KEPT = 8
"""Derived models a worker keeps (least recently used dropped first): a campaign rarely mixes more models."""

_models: OrderedDict[str, DynamicModel] = OrderedDict()


@dataclass(frozen=True)
class Job:
    """What a worker needs for one log (picklable: paths, texts and the frozen task)."""

    key: str
    robot: str
    log: str
    path: str
    model_source: str
    model_text: str
    model_digest: str
    task: Task
    experiment: str | None = None
    time_column: str | None = None
    chain: tuple[str | None, str | None] = (None, None)


def model_for(job: Job) -> DynamicModel:
    """The derived model of ``job``, derived once per worker process (and its products kept with it)."""
    model = _models.get(job.model_digest)
    if model is None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            robot = read_model(job.model_source, job.model_text, job.chain)
        if digest(robot) != job.model_digest:  # the client and the worker read the model differently
            raise DataError(job.model_source, "model", "the worker's symbolic reads this model differently from "
                                                       "the client's: run the same symbolic version on both")
        model = derive(robot)
        _models[job.model_digest] = model
        while len(_models) > MODELS_KEPT:
            _models.popitem(last=False)
    _models.move_to_end(job.model_digest)
    return model


def run_log(job: Job) -> dict[str, Any]:
    """The computed part of ``job``'s results row (module docstring); never raises for a log's problem.

    ``cacheable`` says whether the outcome is a function of the inputs alone (a result, or the error of a
    file's content) and may be kept in the campaign's cache; an internal error is not.
    """
    started = time.perf_counter()
    out: dict[str, Any] = {"key": job.key, "stamp": stamp(), "status": "ok", "error": None, "cacheable": True}
    if os.path.islink(job.path):  # made a link since the campaign file was read: not read (fleet.campaign.linked)
        out.update(status="error", cacheable=False, error=f"{job.log}: is a symbolic link: {NOT_READ}")
        return {**out, "seconds": time.perf_counter() - started}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            model = model_for(job)
            experiment = load(job.path, model.robot.generalized_coordinates if job.task.kind != "simulate" else None,
                              model=model.robot, experiment=job.experiment)
            out["time"] = _column_time(experiment, job) if job.time_column else None
            out.update(_RUNNERS[job.task.kind](model, experiment, job.task))
    except SymbolicError as error:
        out.update(status="error", error=one_line(_located(error, job)))
    except MemoryError:
        out.update(status="error", error="out of memory on the worker", cacheable=False)
    except Exception as error:  # noqa: BLE001 - a bug of symbolic: a row, not a stopped campaign; not cached
        last = traceback.extract_tb(error.__traceback__)[-1]
        out.update(status="error", cacheable=False,
                   error=one_line(f"internal error (a bug of symbolic, please report it): {type(error).__name__}: "
                                  f"{error} at {Path(last.filename).name}:{last.lineno}"))
    out["seconds"] = time.perf_counter() - started
    return out


def _located(error: SymbolicError, job: Job) -> str:
    """The error's message naming the log as the results do (its path relative to the campaign file, not to
    the folder the command ran in), preceded by it when the message names no file itself."""
    text = str(error)
    if error.source is None:
        return f"{job.log}: {text}"
    return job.log + text[len(job.path):] if text.startswith(f"{job.path}:") else text


def _column_time(experiment: Experiment, job: Job) -> str:
    """The log's time from its column of UNIX seconds (the first sample's), as ISO 8601 UTC."""
    column = experiment.extras.get(job.time_column)
    if column is None:
        raise DataError(job.path, f"column '{job.time_column}'", "missing: the campaign reads the log's time from it "
                                                                 f"(UNIX seconds; columns: {listing(experiment.columns())})")
    seconds = float(np.asarray(column, float)[0])
    try:
        return dt.datetime.fromtimestamp(seconds, dt.timezone.utc).isoformat()
    except (OverflowError, OSError, ValueError):
        raise DataError(job.path, f"column '{job.time_column}'", f"{seconds!r} is not a UNIX time in seconds") from None


def _identify(model: DynamicModel, experiment: Experiment, task: Task) -> dict[str, Any]:
    """IDIM-LS of the model's parameters on the log, the events of its own residual, and, when there are
    events, the parameters again without them (:func:`excluded`): a collision says nothing about friction."""
    from symbolic.identify.model import base_regressor, identify_model
    from symbolic.identify.pipeline import cross_validate

    options = dict(settings=task.identification, method=task.option("method", "wls"),
                   consistent=task.option("consistent", False), fix=task.option("fix", ()))
    result = identify_model(model, experiment, **options)
    # the residual of the log's own model at every sample (no decimation) for the events
    every = dataclasses.replace(settings_for(experiment, task.identification), decimation=1)
    full = cross_validate(result.identification, experiment, base_regressor(model, base=result.base), every)
    residual = full.observation.tau - full.predicted
    treated = states(experiment, every)
    motion = np.hstack([full.observation.processing.reduce(treated.q), full.observation.processing.reduce(treated.qd)])
    found, shape = examine(full.observation.t, residual, full.observation.coordinates, task.events, motion)
    events = [e for e in found if not e["recurs"]]  # the log's own verdict; the campaign's is the siblings' (.siblings)
    if events:
        result = identify_model(model, experiment, exclude=excluded(events, result.identification.processing,
                                                                      task.events.window), **options)
    return {"gap": result.identification.relative_error, "parameters": _parameters(result), "bursts": found,
            "profile": shape, "samples": experiment.samples, "duration": float(experiment.t[-1] - experiment.t[0])}


def excluded(events: list[dict[str, Any]], processing, window: float) -> list[tuple[float, float]]:
    """The intervals left out of the second fit: each event widened by half a window and by the decimation
    filter's reach, 4/f_c with f_c its cut-off (0.8 of the decimated Nyquist frequency), over which a burst in τ
    still moves the decimated samples."""
    reach = 4.0 / (0.8 * processing.rate / (2.0 * processing.decimation)) if processing.decimation > 1 else 0.0
    margin = window / 2 + reach
    return [(e["start"] - margin, e["end"] + margin) for e in events]


def _parameters(result) -> list[dict[str, Any]]:
    """Each identified base parameter once: named as the model-file parameter it determines, else by its own name."""
    by_base = {p.source.removeprefix("base parameter "): p for p in result.parameters.values()}
    out = []
    for estimate in result.identification.parameters:
        if estimate.fixed:
            continue
        own = by_base.get(estimate.name)
        name, value, sigma = (own.name, own.value, own.sigma) if own else (estimate.name, estimate.value, estimate.sigma)
        out.append({"name": name, "value": float(value), "sigma": float(sigma), "base": estimate.name,
                    "at_bound": estimate.bound})
    return out


def _diagnose(model: DynamicModel, experiment: Experiment, task: Task) -> dict[str, Any]:
    """:func:`_identify`, then the discrepancy workflow: the effects the model misses and the gap before and after."""
    from symbolic.workflow import SearchSettings, diagnose
    from symbolic.workflow.effects import select

    out = _identify(model, experiment, task)
    names = task.option("effects")
    # one process per log: a campaign spreads its logs over the cores, also one at a time (--workers 0)
    result = diagnose(model, experiment, settings=task.identification, effects=select(names) if names else None,
                      simulate=task.option("simulate", False) or None, fix=task.option("fix", ()), figures=False,
                      search=SearchSettings(processes=1))
    out.update(gap_before=result.before.gap["validation"], gap_after=result.after.gap["validation"],
               effects=[{"effect": f.label(), "coordinate": f.coordinate,
                         "parameters": {k: v for k, v in f.parameters.items()}} for f in result.found])
    return out


def _simulate(model: DynamicModel, experiment: Experiment, task: Task) -> dict[str, Any]:
    """The model (nominal values) in the log's controller loop: relative errors, and the events of τ_meas − τ_sim."""
    from symbolic.simulation import simulate

    options = {k: task.option(k) for k in ("method", "substeps", "friction_velocity") if task.option(k) is not None}
    run = simulate(model, experiment, **options)
    errors = run.compare().relative_errors()
    names = list(run.simulated.coordinates)
    order = [names.index(c) for c in experiment.coordinates]
    residual = np.asarray(experiment.tau, float) - np.asarray(run.simulated.tau, float)[:, order]
    norm = float(np.linalg.norm(experiment.tau))
    q = np.asarray(experiment.q, float)
    motion = np.hstack([q, np.gradient(q, np.asarray(experiment.t, float), axis=0)])
    found, shape = examine(experiment.t, residual, experiment.coordinates, task.events, motion)
    return {"gap": 100.0 * float(np.linalg.norm(residual)) / norm if norm > 0 else float("nan"),
            "simulation": {c: dict(e) for c, e in errors.items()}, "parameters": [], "bursts": found,
            "profile": shape, "samples": experiment.samples, "duration": float(experiment.t[-1] - experiment.t[0])}


_RUNNERS = {"identify": _identify, "diagnose": _diagnose, "simulate": _simulate}


def run_batch(jobs: list[Job]) -> list[dict[str, Any]]:
    """:func:`run_log` of each job in turn: one Dask task for several short logs."""
    return [run_log(job) for job in jobs]
