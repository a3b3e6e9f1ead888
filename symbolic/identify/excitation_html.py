"""``symbolic excite --out DIR --html``: ``DIR/report.html``, the excitation design as one self-contained page
(:mod:`symbolic.htmlpage`), written with report.md and excitation.json as one set.

The tables are read from the dictionary ``excite --json`` prints (excitation.json's content): the criterion, the
limits with the design's peak ratio to each, the predicted σ of every base parameter (and the compared log's).
The figures draw the reference's q, q̇, q̈ per coordinate over one period, their spectra (the harmonics), and the
predicted relative σ per base parameter.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from symbolic import htmlpage
from symbolic.description.units import coordinate_units
from symbolic.htmlpage import Page, bars, line, number
from symbolic.identify.excitation_criteria import DESCRIPTIONS

NAME = htmlpage.REPORT


def render(result: Any, document: Mapping[str, Any]) -> str:
    """The page of ``result`` (an :class:`~symbolic.identify.excitation_report.Excitation`); ``document``: what
    ``--json`` prints."""
    htmlpage.require()
    page = Page(f"Excitation design: {result.model.name}", document, "symbolic excite")
    r = page.result
    d = r["design"]
    page.paragraph(f"Fourier series (Swevers et al. 1997), at rest at t = 0 and T; criterion {d['criterion']} "
                   f"({DESCRIPTIONS.get(d['criterion'], d['criterion'])}). Collision avoidance: {r['collision_avoidance']}.")
    page.table(["quantity", "value"], [
        ["period T (s)", number(r, "design", "trajectory", "period")],
        ["harmonics per coordinate", number(r, "design", "trajectory", "harmonics")],
        ["criterion after the solve", number(r, "design", "value", digits=6)],
        ["criterion at the best start", number(r, "design", "start_value", digits=6)],
        ["grid points", number(r, "design", "grid_points")],
        ["noise: sample rate (Hz)", number(r, "noise", "rate")]])
    page.heading("Limits and the design's peak (ratio to the limit)")
    rows = []
    for c, limits in d["limits"].items():
        rows.append([c, number(r, "design", "limits", c, "position", 0), number(r, "design", "limits", c, "position", 1),
                     number(r, "design", "worst_ratio_to_limit", "position", c, digits=3),
                     number(r, "design", "limits", c, "velocity"), number(r, "design", "worst_ratio_to_limit", "velocity", c, digits=3),
                     number(r, "design", "limits", c, "acceleration"),
                     number(r, "design", "worst_ratio_to_limit", "acceleration", c, digits=3),
                     number(r, "design", "limits", c, "torque"), number(r, "design", "worst_ratio_to_limit", "torque", c, digits=3)])
    page.table(["coordinate", "position from", "to", "ratio", "velocity", "ratio", "acceleration", "ratio", "torque", "ratio"], rows)
    page.heading("Checked in the loop")
    page.paragraph("Not checked: the experiment declares no [controller]." if r["loop"] is None else
                   "Run through the experiment's [controller]: see report.md's table and excitation.json's \"loop\".")
    page.heading("Predicted uncertainty (σ of each base parameter)")
    compare = r["compare"]
    header = ["base parameter", "nominal", "σ design", "σ % design"] + ([f"σ % {compare['label']}"] if compare else [])
    page.table(header, [[name, number(r, "predicted", "parameters", name, "nominal", digits=6),
                         number(r, "predicted", "parameters", name, "sigma"),
                         number(r, "predicted", "parameters", name, "relative_sigma")]
                        + ([number(r, "compare", "parameters", name, "relative_sigma")] if compare else [])
                        for name in r["predicted"]["parameters"]])
    rows = [[p["label"], number(r, key, "samples"), number(r, key, "duration"), number(r, key, "log_det_information", digits=6),
             number(r, key, "condition_number", digits=6)] for key, p in (("predicted", r["predicted"]), ("compare", compare)) if p]
    page.table(["trajectory", "samples kept", "duration (s)", "log det M", "cond(Σ^(−1/2)W)"], rows)
    pair = r.get("separate")
    if pair:
        a, b = pair["parameters"]
        page.heading(f"Separating {a} and {b}")
        page.paragraph("Designed for the pair: Ds-optimality, the information about the two once the others are "
                       "estimated. —: the data cannot separate them (σ = ∞, correlation ±1).")
        page.table(["trajectory", f"σ % {a}", f"σ % {b}", "correlation ρ"],
                   [[label, number(r, "separate", key, "relative_sigma", 0), number(r, "separate", key, "relative_sigma", 1),
                     number(r, "separate", key, "correlation", digits=4)]
                    for key, label in (("design", "design"), ("compare", compare["label"] if compare else ""))
                    if pair.get(key)])
    _figures(page, result)
    return page.render()


def _figures(page: Page, result: Any) -> None:
    t, q, qd, qdd = result.samples()
    names = result.design.trajectory.coordinates
    units = coordinate_units(result.model.robot)
    page.heading("Figures")
    page.paragraph("Drag to zoom, double-click to zoom out, hover for values; click a legend entry to hide its curve.")
    for signal, values in (("position", q), ("velocity", qd), ("acceleration", qdd)):
        unit = {units[c].unit(signal) for c in names} - {""}
        page.figure(f"Reference {signal} over one period", [line(t, values[:, i], c) for i, c in enumerate(names)],
                    x="t (s)", y=signal + (f" ({unit.pop()})" if len(unit) == 1 else ""), height=360)
    # one period sampled: the DFT of its samples (the end, equal to the start, left out) gives each harmonic's amplitude
    harmonics = result.design.trajectory.harmonics
    period = result.design.trajectory.period
    bins = np.arange(1, harmonics + 1)
    amplitude = 2.0 * np.abs(np.fft.rfft(q[:-1], axis=0))[bins] / (len(t) - 1)
    page.figure("Spectrum of the reference positions: amplitude of each harmonic",
                [bars([f"{k / period:.4g}" for k in bins], amplitude[:, i], c) for i, c in enumerate(names)],
                x="frequency (Hz), harmonics of 1/T", y="amplitude of q", categories=True, height=360,
                caption=f"The discrete Fourier transform of one period: the energy sits at the {harmonics} harmonics of 1/T.")
    p = result.predicted
    def shown(relative: Any) -> np.ndarray:
        relative = np.asarray(relative, dtype=float)
        return np.where(np.isfinite(relative), np.minimum(relative, 1e6), np.nan)

    traces = [bars(p.names, shown(p.relative), "design")]
    if result.compare is not None:
        traces.append(bars(result.compare.names, shown(result.compare.relative), result.compare.label))
    page.figure("Predicted relative σ per base parameter", traces, x="base parameter", y="predicted σ (%)", log_y=True,
                categories=True, height=420, caption="Values above 10⁶ % are drawn at 10⁶ %; a parameter whose nominal value is 0 has no "
                "relative σ (no bar, — in the table).")
