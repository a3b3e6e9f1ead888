"""PNG figures of a simulation against its log: measured and simulated signals, and their difference.

matplotlib is optional (``pip install symbolic[plot]``), imported only here when figures are asked
for; without it :func:`draw` raises :class:`MatplotlibMissing` and callers go on without figures.
Per compared coordinate c: ``simulation_<c>.png`` (position, velocity, acceleration, force:
measured and simulated) and ``simulation_error_<c>.png`` (measured − simulated over time, the
worst window shaded, the samples left out at the ends greyed). The PNGs carry no time stamp or
version.
"""

from __future__ import annotations

from pathlib import Path

from symbolic.simulation.comparison import SIGNALS, Comparison
from symbolic.plotting import MatplotlibMissing, figure_class, save_png
from symbolic.writing import safe_stem

UNITS = {"position": "q", "velocity": "q̇", "acceleration": "q̈", "force": "τ"}


def draw(comparison: Comparison, folder: Path, title: str = "") -> tuple[Path, ...]:
    """Write the two figures of every coordinate into ``folder``; return their paths."""
    Figure = figure_class()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    t = comparison.t
    kept = comparison.kept
    written = []
    for j, c in enumerate(comparison.coordinates):
        for kind in ("signals", "error"):
            figure = Figure(figsize=(9, 9), dpi=100)
            axes = figure.subplots(len(SIGNALS), 1, sharex=True)
            for ax, signal in zip(axes, SIGNALS):
                measured = comparison.measured[signal][:, j]
                simulated = comparison.simulated[signal][:, j]
                stat = comparison.statistics[c][signal]
                relative = "-" if stat.relative is None else f"{stat.relative:.3g} %"
                if kind == "signals":
                    ax.plot(t, measured, linewidth=0.9, label="measured")
                    ax.plot(t, simulated, "--", linewidth=0.9, label=f"simulated (relative error {relative})")
                    ax.legend(loc="upper right", fontsize=8)
                else:
                    ax.plot(t, measured - simulated, color="black", linewidth=0.7)
                    ax.axvspan(stat.worst[0], stat.worst[1], color="tab:red", alpha=0.15,
                               label=f"worst {comparison.window:g} s (RMS {stat.worst[2]:.3g})")
                    ax.legend(loc="upper right", fontsize=8)
                for lo, hi in ((t[0], t[kept.start]), (t[kept.stop - 1], t[-1])):
                    if hi > lo:
                        ax.axvspan(lo, hi, color="grey", alpha=0.2)
                ax.set_ylabel(f"{signal} {UNITS[signal]}" + (" error" if kind == "error" else ""))
                ax.grid(True, linewidth=0.3)
            axes[-1].set_xlabel("t [s]")
            what = "measured and simulated" if kind == "signals" else "measured − simulated"
            axes[0].set_title(f"{title + ': ' if title else ''}{what}, coordinate {c}")
            stem = "simulation" if kind == "signals" else "simulation_error"
            written.append(save_png(figure, folder / f"{stem}_{safe_stem(c)}.png"))
    return tuple(written)
