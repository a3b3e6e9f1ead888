"""An experiment is loaded and checked once (symbolic.data.load -> Experiment), and every command reads it alike.

* a misspelt key of any table is refused by identify, simulate, diagnose and first-peak with the same line;
* ``diagnose`` with a simulated path filters the measured velocity once, with its ``settings``;
* CSV files without a header line: named by the experiment's ``columns``, else a message that says so;
* a coordinate without an actuator (``tau_<c> = "0"``): its rows are in the stacked IDIM-LS system and
  determine what the actuated rows cannot;
* drive signals ``u_<c>`` times the model's ``[[drive]] gain`` give what logging τ gives, in identify,
  simulate and diagnose.

The truths are built here: a cart with a passive pendulum whose unactuated equation holds exactly (the
cart's acceleration solved from it with the model's numeric inverse dynamics), and an EMPS-like axis
whose force is the published model's along a chosen motion.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import symbolic
from symbolic import data
from symbolic.cli import main
from symbolic.data import DataError, Experiment, Settings
from symbolic.data.files import write as write_columns
from symbolic.identify.model import identify_model, model_base
from symbolic.numeric import numeric_model
from symbolic.numeric.base_parameters import theta_values
from symbolic.simulation import simulate
from symbolic.workflow import diagnose
from symbolic.workflow.effects import select

import workflow_cases as cases
from models import cart_pendulum

RATE = 1000.0


def error(call, *args, **kwargs) -> str:
    with pytest.raises(DataError) as info:
        call(*args, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


# -- one line for a misspelt key, from every command -----------------------------------------------------------


def emps_log(folder: Path, seconds: float = 3.0) -> Path:
    """An EMPS-like log (the built-in model's force along a smooth motion: τ = M·q̈ + Fv·q̇ + Fc·sign(q̇) + offset
    with its published values), canonical CSV columns with a reference."""
    t = np.arange(0.0, seconds, 1.0 / RATE)
    q = 0.05 * np.sin(2 * np.pi * 0.5 * t)
    qd = 0.05 * 2 * np.pi * 0.5 * np.cos(2 * np.pi * 0.5 * t)
    qdd = -0.05 * (2 * np.pi * 0.5) ** 2 * np.sin(2 * np.pi * 0.5 * t)
    p = {s.name: v for s, v in symbolic.robots.load("emps").parameter_values.items()}
    tau = p["M"] * qdd + p["Fv"] * qd + p["Fc"] * np.sign(qd) + p["offset"]  # the model file's equation
    return write_columns({"t": t, "q_q": q, "tau_q": tau, "ref_q": q}, folder / "log.csv")


PD = 'kind = "pd"\ncoordinates = ["q"]\nkp = [50.0]\nkd = [0.0]\ngain = "gtau"\nreference = "ref"\n'
EXPERIMENT = 'data = "log.csv"\nmodel = "emps"\n[signals]\nt = "t"\nq_q = "q_q"\ntau_q = "tau_q"\nref_q = "ref_q"\n'


@pytest.mark.parametrize(("table", "misspelt", "message"), [
    (f"[controller]\n{PD}", ("kp = ", "kpp = "),
     "[controller] kpp: unknown key (allowed for 'pd': kind, coordinates, gain, saturation, quantisation, disturbance, "
     "delay, kp, kd, reference, velocity_filter); did you mean 'kp'?"),
    (f"[controller]\n{PD}", ('kind = "pd"', 'kind = "pdd"'),
     "[controller] kind: expected one of torque, pd, pid, cascade"),
    ("[identification]\nbandwidth = 20.0\n", ("bandwidth", "bandwith"),
     "[identification] bandwith: unknown key (allowed: bandwidth, cutoff, order, decimation, border, "
     "filter_positions, held_force); did you mean 'bandwidth'?"),
    ("[window]\nstart = 0.1\n", ("start", "begin"), "[window] begin: unknown key (allowed: start, stop)"),
    ("", ('model = "emps"', 'modle = "emps"'), ": modle: unknown key (allowed: data, model, description"),
])
def test_a_misspelt_key_is_refused_alike_by_every_command(tmp_path: Path, capsys: pytest.CaptureFixture, table: str,
                                                          misspelt: tuple[str, str], message: str) -> None:
    """identify once accepted a misspelt [controller] key that simulate refused: each table is now checked
    where the experiment is read, so every command prints the same one line and exits 2."""
    emps_log(tmp_path)
    experiment = tmp_path / "run.experiment.toml"
    experiment.write_text((EXPERIMENT + table).replace(*misspelt))
    commands = [["identify", "emps", str(experiment)], ["simulate", "emps", str(experiment)],
                ["diagnose", "emps", str(experiment), "--out", str(tmp_path / "out")], ["first-peak", str(experiment)]]
    lines = []
    for command in commands:
        assert main(["-q", *command]) == 2, command
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, (command, err)
        lines.append(err[0])
    assert len(set(lines)) == 1, lines
    assert lines[0].startswith(f"error: {experiment}") and message in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_a_misspelt_controller_key_in_python_is_refused_as_in_a_file() -> None:
    log = data.Measurements.from_arrays(np.arange(20) / RATE, ["q"], np.zeros((20, 1)), np.zeros((20, 1)))
    message = error(Experiment.of, log, controller={"kind": "cascade", "kp": [1.0], "kvv": [2.0], "reference": ["0"]})
    assert message.startswith("<arrays>: [controller] kvv: unknown key (allowed for 'cascade': ")
    assert message.endswith("; did you mean 'kv'?")


# -- diagnose's simulated path: the velocity filtered once, with the diagnosis' settings ------------------------


def test_diagnose_with_a_simulated_path_honours_its_settings(tmp_path: Path) -> None:
    """The measured q̇ of the motion gaps is the data set's own (filtered with ``settings``): a stand-in
    simulation that returns 0.98 × q̇ filtered at 3 Hz gives a velocity gap of exactly 2 % when the
    diagnosis is told cutoff = 3 Hz, and not when it filters with its default (rate/10 = 50 Hz)."""
    from symbolic.data.treatment import filtered_motion
    from symbolic.workflow import SimulatedSignals

    model = cases.axis()
    logged = cases.measurements(model, 1, 0.01, seconds=20.0)

    def stand_in(m, p, measurements):
        _, qd, _ = filtered_motion(measurements, 3.0, 4)
        return SimulatedSignals(np.asarray(measurements.tau), np.asarray(measurements.q), 0.98 * qd)

    path = cases.model_file(tmp_path, model)
    gaps = {}
    for label, settings in (("3 Hz", Settings(cutoff=3.0)), ("default", None)):
        d = diagnose(path, logged, settings=settings, simulate=stand_in, effects=select(["offset"]), figures=False)
        gaps[label] = d.to_dict()["gap_detail"]["before"]
    for role in ("estimation", "validation"):
        assert gaps["3 Hz"][role]["velocity"]["q"] == pytest.approx(2.0, rel=1e-9)
        assert gaps["default"][role]["velocity"]["q"] > 2.5  # the 3 Hz stand-in misses what 50 Hz keeps


# -- CSV files without a header line -------------------------------------------------------------------------------


def headerless(folder: Path, samples: int = 50) -> tuple[Path, np.ndarray]:
    t = np.arange(samples) / RATE
    rows = np.round(np.column_stack([t, np.sin(t), -0.5 * np.cos(t), -0.0 * t, -0.0 * t]), 6)  # as printed
    path = folder / "raw.csv"
    path.write_text("\n".join(",".join(f"{v:.6f}" for v in row) for row in rows) + "\n")
    return path, rows


def test_a_csv_without_a_header_line_says_so(tmp_path: Path) -> None:
    """A numeric first line is not taken for names (it gave "column name '-0.000000' appears twice")."""
    path, _ = headerless(tmp_path)
    message = error(data.load, path)
    assert message.startswith(f"{path}: header: the first line '0.000000,0.000000,-0.500000,-0.000000,-0.000000' is "
                              "numbers: the file has no header line; name its 5 columns in an experiment file, columns = ")
    assert "add a header line" in message and "appears twice" not in message


def test_an_experiment_names_the_columns_of_a_csv_without_a_header_line(tmp_path: Path) -> None:
    path, rows = headerless(tmp_path)
    text = ('data = "raw.csv"\ncolumns = ["time", "pos", "current", "spare1", "spare2"]\n[signals]\nt = "time"\n'
            'q_a = "pos"\ntau_a = "2*current"\n')
    experiment = tmp_path / "raw.experiment.toml"
    experiment.write_text(text)
    m = data.load(experiment)
    np.testing.assert_array_equal(m.q[:, 0], rows[:, 1])
    np.testing.assert_array_equal(m.tau[:, 0], 2 * rows[:, 2])
    assert m.samples == len(rows)
    for bad, expected in [
        ('["time", "pos", "current"]', "columns: names 3 column(s), but the lines of raw.csv have 5 field(s) (line 1)"),
        ('["time", "pos", "current", "spare1", "pos"]', "columns: 'pos' is named twice"),
        ('["time", "pos", "current", "spare 1", "spare2"]', "columns[3]: 'spare 1' is not a usable name"),
    ]:
        experiment.write_text(text.replace('["time", "pos", "current", "spare1", "spare2"]', bad))
        assert f"{experiment}: {expected}" in error(data.load, experiment)
    # a file with a header line keeps it: columns would rename silently, so it is refused
    write_columns({"t": rows[:, 0], "pos": rows[:, 1], "current": rows[:, 2], "a": rows[:, 3], "b": rows[:, 4]},
                  tmp_path / "raw.csv")
    experiment.write_text(text)
    assert "columns: raw.csv has a header line ('t,pos,current,a,b'); columns is for a CSV file without one" in error(
        data.load, experiment)


# -- a coordinate without an actuator: tau_<c> = "0" --------------------------------------------------------------

CART = cart_pendulum(M=2.0, m=0.5, l=0.3, viscous=(("Fx", 1.5), ("Ft", 0.02)), gravity=("-9.81", "0", "0"),
                     pole="arm", description="a driven cart with a passive pendulum (no actuator on th)")


def cart_log(folder: Path, model: symbolic.DynamicModel) -> Path:
    """The pendulum's angle chosen (three sines), the cart's acceleration solved from the pendulum's own
    equation τ_th = 0 (affine in ẍ: two evaluations of the model's numeric inverse dynamics), the cart's
    force from its equation. Positions, velocities and accelerations are logged, the pendulum's force is not."""
    num = numeric_model(model)
    t = np.arange(0.0, 10.0, 1.0 / 200.0)
    amplitude, omega, phase = np.array([0.6, 0.3, 0.2]), 2 * np.pi * np.array([0.3, 0.7, 1.1]), np.array([0.0, 1.0, 2.0])
    arg = omega[None] * t[:, None] + phase[None]
    th, thd, thdd = (np.sin(arg) @ amplitude, np.cos(arg) @ (amplitude * omega), -np.sin(arg) @ (amplitude * omega**2))
    x, xd = 0.1 * np.sin(0.5 * t), 0.05 * np.cos(0.5 * t)  # the cart's force does not depend on x; ẋ enters by friction
    xdd, force = np.empty_like(t), np.empty_like(t)
    for k in range(len(t)):
        q, qd = np.array([x[k], th[k]]), np.array([xd[k], thd[k]])
        at0 = num.inverse_dynamics(q, qd, np.array([0.0, thdd[k]]))
        at1 = num.inverse_dynamics(q, qd, np.array([1.0, thdd[k]]))
        xdd[k] = -at0[1] / (at1[1] - at0[1])
        tau = num.inverse_dynamics(q, qd, np.array([xdd[k], thdd[k]]))
        assert abs(tau[1]) < 1e-12 * max(abs(tau[0]), 1.0)
        force[k] = tau[0]
    write_columns({"t": t, "x": x, "xd": xd, "xdd": xdd, "th": th, "thd": thd, "thdd": thdd, "fx": force},
                  folder / "cart.csv")
    experiment = folder / "cart.experiment.toml"
    experiment.write_text('data = "cart.csv"\n[signals]\nt = "t"\nq_x = "x"\nqd_x = "xd"\nqdd_x = "xdd"\ntau_x = "fx"\n'
                          'q_th = "th"\nqd_th = "thd"\nqdd_th = "thdd"\ntau_th = "0"\n'
                          '[identification]\nfilter_positions = false\ndecimation = 1\n')
    return experiment


def test_an_unactuated_coordinate_has_its_rows_in_the_stacked_system(tmp_path: Path) -> None:
    """tau_th = "0": the pendulum's rows are in y = W·β (zeros in y, its regressor in W). Their equation is
    homogeneous, so identify refuses it until a value of it is known (issue 21 §3); with the mass m kept at its
    value, the pendulum's friction Ft — which only that equation holds — is identified to 1e-9."""
    model = symbolic.derive(symbolic.loads(CART, str(tmp_path / "cart.toml")))
    experiment = cart_log(tmp_path, model)
    loaded = data.load(experiment, model=model.robot)
    assert np.all(loaded.tau[:, 1] == 0.0) and loaded.tau.shape == (loaded.samples, 2)
    with pytest.raises(symbolic.IdentificationError, match="no actuator in the data"):
        identify_model(model, experiment)
    result = identify_model(model, experiment, fix=["m"])
    observation = result.observation
    rows = observation.samples
    assert observation.y.shape == (2 * rows,) and observation.W.shape[0] == 2 * rows
    assert np.abs(observation.W[rows:]).max() > 1.0
    assert result.parameters["Ft"].value == pytest.approx(0.02, rel=1e-9)


def test_only_a_generalized_force_may_be_a_number(tmp_path: Path) -> None:
    path, _ = headerless(tmp_path)
    experiment = tmp_path / "raw.experiment.toml"
    experiment.write_text('data = "raw.csv"\ncolumns = ["t", "p", "i", "s1", "s2"]\n[signals]\nt = "t"\nq_a = "0"\n'
                          'tau_a = "i"\n')
    assert "[signals] q_a: '0' uses no signal of the file" in error(data.load, experiment)


# -- drive signals: u_<c> × [[drive]] gain ------------------------------------------------------------------------


def test_a_drive_signal_times_the_drive_gain_is_the_logged_force(tmp_path: Path) -> None:
    """EMPS's model converts its drive voltage by [[drive]] gain = gtau (35.15 N/V): a log of u = τ/35.15
    (a u_q column of a data file, and u_q in an experiment's [signals]) gives what the log of τ gives, in
    identify (to 1e-9), simulate and diagnose."""
    model = symbolic.derive(symbolic.robots.load("emps"))
    log = emps_log(tmp_path, seconds=6.0)
    forces = data.load(log, model=model.robot)
    t, q, tau = forces.t, forces.q[:, 0], forces.tau[:, 0]
    drive = write_columns({"t": t, "q_q": q, "u_q": tau / 35.15, "ref_q": q}, tmp_path / "drive.csv")
    mapped = tmp_path / "drive.experiment.toml"
    mapped.write_text('data = "drive.csv"\n[signals]\nt = "t"\nq_q = "q_q"\nu_q = "u_q"\n')
    driven = data.load(drive, model=model.robot)
    assert driven.drive_gains == {"q": 35.15}
    np.testing.assert_allclose(driven.tau[:, 0], tau, rtol=1e-14)

    reference = identify_model(model, log).identification.values
    for other in (drive, mapped):
        np.testing.assert_allclose(identify_model(model, other).identification.values, reference, rtol=1e-9)

    replayed = simulate(model, log).simulated.q
    np.testing.assert_allclose(simulate(model, drive).simulated.q, replayed, rtol=1e-9, atol=1e-12)

    effects = select(["offset"])
    before = diagnose(model, log, effects=effects, figures=False).before.gap
    after = diagnose(model, drive, effects=effects, figures=False).before.gap
    assert after == pytest.approx(before, rel=1e-9)


def test_a_drive_signal_needs_a_drive_gain(tmp_path: Path) -> None:
    t = np.arange(20) / RATE
    drive = write_columns({"t": t, "q_q": np.sin(t), "u_q": np.cos(t)}, tmp_path / "drive.csv")
    message = error(data.load, drive)
    assert message.startswith(f"{drive}: column 'u_q': the drive signal of 'q' needs the model's [[drive]] gain")
    no_gain = symbolic.derive(symbolic.loads(symbolic.robots.path("emps").read_text().replace('gain = "gtau"', ""),
                                             "<emps without gain>"))
    message = error(data.load, drive, model=no_gain.robot)
    assert "model 'emps' has no [[drive]] gain for coordinate 'q' (tau_q = gain·u_q): add gain to its [[drive]]" in message
    both = write_columns({"t": t, "q_q": np.sin(t), "u_q": np.cos(t), "tau_q": np.cos(t)}, tmp_path / "both.csv")
    assert "column 'u_q': both tau_q and u_q are given" in error(data.load, both, model=no_gain.robot)


# -- the validation set: one rule --------------------------------------------------------------------------------


def test_a_validation_data_file_is_mapped_by_the_experiment(tmp_path: Path) -> None:
    """``--experiment`` maps the estimation file and a plain validation file alike; a validation experiment
    file maps itself. One rule, in the loader."""
    path, rows = headerless(tmp_path)
    experiment = tmp_path / "map.experiment.toml"
    experiment.write_text('data = "unused.csv"\ncolumns = ["time", "pos", "current", "s1", "s2"]\n[signals]\n'
                          't = "time"\nq_a = "pos"\ntau_a = "current"\n')
    loaded = data.load(path, experiment=experiment, validation=path)
    assert isinstance(loaded.validation, Experiment) and loaded.validation.data_file == path.resolve()
    np.testing.assert_array_equal(loaded.validation.tau[:, 0], rows[:, 2])
    other = tmp_path / "other.experiment.toml"
    other.write_text('data = "raw.csv"\ncolumns = ["t", "p", "i", "s1", "s2"]\n[signals]\nt = "t"\nq_a = "p"\n'
                     'tau_a = "3*i"\n')
    loaded = data.load(path, experiment=experiment, validation=other)
    np.testing.assert_array_equal(loaded.validation.tau[:, 0], 3 * rows[:, 2])


# -- the coordinates: a simulation may take a log of some of them, identification needs all -----------------------


def test_a_log_of_some_coordinates_is_simulated_and_refused_by_identification(tmp_path: Path) -> None:
    golden = Path(__file__).parent / "golden" / "double_pendulum.toml"
    model = symbolic.derive(symbolic.load(golden))
    t = np.arange(200) / RATE
    log = write_columns({"t": t, "q_q1": 0.1 * np.sin(t), "tau_q1": np.zeros_like(t)}, tmp_path / "q1.csv")
    assert data.load(log, model=model.robot).coordinates == ("q1",)
    assert simulate(model, log).simulated.samples == len(t)
    message = error(identify_model, model, log)
    assert message.startswith(f"{log}: columns: missing column 'q_q2'")
    other = write_columns({"t": t, "q_x": np.sin(t), "tau_x": np.zeros_like(t)}, tmp_path / "x.csv")
    for call in (lambda: data.load(other, model=model.robot), lambda: identify_model(model, other)):
        assert error(call) == (f"{other}: column 'q_x': signal for coordinate 'x', which the model does not have "
                               "(its coordinates: q1, q2)")


# -- issue 39: canonical columns need no [signals] --------------------------------------------------------------


def test_an_experiment_of_canonical_columns_needs_no_signals_table(tmp_path: Path) -> None:
    """A file whose columns are canonical is its own mapping: an experiment that adds only a controller and the
    data treatment loads the same signals as the data file read directly (it was "[signals]: missing table")."""
    log = emps_log(tmp_path)
    path = tmp_path / "run.experiment.toml"
    path.write_text(f'data = "log.csv"\nmodel = "emps"\n[identification]\nheld_force = true\n[controller]\n{PD}')
    loaded, direct = data.load(path), data.load(log)
    assert loaded.coordinates == direct.coordinates == ("q",) and loaded.settings.held_force is True
    for kind in ("t", "q", "tau", "ref"):
        np.testing.assert_array_equal(getattr(loaded, kind), getattr(direct, kind))
    assert loaded.controller is not None and loaded.controller.kind == "pd" and loaded.model == "emps"


def test_without_signals_a_file_of_other_names_is_refused_with_its_variables(tmp_path: Path) -> None:
    t = np.arange(0.0, 0.1, 1.0 / RATE)
    write_columns({"time": t, "pos": np.sin(t), "volts": np.cos(t)}, tmp_path / "raw.csv")
    path = tmp_path / "raw.experiment.toml"
    path.write_text('data = "raw.csv"\n[identification]\nbandwidth = 20.0\n')
    message = error(data.load, path)
    assert message.startswith(f"{path}: [signals]: missing table, and raw.csv has no canonical column (t, q_<c>, ")
    assert "its variables: time, pos, volts): map them" in message
