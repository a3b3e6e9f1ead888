"""``report.md``: the diagnosis as tables and figures a reviewer reads instead of the numbers."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from symbolic.data.times import time_windows
from symbolic.errors import ModelError
from symbolic.workflow.effects import NOT_SUPPORTED, joint_elasticity
from symbolic.workflow.result import Diagnosis
from symbolic.workflow.records import Candidate, Grouped, Judged
from symbolic.workflow.response import ResponseSearch


def _g(x: Any, digits: int = 4) -> str:
    if x is None:
        return "—"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def _roles(roles: dict[str, Any], sigmas: dict[str, Any] | None = None) -> str:
    parts = []
    for k, v in roles.items():
        s = (sigmas or {}).get(k)
        parts.append(f"{k} = {_g(v)}" + (f" ± {_g(s, 2)}" if s is not None else ""))
    return ", ".join(parts)


def _gap(value: float | None) -> str:
    return "—" if value is None else f"{value:.4g} %"


def _table(header: list[str], rows: list[list[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(_g(c) for c in row) + " |" for row in rows]
    return lines


def _verdict(c: Judged, chosen: Judged | None) -> str:
    if c is chosen:
        return "**accepted**"
    if not c.failed:
        return "qualifies, not chosen (another has a lower ΔBIC or ties with fewer parameters)"
    return "; ".join(c.failed)


def _candidate_row(c: Candidate, chosen: Judged | None) -> list[Any]:
    if c.status != "tested":
        return [c.effect.label(), c.coordinate, c.status, c.reason, "", "", "", "", ""]
    return [c.effect.label(), c.coordinate, _roles(c.roles), f"{100 * c.share:.3g} %", _g(c.p_value, 3),
            f"{100 * c.gain:.3g} %", f"{100 * c.stacked_share:.3g} % / {100 * c.stacked_gain:.3g} %", _g(c.delta_bic),
            _verdict(c, chosen)]


def _group_rows(g: Grouped, chosen: Judged | None) -> list[list[Any]]:
    """The group's line, then (when at least two members earned their place) one per member kept and dropped:
    figures on the member's own coordinate, from the group's fit against the fit without it. A group left
    with one member or none is one line (its members' own figures are the single candidates' above)."""
    if g.status != "tested":
        return [[g.group.label(), g.coordinate, g.status, g.reason, "", "", "", "", ""]]
    rows = [[g.group.label(), g.coordinate, f"{len(g.members)} members", f"{100 * g.share:.3g} %", _g(g.p_value, 3),
             f"{100 * g.gain:.3g} %", f"{100 * g.stacked_share:.3g} % / {100 * g.stacked_gain:.3g} %",
             _g(g.delta_bic), _verdict(g, chosen)]]
    for m, why in [(m, "kept") for m in g.members] + list(g.dropped):
        gain = "—" if m.held0 is None else f"{100 * m.gain:.3g} %"
        rows.append([f"↳ {m.effect.label()}", m.coordinate, _roles(m.roles), f"{100 * m.share:.3g} %", _g(m.p_value, 3),
                     gain, "", _g(m.delta_bic_own), why if why == "kept" else f"dropped: {why}"])
    return rows


def _corrections(d: Diagnosis) -> list[str]:
    """The model file's own values as the data re-identify them: corrections, every value changed, the modes."""
    lines = ["## Corrections", "",
             "The model file's own parameters, re-identified with the effects found: a value the data move beyond "
             "3σ and beyond 10 % is a correction (σ of the fit × the residual's autocorrelation time; only a "
             "parameter that one base parameter determines can be named, a combination is named as such).", ""]
    if d.corrections:
        lines += [f"* **{c['summary']}**" for c in d.corrections]
        lines += [""] + _table(["parameter", "model file", "data (± σ)", "change", "σ away",
                                "held-out gap at the file's value (with it)"],
                               [[c["parameter"], c["nominal"], f"{_g(c['value'])} ± {_g(c['sigma'], 2)}",
                                 "—" if c["relative_change"] is None else f"{100 * c['relative_change']:+.3g} %",
                                 _g(c["evidence"]["sigmas"], 3),
                                 f"{_g(c['evidence']['held_out_gap_at_nominal'])} % ({_g(c['evidence']['held_out_gap'])} %)"]
                                for c in d.corrections])
    else:
        lines.append("No model-file value moves beyond 3σ and 10 %.")
    lines.append("")
    if d.changes:
        lines += ["Values the patch changes:", ""]
        lines += _table(["parameter", "model file", "patched", "σ", "change", ""],
                        [[c["parameter"], c["nominal"], "removed" if c["status"] == "removed" else c["value"], c["sigma"],
                          "—" if c["relative_change"] is None else f"{100 * c['relative_change']:+.3g} %",
                          ("correction" if c["correction"] else "") + (f"kept: fitted {_g(c['fitted'])}, {c['reason']}"
                                                                       if c["status"] == "kept" else "")]
                         for c in d.changes])
        lines.append("")
    if d.modes is not None:
        mode = lambda ms: ", ".join(f"{m['frequency_hz']:.4g} Hz (ζ {m['damping_ratio']:.3g})" for m in ms) or "none"  # noqa: E731
        where = ", ".join(f"{c} = {v:.3g}" for c, v in d.modes["position"].items())
        lines += [f"Modes, linearised at rest at the data's mean position ({where}): the plant alone with the model "
                  f"file's values {mode(d.modes['before'])}; with the patched values {mode(d.modes['after'])}."]
        loop = d.modes.get("closed_loop")
        if loop is not None:
            lines += [f"In the data's [controller] loop: {mode(loop['before'])} → {mode(loop['after'])}."]
        lines.append("")
    return lines


def _elasticity(d: Diagnosis) -> list[str]:
    """The two-encoder test of each joint whose link-side position is logged (docs/workflow.md, "Joint elasticity")."""
    if not d.elasticity:
        return []
    lines = ["### Joint elasticity (two encoders)", "",
             "Where a joint logs its link-side position (`ql_<c>`) beside the motor side's (`q_<c>`), the motor side's "
             "equation τ = J_m·q̈ + Fv·q̇ + Fc·sgn(q̇) + b + k·δ + d·δ̇ (δ = q − q_l) is fitted on the estimation data "
             "and judged on the held-out force (a dead band in the spring, backlash, is then tried against it): the "
             "deflection must remove at least "
             f"{100 * d.search.settings.min_gain:g} % of the motor side's held-out residual power, k be positive and "
             f"{joint_elasticity.MIN_SIGMAS:g} σ from zero, J_m positive, and the elastic motor side predict the force "
             "at least as well as the rigid model's row. Held-out errors are 100·‖τ − τ̂‖/‖τ‖ (%).", ""]
    rows = [[e.coordinate, _g(e.deflection_rms), _g(e.errors["rigid"]), _g(e.errors["motor_side"]), _g(e.errors["elastic"]),
             f"{100 * e.gain:.3g} %",
             ", ".join(f"{k} = {_g(e.values[k])} ± {_g(e.sigmas[k], 2)}" for k in ("stiffness", "damping", "motor_inertia")),
             _elastic_verdict(e), _band(e.backlash)] for e in d.elasticity]
    lines += _table(["coordinate", "deflection rms", "rigid row", "motor side without spring", "with spring",
                     "held-out gain", "motor side (± σ)", "verdict", "dead band (backlash)"], rows)
    named = [e for e in d.elasticity if e.named]
    if named:
        lines += ["", "The patched model holds each named joint as Spong's elastic joint (a coordinate `<c>_flex`, the link "
                  "minus the motor, in the joint's DH entry; the transmission as a [[force]] on it; J_m as the drive's "
                  "rotor inertia). To simulate it, map the deflection in the experiment file (the lines below, added to its "
                  "[signals]); `identify` refuses its link equation (no force: the scale of its parameters rests on "
                  "noise) unless one of them is fixed:", "", "```toml"]
        reference = d.sets["estimation"].measurements.ref is not None
        lines += [line for e in named
                  for line in joint_elasticity.experiment_lines(e, reference)[1 if e is not named[0] else 0:]]
        lines += ["```"]
    lines.append("")
    return lines


def _elastic_verdict(e: Any) -> str:
    """"named" with the link's mode the fit implies, or why not."""
    if not e.named:
        return e.reason
    mode = e.frequency_hz(e.values["joint_inertia"])
    return "named" + (f" (link mode ≈ {mode:.3g} Hz)" if mode else "")


def _band(backlash: dict[str, Any] | None) -> str:
    """The dead band's test in a cell: its width, centre and held-out gain over the spring, and the verdict."""
    if backlash is None:
        return "not tried"
    head = f"width {_g(backlash['width'])} about {_g(backlash['centre'])}, removes {100 * backlash['gain']:.3g} %"
    return f"{head}: named" if backlash["named"] else f"{head}: {backlash['reason']}"


def _response(d: Diagnosis) -> list[str]:
    """The search judged on the response: errors per coordinate before and after, what it named, what it tried."""
    return [] if d.response is None else response_lines(d.response)


def response_lines(r: ResponseSearch, subject: str = "The patched model", start: str = "IDIM-LS") -> list[str]:
    """The section of :func:`_response` for ``r``: ``subject`` is what was simulated, ``start`` where a corrected
    value came from (the re-identification, or the model file)."""
    lines = ["## Judged on the response", "",
             f"{subject} simulated in the experiment's [controller] loop, compared on "
             f"{'force and position' if r.signals == 'both' else r.signals}; each candidate's values fitted by output error on the estimation data and judged on the "
             "held-out data (docs/workflow.md, \"Judged on the response\"). Errors are 100·‖measured − simulated‖"
             "/‖measured − mean‖ (%).", ""]
    rows = []
    for signal in r.before["validation"]:
        for c, before in r.before["validation"][signal].items():
            rows.append([signal, c, _g(r.before["estimation"][signal][c]), _g(r.after["estimation"][signal][c]),
                         _g(before), _g(r.after["validation"][signal][c])])
    lines += _table(["signal", "coordinate", "estimation before", "estimation after", "held out before",
                     "held out after"], rows)
    lines.append("")
    if r.refit is not None and "skipped" in r.refit:
        return lines + [f"Not run: {r.refit['skipped']}.", ""]
    for c in r.corrections:
        change = "" if c["relative_change"] is None else f", {100 * c['relative_change']:+.3g} %"
        lines += [f"Corrected through the response: the {c['kind']} `{c['parameter']}` {_g(c['idim_ls'])} ({start}) → "
                  f"{_g(c['value'])} ± {_g(c['sigma'])}{change} (written into the patched model).", ""]
    if r.named:
        lines += ["Named: " + "; ".join(f"`{j.candidate.label()}` ({_roles(j.roles)}; removes "
                                        f"{100 * j.gain:.3g} % of its held-out simulation error's power)"
                                        for j in r.named) + ".", ""]
        if r.experiment_lines():
            lines += ["To declare in the experiment file:", "", "```toml", *r.experiment_lines(), "```", ""]
    elif not r.corrections:
        lines += ["Named: nothing.", ""]
    tried = [j for round_ in r.rounds for j in round_ if j.verdict is not None]
    if tried:
        lines += _table(["candidate", "fitted", "held-out gain", "why not named"],
                        [[f"`{j.candidate.label()}`", _roles(j.roles) if j.roles else "—",
                          "—" if j.gain == float("-inf") else f"{100 * j.gain:.3g} %", j.verdict] for j in tried])
        lines.append("")
    return lines


def alignment_lines(found: dict[str, Any] | None) -> list[str]:
    """The alignment of each bag read (the JSON's ``"alignment"``, :func:`symbolic.data.bags.markdown_lines`)."""
    from symbolic.data.bags import markdown_lines

    return [] if not found else [line for role, a in found.items()
                                 for line in markdown_lines(a, role if len(found) > 1 else "")]


def markdown(d: Diagnosis) -> str:
    """The report (module docstring)."""
    est, val = d.sets["estimation"], d.sets["validation"]
    path = "simulated controller output" if d.simulated else "inverse dynamics at the measured (filtered) states"
    p = est.states.processing
    lines = [f"# Diagnosis of `{d.model.name}`", "",
             f"Estimation data: {est.measurements.source} ({est.measurements.samples} samples at {p.rate:g} Hz; "
             f"{est.samples} kept after the border of {p.border[0]}+{p.border[1]} samples and decimation by {p.decimation}). "
             f"Held out: {d.held_out}. τ_model is the {path}.", ""]
    lines += alignment_lines(d.alignment())
    lines += ["## Gap", "",
             "‖τ_meas − τ_model‖/‖τ_meas‖ over all coordinates and samples, the nominal model's own parameters "
             "re-identified on the estimation data (numbers written inline in the model file stay fixed).", ""]
    rows = [["estimation", f"{d.before.gap['estimation']:.4g} %", f"{d.after.gap['estimation']:.4g} %"],
            ["held out", f"{d.before.gap['validation']:.4g} %", f"{d.after.gap['validation']:.4g} %"]]
    lines += _table(["data", "before", "after"], rows)
    lines += ["", "Per coordinate (force):", ""]
    rows = [[c] + [_gap(fit.detail[role][c]) for role in ("estimation", "validation") for fit in (d.before, d.after)]
            for c in est.coordinates]
    lines += _table(["coordinate", "estimation before", "estimation after", "held out before", "held out after"], rows)
    if any(gap is None for gap in d.before.detail["estimation"].values()):
        lines += ["", "— an unactuated coordinate (τ = 0 logged: a beam's modal coordinate): no gap relative to its "
                      "force; its residual counts in the gap above."]
    if d.before.motion and d.after.motion:
        lines += ["", "Position and velocity of the simulation, 100·‖x_meas − x_sim‖/‖x_meas‖:", ""]
        rows = [[c, signal] + [f"{fit.motion[role][signal][c]:.4g} %" for role in ("estimation", "validation")
                               for fit in (d.before, d.after)]
                for c in est.coordinates for signal in ("position", "velocity")]
        lines += _table(["coordinate", "signal", "estimation before", "estimation after", "held out before",
                         "held out after"], rows)
    for finding in d.data_findings:
        lines += ["", f"**The data, not the model** (`{finding['finding']}`): {finding['note']}."]
    lines += ["", "## Where", "", f"Nominal model: {d.where_before['verdict']}.", ""]
    rows = []
    for c, r in d.where_before["coordinates"].items():
        rev = r["reversals"]
        rows.append([c, f"{100 * r['share']:.3g} %", _g(r["position"]["eta_squared"], 3), _g(r["velocity"]["eta_squared"], 3),
                     _g(r["acceleration"]["eta_squared"], 3), _g(r["sign"]["difference"]),
                     f"{_g(rev['rms_near'])} / {_g(rev['rms_away'])}",
                     ", ".join(f"{pk['frequency_hz']:.3g} Hz" for pk in r["spectrum"]["peaks"]) or "none",
                     _g(r["whiteness"]["p_value"], 2), _g(r["autocorrelation_time"], 3)])
    lines += _table(["coordinate", "share of residual power", "η² position", "η² velocity", "η² acceleration",
                     "mean(q̇>0) − mean(q̇<0)", "rms near / away from reversals", "spectral peaks",
                     "Ljung–Box p", "τ_int"], rows)
    lines += ["", "η² is the share of the residual's variance explained by its means in ten quantile bins of the state.", ""]
    time_rows = [[c] + [_g(w["rms"], 3) for w in r["time"]] for c, r in d.where_before["coordinates"].items()]
    if time_rows:
        windows = d.where_before["coordinates"][est.coordinates[0]]["time"]
        lines += ["Residual rms in time windows:", ""]
        lines += _table(["coordinate"] + time_windows([(w["start"], w["stop"]) for w in windows]), time_rows)
        lines.append("")
    lines += ["## Name", ""]
    s = d.search.settings
    held = "cross-validation over contiguous time blocks" if d.search.cross_validate else "the validation data"
    lines += [f"Forward selection over the catalogue. A candidate is judged on the rows of its own coordinate(s), not on "
              f"the stacked residual: it is accepted when its parameters are physical, its F-test there (n_eff from that "
              f"coordinate's residual autocorrelation) gives p below {s.alpha:g} divided by the round's trials (Bonferroni), it "
              f"removes at least {100 * s.min_gain:g} % of that coordinate's held-out residual power ({held}) and ΔBIC < 0 "
              f"on its rows; the lowest ΔBIC over all coordinates is accepted; candidates whose fits differ by at most "
              f"{s.tie:g} in twice the log-likelihood tie and the one with fewer parameters is named. A grouped hypothesis "
              f"(the same effect on every coordinate or a named group) is one candidate: its members are kept when each "
              f"earns its place on its own coordinate (physical, the held-out gain, ΔBIC < 0 there) and the group is judged "
              f"on their rows together. The stacked figures (share / held-out gain over all coordinates) are shown, not "
              f"judged. At the end, effects that later ones made insignificant are removed.", ""]
    searched = [f for f in d.found if "explained_share" in f.evidence]  # not the two encoders' test (below)
    if searched:
        rows = [[f.label(), f.coordinate, _roles(f.parameters, f.sigmas), _roles(f.model_parameters),
                 f"{100 * f.evidence['explained_share']:.3g} %", _g(f.evidence["p_value"], 3),
                 f"{100 * f.evidence['held_out_gain']:.3g} %", _g(f.evidence["delta_bic"]),
                 ", ".join(f"{x['effect']}{' (in ' + x['variant'] + ')' if 'variant' in x else ''} on {x['coordinate']}"
                           for x in f.evidence["alternatives"]) or "none",
                 f.evidence["group"]["name"] if "group" in f.evidence else "on its own"]
                for f in searched]
        lines += _table(["effect", "coordinate", "parameters (final fit, ± σ)", "written as", "explained (own)",
                         "p (own rows)", "held-out gain (own)", "ΔBIC (own rows)", "ties", "accepted"], rows)
    else:
        lines.append("**No significant missing effect.**" if not d.found else
                     "**No significant missing effect** beyond the joint elasticity below.")
    lines.append("")
    lines += _elasticity(d)
    header = ["effect", "coordinate", "parameters", "explained (own)", "p (own rows)", "held-out gain (own)",
              "stacked: explained / held-out gain", "ΔBIC", "verdict"]
    for r in d.search.rounds:
        title = f"Round {r.number}: " + (f"accepted {r.chosen.label()}" if r.chosen is not None else "nothing qualifies")
        lines += [f"### {title}", "", f"Bonferroni threshold {r.threshold:.3g}.", ""]
        lines += _table(header, [_candidate_row(c, r.chosen) for c in r.candidates])
        if r.groups:
            lines += ["", "Grouped hypotheses:", ""]
            lines += _table(header, [row for g in r.groups for row in _group_rows(g, r.chosen)])
        lines.append("")
    if NOT_SUPPORTED:
        lines += ["Not yet in the catalogue: " + "; ".join(f"`{k}` ({v})" for k, v in NOT_SUPPORTED.items()) + ".", ""]
    lines += _corrections(d)
    lines += ["## Patch", ""]
    if d.patched_path is not None or d.patched_text is not None:
        name = d.patched_path.name if d.patched_path is not None else f"{d.model.name}_patched.toml"
        lines += [f"`{name}`: the model file with " + (f"{len(d.found)} effect(s) added" if d.found else "no effect added")
                  + "; the model's own parameters that the data determine carry their re-identified values. "
                  "It loads and derives (the shrink below re-derives it).", ""]
    lines += ["## Shrink", "", f"After patching: {d.where_after['verdict']}.", ""]
    lines += _response(d)
    for note in d.notes:
        lines.append(f"* {note}")
    if d.notes:
        lines.append("")
    if d.figures:
        lines += ["## Figures", ""]
        lines += [f"![{f.stem}]({f.name})" for f in d.figures]
        lines.append("")
    return "\n".join(lines).rstrip("\n") + "\n"


def response_markdown(d: Any) -> str:
    """The report of a diagnosis judged on the response alone (:class:`symbolic.workflow.unmeasured.ResponseDiagnosis`):
    the data, the errors before and after per coordinate (recomputed on the patched model), what was named, the
    modes, the notes."""
    r = d.response
    lines = [f"# Diagnosis of `{d.model.name}`, judged on the response", "",
             f"The data measure {', '.join(f'`{c}`' for c in d.measured)} and not "
             f"{', '.join(f'`{c}`' for c in d.unmeasured)}. Held out: {d.held_out}.", ""]
    lines += alignment_lines(d.alignment)
    lines += ["## Simulation errors", "",
             "100·‖measured − simulated‖/‖measured − mean‖ (%), the model file as written and the patched model "
             "simulated again (with the signal values named declared).", ""]
    rows = [[signal, c] + [_g(d.before[role][signal][c]) + " → " + _g(d.after[role][signal][c])
                           for role in ("estimation", "validation")]
            for signal in d.before["validation"] for c in d.before["validation"][signal]]
    lines += _table(["signal", "coordinate", "estimation", "held out"], rows)
    lines.append("")
    lines += response_lines(r, subject="The model file as written", start="model file")
    if d.modes is not None:
        lines += ["## Modes", "", f"Linearised at rest at the data's mean position: {d.modes.get('summary', '')}.", ""]
    if d.patched_path is not None:
        lines += ["## Patched model", "", f"`{d.patched_path.name}` holds the corrected values.", ""]
    if d.figures:
        lines += ["## Figures", ""] + [f"![{p.stem}]({p.name})" for p in d.figures] + [""]
    if d.notes:
        lines += ["## Notes", ""] + [f"- {n}." if not n.endswith(".") else f"- {n}" for n in d.notes] + [""]
    return "\n".join(lines)


def write_folder(folder: Path, files: dict[str, bytes], patched_text: str | None, patched_path: Path | None) -> None:
    """``files`` and the patched model, where there is one, into ``folder``: all or nothing
    (:func:`symbolic.export.write_files`); a folder that cannot take them is the ``--out`` error."""
    from symbolic.export import ExportError, write_files

    if patched_text is not None and patched_path is not None:
        files = {**files, patched_path.name: patched_text.encode("utf-8")}
    try:
        write_files(files, folder)
    except ExportError as error:
        raise ModelError(str(folder), "--out", str(error)) from None
