"""The statistics Milne et al. compare models with: Table 8 (sine sweeps) and Table 11 (step responses).

:func:`frequency_response_errors`: per frequency of a sweep, the magnitude (A₀/A_r) and phase (Milne
(16)) of the fundamental of the measured and the simulated response, each from a whole-period sine fit
(:func:`symbolic.reproduction.milne.sine.steady_state_response`, Milne (14)–(16)), their absolute
differences and the 90th percentiles over the frequencies (Table 8). :func:`step_errors`: the median and
90th percentile of |θ_model − θ_measured| over the samples of a step response (Table 11). The
definitions Milne leave open (the percentile, the magnitude's unit) and how they are read here:
docs/seeds.md, "Milne: the α-invariant model".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from symbolic.data import DataError
from symbolic.reproduction.milne.sine import steady_state_response
from symbolic.reproduction.milne import SOURCE


PERCENTILE = 90.0
"""Milne Tables 8 and 11: the 90th percentile."""


@dataclass(frozen=True)
class FrequencyResponseErrors:
    """Magnitude and phase errors of a model's sweep against the measured one (Milne Table 8).

    Attributes
    ----------
    frequency
        Hz.
    measured_magnitude, model_magnitude
        A₀/A_r per frequency.
    measured_phase, model_phase
        φ per frequency (degrees).
    magnitude_error, phase_error
        |Δ magnitude| and |Δφ| (degrees, wrapped to [0, 180]) per frequency.
    magnitude_percentile, phase_percentile
        Their 90th percentiles (Table 8's columns).
    """

    frequency: tuple[float, ...]
    measured_magnitude: tuple[float, ...]
    model_magnitude: tuple[float, ...]
    measured_phase: tuple[float, ...]
    model_phase: tuple[float, ...]
    magnitude_error: tuple[float, ...]
    phase_error: tuple[float, ...]
    magnitude_percentile: float
    phase_percentile: float


@dataclass(frozen=True)
class StepErrors:
    """Absolute angle errors of a model's step response (Milne Table 11), in the angle's unit.

    Attributes
    ----------
    median, percentile
        Median and 90th percentile of |θ_model − θ_measured| over the samples.
    """

    median: float
    percentile: float


def magnitude_and_phase(t: ArrayLike, response: ArrayLike, reference: ArrayLike, frequency: float, *,
                        transient: float | None = None, decibels: bool = False) -> tuple[float, float]:
    """The fundamental's magnitude A₀/A_r (or 20 log₁₀ of it) and phase φ (degrees) of a response to a sine."""
    fit = steady_state_response(np.asarray(t, float), np.asarray(response, float), np.asarray(reference, float),
                                frequency, transient=transient)
    gain = math.hypot(fit.a1, fit.a2) / fit.reference_amplitude
    return (20.0 * math.log10(gain) if decibels else gain), math.degrees(fit.phase)


def frequency_response_errors(t: ArrayLike, measured: Sequence[ArrayLike], model: Sequence[ArrayLike],
                              reference: Sequence[ArrayLike], frequencies: Sequence[float], *,
                              transient: float | None = None, percentile: float = PERCENTILE,
                              decibels: bool = False) -> FrequencyResponseErrors:
    """Milne Table 8's statistics of one configuration: 90th-percentile magnitude and phase errors.

    Parameters
    ----------
    t
        Sample times (s), shared by all runs.
    measured, model, reference
        One response (rad) per frequency, measured and simulated, and the reference each answered.
    frequencies
        Hz, one per run.
    transient
        Seconds discarded before the sine fits (default: half the record, as the sine fit does).
    percentile
        The percentile reported (90).
    decibels
        Magnitudes in dB instead of as gain ratios.
    """
    count = len(frequencies)
    if count == 0 or not (len(measured) == len(model) == len(reference) == count):
        raise DataError(SOURCE, "responses", f"need one measured, model and reference response per frequency, got "
                        f"{len(measured)}, {len(model)}, {len(reference)} for {count} frequencies")
    rows = []
    for f, y_meas, y_model, r in zip(frequencies, measured, model, reference):
        m_meas, p_meas = magnitude_and_phase(t, y_meas, r, f, transient=transient, decibels=decibels)
        m_model, p_model = magnitude_and_phase(t, y_model, r, f, transient=transient, decibels=decibels)
        dphi = abs((p_model - p_meas + 180.0) % 360.0 - 180.0)
        rows.append((float(f), m_meas, m_model, p_meas, p_model, abs(m_model - m_meas), dphi))
    columns = [tuple(c) for c in zip(*rows)]
    return FrequencyResponseErrors(*columns, float(np.percentile(columns[5], percentile)),
                                   float(np.percentile(columns[6], percentile)))


def step_errors(measured: ArrayLike, model: ArrayLike, *, percentile: float = PERCENTILE) -> StepErrors:
    """Milne Table 11's statistics: median and 90th percentile of |θ_model − θ_measured| over the samples."""
    a = np.asarray(measured, dtype=float).reshape(-1)
    b = np.asarray(model, dtype=float).reshape(-1)
    if a.shape != b.shape or a.size == 0:
        raise DataError(SOURCE, "step responses", f"measured and model must have the same number of samples, "
                        f"got {a.size} and {b.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise DataError(SOURCE, "step responses", "hold NaN or infinity")
    error = np.abs(b - a)
    return StepErrors(float(np.median(error)), float(np.percentile(error, percentile)))
