"""Events judged against the siblings (symbolic.fleet.siblings, docs/fleet.md "Events and systematic misfits").

Fleets of six robots of the two-link arm, six daily logs each of the same test cycle (tests/fleet_cases.py,
``cycle_fleet``): the forces come from the hand-written equations of tests/reference_integrator.py, not from
symbolic, and the truth — the machines' Stribeck friction on q2, which the model lacks, at the cycle's slow
reversal of q2; r04's collision; r02's and r03's drifts — is written there and here only. The campaign sees
the model file, the logs and the campaign file. The campaigns run with ``workers=0`` (the judgement is the
client's; tests/test_fleet.py shows a cluster gives the same files).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from symbolic import fleet
from symbolic.fleet import execution
from symbolic.fleet.siblings import verdict

import fleet_cases

TRUTH = fleet_cases.CYCLE_TRUTH


def run(folder: Path, **kinds) -> tuple:
    """The campaign of a cycle fleet, and the number of events the logs' own verdicts gave (before the siblings)."""
    path = fleet_cases.cycle_fleet(folder, **kinds)
    own: list[int] = []
    judge = execution.judge_bursts

    def counting(rows, campaign):
        own.append(sum(1 for r in rows for b in r.get("bursts") or [] if not b["recurs"]))
        return judge(rows, campaign)

    execution.judge_bursts = counting
    try:
        return fleet.run(fleet.load(path), folder / "out", workers=0, figures=False), own[0]
    finally:
        execution.judge_bursts = judge


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    return run(tmp_path_factory.mktemp("shared"))


def test_the_prediction_interval_test_alarms_at_its_rate_when_logs_are_alike() -> None:
    # the log's level and its m siblings' drawn alike (log-normal): p < a in a fraction a of the draws (exact for
    # the prediction interval; the spread's floor only lowers it), within three binomial standard deviations
    rng = np.random.default_rng(7)
    n = 6000
    for m in (4, 5, 30):
        draws = np.exp(rng.normal(0.4, 0.3, (n, m + 1)))
        p = np.array([verdict(row[0], row[1:]).p_value for row in draws])
        for a in (0.05, 0.01, 0.001):
            assert np.sum(p < a) <= a * n + 3 * np.sqrt(a * n), (m, a, np.mean(p < a))
        assert np.sum(p < 0.05) >= 0.05 * n - 3 * np.sqrt(0.05 * n)  # not conservative by far either


def test_a_shared_misfit_is_reported_once_and_the_collision_is_the_one_event(shared) -> None:
    outcome, own = shared
    assert own == 37  # each log's own verdict: the misfit in all 36 logs and the collision
    (event,) = outcome.events
    robot, index, start, end = TRUTH["event"]
    assert (event["robot"], event["log"]) == (robot, f"logs/{robot}_2024-03-0{4 + index}.csv")
    assert abs(event["start"] - start) < 0.06 and abs(event["end"] - end) < 0.06
    assert set(event["siblings"]["q2"]) == {"own", "fleet"}  # judged against both
    (misfit,) = outcome.misfits
    coordinate, _ = TRUTH["misfit"]
    assert misfit["coordinates"] == [coordinate] and misfit["model"] == "arm"
    assert misfit["logs"] == misfit["of"] == 36 and len(misfit["robots"]) == 6
    assert abs(misfit["cycle_time"] - fleet_cases.slow_reversal()) < 0.5
    assert abs(misfit["state"][f"qd_{coordinate}"]) < 0.05  # where q2 reverses
    assert misfit["ratio"] >= 4.0  # the campaign's burst ratio
    flagged = {(d.series.robot, d.series.parameter): d for d in outcome.drifts if d.flagged}
    assert set(flagged) == set(TRUTH["drift"])  # the drifts are still drifts
    for key, (kind, size) in TRUTH["drift"].items():
        assert flagged[key].kind == kind and flagged[key].fit.relative == pytest.approx(size, abs=0.05)
    assert not [o for o in outcome.outliers if o.flagged] and not outcome.errors


def test_the_misfit_is_in_the_report_and_the_json_once(shared) -> None:
    outcome, _ = shared
    report = Path(outcome.files[0]).parent.joinpath("report.md").read_text()
    section = report.split("## Systematic misfits of the model")[1].split("##")[0]
    assert section.count("\n* ") == 1 and "36 of 36 logs of 6 robots" in section and "symbolic diagnose" in section
    assert report.split("## Events")[1].split("##")[0].count("| r04 |") == 1
    summary = json.loads(json.dumps(outcome.to_dict()))
    assert len(summary["events"]) == 1 and len(summary["misfits"]) == 1
    table = Path(outcome.files[0]).parent.joinpath("results.csv").read_text()
    assert sum(1 for line in table.splitlines()[1:] if " s on q" in line) == 1  # the events column


def test_logs_that_share_no_cycle_time_are_matched_by_state(tmp_path: Path) -> None:
    outcome, own = run(tmp_path, shifted=True)
    assert own >= 30
    (event,) = outcome.events
    assert event["robot"] == TRUTH["event"][0]
    (misfit,) = outcome.misfits
    assert misfit["coordinates"] == ["q2"] and misfit["cycle_time"] is None and misfit["logs"] >= 30
    assert {(d.series.robot, d.series.parameter) for d in outcome.drifts if d.flagged} == set(TRUTH["drift"])


def test_a_fleet_with_nothing_shared_and_no_event_reports_nothing(tmp_path: Path) -> None:
    outcome, own = run(tmp_path, misfit=False, event=False, drift=False)
    assert own == 0 and not outcome.events and not outcome.misfits
    assert not [d for d in outcome.drifts if d.flagged] and not [o for o in outcome.outliers if o.flagged]


def test_a_task_the_cluster_lost_is_an_error_row_for_each_of_its_logs() -> None:
    from symbolic.fleet.execution import _results
    from symbolic.fleet.tasks import Job

    class Lost:
        def result(self):
            raise OSError("worker died")

    group = [Job(str(k), "r", f"logs/{k}.csv", "/nonexistent", "", "", "", None) for k in range(3)]
    rows = _results(Lost(), group)
    assert [r["key"] for r in rows] == ["0", "1", "2"] and all(not r["cacheable"] for r in rows)
    assert rows[1]["error"] == "logs/1.csv: the cluster could not run this log: OSError: worker died"


def test_a_simulate_campaign_judges_the_simulations_residual(tmp_path: Path) -> None:
    # five robots of the axis under PD (tests/reference_integrator.py's exact stick/slip loop), one log each:
    # the model (the machines' values) in the log's controller; a quiet fleet, every log judged, nothing found
    from models import axis
    from reference_integrator import write_axis_experiment

    (tmp_path / "axis.toml").write_text(axis())
    lines = ['[task]', 'kind = "simulate"', '']
    for k in range(5):
        experiment = write_axis_experiment(tmp_path / f"r{k}", counts=2**16, seconds=2.0, force_noise=0.01, seed=k)
        lines += ["[[robot]]", f'id = "r{k}"', 'model = "axis.toml"', "[[robot.log]]",
                  f'file = "{experiment.relative_to(tmp_path).as_posix()}"', "time = 2024-03-04T08:00:00Z", ""]
    (tmp_path / "fleet.toml").write_text("\n".join(lines))
    outcome = fleet.run(fleet.load(tmp_path / "fleet.toml"), tmp_path / "out", workers=0, figures=False)
    assert not outcome.errors and all(r["task"] == "simulate" for r in outcome.rows)
    assert not outcome.events and not outcome.misfits
    kept = [json.loads(p.read_text()) for p in (tmp_path / "out" / "cache").glob("*/*.json")]
    assert len(kept) == 5 and all(k["profile"]["bins"] > 10 and k["profile"]["coordinates"] == ["q"] for k in kept)
