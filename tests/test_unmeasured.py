"""A model whose coordinates the data do not all measure, diagnosed on its response alone (docs/workflow.md,
"Coordinates the data do not measure"; symbolic/workflow/unmeasured.py).

The truth is tests/elastic_reference.py's geared joint (Spong's elastic joint, k = 400 N·m/rad, set-valued Coulomb
friction on the rotor) under the industrial PI velocity cascade, integrated without the product's simulator; the log
keeps the motor encoder only (its link-side encoder column is dropped from the experiment). The model file is the
elastic joint as a user writes it (two coordinates: the motor and the link's deflection from it), with the
truth's values except where a test says; the searching code sees only the file and the log.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import elastic_reference as truth
from symbolic.data import DataError
from symbolic.derivation.dynamics import derive
from symbolic.description.modelfile import load, loads
from symbolic.identify.output_error import output_error, simulation_errors
from symbolic.identify.least_squares import IdentificationError
from symbolic.workflow import diagnose



def _motor_encoder_only(folder, **kwargs):
    return truth.motor_encoder_only(truth.write_joint_experiment(folder, **kwargs))


def _model(folder, **values) -> str:
    path = folder / "elastic.toml"
    path.write_text(truth.elastic_model_text(**values), encoding="utf-8")
    return str(path)


def _labels(result) -> list[str]:
    return [f["label"] for f in result.found]


@pytest.mark.slow
def test_wrong_stiffness_behind_a_motor_encoder_is_named_as_that_stiffness(tmp_path):
    experiment = _motor_encoder_only(tmp_path)
    model = _model(tmp_path, k=1.7 * truth.TRUTH["k"])
    result = diagnose(model, str(experiment), out=tmp_path / "out")
    assert result.judged_on == "response" and result.unmeasured == ("q_flex",)
    assert _labels(result) == ["correction(k)"]
    (correction,) = result.response.corrections
    assert correction["kind"] == "stiffness"
    assert correction["value"] == pytest.approx(truth.TRUTH["k"], rel=0.10)
    # recomputed on the patched model: the held-out force error falls to a tenth or less (the noise and the
    # smoothing of the rotor's Coulomb friction in the product's simulator are what is left)
    before, after = result.before["validation"]["force"]["q"], result.after["validation"]["force"]["q"]
    assert after < 0.1 * before
    patched = load(tmp_path / "out" / "geared_joint_patched.toml")
    assert {q.name: q.value for q in patched.parameters}["k"] == pytest.approx(correction["value"], rel=1e-9)
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "judged on the response" in report and "correction(k)" in report
    assert (tmp_path / "out" / "response_q.png").is_file()
    assert result.modes["after"][0]["frequency_hz"] < result.modes["before"][0]["frequency_hz"]  # softer spring
    json.dumps(result.to_dict(), allow_nan=False)


@pytest.mark.slow
@pytest.mark.parametrize("seed, stiffness", [(0, 400.0), (3, 1500.0)])
def test_right_model_behind_a_motor_encoder_names_nothing(tmp_path, seed, stiffness):
    experiment = _motor_encoder_only(tmp_path, stiffness=stiffness, seed=seed)
    model = _model(tmp_path, k=stiffness)
    result = diagnose(model, str(experiment))
    assert result.found == ()
    assert result.patched_text is None


@pytest.mark.slow
def test_output_error_starts_from_the_model_files_values(tmp_path):
    """identify --method didim without IDIM-LS (docs/data.md, "Output error"): the parameters the response sees
    fitted from the file's values, one of m and c (only m·c enters) held; the stiffness moves most of the way
    from the file's 680 to the truth's 400 and the errors fall."""
    experiment = _motor_encoder_only(tmp_path, seconds=3.0)
    model = derive(load(_model(tmp_path, k=1.7 * truth.TRUTH["k"])))
    fit = output_error(model, str(experiment), signals="both", max_iterations=12)
    assert fit.start_method.startswith("model file's values")
    assert "k" in fit.parameters and not {"m", "c"} <= set(fit.parameters)
    assert abs(fit.parameters["k"].value - truth.TRUTH["k"]) < 0.5 * abs(680.0 - truth.TRUTH["k"])
    assert fit.errors["force"]["q"] < 0.3 * fit.errors_start["force"]["q"]


def test_unmeasured_coordinate_without_a_loop_is_refused(tmp_path):
    experiment = _motor_encoder_only(tmp_path, seconds=0.5)
    text = experiment.read_text(encoding="utf-8")
    experiment.write_text(text[:text.index("[controller]")], encoding="utf-8")
    with pytest.raises(DataError) as caught:
        diagnose(_model(tmp_path), str(experiment))
    assert caught.value.key == "[controller]"
    assert "q_flex" in caught.value.problem and "not in the data" in caught.value.problem


def test_no_response_keeps_the_missing_signal_error(tmp_path):
    experiment = _motor_encoder_only(tmp_path, seconds=0.5)
    with pytest.raises(DataError, match="q_q_flex"):
        diagnose(_model(tmp_path), str(experiment), response=False)


def test_nothing_free_is_evaluated_once_where_asked(tmp_path):
    """output_error(evaluate_if_nothing_free=True) with nothing to fit: the loop at the model's values, its
    errors those of simulation_errors; without the flag, refused."""
    experiment = _motor_encoder_only(tmp_path, seconds=1.0)
    model = derive(loads(truth.elastic_model_text(), "elastic.toml"))
    with pytest.raises(IdentificationError, match="no parameter to fit"):
        output_error(model, str(experiment), start={}, signals="both")
    fit = output_error(model, str(experiment), start={}, signals="both", evaluate_if_nothing_free=True)
    assert fit.parameters == {} and fit.iterations == 0 and fit.converged
    direct = simulation_errors(model, _loaded(experiment, model), signals="both")
    for signal, by in direct.items():
        for c, value in by.items():
            assert fit.errors[signal][c] == pytest.approx(value, rel=1e-12)
    assert np.isfinite(fit.cost)


def _loaded(experiment, model):
    from symbolic.data import load as load_data

    return load_data(str(experiment), None, model=model.robot)


def test_a_correction_that_returns_to_the_files_value_is_not_named():
    """response._still_named: forward selection named d first (a stand-in while k was wrong), then k; in the last
    fit, with both free, d is back within 10 % of the file's value: d is dropped with its reason, k kept with the
    last fit's value and its change measured from the file's value."""
    from types import SimpleNamespace

    from symbolic.identify.output_error import FittedParameter
    from symbolic.workflow.effects.on_response import PARAMETER, RESPONSE_EFFECTS, ResponseCandidate
    from symbolic.workflow.response import Judged, _still_named

    model = derive(loads(truth.elastic_model_text(k=680.0), "elastic.toml"))
    correction = RESPONSE_EFFECTS["correction"]
    d_key, k_key = (PARAMETER, "d", ""), (PARAMETER, "k", "")

    def judged(key, value, start, fitted):
        values = {key: FittedParameter(key[1], value, 0.01, 0.0, start)}
        roles = correction.roles_of(values, 1000.0)
        fit = SimpleNamespace(parameters={k[1]: v for k, v in fitted.items()}, signal_values={})
        return Judged(ResponseCandidate(correction, "", (key,), (start,)), values, {}, {}, 0.5, 0.5, 10.0, roles,
                      True, None, fit)

    first = judged(d_key, 2.4, 0.8, {d_key: FittedParameter("d", 2.4, 0.01, 0.0, 0.8)})
    last_fit = {d_key: FittedParameter("d", 0.82, 0.01, 0.0, 2.4), k_key: FittedParameter("k", 403.0, 0.3, 0.0, 680.0)}
    second = judged(k_key, 403.0, 680.0, last_fit)
    kept, dropped = _still_named(model, [first, second], 1000.0)
    assert [j.candidate.label() for j in kept] == ["correction(k)"]
    assert [j.candidate.label() for j, _ in dropped] == ["correction(d)"]
    assert "10 % at least" in dropped[0][1]
    assert kept[0].roles["file_value"] == 680.0 and kept[0].roles["value"] == 403.0
