"""Campaigns over a fleet (symbolic.fleet, docs/fleet.md): the campaign file's checks, the drift, outlier and
event statistics on cases with a known truth, and a synthetic fleet (tests/fleet_cases.py) run on a local
Dask cluster and on real ``dask scheduler`` + ``dask worker`` processes with identical results.

The truth of each case is written here and in tests/fleet_cases.py; the code that searches sees only the
model file, the logs and the campaign file.
"""

from __future__ import annotations

import csv
import io
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from symbolic import fleet
from symbolic.data import DataError
from symbolic.fleet import campaign as campaigns
from symbolic.fleet.campaign import Analysis, Events
from symbolic.fleet.drift import Series, drifts
from symbolic.fleet.events import bursts
from symbolic.fleet.outliers import outliers

import fleet_cases

ROOT = Path(__file__).resolve().parents[1]
DASK = fleet.available()
needs_dask = pytest.mark.skipif(not DASK, reason="dask.distributed is not installed: pip install 'symbolic[fleet]'")

# --- the campaign file ---------------------------------------------------------------------------------------------

GOOD = '''name = "plant"
[task]
kind = "identify"
[[robot]]
id = "r1"
model = "emps"
logs = "logs/*.csv"
time = { from = "name", pattern = '(\\d{8})', format = "%Y%m%d" }
'''


def write_campaign(folder: Path, text: str) -> Path:
    (folder / "logs").mkdir(parents=True, exist_ok=True)
    (folder / "logs" / "a_20240301.csv").write_text("t,q_q,tau_q\n0,0,0\n")
    path = folder / "plant.toml"
    path.write_text(text)
    return path


def test_a_good_campaign_file_is_read(tmp_path: Path) -> None:
    c = campaigns.load(write_campaign(tmp_path, GOOD))
    (robot,) = c.robots
    assert robot.id == "r1" and robot.robot.name == "emps" and robot.task.kind == "identify"
    (log,) = robot.logs
    assert log.name == "logs/a_20240301.csv" and log.time.isoformat() == "2024-03-01T00:00:00+00:00"
    # without a pattern, the format is found in the name
    plain = campaigns.load(write_campaign(tmp_path, GOOD.replace("pattern = '(\\d{8})', ", "")))
    assert plain.robots[0].logs[0].time.isoformat() == "2024-03-01T00:00:00+00:00"


@pytest.mark.parametrize("change, key, words", [
    (("name =", "nmae ="), "nmae", ["unknown key", "allowed", "did you mean 'name'"]),
    (('kind = "identify"', 'kind = "fit"'), "[task] kind", ["unknown task 'fit'", "identify, diagnose, simulate"]),
    (('kind = "identify"', 'kind = "identify"\nmethod = "lsq"'), "[task] method", ["unknown method", "wls, ols"]),
    (('kind = "identify"', 'kind = "diagnose"\neffects = ["colomb"]'), "[task] effects", ["colomb", "catalogue"]),
    (('kind = "identify"', 'kind = "identify"\n[task.identification]\nbandwith = 3'),
     "[task] identification bandwith", ["unknown key", "did you mean 'bandwidth'"]),
    (('model = "emps"', 'model = "emsp"'), "[[robot]] 'r1' model", ["no model file", "built-in"]),
    (('logs = "logs/*.csv"', 'logs = "log/*.csv"'), "[[robot]] 'r1' logs", ["matches no file"]),
    (("time = {", "tim = {"), "[[robot]] 'r1' tim", ["unknown key", "did you mean 'time'"]),
    (("pattern = '(\\d{8})'", "pattern = '(\\d{8'"), "[[robot]] 'r1' time pattern", ["not a regular expression"]),
    (('from = "name"', 'from = "mtime"'), "[[robot]] 'r1' time from", ['"name"', '"column"']),
    (('id = "r1"', 'id = "r 1"'), "[[robot]] #1 id", ["letters, digits"]),
    (("[task]", "[analysis]\nalpha = 2\n[task]"), "[analysis] alpha", ["expected a number in (0, 1)"]),
])
def test_a_bad_campaign_file_is_one_line_naming_file_key_and_what_is_allowed(tmp_path, change, key, words) -> None:
    path = write_campaign(tmp_path, GOOD.replace(*change))
    with pytest.raises(DataError) as raised:
        campaigns.load(path)
    message = str(raised.value)
    assert "\n" not in message and message.startswith(f"{path}: {key}: "), message
    for word in words:
        assert word in message, message


def test_a_log_whose_name_gives_no_time_is_a_row_with_its_error(tmp_path: Path) -> None:
    from symbolic.fleet.execution import plan
    from symbolic.fleet.store import Store

    path = write_campaign(tmp_path, GOOD)
    (tmp_path / "logs" / "b_undated.csv").write_text("t,q_q,tau_q\n0,0,0\n")
    rows, jobs = plan(campaigns.load(path), Store(tmp_path / "out"))
    assert [r["log"] for r in rows] == ["logs/a_20240301.csv", "logs/b_undated.csv"] and len(jobs) == 1
    assert rows[1]["status"] == "error" and "does not match the pattern" in rows[1]["error"]


def test_a_robot_listed_twice_and_a_missing_time_are_refused(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"\[\[robot\]\] 'r1' id: used twice"):
        campaigns.load(write_campaign(tmp_path, GOOD + "[[robot]]" + GOOD.split("[[robot]]")[1]))
    no_time = GOOD.replace("time = {", "# time = {")
    with pytest.raises(DataError, match=r"\[\[robot\]\] 'r1' time: missing: say how each log's date"):
        campaigns.load(write_campaign(tmp_path, no_time))


URDF = ('<robot name="r"><link name="l0"/>'
        '<link name="l1"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
        '</inertial></link><link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/><inertia ixx="0.01" '
        'iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/><axis xyz="0 0 1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.3 0 0"/>'
        '<axis xyz="0 0 1"/></joint></robot>')


def test_a_urdf_model_with_a_chain_is_read_alike_by_the_campaign_and_a_worker(tmp_path: Path) -> None:
    from symbolic.fleet.execution import plan
    from symbolic.fleet.store import Store
    from symbolic.fleet.tasks import model_for

    (tmp_path / "arm.urdf").write_text(URDF)
    text = GOOD.replace('model = "emps"', 'model = "arm.urdf"\ntip = "l1"')
    c = campaigns.load(write_campaign(tmp_path, text))
    assert c.robots[0].robot.coordinates == ("j1",)
    _, (job,) = plan(c, Store(tmp_path / "out"))
    assert model_for(job).robot.coordinates == ("j1",)  # the worker checks its reading has the client's digest
    with pytest.raises(DataError, match="root and tip choose a chain of a URDF model"):
        campaigns.load(write_campaign(tmp_path, GOOD.replace('model = "emps"', 'model = "emps"\ntip = "l1"')))


# --- drift, outliers, events on cases with a known truth ------------------------------------------------------------

def series(robot: str, values, sigma: float, days=None, name: str = "Fc") -> Series:
    days = np.arange(len(values), dtype=float) * 7 if days is None else np.asarray(days, float)
    times = tuple(f"2024-01-{1 + k:02d}T00:00:00+00:00" for k in range(len(values)))
    return Series(robot, name, days, np.asarray(values, float), np.full(len(values), sigma), times,
                  tuple(f"log{k}" for k in range(len(values))))


def test_drift_finds_a_trend_and_a_step_and_nothing_in_noise() -> None:
    rng = np.random.default_rng(1)
    sigma = 0.01
    quiet = [series(f"q{k}", 1.0 + sigma * rng.normal(size=8), sigma) for k in range(200)]
    rising = series("wear", 1.0 + 0.25 * np.linspace(0, 1, 8) + sigma * rng.normal(size=8), sigma)
    jump = series("step", np.r_[np.ones(5), 1.3 * np.ones(3)] + sigma * rng.normal(size=8), sigma)
    found = {d.series.robot: d for d in drifts([*quiet, rising, jump], Analysis()) if d.flagged}
    assert set(found) == {"wear", "step"}
    assert found["wear"].kind == "trend" and found["wear"].fit.relative == pytest.approx(0.25, abs=0.03)
    assert found["step"].kind == "step" and found["step"].fit.detail["after"] == jump.times[5]
    assert found["step"].fit.relative == pytest.approx(0.30, abs=0.03)


def test_drift_uses_the_scatter_when_the_estimates_vary_more_than_their_sigma() -> None:
    # the σ the identification reports is 10 times too small (a log-to-log variation it does not hold):
    # without the Birge ratio every one of these constant series would be a drift
    rng = np.random.default_rng(2)
    scattered = [series(f"s{k}", 1.0 + 0.02 * rng.normal(size=8), 0.002) for k in range(100)]
    assert not [d for d in drifts(scattered, Analysis()) if d.flagged]


def test_a_small_significant_change_is_not_flagged() -> None:
    # 2 % over the logs with σ = 0.01 %: significant, but below min_change (5 %)
    tiny = series("tiny", 1.0 + 0.02 * np.linspace(0, 1, 8), 1e-4)
    (d,) = drifts([tiny], Analysis())
    assert d.trend.p_value < 1e-10 and not d.flagged


def test_outliers_name_the_robot_that_differs_and_not_one_that_drifts() -> None:
    rng = np.random.default_rng(3)
    sigma = 0.002
    group = [series(f"r{k}", 0.5 * (1 + 0.01 * rng.normal()) + sigma * rng.normal(size=6), sigma, name="m2")
             for k in range(5)]
    heavy = series("heavy", 0.65 + sigma * rng.normal(size=6), sigma, name="m2")
    wearing = series("wearing", 0.5 * (1 + 0.5 * np.linspace(0, 1, 6)) + sigma * rng.normal(size=6), sigma, name="m2")
    every = [*group, heavy, wearing]
    tested = drifts(every, Analysis())
    assert {d.series.robot for d in tested if d.flagged} == {"wearing"}
    found = outliers(every, tested, {s.robot: "arm" for s in every}, Analysis())
    assert {o.robot for o in found if o.flagged} == {"heavy"}


def test_events_find_a_burst_with_its_window_and_nothing_in_noise_or_spikes() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(0, 20, 0.002)
    residual = rng.normal(size=(len(t), 2))
    residual[::997, 1] += 60.0  # isolated spikes (a Coulomb step at each velocity reversal): not events
    assert bursts(t, residual, ("a", "b"), Events()) == []
    inside = (t >= 7.3) & (t <= 7.5)
    residual[inside, 0] += 12 * np.sin(np.pi * (t[inside] - 7.3) / 0.2)
    (event,) = bursts(t, residual, ("a", "b"), Events())
    assert event["coordinates"] == ["a"]
    assert abs(event["start"] - 7.3) < 0.03 and abs(event["end"] - 7.5) < 0.03
    assert 7.3 < event["peak_time"] < 7.5 and event["size"]["a"]["peak"] > 8
    quiet = [bursts(t, rng.normal(size=(len(t), 3)), ("a", "b", "c"), Events()) for _ in range(20)]
    assert not any(quiet)


def test_a_burst_that_recurs_at_the_same_state_is_the_models_not_an_event() -> None:
    # a periodic excitation (5 s): the same burst at the same phase in two periods is a misfit of that state
    rng = np.random.default_rng(5)
    t = np.arange(0, 20, 0.002)
    motion = np.column_stack([np.sin(2 * np.pi * t / 5), np.cos(2 * np.pi * t / 5)])
    residual = rng.normal(size=(len(t), 1))
    for start in (6.3, 11.3):
        inside = (t >= start) & (t <= start + 0.2)
        residual[inside, 0] += 12.0
    assert bursts(t, residual, ("a",), Events(), motion) == []
    assert len(bursts(t, residual, ("a",), Events())) == 2  # without the states, two bursts
    inside = (t >= 2.0) & (t <= 2.2)  # once, at another state: an event
    residual[inside, 0] += 12.0
    (event,) = bursts(t, residual, ("a",), Events(), motion)
    assert abs(event["start"] - 2.0) < 0.03


def test_the_command_without_dask_says_how_to_install_it(monkeypatch, capsys) -> None:
    from symbolic import cli

    monkeypatch.setattr(fleet, "available", lambda: False)
    assert cli.main(["campaign", "plant.toml", "--out", "out"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "pip install 'symbolic[fleet]'" in err and "--workers 0" in err


@pytest.mark.parametrize("arguments, allowed", [(["--workers", "-1"], "0 (one log at a time in this process)"),
                                                (["--workers", "0", "--scheduler", "tcp://h:1"], "a positive number")])
def test_a_bad_worker_count_is_one_line_naming_what_is_allowed(arguments, allowed, capsys) -> None:
    from symbolic import cli

    assert cli.main(["campaign", "plant.toml", "--out", "out", *arguments]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--workers" in err and allowed in err


# --- the synthetic fleet on Dask ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def synthetic(tmp_path_factory) -> Path:
    return fleet_cases.fleet(tmp_path_factory.mktemp("fleet"))


@pytest.fixture(scope="module")
def local(synthetic: Path, tmp_path_factory):
    out = tmp_path_factory.mktemp("local") / "out"
    return out, fleet.run(fleet.load(synthetic), out, workers=2)


def without_run_times(text: str) -> list[dict[str, str]]:
    rows = list(csv.DictReader(io.StringIO(text)))
    for row in rows:
        row.pop("seconds")
    return rows


@needs_dask
def test_the_local_cluster_reports_the_truth_and_nothing_else(local) -> None:
    out, outcome = local
    truth = fleet_cases.TRUTH
    assert len(outcome.rows) == len(fleet_cases.ROBOTS) * fleet_cases.LOGS and outcome.computed == len(outcome.rows)
    flagged = {(d.series.robot, d.series.parameter): d for d in outcome.drifts if d.flagged}
    assert set(flagged) == set(truth["drift"])
    for key, (kind, size) in truth["drift"].items():
        assert flagged[key].kind == kind and flagged[key].fit.relative == pytest.approx(size, abs=0.05)
    step = flagged[("r03", "Fv1")].fit.detail["after"]
    assert step.startswith(f"{fleet_cases.START + truth['step_log'] * fleet_cases.WEEK:%Y-%m-%d}")
    robot, parameter, _ = truth["outlier"]
    different = [o for o in outcome.outliers if o.flagged]
    assert {o.robot for o in different} == {robot}
    # m2 enters the base parameters of the inertia and first moments (ZZR1 = ZZ1 − 0.16(M1 + M2), MXR2 = MX2 + 0.3·M2, ...)
    assert {o.parameter for o in different} <= {"ZZR1", "MXR1", "ZZR2", "MXR2"} and len(different) >= 2
    (event,) = outcome.events
    assert not outcome.misfits  # the model is the machines' law: nothing shared by the siblings' logs
    robot, index, start, end = truth["event"]
    moment = fleet_cases.START + index * fleet_cases.WEEK
    assert event["robot"] == robot and event["log"] == f"logs/{robot}_{moment:%Y-%m-%d}.csv"
    assert abs(event["start"] - start) < 0.06 and abs(event["end"] - end) < 0.06
    assert set(event["coordinates"]) == {"q1", "q2"}
    # the burst is left out of that log's second fit: its friction estimate is as certain as the other logs'
    sigmas = {r["log"]: {p["name"]: p["sigma"] for p in r["parameters"]} for r in outcome.rows if r["robot"] == robot}
    others = [s["Fv1"] for log, s in sigmas.items() if log != event["log"]]
    assert sigmas[event["log"]]["Fv1"] < 1.5 * np.median(others)
    (error,) = outcome.errors
    robot, index = truth["bad"]
    moment = fleet_cases.START + index * fleet_cases.WEEK
    assert error["robot"] == robot and error["log"] == f"logs/{robot}_{moment:%Y-%m-%d}.csv"
    assert "column 'tau_q1': value nan" in error["error"]
    names = {p.name for p in outcome.files}
    assert {"results.csv", "report.md", "drift_r02_Fc2.png", "drift_r03_Fv1.png"} <= names
    report = (out / "report.md").read_text()
    assert "r02, Coulomb friction on q2 (Fc2): up" in report and f"| {truth['event'][0]} |" in report


@needs_dask
def test_a_real_scheduler_and_worker_give_the_same_results(synthetic: Path, local, tmp_path: Path) -> None:
    local_out, _ = local
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    address_file = tmp_path / "scheduler.json"
    started = []
    try:
        started.append(subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--scheduler-file", str(address_file),
                                         "--port", "0", "--no-dashboard"], env=env, cwd=tmp_path,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        deadline = time.monotonic() + 60
        while not address_file.exists():
            assert time.monotonic() < deadline and started[0].poll() is None, "the dask scheduler did not start"
            time.sleep(0.2)
        started.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", "--scheduler-file", str(address_file),
                                         "--nworkers", "1", "--nthreads", "1", "--no-dashboard"], env=env, cwd=tmp_path,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        import json

        address = json.loads(address_file.read_text())["address"]
        out = tmp_path / "remote"
        done = subprocess.run([sys.executable, "-m", "symbolic", "campaign", str(synthetic), "--out", str(out),
                               "--scheduler", address, "--workers", "1", "--json"], env=env, cwd=tmp_path,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        summary = json.loads(done.stdout)
        assert summary["computed"] == summary["logs"] and len(summary["errors"]) == 1
    finally:
        for process in reversed(started):
            os.killpg(process.pid, signal.SIGTERM)
            process.wait(timeout=30)
    assert without_run_times((out / "results.csv").read_text()) == \
        without_run_times((local_out / "results.csv").read_text())
    assert (out / "report.md").read_text() == (local_out / "report.md").read_text()


@needs_dask
def test_one_at_a_time_without_dask_gives_the_clusters_results(synthetic: Path, local, tmp_path: Path,
                                                                monkeypatch, capsys) -> None:
    """``--workers 0`` runs every log in this process, Dask neither needed nor used: the same table and report."""
    from symbolic import cli
    from symbolic.fleet import execution

    def no_cluster(*args, **kwargs):
        raise AssertionError("--workers 0 went to Dask")

    local_out, _ = local
    monkeypatch.setattr(fleet, "available", lambda: False)
    monkeypatch.setattr(execution, "_on_cluster", no_cluster)
    out = tmp_path / "serial"
    assert cli.main(["-q", "campaign", str(synthetic), "--out", str(out), "--workers", "0"]) == 0, capsys.readouterr().err
    assert without_run_times((out / "results.csv").read_text()) == \
        without_run_times((local_out / "results.csv").read_text())
    assert (out / "report.md").read_text() == (local_out / "report.md").read_text()


@needs_dask
def test_a_rerun_computes_only_what_is_new(synthetic: Path, local, tmp_path: Path) -> None:
    local_out, first = local
    folder = tmp_path / "fleet"
    shutil.copytree(synthetic.parent, folder)
    out = tmp_path / "out"
    shutil.copytree(local_out, out)
    again = fleet.run(fleet.load(folder / synthetic.name), out)
    assert (again.computed, again.cached) == (0, len(first.rows))  # the bad file's error is kept too: its bytes decide it
    assert (out / "results.csv").read_text() == (local_out / "results.csv").read_text()
    logs = folder / "logs"
    shutil.copy(logs / "r01_2024-03-04.csv", logs / "r01_2024-05-06.csv")  # the same bytes under a new name
    text = (logs / "r01_2024-03-11.csv").read_text().replace(",0.", ",-0.", 1)  # one value changed
    (logs / "r01_2024-05-13.csv").write_text(text)
    more = fleet.run(fleet.load(folder / synthetic.name), out)
    assert more.computed == 1 and len(more.rows) == len(first.rows) + 2
