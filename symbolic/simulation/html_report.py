"""``symbolic simulate --out DIR --html``: ``DIR/report.html``, the simulation against its log as one
self-contained page (:mod:`symbolic.htmlpage`).

The tables are read from the dictionary ``simulate --json`` prints (``document``); the figures draw, per
compared coordinate, each signal measured and simulated with their difference (the worst window shaded, the
border left out greyed), the force's difference against the velocity and the position, and the Welch spectra of
the position's and the force's differences.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from symbolic import htmlpage
from symbolic.data.filters import spectrum
from symbolic.description.units import CoordinateUnits, units_for
from symbolic.htmlpage import Page, band, line, number, points
from symbolic.simulation.comparison import SIGNALS, Comparison

NAME = htmlpage.REPORT


def render(comparison: Comparison, document: Mapping[str, Any], title: str = "",
           units: Mapping[str, CoordinateUnits] | None = None, notes: Sequence[str] = ()) -> str:
    """The page (module docstring); ``document``: what ``--json`` prints."""
    htmlpage.require()
    page = Page(f"Simulation: {title}" if title else "Simulation", document, "symbolic simulate")
    r = page.result
    page.paragraph(f"Model {r['model']}, {r['samples']} samples; controller: {r['controller']}; method {r['method']}"
                   + (f", {r['substeps']} sub-step(s) per sample" if r.get("substeps") else "") + ".")
    page.heading("Measured against simulated")
    page.paragraph(f"Relative error 100·‖x_meas − x_sim‖/‖x_meas‖ (%), the RMS of the difference and the worst "
                   f"{r['window']:g} s window, over the {r['samples_compared']} samples compared (the filter's border "
                   "left out).")
    rows = []
    for c in comparison.coordinates:
        u = units_for(units, c)
        for s in SIGNALS:
            if s not in r["relative_error"].get(c, {}):
                continue
            rows.append([c, s, number(r, "relative_error", c, s), number(r, "rms", c, s, unit=u.unit(s)),
                         number(r, "worst_window", c, s, "start", digits=5), number(r, "worst_window", c, s, "stop", digits=5),
                         number(r, "worst_window", c, s, "rms", unit=u.unit(s))])
    page.table(["coordinate", "signal", "relative error (%)", "RMS", "worst window from (s)", "to (s)", "its RMS"], rows)
    page.items(notes)
    htmlpage.alignment(page, r)  # the bag's topics, when the data are one
    page.heading("Figures")
    page.paragraph("Drag to zoom, double-click to zoom out, hover for values; click a legend entry to hide its curve.")
    t, kept = comparison.t, comparison.kept
    border = [band(lo, hi, "not compared (filter border)", "rgba(128,128,128,0.2)")
              for lo, hi in ((t[0], t[kept.start]), (t[kept.stop - 1], t[-1])) if hi > lo]
    rate = 1.0 / float(np.mean(np.diff(t))) if len(t) > 1 else 1.0
    for j, c in enumerate(comparison.coordinates):
        u = units_for(units, c)
        page.heading(f"Coordinate {c}", 3)
        for s in SIGNALS:
            measured, simulated = comparison.measured[s][:, j], comparison.simulated[s][:, j]
            worst = r["worst_window"][c][s]
            page.figure(f"{s} of {c}: measured and simulated", [
                line(t, measured, "measured"), line(t, simulated, "simulated", dash="dash"),
                {**line(t, measured - simulated, "measured − simulated (right axis)", width=0.8, color="black"),
                 "yaxis": "y2"}],
                x="t (s)", y=u.label(s, f"{s} of {c}"), y2=u.label(s, "measured − simulated"), height=360,
                shapes=[*border, band(worst["start"], worst["stop"], "worst window")],
                caption=f"Shaded red: the worst {r['window']:g} s window; grey: the border not compared.")
        # in a loop the force differs; replayed open loop (no [controller]) it is the log's, and the model's error
        # shows in the acceleration
        shown = "force" if np.any(comparison.measured["force"][kept, j] != comparison.simulated["force"][kept, j]) \
            else "acceleration"
        error = comparison.measured[shown][kept, j] - comparison.simulated[shown][kept, j]
        for s in ("velocity", "position"):
            page.figure(f"{shown.capitalize()} difference against the measured {s} of {c}",
                        [points(comparison.measured[s][kept, j], error, f"measured − simulated {shown}")],
                        x=u.label(s, f"{s} of {c}"), y=u.label(shown, f"{shown} difference"), height=360,
                        caption="" if shown == "force" else "The force is the log's (no controller: replayed), so "
                                                            "the model's error shows in the acceleration.")
        differences = {f"{s} difference": comparison.measured[s][kept, j] - comparison.simulated[s][kept, j]
                       for s in ("position", shown)}
        page.figure(f"Spectra of the differences on {c} (Welch)", htmlpage.spectrum_traces({k: spectrum(v, rate) for k, v in differences.items()}),
                    x="frequency (Hz)", y="PSD ((unit)²/Hz)", log_y=True, height=360)
    return page.render()
