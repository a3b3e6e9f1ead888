"""Output-error identification (DIDIM) against closed-loop logs made without the product's simulator.

The logs come from tests/reference_integrator.py: an axis J·q̈ = τ − Fv·q̇ − Fc·sgn(q̇) integrated exactly
between samples with stick/slip Coulomb friction, under a discrete PD loop at 1 kHz with zero-order hold,
read by a 16-bit encoder (2π/65536 rad) and with white force noise. The product simulates the same loop
with friction's sign smoothed as tanh(v/ε), ε = 1e-4 rad/s: on noise-free, unquantised data its fit
lands within 2e-5 (relative) of the truth, the smoothing's bias; the tolerances below add 4σ to it.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import models
import symbolic
from reference_integrator import ARM, write_arm_experiment, write_axis_experiment
from shared_data import emps  # noqa: F401  (fixture)
from symbolic.data import DataError, load
from symbolic.identify.output_error import closed_loop, output_error

TRUTH = {"J": 0.05, "Fv": 0.3, "Fc": 0.4}
PERTURBED = {"J": 0.065, "Fv": 0.22, "Fc": 0.5}  # +30 %, −27 %, +25 %
SMOOTHING_BIAS = 1e-4
"""Relative: the fit of the tanh-smoothed simulation to the exact stick/slip loop, noise-free (measured 2e-5)."""
NOISE = 0.02  # N·m, about 1 % of the force's RMS (1.95 N·m)


@pytest.fixture(scope="module")
def axis_model():
    return symbolic.derive(symbolic.loads(models.axis(), "axis"))


@pytest.mark.slow
def test_recovers_the_truth_from_perturbed_parameters(axis_model, tmp_path: Path) -> None:
    """(a) From parameters 20-30 % off, with encoder quantisation and force noise: every parameter within
    4σ of the truth (plus the smoothing's bias), the residual's RMS between the noise's standard deviation and
    what the quantiser adds to it, converged (within 1σ: the quantised loop's cost has steps)."""
    experiment = write_axis_experiment(tmp_path, force_noise=NOISE, counts=2**16, seconds=3.0, seed=1)
    fit = output_error(axis_model, experiment, start=PERTURBED)
    assert fit.converged, fit.message
    for name, truth in TRUTH.items():
        p = fit.parameters[name]
        assert abs(p.value - truth) <= 4 * p.sigma + SMOOTHING_BIAS * truth, (name, p, truth)
        assert p.sigma < 0.01 * truth  # the data determine it to better than 1 %
    tau = load(experiment).tau[:, 0]
    rms = fit.errors["force"]["q"] / 100 * np.std(tau)
    # the residual holds the noise and the quantiser's jitter: the simulated encoder reads a count more or
    # less than the machine's at some samples, and kd times the backward difference turns one count into
    # kd·(2π/65536)/T = 0.096 N·m
    jitter = 1.0 * 2 * math.pi / 2**16 / 1e-3
    assert NOISE <= rms <= math.hypot(NOISE, jitter), rms
    assert fit.errors["force"]["q"] < fit.errors_start["force"]["q"] / 5


@pytest.mark.slow
def test_noise_free_optimum_is_kept(axis_model, tmp_path: Path) -> None:
    """(b) Noise-free, exact positions: from the truth it does not move (within the smoothing's bias); from
    the IDIM-LS start (0.5 % off on J here: the filters' bias) it lands on the truth as well."""
    experiment = write_axis_experiment(tmp_path, counts=0, seconds=2.0)
    at_truth = output_error(axis_model, experiment, start=TRUTH)
    from_idim = output_error(axis_model, experiment)
    assert at_truth.converged and from_idim.converged, (at_truth.message, from_idim.message)
    assert from_idim.start_method.startswith("IDIM-LS")
    for name, truth in TRUTH.items():
        assert at_truth.parameters[name].value == pytest.approx(truth, rel=SMOOTHING_BIAS)
        assert from_idim.parameters[name].value == pytest.approx(truth, rel=SMOOTHING_BIAS)
    assert at_truth.iterations <= 2


@pytest.mark.parametrize(("epsilon", "step", "tolerance", "kind"),
                         [(1e-2, 1e-5, 1e-6, "pd"), (1e-4, 1e-7, 3e-6, "pd"), (1e-2, 1e-5, 1e-6, "pid")])
def test_sensitivities_are_the_derivative_of_the_simulation(axis_model, tmp_path: Path, epsilon: float, step: float,
                                                             tolerance: float, kind: str) -> None:
    """(c) ∂y/∂θ by CasADi's forward mode against central differences of the same compiled simulation
    (no quantiser: the staircase has no derivative to compare), force and position. The differences'
    error falls as step² (measured: 1.8e-6, 1.8e-8 at steps 1e-4, 1e-5 for ε = 1e-2); with the default
    ε = 1e-4, tanh(v/ε) bends so sharply at the velocity's zeros that a step of 1e-7 is needed (1.7e-6 at
    1e-6, 7.6e-7 at 1e-7, where rounding starts to count). The PID's integral is part of the state."""
    experiment = write_axis_experiment(tmp_path, counts=0, seconds=0.6)
    if kind == "pid":  # the same log run by a PID (the sensitivities' check needs no truth)
        experiment.write_text(experiment.read_text().replace('kind = "pd"', 'kind = "pid"\nki = [30.0]'))
    measurements = load(experiment)
    names = list(TRUTH)
    loop = closed_loop(axis_model, measurements, names, parameters=PERTURBED, friction_velocity=epsilon)
    theta = np.array([PERTURBED[n] for n in names])
    y, dy = loop.run(theta)
    assert np.isfinite(dy).all()
    for j in range(len(names)):
        h = step * theta[j]
        up, down = theta.copy(), theta.copy()
        up[j] += h
        down[j] -= h
        difference = (loop.run(up, sensitivities=False)[0] - loop.run(down, sensitivities=False)[0]) / (2 * h)
        for column in (0, 3):  # q and τ
            exact = dy[:, column, j]
            assert np.linalg.norm(difference[:, column] - exact) <= tolerance * np.linalg.norm(exact), (names[j], column)


@pytest.mark.slow
def test_two_link_arm_recovers_the_truth(tmp_path: Path) -> None:
    """A two-link arm in a vertical plane under PD on both joints at 500 Hz (tests/reference_integrator.py:
    its dynamics written out by hand, DOP853 at rtol 1e-11 between samples), 18-bit encoders, 0.05 N·m force
    noise: from I1, I2, m2, Fv1, Fv2 20-30 % off (the links' centres of mass and m1 known: the inertial
    parameters enter only combinations), each comes back within 4σ plus 2e-3 — the noise-free fit's offset
    (at most 1.5e-3, on I1), which comes from the initial velocity estimated from the first positions."""
    text = models.arm(parameters="Fv1 = 0.8\nFv2 = 0.5\n", friction1='viscous = "Fv1"', friction2='viscous = "Fv2"')
    model = symbolic.derive(symbolic.loads(text, "arm"))
    experiment = write_arm_experiment(tmp_path, counts=2**18, force_noise=0.05, seed=1)
    start = {"I1": 0.05, "I2": 0.015, "m2": 2.5, "Fv1": 1.0, "Fv2": 0.4}
    fit = output_error(model, experiment, start=start)
    assert fit.converged, fit.message
    for name, p in fit.parameters.items():
        assert abs(p.value - ARM[name]) <= 4 * p.sigma + 2e-3 * ARM[name], (name, p, ARM[name])
    assert max(fit.errors["force"].values()) < 2.0  # %, from about 30
    # from IDIM-LS's consistent parameters, all of them: the inertial ones are seen only in combinations
    combined = output_error(model, experiment, consistent=True)
    assert combined.converged, combined.message
    for name in ("m1", "m2", "c1", "c2", "I1", "I2"):
        assert combined.parameters[name].sigma == math.inf, combined.parameters[name]
    for name in ("Fv1", "Fv2"):
        p = combined.parameters[name]
        assert abs(p.value - ARM[name]) <= 4 * p.sigma + 2e-3 * ARM[name], (name, p)
    assert "only in combinations" in combined.table()
    for c, error in combined.errors["force"].items():
        assert error < combined.errors_start["force"][c], c


@pytest.mark.slow
def test_saturated_loop_still_converges(axis_model, tmp_path: Path) -> None:
    """A command clipped at ±3 N·m (its peaks reach 5): the clip's derivative is 0 where it holds; the fit
    converges from 25-30 % off and recovers the truth within 4σ plus the smoothing's bias."""
    experiment = write_axis_experiment(tmp_path, counts=2**16, force_noise=NOISE, seconds=3.0, saturation=3.0)
    tau = load(experiment).tau[:, 0]
    assert np.mean(np.abs(tau) >= 3.0 - 4 * NOISE) > 0.01  # the limit holds on some samples
    fit = output_error(axis_model, experiment, start=PERTURBED)
    assert fit.converged, fit.message
    for name, truth in TRUTH.items():
        p = fit.parameters[name]
        assert abs(p.value - truth) <= 4 * p.sigma + SMOOTHING_BIAS * truth, (name, p, truth)


def test_a_fitted_parameter_in_the_drive_gain_is_refused(tmp_path: Path) -> None:
    """The controller's constants are evaluated once: a parameter setting its drive gain cannot be fitted."""
    model = symbolic.derive(symbolic.loads(models.axis(parameters="Fv = 0.3\nFc = 0.4\nkg = 1.0\n"), "axis"))
    experiment = write_axis_experiment(tmp_path, counts=0, seconds=0.3)
    experiment.write_text(experiment.read_text() + 'gain = "kg"\n')
    with pytest.raises(symbolic.errors.IdentificationError, match=r"gain: kg would be fitted.*--fix kg"):
        output_error(model, experiment, start={"J": 0.05, "kg": 1.0})


def test_torque_replay_has_no_force_error_to_fit(axis_model, tmp_path: Path) -> None:
    """Under torque replay the simulated force is the logged one: --signals force is refused, naming what to do."""
    write_axis_experiment(tmp_path, counts=0, seconds=0.3)
    with pytest.raises(DataError, match="forces are replayed.*--signals position"):
        output_error(axis_model, tmp_path / "axis.csv", start=TRUTH)
    with pytest.raises(DataError, match="unknown signals 'speed'"):
        output_error(axis_model, tmp_path / "axis.csv", signals="speed")


@pytest.mark.parametrize("counts", [0, 2**16])
def test_substeps_unstable_at_a_trial_step_are_chosen_again(axis_model, tmp_path: Path, counts: int) -> None:
    """From an inertia 4× the truth's, the RK4 sub-steps chosen at the start (21 a sample, 1 when calm) give
    h·ρ ≈ 3.8 at the truth — the smoothed sign's rate Fc/(J·ε) grows as J falls — outside RK4's stability bound
    2.785. There the simulated state stays finite but its sensitivities grow without bound: the fit once stopped
    "converged" (the Gauss–Newton step "inf σ") at J, Fv, Fc = 0.0418, 0.121, 0.462 with the exact encoder, and
    at 0.0485, 0.269, 0.519 with the 16-bit one and calm samples (sensitivities of 10⁴⁴). A trial step there now
    has the sub-steps chosen again (docs/data.md, "Output error"), and the noise-free fit lands on the truth."""
    experiment = write_axis_experiment(tmp_path, counts=counts, seconds=1.0)
    start = {**TRUTH, "J": 4 * TRUTH["J"]}
    loop = closed_loop(axis_model, load(experiment), list(TRUTH), parameters=start)
    at_start, at_truth = np.array(list(start.values())), np.array(list(TRUTH.values()))
    assert loop.calm and loop.stable(at_start) and not loop.stable(at_truth)
    finer = loop.restepped(at_truth)
    assert finer.substeps > loop.substeps and finer.stable(at_truth) and finer.stable(at_start)
    fit = output_error(axis_model, experiment, start=start)
    assert fit.converged, fit.message
    for name, truth in TRUTH.items():  # the quantised loop's cost has steps: within 1e-3 of the truth
        assert fit.parameters[name].value == pytest.approx(truth, rel=SMOOTHING_BIAS if counts == 0 else 1e-3), name


def test_stops_unconverged_and_says_so(axis_model, tmp_path: Path) -> None:
    experiment = write_axis_experiment(tmp_path, counts=0, seconds=0.5)
    fit = output_error(axis_model, experiment, start=PERTURBED, max_iterations=1)
    assert not fit.converged and fit.iterations == 1
    assert "stopped after 1 iterations" in fit.message and fit.to_dict()["converged"] is False


def test_a_signal_weighted_zero_is_left_out_of_the_cost(axis_model, tmp_path: Path) -> None:
    """"both" with the position's weight 0 fits as "force" alone (its columns weigh 0, not 0/0 = NaN, which
    made the least squares fail with 'SVD did not converge')."""
    experiment = write_axis_experiment(tmp_path, counts=0, seconds=0.5)
    both = output_error(axis_model, experiment, start=PERTURBED, signals="both", weights=(1.0, 0.0), max_iterations=2)
    force = output_error(axis_model, experiment, start=PERTURBED, signals="force", max_iterations=2)
    assert math.isfinite(both.cost) and both.cost == pytest.approx(force.cost, rel=1e-9)
    for name in TRUTH:
        assert both.parameters[name].value == pytest.approx(force.parameters[name].value, rel=1e-9)


def run(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "symbolic", "-q", *args], capture_output=True, text=True, env=env)


@pytest.mark.slow
def test_command_writes_the_model_file(tmp_path: Path) -> None:
    """``identify --method didim --fix Fc --out``: Fc kept, the others fitted and written, JSON says converged."""
    model = tmp_path / "axis.toml"
    model.write_text(models.axis(), encoding="utf-8")
    experiment = write_axis_experiment(tmp_path, counts=2**16, seconds=1.5, force_noise=NOISE)
    out = tmp_path / "fitted.toml"
    result = run("identify", str(model), str(experiment), "--method", "didim", "--fix", "Fc", "--out", str(out),
                 "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["converged"] is True and set(report["parameters"]) == {"J", "Fv"} and report["fixed"] == {"Fc": 0.4}
    fitted = symbolic.load(out)
    values = {p.name: p.value for p in fitted.parameters}
    assert values["J"] == pytest.approx(report["parameters"]["J"]["value"]) and values["Fc"] == 0.4
    bad = run("identify", str(model), str(experiment), "--method", "didim", "--max-iterations", "0")
    assert bad.returncode != 0 and "max_iterations: expected a whole number ≥ 1, got 0" in bad.stderr


@pytest.mark.slow
def test_emps_converges_from_the_idim_ls_start(emps: Path) -> None:  # noqa: F811
    """(d) EMPS (shipped experiment, its cascade loop): DIDIM on the force converges from IDIM-LS; the
    parameters move by less than 5 % (docs/data.md, "Output error", gives them beside IDIM-LS) and the
    force's error does not grow."""
    from symbolic import robots

    model = symbolic.derive(robots.load("emps"))
    fit = output_error(model, robots.example_path("emps_estimation"))
    assert fit.converged, fit.message
    for p in fit.parameters.values():
        assert abs(p.value - p.start) <= 0.05 * abs(p.start), p
        assert math.isfinite(p.sigma) and p.sigma > 0
    assert fit.errors["force"]["q"] <= fit.errors_start["force"]["q"]
