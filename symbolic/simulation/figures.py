"""PNG figures of a simulation against its log: measured and simulated signals, and their difference.

matplotlib is optional (``pip install symbolic[plot]``), imported only here when figures are asked
for; without it :func:`draw` raises :class:`MatplotlibMissing` and callers go on without figures.
Per compared coordinate c: ``simulation_<c>.png`` (position, velocity, acceleration, force:
measured and simulated) and ``simulation_error_<c>.png`` (measured − simulated over time, the
worst window shaded, the samples left out at the ends greyed). Every axis carries its unit (from the
model: :mod:`symbolic.description.units`) and every mark a legend entry. The PNGs carry no time stamp or
version.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from symbolic.description.units import CoordinateUnits, units_for
from symbolic.plotting import MatplotlibMissing, figure_class, save_png
from symbolic.simulation.comparison import SIGNALS, Comparison
from symbolic.writing import safe_stem

__all__ = ["MatplotlibMissing", "draw", "figures"]


def draw(comparison: Comparison, folder: Path, title: str = "",
         units: Mapping[str, CoordinateUnits] | None = None) -> tuple[Path, ...]:
    """Write the two figures of every coordinate into ``folder``; return their paths.

    ``units``: per coordinate, from the model (:func:`symbolic.description.units.coordinate_units`);
    without, the axes name their quantity only.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, figure in figures(comparison, title, units).items():
        written.append(save_png(figure, folder / name))
    return tuple(written)


def figures(comparison: Comparison, title: str = "",
            units: Mapping[str, CoordinateUnits] | None = None) -> dict[str, Any]:
    """The matplotlib figures :func:`draw` writes, by file name (in the order written)."""
    Figure = figure_class()
    out = {}
    for j, c in enumerate(comparison.coordinates):
        for kind in ("signals", "error"):
            figure = Figure(figsize=(9, 9), dpi=100)
            axes = figure.subplots(len(SIGNALS), 1, sharex=True)
            for ax, signal in zip(axes, SIGNALS):
                _panel(ax, comparison, j, c, signal, kind, units_for(units, c))
            axes[-1].set_xlabel("t (s)")
            what = "measured and simulated" if kind == "signals" else "measured − simulated"
            axes[0].set_title(f"{title + ': ' if title else ''}{what}, coordinate {c}")
            stem = "simulation" if kind == "signals" else "simulation_error"
            out[f"{stem}_{safe_stem(c)}.png"] = figure
    return out


def _panel(ax: Any, comparison: Comparison, j: int, c: str, signal: str, kind: str, units: CoordinateUnits) -> None:
    """One signal of coordinate ``c``: its curves, the worst window (error figure), the border left out."""
    t, kept = comparison.t, comparison.kept
    measured = comparison.measured[signal][:, j]
    simulated = comparison.simulated[signal][:, j]
    stat = comparison.statistics[c][signal]
    unit = units.unit(signal)
    if kind == "signals":
        relative = "-" if stat.relative is None else f"{stat.relative:.3g} %"
        ax.plot(t, measured, linewidth=0.9, label="measured")
        ax.plot(t, simulated, "--", linewidth=0.9, label=f"simulated (relative error {relative})")
        ax.set_ylabel(units.label(signal, f"{signal} of {c}"))
    else:
        ax.plot(t, measured - simulated, color="black", linewidth=0.7, label="measured − simulated")
        rms = f"{stat.worst[2]:.3g}" + (f" {unit}" if unit else "")
        ax.axvspan(stat.worst[0], stat.worst[1], color="tab:red", alpha=0.15,
                   label=f"worst {comparison.window:g} s window (RMS {rms})")
        ax.set_ylabel(units.label(signal, f"{signal} error of {c}"))
    border = [(lo, hi) for lo, hi in ((t[0], t[kept.start]), (t[kept.stop - 1], t[-1])) if hi > lo]
    for k, (lo, hi) in enumerate(border):
        ax.axvspan(lo, hi, color="grey", alpha=0.2,
                   label="not compared (filter border)" if k == 0 else None)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(True, linewidth=0.3)
