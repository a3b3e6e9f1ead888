"""``symbolic campaign --out DIR --html``: ``DIR/report.html`` (the fleet) linking one page per robot,
``DIR/robot_<id>.html``, each self-contained (:mod:`symbolic.htmlpage`), written with report.md and results.csv
as one set.

One source: the campaign page is built from the dictionary ``campaign --json`` prints
(:meth:`Outcome.to_dict`) with the rows of results.csv beside it (``rows``: one per log, as the table writes
them); a robot's page from the same dictionary narrowed to that robot (its rows, its drifts and outliers).
The figures draw those rows: every log's gap against time, and per parameter the estimates with σ against
time with the fitted trend or step where one is flagged. Run times and cache counts are left out
(:data:`symbolic.htmlpage.VOLATILE`): the same campaign gives the same pages.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from symbolic import htmlpage
from symbolic.fleet.events import describe
from symbolic.htmlpage import Page, line, number, points
from symbolic.writing import safe_stem

NAME = htmlpage.REPORT


def page_name(robot: str) -> str:
    return f"robot_{safe_stem(robot)}.html"


def render(outcome: Any) -> dict[str, bytes]:
    """{file name: bytes}: the campaign's page and one page per robot (module docstring)."""
    htmlpage.require()
    document = {**outcome.to_dict(), "rows": [dict(r) for r in outcome.rows]}
    out = {NAME: _campaign(outcome, document).encode("utf-8")}
    for robot in outcome.campaign.robots:
        out[page_name(robot.id)] = _robot(outcome, document, robot).encode("utf-8")
    return out


def _campaign(outcome: Any, document: Mapping[str, Any]) -> str:
    campaign = outcome.campaign
    page = Page(f"Campaign {campaign.name}", document, "symbolic campaign")
    r = page.result
    if campaign.description:
        page.paragraph(campaign.description)
    page.table(["", "count"], [["logs", number(r, "logs")], ["robots", number(r, "robots")],
                               ["drift series tested", number(r, "tested", "series")],
                               ["outlier tests", number(r, "tested", "outlier_tests")]])
    page.heading("Robots (one page each)")
    rows = []
    for robot in campaign.robots:
        index = [i for i, row in enumerate(r["rows"]) if row["robot"] == robot.id]
        gaps = [r["rows"][i].get("gap") for i in index if r["rows"][i]["status"] == "ok"]
        gaps = [g for g in gaps if isinstance(g, (int, float))]
        rows.append([robot.id, robot.robot.name, len(index), f"{np.median(gaps):.3g}" if gaps else "",
                     sum(d["robot"] == robot.id for d in r["drift"]), sum(o["robot"] == robot.id for o in r["outliers"]),
                     sum(e["robot"] == robot.id for e in r["events"]), sum(x["robot"] == robot.id for x in r["errors"])])
    page.table(["robot", "model", "logs", "median gap (%)", "drifting", "outlier in", "events", "errors"], rows)
    for robot in campaign.robots:
        page.link(f"{robot.id}: its logs, parameters with σ and figures", page_name(robot.id))
    _drift(page, r, list(range(len(r["drift"]))))
    _outliers(page, r, list(range(len(r["outliers"]))))
    page.heading("Events (residual bursts)")
    if r["events"]:
        page.table(["robot", "log", "start (s)", "end (s)", "coordinates", "RMS / log's residual", "what"],
                   [[e["robot"], e["log"], number(r, "events", k, "start", digits=5), number(r, "events", k, "end", digits=5),
                     ", ".join(e["coordinates"]), number(r, "events", k, "ratio", digits=3), describe(e)]
                    for k, e in enumerate(r["events"])])
    else:
        page.paragraph("No residual bursts.")
    page.heading("Logs that could not be processed")
    page.items([f"{e['robot']}: {e['error']}" for e in r["errors"]] or ["None."])
    page.heading("Figures")
    traces = []
    for robot in campaign.robots:
        days, gaps = _gaps(r["rows"], robot.id)
        if days:
            traces.append({**line(days, gaps, robot.id), "mode": "lines+markers"})
    page.figure("The gap of every log", traces, x="days since the campaign's first log",
                y="gap ‖τ − τ_model‖/‖τ‖ (%)")
    return page.render()


def _gaps(rows: list[Mapping[str, Any]], robot: str) -> tuple[list[float], list[float]]:
    points_ = [(row["days"], row["gap"]) for row in rows if row["robot"] == robot and row["status"] == "ok"
               and row.get("days") is not None and isinstance(row.get("gap"), (int, float))]
    return [p[0] for p in points_], [p[1] for p in points_]


def _drift(page: Page, r: Mapping[str, Any], index: list[int]) -> None:
    page.heading("Drift")
    if not index:
        page.paragraph("No parameter drifts.")
        return
    page.table(["robot", "parameter", "kind", "relative change", "change", "level before", "p-value", "logs"],
               [[r["drift"][k]["robot"], r["drift"][k]["parameter"], r["drift"][k]["kind"],
                 number(r, "drift", k, "relative_change", digits=3, signed=True, scale=100, unit="%"), number(r, "drift", k, "change", digits=4),
                 number(r, "drift", k, "level_before", digits=5), number(r, "drift", k, "p_value", digits=2),
                 number(r, "drift", k, "logs")] for k in index])


def _outliers(page: Page, r: Mapping[str, Any], index: list[int]) -> None:
    page.heading("Outliers among siblings")
    if not index:
        page.paragraph("No robot differs from its siblings.")
        return
    page.table(["robot", "parameter", "level", "σ", "siblings' mean", "relative difference", "p-value"],
               [[r["outliers"][k]["robot"], r["outliers"][k]["parameter"], number(r, "outliers", k, "level", digits=5),
                 number(r, "outliers", k, "sigma", digits=2), number(r, "outliers", k, "siblings_mean", digits=5),
                 number(r, "outliers", k, "relative_difference", digits=3, signed=True, scale=100, unit="%"),
                 number(r, "outliers", k, "p_value", digits=2)] for k in index])


def _robot(outcome: Any, document: Mapping[str, Any], robot: Any) -> str:
    mine = {"campaign": document["campaign"], "robot": robot.id, "model": robot.robot.name,
            "rows": [row for row in document["rows"] if row["robot"] == robot.id],
            "drift": [d for d in document["drift"] if d["robot"] == robot.id],
            "outliers": [o for o in document["outliers"] if o["robot"] == robot.id],
            "events": [e for e in document["events"] if e["robot"] == robot.id]}
    page = Page(f"Campaign {document['campaign']}: robot {robot.id} ({robot.robot.name})", mine, "symbolic campaign")
    r = page.result
    page.link("← the campaign", NAME)
    page.heading("Logs")
    page.table(["log", "time", "status", "gap (%)", "samples", "duration (s)", "note"],
               [[row["log"], row.get("time") or "", row["status"],
                 number(r, "rows", i, "gap") if isinstance(row.get("gap"), (int, float)) else "—",
                 number(r, "rows", i, "samples") if row.get("samples") is not None else "—",
                 number(r, "rows", i, "duration") if row.get("duration") is not None else "—",
                 row.get("error") or ""] for i, row in enumerate(r["rows"])])
    names = list(dict.fromkeys(p["name"] for row in r["rows"] for p in row.get("parameters") or []))
    if names:
        page.heading("Parameters, log by log (value ± σ)")
        rows = []
        for i, row in enumerate(r["rows"]):
            for k, p in enumerate(row.get("parameters") or []):
                rows.append([row["log"], p["name"], number(r, "rows", i, "parameters", k, "value", digits=6),
                             number(r, "rows", i, "parameters", k, "sigma", digits=3), p.get("at_bound") or ""])
        page.table(["log", "parameter", "value", "σ", "at a bound"], rows)
    effects = [(i, k, e) for i, row in enumerate(r["rows"]) for k, e in enumerate(row.get("effects") or [])]
    if effects:
        page.heading("Effects found (diagnose)")
        page.table(["log", "effect", "coordinate", "parameters"],
                   [[r["rows"][i]["log"], e["effect"], e["coordinate"],
                     ", ".join(f"{n} = {v:.4g}" for n, v in e["parameters"].items() if v is not None)] for i, k, e in effects])
    simulated = [(i, row) for i, row in enumerate(r["rows"]) if row.get("simulation")]
    if simulated:
        page.heading("Simulation: relative errors (%)")
        page.table(["log", "coordinate", "signal", "relative error (%)"],
                   [[row["log"], c, s, number(r, "rows", i, "simulation", c, s)]
                    for i, row in simulated for c, signals in row["simulation"].items() for s in signals])
    _drift(page, r, list(range(len(r["drift"]))))
    _outliers(page, r, list(range(len(r["outliers"]))))
    if r["events"]:
        page.heading("Events")
        page.items(f"{e['log']}: {describe(e)}" for e in r["events"])
    page.heading("Figures")
    days, gaps = _gaps(r["rows"], robot.id)
    page.figure(f"The gap of {robot.id}'s logs", [{**line(days, gaps, robot.id), "mode": "lines+markers"}],
                x="days since the campaign's first log", y="gap ‖τ − τ_model‖/‖τ‖ (%)", height=340)
    flagged = {(d["parameter"]): d for d in r["drift"]}
    for name in names:
        found = [(row["days"], p["value"], p["sigma"]) for row in r["rows"] for p in row.get("parameters") or []
                 if p["name"] == name and row.get("days") is not None]
        if not found:
            continue
        x, y, s = (np.asarray(v, dtype=float) for v in zip(*found))
        traces = [points(x, y, "estimate ± σ", size=7, error=s)]
        drift = flagged.get(name)
        caption = ""
        if drift is not None:
            moments = {row["time"]: row["days"] for row in r["rows"] if row.get("time") and row.get("days") is not None}
            traces.append(_fitted(drift, x, moments))
            caption = (f"Flagged: {drift['kind']}, {100 * drift['relative_change']:+.3g} % (p = {drift['p_value']:.2g})."
                       if drift.get("relative_change") is not None else f"Flagged: {drift['kind']}.")
        page.figure(f"{name} of {robot.id}, log by log", traces, x="days since the campaign's first log", y=name,
                    height=340, caption=caption)
    return page.render()


def _fitted(drift: Mapping[str, Any], days: np.ndarray, moments: Mapping[str, float]) -> dict[str, Any]:
    """The flagged fit over the estimates: the trend line, or the levels before and after the step (from the log
    whose time is the drift's ``after``)."""
    if drift["kind"] == "step" and drift.get("level_after") is not None and drift.get("after") in moments:
        levels = np.where(days >= moments[drift["after"]], drift["level_after"], drift["level_before"])
        return {**line(days, levels, "fitted step: level before, level after"), "line": {"shape": "hv", "width": 2}}
    slope = drift.get("slope_per_day") or 0.0
    return line(days, drift["level_before"] + slope * (days - days[0]), "fitted trend", width=2)
