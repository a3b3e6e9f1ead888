"""``symbolic identify --html FILE``: the identification as one self-contained HTML page (:mod:`symbolic.htmlpage`).

The tables are read from the dictionary ``identify --json`` prints (``document``); the figures draw the
estimation set (and the cross-test set) per coordinate: measured and predicted τ against time, the residual
against time, velocity and position, and its Welch spectrum.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from symbolic import htmlpage
from symbolic.data.filters import spectrum
from symbolic.description.units import coordinate_units
from symbolic.htmlpage import Page, line, number, points


def render(result: Any, document: Mapping[str, Any] | None = None, data: str = "") -> str:
    """The page of ``result`` (a :class:`~symbolic.identify.model.ModelIdentification`); ``document``: what
    ``--json`` prints (default ``result.to_dict()``); ``data``: the log's name for the title."""
    htmlpage.require()
    page = Page(f"Identification: {result.model.name}" + (f", {data}" if data else ""),
                document if document is not None else result.to_dict(), "symbolic identify")
    r = page.result
    page.heading("Fit")
    page.table(["quantity", "value"], [
        ["relative error ‖τ − Wβ̂‖/‖τ‖, estimation data (%)", number(r, "relative_error")],
        ["relative error, cross-test data (%)", number(r, "validation_relative_error")],
        ["condition number of W", number(r, "condition_number")]])
    page.heading("Model-file parameters (value ± σ)")
    if r["parameters"]:
        page.table(["parameter", "identified", "σ", "σ (%)", "note"],
                   [[name, number(r, "parameters", name, "value", digits=6), number(r, "parameters", name, "sigma", digits=3),
                     number(r, "parameters", name, "relative_sigma", digits=3),
                     f"at its {p['at_bound']}" if p.get("at_bound") else ""] for name, p in r["parameters"].items()])
    else:
        page.paragraph("No model-file parameter is determined by one base parameter alone (see the base parameters).")
    if r["fixed"]:
        page.table(["kept at its value (fixed)", "value"], [[n, number(r, "fixed", n, digits=6)] for n in r["fixed"]])
    if r["undetermined"]:
        note = result.undetermined_note()
        page.paragraph(note or ("not determined alone: " + ", ".join(r["undetermined"])))
    page.heading("Base parameters (value ± σ)")
    page.table(["base parameter", "combination of the model's parameters", "value", "σ", "σ (%)"],
               [[b["name"], b["expression"], number(r, "base_parameters", k, "value", digits=6),
                 number(r, "base_parameters", k, "sigma", digits=3), number(r, "base_parameters", k, "relative_sigma", digits=3)]
                for k, b in enumerate(r["base_parameters"])])
    if r.get("consistent"):
        page.heading("Physically consistent fit")
        page.table(["quantity", "value"], [[k, number(r, "consistent", k)] for k, v in r["consistent"].items()
                                           if isinstance(v, (int, float)) and not isinstance(v, bool)])
    if r.get("kept"):
        page.items(f"not written: {name} keeps its value in the model file: {why}" for name, why in r["kept"].items())
    htmlpage.alignment(page, r)  # the bag's topics, when the data are one
    _figures(page, result)
    return page.render()


def _figures(page: Page, result: Any) -> None:
    units = coordinate_units(result.model.robot)
    ident = result.identification
    sets = [("estimation data", result.observation, ident.predict(result.observation))]
    if result.validation is not None:
        sets.append(("cross-test data", result.validation.observation, result.validation.predicted))
    page.heading("Figures")
    page.paragraph("Drag to zoom, double-click to zoom out, hover for values; click a legend entry to hide its curve.")
    for what, obs, predicted in sets:
        rate = 1.0 / float(np.mean(np.diff(obs.t))) if len(obs.t) > 1 else 1.0
        for j, c in enumerate(obs.coordinates):
            u = units[c]
            residual = obs.tau[:, j] - predicted[:, j]
            page.heading(f"{c}, {what}", 3)
            page.figure(f"Measured and predicted τ on {c} ({what})",
                        [line(obs.t, obs.tau[:, j], f"measured τ_{c}"),
                         line(obs.t, predicted[:, j], f"predicted τ_{c} (W·β̂)", dash="dash"),
                         {**line(obs.t, residual, "residual: measured − predicted (right axis)", width=0.8,
                                 color="black"), "yaxis": "y2"}],
                        x="t (s)", y=u.label("force", f"generalized force on {c}"), y2=u.label("force", "residual"))
            if obs.qd is not None:
                for signal, values in (("velocity", obs.qd), ("position", obs.q)):
                    page.figure(f"Residual against the {signal} of {c} ({what})",
                                [points(values[:, j], residual, "measured − predicted")],
                                x=u.label(signal, f"{signal} of {c}"), y=u.label("force", "residual"), height=360)
            page.figure(f"Residual spectrum on {c} (Welch, {what})", htmlpage.spectrum_traces({"residual": spectrum(residual, rate)}),
                        x="frequency (Hz)", y="PSD of the residual" + (f" (({u.force})²/Hz)" if u.force else ""), log_y=True)
