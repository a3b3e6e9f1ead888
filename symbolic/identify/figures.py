"""PNG figures of an identification: measured and predicted generalized force, and the residual.

matplotlib is optional (``pip install symbolic[plot]``): it is imported only here, when figures are
asked for; without it :func:`draw` raises :class:`MatplotlibMissing` and callers carry on without
figures. File names are fixed: ``identification_<coordinate>.png`` and, with a cross-test,
``validation_<coordinate>.png``; the PNGs carry no time stamp or version, so the same data give the
same files with the same matplotlib.
"""

from __future__ import annotations

from pathlib import Path


from symbolic.identify.least_squares import Identification, Validation
from symbolic.plotting import MatplotlibMissing, figure_class, save_png
from symbolic.writing import safe_stem
from symbolic.identify.processing import Observation


def draw(
    identification: Identification, observation: Observation, folder: Path, validation: Validation | None = None
) -> tuple[Path, ...]:
    """Write one figure per coordinate (estimation set, and cross-test set if given); return the paths."""
    Figure = figure_class()
    folder.mkdir(parents=True, exist_ok=True)
    sets = [("identification", observation, identification.predict(observation), identification.relative_error)]
    if validation is not None:
        sets.append(("validation", validation.observation, validation.predicted, validation.relative_error))
    written = []
    for stem, obs, predicted, error in sets:
        for j, c in enumerate(obs.coordinates):
            figure = Figure(figsize=(8, 5), dpi=100)
            top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(3, 1))
            top.plot(obs.t, obs.tau[:, j], label=f"measured tau_{c}", linewidth=1.0)
            top.plot(obs.t, predicted[:, j], "--", label=f"predicted (relative error {error:.3g} %)", linewidth=1.0)
            top.set_ylabel(f"tau_{c}")
            top.legend(loc="upper right")
            top.set_title(f"{stem}: {identification.method.upper()}, coordinate {c}")
            bottom.plot(obs.t, obs.tau[:, j] - predicted[:, j], color="black", linewidth=0.8)
            bottom.set_ylabel("residual")
            bottom.set_xlabel("t [s]")
            for axes in (top, bottom):
                axes.grid(True, linewidth=0.3)
            written.append(save_png(figure, folder / f"{stem}_{safe_stem(c)}.png"))
    return tuple(written)


__all__ = ["MatplotlibMissing", "draw"]
