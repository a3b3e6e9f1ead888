"""Data sets as the workflow sees them: measurements through the IDIM-LS treatment, and the held-out split.

Every signal the workflow compares — measured τ, the model's regressor columns, a candidate effect's
columns — goes through the same treatment as in identification (:mod:`symbolic.identify.processing`):
positions low-passed, differentiated, the border dropped and everything decimated in parallel. A
candidate's column is therefore computed from the filtered states at every sample and then reduced
exactly like the regressor, so that adding it to the model and re-identifying gives the same numbers.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from symbolic.data import DataError, Measurements, load
from symbolic.data.measurements import check_forces
from symbolic.data.treatment import Settings, States, states
from symbolic.description.robot import Robot

HOLDOUT_FRACTION = 0.2
"""Without a validation data set, the last fifth of the estimation data (in time) is held out."""


@dataclass(frozen=True, eq=False)
class DataSet:
    """One data set after the IDIM-LS treatment.

    Attributes
    ----------
    role
        ``"estimation"`` or ``"validation"``.
    measurements
        The measurements it was made from.
    states
        Filtered q, q̇, q̈ at every sample (before the border is dropped) and the treatment.
    t, tau
        Time and measured generalized forces of the kept (decimated) samples; ``tau`` is ``samples × N``.
    q, qd, qdd
        The filtered states reduced like τ (for plots and localisation).
    record, start
        When these samples continue a record (the held-out last fifth of the estimation data): that
        whole record treated as one, and the index of this set's first sample in it. An effect with
        memory (a filter) runs through the record, so that its state at this set's first sample is the
        one the motion before left, not a guess; ``None`` and 0 otherwise.
    """

    role: str
    measurements: Measurements = field(repr=False)
    states: States = field(repr=False)
    t: np.ndarray = field(repr=False)
    tau: np.ndarray = field(repr=False)
    q: np.ndarray = field(repr=False)
    qd: np.ndarray = field(repr=False)
    qdd: np.ndarray = field(repr=False)
    record: DataSet | None = field(default=None, repr=False)
    start: int = 0

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.measurements.coordinates

    @property
    def samples(self) -> int:
        """Kept samples per coordinate."""
        return len(self.t)

    def reduce(self, x: np.ndarray) -> np.ndarray:
        """A signal sampled like the measurements (``samples × …``), border dropped and decimated."""
        return self.states.processing.reduce(x)

    def stack(self, x: np.ndarray) -> np.ndarray:
        """Reduced ``samples × N [× k]`` arranged as the stacked system: coordinate by coordinate."""
        x = np.asarray(x, dtype=float)
        return x.transpose(1, 0, *range(2, x.ndim)).reshape(x.shape[0] * x.shape[1], *x.shape[2:])  # 0 columns too


def position_steps(q: np.ndarray) -> tuple[float, ...]:
    """Per column of the logged positions ``q`` (``samples × N``), its quantum: the smallest change between two
    samples (an encoder moves by whole counts, and a slow axis by one count at a time somewhere in a log), or 0
    where none is above 1e-12 of the column's range (a constant column)."""
    out = []
    for column in np.asarray(q, dtype=float).T:
        change = np.abs(np.diff(column))
        moved = change[change > 1e-12 * float(np.ptp(column))] if column.size > 1 else change[:0]
        out.append(float(moved.min()) if moved.size else 0.0)
    return tuple(out)


def treat(measurements: Measurements, role: str, settings: Settings | None = None) -> DataSet:
    """The IDIM-LS treatment of ``measurements`` (steps 1–2 at every sample; τ and states reduced)."""
    s = states(measurements, settings)
    p = s.processing
    return DataSet(role, measurements, s, p.reduce_times(measurements.t), p.reduce(p.forces(measurements.tau)),
                   p.reduce(s.q), p.reduce(s.qd), p.reduce(s.qdd))


def with_held_force(data: DataSet) -> DataSet:
    """``data`` treated as if its force were declared a held command (``held_force``): the same filtered
    states, τ as the mean over each sample (:meth:`~symbolic.data.treatment.Processing.forces`)."""
    p = dataclasses.replace(data.states.processing, held_force=True)
    record = None if data.record is None else with_held_force(data.record)
    return dataclasses.replace(data, states=dataclasses.replace(data.states, processing=p),
                               tau=p.reduce(p.forces(data.measurements.tau)), record=record)


def time_slice(measurements: Measurements, start: int, stop: int) -> Measurements:
    """Samples ``start:stop`` of ``measurements`` (every per-sample signal cut alike; an experiment keeps
    its settings and controller: :meth:`~symbolic.data.measurements.Measurements.slice`)."""
    return measurements.slice(start, stop)


def split(measurements: Measurements, fraction: float = HOLDOUT_FRACTION) -> tuple[Measurements, Measurements]:
    """The first ``1 − fraction`` of the samples and the last ``fraction`` (contiguous blocks in time)."""
    cut = int(round(measurements.samples * (1.0 - fraction)))
    return time_slice(measurements, 0, cut), time_slice(measurements, cut, measurements.samples)


def held_out_split(measurements: Measurements, how: str = "") -> tuple[Measurements, Measurements, str]:
    """(the first part, the last :data:`HOLDOUT_FRACTION` in time, a sentence saying where it is and ``how`` it is
    used) of a record without validation data; refused where either part would have fewer than 2 samples."""
    first, last = split(measurements)
    if min(first.samples, last.samples) < 2:
        raise DataError(str(measurements.source), "samples",
                        f"{measurements.samples} samples are too few to hold out the last "
                        f"{100 * HOLDOUT_FRACTION:g} % and estimate on the rest; give a validation data set (--validate)")
    return first, last, (f"the last {100 * HOLDOUT_FRACTION:g} % of the data in time "
                         f"({last.t[0]:.6g} s to {last.t[-1]:.6g} s){how}, not used for estimation")


def load_sets(
    model: Robot | tuple[str, ...],
    data: str | Path | Measurements,
    experiment: str | Path | None = None,
    validation: str | Path | Measurements | None = None,
    settings: Settings | None = None,
) -> tuple[DataSet, DataSet, str]:
    """Estimation and held-out data sets, and a sentence saying where the held-out data come from.

    ``data`` and ``validation`` are loaded for ``model`` (a validated robot, or just its coordinates) by
    :func:`symbolic.data.load`, as in ``symbolic identify``; without a validation set (given, or the
    experiment's own) the last :data:`HOLDOUT_FRACTION` of ``data`` in time is held out and the rest is
    the estimation set.
    """
    robot = model if isinstance(model, Robot) else None
    coordinates = tuple(robot.generalized_coordinates if robot is not None else model)
    measurements = load(data, coordinates, model=robot, experiment=experiment, validation=validation)
    for loaded in (measurements, measurements.validation):
        if loaded is not None:
            check_forces(loaded)
    if measurements.validation is None:
        first, last, held_out = held_out_split(measurements)
        start = first.samples
        try:
            tail = dataclasses.replace(treat(last, "validation", settings), record=treat(measurements, "record", settings),
                                       start=start)
            return treat(first, "estimation", settings), tail, held_out
        except DataError as error:
            raise DataError(str(measurements.source), "samples",
                            f"too few samples to hold out the last {100 * HOLDOUT_FRACTION:g} % ({error.problem}); "
                            "give a validation data set (--validate)") from None
    other = measurements.validation
    held_out = f"the validation data {other.source}"
    return treat(measurements, "estimation", settings), treat(other, "validation", settings), held_out
