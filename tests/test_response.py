"""The search judged on the response (symbolic.workflow.response, issue 34): what the simulated closed loop
shows and the inverse dynamics cannot — a force logged late, one joint's drive gain — named with its value,
and nothing named where nothing is missing.

Truth from tests/reference_integrator.py (the exact stick/slip axis under a discrete PD loop, the 2-link arm
by DOP853 at rtol 1e-11), never from the product's simulator; the searching code sees the logs and the
model file only. Counts over many seeds: bench/response.py (bench/results/response.md)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import models
from reference_integrator import write_arm_experiment, write_axis_experiment

import symbolic
from symbolic.data import load, signal_layer
from symbolic.identify.output_error import closed_loop
from symbolic.workflow import diagnose
from symbolic.workflow.effects.on_response import RESPONSE_EFFECTS

AXIS = {"J": 0.05, "Fv": 0.3, "Fc": 0.4}
"""write_axis_experiment's truth."""


def _diagnose(tmp_path: Path, kind: str, text: str | None = None, effects: list | None = None, **options):
    text = text or (models.axis() if kind == "axis" else models.arm())
    write = write_axis_experiment if kind == "axis" else write_arm_experiment
    experiment = write(tmp_path, seconds=4.0 if kind == "axis" else 6.0, **options)
    model = tmp_path / f"{kind}.toml"
    model.write_text(text, encoding="utf-8")
    return diagnose(str(model), str(experiment), simulate=True, out=tmp_path / "out", figures=False, response=True,
                    effects=effects)


def _named(result) -> dict[str, dict[str, float]]:
    return {j.candidate.label(): j.roles for j in result.response.named}


@pytest.mark.slow
def test_a_force_logged_late_is_named_as_a_delay(tmp_path: Path) -> None:
    result = _diagnose(tmp_path, "axis", log_delay=3, force_noise=0.02, counts=2**16, seed=1)
    named = _named(result)
    assert list(named) == ["delay(q)"]
    assert abs(named["delay(q)"]["delay"] - 3.0) < 1.0  # within one sample (issue 34)
    response = result.response
    assert response.after["validation"]["force"]["q"] < 0.5 * response.before["validation"]["force"]["q"]
    values = response.parameter_values()  # refitted with the delay: the truth's to 1 %
    for name, truth in AXIS.items():
        assert values[name] == pytest.approx(truth, rel=0.01)
    patched = (tmp_path / "out" / "axis_patched.toml").read_text(encoding="utf-8")
    assert "corrected by the output error" in patched
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "## Judged on the response" in report and "[sensors]\ntau_q = { delay = " in report
    data = result.to_dict()["response"]
    assert data["named"][0]["effect"] == "delay" and data["experiment_lines"][0] == "[sensors]"
    import tomllib

    declared = tomllib.loads("\n".join(data["experiment_lines"]))  # lines an experiment file takes as they are
    assert abs(declared["sensors"]["tau_q"]["delay"] - 3.0) < 1.0
    json.dumps(data)


@pytest.mark.slow
@pytest.mark.parametrize("delay, seed, counts", [(2, 13, 2**16), (5, 14, 2**20)])
def test_a_delay_the_equation_error_reads_as_a_second_mass_is_named_a_delay(tmp_path: Path, delay: int, seed: int,
                                                                            counts: int) -> None:
    """The axis's force logged 2 (5) samples late: the equation error alone names a load rattling in a dead band
    (backlash, second mass; contact near 4 Hz, heavily damped: a lag looks so to it), which adds a coordinate the
    data lack and kept the search judged on the response from running. Diagnosed again without second masses, the
    response names the delay, and simulated in the loop the delay leaves far less of the held-out error than the
    second mass did: the delay is the diagnosis (docs/workflow.md, "Judged on the response")."""
    result = _diagnose(tmp_path, "axis", log_delay=delay, force_noise=0.02 if delay == 2 else 0.01, counts=counts, seed=seed)
    assert result.found == ()
    named = _named(result)
    assert list(named) == ["delay(q)"] and abs(named["delay(q)"]["delay"] - delay) < 1.0
    (note,) = [n for n in result.notes if n.startswith("without backlash (second mass) on q")]
    assert "names delay(q)" in note and "so backlash (second mass) on q is not named" in note
    assert "with second masses" in result.seconds


@pytest.mark.slow
def test_an_equation_error_stand_in_for_a_delay_is_dropped(tmp_path: Path) -> None:
    """Joint 2's force logged 3 samples late: the equation error names a stand-in on joint 2 first (an inertia,
    or an offset); once the response names the delay, the stand-in, refitted with it, no longer lowers the
    held-out simulation error and is not written (symbolic.workflow.stand_ins). The force is declared as
    logged, so the diagnosis runs once and the review's note is the one to read."""
    result = _diagnose(tmp_path, "arm", log_delay=(0, 3), force_noise=0.05, seed=1,
                       layer="[identification]\nheld_force = false\n")
    assert list(_named(result)) == ["delay(q2)"]
    assert abs(_named(result)["delay(q2)"]["delay"] - 3.0) < 1.0
    assert result.to_dict()["found"] == []
    dropped = [n for n in result.notes if "a stand-in for them, not written" in n]
    assert len(dropped) >= 1 and all("on q2" in n for n in dropped)
    patched = (tmp_path / "out" / "arm_patched.toml").read_text(encoding="utf-8")
    assert "symbolic diagnose: " not in patched  # no effect written (its comments read "symbolic diagnose: <label>")
    assert patched.count("[[friction]]") == 2 and "rotor_inertia" not in patched


@pytest.mark.slow
def test_a_true_finding_beside_a_delay_is_kept(tmp_path: Path) -> None:
    """The model file lacks joint 1's viscous friction (truth 0.8) and joint 2's force is logged 3 samples
    late: the review keeps viscous(q1), which the delay does not explain, and the response names the delay."""
    text = models.arm(parameters="Fv2 = 0.5\nFc1 = 0.6\nFc2 = 0.4\n", friction1='coulomb = "Fc1"')
    result = _diagnose(tmp_path, "arm", text=text, log_delay=(0, 3), force_noise=0.05, seed=1)
    assert list(_named(result)) == ["delay(q2)"]
    found = [(f["effect"], f["coordinate"]) for f in result.to_dict()["found"]]
    assert found == [("viscous", "q1")]
    assert result.to_dict()["found"][0]["parameters"]["viscous"] == pytest.approx(0.8, rel=0.1)
    assert not [n for n in result.notes if "a stand-in for them" in n]


@pytest.mark.slow
def test_one_joints_drive_gain_is_named_on_that_joint(tmp_path: Path) -> None:
    result = _diagnose(tmp_path, "arm", drive=((1.0, 0.0), (1.3, 0.0)), force_noise=0.05, seed=1)
    named = _named(result)
    assert list(named) == ["drive_gain(q2)"]
    assert named["drive_gain(q2)"]["gain"] == pytest.approx(1.3, rel=0.02)


@pytest.mark.slow
def test_an_axis_drive_gain_is_named_where_the_inertia_is_known(tmp_path: Path) -> None:
    """On one axis a drive gain scales every parameter alike (the data cannot tell, module docstring of
    drive_gain); with J known (fixed = true) it is the drive's gain, and Fv, Fc come out with it."""
    text = models.axis().replace("J = { value = 0.05,", "J = { value = 0.05, fixed = true,")
    result = _diagnose(tmp_path, "axis", text, drive=(1.3, 0.0), force_noise=0.02, counts=2**16, seed=1)
    named = _named(result)
    assert list(named) == ["drive_gain(q)"] and named["drive_gain(q)"]["gain"] == pytest.approx(1.3, rel=0.01)
    values = result.response.parameter_values()
    assert values["Fv"] == pytest.approx(AXIS["Fv"], rel=0.02) and values["Fc"] == pytest.approx(AXIS["Fc"], rel=0.02)


@pytest.mark.slow
def test_a_position_sensors_bias_is_named_where_gravity_is_known(tmp_path: Path) -> None:
    """Joint 2's encoder reads 0.05 rad more than the angle (the loop holds the arm off by as much); with the
    links' masses and centres of mass known, gravity shows it: sensor_bias(q2) 0.05 within 10 %, first. Nothing
    else is named (a second round's q1 bias of −0.0015 rad was, before σ counted the error's colour)."""
    text = models.arm()
    for name, value in (("m1", "3.0"), ("m2", "2.0"), ("c1", "0.2"), ("c2", "0.15")):
        text = text.replace(f"{name} = {value}\n", f"{name} = {{ value = {value}, fixed = true }}\n")
    # the log holds the loop's command over each sample: declared, so that the diagnosis runs once. The
    # equation-error search reads the bias as a payload on link 2 (a rotated centre of mass) when it may; left
    # out here, this test is of the response (with it, the response still names the bias, 0.0495, but refits
    # the payload's values too: minutes of compiling new sensitivities, bench/response.py)
    from symbolic.workflow.effects import EFFECTS

    effects = [e for k, e in EFFECTS.items() if k != "payload"] + list(RESPONSE_EFFECTS.values())
    result = _diagnose(tmp_path, "arm", text, effects, counts=0, position_bias=(0.0, 0.05), force_noise=0.05,
                       seed=1, layer="[identification]\nheld_force = true\n")
    named = _named(result)
    assert list(named) == ["sensor_bias(q2)"] and named["sensor_bias(q2)"]["bias"] == pytest.approx(0.05, rel=0.1)
    # the second round's sensor_bias(q1) (−0.0015 rad, 10.8 % of a held-out error at its floor) was named while
    # its σ assumed a white simulation error; with σ × √τ_int it is far below 5σ
    (second,) = [j for j in result.response.rounds[1] if j.candidate.label() == "sensor_bias(q1)"]
    assert second.sigmas < 5.0


@pytest.mark.slow
def test_a_drive_applying_its_command_late_is_named_as_a_drive_delay(tmp_path: Path) -> None:
    """The axis's drive applies each PD command 2 samples late (the loop runs on the late force; the log holds the
    command when computed): drive_delay(q) 2, within one sample, and nothing else; not a logged force's lag."""
    result = _diagnose(tmp_path, "axis", drive_delay=2, force_noise=0.02, counts=2**16, seed=1)
    named = _named(result)
    assert list(named) == ["drive_delay(q)"] and abs(named["drive_delay(q)"]["delay"] - 2.0) < 1.0
    assert result.response.experiment_lines() == ["[drive]", "tau_q = { delay = 2 }"]
    (judged,) = result.response.named
    assert judged.gain > 0.5 and judged.to_dict()["distance_in_sigmas"] is None  # a scanned whole number: no σ


@pytest.mark.slow
def test_a_drive_delay_of_the_arms_loop(tmp_path: Path) -> None:
    """Both drives of the arm apply their commands 2 samples late (a bus cycle): one delay for the loop,
    drive_delay(all), not one joint's."""
    result = _diagnose(tmp_path, "arm", drive_delay=(2, 2), force_noise=0.05, counts=2**16, seed=2)
    named = _named(result)
    assert list(named) == ["drive_delay(all)"] and abs(named["drive_delay(all)"]["delay"] - 2.0) < 1.0
    assert result.response.experiment_lines() == ["[drive]", "tau_q1 = { delay = 2 }", "tau_q2 = { delay = 2 }"]


@pytest.mark.slow
def test_one_joints_drive_delay_is_named_on_that_joint(tmp_path: Path) -> None:
    """Only the second joint's drive applies its commands late, 3 samples (its own drive's latency; the first
    joint's is on time): drive_delay(q2) 3, within one sample — not the loop's delay, not the first joint's."""
    result = _diagnose(tmp_path, "arm", drive_delay=(0, 3), force_noise=0.05, counts=2**16, seed=3)
    named = _named(result)
    assert list(named) == ["drive_delay(q2)"] and abs(named["drive_delay(q2)"]["delay"] - 3.0) < 1.0
    assert result.response.experiment_lines() == ["[drive]", "tau_q2 = { delay = 3 }"]


@pytest.mark.slow
def test_a_position_sensors_bias_is_named_under_a_quantising_loop(tmp_path: Path) -> None:
    """The same bias read through a 2^16-count encoder that the PD loop quantises (declared in its [controller]):
    the fit adds the bias to the count (docs/data.md), and sensor_bias(q2) comes out within 10 %, alone."""
    text = models.arm()
    for name, value in (("m1", "3.0"), ("m2", "2.0"), ("c1", "0.2"), ("c2", "0.15")):
        text = text.replace(f"{name} = {value}\n", f"{name} = {{ value = {value}, fixed = true }}\n")
    from symbolic.workflow.effects import EFFECTS

    effects = [e for k, e in EFFECTS.items() if k != "payload"] + list(RESPONSE_EFFECTS.values())
    result = _diagnose(tmp_path, "arm", text, effects, counts=2**16, position_bias=(0.0, 0.05), force_noise=0.05,
                       seed=1, layer="[identification]\nheld_force = true\n")
    named = _named(result)
    assert list(named) == ["sensor_bias(q2)"] and named["sensor_bias(q2)"]["bias"] == pytest.approx(0.05, rel=0.1)


@pytest.mark.slow
@pytest.mark.parametrize("kind, options", [("axis", dict(seed=3, counts=2**16, force_noise=0.03)),
                                           ("axis", dict(seed=4, counts=2**20, force_noise=0.01)),
                                           ("arm", dict(seed=2, force_noise=0.05))])
def test_nothing_missing_names_nothing(tmp_path: Path, kind: str, options: dict) -> None:
    result = _diagnose(tmp_path, kind, **options)
    assert result.response is not None
    assert _named(result) == {}
    assert result.response.refit is None or result.response.refit["moved"] == []
    assert result.response.corrections == ()
    tried = [j for r in result.response.rounds for j in r]
    assert {j.candidate.effect.identifier for j in tried} >= {"delay", "drive_gain", "drive_delay"}


def test_freed_adds_a_channel_at_its_null_value(tmp_path: Path) -> None:
    model = symbolic.derive(symbolic.loads(models.axis(), "axis"))
    experiment = write_axis_experiment(tmp_path, counts=0, seconds=0.3)
    measurements = load(experiment, ("q",), model=model.robot)
    freed = signal_layer.freed(measurements, {("sensors", "tau_q", "delay"): None}, "test")
    assert [(f.table, f.signal, f.field, f.start) for f in freed.signal_layer.free] == [("sensors", "tau_q", "delay", 0.0)]
    np.testing.assert_array_equal(freed.tau, measurements.tau)  # neutral: the model's signals unchanged
    shifted = signal_layer.freed(measurements, {("sensors", "tau_q", "delay"): 2.0}, "test")
    np.testing.assert_allclose(shifted.tau[:-3, 0], measurements.tau[2:-1, 0], rtol=0, atol=1e-12)
    with pytest.raises(symbolic.DataError, match="other table"):
        signal_layer.freed(freed, {("drive", "tau_q", "gain"): None}, "test")


def test_a_force_sensors_values_reuse_one_simulation(tmp_path: Path) -> None:
    """θ of force-sensor values only acts on the comparison: the loop is simulated once and its derivative
    is zero (the comparison's own derivative is the residuals')."""
    model = symbolic.derive(symbolic.loads(models.axis(), "axis"))
    experiment = write_axis_experiment(tmp_path, counts=0, seconds=0.3)
    measurements = signal_layer.freed(load(experiment, ("q",), model=model.robot),
                                      {("sensors", "tau_q", "delay"): None}, "test")
    loop = closed_loop(model, measurements, [], signal_values=measurements.signal_layer.free)
    assert loop.comparison_only
    y1, dy = loop.run(np.array([0.0]))
    y2, _ = loop.run(np.array([2.5]), sensitivities=False)
    assert y1 is y2 and not dy.any()


def test_the_command_line_takes_response_effects(tmp_path: Path) -> None:
    write_axis_experiment(tmp_path, counts=2**16, seconds=2.0, force_noise=0.02, log_delay=3)
    model = tmp_path / "axis.toml"
    model.write_text(models.axis(), encoding="utf-8")
    run = subprocess.run([sys.executable, "-m", "symbolic", "diagnose", str(model), str(tmp_path / "axis.experiment.toml"),
                          "--simulate", "--effects", "viscous,delay", "--json", "--out", str(tmp_path / "out")],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    response = json.loads(run.stdout)["response"]
    assert [n["effect"] for n in response["named"]] == ["delay"]
    tried = {c["effect"] for r in response["rounds"] for c in r}
    assert tried == {"delay"}
    wrong = subprocess.run([sys.executable, "-m", "symbolic", "diagnose", str(model), str(tmp_path / "axis.experiment.toml"),
                            "--effects", "dealy", "--out", str(tmp_path / "o2")], capture_output=True, text=True, timeout=120)
    assert wrong.returncode == 2 and "delay" in wrong.stderr


def test_every_response_effect_declares_itself() -> None:
    assert set(RESPONSE_EFFECTS) == {"delay", "drive_delay", "drive_gain", "sensor_bias", "correction"}
    for effect in RESPONSE_EFFECTS.values():
        described = effect.describe()
        assert described["judged_on"] == "response" and effect.summary and effect.guide and effect.roles


def test_on_with_the_simulated_path_unless_refused(tmp_path: Path) -> None:
    experiment = write_axis_experiment(tmp_path, counts=2**16, seconds=1.0, force_noise=0.02)
    model = tmp_path / "axis.toml"
    model.write_text(models.axis(), encoding="utf-8")
    assert diagnose(str(model), str(experiment), simulate=True, figures=False).response is not None
    refused = diagnose(str(model), str(experiment), simulate=True, figures=False, response=False)
    assert refused.response is None and refused.to_dict()["response"] is None
    assert diagnose(str(model), str(experiment), figures=False).response is None  # the inverse path


@pytest.mark.slow
@pytest.mark.parametrize("factor", [1.0, 1.6])
def test_the_rigs_half_sample_log_is_named_and_its_stiffness_kept(tmp_path: Path, factor: float) -> None:
    """tests/workflow_cases.py logs the mean of the held command over [t_k − T/2, t_k + T/2] (aligned with
    the positions for the inverse model): against the loop's command at t_k that is a lag of half a sample,
    which the response names — and nothing else, with the file's Ks right (1.0) or 1.6× too soft, where
    IDIM-LS corrects it and the output error keeps the correction (the truth's Ks to 1 %)."""
    from test_gaps_after import run_rig

    result = run_rig(tmp_path, factor, simulate=True, response=True)
    named = _named(result)
    assert list(named) == ["delay(theta)"]
    assert named["delay(theta)"]["delay"] == pytest.approx(0.5, abs=0.1)
    patched = {p.name: p.value for p in symbolic.load(result.patched_path).parameters}
    assert patched["Ks"] == pytest.approx(factor, rel=0.01)


def test_beyond_max_refit_the_search_is_local_and_beyond_max_local_not_run(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """Beyond MAX_REFIT parameters the search is local (the refit frees the values acting on one coordinate's
    force alone, each candidate its own coordinate's): the axis's three, against a limit of two, still name the
    force's 3-sample delay, and the JSON and the report say the search was local. Beyond MAX_LOCAL it is not
    run, and they say why."""
    import symbolic.workflow.response as response

    monkeypatch.setattr(response, "MAX_REFIT", 2)
    result = _diagnose(tmp_path / "local", "axis", log_delay=3, force_noise=0.02, counts=2**16, seed=1)
    named = _named(result)
    assert list(named) == ["delay(q)"] and abs(named["delay(q)"]["delay"] - 3.0) < 1.0
    data = result.to_dict()["response"]
    assert data["local"] is True and data["notes"][0].startswith("local search")
    assert sorted(data["parameter_values"]) == ["Fc", "Fv", "J"]
    monkeypatch.setattr(response, "MAX_LOCAL", 2)
    result = _diagnose(tmp_path / "skipped", "axis", log_delay=3, force_noise=0.02, counts=2**16, seed=1)
    assert result.response.named == () and result.response.rounds == ()
    data = result.to_dict()["response"]
    assert "more than the 2" in data["refit"]["skipped"] and data["notes"][0].startswith("not run")
    assert "Not run: the model has 3 parameters acting on one coordinate's force alone" in \
        (tmp_path / "skipped" / "out" / "report.md").read_text(encoding="utf-8")


def test_own_rows_are_the_values_acting_on_one_coordinates_force_alone() -> None:
    """On the 2-link arm: the friction values act on their own joint's row, link 1's inertial values on joint 1's
    alone; link 2's on both (joint 1 carries link 2) and a length is in Y itself: neither is own-row."""
    from symbolic.workflow.terms import own_rows

    model = symbolic.derive(symbolic.loads(models.arm(), "<arm>"))
    own = own_rows(model, [p.name for p in model.robot.parameters])
    assert own == {"m1": "q1", "c1": "q1", "I1": "q1", "Fv1": "q1", "Fc1": "q1", "Fv2": "q2", "Fc2": "q2"}
    assert not {"m2", "l1"} & set(own)


def test_a_drive_gain_restarts_where_the_equation_error_scaled_its_joints_own_values() -> None:
    """IDIM-LS fits a joint's own values as θ/g behind a drive gain g: the restart is g = the median of file/corrected,
    those values back at the file's; no restart where nothing was corrected, nor for a ratio within 2 % of 1 or
    outside the plausible range (drive_gain.MIN_CHANGE, PLAUSIBLE)."""
    gain = RESPONSE_EFFECTS["drive_gain"]
    (candidate,) = [c for c in gain.candidates(symbolic.derive(symbolic.loads(models.arm(), "<arm>")),
                                               _gain_log(), set()) if c.coordinate == "q2"]
    (start,) = gain.restarts(candidate, {"Fv2": (0.4, 0.5), "Fc2": (0.2, 0.25), "I2": (1.0, 1.3)})
    assert start == {("drive", "tau_q2", "gain"): 0.8, ("parameter", "Fv2", ""): 0.4,
                     ("parameter", "Fc2", ""): 0.2, ("parameter", "I2", ""): 1.0}
    assert gain.restarts(candidate, {}) == []
    assert gain.restarts(candidate, {"Fv2": (1.0, 1.01)}) == []
    assert gain.restarts(candidate, {"Fv2": (1.0, 10.0)}) == []
    assert gain.restarts(candidate, {"Fv2": (1.0, -2.0)}) == []
    assert RESPONSE_EFFECTS["sensor_bias"].restarts(candidate, {"Fv2": (0.4, 0.5)}) == []


def _gain_log():
    """A 2-joint log whose forces both vary, with a signal layer (a drive gain is a candidate on both joints)."""
    from symbolic.data import Measurements
    from symbolic.data.experiment import Experiment

    t = np.arange(200) * 1e-3
    log = Measurements.from_arrays(t, ("q1", "q2"), np.c_[np.sin(t), np.cos(t)], np.c_[np.cos(t), np.sin(3 * t)])
    return Experiment.of(log, controller={"kind": "torque"})


def test_help_and_list_name_the_response_effects() -> None:
    """``diagnose --help`` reads the response effects' summaries from their files' text (no import), equal to the
    registry's; ``--list-effects`` lists them with their roles."""
    from symbolic.workflow.effect_summaries import response_summaries

    assert list(response_summaries().items()) == [(k, e.summary) for k, e in RESPONSE_EFFECTS.items()]
    shown = subprocess.run([sys.executable, "-m", "symbolic", "diagnose", "--help"], capture_output=True, text=True,
                           timeout=60).stdout
    listed = subprocess.run([sys.executable, "-m", "symbolic", "diagnose", "--list-effects"], capture_output=True,
                            text=True, timeout=60).stdout
    for key, effect in RESPONSE_EFFECTS.items():
        assert key in shown.split("judged on the response", 1)[1]
        assert f"{key}  {effect.summary}" in listed
