"""The timing of the force a log holds, on logs written by ``symbolic simulate`` itself.

``simulate`` writes, at t_k, the controller's output held over [t_k, t_k+1) (zero-order hold). Read from its
positions alone (velocity and acceleration by central differences, as a measured log is), the states at t_k
see the force's mean over the sample, (τ_k−1 + τ_k)/2: the written force leads the motion by half a sample.
A 2-link arm (Fv1 = 0.5, Fv2 = 0.3 N·m·s/rad, Coulomb on both joints) simulated in a PD loop, its log read
that way, diagnosed with the model that lacks joint 2's viscous friction: on the nominal model the missing
friction hides the lead (the held-force check removes less than the effect size), on the patched model the
lead is most of what is left. Before the check ran again on the patched model, diagnose named the viscous
term (0.2953) and wrote Fv1 = 0.4795 ± 0.0042 (−4.1 %, 5σ) into the patched model without a word; now
0.3003 and 0.50022 ± 0.0004.
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import symbolic
from symbolic.data import Settings
from symbolic.simulation import simulate
from symbolic.simulation.simulator import EXPERIMENT_NAME
from symbolic.workflow import diagnose

sys.path.insert(0, str(Path(__file__).parent))
from models import arm  # noqa: E402

TRUTH = "Fv1 = 0.5\nFv2 = 0.3\nFc1 = 0.6\nFc2 = 0.4\n"
MISSING = "Fv1 = 0.5\nFc1 = 0.6\nFc2 = 0.4\n"  # joint 2's viscous friction removed from the file
RATE, SECONDS = 500.0, 12.0
CONTROLLER = '''[controller]
kind = "pd"
kp = [400.0, 100.0]
kd = [20.0, 5.0]
reference = ["0.2 + 0.8*sin(2*pi*0.3*t) + 0.3*sin(2*pi*0.7*t)", "-0.3 + 0.9*sin(2*pi*0.45*t + 1) + 0.2*sin(2*pi*1.1*t)"]
'''
POSITIONS_ONLY = '''data = "simulated.csv"
[signals]
t = "t"
q_q1 = "q_q1"
q_q2 = "q_q2"
tau_q1 = "tau_q1"
tau_q2 = "tau_q2"
'''
"""The user's own experiment file for the written log: positions and forces, the timing not declared."""


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder ``simulate`` wrote: the truth arm in its PD loop over a log of the initial position."""
    folder = tmp_path_factory.mktemp("held_force")
    t = np.arange(int(RATE * SECONDS) + 1) / RATE
    symbolic.data.write_columns({"t": t, "q_q1": 0 * t + 0.2, "q_q2": 0 * t - 0.3, "tau_q1": 0 * t,
                                 "tau_q2": 0 * t}, folder / "start.csv")
    (folder / "run.experiment.toml").write_text('data = "start.csv"\n' + CONTROLLER, encoding="utf-8")
    (folder / "truth.toml").write_text(arm(parameters=TRUTH), encoding="utf-8")
    (folder / "missing.toml").write_text(arm(parameters=MISSING, friction2='coulomb = "Fc2"'), encoding="utf-8")
    run = simulate(symbolic.derive(symbolic.load(folder / "truth.toml")), folder / "run.experiment.toml")
    run.write(folder / "sim")
    (folder / "sim" / "positions.experiment.toml").write_text(POSITIONS_ONLY, encoding="utf-8")
    return folder


def diagnosed(folder: Path, model: str, data: Path, out: str) -> symbolic.workflow.result.Diagnosis:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return diagnose(folder / model, data, out=folder / out, figures=False)


def patched_value(d, name: str) -> float:
    """``name``'s value in the patched model file diagnose wrote."""
    return {p.name: float(p.value) for p in symbolic.load(d.patched_path).parameters}[name]


def test_simulate_writes_the_timing_of_its_force(written: Path) -> None:
    """Beside simulated.csv, an experiment file that reads its positions and forces with held_force = true,
    and says in a comment what the columns are; the log's other treatment settings are kept (none here)."""
    path = written / "sim" / EXPERIMENT_NAME
    text = path.read_text(encoding="utf-8")
    assert "held over [t_k, t_k+1) (zero-order hold)" in text
    experiment = symbolic.data.load(path)
    assert experiment.settings == Settings(held_force=True)
    assert experiment.qd is None and experiment.qdd is None  # read as a measured log: central differences
    assert experiment.coordinates == ("q1", "q2") and experiment.samples == int(RATE * SECONDS) + 1


@pytest.mark.slow
def test_a_held_force_found_on_the_patched_model_is_treated_before_anything_is_written(written: Path) -> None:
    """The log read from its positions, the timing not declared: the viscous term is named within 1 % of 0.3
    and Fv1 stays within 0.5 % of 0.5 (the data are noise-free: what is left is the treatment's error — filtering,
    decimation, the simulation's smoothed Coulomb sign — 0.04 % here, against −4.1 % when the force was taken
    as logged), and the data finding says what the timing is,
    in the JSON and report.md."""
    d = diagnosed(written, "missing.toml", written / "sim" / "positions.experiment.toml", "out")
    assert [(f.effect, f.coordinate) for f in d.found] == [("viscous", "q2")]
    assert d.found[0].parameters["viscous"] == pytest.approx(0.3, rel=0.01)
    assert patched_value(d, "Fv1") == pytest.approx(0.5, rel=0.005)
    (finding,) = json.loads(json.dumps(d.to_dict()))["data_findings"]
    assert finding["finding"] == "held_force" and finding["treated"] is True
    assert finding["timing"] == "held over each sample (zero-order hold)"
    # on the nominal model the missing friction hides the lead; on the patched model it dominates
    assert finding["removed_share"] < 0.1 < 0.3 < finding["patched"]["removed_share"]
    assert finding["patched"]["found"] == [{"effect": "viscous", "coordinate": "q2"}]
    report = (written / "out" / "report.md").read_text(encoding="utf-8")
    assert "the force is held over each sample (zero-order hold): treated as held_force = true" in report
    assert d.sets["estimation"].states.processing.held_force  # every number is for the force so treated


@pytest.mark.slow
def test_nothing_missing_names_nothing_and_the_timing_is_still_reported(written: Path) -> None:
    """The truth itself on the same log: no effect, no value moved beyond its σ, the timing treated."""
    d = diagnosed(written, "truth.toml", written / "sim" / "positions.experiment.toml", "null")
    assert d.found == ()
    assert patched_value(d, "Fv1") == pytest.approx(0.5, rel=0.005)
    assert [f["treated"] for f in d.data_findings] == [True]


@pytest.mark.slow
def test_declared_or_read_with_its_own_accelerations_nothing_is_treated(written: Path) -> None:
    """The experiment simulate wrote declares the timing (no check, no finding); simulated.csv given as data
    is read with its qd/qdd columns, the state at t_k with τ_k acting, for which the force as logged is
    right: the patched model's check finds nothing to treat and the values are as good."""
    for data, out in ((written / "sim" / EXPERIMENT_NAME, "declared"), (written / "sim" / "simulated.csv", "own")):
        d = diagnosed(written, "missing.toml", data, out)
        assert [(f.effect, f.coordinate) for f in d.found] == [("viscous", "q2")], out
        assert d.found[0].parameters["viscous"] == pytest.approx(0.3, rel=0.01), out
        assert patched_value(d, "Fv1") == pytest.approx(0.5, rel=0.005), out
        assert d.data_findings == (), out
        assert d.sets["estimation"].states.processing.held_force is (out == "declared")
