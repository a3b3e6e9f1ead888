"""Madill's first-peak friction identification (5.3, (5.6)–(5.9)): the printed formulas, recovery of
known J, B, f from simulated proportional-control step responses, experiment files and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

import models
import symbolic
from symbolic.cli import main
from symbolic.data import DataError, Measurements, write
from symbolic.reproduction.madill import first_peak as fp
from symbolic.simulation import simulate
from symbolic.description import modelfile


def joint_text(parameters: str = "") -> str:
    """One revolute joint (:func:`models.axis`): rotor inertia J, viscous B, Coulomb f, no gravity torque;
    ``parameters``: more [parameters] lines."""
    return models.axis(J=0.2, parameters="B = 0.3\nf = 0.09\n" + parameters, friction='viscous = "B"\ncoulomb = "f"')


PERIOD = 1e-3
SIGNALS = '[signals]\nt = "t"\nq_q = "q_q"\ntau_q = "tau_q"\nref_q = "ref_q"\n'


@pytest.fixture(scope="module")
def joint() -> symbolic.DynamicModel:
    return symbolic.derive(modelfile.loads(joint_text()))


def step_log(levels: list[float], hold: float) -> tuple[np.ndarray, np.ndarray]:
    samples = int(round(hold / PERIOD))
    reference = np.repeat(np.asarray(levels, float), samples)
    return np.arange(reference.size) * PERIOD, reference


def run(joint, values: dict[str, float], levels: list[float], hold: float, controller: dict) -> tuple[np.ndarray, np.ndarray, Measurements]:
    """The joint with ``values`` under ``controller`` following the stepped reference; the simulated log."""
    t, reference = step_log(levels, hold)
    n = t.size
    log = Measurements.from_arrays(t, ("q",), np.zeros((n, 1)), np.zeros((n, 1)), ref=reference[:, None])
    result = simulate(joint, log, controller={"reference": "ref", **controller}, parameters=values)
    return t, reference, result.simulated


# -- the formulas as printed ---------------------------------------------------------------------------------


def test_formulas_match_the_printed_form() -> None:
    """(5.8) is the inverse of α = 1 + exp(−ζπ/√(1 − ζ²)); (5.9) inverts t_p; J = K/ωn², B = 2ζ√(KJ)."""
    for zeta in (0.007, 0.1, 0.5, 0.9):
        alpha = fp.slope_from_zeta(zeta)
        beta = -math.log(alpha - 1)
        assert fp.zeta_from_slope(alpha) == pytest.approx(beta / math.sqrt(math.pi**2 + beta**2), rel=1e-15)
        assert fp.zeta_from_slope(alpha) == pytest.approx(zeta, rel=1e-12)
    chain = fp.from_peaks(1.5, 0.02, 0.7, 4.0)
    assert chain.omega_n == pytest.approx(math.pi / (0.7 * math.sqrt(1 - chain.zeta**2)), rel=1e-15)
    assert chain.J == pytest.approx(4.0 / chain.omega_n**2, rel=1e-15)
    assert chain.B == pytest.approx(2 * chain.zeta * math.sqrt(4.0 * chain.J), rel=1e-15)
    assert chain.f == pytest.approx(4.0 * 0.02, rel=1e-15)
    with pytest.raises(ValueError, match="outside"):
        fp.zeta_from_slope(2.0)


@pytest.mark.parametrize("J, B, K", [(0.204, 0.012, 3.61), (0.2, 0.3, 4.0), (0.026, 0.009, 3.69)])
def test_chain_inverts_the_step_response_of_5_7(J: float, B: float, K: float) -> None:
    """The peak and its time read off the step response of K/(Js² + Bs + K) (SciPy, not our formulas)
    give back J and B through (5.8), (5.9)."""
    omega = math.sqrt(K / J)
    t = np.linspace(0.0, 1.5 * math.pi / omega, 30_001)
    _, y = signal.step(signal.lti([K], [J, B, K]), T=t)
    m = int(np.argmax(y))
    chain = fp.from_peaks(float(y[m]), 0.0, float(t[m]), K)
    assert chain.J == pytest.approx(J, rel=1e-4)
    assert chain.B == pytest.approx(B, rel=2e-4)  # t[m] on a grid of 5e-5 t_p


# -- recovery from simulated step responses ------------------------------------------------------------------


@pytest.mark.parametrize(
    "values, gain, resolution, noise",
    [
        ({"J": 0.2, "B": 0.3, "f": 0.09}, 4.0, math.pi / 8000, 1e-4),  # moderately damped; encoder of Table 5.2, noise
        ({"J": 0.204, "B": 0.012, "f": 0.088}, 3.61, math.pi / 8000, 0.0),  # Madill's axial joint (Table 5.4), ζ ≈ 0.007
    ],
)
def test_recovers_J_B_f_within_2_percent(joint, values, gain, resolution, noise) -> None:
    levels = [0.0, -0.1, 0.1, -0.2, 0.1, -0.3, 0.0, 0.15, -0.15, 0.25, -0.1, 0.3, -0.05]
    controller = {"kind": "pd", "kp": [gain], "kd": [0.0], "quantisation": [resolution]}
    t, reference, simulated = run(joint, values, levels, 8.0, controller)
    q = simulated.q[:, 0]
    q = np.floor(q / resolution + 0.5) * resolution + np.random.default_rng(7).normal(0.0, noise, q.size)
    result = fp.identify(t, q, reference, gain)
    assert len(result.steps) == len(levels) - 1 and not result.rejected  # (flat-topped small steps keep their peaks)
    for name in ("J", "B", "f"):
        assert getattr(result, name) == pytest.approx(values[name], rel=0.02), name
    # the sampled loop's hold: without K·T/2 the light damping would be 15 % low
    assert result.hold_damping == pytest.approx(gain * PERIOD / 2, rel=1e-12)


def test_derivative_term_and_delay_are_taken_out_of_the_damping(joint) -> None:
    values = {"J": 0.2, "B": 0.1, "f": 0.05}
    controller = {"kind": "pd", "kp": [5.0], "kd": [0.2], "delay": 2}
    t, reference, simulated = run(joint, values, [0.0, 0.2, -0.1, 0.3, 0.0], 5.0, controller)
    result = fp.identify(t, simulated.q[:, 0], reference, 5.0, derivative_gain=0.2, delay=2)
    assert result.derivative_damping == 0.2 and result.hold_damping == pytest.approx(5.0 * 2.5 * PERIOD)
    for name in ("J", "B", "f"):
        assert getattr(result, name) == pytest.approx(values[name], rel=0.02), name


def test_experiment_file_and_command_line(joint, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The gain declared as an expression of the model's parameters (gtau·kp), read through an experiment file."""
    model = tmp_path / "joint.toml"
    model.write_text(joint_text("gtau = 2.0\n"), encoding="utf-8")
    controller = {"kind": "pd", "kp": [2.0], "kd": [0.0], "gain": "gtau"}
    t, reference, simulated = run(joint, {"J": 0.2, "B": 0.3, "f": 0.09}, [0.0, 0.1, -0.2, 0.3, -0.1], 5.0,
                                  {**controller, "gain": [2.0]})
    write(simulated.__class__.from_arrays(t, ("q",), simulated.q[:, :1], simulated.tau[:, :1], ref=reference[:, None]),
          tmp_path / "steps.csv")
    experiment = tmp_path / "steps.toml"
    experiment.write_text('data = "steps.csv"\nmodel = "joint.toml"\n' + SIGNALS + '[controller]\nkind = "pd"\nkp = [2.0]\n'
                          'kd = [0.0]\ngain = "gtau"\nreference = "ref"\n', encoding="utf-8")
    result = fp.identify_experiment(experiment)
    assert result.gain == 4.0 and result.coordinate == "q"
    assert result.f == pytest.approx(0.09, rel=0.02) and result.J == pytest.approx(0.2, rel=0.02)
    assert main(["-q", "first-peak", str(experiment), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["J"] == pytest.approx(result.J, rel=1e-12) and len(payload["steps"]) == 4
    assert main(["-q", "first-peak", str(experiment)]) == 0
    assert "ζ =" in capsys.readouterr().out


# -- bad input -----------------------------------------------------------------------------------------------


def test_bad_arrays() -> None:
    t = np.arange(1000) * PERIOD
    with pytest.raises(DataError, match="has no step"):
        fp.identify(t, np.zeros(1000), np.zeros(1000), 1.0)
    with pytest.raises(DataError, match="gain K must be a number > 0"):
        fp.identify(t, np.zeros(1000), np.ones(1000), 0.0)
    with pytest.raises(DataError, match="same length"):
        fp.identify(t, np.zeros(999), np.ones(1000), 1.0)
    ramp = np.linspace(0, 1, 1000)
    with pytest.raises(DataError, match="not a sequence of steps"):
        fp.identify(t, ramp, ramp, 1.0)


def test_too_few_usable_steps(joint) -> None:
    values = {"J": 0.2, "B": 0.3, "f": 0.09}
    controller = {"kind": "pd", "kp": [4.0], "kd": [0.0]}
    t, reference, simulated = run(joint, values, [0.0, 0.2], 3.0, controller)
    with pytest.raises(DataError, match=r"1 usable step response\(s\)"):
        fp.identify(t, simulated.q[:, 0], reference, 4.0)
    t, reference, simulated = run(joint, values, [0.0, 0.2, 0.0, 0.2], 3.0, controller)
    with pytest.raises(DataError, match="have the size"):  # the joint rests at different offsets: sizes differ slightly
        fp.identify(t, np.round(simulated.q[:, 0], 1), reference, 4.0)
    # a step shorter than its rise time has no first peak; one within the dead band ±f/K does not move
    t, reference, simulated = run(joint, values, [0.0, 0.2, 0.3, 0.31, -0.1], 0.3, controller)
    with pytest.raises(DataError, match="no first peak"):
        fp.identify(t, simulated.q[:, 0], reference, 4.0)


@pytest.mark.parametrize(
    "controller, message",
    [
        (None, r"\[controller\]: missing"),
        ('kind = "cascade"\nkp = [1.0]\nkv = [1.0]\nreference = "ref"', "needs proportional"),
        ('kind = "pd"\nkp = [1.0]\nkd = [0.1]\nvelocity_filter = [0.5, 0.5]\nreference = "ref"', "filtered derivative"),
        ('kind = "pd"\nkp = [1.0]\nkd = [0.0]\nsaturation = [0.01]\nreference = "ref"', "saturate"),
        ('kind = "pd"\nkp = [1.0]\nkd = [0.0]\ngain = "gtau"\nreference = "ref"', "unknown name 'gtau'"),
    ],
)
def test_bad_experiment_files(tmp_path: Path, capsys: pytest.CaptureFixture[str], controller: str | None, message: str) -> None:
    t, reference = step_log([0.0, 0.1, 0.2], 1.0)
    n = t.size  # a joint that never moves: every check below comes before the steps are looked at
    write(Measurements.from_arrays(t, ("q",), np.zeros((n, 1)), np.zeros((n, 1)), ref=reference[:, None]), tmp_path / "d.csv")
    experiment = tmp_path / "e.toml"
    experiment.write_text('data = "d.csv"\n' + SIGNALS + (f"[controller]\n{controller}\n" if controller else ""), encoding="utf-8")
    with pytest.raises(DataError, match=message):
        fp.identify_experiment(experiment)
    assert main(["-q", "first-peak", str(experiment)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "e.toml" in err and "Traceback" not in err


def test_unknown_coordinate(tmp_path: Path) -> None:
    t, reference = step_log([0.0, 0.1, 0.2], 1.0)
    n = t.size
    write(Measurements.from_arrays(t, ("q",), reference[:, None], np.zeros((n, 1)), ref=reference[:, None]), tmp_path / "d.csv")
    experiment = tmp_path / "e.toml"
    experiment.write_text('data = "d.csv"\n' + SIGNALS + '[controller]\nkind = "pd"\nkp = [1.0]\nkd = [0.0]\nreference = "ref"\n',
                          encoding="utf-8")
    with pytest.raises(DataError, match="'x' is not driven by the controller"):
        fp.identify_experiment(experiment, "x")
