"""``DIR/report.md`` of a campaign and its figures, and the lines the command prints (docs/fleet.md, "Report").

Input: an :class:`~symbolic.fleet.execution.Outcome`. Output: {file name: bytes} — ``report.md``, a figure per
drifting parameter (``drift_<robot>_<parameter>.png``: the estimates against time with σ bars and the
fitted trend or step) and ``fleet_gap.png`` (every log's gap against time, per robot) — and notes (figures
skipped without matplotlib). The text depends on the results only (no run times, no paths but the logs'
names relative to the campaign file), so the same campaign gives the same report.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from symbolic.description.robot import Directional, Robot
from symbolic.errors import MatplotlibMissing
from symbolic.fleet.drift import Drift
from symbolic.fleet.events import describe
from symbolic.writing import safe_stem

MARGINS = {"left": 0.14, "right": 0.97, "bottom": 0.13, "top": 0.91}
"""The figures' margins (fractions of 7 × 4 in), fixed: Matplotlib's tight_layout measured every text twice and took
40 % of the report's time, which a campaign of short logs waits for (bench/results/fleet.md)."""
ROLES = {"viscous": "viscous friction", "coulomb": "Coulomb friction", "offset": "force offset"}


def labels(robot: Robot) -> dict[str, str]:
    """{parameter: "Coulomb friction on q2"} for the friction coefficients of ``robot``; its [parameters]
    description for the others that have one."""
    out = {p.name: p.description for p in robot.parameters if p.description}
    for friction in robot.frictions:
        for role, name in ROLES.items():
            value = getattr(friction, role)
            parts = [("", value)] if not isinstance(value, Directional) else [
                (" (q̇ > 0)", value.positive), (" (q̇ < 0)", value.negative)]
            for suffix, expression in parts:
                if expression is not None and str(expression) in {p.name for p in robot.parameters}:
                    out[str(expression)] = f"{name} on {friction.coordinate}{suffix}"
    return out


def named(parameter: str, label: str | None) -> str:
    return f"{label} ({parameter})" if label else parameter


def _date(iso: str | None) -> str:
    return "" if not iso else dt.datetime.fromisoformat(iso).strftime("%Y-%m-%d %H:%M")


def _span(days: float) -> str:
    if days >= 14:
        return f"{days / 7:.3g} weeks"
    if days >= 1:
        return f"{days:.3g} days"
    return f"{days * 24:.3g} hours"


def drift_line(d: Drift, label: str | None) -> str:
    """``r07, Coulomb friction on q3 (Fc3): up 38.2 % over 6 weeks (trend, p = 2.1e-09)``."""
    fit = d.fit
    way = "up" if fit.change > 0 else "down"
    size = f"{abs(100 * fit.relative):.3g} %" if math.isfinite(fit.relative) else f"by {abs(fit.change):.4g} from 0"
    when = (f"step between {_date(fit.detail['before_step'])} and {_date(fit.detail['after'])}" if d.kind == "step"
            else f"trend over {_span(float(np.ptp(d.series.days)))}")
    return f"{d.series.robot}, {named(d.series.parameter, label)}: {way} {size} ({when}, {len(d.series.values)} logs, " \
           f"p = {fit.p_value:.2g})"


def outlier_line(o, label: str | None) -> str:
    way = "above" if o.level > o.siblings else "below"
    return (f"{o.robot}, {named(o.parameter, label)}: {o.level:.5g} ± {o.sigma:.2g}, {abs(100 * o.relative):.3g} % {way} "
            f"its {o.count} siblings' {o.siblings:.5g} (spread {o.spread:.2g}; p = {o.p_value:.2g})")


def misfit_line(m: dict[str, Any]) -> str:
    """``arm, q2 at 0.130 s of the cycle (q_q1 = 0.3, ...): 36 of 36 logs of 6 robots, RMS 6.1× ...``."""
    where = f" at {m['cycle_time']:.3f} s of the cycle" if m.get("cycle_time") is not None else ""
    state = ", ".join(f"{k} = {v:.3g}" for k, v in m["state"].items())
    robots = len(m["robots"])
    return (f"{m['model']}, {', '.join(m['coordinates'])}{where}" + (f" (state {state})" if state else "")
            + f": {m['logs']} of {m['of']} logs of {robots} robot{'s' if robots != 1 else ''}, RMS {m['ratio']:.3g}× "
            f"the log's residual (median; {m['ratio_range'][0]:.3g}–{m['ratio_range'][1]:.3g}), peak {m['peak']:.4g}")


DIAGNOSE = ("a misfit of the model at that phase, not an event: `symbolic diagnose MODEL LOG --validate LOG2` on two "
            "of those logs names what the model lacks (docs/workflow.md)")


def summary(outcome) -> list[str]:
    """The lines ``symbolic campaign`` prints."""
    every = _labels(outcome)
    lines = [f"{len(outcome.rows)} logs of {len(outcome.campaign.robots)} robots: {outcome.computed} computed, "
             f"{outcome.cached} from the cache, {len(outcome.errors)} could not be processed"]
    lines += [f"drift: {drift_line(d, every[d.series.robot].get(d.series.parameter))}" for d in outcome.drifts if d.flagged]
    lines += [f"outlier: {outlier_line(o, every[o.robot].get(o.parameter))}" for o in outcome.outliers if o.flagged]
    lines += [f"event: {e['robot']} {e['log']}: {describe(e)}" for e in outcome.events]
    lines += [f"misfit: {misfit_line(m)} ({DIAGNOSE})" for m in outcome.misfits]
    lines += [f"error: {r['robot']}: {r['error']}" for r in outcome.errors]
    if not any(d.flagged for d in outcome.drifts) and not any(o.flagged for o in outcome.outliers) and \
            not outcome.events and not outcome.misfits:
        lines.append("no drift, no outlier, no event, no misfit")
    return lines


def _labels(outcome) -> dict[str, dict[str, str]]:
    return {r.id: labels(r.robot) for r in outcome.campaign.robots}


def render(outcome, figures: bool = True, html: bool = False) -> tuple[dict[str, bytes], list[str]]:
    """``report.md`` and the figures as bytes by file name, and notes (module docstring); ``html``: report.html and
    a page per robot too (:mod:`symbolic.fleet.html_report`)."""
    pictures: dict[str, bytes] = {}
    notes: list[str] = []
    if figures:
        try:
            pictures = draw(outcome)
        except MatplotlibMissing as missing:
            notes.append(str(missing))
    pages: dict[str, bytes] = {}
    if html:
        from symbolic.fleet import html_report

        pages = html_report.render(dataclasses.replace(outcome, notes=tuple(notes)))
    return {"report.md": markdown(outcome, pictures, notes).encode("utf-8"), **pictures, **pages}, notes


def figure_name(d: Drift) -> str:
    return f"drift_{safe_stem(d.series.robot)}_{safe_stem(d.series.parameter)}.png"


def markdown(outcome, pictures: Mapping[str, bytes], notes: list[str]) -> str:
    campaign = outcome.campaign
    every = _labels(outcome)
    a = campaign.analysis
    flagged = [d for d in outcome.drifts if d.flagged]
    different = [o for o in outcome.outliers if o.flagged]
    events = outcome.events
    out = [f"# Campaign {campaign.name}", ""]
    if campaign.description:
        out += [campaign.description, ""]
    kinds = sorted({r.task.kind for r in campaign.robots})
    out += [f"{len(outcome.rows)} logs of {len(campaign.robots)} robots ({', '.join(kinds)}); "
            f"{len(outcome.errors)} could not be processed. {len(outcome.drifts)} series (robot × parameter) tested "
            f"for drift, {len(outcome.outliers)} robot parameters against their siblings'; a fleet without drift, "
            f"outlier or event is flagged with probability at most α = {a.alpha:g} (Bonferroni), and a change or "
            f"difference must be at least {100 * a.min_change:g} % (docs/fleet.md).", ""]
    out += ["## Drift", ""]
    if not flagged:
        out += ["No parameter drifts.", ""]
    for d in flagged:
        out += [f"* {drift_line(d, every[d.series.robot].get(d.series.parameter))}"]
        if figure_name(d) in pictures:
            out += ["", f"  ![{d.series.robot} {d.series.parameter}]({figure_name(d)})", ""]
    out += ["", "## Outliers", ""]
    out += ["No robot differs from its siblings."] if not different else \
        [f"* {outlier_line(o, every[o.robot].get(o.parameter))}" for o in different]
    out += ["", "## Events", ""]
    if not events:
        out += ["No residual burst that differs from the siblings' logs at its phase."]
    else:
        out += ["| robot | log | log time | window (s) | coordinates | peak | RMS / log's residual | the siblings there |",
                "|---|---|---|---|---|---|---|---|"]
        for e in events:
            c = max(e["size"], key=lambda k: e["size"][k]["ratio"])
            out.append(f"| {e['robot']} | {e['log']} | {_date(e['time'])} | {e['start']:.3f}–{e['end']:.3f} | "
                       f"{', '.join(e['coordinates'])} | {e['size'][c]['peak']:.4g} on {c} | {e['ratio']:.3g} | "
                       f"{siblings_cell(e, c)} |")
    out += ["", "## Systematic misfits of the model", ""]
    if not outcome.misfits:
        out += ["No burst is shared by the siblings' logs."]
    else:
        out += ["Bursts that the logs of a model share at the same phase of the cycle (or state), each reported once "
                "here rather than as events in every log: the model lacks something there. `symbolic diagnose MODEL LOG "
                "--validate LOG2` on two of those logs names what (docs/workflow.md; the misfit's phase must be in the "
                "held-out data, which by default is the log's last fifth).", ""]
        out += [f"* {misfit_line(m)}; e.g. {', '.join(m['examples'])}" for m in outcome.misfits]
    out += ["", "## Logs that could not be processed", ""]
    out += ["None."] if not outcome.errors else [f"* {r['robot']}: {r['error']}" for r in outcome.errors]
    out += ["", "## Fleet", "", *fleet_table(outcome), ""]
    if "fleet_gap.png" in pictures:
        out += ["![the gap of every log](fleet_gap.png)", ""]
    out += notes
    return "\n".join(out).rstrip() + "\n"


def siblings_cell(event: dict[str, Any], coordinate: str) -> str:
    """``own 5 logs 1.6×, p = 4e-06; fleet 30 logs 1.5×, p = 5e-19`` (their level at the event's phase, as a
    windowed RMS ratio), or why the log's own verdict stands."""
    judged = (event.get("siblings") or {}).get(coordinate)
    if not judged:
        return "none to compare: the log's own verdict"
    return "; ".join(f"{name} {v['logs']} logs {v['median_ratio']:.2g}×, p = {v['p_value']:.1g}"
                     for name, v in judged.items())


def fleet_table(outcome) -> list[str]:
    """Per robot: model, logs, first and last, the median gap, and what was flagged."""
    lines = ["| robot | model | logs | first | last | median gap (%) | drifting | outlier in | events | errors |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for robot in outcome.campaign.robots:
        rows = [r for r in outcome.rows if r["robot"] == robot.id]
        times = sorted(r["time"] for r in rows if r.get("time"))
        gaps = [r["gap"] for r in rows if r["status"] == "ok" and isinstance(r.get("gap"), (int, float))]
        drifting = ", ".join(d.series.parameter for d in outcome.drifts if d.flagged and d.series.robot == robot.id)
        other = ", ".join(o.parameter for o in outcome.outliers if o.flagged and o.robot == robot.id)
        count = sum(len(r.get("events") or []) for r in rows)
        errors = sum(r["status"] != "ok" for r in rows)
        gap = f"{np.median(gaps):.3g}" if gaps else ""
        lines.append(f"| {robot.id} | {robot.robot.name} | {len(rows)} | {_date(times[0]) if times else ''} | "
                     f"{_date(times[-1]) if times else ''} | {gap} | {drifting} | {other} | {count} | {errors} |")
    return lines


def draw(outcome) -> dict[str, bytes]:
    """The figures (module docstring) as PNG bytes; :class:`MatplotlibMissing` without matplotlib."""
    from symbolic.plotting import figure_class, png_bytes

    Figure = figure_class()
    every = _labels(outcome)
    out = {}
    for d in outcome.drifts:
        if not d.flagged:
            continue
        s = d.series
        fig = Figure(figsize=(7, 4))
        ax = fig.add_subplot(1, 1, 1)
        ax.errorbar(s.days, s.values, yerr=s.sigmas, fmt="o", ms=4, capsize=3, label="estimate ± σ")
        fit = d.fit
        if d.kind == "step":
            k = s.times.index(fit.detail["after"])
            ax.plot(s.days[:k], np.full(k, fit.before), "-", label="level before")
            ax.plot(s.days[k:], np.full(len(s.days) - k, fit.detail["level_after"]), "-", label="level after")
        else:
            ax.plot(s.days, fit.before + fit.detail["slope_per_day"] * (s.days - s.days[0]), "-", label="trend")
        ax.set_xlabel("days since the campaign's first log")
        ax.set_ylabel(s.parameter)
        ax.set_title(f"{s.robot}: {named(s.parameter, every[s.robot].get(s.parameter))}", fontsize=10)
        ax.legend(loc="best")
        fig.subplots_adjust(**MARGINS)
        out[figure_name(d)] = png_bytes(fig, dpi=90)
    fig = Figure(figsize=(7, 4))
    ax = fig.add_subplot(1, 1, 1)
    for robot in outcome.campaign.robots:
        points = [(r["days"], r["gap"]) for r in outcome.rows if r["robot"] == robot.id and r["status"] == "ok"
                  and r.get("days") is not None and isinstance(r.get("gap"), (int, float))]
        if points:
            days, gaps = zip(*points)
            ax.plot(days, gaps, "o-", ms=3, label=robot.id)
    ax.set_xlabel("days since the campaign's first log")
    ax.set_ylabel("gap ‖τ − τ_model‖/‖τ‖ (%)")
    if ax.lines and len(outcome.campaign.robots) <= 12:
        ax.legend(loc="best", fontsize=7)
    fig.subplots_adjust(**MARGINS)
    out["fleet_gap.png"] = png_bytes(fig, dpi=90)
    return out
