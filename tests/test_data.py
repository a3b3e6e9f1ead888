"""symbolic.data: data files, experiment files, their errors, and the shipped EMPS examples."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from shared_data import emps  # noqa: F401  (fixture)
from symbolic.data import DataError, Measurements, load, write
from symbolic import robots

H = 1e-3


def canonical(n: int = 50) -> dict[str, np.ndarray]:
    """Two coordinates a, b with positions, forces, velocities, and an extra signal."""
    t = np.arange(n) * H
    return {
        "t": t,
        "q_a": np.sin(t),
        "tau_a": 2 * np.cos(t),
        "q_b": t**2,
        "tau_b": -t,
        "qd_a": np.cos(t),
        "qd_b": 2 * t,
        "pulses": (t > 0.02).astype(float),
    }


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    rows = np.column_stack(list(columns.values()))
    path.write_text(",".join(columns) + "\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in rows) + "\n")
    return path


def experiment(tmp_path: Path, text: str, data: dict[str, np.ndarray] | None = None, name: str = "log.mat") -> Path:
    """An experiment file next to a .mat file holding ``data`` (MATLAB column vectors and 1x1 scalars)."""
    if data is not None:
        scipy.io.savemat(tmp_path / name, {k: np.asarray(v, dtype=float).reshape(-1, 1) for k, v in data.items()})
    path = tmp_path / "run.experiment.toml"
    path.write_text(text)
    return path


def mat_data(n: int = 200) -> dict[str, np.ndarray]:
    t = np.arange(n) * H
    return {"time": t, "pos": np.sin(3 * t), "volt": np.cos(t), "gain": np.array([2.5]), "qg": np.sin(3 * t + 0.1)}


def error(call, *args, **kwargs) -> str:
    with pytest.raises(DataError) as info:
        call(*args, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


# ---------------------------------------------------------------------------------------------- data files


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
def test_canonical_files_load_by_coordinate(tmp_path: Path, suffix: str) -> None:
    columns = canonical()
    path = tmp_path / f"log{suffix}"
    if suffix == ".csv":
        write_csv(path, columns)
    elif suffix == ".npz":
        np.savez(path, **columns)
    else:
        scipy.io.savemat(path, {k: v.reshape(-1, 1) for k, v in columns.items()})
    m = load(path, coordinates=["b", "a"])
    assert m.coordinates == ("b", "a")
    np.testing.assert_array_equal(m.q, np.column_stack([columns["q_b"], columns["q_a"]]))
    np.testing.assert_array_equal(m.tau[:, 1], columns["tau_a"])
    np.testing.assert_array_equal(m.qd[:, 0], columns["qd_b"])
    assert m.qdd is None and m.ref is None
    assert list(m.extras) == ["pulses"]
    assert m.sample_period == pytest.approx(H, rel=1e-12)
    assert m.source == path and m.model is None and m.controller is None
    assert not m.q.flags.writeable
    # without coordinates: taken from the q_ columns in file order
    assert load(path).coordinates == ("a", "b")


def test_npz_and_mat_scalars_are_constants(tmp_path: Path) -> None:
    columns = canonical()
    np.savez(tmp_path / "log.npz", gain=np.float64(3.5), **columns)
    assert dict(load(tmp_path / "log.npz").constants) == {"gain": 3.5}


def test_write_then_load_gives_the_same_numbers_and_bytes(tmp_path: Path) -> None:
    m = load(write_csv(tmp_path / "in.csv", canonical()))
    for suffix in (".csv", ".npz"):
        first = write(m, tmp_path / f"out{suffix}")
        again = load(first)
        for (name, a), (other, b) in zip(m.columns().items(), again.columns().items()):
            assert name == other
            np.testing.assert_array_equal(a, b)
        before = first.read_bytes()
        write(m, first)
        assert first.read_bytes() == before


def test_from_arrays_checks_like_a_file() -> None:
    t = np.arange(10) * H
    m = Measurements.from_arrays(t, ["x"], np.sin(t)[:, None], np.cos(t)[:, None])
    assert m.q.shape == (10, 1) and m.rate == pytest.approx(1000.0)
    t[5] = t[4]
    assert "not increasing" in error(Measurements.from_arrays, t, ["x"], np.sin(t)[:, None], np.cos(t)[:, None])


# ---------------------------------------------------------------------------------------------- data errors


def test_missing_column(tmp_path: Path) -> None:
    columns = canonical()
    del columns["tau_b"]
    message = error(load, write_csv(tmp_path / "log.csv", columns), coordinates=["a", "b"])
    assert "log.csv: columns: missing column 'tau_b'" in message and "required: t" in message


def test_missing_column_for_a_coordinate_of_the_model(tmp_path: Path) -> None:
    message = error(load, write_csv(tmp_path / "log.csv", canonical()), coordinates=["a", "b", "c"])
    assert "missing column 'q_c'" in message


def test_missing_time(tmp_path: Path) -> None:
    columns = canonical()
    del columns["t"]
    assert "missing column 't'" in error(load, write_csv(tmp_path / "log.csv", columns))


def test_optional_signal_for_some_coordinates_only(tmp_path: Path) -> None:
    columns = canonical()
    del columns["qd_b"]
    message = error(load, write_csv(tmp_path / "log.csv", columns))
    assert "missing column 'qd_b' while 'qd_a' is given" in message


def test_signal_for_a_coordinate_the_model_does_not_have(tmp_path: Path) -> None:
    message = error(load, write_csv(tmp_path / "log.csv", canonical()), coordinates=["a"])
    assert "column 'q_b': signal for coordinate 'b', which the model does not have (its coordinates: a)" in message


def test_time_not_increasing(tmp_path: Path) -> None:
    columns = canonical()
    columns["t"][7] = columns["t"][6]
    message = error(load, write_csv(tmp_path / "log.csv", columns))
    assert "column 't': time is not increasing" in message and "at sample 7" in message


def test_time_not_uniform_says_what_was_found(tmp_path: Path) -> None:
    columns = canonical(2000)
    columns["t"][1234:] += 0.1e-3  # one step of 1.1 ms, and 0.9 ms after
    columns["t"][1235:] -= 0.1e-3
    path = write_csv(tmp_path / "log.csv", columns)
    message = error(load, path)
    assert "time step varies from 0.9 ms to 1.1 ms" in message
    assert "at sample 1234" in message and "resample" in message


def test_resampling_on_request_interpolates_onto_a_uniform_grid(tmp_path: Path) -> None:
    n = 100
    t = np.arange(n) * H
    t[40:] += 0.5e-3  # a late sample
    t[-1] = (n - 1) * H
    columns = {"t": t, "q_a": 3 * t + 1, "tau_a": -2 * t}  # linear: interpolation is exact
    m = load(write_csv(tmp_path / "log.csv", columns), resample=True)
    assert m.resampled
    np.testing.assert_allclose(np.diff(m.t), H, rtol=1e-9)
    np.testing.assert_allclose(m.q[:, 0], 3 * m.t + 1, rtol=1e-13)
    np.testing.assert_allclose(m.tau[:, 0], -2 * m.t, rtol=1e-13, atol=1e-15)


def test_jitter_below_the_tolerance_is_accepted(tmp_path: Path) -> None:
    columns = canonical()
    columns["t"] = columns["t"] + np.random.default_rng(1).uniform(-0.4e-6, 0.4e-6, len(columns["t"]))
    m = load(write_csv(tmp_path / "log.csv", columns))
    assert not m.resampled


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nan_or_inf_names_column_and_sample(tmp_path: Path, bad: float) -> None:
    columns = canonical()
    columns["tau_b"][17] = bad
    columns["tau_b"][30] = bad
    message = error(load, write_csv(tmp_path / "log.csv", columns))
    assert re.search(rf"column 'tau_b': value -?{bad} at sample 17 \(t = 0.017 s\) and at 1 more sample", message)


def test_length_mismatch_in_a_csv_row(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "log.csv", canonical())
    lines = path.read_text().splitlines()
    lines[5] = lines[5].rsplit(",", 1)[0]
    path.write_text("\n".join(lines))
    assert "log.csv: line 6: length mismatch: 7 fields, the header has 8" in error(load, path)


def test_length_mismatch_between_arrays(tmp_path: Path) -> None:
    columns = canonical()
    columns["tau_a"] = columns["tau_a"][:-3]
    np.savez(tmp_path / "log.npz", **columns)
    message = error(load, tmp_path / "log.npz")
    assert "column 'tau_a': length mismatch: 47 samples, while 't' has 50" in message


def test_text_in_a_number_column(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "log.csv", canonical())
    path.write_text(path.read_text().replace("\n0.003", "\nthree", 1))
    assert "line 5 column 't': cannot read 'three' as a number" in error(load, path)


def test_unknown_file_type(tmp_path: Path) -> None:
    path = tmp_path / "log.xlsx"
    path.write_bytes(b"\x00\x01 spreadsheet")
    message = error(load, path)
    assert "log.xlsx: file: unknown file type '.xlsx'" in message and ".csv" in message and ".toml" in message


def test_file_type_from_content(tmp_path: Path) -> None:
    scipy.io.savemat(tmp_path / "log.mat", {k: v.reshape(-1, 1) for k, v in canonical().items()})
    (tmp_path / "log.mat").rename(tmp_path / "log.data")
    assert load(tmp_path / "log.data").coordinates == ("a", "b")


def test_matrix_variable_is_refused_where_a_signal_is_needed(tmp_path: Path) -> None:
    columns = canonical()
    np.savez(tmp_path / "log.npz", **{**columns, "q_a": np.ones((50, 2))})
    assert "column 'q_a': is of shape (50, 2)" in error(load, tmp_path / "log.npz")


# ---------------------------------------------------------------------------------------------- experiments

EXPERIMENT = """
data = "log.mat"
model = "emps"
[signals]
t = "time"
q_x = "pos/scale"
tau_x = "gain*volt"
ref_x = "qg/scale"
pulses = "2*sign(volt)"
[constants]
scale = 2.0
"""


def test_experiment_maps_variables_by_expressions(tmp_path: Path) -> None:
    data = mat_data()
    m = load(experiment(tmp_path, EXPERIMENT, data), coordinates=["x"])
    np.testing.assert_allclose(m.q[:, 0], data["pos"] / 2.0, rtol=1e-15)
    np.testing.assert_allclose(m.tau[:, 0], 2.5 * data["volt"], rtol=1e-15)
    np.testing.assert_array_equal(m.extras["pulses"], 2 * np.sign(data["volt"]))
    assert m.model == "emps" and m.data_file == (tmp_path / "log.mat").resolve()
    assert dict(m.constants) == {"gain": 2.5, "scale": 2.0}


def test_experiment_rate_window_controller(tmp_path: Path) -> None:
    text = """
data = "log.mat"
model = "arm.toml"
rate = 1000.0
[signals]
q_x = "pos"
tau_x = "volt"
[window]
start = 0.05
stop = 0.1
[controller]
kind = "pd"
kp = [40.0]
kd = [0.5]
reference = ["0.1*t"]
"""
    (tmp_path / "arm.toml").write_text("")
    m = load(experiment(tmp_path, text, mat_data()))
    assert m.t[0] == pytest.approx(0.05) and m.t[-1] == pytest.approx(0.1) and m.samples == 51
    assert m.model == str((tmp_path / "arm.toml").resolve()) and m.window == (0.05, 0.1)
    assert m.controller.kind == "pd" and m.controller.coordinates == ("x",) and m.controller.kp.tolist() == [40.0]
    assert m.controller.kd.tolist() == [0.5] and m.controller.reference == ("0.1*t",)


def test_experiment_rate_inside_signals(tmp_path: Path) -> None:
    text = 'data = "log.mat"\n[signals]\nrate = 500.0\nq_x = "pos"\ntau_x = "volt"\n'
    assert load(experiment(tmp_path, text, mat_data())).sample_period == pytest.approx(2e-3)


def test_unknown_variable_in_an_expression(tmp_path: Path) -> None:
    path = experiment(tmp_path, EXPERIMENT.replace("gain*volt", "gtau*volt"), mat_data())
    message = error(load, path)
    assert "run.experiment.toml: [signals] tau_x: unknown variable 'gtau' in 'gtau*volt'" in message
    assert "variables of log.mat: " in message and "gain" in message and "[constants]: scale" in message


def test_expressions_are_never_evaluated_as_python(tmp_path: Path) -> None:
    path = experiment(tmp_path, EXPERIMENT.replace('"gain*volt"', "\"__import__('os').getcwd()\""), mat_data())
    message = error(load, path)
    assert "[signals] tau_x: call of '__import__('os').getcwd' is not allowed" in message


def test_ambiguous_constant(tmp_path: Path) -> None:
    path = experiment(tmp_path, EXPERIMENT + "gain = 3.0\n", mat_data())
    message = error(load, path)
    assert "[constants] gain: ambiguous: 'gain' is also a variable of log.mat" in message


def test_experiment_signal_for_a_coordinate_the_model_does_not_have(tmp_path: Path) -> None:
    message = error(load, experiment(tmp_path, EXPERIMENT, mat_data()), coordinates=["q"])
    assert "[signals] q_x: signal for coordinate 'x', which the model does not have (its coordinates: q)" in message


def test_experiment_missing_signal(tmp_path: Path) -> None:
    path = experiment(tmp_path, EXPERIMENT.replace('tau_x = "gain*volt"', ""), mat_data())
    assert "run.experiment.toml: [signals]: missing signal 'tau_x'" in error(load, path)


def test_empty_window(tmp_path: Path) -> None:
    path = experiment(tmp_path, EXPERIMENT + "[window]\nstart = 5.0\nstop = 6.0\n", mat_data())
    message = error(load, path)
    assert "[window]: the window [5, 6] s holds 0 sample(s)" in message and "the data span 0 s to 0.199 s" in message


def test_experiment_length_mismatch_between_variables(tmp_path: Path) -> None:
    data = mat_data()
    data["volt"] = data["volt"][:150]
    message = error(load, experiment(tmp_path, EXPERIMENT, data))
    assert "[signals] tau_x: length mismatch: 150 samples, while 't' has 200" in message
    message = error(load, experiment(tmp_path, EXPERIMENT.replace("gain*volt", "volt - pos")))
    assert "[signals] tau_x: length mismatch between the variables of 'volt - pos': pos has 200 samples, volt has 150" in message


def test_experiment_nan_from_an_expression(tmp_path: Path) -> None:
    path = experiment(tmp_path, EXPERIMENT.replace('"pos/scale"', '"sqrt(pos - 0.3)"'), mat_data())
    assert re.search(r"\[signals\] q_x: value nan at sample \d+ \(t = [0-9.]+ s\)", error(load, path))


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (('data = "log.mat"', 'data = "elsewhere.mat"'), "data: data file 'elsewhere.mat' not found"),
        (('model = "emps"', 'model = "nowhere/arm.toml"'), "model: model file 'nowhere/arm.toml' not found"),
        (('data = "log.mat"', 'colour = 3\ndata = "log.mat"'), "colour: unknown key (allowed: data, model"),
        (('data = "log.mat"', 'rate = 100.0\ndata = "log.mat"'), "rate: give either the time (t in [signals]) or a rate"),
        (('data = "log.mat"', 'controller = 3\ndata = "log.mat"'), "[controller]: expected a table, got int"),
        (('data = "log.mat"', 'resample = 1\ndata = "log.mat"'), "resample: expected true or false"),
        (('t = "time"', 't = "time"\n"q x" = "pos"'), "[signals] q x: a signal name must be an identifier"),
        (("scale = 2.0", "scale = 'two'"), "[constants] scale: expected a finite number"),
        (("scale = 2.0", "sin = 2.0"), "[constants] sin: not a usable name"),
        (('t = "time"', "t = 3"), "[signals] t: 3 uses no signal of the file"),
        (("[constants]", "[window]\nbegin = 0.0\n[constants]"), "[window] begin: unknown key"),
        (("[signals]", "x = [\n[signals]"), "TOML syntax"),
    ],
)
def test_experiment_errors(tmp_path: Path, change: tuple[str, str], expected: str) -> None:
    path = experiment(tmp_path, EXPERIMENT.replace(*change), mat_data())
    assert expected in error(load, path)


def test_data_found_through_the_search_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "store"
    folder.mkdir()
    scipy.io.savemat(folder / "log.mat", {k: v.reshape(-1, 1) for k, v in mat_data().items()})
    path = experiment(tmp_path, EXPERIMENT.replace('"log.mat"', '"../../somewhere/log.mat"'))
    monkeypatch.delenv("SYMBOLIC_DATA_PATH", raising=False)
    assert "SYMBOLIC_DATA_PATH unset" in error(load, path)
    monkeypatch.setenv("SYMBOLIC_DATA_PATH", str(tmp_path / "empty") + ":" + str(folder))
    assert load(path).data_file == (folder / "log.mat").resolve()


# ---------------------------------------------------------------------------------------------- shipped examples


def test_experiment_files_are_examples_not_robots() -> None:
    assert robots.examples() == ["emps_estimation", "emps_excitation", "emps_one_way", "emps_pulses", "panda_excitation",
                                 "puma560_excitation"]
    assert not any("experiment" in name for name in robots.names())
    assert robots.example_path("emps_pulses").name == "emps_pulses.experiment.toml"
    with pytest.raises(KeyError):
        robots.example_path("nope")


def test_emps_examples_load(emps: Path) -> None:
    raw = scipy.io.loadmat(emps / "DATA_EMPS_PULSES.mat")
    m = load(robots.example_path("emps_pulses"), coordinates=["q"])
    assert m.samples == 24841 and m.sample_period == pytest.approx(1e-3, rel=1e-12)
    np.testing.assert_array_equal(m.q[:, 0], raw["qm"][:, 0])
    np.testing.assert_allclose(m.tau[:, 0], raw["gtau"][0, 0] * raw["vir"][:, 0], rtol=1e-15)
    np.testing.assert_array_equal(m.extras["pulses_N"], raw["pulses_N"][:, 0])
    assert m.model == "emps" and m.controller.kind == "cascade" and m.settings.bandwidth == 20.0
    assert dict(load(robots.example_path("emps_estimation"), coordinates=["q"]).constants)["gtau"] == raw["gtau"][0, 0]
    # the model the experiments name is the built-in one, and its coordinates are the data's
    assert robots.load(m.model).coordinates == m.coordinates
