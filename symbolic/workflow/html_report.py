"""``symbolic diagnose --out DIR --html``: ``DIR/report.html``, the diagnosis as one self-contained page
(:mod:`symbolic.htmlpage`), written with report.md as one set.

The tables are read from the dictionary ``diagnose --json`` prints (``document``, :meth:`Diagnosis.to_dict`):
the gaps before and after (headline and per coordinate), the named effects with their parameters and σ, the
model file's values the patch changes, the corrections with their held-out gaps, the joint elasticity tests (two
encoders; the one-encoder variant's values), the modes before and after, the search judged on the response, what
the data's treatment explains, the bag's alignment — the sections of report.md, whose numbers are the same ones.
:func:`render_response` is the page of a diagnosis judged on the response alone. The figures draw what the PNGs draw, from the same arrays
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
from symbolic.htmlpage import Page, line, lookup, number, points
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
    corrections(page, r)
    elasticity(page, r)
    modes(page, r, "modes")
    if r.get("response") is not None:
        response(page, r, ("response",))
    findings(page, r)
    alignment(page, r)
    if r["patched_model"]:
        page.paragraph(f"Patched model file: {r['patched_model']}")
    page.items(r["notes"])
    _figures(page, d)
    return page.render()


# The sections below mirror report.md's (symbolic/workflow/report.py) and read only ``r``, the --json dictionary:
# report.md formats the same numbers from the objects that dictionary is made of (Diagnosis.to_dict), so the two
# show one set of values and the tests compare the page's with --json.


def corrections(page: Page, r: Mapping[str, Any]) -> None:
    """The model-file values the data move beyond 3σ and 10 % (report.md, "Corrections"), each with the held-out
    gap at the file's value and with the correction."""
    if not r["corrections"]:
        return
    page.heading("Corrections")
    page.items(c["summary"] for c in r["corrections"])
    page.table(["parameter", "model file", "data", "σ", "change", "σ away", "held-out gap at the file's value",
                "with the correction"],
               [[c["parameter"], number(r, "corrections", k, "nominal", digits=6), number(r, "corrections", k, "value", digits=6),
                 number(r, "corrections", k, "sigma", digits=3),
                 "—" if c.get("relative_change") is None else
                 number(r, "corrections", k, "relative_change", digits=3, signed=True, scale=100, unit="%"),
                 number(r, "corrections", k, "evidence", "sigmas", digits=3),
                 number(r, "corrections", k, "evidence", "held_out_gap_at_nominal", unit="%"),
                 number(r, "corrections", k, "evidence", "held_out_gap", unit="%")]
                for k, c in enumerate(r["corrections"])])


def elasticity(page: Page, r: Mapping[str, Any]) -> None:
    """Joint elasticity: the two-encoder test of each joint whose link side is logged (``joint_elasticity``), and
    the one-encoder variant among the effects found (report.md, "Joint elasticity")."""
    tests = r.get("joint_elasticity") or []
    single = [(k, f) for k, f in enumerate(r["found"]) if f["effect"] == "joint_elasticity" and f.get("variant") == "one_encoder"]
    if not tests and not single:
        return
    page.heading("Joint elasticity")
    if tests:
        page.heading("Two encoders", 3)
        page.paragraph("The motor side's equation with the deflection δ = q − q_l (stiffness k, damping d, rotor "
                       "inertia J_m) fitted on the estimation data and judged on the held-out force; errors "
                       "100·‖τ − τ̂‖/‖τ‖ (%). A dead band in the spring (backlash) is then tried against it.")
        rows = []
        for k, e in enumerate(tests):
            at = ("joint_elasticity", k)
            verdict = ("named" if e["named"] else e["reason"] or "not named")
            rows.append([e["coordinate"], number(r, *at, "deflection_rms"),
                         number(r, *at, "held_out_error_percent", "rigid", unit="%"),
                         number(r, *at, "held_out_error_percent", "motor_side", unit="%"),
                         number(r, *at, "held_out_error_percent", "elastic", unit="%"),
                         number(r, *at, "gain", digits=3, scale=100, unit="%"),
                         number(r, *at, "values", "stiffness", digits=6), number(r, *at, "sigmas", "stiffness", digits=3),
                         number(r, *at, "values", "damping", digits=6), number(r, *at, "sigmas", "damping", digits=3),
                         number(r, *at, "values", "motor_inertia", digits=6),
                         number(r, *at, "sigmas", "motor_inertia", digits=3),
                         number(r, *at, "link_mode_hz", digits=3, unit="Hz"), verdict])
        page.table(["coordinate", "deflection rms", "held-out error: rigid row", "motor side without spring",
                    "with spring", "held-out gain", "k", "σ(k)", "d", "σ(d)", "J_m", "σ(J_m)", "link mode", "verdict"],
                   rows)
        bands = [(k, e) for k, e in enumerate(tests) if e.get("backlash") is not None]
        if bands:
            page.table(["coordinate", "dead band width", "about", "held-out gain over the spring", "verdict"],
                       [[e["coordinate"], number(r, "joint_elasticity", k, "backlash", "width"),
                         number(r, "joint_elasticity", k, "backlash", "centre"),
                         number(r, "joint_elasticity", k, "backlash", "gain", digits=3, scale=100, unit="%"),
                         "named" if e["backlash"]["named"] else e["backlash"]["reason"]] for k, e in bands])
    if single:
        page.heading("One encoder", 3)
        page.paragraph("Found by the search from the motor encoder alone: the link's ringing on its spring in the motor "
                       "side's force (its parameters and σ are in the effects table above).")
        page.table(["coordinate", "parameter", "value", "σ"],
                   [[f["coordinate"], role, number(r, "found", k, "parameters", role, digits=6),
                     number(r, "found", k, "evidence", "sigma", role, digits=3) if role in f["evidence"]["sigma"] else "—"]
                    for k, f in single for role in f["parameters"]])


def modes(page: Page, r: Mapping[str, Any], key: str) -> None:
    """The linearised modes before and after (report.md's modes sentence), the plant alone and in the data's
    [controller] loop; paired in order of frequency, a mode only one side has stands alone."""
    found = r.get(key)
    if not found:
        return
    page.heading("Modes before and after")
    where = ", ".join(f"{c} = {v:.3g}" for c, v in (found.get("position") or {}).items())
    page.paragraph(f"Linearised at rest at the data's mean position ({where}): the model file's values (before) and "
                   "the patched values (after); frequency and damping ratio ζ.")
    rows = []
    for what, at in (("plant alone", (key,)), ("in the [controller] loop", (key, "closed_loop"))):
        block = lookup(r, at)
        if block is None:
            continue
        before, after = block.get("before") or [], block.get("after") or []
        for k in range(max(len(before), len(after))):
            row: list[Any] = [what, k + 1]
            for side, listed in (("before", before), ("after", after)):
                row += ([number(r, *at, side, k, "frequency_hz", unit="Hz"), number(r, *at, side, k, "damping_ratio", digits=3)]
                        if k < len(listed) else ["—", "—"])
            rows.append(row)
    if rows:
        page.table(["system", "mode", "before", "ζ before", "after", "ζ after"], rows)
    else:
        page.paragraph("No oscillatory mode before or after.")


def response(page: Page, r: Mapping[str, Any], at: tuple[str, ...], subject: str = "The patched model",
             start: str = "IDIM-LS") -> None:
    """The search judged on the response (report.md, "Judged on the response"): the simulation errors per signal and
    coordinate before and after, the corrections and effects it named with σ, every candidate tried."""
    s = lookup(r, at)
    page.heading("Judged on the response")
    page.paragraph(f"{subject} simulated in the experiment's [controller] loop, compared on "
                   f"{'force and position' if s['signals'] == 'both' else s['signals']}; each candidate's values fitted "
                   "by output error on the estimation data and judged on the held-out data. Errors are "
                   "100·‖measured − simulated‖/‖measured − mean‖ (%).")
    page.table(["signal", "coordinate", "estimation before", "estimation after", "held out before", "held out after"],
               [[signal, c, number(r, *at, "before", "estimation", signal, c, unit="%"),
                 number(r, *at, "after", "estimation", signal, c, unit="%"),
                 number(r, *at, "before", "validation", signal, c, unit="%"),
                 number(r, *at, "after", "validation", signal, c, unit="%")]
                for signal in s["before"]["validation"] for c in s["before"]["validation"][signal]])
    refit = s.get("refit")
    if refit is not None and "skipped" in refit:
        page.paragraph(f"Not run: {refit['skipped']}.")
        return
    if s["corrections"]:
        page.paragraph("Corrected through the response (written into the patched model):")
        page.table(["parameter", "kind", start, "value", "σ", "change"],
                   [[c["parameter"], c["kind"], number(r, *at, "corrections", k, "idim_ls", digits=6),
                     number(r, *at, "corrections", k, "value", digits=6), number(r, *at, "corrections", k, "sigma", digits=3),
                     "—" if c.get("relative_change") is None else
                     number(r, *at, "corrections", k, "relative_change", digits=3, signed=True, scale=100, unit="%")]
                    for k, c in enumerate(s["corrections"])])
    if s["named"]:
        page.paragraph("Named:")
        page.table(["effect", "quantity", "value", "held-out gain"], _judged_rows(r, (*at, "named"), s["named"]))
        if s["experiment_lines"]:
            page.paragraph("To declare in the experiment file:")
            page.code(s["experiment_lines"])
    elif not s["corrections"]:
        page.paragraph("Named: nothing.")
    tried = [(k, i, j) for k, round_ in enumerate(s["rounds"]) for i, j in enumerate(round_) if j.get("verdict") is not None]
    if tried:
        page.paragraph("Tried and not named:")
        rows: list[list[Any]] = []
        for k, i, j in tried:
            values = [n for n, v in j["parameters"].items() if isinstance(v, (int, float)) and not isinstance(v, bool)]
            gain = number(r, *at, "rounds", k, i, "held_out_gain", digits=3, scale=100, unit="%")
            for n_, name in enumerate(values or [None]):  # one row per fitted value: each number its own cell
                rows.append([j["label"] if n_ == 0 else "", name or "—",
                             "—" if name is None else number(r, *at, "rounds", k, i, "parameters", name, digits=4),
                             gain if n_ == 0 else "", j["verdict"] if n_ == 0 else ""])
        page.table(["candidate", "fitted", "value", "held-out gain", "why not named"], rows)


def _judged_rows(r: Mapping[str, Any], at: tuple[Any, ...], judged: list[Mapping[str, Any]]) -> list[list[Any]]:
    """One row per fitted value of each judged candidate, then one per σ: the σ are keyed by the fitted
    quantity's name in the model or the signal layer (``[sensors] tau_q delay``), not by the role, so each is
    shown under its own name."""
    rows: list[list[Any]] = []
    for k, j in enumerate(judged):
        first = True
        for name, v in j["parameters"].items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                rows.append([j["label"] if first else "", name, number(r, *at, k, "parameters", name, digits=6),
                             number(r, *at, k, "held_out_gain", digits=3, scale=100, unit="%") if first else ""])
                first = False
        for name in j.get("sigmas") or {}:
            rows.append(["", f"σ of {name}", number(r, *at, k, "sigmas", name, digits=3), ""])
    return rows


def findings(page: Page, r: Mapping[str, Any]) -> None:
    """What the data's treatment explains (report.md, "The data, not the model"): the gaps with the force as logged
    and as held over each sample, for the nominal model and (where checked) the patched one."""
    if not r.get("data_findings"):
        return
    page.heading("The data, not the model")
    for k, f in enumerate(r["data_findings"]):
        page.paragraph(f"{f['finding']}: {f['note']}.")
        rows = []
        for model, at in (("nominal", ("data_findings", k)), ("patched", ("data_findings", k, "patched"))):
            try:
                block = lookup(r, at)
            except (KeyError, IndexError, TypeError):
                continue
            for role, data in (("gap_estimation", "estimation"), ("gap_validation", "held out")):
                if isinstance(block, Mapping) and isinstance(block.get(role), Mapping):
                    rows.append([model, data, number(r, *at, role, "as_logged", unit="%"),
                                 number(r, *at, role, "held_force", unit="%")])
        if rows:
            page.table(["model", "data", "gap, force as logged", "force held over each sample"], rows)


def alignment(page: Page, r: Mapping[str, Any]) -> None:
    """The alignment of the bags read (:func:`symbolic.htmlpage.alignment`)."""
    htmlpage.alignment(page, r)


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


def render_response(d: Any, document: Mapping[str, Any] | None = None, drawn: Mapping[str, Any] | None = None) -> str:
    """The page of a diagnosis judged on the response alone (:class:`symbolic.workflow.unmeasured.ResponseDiagnosis`):
    the simulation errors before and after per signal and coordinate, the corrections and effects named with σ, the
    modes before and after, the bag's alignment, and per measured coordinate the held-out position and force
    measured and simulated (the model file as written, the patched model) and the force error's spectrum.
    ``document``: what ``--json`` prints (default ``d.to_dict()``); ``drawn``: the held-out signals
    (:func:`symbolic.workflow.unmeasured.curves`; no figures without them)."""
    htmlpage.require()
    page = Page(f"Diagnosis: {d.model.name}, judged on the response",
                document if document is not None else d.to_dict(), "symbolic diagnose")
    r = page.result
    page.paragraph(f"The data measure {', '.join(r['measured'])} and not {', '.join(r['unmeasured'])}: the model "
                   "can only be judged on its response, simulated in the experiment's [controller] loop with those "
                   f"coordinates from rest. Held out: {r['held_out']}.")
    page.heading("Simulation errors")
    page.paragraph("100·‖measured − simulated‖/‖measured − mean‖ (%): before, the model file as written; after, the "
                   "patched model simulated again with the signal values named declared.")
    page.table(["signal", "coordinate", "estimation before", "estimation after", "held out before", "held out after"],
               [[signal, c, number(r, "before", "estimation", signal, c, unit="%"),
                 number(r, "after", "estimation", signal, c, unit="%"),
                 number(r, "before", "validation", signal, c, unit="%"),
                 number(r, "after", "validation", signal, c, unit="%")]
                for signal in r["before"]["validation"] for c in r["before"]["validation"][signal]])
    response(page, r, ("response",), subject="The model file as written", start="model file")
    if r["kept"]:
        page.paragraph("Kept at the model file's value (the fitted value is not physical):")
        page.table(["parameter", "fitted", "why"], [[k["parameter"], number(r, "kept", i, "value", digits=6), k["reason"]]
                                                    for i, k in enumerate(r["kept"])])
    modes(page, r, "modes")
    alignment(page, r)
    if r["patched_model"]:
        page.paragraph(f"Patched model file: {r['patched_model']}")
    page.items(r["notes"])
    if drawn is not None:
        _response_figures(page, d, drawn)
    return page.render()


def _response_figures(page: Page, d: Any, drawn: Mapping[str, Any]) -> None:
    """Per measured coordinate (the signals of :func:`symbolic.workflow.unmeasured.curves`, which the PNGs draw)."""
    from symbolic.workflow.where import spectrum as welch

    units = coordinate_units(d.model.robot)
    t = drawn["t"]
    page.heading("Figures (held-out data)")
    page.paragraph("Drag to zoom, double-click to zoom out, hover for values; click a legend entry to hide its curve.")
    for c, signals in drawn["coordinates"].items():
        u = units[c]
        page.heading(f"Coordinate {c}", 3)
        for signal in ("position", "force"):
            traces = [line(t, y[signal], f"simulated, {run}", dash="dash") for run, y in signals["simulated"].items()]
            traces.append(line(t, signals["measured"][signal], "measured (as logged)", color="black", width=0.9))
            page.figure(f"Held-out {signal} of {c}: measured and simulated", traces, x="t (s)",
                        y=u.label(signal, f"{signal} of {c}"), height=380)
        spectra = {f"measured − simulated, {run}": welch(signals["measured"]["force"] - y["force"], drawn["rate"])
                   for run, y in signals["simulated"].items()}
        page.figure(f"Held-out simulated force error on {c} (Welch)", htmlpage.spectrum_traces(spectra),
                    x="frequency (Hz)", y="PSD of the force error" + (f" (({u.force})²/Hz)" if u.force else ""),
                    log_y=True, height=380)
