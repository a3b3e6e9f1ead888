"""The simulator (symbolic.simulation.simulate) against independent references.

* the discrete controller against a loop written here in NumPy, for every kind and feature;
* the CasADi right-hand side against NumericModel.forward_dynamics (SymPy → math);
* a closed loop simulated here with SciPy's DOP853 on NumericModel (the "truth"), logged with
  quantisation and noise, then re-simulated from the log: errors at the noise level (the truth's own
  errors against the log); with a 10 % mass error, clearly above it;
* energy conservation without friction and control, for a rigid and a flexible model, at RK4's order;
* the sub-step from the spectral radius: equal to the highest natural frequency of the flexible
  five-bar, and stable where one step per sample is not;
* Coulomb sticking without chatter (smoothed sign), and sliding at the terminal velocity.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, fsolve

import symbolic
from symbolic.data import DataError, Experiment, Measurements, Settings
from symbolic.simulation import controller as control
from symbolic.numeric import natural_frequencies
from symbolic.simulation import simulate
from symbolic.simulation.comparison import SIGNALS, compare
from symbolic.simulation.simulator import _plant, initial_velocity
import controller_steps
import models
from conftest import derived

GOLDEN = Path(__file__).parent / "golden"

PENDULUM_FRICTION = """
[[friction]]
coordinate = "q1"
viscous = "0.05"

[[friction]]
coordinate = "q2"
viscous = "0.03"
"""


@pytest.fixture(scope="module")
def pendulum() -> symbolic.DynamicModel:
    """The golden double pendulum with viscous friction on both joints."""
    return symbolic.derive(symbolic.loads((GOLDEN / "double_pendulum.toml").read_text() + PENDULUM_FRICTION))


# -- the controller ---------------------------------------------------------------------------------------------


LOOP_KINDS = [k for k in control.KINDS if k not in (control.STATE_FEEDBACK, control.CASCADE_PI)]
"""The kinds with per-coordinate loops; state feedback and the PI cascade have their own contract tests
(tests/test_state_feedback.py, tests/test_cascade.py)."""


def reference_loop(kind: str, q: np.ndarray, r: np.ndarray, d: np.ndarray, tau_log: np.ndarray, period: float,
                   gains: dict, gain: np.ndarray, saturation: np.ndarray, resolution: np.ndarray, taps: np.ndarray,
                   delay: int) -> np.ndarray:
    """The [controller] contract written out sample by sample (docs/simulation.md), for one coordinate set."""
    samples, nc = q.shape
    measured = np.where(resolution > 0, np.floor(q / np.where(resolution > 0, resolution, 1) + 0.5) * resolution, q)
    backward = np.zeros((samples, nc))
    backward[1:] = np.diff(measured, axis=0) / period
    velocity = np.zeros((samples, nc))
    for i, w in enumerate(taps):
        velocity[i:] += w * backward[: samples - i]
    error = r - measured
    integral = np.cumsum(error, axis=0) * period
    u = {
        "torque": tau_log,
        "pd": gains["kp"] * error - gains["kd"] * velocity,
        "pid": gains["kp"] * error - gains["kd"] * velocity + gains.get("ki", 0) * integral,
        "cascade": gains.get("kv", 0) * (gains["kp"] * error - velocity),
    }[kind]
    u = np.clip(u, -saturation, saturation)
    applied = np.zeros_like(u)
    applied[delay:] = u[: samples - delay]
    return gain * (applied + d)


@pytest.mark.parametrize("kind", LOOP_KINDS)
@pytest.mark.parametrize("delay", [0, 2, control.LINE_IN_MEMORY + 8])
def test_controller_function_is_the_contract(kind: str, delay: int) -> None:
    """A delay up to LINE_IN_MEMORY is in the function's memory; a longer one in a DelayLine, one sample at a time."""
    rng = np.random.default_rng(7)
    samples, period = 60, 2e-3
    names = ("a", "b", "c")  # the model's coordinates; the controller drives c and a, in that order
    q = np.cumsum(rng.normal(0, 1e-3, (samples, 3)), axis=0)
    table = {"kind": kind, "coordinates": ["c", "a"], "delay": delay, "gain": [2.0, 0.5], "saturation": [0.4, 1e9],
             "quantisation": [1e-4, 0.0], "disturbance": ["dist_c", "0.01*t"]}
    gains = {"kp": np.array([30.0, 10.0]), "kd": np.array([0.3, 0.1]), "ki": np.array([5.0, 1.0]),
             "kv": np.array([2.0, 4.0])}
    if kind != "torque":
        table.update({k: gains[k].tolist() for k in control.GAINS[kind]})
        table.update({"reference": ["0.01*sin(t)", "ref_a"], "velocity_filter": [0.5, 0.3, 0.2]})
    t = np.arange(samples) * period
    log = Measurements.from_arrays(t, ["a", "c"], q[:, [0, 2]], rng.normal(0, 1, (samples, 2)),
                                   ref=rng.normal(0, 1e-2, (samples, 2)), extras={"dist_c": rng.normal(0, 0.1, samples)})
    ctrl = control.parse(table, log.coordinates, (), "<test>", names)
    signals = control.inputs(ctrl, log, names)
    assert control.line_outside(ctrl) == (delay > control.LINE_IN_MEMORY) and ctrl.delay == delay
    got = controller_steps.run_step(ctrl, names, period, q, signals)
    expected_r = np.column_stack([0.01 * np.sin(t), log.ref[:, 0]])
    expected_d = np.column_stack([log.extras["dist_c"], 0.01 * t])
    taps = np.array([0.5, 0.3, 0.2]) if kind != "torque" else np.array([1.0])
    expected = reference_loop(kind, q[:, [2, 0]], expected_r, expected_d, log.tau[:, [1, 0]], period, gains,
                              np.array([2.0, 0.5]), np.array([0.4, 1e9]), np.array([1e-4, 0.0]), taps, delay)
    np.testing.assert_allclose(got[:, [2, 0]], expected, rtol=1e-12, atol=1e-12)
    assert np.all(got[:, 1] == 0.0)  # b is not driven


def delayed_axis_reference(J: float, Fv: float, kp: float, kd: float, t: np.ndarray, r: np.ndarray, delay: int,
                           substeps: int) -> np.ndarray:
    """The closed loop J·q̈ = τ − Fv·q̇ written out: PD on the exact position and the backward-difference
    velocity, its output applied ``delay`` samples later (0 before), held, RK4 with ``substeps``; rows
    [q, q̇, τ] at the samples, from rest at q = 0."""
    period = t[1] - t[0]
    h = period / substeps
    x, previous = np.zeros(2), 0.0
    outputs, rows = [], []
    for k in range(len(t)):
        v = 0.0 if k == 0 else (x[0] - previous) / period
        previous = x[0]
        outputs.append(kp * (r[k] - x[0]) - kd * v)
        tau = outputs[k - delay] if k >= delay else 0.0
        rows.append([x[0], x[1], tau])
        f = lambda y: np.array([y[1], (tau - Fv * y[1]) / J])  # noqa: E731
        for _ in range(substeps):
            k1 = f(x)
            k2 = f(x + h / 2 * k1)
            k3 = f(x + h / 2 * k2)
            k4 = f(x + h * k3)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return np.array(rows)


@pytest.mark.parametrize("delay", [3, control.LINE_IN_MEMORY + 1, 57])
def test_delayed_loop_matches_a_loop_written_out(delay: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Delays on both sides of LINE_IN_MEMORY (57 does not divide the 400 samples: a short last chunk)
    against the loop written here, and the ring buffer against the shift register it replaces (the same
    run with the whole line in memory)."""
    model = symbolic.derive(symbolic.loads(models.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), "axis"))
    t = np.arange(400) * 1e-3
    r = 0.2 * np.sin(2 * np.pi * 3 * t) + 0.1
    log = Measurements.from_arrays(t, ["q"], np.zeros((400, 1)), np.zeros((400, 1)), ref=r[:, None])
    table = {"kind": "pd", "kp": [8.0], "kd": [0.2], "reference": "ref", "delay": delay}
    run = simulate(model, log, controller=table, initial=(np.zeros(1), np.zeros(1)), substeps=2)
    expected = delayed_axis_reference(0.05, 0.3, 8.0, 0.2, t, r, delay, 2)
    got = np.column_stack([run.simulated.q[:, 0], run.simulated.qd[:, 0], run.simulated.tau[:, 0]])
    assert np.abs(expected[:, 2]).max() > 0.5  # the controller acts, and against its own delay
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    monkeypatch.setattr(control, "LINE_IN_MEMORY", 10**6)
    in_memory = simulate(model, log, controller=table, initial=(np.zeros(1), np.zeros(1)), substeps=2)
    np.testing.assert_allclose(in_memory.simulated.q, run.simulated.q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(in_memory.simulated.tau, run.simulated.tau, rtol=0, atol=1e-14)


def test_delayed_loop_in_solve_ivp_matches_the_fixed_step() -> None:
    """The solve_ivp path runs its delay line one sample at a time: the same forces as RK4's chunks, the
    positions to the tolerances."""
    model = symbolic.derive(symbolic.loads(models.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), "axis"))
    t = np.arange(200) * 1e-3
    log = Measurements.from_arrays(t, ["q"], np.zeros((200, 1)), np.zeros((200, 1)), ref=np.full((200, 1), 0.1))
    table = {"kind": "pd", "kp": [8.0], "kd": [0.2], "reference": "ref", "delay": control.LINE_IN_MEMORY + 5}
    start = (np.zeros(1), np.zeros(1))
    rk4 = simulate(model, log, controller=table, initial=start, substeps=8)
    radau = simulate(model, log, controller=table, initial=start, method="Radau", rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(radau.simulated.q, rk4.simulated.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(radau.simulated.tau, rk4.simulated.tau, rtol=0, atol=1e-6)


def test_delay_reaching_the_end_of_the_log_is_refused(tmp_path: Path) -> None:
    """A delay of samples − 1 or more leaves no interval for any output to act: refused where the experiment
    is read and where a table is given to simulate, with the allowed range."""
    model = derived("emps")
    t = np.arange(50) * 1e-3
    log = Measurements.from_arrays(t, ["q"], np.zeros((50, 1)), np.zeros((50, 1)), ref=np.zeros((50, 1)))
    table = {"kind": "pd", "kp": [1.0], "kd": [0.0], "reference": "ref"}
    simulate(model, log, controller={**table, "delay": 48})  # the first output acts over the last interval
    with pytest.raises(DataError) as info:
        simulate(model, log, controller={**table, "delay": 49})
    assert str(info.value) == ("<arrays>: [controller] delay: 49 samples reaches the end of the log (50 samples): "
                               "no output would act within it (allowed: 0 to 48)")
    data_file = symbolic.data.write_columns({"t": t, "q_q": t * 0, "tau_q": t * 0, "ref_q": t * 0},
                                            tmp_path / "log.csv")
    experiment = tmp_path / "run.experiment.toml"
    experiment.write_text(f'data = "{data_file.name}"\n[signals]\nt = "t"\nq_q = "q_q"\ntau_q = "tau_q"\n'
                          'ref_q = "ref_q"\n[controller]\nkind = "pd"\nkp = [1.0]\nkd = [0.0]\n'
                          'reference = "ref"\ndelay = 100000\n')
    with pytest.raises(DataError) as info:
        symbolic.data.load(experiment)
    assert str(info.value) == (f"{experiment}: [controller] delay: 100000 samples reaches the end of the log "
                               "(50 samples): no output would act within it (allowed: 0 to 48)")


def test_gain_may_name_a_parameter() -> None:
    model = derived("emps")
    ctrl = control.parse({"kind": "pd", "kp": [1.0], "kd": [0.0], "reference": ["0"], "gain": "gtau"}, ("q",),
                         model.parameter_symbols, "<test>")
    c = control.constants(ctrl, dict(zip(model.parameter_symbols, model.parameters.values())))
    assert c[4] == pytest.approx(35.15)


# -- the plant ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["janot_branch", "single_flexible_link", "omni"])
def test_right_hand_side_is_the_forward_dynamics(name: str) -> None:
    """Away from zero velocity (|q̇| ≥ 0.05, tanh(q̇/1e-4) = sign(q̇) in floating point) the smoothed
    right-hand side equals NumericModel.forward_dynamics, which has the exact sign."""
    model = derived(name)
    num = symbolic.numeric_model(model)
    plant = _plant(model)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-1, 1, model.n) * 0.5
        qd = rng.choice([-1, 1], model.n) * rng.uniform(0.05, 1.0, model.n)
        tau = rng.normal(0, 1, model.n)
        xdot = np.asarray(plant.rhs(np.concatenate([q, qd]), tau, num.p0, 1e-4, 0.0)).ravel()
        np.testing.assert_allclose(xdot[: model.n], qd, rtol=0, atol=0)
        np.testing.assert_allclose(xdot[model.n:], num.forward_dynamics(q, qd, tau), rtol=1e-10, atol=1e-10)


# -- self-made truth ---------------------------------------------------------------------------------------------

KP, KD, RESOLUTION = np.array([60.0, 30.0]), np.array([3.0, 1.5]), 1e-5
SIGMA_Q, SIGMA_TAU = 1e-5, 0.05


def truth(model: symbolic.DynamicModel, duration: float = 1.5, rate: float = 1000.0):
    """PD at ``rate`` with zero-order hold and a quantising sensor, integrated by DOP853 on NumericModel.

    Starts at rest in equilibrium under the held reference (so the log starts at rest), the reference
    moving after 0.2 s. Returns t, reference, q, q̇, q̈, τ.
    """
    num = symbolic.numeric_model(model)
    h = 1.0 / rate
    t = np.arange(int(round(duration * rate)) + 1) * h
    moving = np.clip(t - 0.2, 0, None)
    ref = np.column_stack([-1.2 + 0.4 * (1 - np.cos(2 * np.pi * 0.5 * moving)),
                           0.2 + 0.3 * (1 - np.cos(2 * np.pi * 0.8 * moving))])
    x = np.concatenate([fsolve(lambda q: KP * (ref[0] - q) - num.gravity(q), ref[0], xtol=1e-13), np.zeros(2)])
    previous = None
    out = []
    for k in range(len(t)):
        measured = np.floor(x[:2] / RESOLUTION + 0.5) * RESOLUTION
        v = np.zeros(2) if previous is None else (measured - previous) / h
        tau = KP * (ref[k] - measured) - KD * v
        previous = measured
        out.append(np.concatenate([x, num.forward_dynamics(x[:2], x[2:], tau), tau]))
        x = solve_ivp(lambda s, y: np.concatenate([y[2:], num.forward_dynamics(y[:2], y[2:], tau)]), (0, h), x,
                      method="DOP853", rtol=1e-11, atol=1e-13).y[:, -1]
    out = np.array(out)
    return t, ref, out[:, :2], out[:, 2:4], out[:, 4:6], out[:, 6:]


@pytest.mark.slow
def test_resimulated_log_agrees_to_the_noise_level(pendulum: symbolic.DynamicModel) -> None:
    t, ref, q, qd, qdd, tau = truth(pendulum)
    rng = np.random.default_rng(1)
    logged = np.floor(q / RESOLUTION + 0.5) * RESOLUTION + rng.normal(0, SIGMA_Q, q.shape)
    log = Measurements.from_arrays(t, ["q1", "q2"], logged, tau + rng.normal(0, SIGMA_TAU, tau.shape), ref=ref)
    log = Experiment.of(log, settings=Settings(bandwidth=3.0))
    exact = Measurements.from_arrays(t, ["q1", "q2"], q, tau, qd=qd, qdd=qdd)
    table = {"kind": "pd", "kp": KP.tolist(), "kd": KD.tolist(), "reference": "ref",
             "quantisation": [RESOLUTION, RESOLUTION]}
    comparisons = [compare(log, exact),  # the truth itself against its log: the noise level
                   simulate(pendulum, log, controller=table).compare(),
                   simulate(pendulum, log, controller=table, parameters={"m1": 1.1, "m2": 0.88}).compare()]
    # every comparison filters the log with the experiment's treatment: cut-off 5 × 3 Hz, not the rule's 5 × 20 Hz
    assert [c.treatment.cutoff for c in comparisons] == [15.0] * 3
    noise, right, wrong = (c.relative_errors() for c in comparisons)
    for c in ("q1", "q2"):
        for signal in SIGNALS:
            assert right[c][signal] <= 1.3 * noise[c][signal], (c, signal, right[c][signal], noise[c][signal])
            floor = 1.2 if signal == "acceleration" else 5.0  # q̈ is dominated by the controller's quantisation steps
            assert wrong[c][signal] >= floor * noise[c][signal], (c, signal, wrong[c][signal], noise[c][signal])


@pytest.mark.slow
def test_exact_initial_state_reproduces_the_truth(pendulum: symbolic.DynamicModel) -> None:
    """From the truth's own initial state, RK4 follows DOP853 to its order: the error falls ~16× per halving."""
    t, ref, q, qd, qdd, tau = truth(pendulum, duration=0.6)
    log = Measurements.from_arrays(t, ["q1", "q2"], q, tau, ref=ref)
    table = {"kind": "pd", "kp": KP.tolist(), "kd": KD.tolist(), "reference": "ref",
             "quantisation": [RESOLUTION, RESOLUTION]}
    errors = []
    for substeps in (1, 2):
        run = simulate(pendulum, log, controller=table, initial=(q[0], qd[0]), substeps=substeps)
        np.testing.assert_array_equal(run.simulated.tau, tau)  # the same quantised measurements, sample for sample
        errors.append(np.abs(run.simulated.q - q).max())
    assert errors[0] < 1e-9 and 10 < errors[0] / errors[1] < 24, errors


def test_stiff_and_fixed_step_agree(pendulum: symbolic.DynamicModel) -> None:
    t = np.arange(301) * 1e-3
    ref = np.column_stack([-1.0 + 0.2 * np.sin(5 * t), 0.3 * np.sin(7 * t)])
    log = Measurements.from_arrays(t, ["q1", "q2"], np.tile(ref[0], (301, 1)), np.zeros((301, 2)), ref=ref)
    table = {"kind": "pid", "kp": [40.0, 20.0], "kd": [2.0, 1.0], "ki": [5.0, 5.0], "reference": "ref"}
    start = (ref[0], np.zeros(2))
    rk4 = simulate(pendulum, log, controller=table, initial=start, substeps=4)
    vm = simulate(pendulum, log, controller=table, initial=start, substeps=4, compiled=False)
    radau = simulate(pendulum, log, controller=table, initial=start, method="Radau", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(vm.simulated.q, rk4.simulated.q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(radau.simulated.q, rk4.simulated.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(radau.simulated.qdd, rk4.simulated.qdd, rtol=0, atol=1e-6)


# -- energy -------------------------------------------------------------------------------------------------------


def energy_drift(model: symbolic.DynamicModel, substeps: int, modal: float) -> float:
    """Largest relative change of ½q̇ᵀDq̇ + V + V_strain over 10 s at 1 kHz, unforced, from a moving start."""
    num = symbolic.numeric_model(model)
    names = model.robot.generalized_coordinates
    rigid = len(model.robot.coordinates)
    t = np.arange(10001) * 1e-3
    log = Measurements.from_arrays(t, names[:rigid], np.zeros((len(t), rigid)), np.zeros((len(t), rigid)))
    q0, qd0 = np.full(model.n, modal), np.zeros(model.n)
    q0[:rigid], qd0[:rigid] = 0.3, 0.5
    run = simulate(model, log, initial=(q0, qd0), substeps=substeps)
    order = [list(run.simulated.coordinates).index(c) for c in names]
    q, qd = run.simulated.q[::50, order], run.simulated.qd[::50, order]
    energy = np.array([0.5 * v @ num.inertia(x) @ v + num.potential(x) + num.strain_energy(x) for x, v in zip(q, qd)])
    return float(np.abs(energy - energy[0]).max() / abs(energy[0]))


@pytest.mark.slow
@pytest.mark.parametrize(("name", "substeps", "modal"), [("omni", 1, 0.0), ("single_flexible_link", 20, 1e-3)])
def test_energy_is_conserved_to_the_integrators_order(name: str, substeps: int, modal: float) -> None:
    model = derived(name)
    assert not model.robot.frictions and not model.robot.forces
    coarse, fine = energy_drift(model, substeps, modal), energy_drift(model, 2 * substeps, modal)
    assert fine < 1e-3, (coarse, fine)
    assert coarse / fine > 12, (coarse, fine)  # at least RK4's fourth order (2⁴ = 16; 2⁵ seen: dissipative error)


# -- sub-steps -----------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_substeps_follow_the_highest_natural_frequency() -> None:
    model = derived("fivebar_flexible")
    omega = natural_frequencies(model)[0].max()
    t = np.arange(1001) / 500.0  # 500 Hz: one RK4 step per sample has h·ω = 4.3 > 2.83, unstable
    log = Measurements.from_arrays(t, ["q0", "q1", "q2"], np.zeros((len(t), 3)), np.zeros((len(t), 3)))
    start = (np.zeros(model.n), np.zeros(model.n))
    run = simulate(model, log, initial=start)
    assert run.spectral_radius == pytest.approx(omega, rel=1e-9)
    assert run.substeps == math.ceil(omega / 500.0)
    assert np.isfinite(run.simulated.q).all() and np.abs(run.simulated.q).max() < 1.0
    with pytest.raises(DataError, match="no longer finite"):
        simulate(model, log, initial=start, substeps=1)


# -- friction ------------------------------------------------------------------------------------------------------


def pushed(force: float, seconds: float = 2.0) -> Measurements:
    t = np.arange(int(seconds * 1000) + 1) * 1e-3
    return Measurements.from_arrays(t, ["q"], np.zeros((len(t), 1)), np.full((len(t), 1), force))


def test_coulomb_friction_sticks_without_chatter() -> None:
    """EMPS pushed by 10 N: with the offset −3.16 N, 13.16 N < Fc = 20.39 N, so it sticks: it creeps at the
    v of Fv·v + Fc·tanh(v/ε) = 13.16 N (≈ ε·artanh(13.16/20.39)) and the velocity never changes sign."""
    model = derived("emps")
    values = {s.name: v for s, v in model.parameters.items()}
    eps = 1e-4
    run = simulate(model, pushed(10.0), initial=([0.0], [0.0]), friction_velocity=eps)
    creep = brentq(lambda v: values["Fv"] * v + values["Fc"] * math.tanh(v / eps) - (10.0 - values["offset"]), 0, 10 * eps,
                   xtol=1e-16)
    assert creep < eps * math.atanh((10.0 - values["offset"]) / values["Fc"])
    v = run.simulated.qd[:, 0]
    assert np.all(v >= 0) and v.max() <= creep * (1 + 1e-9)
    assert v[-1] == pytest.approx(creep, rel=1e-6)
    assert run.simulated.q[-1, 0] < 2.0 * creep


def test_coulomb_friction_slides_at_the_terminal_velocity() -> None:
    model = derived("emps")
    values = {s.name: v for s, v in model.parameters.items()}
    run = simulate(model, pushed(60.0, 10.0), initial=([0.0], [0.0]))
    terminal = (60.0 - values["offset"] - values["Fc"]) / values["Fv"]
    assert run.simulated.qd[-1, 0] == pytest.approx(terminal, rel=1e-9)


def test_initial_velocity_is_the_slope_of_a_parabola() -> None:
    t = np.arange(200) * 1e-3
    q = 0.1 + 0.3 * t + 2.0 * t**2
    log = Measurements.from_arrays(t, ["q"], q[:, None], np.zeros((200, 1)))
    assert initial_velocity(log)[0] == pytest.approx(0.3, rel=1e-9)


# -- Pinocchio ---------------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_panda_closed_loop_agrees_with_pinocchio_aba() -> None:
    """The same discrete PD and RK4 steps with Pinocchio's articulated-body algorithm (an independent
    dynamics): the two trajectories agree to rounding over 1 s."""
    pin = pytest.importorskip("pinocchio")
    from reference_pinocchio import build

    model = derived("panda")
    reference = build(model.robot)
    workspace = reference.createData()
    q0 = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    t = np.arange(1001) * 1e-3
    ref = q0 + 0.3 * np.sin(2 * np.pi * np.outer(t, np.linspace(0.2, 0.5, 7)))
    kp, kd = np.array([600.0, 600, 600, 600, 250, 150, 50]), np.array([30.0, 30, 30, 30, 10, 10, 5])
    coordinates = list(model.robot.coordinates)
    log = Measurements.from_arrays(t, coordinates, np.tile(q0, (len(t), 1)), np.zeros((len(t), 7)), ref=ref)
    table = {"kind": "pd", "kp": kp.tolist(), "kd": kd.tolist(), "reference": "ref"}
    simulated = simulate(model, log, controller=table, initial=(q0, np.zeros(7)), substeps=2).simulated
    h = 0.5e-3
    q, v, previous = q0.copy(), np.zeros(7), None
    worst = 0.0
    for k in range(len(t)):
        velocity = np.zeros(7) if previous is None else (q - previous) * 1e3
        tau = kp * (ref[k] - q) - kd * velocity
        previous = q.copy()
        worst = max(worst, np.abs(simulated.q[k] - q).max(), np.abs(simulated.qd[k] - v).max())
        for _ in range(2):
            a1 = pin.aba(reference, workspace, q, v, tau)
            a2 = pin.aba(reference, workspace, q + h / 2 * v, v + h / 2 * a1, tau)
            a3 = pin.aba(reference, workspace, q + h / 2 * (v + h / 2 * a1), v + h / 2 * a2, tau)
            a4 = pin.aba(reference, workspace, q + h * (v + h / 2 * a2), v + h * a3, tau)
            q, v = (q + h / 6 * (v + 2 * (v + h / 2 * a1) + 2 * (v + h / 2 * a2) + (v + h * a3)),
                    v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4))
    assert worst < 1e-11, worst


def test_rk4_stability_bounds_are_where_the_stability_function_has_modulus_one() -> None:
    """docs/simulation.md ("Sub-steps"): RK4's R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 has |R| = 1 at z = ±i·2√2 and
    at z = −2.785…; just inside each bound |R| < 1, just outside > 1."""
    from symbolic.simulation.simulator import RK4_IMAGINARY_BOUND, RK4_REAL_BOUND

    def R(z: complex) -> float:
        return abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)

    assert RK4_IMAGINARY_BOUND == pytest.approx(2.8284271247461903, rel=1e-15)
    for z in (1j * RK4_IMAGINARY_BOUND, -RK4_REAL_BOUND):
        assert R(z) == pytest.approx(1.0, abs=1e-12)
        assert R(z * (1 - 1e-6)) < 1.0 < R(z * (1 + 1e-6))


# -- the whole command on a warm cache folder: no SymPy (issue 38 §2) --------------------------------------------


def _emps_experiment(folder: Path, model: str = "emps") -> Path:
    """A 2 s, 1 kHz PD log of the EMPS carriage (a CSV file and its experiment file) in ``folder``."""
    t = np.arange(2001) * 1e-3
    ref = 0.05 * np.sin(2 * np.pi * t)
    np.savetxt(folder / "log.csv", np.column_stack([t, ref, np.zeros_like(t), ref]), delimiter=",",
               header="t,q,tau,r", comments="", fmt="%.17g")
    path = folder / "run.toml"
    path.write_text(f'data = "log.csv"\nmodel = "{model}"\n\n[signals]\nt = "t"\nq_q = "q"\ntau_q = "tau"\n'
                    'ref_q = "r"\n\n[controller]\nkind = "pd"\ncoordinates = ["q"]\nkp = [20000.0]\nkd = [500.0]\n'
                    'gain = 1\nreference = "ref"\n')
    return path


def _simulate_command(cache: Path, *argv: str) -> tuple[dict, list[str]]:
    """``symbolic -q simulate ARGV --json`` in a fresh process with the cache folder ``cache``: its JSON (without
    the timings) and which of SymPy and the derivation it imported."""
    import json
    import os
    import subprocess
    import sys

    code = ("import contextlib, io, json, sys\nfrom symbolic import cli\nout = io.StringIO()\n"
            "with contextlib.redirect_stdout(out):\n    code = cli.main(sys.argv[1:])\n"
            "assert code == 0, code\nresult = json.loads(out.getvalue())\nresult.pop('timings')\n"
            "print(json.dumps([result, sorted(m for m in sys.modules if m == 'sympy' or "
            "m.startswith('symbolic.derivation'))]))")
    env = dict(os.environ, SYMBOLIC_CACHE_DIR=str(cache))
    done = subprocess.run([sys.executable, "-c", code, "-q", "simulate", *argv, "--json"], capture_output=True,
                          text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    result, imported = json.loads(done.stdout.splitlines()[-1])
    return result, imported


def test_warm_simulate_command_does_not_import_sympy(tmp_path: Path) -> None:
    """docs/simulation.md ("The whole command"): the first run derives the model and keeps its numbers and CasADi
    plant in the cache folder; the second reads them and neither parses the model file nor imports SymPy, and
    gives the same result."""
    experiment = _emps_experiment(tmp_path)
    cold, imported = _simulate_command(tmp_path / "cache", "emps", str(experiment))
    assert "sympy" in imported
    warm, imported = _simulate_command(tmp_path / "cache", "emps", str(experiment))
    assert imported == []
    assert warm == cold


def test_a_changed_model_file_is_not_simulated_from_its_old_numbers(tmp_path: Path) -> None:
    """The numbers kept for a warm run are keyed by the model file: a parameter changed in it is simulated
    with its new value (as from an empty cache folder), never with the numbers of the file before."""
    model = tmp_path / "carriage.toml"
    model.write_text(symbolic.robots.path("emps").read_text())
    experiment = _emps_experiment(tmp_path, str(model))
    before, _ = _simulate_command(tmp_path / "cache", str(model), str(experiment))
    again, imported = _simulate_command(tmp_path / "cache", str(model), str(experiment))
    assert again == before and imported == []
    model.write_text(model.read_text().replace("M = { value = 95.1089,", "M = { value = 60.0,"))
    changed, _ = _simulate_command(tmp_path / "cache", str(model), str(experiment))
    fresh, _ = _simulate_command(tmp_path / "fresh", str(model), str(experiment))
    assert changed == fresh and changed != before


def test_calm_and_stiff_samples_follow_the_exact_path(tmp_path: Path) -> None:
    """The 2-link arm with Coulomb friction on both joints under PD (exact encoder): RK4 needs hundreds of
    sub-steps a sample for the smoothed sign's damper and one without it, so a calm sample — every velocity clear
    of zero over it — takes one (docs/simulation.md, "Calm samples"). Against the same run with four times the
    sub-steps everywhere, its positions are as close as those of the run with all the sub-steps in every sample
    (1e-9 rad more allowed), and so are its forces; against the exact stick/slip axis
    (tests/reference_integrator.py), the positions are within 1e-5 rad. With ε = 1e-5 the axis needs 801 RK4
    sub-steps, enough for a stiff sample to try linearly implicit ones first ("Stiff samples"): its distance to the
    exact motion is within 2e-6 rad and no more than 1.05 times that of RK4's 801 sub-steps in every sample."""
    from reference_integrator import axis_pd_run, reference_motion, write_arm_experiment, write_axis_experiment

    from symbolic.simulation.simulator import IMPLICIT_PER_CALM, IMPLICIT_WORTH

    experiment = write_arm_experiment(tmp_path / "arm", seconds=3.0, counts=0)
    arm = symbolic.derive(symbolic.loads(models.arm(), "<arm>"))
    calm = simulate(arm, experiment)
    assert calm.calm_substeps == 1 and calm.substeps >= 4 and calm.to_dict()["calm_substeps"] == 1
    every = simulate(arm, experiment, substeps=calm.substeps)
    finer = simulate(arm, experiment, substeps=4 * calm.substeps)
    assert every.calm_substeps == 0

    def apart(run, signal: str) -> float:
        return float(np.abs(np.asarray(getattr(run.simulated, signal)) - np.asarray(getattr(finer.simulated, signal))).max())

    assert apart(calm, "q") <= 1.5 * apart(every, "q") + 1e-9
    assert apart(calm, "tau") <= 1.5 * apart(every, "tau") + 1e-9
    path = write_axis_experiment(tmp_path / "axis", counts=0, seconds=4.0)
    axis = symbolic.derive(symbolic.loads(models.axis(), "<axis>"))
    t = np.arange(4000) / 1000.0
    true, _, _ = axis_pd_run(t, reference_motion(t), 0.05, 0.3, 0.4, 20.0, 1.0, 0.0)
    run = simulate(axis, path)
    assert run.calm_substeps == 1
    assert np.abs(np.asarray(run.simulated.q)[:, 0] - true).max() < 1e-5
    stiff = simulate(axis, path, friction_velocity=1e-5)
    rk4 = simulate(axis, path, friction_velocity=1e-5, substeps=stiff.substeps)
    assert stiff.calm_substeps == 1 and stiff.substeps >= IMPLICIT_WORTH * IMPLICIT_PER_CALM
    distance = {name: np.abs(np.asarray(r.simulated.q)[:, 0] - true).max() for name, r in (("stiff", stiff), ("rk4", rk4))}
    assert max(distance.values()) < 2e-6 and distance["stiff"] <= 1.05 * distance["rk4"]


def test_linearly_implicit_steps_are_second_order_and_stable_where_rk4_is_not() -> None:
    """ROS2 (Verwer et al. 1999, eq. 2.3) on the hub and spring without Coulomb friction, a linear system
    ẋ = Ax + b under a constant force: against the exact solution (the matrix exponential), its error over
    0.2 s falls 4-fold (3.6–4.4) when the sub-step halves (second order), and with the spring 10⁶ times stiffer
    (h·ρ ≈ 190, far outside RK4's region) and released unstretched, it follows the exact motion within 1e-3 where
    RK4 explodes."""
    from scipy.linalg import expm

    from symbolic.simulation.simulator import _linearly_implicit_sample, _rk4_sample

    model = symbolic.derive(symbolic.loads(models.hub_spring(), "<hub>"))
    plant = _plant(model)
    names = [str(s) for s in model.parameter_symbols]
    tau, x0 = np.array([0.05, 0.0]), np.array([0.1, -0.2, 0.5, 1.0])

    def run(values: dict, step, samples: int, period: float, x0: np.ndarray = x0) -> np.ndarray:
        p = np.array([values[name] for name in names])
        x = x0
        for k in range(samples):
            out = step(x, plant.rhs(x, tau, p, 1e-4, 0.0), tau, p, 1e-4, k * period)
            x = np.asarray(out[0] if isinstance(out, tuple) else out).ravel()
        return x

    def exact(values: dict, seconds: float, x0: np.ndarray = x0) -> np.ndarray:
        p = np.array([values[name] for name in names])
        A = np.asarray(plant.state_jacobian(x0, tau, p, 1e-4, 0.0))
        b = np.asarray(plant.rhs(np.zeros(4), tau, p, 1e-4, 0.0)).ravel()
        M = np.zeros((5, 5))
        M[:4, :4], M[:4, 4] = A, b
        return (expm(M * seconds) @ np.append(x0, 1.0))[:4]

    values = {"J_h": 0.02, "J_l": 0.004, "Ks": 1.2, "Ds": 0.002, "Fv1": 0.01, "Fc1": 0.0}
    errors = [np.abs(run(values, _linearly_implicit_sample(plant, 0.01, k), 20, 0.01) - exact(values, 0.2)).max()
              for k in (8, 16, 32)]
    assert all(3.6 < errors[i] / errors[i + 1] < 4.4 for i in range(2)), errors
    stiff, rigid = {**values, "Ks": 1.2e6}, np.array([0.1, 0.0, 0.5, 0.0])  # the spring unstretched and still
    implicit = run(stiff, _linearly_implicit_sample(plant, 0.01, 1), 50, 0.01, rigid)
    assert np.abs(implicit - exact(stiff, 0.5, rigid)).max() < 1e-3
    with np.errstate(all="ignore"):
        explicit = run(stiff, _rk4_sample(plant, 0.01, 1), 50, 0.01, rigid)
    assert not np.abs(explicit - exact(stiff, 0.5, rigid)).max() < 1.0
