"""``report.md``: the diagnosis as tables and figures a reviewer reads instead of the numbers."""

from __future__ import annotations

from typing import Any

from symbolic.workflow.effects import NOT_SUPPORTED
from symbolic.workflow.result import Diagnosis
from symbolic.workflow.search import Candidate


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


def _candidate_row(c: Candidate, chosen: Candidate | None) -> list[Any]:
    if c.status != "tested":
        return [c.effect.label(), c.coordinate, c.status, c.reason, "", "", "", ""]
    if c is chosen:
        verdict = "**accepted**"
    elif not c.failed:
        verdict = "qualifies, not chosen (another has a lower ΔBIC or ties with fewer parameters)"
    else:
        verdict = "; ".join(c.failed)
    return [c.effect.label(), c.coordinate, _roles(c.roles), f"{100 * c.share:.3g} %", _g(c.p_value, 3),
            f"{100 * c.gain:.3g} %", _g(c.delta_bic), verdict]


def markdown(d: Diagnosis) -> str:
    """The report (module docstring)."""
    est, val = d.sets["estimation"], d.sets["validation"]
    path = "simulated controller output" if d.simulated else "inverse dynamics at the measured (filtered) states"
    p = est.states.processing
    lines = [f"# Diagnosis of `{d.model.name}`", "",
             f"Estimation data: {est.measurements.source} ({est.measurements.samples} samples at {p.rate:g} Hz; "
             f"{est.samples} kept after the border of {p.border[0]}+{p.border[1]} samples and decimation by {p.decimation}). "
             f"Held out: {d.held_out}. τ_model is the {path}.", "",
             "## Gap", "",
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
        lines += _table(["coordinate"] + [f"{w['start']:.3g}–{w['stop']:.3g} s" for w in windows], time_rows)
        lines.append("")
    lines += ["## Name", ""]
    s = d.search.settings
    held = "cross-validation over contiguous time blocks" if d.search.cross_validate else "the validation data"
    lines += [f"Forward selection over the catalogue; a candidate is accepted when its parameters are physical, its "
              f"F-test (autocorrelation-corrected) gives p below {s.alpha:g} divided by the round's trials (Bonferroni), it "
              f"removes at least {100 * s.min_gain:g} % of the held-out residual power ({held}) and ΔBIC < 0; the "
              f"lowest ΔBIC is accepted; candidates whose fits differ by at most {s.tie:g} in n_eff·|ln(RSS₁/RSS₂)| tie "
              f"and the one with fewer parameters is named. At the end, effects that later ones made insignificant are removed.", ""]
    if d.found:
        rows = [[f.label(), f.coordinate, _roles(f.parameters, f.sigmas), _roles(f.model_parameters),
                 f"{100 * f.evidence['explained_share']:.3g} %", _g(f.evidence["p_value"], 3),
                 f"{100 * f.evidence['held_out_gain']:.3g} %", _g(f.evidence["delta_bic"]),
                 ", ".join(f"{x['effect']}{' (in ' + x['variant'] + ')' if 'variant' in x else ''} on {x['coordinate']}"
                           for x in f.evidence["alternatives"]) or "none"]
                for f in d.found]
        lines += _table(["effect", "coordinate", "parameters (final fit, ± σ)", "written as", "explained", "p",
                         "held-out gain", "ΔBIC", "ties"], rows)
    else:
        lines.append("**No significant missing effect.**")
    lines.append("")
    for r in d.search.rounds:
        title = f"Round {r.number}: " + (f"accepted {r.accepted.candidate.label()}" if r.accepted else "nothing qualifies")
        lines += [f"### {title}", "", f"Bonferroni threshold {r.threshold:.3g}.", ""]
        lines += _table(["effect", "coordinate", "parameters", "explained", "p", "held-out gain", "ΔBIC", "verdict"],
                        [_candidate_row(c, r.accepted.candidate if r.accepted else None) for c in r.candidates])
        lines.append("")
    if NOT_SUPPORTED:
        lines += ["Not yet in the catalogue: " + "; ".join(f"`{k}` ({v})" for k, v in NOT_SUPPORTED.items()) + ".", ""]
    lines += ["## Patch", ""]
    if d.patched_path is not None or d.patched_text is not None:
        name = d.patched_path.name if d.patched_path is not None else f"{d.model.name}_patched.toml"
        lines += [f"`{name}`: the model file with " + (f"{len(d.found)} effect(s) added" if d.found else "no effect added")
                  + "; the model's own parameters that the data determine carry their re-identified values. "
                  "It loads and derives (the shrink below re-derives it).", ""]
    lines += ["## Shrink", "", f"After patching: {d.where_after['verdict']}.", ""]
    for note in d.notes:
        lines.append(f"* {note}")
    if d.notes:
        lines.append("")
    if d.figures:
        lines += ["## Figures", ""]
        lines += [f"![{f.stem}]({f.name})" for f in d.figures]
        lines.append("")
    return "\n".join(lines).rstrip("\n") + "\n"
