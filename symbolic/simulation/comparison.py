"""Where simulation and measurement disagree: per coordinate and signal, relative error, RMS, worst window.

Input: a measured log and the simulated one at its time stamps. The measured velocity and acceleration
come from the data treatment of identification (:mod:`symbolic.data.treatment`, the same
``[identification]`` keys), the simulated ones are the integrator's state, unfiltered; positions and
forces are compared as they are, the treatment's border left out. Output: a :class:`Comparison` holding
per coordinate and signal the relative error ``100·‖x_meas − x_sim‖/‖x_meas‖`` (the EMPS publication's
definition), the RMS of the difference and the worst ``window`` (default 1 s). Defaults and reasons:
docs/simulation.md, "Comparison".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symbolic.data import DataError, Measurements
from symbolic.data.times import time_windows
from symbolic.data.treatment import Settings, filtered_motion, settings_for

SIGNALS = ("position", "velocity", "acceleration", "force")

@dataclass(frozen=True)
class Treatment:
    """The filtering applied to the measured positions (``cutoff`` None: none) and the border left out."""

    cutoff: float | None
    order: int
    border: int
    note: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """Plain values, for JSON."""
        return {"cutoff": self.cutoff, "order": self.order, "border": self.border}


def treatment(measurements: Measurements, settings: Settings | None = None) -> Treatment:
    """The treatment for ``measurements``: identification's rules and choices (``settings``, else the
    experiment's ``[identification]``: :func:`symbolic.data.treatment.settings_for`). Where identification
    would refuse short data, the comparison still runs: positions unfiltered when there are at most
    3·order samples, no border when fewer than two samples would be left."""
    chosen = settings_for(measurements, settings)
    source = str(measurements.source)
    rate = measurements.rate
    _, cutoff, order, border = chosen.rules(rate)
    note = None
    if cutoff is not None and not cutoff < rate / 2:
        raise DataError(source, "[identification] cutoff", f"{cutoff:g} Hz is not below the Nyquist frequency "
                                                           f"{rate / 2:g} Hz of the data")
    if cutoff is not None and measurements.samples <= 3 * order:
        note = f"{measurements.samples} samples are too few for the low-pass: positions not filtered"
        cutoff = None
        if chosen.border is None:
            border = (2, 2)
    width = max(border)
    if measurements.samples - 2 * width < 2:
        note, width = f"{measurements.samples} samples: no border left out", 0
    return Treatment(cutoff, order, width, note)


@dataclass(frozen=True, eq=False)
class Motion:
    """Measured velocity and acceleration (samples × N, the data's coordinates) and how they were obtained."""

    qd: np.ndarray
    qdd: np.ndarray
    treatment: Treatment


def measured_motion(measurements: Measurements) -> Motion:
    """q̇ and q̈ of the data, filtered and differenced as for identification (docs/simulation.md, "Comparison")."""
    how = treatment(measurements)
    _, qd, qdd = filtered_motion(measurements, how.cutoff, how.order)
    return Motion(qd, qdd, how)


@dataclass(frozen=True)
class Statistic:
    """The disagreement of one signal of one coordinate.

    Attributes
    ----------
    relative
        ``100·‖x_meas − x_sim‖/‖x_meas‖`` in %; ``None`` when the measured signal is zero.
    rms
        RMS of the error, in the signal's unit.
    worst
        ``(start, stop, rms)``: the window (seconds) with the largest RMS error, and that RMS.
    """

    relative: float | None
    rms: float
    worst: tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class Comparison:
    """Measured against simulated, per coordinate (the data's) and signal (:data:`SIGNALS`).

    Attributes
    ----------
    coordinates
        The compared coordinates.
    statistics
        ``{coordinate: {signal: Statistic}}``.
    t
        Time stamps of all samples.
    measured, simulated
        ``{signal: samples × N}`` (all samples; statistics use ``kept``).
    kept
        ``slice`` of the samples the statistics use (the border left out).
    treatment
        The measured data's filtering.
    window
        Length of the worst window, seconds.
    """

    coordinates: tuple[str, ...]
    statistics: Mapping[str, Mapping[str, Statistic]]
    t: np.ndarray = field(repr=False)
    measured: Mapping[str, np.ndarray] = field(repr=False)
    simulated: Mapping[str, np.ndarray] = field(repr=False)
    kept: slice
    treatment: Treatment
    window: float

    def relative_errors(self) -> dict[str, dict[str, float | None]]:
        """``{coordinate: {signal: %}}``."""
        return {c: {s: stat.relative for s, stat in signals.items()} for c, signals in self.statistics.items()}

    def to_dict(self) -> dict[str, Any]:
        """Relative errors (%), RMS, worst windows and the treatment, for JSON."""
        return {
            "relative_error": self.relative_errors(),
            "rms": {c: {s: stat.rms for s, stat in signals.items()} for c, signals in self.statistics.items()},
            "worst_window": {c: {s: {"start": stat.worst[0], "stop": stat.worst[1], "rms": stat.worst[2]}
                                 for s, stat in signals.items()} for c, signals in self.statistics.items()},
            "window": self.window,
            "samples_compared": self.kept.stop - self.kept.start,
            "treatment": self.treatment.to_dict(),
        }

    def summary(self) -> str:
        """A table: coordinate, signal, relative error, RMS, worst window."""
        lines = [f"{'coordinate':12s} {'signal':12s} {'relative %':>11s} {'RMS':>11s}  worst {self.window:g} s window"]
        rows = [(c, s, stat) for c, signals in self.statistics.items() for s, stat in signals.items()]
        spans = time_windows([stat.worst[:2] for _, _, stat in rows])
        for (c, s, stat), span in zip(rows, spans):
            relative = "-" if stat.relative is None else f"{stat.relative:.4g}"
            lines.append(f"{c:12s} {s:12s} {relative:>11s} {stat.rms:11.4g}  {span} (RMS {stat.worst[2]:.4g})")
        return "\n".join(lines)


def compare(measured: Measurements, simulated: Measurements, window: float = 1.0) -> Comparison:
    """Compare a simulation with its log, coordinate by coordinate (docs/simulation.md, "Comparison").

    ``simulated`` must have the log's time stamps and every coordinate of the log (extra coordinates,
    e.g. modal ones, are ignored).
    """
    source = str(measured.source)
    if not (isinstance(window, (int, float)) and math.isfinite(window) and window > 0):
        raise DataError(source, "window", f"expected a duration in seconds > 0, got {window!r}")
    if simulated.samples != measured.samples or not np.array_equal(simulated.t, measured.t):
        raise DataError(source, "t", "the simulation's time stamps differ from the log's")
    motion = measured_motion(measured)
    index = [list(simulated.coordinates).index(c) for c in measured.coordinates]
    meas = {"position": measured.q, "velocity": motion.qd, "acceleration": motion.qdd, "force": measured.tau}
    sim = {"position": simulated.q[:, index], "velocity": simulated.qd[:, index],
           "acceleration": simulated.qdd[:, index], "force": simulated.tau[:, index]}
    border = motion.treatment.border
    kept = slice(border, measured.samples - border)
    width = min(max(1, round(min(window * measured.rate, kept.stop - kept.start))), kept.stop - kept.start)  # no overflow
    t = measured.t[kept]
    statistics = {
        c: {s: _statistic(meas[s][kept, j], sim[s][kept, j], t, width) for s in SIGNALS}
        for j, c in enumerate(measured.coordinates)
    }
    return Comparison(tuple(measured.coordinates), statistics, measured.t, meas, sim, kept, motion.treatment,
                      width * measured.sample_period)


def _statistic(measured: np.ndarray, simulated: np.ndarray, t: np.ndarray, width: int) -> Statistic:
    error = measured - simulated
    norm = float(np.linalg.norm(measured))
    relative = 100.0 * float(np.linalg.norm(error)) / norm if norm > 0 else None
    squares = np.concatenate([[0.0], np.cumsum(error**2)])
    means = (squares[width:] - squares[:-width]) / width
    start = int(np.argmax(means))
    worst = (float(t[start]), float(t[start + width - 1]), math.sqrt(max(float(means[start]), 0.0)))
    return Statistic(relative, math.sqrt(float(np.mean(error**2))), worst)
