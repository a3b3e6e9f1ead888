"""The signal layer of experiment files ([sensors], [drive]; docs/data.md, "The signal layer").

* each refusal is one precise line (file, table, signal, value, what is allowed);
* a log made here from a clean analytic signal with a known delay, gain and bias is corrected back to the
  clean signal within the interpolator's stated bound (exactly for a whole-sample delay);
* identification on a synthetic EMPS log whose force sensor has gain 1.1 and bias 0.2 declared gives the
  true parameters (and, undeclared, it does not);
* the simulation applies the drive's gain, bias and delay: a replayed command against the same log with
  the applied force written out here, a PD loop against the same loop with its gain multiplied by hand.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import symbolic
from symbolic import robots
from symbolic.data import DataError, load
from symbolic.data.signal_layer import ERROR_CONSTANT, MAX_DELAY, FreeValue, reapply, shift
from symbolic.identify.model import identify_model
from symbolic.simulation import simulate

RATE = 1000.0
TRUTH = {"M_carriage": 95.0, "Fv": 200.0, "Fc": 20.0, "offset": -3.0}


def motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ of two sinusoids (1.1 and 2.3 Hz)."""
    w1, w2 = 2 * np.pi * 1.1, 2 * np.pi * 2.3
    q = 0.05 * np.sin(w1 * t) + 0.02 * np.sin(w2 * t + 0.4)
    qd = 0.05 * w1 * np.cos(w1 * t) + 0.02 * w2 * np.cos(w2 * t + 0.4)
    qdd = -0.05 * w1**2 * np.sin(w1 * t) - 0.02 * w2**2 * np.sin(w2 * t + 0.4)
    return q, qd, qdd


def experiment(folder: Path, columns: dict[str, np.ndarray], text: str = "", name: str = "run.toml") -> Path:
    """A CSV log of ``columns`` and an experiment file reading it, with ``text`` appended."""
    names = list(columns)
    rows = np.column_stack([columns[n] for n in names])
    np.savetxt(folder / "log.csv", rows, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    path = folder / name
    path.write_text(f'data = "log.csv"\n{text}', encoding="utf-8")
    return path


def plain(folder: Path, text: str, samples: int = 200) -> Path:
    t = np.arange(samples) / RATE
    q, qd, _ = motion(t)
    return experiment(folder, {"t": t, "q_q": q, "qd_q": qd, "tau_q": np.cos(t)}, text)


# -- refusals -------------------------------------------------------------------------------------------------

REFUSED = [
    ("[sensors]\nq_q = { dealy = 0.5 }\n",
     "[sensors] q_q dealy: unknown key (allowed: delay, gain, bias); did you mean 'delay'?"),
    ("[sensors]\ntau_q = { gain = 0.0 }\n",
     "[sensors] tau_q gain: 0 (allowed: a finite non-zero number; a negative gain is a reversed sign)"),
    ("[sensors]\nq_q = { delay = -1 }\n", "[sensors] q_q delay: -1 samples (allowed: 0 to 1000 samples"),
    ("[sensors]\nq_q = { delay = 1001.5 }\n", "[sensors] q_q delay: 1001.5 samples (allowed: 0 to 1000"),
    ("[sensors]\nq_q = { bias = nan }\n", "[sensors] q_q bias: expected a finite number, got nan"),
    ("[sensors]\nq_q = { gain = true }\n", "[sensors] q_q gain: expected a finite number, got True"),
    ("[sensors]\nq_q = { gain = \"2\" }\n", "[sensors] q_q gain: expected a finite number, got '2'"),
    ("[sensors]\nq_q = 0.5\n", "[sensors] q_q: expected a table such as { delay = 0.5, gain = 1.0, bias = 0.0 }, got 0.5"),
    ("[sensors]\nref_q = { delay = 1 }\n", "[sensors] ref_q: not a signal of [sensors] (allowed: q_<c>, qd_<c>, tau_<c>"),
    ("[sensors]\nq_x = { delay = 1 }\n",
     "[sensors] q_x: no such signal in the data (allowed: q_q, qd_q, tau_q); did you mean 'q_q'?"),
    ("[drive]\nq_q = { gain = 2 }\n", "[drive] q_q: not a signal of [drive] (allowed: tau_<c>"),
    ("[drive]\ntau_p = { gain = 2 }\n", "[drive] tau_p: no such signal in the data (allowed: tau_q)"),
    ("[sensors]\ntau_q = { gain = 2 }\n[drive]\ntau_q = { gain = 2 }\n",
     "[drive] tau_q: tau_q is also in [sensors]: the logged force is either"),
    ("[sensors]\nq_q = { delay = 0.5, free = true }\n",
     "[sensors] q_q free: say which value is free: e.g. delay = { value = 0.5, free = true }"),
    ("[sensors]\nq_q = { delay = { value = 0.5, fre = true } }\n",
     "[sensors] q_q delay fre: unknown key (allowed: value, free); did you mean 'free'?"),
    ("[sensors]\nq_q = { delay = { value = 0.5, free = 1 } }\n",
     "[sensors] q_q delay free: expected true or false, got 1"),
    ("[sensors]\nq_q = { gain = { free = false } }\n",
     "[sensors] q_q gain: a table needs value = <number> unless free = true"),
    ("[sensors]\nq_q = { delay = 20.5 }\n",
     "[sensors] q_q delay: 20.5 samples (allowed: 0 to 20, at most 1000 and a tenth of the log's 200 samples)"),
    ("sensors = 3\n", "[sensors]: expected a table of signals, got int"),
    ("[sensors]\nq_q = { gain = 1e-33 }\n", "[sensors] q_q: gain 1e-33 and bias 0 make the model's signal 7.78837e+30 "
     "at sample 0 (t = 0 s) (allowed: finite numbers of magnitude at most 1e+30)"),
    ("[sensor]\nq_q = { delay = 1 }\n", "sensor: unknown key (allowed: data, model, description, rate, resample, "
     "columns, signals, constants, window, controller, identification, sensors, drive, excitation, alignment); "
     "did you mean 'sensors'?"),
]


@pytest.mark.parametrize("text, message", REFUSED)
def test_each_refusal_is_one_precise_line(tmp_path: Path, text: str, message: str) -> None:
    path = plain(tmp_path, text)
    with pytest.raises(DataError) as error:
        load(path)
    assert str(error.value).startswith(f"{path}: "), str(error.value)
    assert message in str(error.value), str(error.value)
    assert "\n" not in str(error.value)


def test_free_values_are_recorded_and_applied_at_their_start(tmp_path: Path) -> None:
    path = plain(tmp_path, "[sensors]\nq_q = { delay = { value = 2, free = true }, gain = 1.5 }\n"
                           "tau_q = { bias = { free = true } }\n")
    loaded = load(path)
    layer = loaded.signal_layer
    assert layer.free == (FreeValue("sensors", "q_q", "delay", 2.0), FreeValue("sensors", "tau_q", "bias", 0.0))
    raw = layer.logged["q_q"]
    np.testing.assert_array_equal(loaded.q[:-2, 0], raw[2:] / 1.5)  # a whole-sample delay: an exact shift
    assert layer.sensors["q_q"].gain == 1.5 and MAX_DELAY == 1000.0


# -- the round trip ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("delay", [0.0, 3.0, 0.5, 2.37])
def test_a_sensor_log_is_corrected_back_to_the_clean_signal(tmp_path: Path, delay: float) -> None:
    """measured = gain·true(t − delay) + bias, written from the analytic signal; the loaded q equals the
    clean q within 3/128·h⁴·max|q⁗| (exactly, to rounding, for a whole-sample delay), but for the first
    sample and the last ⌈delay⌉ + 2, whose stencils reach past the ends."""
    samples, gain, bias = 2000, 0.8, 0.3
    t = np.arange(samples) / RATE
    q, qd, _ = motion(t)
    late = motion(t - delay / RATE)
    path = experiment(tmp_path, {"t": t, "q_q": gain * late[0] + bias, "qd_q": -2.0 * late[1] + 1.0,
                                 "tau_q": np.cos(t)},
                      f"[sensors]\nq_q = {{ delay = {delay}, gain = {gain}, bias = {bias} }}\n"
                      f"qd_q = {{ delay = {delay}, gain = -2.0, bias = 1.0 }}\n")
    loaded = load(path)
    kept = slice(1, samples - int(np.ceil(delay)) - 2)
    w1, w2 = 2 * np.pi * 1.1, 2 * np.pi * 2.3
    h = 1 / RATE
    fourth = 0.05 * w1**4 + 0.02 * w2**4  # max |q⁗|, and |q̇⁗| ≤ this times w2
    whole = delay == int(delay)
    bound_q = 1e-15 * 4 if whole else ERROR_CONSTANT * h**4 * fourth * (1 + 1e-6) + 4e-16
    bound_qd = 1e-14 if whole else ERROR_CONSTANT * h**4 * fourth * w2 + 1e-14
    assert np.max(np.abs(loaded.q[kept, 0] - q[kept])) <= bound_q
    assert np.max(np.abs(loaded.qd[kept, 0] - qd[kept])) <= bound_qd
    if not whole:  # the bound is tight enough to mean something: linear interpolation would miss it
        linear = (1 - delay % 1) * np.roll(q, -1) + (delay % 1) * q
        assert np.max(np.abs(linear[kept] - q[kept])) > 100 * bound_q


def test_the_drive_applies_gain_bias_and_a_fractional_delay_to_the_logged_command(tmp_path: Path) -> None:
    samples, gain, bias, delay = 1000, 1.7, -0.25, 1.5
    t = np.arange(samples) / RATE
    command = np.sin(2 * np.pi * 3 * t)
    path = experiment(tmp_path, {"t": t, "q_q": motion(t)[0], "tau_q": command},
                      f"[drive]\ntau_q = {{ delay = {delay}, gain = {gain}, bias = {bias} }}\n")
    loaded = load(path)
    applied = gain * (np.sin(2 * np.pi * 3 * (t - delay / RATE)) + bias)  # written out from the definition
    kept = slice(4, samples)
    bound = gain * ERROR_CONSTANT * (2 * np.pi * 3 / RATE) ** 4 + 1e-15
    assert np.max(np.abs(loaded.tau[kept, 0] - applied[kept])) <= bound
    np.testing.assert_array_equal(loaded.signal_layer.logged["tau_q"], command)


def test_shift_is_exact_for_cubics() -> None:
    k = np.arange(50.0)
    x = 0.3 * k**3 - k**2 + 2.0
    y = shift(x, -0.3)  # x at k − 0.3
    exact = 0.3 * (k - 0.3) ** 3 - (k - 0.3) ** 2 + 2.0
    np.testing.assert_allclose(y[2:-2], exact[2:-2], rtol=0, atol=1e-9)


# -- identification -----------------------------------------------------------------------------------------


def emps_log(folder: Path, text: str, sensor: tuple[float, float] = (1.0, 0.0)) -> Path:
    t = np.arange(0.0, 8.0, 1 / RATE)
    q, qd, qdd = motion(t)
    tau = TRUTH["M_carriage"] * qdd + TRUTH["Fv"] * qd + TRUTH["Fc"] * np.sign(qd) + TRUTH["offset"]
    gain, bias = sensor
    return experiment(folder, {"t": t, "q_q": q, "qd_q": qd, "qdd_q": qdd, "tau_q": gain * tau + bias},
                      'model = "emps"\n' + text)


def test_identification_reads_the_force_through_the_declared_sensor(tmp_path: Path) -> None:
    model = symbolic.derive(robots.load("emps"))
    path = emps_log(tmp_path, "[sensors]\ntau_q = { gain = 1.1, bias = 0.2 }\n", sensor=(1.1, 0.2))
    result = identify_model(model, path)
    values = dict(zip(result.identification.names, result.identification.values))
    for name, truth in TRUTH.items():
        assert values[name] == pytest.approx(truth, rel=2e-3), (name, values)
    undeclared = identify_model(model, emps_log(tmp_path, "", sensor=(1.1, 0.2)))
    wrong = dict(zip(undeclared.identification.names, undeclared.identification.values))
    assert wrong["M_carriage"] == pytest.approx(1.1 * TRUTH["M_carriage"], rel=2e-3)  # what the layer removes


# -- simulation -----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def emps() -> symbolic.DynamicModel:
    return symbolic.derive(robots.load("emps"))


def test_simulate_replays_the_command_through_the_drive(tmp_path: Path, emps: symbolic.DynamicModel) -> None:
    t = np.arange(0.0, 1.0, 1 / RATE)
    q, qd, qdd = motion(t)
    command = 40.0 * np.sin(2 * np.pi * 2 * t)
    declared = experiment(tmp_path, {"t": t, "q_q": q, "tau_q": command},
                          "[drive]\ntau_q = { gain = 2.0, bias = 0.5, delay = 3 }\n")
    delayed = np.concatenate([np.full(3, command[0]), command[:-3]])
    (tmp_path / "by_hand").mkdir()
    written = experiment(tmp_path / "by_hand", {"t": t, "q_q": q, "tau_q": 2.0 * (delayed + 0.5)})
    a, b = simulate(emps, load(declared, model=emps.robot)), simulate(emps, load(written, model=emps.robot))
    np.testing.assert_allclose(a.simulated.q, b.simulated.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.simulated.tau, b.simulated.tau, rtol=0, atol=1e-12)
    assert np.max(np.abs(b.simulated.q - simulate(emps, load(experiment(tmp_path / "by_hand", {
        "t": t, "q_q": q, "tau_q": command}), model=emps.robot)).simulated.q)) > 1e-4  # the drive matters


def test_a_feedback_loop_drives_the_model_through_the_drive(tmp_path: Path, emps: symbolic.DynamicModel) -> None:
    """PD with the drive's gain 1.5, bias 2 N and one sample of delay, applied 1.5·(u(t − h) + 2), against the
    same law written in the [controller] by hand: gain 1.5, delay 1, a disturbance of 2."""
    t = np.arange(0.0, 1.0, 1 / RATE)
    q, _, _ = motion(t)
    columns = {"t": t, "q_q": q, "tau_q": np.zeros_like(t), "ref_q": q, "two": np.full_like(t, 2.0)}
    loop = '[controller]\nkind = "pd"\nkp = [20000.0]\nkd = [800.0]\nreference = "ref"\n'
    declared = experiment(tmp_path, columns, loop + "[drive]\ntau_q = { gain = 1.5, bias = 2.0, delay = 1 }\n")
    by_hand = experiment(tmp_path, columns, loop + 'gain = [1.5]\ndelay = 1\ndisturbance = ["two"]\n', "hand.toml")
    a, b = (simulate(emps, load(p, model=emps.robot)) for p in (declared, by_hand))
    np.testing.assert_allclose(a.simulated.q, b.simulated.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.simulated.tau, b.simulated.tau, rtol=0, atol=1e-9)
    plain_loop = simulate(emps, load(experiment(tmp_path, columns, loop, "plain.toml"), model=emps.robot))
    assert np.max(np.abs(plain_loop.simulated.tau - a.simulated.tau)) > 1.0


def test_a_fractional_drive_delay_in_a_feedback_loop_is_refused(tmp_path: Path, emps: symbolic.DynamicModel) -> None:
    t = np.arange(0.0, 0.2, 1 / RATE)
    q = motion(t)[0]
    path = experiment(tmp_path, {"t": t, "q_q": q, "tau_q": np.zeros_like(t), "ref_q": q},
                      '[controller]\nkind = "pd"\nkp = [1.0]\nkd = [0.0]\nreference = "ref"\n'
                      "[drive]\ntau_q = { delay = 0.5 }\n")
    with pytest.raises(DataError, match=r"\[drive\] delay: delays of 0.5 samples on the coordinates of a feedback"):
        simulate(emps, load(path, model=emps.robot))


def test_new_values_are_applied_again_from_the_logs(tmp_path: Path) -> None:
    """What a fit of a free value evaluates: the layer with another value, applied to the kept logs, equals
    the experiment loaded with that value written in the file; a slice keeps the logs aligned."""
    path = plain(tmp_path, "[sensors]\ntau_q = { gain = { value = 1.0, free = true }, bias = 0.1 }\n")
    loaded = load(path)
    moved = reapply(loaded, loaded.signal_layer.with_values({("sensors", "tau_q", "gain"): 1.25}), str(path))
    (tmp_path / "b").mkdir()
    written = load(plain(tmp_path / "b", "[sensors]\ntau_q = { gain = 1.25, bias = 0.1 }\n"))
    np.testing.assert_array_equal(moved.tau, written.tau)
    assert moved.signal_layer.sensors["tau_q"].gain == 1.25 and loaded.signal_layer.sensors["tau_q"].gain == 1.0
    with pytest.raises(DataError, match=r"\[sensors\] tau_q gain: 0 \(allowed: a finite non-zero number"):
        loaded.signal_layer.with_values({("sensors", "tau_q", "gain"): 0.0})
    with pytest.raises(DataError, match=r"\[drive\] tau_q gain: not a value of the layer \(declared: \(sensors, tau_q"):
        loaded.signal_layer.with_values({("drive", "tau_q", "gain"): 2.0})
    part = loaded.slice(10, 50)
    assert part.signal_layer.logged["tau_q"].shape == (40,)
    np.testing.assert_array_equal(reapply(part, part.signal_layer, str(path)).tau, part.tau)


def test_a_feedback_loop_reads_the_position_through_the_declared_sensor(tmp_path: Path,
                                                                           emps: symbolic.DynamicModel) -> None:
    """PD reading q_m = 1.25·q + 0.01 (declared) against the law written out for the true q by hand:
    kp·(r − q_m) − kd·q̇_m = 1.25·kp·((r − 0.01)/1.25 − q) − 1.25·kd·q̇, the log's positions the true ones."""
    t = np.arange(0.0, 0.4, 1 / RATE)
    q, _, _ = motion(t)
    ref = q + 0.002
    loop = '[controller]\nkind = "pd"\nreference = "ref"\n'
    declared = experiment(tmp_path, {"t": t, "q_q": 1.25 * q + 0.01, "tau_q": np.zeros_like(t), "ref_q": ref},
                          loop + "kp = [20000.0]\nkd = [800.0]\n[sensors]\nq_q = { gain = 1.25, bias = 0.01 }\n")
    (tmp_path / "by_hand").mkdir()
    by_hand = experiment(tmp_path / "by_hand", {"t": t, "q_q": q, "tau_q": np.zeros_like(t), "ref_q": ref,
                                                "shifted": (ref - 0.01) / 1.25},
                         '[controller]\nkind = "pd"\nreference = ["shifted"]\nkp = [25000.0]\nkd = [1000.0]\n')
    for method in ("rk4", "Radau"):
        a, b = (simulate(emps, load(p, model=emps.robot), method=method) for p in (declared, by_hand))
        np.testing.assert_allclose(a.simulated.q, b.simulated.q, rtol=0, atol=1e-10)
        np.testing.assert_allclose(a.simulated.tau, b.simulated.tau, rtol=0, atol=1e-6)
    unread = simulate(emps, load(experiment(tmp_path, {"t": t, "q_q": q, "tau_q": np.zeros_like(t), "ref_q": ref},
                                            loop + "kp = [20000.0]\nkd = [800.0]\n", "plain.toml"), model=emps.robot))
    assert np.max(np.abs(unread.simulated.q - a.simulated.q)) > 1e-3  # the sensor matters


@pytest.mark.slow
def test_diagnose_simulate_sees_the_machine_through_its_drive(tmp_path: Path, emps: symbolic.DynamicModel,
                                                              capsys: pytest.CaptureFixture) -> None:
    """A PD-controlled EMPS whose drive applies 1.3·(command + 1 N) one sample late, simulated here, its
    command logged: declared, diagnose --simulate names nothing and keeps the mass; undeclared, the mass
    comes out 1.3 times too low (what the drive's gain does to an inverse dynamics read at the command)."""
    import json

    from symbolic.cli import main

    t = np.arange(0.0, 12.0, 1 / RATE)
    ref = 0.05 * np.sign(np.sin(2 * np.pi * 0.4 * t)) + 0.05 * np.sin(2 * np.pi * 1.3 * t)
    loop = '[controller]\nkind = "pd"\nkp = [20000.0]\nkd = [800.0]\nreference = "ref"\n'
    layer = "[drive]\ntau_q = { gain = 1.3, bias = 1.0, delay = 1 }\n"
    (tmp_path / "truth").mkdir()
    truth = experiment(tmp_path / "truth", {"t": t, "q_q": ref, "tau_q": np.zeros_like(t), "ref_q": ref}, loop + layer)
    applied = simulate(emps, load(truth, model=emps.robot)).simulated
    command = np.append(applied.tau[1:, 0], applied.tau[-1, 0]) / 1.3 - 1.0  # applied one sample after
    rng = np.random.default_rng(1)
    columns = {"t": t, "q_q": applied.q[:, 0] + rng.normal(0, 1e-6, len(t)),
               "tau_q": command + rng.normal(0, 0.05, len(t)), "ref_q": ref}
    masses = {}
    for name, text in (("declared", loop + layer), ("undeclared", loop)):
        path = experiment(tmp_path, columns, text, f"{name}.toml")
        capsys.readouterr()
        assert main(["diagnose", "emps", str(path), "--simulate", "--effects", "inertia", "--json",
                     "--out", str(tmp_path / name)]) == 0
        result = json.loads(capsys.readouterr().out)
        masses[name] = {c["parameter"]: c["value"] for c in result["parameter_changes"]}["M"]
        if name == "declared":
            assert result["found"] == [] and result["corrections"] == []
    nominal = robots.load("emps").parameter_values
    mass = next(v for s, v in nominal.items() if s.name == "M")
    assert masses["declared"] == pytest.approx(float(mass), rel=1e-3)
    assert masses["undeclared"] == pytest.approx(float(mass) / 1.3, rel=0.03)


def test_measurements_built_in_python_take_the_layer_as_a_table() -> None:
    t = np.arange(300) / RATE
    q, qd, _ = motion(t)
    measurements = symbolic.data.Measurements.from_arrays(t, ["q"], q[:, None], 2.0 * np.cos(t)[:, None] + 0.5)
    experiment_ = symbolic.data.Experiment.of(measurements, signal_layer={"sensors": {"tau_q": {"gain": 2.0,
                                                                                                "bias": 0.5}}})
    np.testing.assert_allclose(experiment_.tau[:, 0], np.cos(t), rtol=0, atol=1e-15)
    with pytest.raises(DataError, match=r"<arrays>: \[drive\] u_q: not a signal of \[drive\] .*name tau_q"):
        symbolic.data.Experiment.of(measurements, signal_layer={"drive": {"u_q": {"gain": 2.0}}})
    with pytest.raises(DataError, match=r"<arrays>: signal_layer: these data already have a signal layer applied"):
        symbolic.data.Experiment.of(experiment_, signal_layer={"sensors": {"tau_q": {"gain": 2.0}}})


@pytest.mark.parametrize("method", ["rk4", "Radau"])
def test_a_feedback_loop_reads_the_position_late_by_the_sensors_delay(tmp_path: Path, emps: symbolic.DynamicModel,
                                                                      method: str) -> None:
    """A PD reading the position 2 samples late, u_k = kp·(r_k − q_k−2) − kd·q̇_m,k−2, is the PD with an output
    delay of 2 samples and the reference 2 samples ahead, u_k−2 = kp·(r'_k−2 − q_k−2) − ..., r'_j = r_j+2
    (both apply 0 for the first two samples: the reference starts at rest at the initial position 0). A
    fractional delay lies between the two whole ones it interpolates (it reads a mix of their positions)."""
    t = np.arange(0.0, 0.4, 1 / RATE)
    ramp = np.clip(t - 0.05, 0.0, None)
    ref = 0.02 * (1 - np.cos(2 * np.pi * 3 * ramp)) * (ramp > 0)
    q = np.zeros_like(t)
    loop = '[controller]\nkind = "pd"\nkp = [20000.0]\nkd = [800.0]\n'
    columns = {"t": t, "q_q": q, "tau_q": np.zeros_like(t), "ref_q": ref, "ahead": np.append(ref[2:], [ref[-1]] * 2)}
    runs = {}
    for name, text in (("sensor", 'reference = "ref"\n[sensors]\nq_q = { delay = 2 }\n'),
                       ("by_hand", 'reference = ["ahead"]\ndelay = 2\n'),
                       ("fractional", 'reference = "ref"\n[sensors]\nq_q = { delay = 1.5 }\n'),
                       ("one", 'reference = "ref"\n[sensors]\nq_q = { delay = 1 }\n')):
        path = experiment(tmp_path, columns, loop + text, f"{name}.toml")
        runs[name] = simulate(emps, load(path, model=emps.robot), method=method).simulated
    np.testing.assert_allclose(runs["sensor"].q, runs["by_hand"].q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(runs["sensor"].tau, runs["by_hand"].tau, rtol=0, atol=1e-7)
    assert np.max(np.abs(runs["one"].q - runs["sensor"].q)) > 1e-5  # the delay matters
    low = np.minimum(runs["one"].q, runs["sensor"].q) - 1e-6
    high = np.maximum(runs["one"].q, runs["sensor"].q) + 1e-6
    assert np.all((low <= runs["fractional"].q) & (runs["fractional"].q <= high))


def test_the_sensor_model_of_a_simulation_and_the_delays_derivative() -> None:
    """SignalLayer.sensed is the forward sensor model (it reproduces the log from the clean signal, the
    inverse of the correction), and shift_derivative is the derivative of shift in the offset (the taps'
    derivatives, against a central difference of shift itself)."""
    t = np.arange(400) / RATE
    q, qd, _ = motion(t)
    clean = symbolic.data.Measurements.from_arrays(t, ["q"], q[:, None], np.cos(t)[:, None], qd=qd[:, None])
    layer = symbolic.data.Experiment.of(clean, signal_layer={"sensors": {"q_q": {"delay": 1.3, "gain": 0.9,
                                                                                 "bias": 0.02}}}).signal_layer
    late = motion(t - 1.3 / RATE)[0]
    sensed = layer.sensed(clean)["q_q"]
    assert np.max(np.abs(sensed[4:] - (0.9 * late[4:] + 0.02))) <= 0.9 * ERROR_CONSTANT * (
        0.05 * (2 * np.pi * 1.1) ** 4 + 0.02 * (2 * np.pi * 2.3) ** 4) / RATE**4 + 1e-15
    from symbolic.data.signal_layer import shift_derivative

    x = np.sin(np.arange(60) * 0.3)
    for offset in (-2.7, -0.4, 0.25, 1.6):
        step = 1e-6
        central = (shift(x, offset + step) - shift(x, offset - step)) / (2 * step)
        np.testing.assert_allclose(shift_derivative(x, offset)[3:-4], central[3:-4], rtol=0, atol=1e-8)


@pytest.mark.parametrize("method", ["rk4", "Radau"])
def test_each_drive_of_a_feedback_loop_applies_its_command_its_own_samples_late(tmp_path: Path, method: str) -> None:
    """Each coordinate's drive its own whole delay inside a PD loop (docs/data.md): the force applied to q1 at
    sample k is the PD law at sample k − d1, and to q2 at k − d2, from the simulated positions (no quantisation:
    kp·(r − q) − kd·(q_j − q_j−1)/T, 0 before the first command arrives). Delays alike are the loop's own
    ``[controller] delay``: the same run to the last bit."""
    import models

    model_path = tmp_path / "arm.toml"
    model_path.write_text(models.arm(), encoding="utf-8")
    arm = symbolic.derive(symbolic.load(str(model_path)))
    t = np.arange(0.0, 0.3, 1 / RATE)
    ref = np.column_stack([0.3 * np.sin(2 * np.pi * 2 * t), -0.2 * np.sin(2 * np.pi * 3 * t)])
    kp, kd = np.array([120.0, 60.0]), np.array([8.0, 4.0])
    columns = {"t": t, "q_q1": np.zeros_like(t), "q_q2": np.zeros_like(t), "tau_q1": np.zeros_like(t),
               "tau_q2": np.zeros_like(t), "ref_q1": ref[:, 0], "ref_q2": ref[:, 1]}
    loop = ('[controller]\nkind = "pd"\ncoordinates = ["q1", "q2"]\nkp = [120.0, 60.0]\nkd = [8.0, 4.0]\n'
            'reference = "ref"\n')
    runs = {}
    for name, text in (("own", "[drive]\ntau_q1 = { delay = 1 }\ntau_q2 = { delay = 3 }\n"),
                       ("alike", "[drive]\ntau_q1 = { delay = 2 }\ntau_q2 = { delay = 2 }\n"),
                       ("loop", "delay = 2\n")):
        path = experiment(tmp_path, columns, loop + text, f"{name}.toml")
        runs[name] = simulate(arm, load(path, model=arm.robot), method=method).simulated
    np.testing.assert_array_equal(runs["alike"].q, runs["loop"].q)
    q, tau = runs["own"].q, runs["own"].tau
    velocity = np.vstack([np.zeros((1, 2)), np.diff(q, axis=0) * RATE])
    law = kp * (ref - q) - kd * velocity
    for j, d in enumerate((1, 3)):
        np.testing.assert_array_equal(tau[:d, j], 0.0)
        np.testing.assert_allclose(tau[d:, j], law[:-d, j], rtol=1e-12, atol=1e-9)
    assert np.max(np.abs(runs["own"].q - runs["alike"].q)) > 1e-4  # the delays matter
