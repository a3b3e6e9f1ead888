"""``backlash`` from the motor's encoder alone (symbolic/workflow/effects/backlash.py).

The truth is tests/elastic_reference.py (the rotor's Coulomb friction set-valued, the link by symplectic Euler at 50
steps a sample, the industrial PI velocity cascade on the motor encoder), its link encoder left out of the experiment.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.integrate

import elastic_reference as truth
import models
from symbolic.derivation import derive
from symbolic.description import loads
from symbolic.workflow import diagnose
from symbolic.workflow.effects import EFFECTS, Context
from symbolic.workflow.effects.backlash import rattle
from symbolic.workflow.effects.joint_elasticity import LinkSide


def test_a_dead_band_is_named_with_its_width_from_the_motor_encoder(tmp_path):
    """The geared joint, k 2000 with a 10 mrad dead band, its motor encoder alone: named ``backlash`` (one encoder) with
    its width within 10 % (0.00997 when written) and nothing else — before, the linear spring took it (k 151 for 2000)
    with an offset. The spring in contact comes out soft and damped (k 1104, d 7.1 when written): a lightly damped
    rattle is chaotic, so the link's deflection integrated from the motor's filtered motion cannot follow the truth's
    ringing, and a damped contact fits its mean. The patched file holds Spong's joint with the band; report.md lists the
    finding with the search's (it said "no significant missing effect beyond the joint elasticity" for a one-encoder
    finding)."""
    model, experiment = truth.case_files(tmp_path, "joint", one_encoder=True, stiffness=2000.0, backlash=0.01)
    result = diagnose(str(model), str(experiment), out=tmp_path / "out", figures=False)
    assert [(f.effect, f.coordinate, f.variant) for f in result.found] == [("backlash", "q", "one_encoder")]
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| backlash (one encoder) | q | width = " in report and "No significant missing effect" not in report
    (found,) = result.found
    assert found.parameters["width"] == pytest.approx(0.01, rel=0.10)
    assert result.after.gap["validation"] < 0.25 * result.before.gap["validation"]
    patched = derive(loads(result.patched_text, str(tmp_path / "p.toml")))
    values = {p.name: float(p.value) for p in patched.robot.parameters}
    assert patched.robot.generalized_coordinates == ("q", "q_flex")
    assert values["backlash_q"] == pytest.approx(found.parameters["width"], rel=1e-12)
    assert values["k_q_joint"] == pytest.approx(found.parameters["stiffness"], rel=1e-12)


@pytest.mark.slow
def test_a_dead_band_on_joint_2_of_an_arm_from_the_motor_encoders(tmp_path):
    """Joint 2 of the two-link arm, k 2000 with an 8 mrad band, motor encoders alone: ``backlash(q2)`` with its width
    within 10 % (0.00788 when written), nothing on joint 1."""
    model, experiment = truth.case_files(tmp_path, "arm", one_encoder=True, stiffness=2000.0, backlash=0.008)
    result = diagnose(str(model), str(experiment), figures=False)
    assert [(f.effect, f.coordinate) for f in result.found] == [("backlash", "q2")]
    assert result.found[0].parameters["width"] == pytest.approx(0.008, rel=0.10)


def _loaded_axis(folder, monkeypatch, **kwargs):
    """The truth's joint with a weightless link (a load of 0.15 on the coupling), the model file its motor alone: the
    tests' rotary axis with the truth's rotor inertia and friction (no [[drive]]: a second mass there is
    flexible_mode's, not a transmission's)."""
    monkeypatch.setitem(truth.TRUTH, "m", 0.0)
    experiment = truth.motor_encoder_only(truth.write_joint_experiment(folder, **kwargs))
    model = folder / "axis.toml"
    model.write_text(models.axis(parameters=f"Fv = {truth.TRUTH['Fv']!r}\nFc = {truth.TRUTH['Fc']!r}\n", J=truth.TRUTH["Jm"]))
    return model, experiment


def test_a_load_rattling_in_a_dead_band_is_named_backlash_with_its_width(tmp_path, monkeypatch):
    """A load on a coupling with a 10 mrad dead band (k 2000), behind an axis whose model file declares no motor:
    ``backlash`` (second mass) with its width within 10 % (0.01000 when written) — before, a flexible_mode at 3.4 Hz,
    31 % of the held-out force left. Written as flexible_mode's second mass with the band in its coupling."""
    model, experiment = _loaded_axis(tmp_path, monkeypatch, stiffness=2000.0, backlash=0.01)
    result = diagnose(str(model), str(experiment), figures=False)
    assert [(f.effect, f.coordinate, f.variant) for f in result.found] == [("backlash", "q", "second_mass")]
    assert result.found[0].parameters["width"] == pytest.approx(0.01, rel=0.10)
    assert result.after.gap["validation"] < 0.25 * result.before.gap["validation"]
    patched = derive(loads(result.patched_text, str(tmp_path / "p.toml")))
    values = {p.name: float(p.value) for p in patched.robot.parameters}
    assert patched.robot.generalized_coordinates == ("q", "q_flex")
    assert values["backlash_q"] == pytest.approx(result.found[0].parameters["width"], rel=1e-12)
    assert values["J_q_load"] == pytest.approx(truth.TRUTH["Jl"], rel=0.25)


@pytest.mark.slow
def test_a_load_on_a_plain_coupling_stays_a_flexible_mode(tmp_path, monkeypatch):
    """The same load on a coupling without a band (k 400): flexible_mode, not backlash (the band's width goes to the
    narrow edge of the range searched)."""
    model, experiment = _loaded_axis(tmp_path, monkeypatch)
    result = diagnose(str(model), str(experiment), figures=False)
    assert [(f.effect, f.coordinate) for f in result.found] == [("flexible_mode", "q")]


def test_the_rattle_is_the_link_equation_integrated():
    """:func:`rattle` against SciPy's adaptive integration (DOP853, tolerance 1e-9, the same linear interpolation of
    the forcing) of D·δ̈ + B·δ̇ + A·δ + [|δ| > b/2]·(k·(δ ∓ b/2) + d·δ̇) = T: a damped link (ζ 0.3, 12 Hz) driven
    through its band (±2 mrad; the torque alone deflects it 0.7 mrad) by a two-tone torque at 10 kHz, within 0.2 % of
    the deflection's RMS (symplectic Euler's error; 0.045 % when written)."""
    rate, n = 10_000.0, 10_000
    t = np.arange(n) / rate
    torque = 0.6 * np.sin(2 * np.pi * 1.5 * t) + 0.2 * np.sin(2 * np.pi * 7.0 * t + 0.4)
    inertia, mean = 0.15 + 0.01 * np.cos(t), 0.15
    a_coef, b_coef = 0.5 * np.sin(t), 0.02 * np.ones(n)
    link = LinkSide(torque, inertia[:, None], a_coef[:, None], b_coef[:, None], inertia, mean, 0)
    frequency, zeta, width = 12.0, 0.3, 0.004
    w = 2 * math.pi * frequency
    k, d = mean * w * w, 2 * zeta * w * mean
    delta, _, _ = rattle(link, (frequency, zeta, width), rate)

    def at(x: np.ndarray, time: float) -> float:
        return float(np.interp(time, t, x))

    def rhs(time: float, y: np.ndarray) -> list[float]:
        x, v = y
        band = k * (x - math.copysign(width / 2, x)) + d * v if abs(x) > width / 2 else 0.0
        return [v, (at(torque, time) - at(b_coef, time) * v - at(a_coef, time) * x - band) / at(inertia, time)]

    start = torque[0] / k + math.copysign(width / 2, torque[0])
    exact = scipy.integrate.solve_ivp(rhs, (0.0, t[-1]), [start, 0.0], t_eval=t, method="DOP853", rtol=1e-9,
                                      atol=1e-12, max_step=1e-3).y[0]
    assert np.sqrt(np.mean((delta - exact) ** 2)) < 2e-3 * np.sqrt(np.mean(exact ** 2))


def test_a_band_at_the_grid_s_narrow_edge_is_a_spring():
    """A width at the narrow edge of the range searched is not located: the linear spring, one parameter fewer,
    is the finding then (the check says so); inside the range, and with the link's inertia, it passes."""
    model = derive(loads(truth.model_text(), "joint.toml"))
    q = np.linspace(0.1, 0.5, 200)[:, None]
    context = Context(model.robot, ("q",), q, 0 * q, 0 * q, 40.0, 0.01, model=model)
    effect = EFFECTS["backlash_one_encoder"]
    rows, _ = effect.grid(context, 0)
    narrow = rows[:, 2].min()
    roles = effect.roles_of(np.array([0.15]), (10.0, 0.1, narrow), None)
    assert "a spring without a band" in effect.check(roles, None, context, 0)
    assert effect.check(effect.roles_of(np.array([0.15]), (10.0, 0.1, 30 * narrow), None), None, context, 0) is None
    assert "link's inertia" in effect.check(effect.roles_of(np.array([0.01]), (10.0, 0.1, 30 * narrow), None), None,
                                            context, 0)


def test_the_compiled_rattle_and_the_python_loop_agree():
    """Without a compiler :func:`rattle` runs the same loop in Python: the two agree to rounding (1e-12 of the
    deflection's range) on a link driven through its band with sub-steps (ω·h 0.75: four a sample)."""
    from symbolic.workflow.effects import backlash

    assert backlash._compiled() is not None, "gcc is needed for this test (the C loop)"
    rate, n = 1000.0, 3000
    t = np.arange(n) / rate
    torque = 0.6 * np.sin(2 * np.pi * 1.5 * t)
    inputs = np.ascontiguousarray(np.column_stack([torque, 0.15 + 0.01 * np.cos(t), 0.5 * np.sin(t), 0.02 + 0 * t]))
    parameters = np.array([120.0**2, 2 * 0.1 * 120.0, 0.002, 0.15])
    compiled, python = np.empty((n, 3)), np.empty((n, 3))
    assert backlash.substeps(120.0, rate) == 1 and backlash.substeps(750.0, rate) == 4
    backlash._compiled()(inputs, parameters, 4, 1 / rate, 0.003, compiled)
    backlash._loop(inputs, parameters, 4, 1 / rate, 0.003, python)
    span = np.ptp(compiled, axis=0)
    assert np.all(np.abs(compiled - python) <= 1e-12 * span)
    assert np.ptp(compiled[:, 0]) > 2 * 0.002  # it crossed the band


def test_a_free_load_rattles_the_same_without_its_zero_terms():
    """A free unit load (LoadBacklash's: D = 1, A = B = 0) runs the C loop without those terms and the division by
    1 (issue 38: the division is most of the loop's latency): the same numbers as the general loop, sub-steps or
    not; a link with any term of its own is not free."""
    from symbolic.workflow.effects import backlash
    from symbolic.workflow.effects.joint_elasticity import LinkSide

    assert backlash._compiled_free() is not None, "gcc is needed for this test (the C loop)"
    rate, n = 1000.0, 3000
    t = np.arange(n) / rate
    ones, zeros = np.ones((n, 1)), np.zeros((n, 1))
    link = LinkSide(0.6 * np.sin(2 * np.pi * 1.5 * t), ones, zeros, zeros, ones[:, 0], 1.0, 0)
    assert link.free
    assert not LinkSide(link.torque, ones, zeros + 0.1, zeros, ones[:, 0], 1.0, 0).free
    assert not LinkSide(link.torque, 2 * ones, zeros, zeros, 2 * ones[:, 0], 2.0, 0).free
    for w, steps in [(120.0, 1), (750.0, 4)]:
        parameters = np.array([w**2, 2 * 0.1 * w, 0.002, 1.0])
        general, free = np.empty((n, 3)), np.empty((n, 3))
        backlash._compiled()(link.driving, parameters, steps, 1 / rate, 0.003, general)
        backlash._compiled_free()(link.driving, parameters, steps, 1 / rate, 0.003, free)
        assert np.array_equal(general, free) and np.ptp(free[:, 0]) > 2 * 0.002


def test_a_quantised_loop_s_hunting_is_not_a_dead_band(tmp_path):
    """The tests' axis under PD with a 12-bit encoder and nothing missing: its loop hunts about the quantised reading,
    which the second mass's rattle fitted as a band of 2.2 counts (18 % of the residual, held out too) before a band
    had to span :attr:`Backlash.MIN_COUNTS` of the log's position steps; now nothing is named."""
    import warnings

    import workflow_cases as cases

    text = cases.axis()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = cases.measurements(text, 301, 0.01, resolution=2 * np.pi / 2**12)
        result = diagnose(cases.model_file(tmp_path, text), data, figures=False)
    assert result.found == () and result.corrections == ()


def test_a_band_of_a_few_encoder_counts_is_refused():
    model = derive(loads(truth.model_text(), "joint.toml"))
    q = np.linspace(0.1, 0.5, 200)[:, None]
    effect = EFFECTS["backlash_one_encoder"]
    roles = effect.roles_of(np.array([0.15]), (10.0, 0.1, 0.004), None)
    for step, refused in ((0.002, True), (0.0009, False)):
        context = Context(model.robot, ("q",), q, 0 * q, 0 * q, 40.0, 0.01, model=model, position_step=(step,))
        assert ("2 of the log's position steps" in (effect.check(roles, None, context, 0) or "")) == refused


def test_position_steps_are_an_encoder_s_counts():
    """The smallest change between samples: the count of a quantised column, 0 for a constant one; a column that
    is not quantised gives its smallest change (the rule on the band then asks nothing noticeable)."""
    from symbolic.workflow.dataset import position_steps

    count = 2 * np.pi / 2**14
    t = np.linspace(0.0, 2.0, 2001)
    quantised = np.round(0.3 * np.sin(2 * np.pi * t) / count) * count
    steps = position_steps(np.column_stack([quantised + 1.0, np.full_like(t, 0.2), 0.3 * np.sin(2 * np.pi * t)]))
    assert steps[0] == pytest.approx(count, rel=1e-9) and steps[1] == 0.0 and steps[2] < count / 10
