"""The replay in windows (``[controller] kind = "torque"``, ``restart``): the logged force replayed on the model,
restarted from the measured state every ``restart`` seconds — the response of a machine whose own loop is not
declared (docs/simulation.md, "Replay in windows").

Truths from tests/reference_integrator.py (the two-link arm by DOP853 at rtol 1e-11, under its PD loop), never from
the product's simulator; the searching code sees the logs and the model file only."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import models
from reference_integrator import ARM, arm_forward, write_arm_experiment

import symbolic
from symbolic.data import DataError, Experiment, Measurements, load
from symbolic.data.controller import parse
from symbolic.identify.output_error import closed_loop
from symbolic.simulation import simulate
from symbolic.simulation.simulator import segments, velocity_at
from symbolic.workflow import diagnose

TRUE_ARM = "Fv1 = 0.8\nFv2 = 0.5\nFc1 = 0.0\nFc2 = 0.0\n"
"""The arm's model file at reference_integrator.ARM's values (viscous friction only)."""

REPLAY = '[controller]\nkind = "torque"\ncoordinates = ["q1", "q2"]\nrestart = {restart}\n'


@pytest.fixture(scope="module")
def arm_model():
    return symbolic.derive(symbolic.loads(models.arm(parameters=TRUE_ARM), "arm"))


def _replayed(experiment: Path, restart: float) -> Path:
    """The experiment with its PD ``[controller]`` replaced by the replay in windows (the loop not declared)."""
    text = experiment.read_text(encoding="utf-8")
    experiment.write_text(text[:text.index("[controller]")] + REPLAY.format(restart=restart), encoding="utf-8")
    return experiment


def test_restart_is_a_replays_key_checked_where_it_is_read() -> None:
    controller = parse({"kind": "torque", "coordinates": ["q"], "restart": 0.1}, ["q"], (), "x.toml")
    assert controller.restart == 0.1 and controller.restart_samples(1e-3) == 100
    assert "restarted from the measured state every 0.1 s" in controller.describe()
    assert parse({"kind": "torque", "coordinates": ["q"]}, ["q"], (), "x.toml").restart_samples(1e-3) is None
    with pytest.raises(DataError, match=r"x.toml: \[controller\] restart: .*not used by kind 'pd'"):
        parse({"kind": "pd", "coordinates": ["q"], "kp": [1.0], "kd": [0.1], "reference": "ref", "restart": 0.1},
              ["q"], (), "x.toml")
    for bad in (0, -0.1, True, "0.1", float("nan")):
        with pytest.raises(DataError, match=r"x.toml: \[controller\] restart: expected the seconds"):
            parse({"kind": "torque", "coordinates": ["q"], "restart": bad}, ["q"], (), "x.toml")
    short = parse({"kind": "torque", "coordinates": ["q"], "restart": 0.001}, ["q"], (), "x.toml")
    with pytest.raises(DataError, match=r"\[controller\] restart: 0.001 s is 1 sample.*at least 2 samples"):
        short.restart_samples(1e-3)


@given(samples=st.integers(1, 5000), chunk=st.integers(1, 1100), every=st.one_of(st.none(), st.integers(2, 700)))
def test_blocks_cover_the_log_and_never_cross_a_restart(samples: int, chunk: int, every: int | None) -> None:
    blocks = segments(samples, chunk, every)
    assert blocks[0][0] == 0 and sum(size for _, size, _ in blocks) == samples
    for (start, size, window), (following, _, _) in zip(blocks, blocks[1:] + [(samples, 0, None)]):
        assert start + size == following and 1 <= size <= chunk
        if every is not None:
            assert start // every == (start + size - 1) // every  # within one window
            assert window == (start // every if start % every == 0 and start else None)
        else:
            assert window is None


def _exact_arm_log(seconds: float = 2.0, rate: float = 500.0) -> Measurements:
    """The arm under a PD loop about a moving reference, integrated by DOP853 (rtol 1e-12) with the force held
    over each sample, its exact positions *and velocities* logged with the force applied."""
    from scipy.integrate import solve_ivp

    t = np.arange(int(seconds * rate)) / rate
    reference = np.column_stack([-0.6 + 0.5 * np.sin(2.1 * t), 0.8 + 0.4 * np.sin(3.3 * t + 0.4)])
    state = np.array([-0.6, 0.8, 0.0, 0.0])
    q, qd, tau = (np.empty((len(t), 2)) for _ in range(3))
    for k in range(len(t)):
        q[k], qd[k] = state[:2], state[2:]
        tau[k] = np.array([120.0, 60.0]) * (reference[k] - state[:2]) - np.array([8.0, 4.0]) * state[2:]
        state = solve_ivp(lambda _, x: np.concatenate([x[2:], arm_forward(x[:2], x[2:], tau[k], ARM)]),
                          (0.0, 1.0 / rate), state, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    return Measurements.from_arrays(t, ("q1", "q2"), q, tau, qd=qd)


def test_each_window_starts_at_the_measured_state_and_follows_the_truth(arm_model) -> None:
    """With the logged velocities exact, every window restarts exactly on the truth (bit for bit), and the replay
    follows it to RK4's error (4 sub-steps of 0.5 ms: measured 6e-12 rad at 0.2 s windows, 2e-11 in one run)."""
    log = _exact_arm_log()
    windowed = simulate(arm_model, Experiment.of(log, controller={"kind": "torque", "coordinates": ["q1", "q2"],
                                                                  "restart": 0.2}), substeps=4)
    starts = np.arange(0, log.samples, 100)
    assert np.array_equal(windowed.simulated.q[starts], log.q[starts])
    assert np.array_equal(windowed.simulated.qd[starts], log.qd[starts])
    assert np.abs(windowed.simulated.q - log.q).max() < 1e-10


def test_without_logged_velocities_a_window_starts_at_the_centred_slope(arm_model, tmp_path: Path) -> None:
    experiment = _replayed(write_arm_experiment(tmp_path, seconds=1.0, counts=0), 0.1)
    data = load(experiment, model=arm_model.robot)
    run = simulate(arm_model, data)
    for k in (50, 100, 450):
        slope = velocity_at(data, k)
        assert np.allclose(slope, (data.q[k + 1] - data.q[k - 1]) / (2 / 500), rtol=0.02)
        assert np.array_equal(run.simulated.qd[k], slope)  # each a window's first sample (every 50)
    with pytest.raises(DataError, match=r"restart.*'rk4' only"):
        simulate(arm_model, data, method="Radau")


def test_sensitivities_through_the_restarts_are_the_derivative_of_the_simulation(arm_model, tmp_path: Path) -> None:
    """∂q/∂θ through the windows — the model's parameters, a drive gain on the replayed force and a position
    sensor's bias (which moves every window's start) — against central differences of the same simulation."""
    layer = ("[drive]\ntau_q2 = { gain = { value = 1.1, free = true } }\n"
             "[sensors]\nq_q1 = { bias = { value = 0.01, free = true } }\n")
    experiment = write_arm_experiment(tmp_path, seconds=1.0, counts=0)
    experiment = _replayed(experiment, 0.1)
    experiment.write_text(experiment.read_text(encoding="utf-8") + layer, encoding="utf-8")
    data = load(experiment, model=arm_model.robot)
    names = ["I2", "Fv2", "m2"]
    loop = closed_loop(arm_model, data, names, signal_values=data.signal_layer.free)
    assert loop.windows is not None and loop.windows.every == 50
    theta = np.array([ARM["I2"], ARM["Fv2"], ARM["m2"], 1.1, 0.01])
    y, dy = loop.run(theta)
    for j in range(len(theta)):
        h = 1e-6 * max(abs(theta[j]), 1.0)
        up, down = theta.copy(), theta.copy()
        up[j] += h
        down[j] -= h
        difference = (loop.run(up, sensitivities=False)[0] - loop.run(down, sensitivities=False)[0]) / (2 * h)
        exact = dy[:, :2, j]
        assert np.linalg.norm(difference[:, :2] - exact) <= 1e-6 * np.linalg.norm(exact), j


@pytest.mark.slow
@pytest.mark.parametrize(("gain", "seed", "counts"), [(1.3, 1, 2**16), (0.8, 2, 2**18)])
def test_a_joints_drive_gain_is_named_in_the_replay(tmp_path: Path, gain: float, seed: int, counts: int) -> None:
    """The arm under its PD loop, joint 2's drive applying gain × its command; the experiment declares no loop,
    only the replay in windows of 0.2 s: ``drive_gain(q2)`` is named within 2 %, and nothing else."""
    experiment = write_arm_experiment(tmp_path, seconds=6.0, force_noise=0.05, seed=seed, counts=counts,
                                      drive=((1.0, 0.0), (gain, 0.0)))
    result = _diagnose(tmp_path, _replayed(experiment, 0.2))
    named = {j.candidate.label(): j.roles for j in result.response.named}
    assert list(named) == ["drive_gain(q2)"]
    assert named["drive_gain(q2)"]["gain"] == pytest.approx(gain, rel=0.02)


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "counts", "restart"), [(3, 2**16, 0.2), (4, 2**20, 0.1), (5, 2**17, 0.5)])
def test_nothing_missing_names_nothing_in_the_replay(tmp_path: Path, seed: int, counts: int, restart: float) -> None:
    experiment = write_arm_experiment(tmp_path, seconds=6.0, force_noise=0.05, seed=seed, counts=counts)
    result = _diagnose(tmp_path, _replayed(experiment, restart))
    assert result.response is not None and result.response.named == ()
    tried = {j.candidate.effect.identifier for r in result.response.rounds for j in r}
    assert {"drive_gain", "sensor_bias"} <= tried


def _diagnose(tmp_path: Path, experiment: Path):
    model = tmp_path / "arm.toml"
    model.write_text(models.arm(), encoding="utf-8")  # Coulomb friction the truth lacks: the equation error's to mend
    return diagnose(str(model), str(experiment), simulate=True, out=tmp_path / "out", figures=False, response=True)


def test_the_replays_gaps_are_the_inverse_models(tmp_path: Path) -> None:
    """A replay's simulated force is the logged one (its gap 0 whatever the model), so ``--simulate`` on a replay
    keeps the inverse model's gaps, says so, and judges only the response on the simulated positions."""
    experiment = _replayed(write_arm_experiment(tmp_path, seconds=3.0, force_noise=0.05, seed=1), 0.2)
    model = tmp_path / "arm.toml"
    model.write_text(models.arm(), encoding="utf-8")
    plain = diagnose(str(model), str(experiment), figures=False)
    replayed = diagnose(str(model), str(experiment), simulate=True, figures=False, response=False)
    assert replayed.before.detail == plain.before.detail and replayed.after.detail == plain.after.detail
    assert min(plain.before.detail["validation"].values()) > 0.1  # % : a gap to see, not the replay's 0
    assert any("replays the logged force" in n for n in replayed.notes)


def test_held_out_data_without_a_controller_are_driven_as_the_estimation_experiment(tmp_path: Path) -> None:
    """A ``--validate`` log that declares no ``[controller]`` is judged on its response under the estimation
    experiment's (here the replay in windows: before, it was replayed in one run), with a note; a held-out log with
    its own controller, or an estimation without one, is left as it is."""
    from symbolic.workflow.diagnosis import carried_controller

    estimation = load(_replayed(write_arm_experiment(tmp_path / "e", seconds=0.4, counts=0), 0.1))
    plain = Measurements(t=estimation.t, q=estimation.q, qd=None, qdd=None, tau=estimation.tau,
                         coordinates=estimation.coordinates, source="held.csv")
    notes: list[str] = []
    held = carried_controller(plain, estimation, notes)
    assert held.controller is estimation.controller and held.controller.restart == 0.1
    assert notes == ['the held-out data (held.csv) declare no [controller]: the search judged on the response drives '
                     'them with the estimation experiment\'s (kind "torque")']
    assert carried_controller(estimation, estimation, notes) is estimation
    assert carried_controller(plain, plain, notes) is plain and len(notes) == 1
