"""IDIM-LS end to end: load, treat, solve; cross-validation on another data set; a report for the CLI."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from symbolic.data import Measurements, load
from symbolic.description.units import CoordinateUnits
from symbolic.identify.least_squares import RELATIVE_SIGMA_THRESHOLD, Identification, Validation, norm, solve
from symbolic.identify.processing import Observation, RegressorFunction, Settings, observe


def identify(
    measurements: Measurements,
    regressor: RegressorFunction,
    names: Sequence[str],
    settings: Settings | None = None,
    method: str = "wls",
    threshold: float = RELATIVE_SIGMA_THRESHOLD,
) -> Identification:
    """Identify the parameters of ``τ = Y(q, q̇, q̈)·β`` from ``measurements`` by IDIM-LS.

    Parameters
    ----------
    measurements
        The data (:func:`symbolic.data.load`).
    regressor
        ``regressor(q, qd, qdd) -> Y`` with ``samples × N`` inputs and a ``samples × N × P`` result.
    names
        The P parameter names, in the order of Y's columns.
    settings
        The data treatment (:class:`~symbolic.identify.processing.Settings`); unset fields come from the
        experiment's ``[identification]`` table, then from Gautier's rules.
    method
        ``"wls"`` (weighted per coordinate, default) or ``"ols"``.
    threshold
        Relative σ (%) above which a parameter is flagged.
    """
    return solve(observe(measurements, regressor, len(names), settings), names, method, threshold)


def cross_validate(
    identification: Identification,
    measurements: Measurements,
    regressor: RegressorFunction,
    settings: Settings | None = None,
) -> Validation:
    """Relative error of the identified parameters on ``measurements`` (another data set).

    The data are treated with the same settings as the estimation (``settings`` or the data's own
    ``[identification]`` table give the bandwidth, cut-off, ...; by default the rules, which at the same
    rate give the same filters).
    """
    observation = observe(measurements, regressor, len(identification.names), settings)
    predicted = identification.predict(observation)
    errors = {
        c: _relative(observation.tau[:, j], predicted[:, j]) for j, c in enumerate(observation.coordinates)
    }
    return Validation(_relative(observation.tau, predicted), errors, observation, predicted)


def _relative(measured: np.ndarray, predicted: np.ndarray) -> float:
    """100·‖measured − predicted‖/‖measured‖ (%); NaN for a coordinate whose force is zero (no actuator:
    tau_<c> = "0"), where a relative error means nothing."""
    size = norm(measured)
    return float(100.0 * norm(measured - predicted) / size) if size > 0 else float("nan")


@dataclass(frozen=True, eq=False)
class Report:
    """What :func:`run` found: the identification, its observation, and the optional cross-test."""

    identification: Identification
    observation: Observation = field(repr=False)
    measurements: Measurements = field(repr=False)
    validation: Validation | None = None
    figures: tuple[Path, ...] = ()
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The identification's :meth:`~Identification.to_dict`, the data file, the cross-test error."""
        out = self.identification.to_dict()
        out["data"] = str(self.measurements.source)
        out["validation_relative_error"] = None if self.validation is None else self.validation.relative_error
        out["figures"] = [str(p) for p in self.figures]
        out["notes"] = list(self.notes)
        return out


def run(
    data: str | Path | Measurements,
    regressor: RegressorFunction,
    names: Sequence[str],
    coordinates: Sequence[str],
    *,
    validation: str | Path | Measurements | None = None,
    settings: Settings | None = None,
    method: str = "wls",
    figures: str | Path | None = None,
    resample: bool = False,
    units: Mapping[str, CoordinateUnits] | None = None,
) -> Report:
    """Load data (a data or experiment file), identify, optionally cross-test and draw figures.

    The function a command line calls: errors in the files are :class:`~symbolic.data.DataError`.
    ``figures`` names a folder for PNG figures (:mod:`symbolic.identify.figures`); without matplotlib
    none are drawn and the report's notes say so; ``units`` (per coordinate,
    :func:`symbolic.description.units.coordinate_units` of the model) label their axes.
    """
    measurements = load(data, tuple(coordinates), validation=validation, resample=resample)
    observation = observe(measurements, regressor, len(names), settings)
    identification = solve(observation, names, method)
    checked = None
    if measurements.validation is not None:
        checked = cross_validate(identification, measurements.validation, regressor, settings)
    written: tuple[Path, ...] = ()
    notes: tuple[str, ...] = ()
    if figures is not None:
        from symbolic.identify import figures as drawing

        try:
            written = drawing.draw(identification, observation, Path(figures), checked, units)
        except drawing.MatplotlibMissing as missing:
            notes = (str(missing),)
    return Report(identification, observation, measurements, checked, written, notes)
