"""``symbolic diagnose --out DIR --html``: ``DIR/report.html``, the diagnosis as one self-contained page
(:mod:`symbolic.htmlpage`), written with report.md as one set.

The tables are read from the dictionary ``diagnose --json`` prints (``document``, :meth:`Diagnosis.to_dict`):
the gaps before and after (headline and per coordinate), the named effects with their parameters and σ, the
model file's values the patch changes. The figures draw what the PNGs draw, from the same arrays
(:func:`symbolic.workflow.figures.effect_curves`): per coordinate the residual before and after against time,
velocity and position, and its Welch spectrum; per effect found, the partial residual against the state it
depends on with the fitted term.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from symbolic import htmlpage
from symbolic.description.units import coordinate_units
from symbolic.htmlpage import Page, line, number, points
from symbolic.workflow.result import Diagnosis
from symbolic.data.filters import spectrum

NAME = htmlpage.REPORT
BEFORE, AFTER = "nominal model (re-identified)", "patched model"


def render(d: Diagnosis, document: Mapping[str, Any] | None = None) -> str:
    """The page (module docstring); ``document``: what ``--json`` prints (default ``d.to_dict()``)."""
    htmlpage.require()
    page = Page(f"Diagnosis: {d.model.name}", document if document is not None else d.to_dict(), "symbolic diagnose")
    r = page.result
    page.paragraph(f"Gaps ‖x − x_model‖/‖x‖ in %, on the {r['path']} path; signals compared: {r['gap_detail']['signals']}"
                   f"; held-out data: {r['held_out']}.")
    page.heading("The gap")
    page.table(["data", "before (nominal model, re-identified)", "after (patched model)"],
               [[role, number(r, "gap_before", role, unit="%"), number(r, "gap_after", role, unit="%")]
                for role in r["gap_before"]])
    detail = r["gap_detail"]
    rows = []
    for role in detail["before"]:
        for signal in ("force", "position", "velocity"):  # position and velocity on the simulated path only
            for c in detail["before"][role].get(signal) or {}:
                rows.append([c, role, signal, number(r, "gap_detail", "before", role, signal, c, unit="%"),
                             number(r, "gap_detail", "after", role, signal, c, unit="%")])
    page.table(["coordinate", "data", "signal", "gap before", "after"], rows)
    verdict = r["verdict"]
    page.paragraph(f"Verdict before: {verdict['before']}; after: {verdict['after']}.")
    page.heading("Effects found")
    if r["found"]:
        rows = []
        for k, f in enumerate(r["found"]):
            label = f["effect"] + (f" ({f['variant']})" if f.get("variant") else "")
            for role in f["parameters"]:
                rows.append([label, f["coordinate"], role, number(r, "found", k, "parameters", role, digits=6),
                             number(r, "found", k, "evidence", "sigma", role, digits=3) if role in f["evidence"]["sigma"]
                             else "—"])
        page.table(["effect", "coordinate", "parameter", "value", "σ"], rows)
        written = [[f["effect"], f["coordinate"], name, number(r, "found", k, "model_parameters", name, digits=6)]
                   for k, f in enumerate(r["found"]) for name in f["model_parameters"]]
        if written:
            page.paragraph("Written into the patched model file:")
            page.table(["effect", "coordinate", "model-file parameter", "value"], written)
    else:
        page.paragraph("No significant missing effect.")
    changes = r["parameter_changes"]
    if changes:
        page.heading("Values the patch changes (value ± σ)")
        page.table(["parameter", "model file", "patched", "σ", "change", "status"],
                   [[c["parameter"], number(r, "parameter_changes", k, "nominal", digits=6),
                     "removed" if c["status"] == "removed" else number(r, "parameter_changes", k, "value", digits=6),
                     number(r, "parameter_changes", k, "sigma", digits=3) if c.get("sigma") is not None else "—",
                     "—" if c.get("relative_change") is None else
                     number(r, "parameter_changes", k, "relative_change", digits=3, signed=True, scale=100, unit="%"),
                     c["status"] + (" (correction)" if c.get("correction") else "")] for k, c in enumerate(changes)])
    if r["corrections"]:
        page.items(c["summary"] for c in r["corrections"])
    if r["patched_model"]:
        page.paragraph(f"Patched model file: {r['patched_model']}")
    page.items(r["notes"])
    _figures(page, d)
    return page.render()


def _figures(page: Page, d: Diagnosis) -> None:
    from symbolic.workflow.figures import _parameters, effect_curves

    est = d.sets["estimation"]
    units = coordinate_units(d.model.robot)
    before = est.tau - d.before.predicted["estimation"]
    after = est.tau - d.after.predicted["estimation"]
    rate = 1.0 / float(np.mean(np.diff(est.t)))
    page.heading("Figures (estimation data)")
    page.paragraph("Drag to zoom, double-click to zoom out, hover for values; click a legend entry to hide its curve.")
    for j, c in enumerate(est.coordinates):
        u = units[c]
        page.heading(f"Coordinate {c}", 3)
        residual = u.label("force", f"τ_meas − τ_model on {c}")
        page.figure(f"Residual on {c} against time", [line(est.t, before[:, j], BEFORE), line(est.t, after[:, j], AFTER)],
                    x="t (s)", y=residual, height=380)
        for signal, values in (("velocity", est.qd), ("position", est.q)):
            page.figure(f"Residual on {c} against its {signal}",
                        [points(values[:, j], before[:, j], BEFORE), points(values[:, j], after[:, j], AFTER)],
                        x=u.label(signal, f"{signal} of {c}"), y=residual, height=380)
        traces = htmlpage.spectrum_traces({BEFORE: spectrum(before[:, j], rate), AFTER: spectrum(after[:, j], rate)})
        peaks = [p["frequency_hz"] for p in d.where_before["coordinates"][c]["spectrum"]["peaks"]]
        page.figure(f"Residual spectrum on {c} (Welch)", traces, x="frequency (Hz)",
                    y="PSD of the residual" + (f" (({u.force})²/Hz)" if u.force else ""), log_y=True, height=380,
                    shapes=[{"type": "line", "xref": "x", "yref": "paper", "x0": p, "x1": p, "y0": 0, "y1": 1,
                             "line": {"dash": "dash", "width": 1}} for p in peaks],
                    caption=("Dashed: peaks of the nominal model's residual at " + ", ".join(f"{p:.3g}" for p in peaks)
                             + " Hz.") if peaks else "")
    for k, e in enumerate(effect_curves(d), start=1):
        a, found, c = e["accepted"], e["found"], e["coordinate"]
        u = units[c]
        order = np.argsort(e["x"], kind="stable")
        what = f"the model's {a.effect.refines} term and " if e["refined"] else ""
        axis = e["axis"]
        page.figure(f"Effect {k}: {found.label()} on {c}",
                    [points(e["x"], e["points"], f"data: final residual + {what}the fitted effect", color="grey"),
                     line(e["x"][order], e["curve"][order], f"fitted {found.label()}: {_parameters(a.effect, found, u)}",
                          color="#d62728", width=2)],
                    x="t (s)" if axis == "time" else u.label(axis, f"{axis} of {c}"),
                    y=u.label("force", (f"{a.effect.refines} friction" if e["refined"] else "generalized force of the effect")
                              + f" on {c}"), height=400)
