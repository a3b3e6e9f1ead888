"""PNG figures of an identification: measured and predicted generalized force, and the residual.

matplotlib is optional (``pip install symbolic[plot]``): it is imported only here, when figures are
asked for; without it :func:`draw` raises :class:`MatplotlibMissing` and callers carry on without
figures. File names are fixed: ``identification_<coordinate>.png`` and, with a cross-test,
``validation_<coordinate>.png``; the PNGs carry no time stamp or version, so the same data give the
same files with the same matplotlib. The force axes carry the coordinate's unit (N·m for a revolute
coordinate, N for a prismatic one: :mod:`symbolic.description.units`) when the model is known.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from symbolic.description.units import CoordinateUnits, units_for
from symbolic.identify.least_squares import Identification, Validation
from symbolic.identify.processing import Observation
from symbolic.plotting import MatplotlibMissing, figure_class, save_png
from symbolic.writing import safe_stem


def draw(
    identification: Identification, observation: Observation, folder: Path, validation: Validation | None = None,
    units: Mapping[str, CoordinateUnits] | None = None,
) -> tuple[Path, ...]:
    """Write one figure per coordinate (estimation set, and cross-test set if given); return the paths.

    ``units``: per coordinate, from the model (:func:`symbolic.description.units.coordinate_units`);
    without, the axes name their quantity only.
    """
    folder.mkdir(parents=True, exist_ok=True)
    return tuple(save_png(figure, folder / name)
                 for name, figure in figures(identification, observation, validation, units).items())


def figures(identification: Identification, observation: Observation, validation: Validation | None = None,
            units: Mapping[str, CoordinateUnits] | None = None) -> dict[str, Any]:
    """The matplotlib figures :func:`draw` writes, by file name (in the order written)."""
    Figure = figure_class()
    sets = [("identification", observation, identification.predict(observation), identification.relative_error)]
    if validation is not None:
        sets.append(("validation", validation.observation, validation.predicted, validation.relative_error))
    out = {}
    for stem, obs, predicted, error in sets:
        for j, c in enumerate(obs.coordinates):
            u = units_for(units, c)
            figure = Figure(figsize=(8, 5), dpi=100)
            top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(3, 1))
            top.plot(obs.t, obs.tau[:, j], label=f"measured τ_{c}", linewidth=1.0)
            top.plot(obs.t, predicted[:, j], "--", label=f"predicted τ_{c} (relative error {error:.3g} %)",
                     linewidth=1.0)
            top.set_ylabel(u.label("force", f"generalized force τ_{c}"))
            top.legend(loc="upper right")
            what = "estimation data" if stem == "identification" else "cross-test data"
            top.set_title(f"{stem} ({what}): {identification.method.upper()}, coordinate {c}")
            bottom.plot(obs.t, obs.tau[:, j] - predicted[:, j], color="black", linewidth=0.8,
                        label="measured − predicted")
            bottom.set_ylabel(u.label("force", "residual"))
            bottom.set_xlabel("t (s)")
            bottom.legend(loc="upper right", fontsize=8)
            for axes in (top, bottom):
                axes.grid(True, linewidth=0.3)
            out[f"{stem}_{safe_stem(c)}.png"] = figure
    return out


__all__ = ["MatplotlibMissing", "draw", "figures"]
