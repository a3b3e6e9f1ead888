"""ROS 2 bags and MCAP files as data files (symbolic.data.bags; docs/data.md, "Bags and MCAP files").

The bags are written here, in tmp_path, by the writers of the libraries the reader uses (rosbags' rosbag2 Writer
with sqlite3 and MCAP storage; mcap_ros2's MCAP Writer), from EMPS's log and from a synthetic two-link log,
joint states at 1 kHz (header stamps, logged 0.3 ms later) and commands at 500 Hz (no header: log time). Each
identifies the same parameters as the canonical CSV of the same numbers to 1e-9 relative.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bag_writers as bw
import models
import symbolic
from shared_data import emps_folder
from symbolic.data import DataError, load
from symbolic.data import bags
from symbolic.data import files
from symbolic.identify.model import base_regressor, identify_model, model_base

KINDS = ("mcap", "sqlite3", "rosbag2-mcap")
EPOCH = 1_700_000_000_000_000_000
"""The bags' clock at t = 0 (ns since 1970): stamps as a robot writes them."""
JOINTS = ("shoulder_joint", "elbow_joint")
"""The arm's joints as its messages name them (a URDF's names), mapped onto the model's q1, q2."""


@pytest.fixture(scope="module")
def arm() -> symbolic.DynamicModel:
    return symbolic.derive(symbolic.loads(models.arm(), "arm"))


def arm_log(arm, seconds: float = 3.0, rate: float = 1000.0):
    """t, q, τ (the model's, plus seeded noise) and the commands held at 500 Hz, at ``rate``."""
    n = int(round(seconds * rate)) + 1
    t = np.arange(n) / rate
    w = 2 * np.pi * np.array([[0.5, 1.3], [0.7, 1.9]])
    amplitude = np.array([[0.8, 0.3], [0.6, 0.25]])
    q = np.column_stack([sum(amplitude[j, i] * np.sin(w[j, i] * t + j) for i in range(2)) for j in range(2)])
    qd = np.column_stack([sum(amplitude[j, i] * w[j, i] * np.cos(w[j, i] * t + j) for i in range(2)) for j in range(2)])
    qdd = np.column_stack([sum(-amplitude[j, i] * w[j, i] ** 2 * np.sin(w[j, i] * t + j) for i in range(2))
                           for j in range(2)])
    tau = np.einsum("snp,p->sn", base_regressor(arm)(q, qd, qdd), model_base(arm)[1].values)
    tau = tau + np.random.default_rng(7).normal(0.0, 0.01, tau.shape)
    ref = np.roll(q, -10, axis=0)[::2]  # the commands, 10 ms ahead, every other sample
    return t, q, tau, ref


def arm_topics(t, q, tau, ref) -> list[bw.Topic]:
    stamps = EPOCH + np.round(t * 1e9).astype(np.int64)
    return [bw.joint_states(stamps, list(JOINTS), q, tau), bw.commands("/arm/command", stamps[::2], ref)]


ARM_SIGNALS = """
[signals]
q_q1 = "/joint_states.position[shoulder_joint]"
q_q2 = "/joint_states.position[elbow_joint]"
tau_q1 = "/joint_states.effort[shoulder_joint]"
tau_q2 = "/joint_states.effort[elbow_joint]"
ref_q1 = "/arm/command.data[0]"
ref_q2 = "/arm/command.data[1]"
"""


def experiment(folder: Path, bag: Path, body: str = ARM_SIGNALS, name: str = "run.experiment.toml") -> Path:
    path = folder / name
    path.write_text(f'data = "{bag.name}"\n{body}')
    return path


def canonical_csv(path: Path, t, coordinates, q, tau, ref) -> Path:
    columns = {"t": t}
    for kind, values in (("q", q), ("tau", tau), ("ref", ref)):
        columns.update({f"{kind}_{c}": values[:, j] for j, c in enumerate(coordinates)})
    return files.write(columns, path)


@pytest.mark.parametrize("kind", KINDS)
def test_a_two_link_bag_identifies_as_its_canonical_csv(arm, kind: str, tmp_path: Path) -> None:
    t, q, tau, ref = arm_log(arm)
    bag = bw.write(kind, tmp_path / "arm", arm_topics(t, q, tau, ref))
    held = np.repeat(ref, 2, axis=0)[:len(t)]  # the commands held between their messages
    csv = canonical_csv(tmp_path / "arm.csv", t, ("q1", "q2"), q, tau, held)
    from_bag = load(experiment(tmp_path, bag), model=arm.robot)
    from_csv = load(csv, model=arm.robot)
    assert np.array_equal(from_bag.q, from_csv.q) and np.array_equal(from_bag.tau, from_csv.tau)
    assert np.array_equal(from_bag.ref, from_csv.ref) and np.array_equal(from_bag.t, from_csv.t)
    whole = identify_model(arm, experiment(tmp_path, bag))
    a, b = whole.identification, identify_model(arm, csv).identification
    assert whole.to_dict()["alignment"]["base"] == "the stamps of /joint_states"  # identify --json
    assert "alignment" not in identify_model(arm, csv).to_dict()
    assert a.names == b.names
    np.testing.assert_allclose(a.values, b.values, rtol=1e-9, atol=0)
    np.testing.assert_allclose(a.sigmas, b.sigmas, rtol=1e-9, atol=0)
    report = from_bag.alignment
    assert report.base == "the stamps of /joint_states" and report.samples == len(t)
    rates = {r.topic: round(r.rate, 6) for r in report.topics}
    assert rates == {"/joint_states": 1000.0, "/arm/command": 500.0}
    stamps = {r.topic: r.stamps for r in report.topics}
    assert stamps == {"/joint_states": "header", "/arm/command": "log"}
    assert all(not r.gaps and r.dropped == 0 for r in report.topics)


def emps_log():
    import scipy.io

    m = scipy.io.loadmat(emps_folder() / "DATA_EMPS.mat")
    return (m["t"].ravel(), m["qm"].ravel(), m["vir"].ravel(), m["qg"].ravel(), float(m["gtau"][0, 0]))


@pytest.mark.parametrize("kind", ("mcap", "sqlite3"))
def test_emps_from_a_bag_gives_the_csv_figures(kind: str, tmp_path: Path) -> None:
    """EMPS's log as a joint state (position, and the drive voltage as effort) at 1 kHz and its reference at
    500 Hz; the force is gtau times the voltage, the drive gain, in [signals]."""
    t, qm, vir, qg, gtau = emps_log()
    stamps = EPOCH + np.round(t * 1e9).astype(np.int64)  # the log's own (single-precision) instants, to the ns
    topics = [bw.joint_states(stamps, ["carriage"], qm[:, None], vir[:, None]),
              bw.commands("/command", stamps[::2], qg[::2, None])]
    bag = bw.write(kind, tmp_path / "emps", topics)
    spec = experiment(tmp_path, bag, f"""model = "emps"
[signals]
q_q = "/joint_states.position[carriage]"
tau_q = "gtau * /joint_states.effort[carriage]"
ref_q = "/command.data[0]"
[constants]
gtau = {gtau!r}
[identification]
bandwidth = 20.0
""")
    csv = canonical_csv(tmp_path / "emps.csv", t, ("q",), qm[:, None], (gtau * vir)[:, None],
                        np.repeat(qg[::2], 2)[:len(t), None])
    model = symbolic.derive(symbolic.robots.load("emps"))
    from symbolic.data import Settings

    a = identify_model(model, spec).identification
    b = identify_model(model, csv, settings=Settings(bandwidth=20.0)).identification
    np.testing.assert_allclose(a.values, b.values, rtol=1e-9, atol=0)
    # the README's figures (the shipped experiment on DATA_EMPS.mat)
    assert [f"{v:.6g}" for v in a.values] == ["95.1163", "203.373", "20.409", "-3.17003"]
    assert f"{a.relative_error:.4g}" == "4.039"
    # the voltage as the drive signal u_q: the model's [[drive]] gain (gtau = 35.15 N/V, the published value)
    driven = load(experiment(tmp_path, bag, 'model = "emps"\n[signals]\nq_q = "/joint_states.position[carriage]"\n'
                                            'u_q = "/joint_states.effort[carriage]"\n', "u.toml"), model=model.robot)
    assert dict(driven.drive_gains) == {"q": 35.15}
    np.testing.assert_array_equal(driven.tau[:, 0], 35.15 * vir)


def small_arm_bag(arm, tmp_path: Path, kind: str = "mcap", drop: slice | None = None, seconds: float = 1.0,
                  topics=None) -> Path:
    t, q, tau, ref = arm_log(arm, seconds)
    written = topics if topics is not None else arm_topics(t, q, tau, ref)
    if drop is not None:
        del written[0].messages[drop]
    return bw.write(kind, tmp_path / "arm", written)


def test_a_dropped_burst_is_a_reported_gap(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path, drop=slice(400, 420))  # 20 joint states (20 ms) lost
    with pytest.warns(symbolic.ModelWarning, match=r"/joint_states: 1 gap\(s\) in the messages, 20 message\(s\) "
                                                   r"missing at 1000 Hz; the longest 21 ms at t = 0.399 s"):
        loaded = load(experiment(tmp_path, bag), model=arm.robot)
    report = loaded.alignment
    assert report.base.startswith("a uniform grid at the rate of /joint_states")
    assert report.samples == 1001 and np.allclose(np.diff(loaded.t), 1e-3)
    joint = next(r for r in report.topics if r.topic == "/joint_states")
    assert [(round(g[0], 6), round(g[1], 6), g[2]) for g in joint.gaps] == [(0.399, 0.021, 20)]
    assert any("1 gap(s), 20 message(s) missing" in line for line in report.lines())


def test_a_gap_beyond_max_gap_is_refused(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path, drop=slice(300, 500))
    with pytest.raises(DataError) as caught:
        load(experiment(tmp_path, bag), model=arm.robot)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{bag}: /joint_states: a gap of 201 ms at t = 0.299 s")
    assert "[alignment] max_gap" in message
    with pytest.warns(symbolic.ModelWarning, match="201 ms at t = 0.299 s, bridged by linear interpolation"):
        loaded = load(experiment(tmp_path, bag, ARM_SIGNALS + "[alignment]\nmax_gap = 0.5\n"), model=arm.robot)
    assert loaded.samples == 1001


def refusal(path: Path, model=None) -> str:
    with pytest.raises(DataError) as caught:
        load(path, model=model)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_an_unknown_joint_name_is_one_line(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path)
    spec = experiment(tmp_path, bag, ARM_SIGNALS.replace("position[elbow_joint]", "position[elbow_jiont]"))
    assert refusal(spec, arm.robot) == (
        f"{spec}: [signals] q_q2: joint 'elbow_jiont' is not among the names of /joint_states (its name: "
        "shoulder_joint, elbow_joint); did you mean 'elbow_joint'?; give a joint the topic names (the URDF's joint "
        "names) or a position, [0]")


def test_a_topic_of_another_type_is_one_line(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path)
    spec = experiment(tmp_path, bag, ARM_SIGNALS.replace('"/arm/command.data[0]"', '"/arm/command.position[q1]"'))
    assert refusal(spec, arm.robot) == (
        f"{spec}: [signals] ref_q1: /arm/command is a std_msgs/msg/Float64MultiArray, which has no field 'position' "
        "(its fields: layout, data)")
    spec = experiment(tmp_path, bag, ARM_SIGNALS.replace('"/arm/command.data[0]"', '"/arm/command.layout"'))
    assert "is a message std_msgs/msg/MultiArrayLayout (its fields: dim, data_offset): name one of its numbers" in \
        refusal(spec, arm.robot)
    spec = experiment(tmp_path, bag, ARM_SIGNALS.replace('"/arm/command.data[0]"', '"/arm/command.data"'))
    assert "/arm/command.data is an array: give a position, /arm/command.data[0], or a name" in refusal(spec, arm.robot)
    spec = experiment(tmp_path, bag, ARM_SIGNALS.replace('"/arm/command.data[0]"', '"/arm/comand.data[0]"'))
    assert "[signals] ref_q1: no topic '/arm/comand' in arm.mcap (its topics: /arm/command (std_msgs/msg/" \
           "Float64MultiArray, 501 messages), /joint_states (sensor_msgs/msg/JointState, 1001 messages)); did you " \
           "mean '/arm/command'?" in refusal(spec, arm.robot)
    spec = experiment(tmp_path, bag, ARM_SIGNALS.replace('"/arm/command.data[0]"', '"/joint_states.name[0]"'))
    assert "/joint_states.name is an array of string (allowed: arrays of numbers)" in refusal(spec, arm.robot)


@pytest.mark.parametrize("kind", ("mcap", "sqlite3"))
def test_a_truncated_file_is_one_line_and_nothing_is_written(arm, kind: str, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path, kind)
    storage = bag if bag.is_file() else next(bag.glob("*.db3"))
    data = storage.read_bytes()
    storage.write_bytes(data[: len(data) * 2 // 3])
    spec = experiment(tmp_path, bag)
    message = refusal(spec, arm.robot)
    assert message.startswith(f"{storage}: file: truncated: ")
    model = tmp_path / "arm.toml"
    model.write_text(models.arm())
    out = tmp_path / "identified.toml"
    done = subprocess.run([sys.executable, "-m", "symbolic", "-q", "identify", str(model), str(spec), "--out", str(out)],
                          capture_output=True, text=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert done.returncode == 2 and done.stderr == f"error: {message}\n"
    assert not out.exists()


def test_the_grammar_is_strict_and_nothing_is_evaluated(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path)
    for text, expected in (
        ("/joint_states.position[", "cannot read the topic reference at character 23 of '/joint_states.position['"),
        ("/joint_states", "cannot read a topic reference at character 1"),
        ("/joint_states.position[0].__class__", "/joint_states.position[0] is a number, which has no fields"),
        ("__import__('os') * /joint_states.position[0]", "[signals] q_q1:"),
        ("/joint_states.header.stamp.sec.x", "/joint_states.header.stamp.sec is a int32, which has no fields"),
    ):
        spec = experiment(tmp_path, bag, ARM_SIGNALS.replace('"/joint_states.position[shoulder_joint]"', repr(text)))
        assert expected in refusal(spec, arm.robot), text


def test_expressions_of_topics_and_the_declared_methods(arm, tmp_path: Path) -> None:
    """A current topic times a drive gain (a constant), a position by its index, the methods overridden."""
    t, q, tau, ref = arm_log(arm, 1.0)
    topics = arm_topics(t, q, tau, ref)
    stamps = EPOCH + np.round(t[::4] * 1e9).astype(np.int64) + 123_456  # 250 Hz, not on the joint states' instants
    topics.append(bw.commands("/currents", stamps, tau[::4] / 2.5))
    bag = bw.write("mcap", tmp_path / "arm", topics)
    body = ARM_SIGNALS.replace('"/joint_states.effort[elbow_joint]"', '"k * /currents.data[1]"')
    body = body.replace("[elbow_joint]", "[1]") + '[constants]\nk = 2.5\n[alignment]\nmethod = { ref_q1 = "linear" }\n'
    loaded = load(experiment(tmp_path, bag, body), model=arm.robot)
    stamped = (stamps - EPOCH) / 1e9 - 1e-3  # t = 0 at the first joint state after the first current
    inside = (loaded.t >= stamped[0]) & (loaded.t <= stamped[-1])
    expected = np.interp(loaded.t, stamped, 2.5 * (tau[::4, 1] / 2.5))
    np.testing.assert_allclose(loaded.tau[:, 1][inside], expected[inside], rtol=1e-12, atol=1e-12)
    assert loaded.t[0] == pytest.approx(0.0) and loaded.alignment.start_ns == EPOCH + 1_000_000  # the first instant all have
    np.testing.assert_array_equal(loaded.q[:, 1], q[1:len(loaded.t) + 1, 1])
    commands = (np.arange(0, len(t), 2) / 1000.0)
    np.testing.assert_allclose(loaded.ref[:, 0], np.interp(loaded.t + 1e-3, commands, ref[:, 0]), rtol=0, atol=1e-15)
    assert {r.topic: r.methods for r in loaded.alignment.topics} == {
        "/joint_states": ("linear",), "/arm/command": ("hold", "linear"), "/currents": ("linear",)}
    dropped = {r.topic: (r.before, r.after, r.repeated) for r in loaded.alignment.topics}
    assert dropped == {"/joint_states": (1, 0, 0), "/arm/command": (0, 0, 0), "/currents": (0, 0, 0)}
    assert any("/joint_states (sensor_msgs/msg/JointState): 1001 messages at 1000 Hz (header time), linear; no gap; "
               "dropped 1 before the time base" in line for line in loaded.alignment.lines())


def test_a_bag_without_an_experiment_lists_its_topics(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path, "sqlite3")
    message = refusal(bag, arm.robot)
    assert message.startswith(f"{bag}: [signals]: a rosbag2 bag's topics are mapped onto the signals by an experiment")
    assert "/joint_states (sensor_msgs/msg/JointState, 1001 messages)" in message


def test_without_the_readers_the_error_names_the_install(monkeypatch, arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path)
    spec = experiment(tmp_path, bag)
    for module in ("mcap", "mcap.reader", "mcap.exceptions"):
        monkeypatch.setitem(sys.modules, module, None)
    assert refusal(spec, arm.robot) == (f"{bag}: file: reading MCAP files needs the packages mcap and rosbags, which "
                                        "are not installed (install them: pip install 'symbolic[bags]')")


def test_progress_while_reading(arm, tmp_path: Path, monkeypatch, caplog) -> None:
    bag = small_arm_bag(arm, tmp_path)
    monkeypatch.setattr(bags, "PROGRESS_EVERY", 0.0)
    with caplog.at_level("INFO", logger="symbolic"):
        load(experiment(tmp_path, bag), model=arm.robot)
    lines = [r.getMessage() for r in caplog.records]
    assert any(line.startswith("arm.mcap: read 512 of 1502 messages (34 %), ") for line in lines), lines
    assert any(line.endswith("time base: the stamps of /joint_states, 1001 samples at 1000 Hz, t = 0 at "
                             "1700000000.000000000 s of the bag's clock") for line in lines), lines


def test_a_validation_bag_is_mapped_by_the_experiment(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    second = small_arm_bag(arm, other, "sqlite3")
    loaded = load(bag, model=arm.robot, validation=second, experiment=experiment(tmp_path, bag))
    assert loaded.validation.alignment.file == str(second.resolve())
    np.testing.assert_array_equal(loaded.validation.q, loaded.q)


def test_a_campaign_reads_bags_and_bag_folders(arm, tmp_path: Path, capsys) -> None:
    """Logs that are MCAP files and rosbag2 folders, mapped by the robot's experiment; results kept by content."""
    from symbolic import cli

    logs = tmp_path / "logs"
    logs.mkdir()
    t, q, tau, ref = arm_log(arm, 2.0)
    for k, kind in enumerate(("mcap", "sqlite3", "rosbag2-mcap")):
        bw.write(kind, logs / f"arm_2024-03-0{k + 1}", arm_topics(t, q, tau * (1 + 0.01 * k), ref))
    (tmp_path / "arm.toml").write_text(models.arm())
    experiment(tmp_path, logs / "arm_2024-03-01.mcap", ARM_SIGNALS, "map.experiment.toml")
    campaign = tmp_path / "fleet.toml"
    campaign.write_text('name = "bags"\n[task]\nkind = "identify"\n[[robot]]\nid = "r01"\nmodel = "arm.toml"\n'
                        'logs = "logs/arm_*"\nexperiment = "map.experiment.toml"\n'
                        'time = { from = "name", pattern = "_(\\\\d{4}-\\\\d{2}-\\\\d{2})", format = "%Y-%m-%d" }\n')
    out = tmp_path / "out"
    assert cli.main(["-q", "campaign", str(campaign), "--out", str(out), "--workers", "0"]) == 0, capsys.readouterr()
    import csv

    rows = list(csv.DictReader((out / "results.csv").open()))
    assert [(r["log"], r["status"]) for r in rows] == [
        ("logs/arm_2024-03-01.mcap", "ok"), ("logs/arm_2024-03-02", "ok"), ("logs/arm_2024-03-03", "ok")]
    fv = [float(r["value:Fv1"]) for r in rows]  # the forces 1 % and 2 % larger: every coefficient with them
    assert fv[1] == pytest.approx(1.01 * fv[0], rel=1e-9) and fv[2] == pytest.approx(1.02 * fv[0], rel=1e-9)
    import json
    import shutil

    def run() -> dict:
        capsys.readouterr()
        assert cli.main(["-q", "campaign", str(campaign), "--out", str(out), "--workers", "0", "--json"]) == 0
        return json.loads(capsys.readouterr().out)

    again = run()
    assert (again["computed"], again["cached"]) == (0, 3)  # a folder's results are kept by its files' bytes
    shutil.rmtree(logs / "arm_2024-03-02")
    bw.write("sqlite3", logs / "arm_2024-03-02", arm_topics(t, q, tau * 1.05, ref))
    changed = run()
    assert (changed["computed"], changed["cached"]) == (1, 2)


def test_excite_compares_with_a_bag(arm, tmp_path: Path, capsys) -> None:
    """``excite --compare`` reads an existing log as identify does: here a bag through its experiment."""
    from symbolic import cli

    bag = small_arm_bag(arm, tmp_path, seconds=2.0)
    spec = experiment(tmp_path, bag, ARM_SIGNALS + "[identification]\nbandwidth = 4.0\n")
    (tmp_path / "arm.toml").write_text(models.arm())
    code = cli.main(["-q", "excite", str(tmp_path / "arm.toml"), "--duration", "2", "--harmonics", "2", "--starts",
                     "1", "--out", str(tmp_path / "design"), "--compare", str(spec), "--no-figures", "--json",
                     "--rate", "1000", "--position=-1:1", "--velocity", "3", "--acceleration", "30", "--torque", "60",
                     "--force-noise", "0.01"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    import json

    compared = json.loads(captured.out)["compare"]
    assert compared["duration"] == pytest.approx(2.0) and compared["samples"] > 1000  # kept after the borders
    assert all(math.isfinite(p["sigma"]) for p in compared["parameters"].values()), compared


def symbolic_command(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "symbolic", *args], capture_output=True, text=True, cwd=cwd,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})


def test_simulate_reports_the_alignment_on_stderr_quiet_with_q(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path, seconds=2.0)
    experiment(tmp_path, bag)
    (tmp_path / "arm.toml").write_text(models.arm())
    loud = symbolic_command("simulate", "arm.toml", "run.experiment.toml", "--json", cwd=tmp_path)
    quiet = symbolic_command("-q", "simulate", "arm.toml", "run.experiment.toml", "--json", cwd=tmp_path)
    assert loud.returncode == 0 and quiet.returncode == 0, loud.stderr + quiet.stderr
    assert f"symbolic: {bag}: time base: the stamps of /joint_states, 2001 samples at 1000 Hz" in loud.stderr
    assert f"symbolic: {bag}: /arm/command (std_msgs/msg/Float64MultiArray): 1001 messages at 500 Hz (log time), " \
           "hold; no gap; dropped none" in loud.stderr
    assert quiet.stderr == ""
    import json

    assert json.loads(quiet.stdout)["relative_error"] == json.loads(loud.stdout)["relative_error"]


def test_diagnose_reads_a_bag(arm, tmp_path: Path, capsys) -> None:
    from symbolic import cli

    bag = small_arm_bag(arm, tmp_path, "sqlite3", seconds=2.0)
    spec = experiment(tmp_path, bag)
    (tmp_path / "arm.toml").write_text(models.arm())
    assert cli.main(["-q", "diagnose", str(tmp_path / "arm.toml"), str(spec), "--out", str(tmp_path / "d")]) == 0, \
        capsys.readouterr().err
    assert "no significant missing effect" in capsys.readouterr().out
    assert (tmp_path / "d" / "report.md").is_file()


def test_message_time_header_stamp_else_log_time(arm, tmp_path: Path) -> None:
    """Header stamps when set; a topic whose stamps are unset (0) and ``stamp = "log"`` take the log time."""
    t, q, tau, ref = arm_log(arm, 0.5)
    topics = arm_topics(t, q, tau, ref)
    stamped = load(experiment(tmp_path, bw.write("mcap", tmp_path / "a", topics)), model=arm.robot)
    logged = load(experiment(tmp_path, bw.write("mcap", tmp_path / "b", topics), ARM_SIGNALS + '[alignment]\n'
                             'stamp = "log"\n', "b.toml"), model=arm.robot)
    for _, fields in topics[0].messages:
        fields["header"] = {"stamp": 0}
    unset = load(experiment(tmp_path, bw.write("mcap", tmp_path / "c", topics), name="c.toml"), model=arm.robot)
    assert [r.stamps for r in stamped.alignment.topics if r.topic == "/joint_states"] == ["header"]
    for loaded in (logged, unset):
        assert [r.stamps for r in loaded.alignment.topics if r.topic == "/joint_states"] == ["log"]
        assert loaded.alignment.start_ns == EPOCH + 300_000  # the joint states logged 0.3 ms after their instants
        np.testing.assert_array_equal(loaded.q, stamped.q)  # the same instants, 0.3 ms later on the bag's clock


def test_an_mcap_file_is_streamed_chunk_by_chunk(arm, tmp_path: Path, monkeypatch) -> None:
    """A bag larger than memory is never read whole: when a message is handed over, the MCAP reader has
    decompressed only the chunks up to it (here 4 KiB chunks: 42 of them)."""
    bw.need("mcap", "mcap_ros2", "rosbags")
    import mcap.stream_reader

    t, q, tau, ref = arm_log(arm, 1.0)
    bag = bw.write_mcap(tmp_path / "arm.mcap", arm_topics(t, q, tau, ref), chunk_size=4096)
    chunks = []
    original = mcap.stream_reader.breakup_chunk
    monkeypatch.setattr(mcap.stream_reader, "breakup_chunk", lambda *a, **k: chunks.append(1) or original(*a, **k))
    reader = bags.open_bag(bag)
    try:
        seen = [len(chunks) for _ in reader.messages(list(reader.topics))]
    finally:
        reader.close()
    assert len(seen) == 1502 and seen[-1] > 30
    assert seen[0] <= 2 and all(s <= 2 + k * seen[-1] // len(seen) + 2 for k, s in enumerate(seen))


def test_refusals_of_the_experiment_keys(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path, seconds=0.2)
    for extra, where, expected in (
        ("rate = 1000.0\n", "rate", "is a bag, whose messages carry their time: give the time base's rate as "
                                    "[alignment] rate"),
        ('columns = ["a"]\n', "columns", "is a bag, whose topics [signals] maps (leave out columns)"),
        ("[alignment]\nrat = 1000.0\n", "[alignment] rat", "unknown key (allowed: rate, clock, stamp, max_gap, method); "
                                                           "did you mean 'rate'?"),
        ("[alignment]\nrate = -1.0\n", "[alignment] rate", "expected the time base's rate in Hz"),
        ('[alignment]\nmethod = { ref_q3 = "hold" }\n', "[alignment] method ref_q3", "no such signal in [signals]"),
        ('[alignment]\nmethod = { ref_q1 = "cubic" }\n', "[alignment] method ref_q1", 'expected "linear"'),
        ('[alignment]\nstamp = "publish"\n', "[alignment] stamp", "expected one of 'header', 'log'"),
        ('[alignment]\nclock = "/clock"\n', "[alignment] clock", "no topic '/clock' in arm.mcap"),
        ('[alignment]\nclock = "/joint_states"\nrate = 100.0\n', "[alignment] clock", "not both"),
    ):
        body = ARM_SIGNALS + extra if extra.startswith("[") else extra + ARM_SIGNALS
        spec = experiment(tmp_path, bag, body)
        message = refusal(spec, arm.robot)
        assert message.startswith(f"{spec}: {where}: ") and expected in message, message
    spec = experiment(tmp_path, bag, ARM_SIGNALS.replace("[signals]", "[signals]\nt = \"/joint_states.header.stamp.sec\""))
    assert "[signals] t: a bag's time is its messages'" in refusal(spec, arm.robot)
    t, q, tau, ref = arm_log(arm, 0.2)
    csv = canonical_csv(tmp_path / "arm.csv", t, ("q1", "q2"), q, tau, q)
    spec = experiment(tmp_path, csv, "[alignment]\nrate = 1000.0\n")
    assert refusal(spec, arm.robot) == (f"{spec}: [alignment]: aligns the topics of a bag (.mcap, .db3, a rosbag2 "
                                        "folder); arm.csv is a data file with one time: leave it out")


def test_a_clock_that_jitters_needs_a_rate_or_resample(arm, tmp_path: Path) -> None:
    t, q, tau, ref = arm_log(arm, 0.5)
    topics = arm_topics(t, q, tau, ref)
    jitter = np.random.default_rng(1).integers(-5_000, 5_000, len(t))  # ±5 µs: 0.5 % of the step
    for (_, fields), dt in zip(topics[0].messages, jitter):
        fields["header"] = {"stamp": fields["header"]["stamp"] + int(dt)}
    bag = bw.write("mcap", tmp_path / "arm", topics)
    message = refusal(experiment(tmp_path, bag), arm.robot)
    assert "[alignment]: the stamps of /joint_states, the time base, vary from" in message
    assert "give [alignment] rate = <Hz> (a uniform grid) or resample = true" in message
    on_grid = load(experiment(tmp_path, bag, ARM_SIGNALS + "[alignment]\nrate = 1000.0\n"), model=arm.robot)
    assert on_grid.alignment.base == "a uniform grid at [alignment] rate = 1000 Hz"
    assert np.allclose(np.diff(on_grid.t), 1e-3, rtol=0, atol=1e-12)
    resampled = load(experiment(tmp_path, bag, "resample = true\n" + ARM_SIGNALS), model=arm.robot)
    assert resampled.alignment.base == "a uniform grid over the stamps of /joint_states (resample = true)"
    assert np.abs(on_grid.q - q[:len(on_grid.t)]).max() < 1e-4  # within the jitter (µs) times the velocity


def test_the_reference_scanner_on_arbitrary_text() -> None:
    """Whatever a [signals] text holds, the scanner gives a rewritten text or one DataError; valid references
    joined by operators come back as variables, each reference read as written."""
    from hypothesis import given, settings, strategies as st

    alphabet = st.sampled_from(list("/._[]()*+-' \"0123456789abcxyz_") + ["/joint_states", ".position", "[q1]", "**"])

    @settings(max_examples=300, deadline=None)
    @given(st.lists(alphabet, max_size=30).map("".join))
    def anything(text: str) -> None:
        try:
            rewritten, requests = bags.rewrite({"q_a": text}, {}, "run.toml")
        except DataError as error:
            assert "\n" not in str(error) and str(error).startswith("run.toml: [signals] q_a: ")
            return
        assert all(r.reference.text in text for r in requests)

    anything()
    names = st.from_regex(r"[a-z_][a-z0-9_]{0,6}", fullmatch=True)
    reference = st.builds(lambda topic, field, index: f"/{topic}.{field}" + ("" if index is None else f"[{index}]"),
                          names, names, st.one_of(st.none(), st.integers(0, 99), names))

    @settings(max_examples=200, deadline=None)
    @given(st.lists(reference, min_size=1, max_size=4), st.lists(st.sampled_from([" + ", "*", " / ", "-", "**"]),
                                                                 min_size=3, max_size=3))
    def joined(references: list[str], operators: list[str]) -> None:
        text = references[0] + "".join(op + ref for op, ref in zip(operators, references[1:]))
        rewritten, requests = bags.rewrite({"q_a": text}, {}, "run.toml")
        assert [r.reference.text for r in requests] == list(dict.fromkeys(references))
        assert "/" not in rewritten["q_a"].replace(" / ", "")

    joined()


def test_a_rate_far_above_the_topics_is_refused(arm, tmp_path: Path) -> None:
    bag = small_arm_bag(arm, tmp_path, seconds=0.2)
    message = refusal(experiment(tmp_path, bag, ARM_SIGNALS + "[alignment]\nrate = 1e9\n"), arm.robot)
    assert "[alignment] rate: 1e+09 Hz over the 0.2 s the topics share makes 200000001 samples, more than 10 times " \
           "the 201 messages of the busiest topic" in message


URDF = '''<?xml version="1.0"?>
<robot name="two">
 <link name="base_link"/>
 <link name="upper"><inertial><origin xyz="0.2 0 0"/><mass value="2"/>
   <inertia ixx="0.01" iyy="0.05" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <link name="fore"><inertial><origin xyz="0.15 0 0"/><mass value="1"/>
   <inertia ixx="0.005" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <joint name="shoulder_pan_joint" type="revolute"><parent link="base_link"/><child link="upper"/>
   <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="3"/></joint>
 <joint name="elbow_joint" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="0.4 0 0"/>
   <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="3"/></joint>
</robot>
'''


def test_urdf_joint_names_map_unchanged(arm, tmp_path: Path) -> None:
    """A URDF model's coordinates are its joints' names, which a JointState names too: q_<joint> =
    "/joint_states.position[<joint>]", whatever the order of the names in the messages."""
    (tmp_path / "two.urdf").write_text(URDF)
    robot = symbolic.load(tmp_path / "two.urdf")
    assert robot.generalized_coordinates == ("shoulder_pan_joint", "elbow_joint")
    t, q, tau, ref = arm_log(arm, 0.5)
    stamps = EPOCH + np.round(t * 1e9).astype(np.int64)
    topic = bw.joint_states(stamps, ["elbow_joint", "shoulder_pan_joint"], q[:, ::-1], tau[:, ::-1])
    for k, (_, fields) in enumerate(topic.messages):  # a publisher that reorders its joints now and then
        if k % 7 == 0:
            fields.update(name=["shoulder_pan_joint", "elbow_joint"], position=q[k], effort=tau[k])
    bag = bw.write("sqlite3", tmp_path / "run", [topic])
    body = "[signals]\n" + "".join(f'q_{c} = "/joint_states.position[{c}]"\ntau_{c} = "/joint_states.effort[{c}]"\n'
                                   for c in robot.generalized_coordinates)
    loaded = load(experiment(tmp_path, bag, body), robot.generalized_coordinates, model=robot)
    np.testing.assert_array_equal(loaded.q, q)
    np.testing.assert_array_equal(loaded.tau, tau)


def test_an_mcap_channel_that_is_not_ros2_cdr_is_named(arm, tmp_path: Path) -> None:
    bw.need("mcap", "rosbags")
    from mcap.writer import Writer

    path = tmp_path / "json.mcap"
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start(profile="", library="test")
        schema = writer.register_schema("Position", "jsonschema", b'{"type": "object"}')
        channel = writer.register_channel("/joint_states", "json", schema)
        for k in range(10):
            writer.add_message(channel, k * 1_000_000, f'{{"position": [{k}]}}'.encode(), k * 1_000_000)
        writer.finish()
    spec = experiment(tmp_path, path, ARM_SIGNALS)
    assert refusal(spec, arm.robot) == (f"{spec}: [signals] q_q1: topic /joint_states (Position) cannot be read: its "
                                        "messages are encoded as 'json' (allowed: ROS 2 messages, CDR-encoded, with a "
                                        "ros2msg or ros2idl schema)")


def test_a_gap_in_the_commands_is_held_and_reported(arm, tmp_path: Path) -> None:
    t, q, tau, ref = arm_log(arm, 1.0)
    topics = arm_topics(t, q, tau, ref)
    del topics[1].messages[100:110]  # 10 commands (20 ms at 500 Hz) lost
    bag = bw.write("mcap", tmp_path / "arm", topics)
    with pytest.warns(symbolic.ModelWarning, match=r"/arm/command: 1 gap\(s\) in the messages, 10 message\(s\) missing "
                                                   r"at 500 Hz; the longest 22 ms at t = 0.198 s, bridged by holding "
                                                   r"the last message"):
        loaded = load(experiment(tmp_path, bag), model=arm.robot)
    assert loaded.alignment.base == "the stamps of /joint_states"  # the clock has no gap
    np.testing.assert_array_equal(loaded.ref[198:220, 0], np.full(22, ref[99, 0]))  # held across the gap
    assert loaded.ref[220, 0] == ref[110, 0]
