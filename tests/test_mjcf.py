"""MJCF export (symbolic/export/mjcf.py) checked by MuJoCo itself, no mocks.

The written file is loaded with ``mujoco.MjModel.from_xml_path``; at random states MuJoCo's inverse dynamics
(``mj_inverse``: qfrc_inverse) and bias (``qfrc_bias``) are compared with symbolic's numeric model (the rigid part
D(q)·q̈ + C·q̇ + g, friction taken out of ours and MuJoCo's constraints — contacts, limits, friction loss — and
passive forces switched off), then armature, damping and friction loss each on its own, the round trip URDF →
model → MJCF against Pinocchio's model of the same URDF, the identified EMPS axis replayed open loop in MuJoCo
against symbolic's own simulation, and the refusals.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import symbolic
from symbolic.description.robot import Drive, Friction
from symbolic.export.mjcf import mjcf
from symbolic.numeric import numeric_model
from shared_data import emps  # noqa: F401  (fixture)

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is not installed (pip install -e '.[dev]' brings it)")

TOLERANCE = 1e-9
"""Relative: ‖τ_MuJoCo − τ_symbolic‖∞ / max(‖τ_symbolic‖∞, ‖bias_symbolic‖∞) at each state, for τ and the bias."""

PUMA_PHYSICAL = {"m1": 1.0, "Ixx1": 0.35, "Izz1": 0.35, "Izz3": 0.025}
"""Corke's PUMA 560 inertias of links 1 (mass 0, diag(0, 0.35, 0)) and 3 break A + B ≥ C, which MuJoCo refuses:
the kinematics (standard DH) is checked with these physical values instead."""

URDF_ARMS = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", None),
    "panda_urdf": ("panda_description/urdf/panda.urdf", "panda_link7"),  # the fingers' <mimic> is a constraint
    "kinova": ("kinova_description/robots/kinova.urdf", None),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", None),
    "z1": ("z1_description/urdf/z1.urdf", None),
    "so101": ("so_arm_description/urdf/so101.urdf", None),
}


def quiet(function, *args, **kwargs):
    """``function(*args)`` with symbolic's ModelWarnings (Corke's inertias, what MJCF leaves out) silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return function(*args, **kwargs)


def load(robot: symbolic.Robot, folder: Path, values=None):
    """The robot written as MJCF into ``folder`` and read back by MuJoCo's own loader."""
    path = folder / f"{robot.name}.xml"
    path.write_text(quiet(mjcf, robot, values))
    return mujoco.MjModel.from_xml_path(str(path))


def dof_index(m, coordinates) -> np.ndarray:
    """MuJoCo's dof address of each coordinate (joints are named after the coordinates)."""
    return np.array([m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, c)] for c in coordinates])


def rigid_only(m) -> None:
    """Switch off what is not the rigid dynamics: constraints (contacts, limits, friction loss) and passive forces."""
    m.opt.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONSTRAINT | mujoco.mjtDisableBit.mjDSBL_DAMPER
                           | mujoco.mjtDisableBit.mjDSBL_SPRING)


def mujoco_dynamics(m, index, q, qd, qdd) -> tuple[np.ndarray, np.ndarray]:
    """(qfrc_inverse, qfrc_bias) in the coordinates' order."""
    d = mujoco.MjData(m)
    d.qpos[index], d.qvel[index], d.qacc[index] = q, qd, qdd
    mujoco.mj_inverse(m, d)
    return d.qfrc_inverse[index].copy(), d.qfrc_bias[index].copy()


def worst_relative_error(robot: symbolic.Robot, m, values=None, states: int = 5, seed: int = 11) -> float:
    """max over random states of the relative differences of τ and of the bias, MuJoCo against symbolic."""
    num = numeric_model(symbolic.derive(robot))
    p = num.parameters.updated(values or {}).array()
    rigid_only(m)
    index = dof_index(m, robot.coordinates)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(states):
        q, qd, qdd = rng.uniform(-1.5, 1.5, (3, len(robot.coordinates)))
        friction = num.friction(q, qd, p)
        tau, bias = num.inverse_dynamics(q, qd, qdd, p) - friction, num.bias(q, qd, p) - friction
        tau_mj, bias_mj = mujoco_dynamics(m, index, q, qd, qdd)
        scale = max(np.abs(tau).max(), np.abs(bias).max())  # EMPS's bias is 0: gravity is across its axis
        worst = max(worst, np.abs(tau_mj - tau).max() / scale, np.abs(bias_mj - bias).max() / scale)
    return worst


def robots_folder() -> Path:
    from test_urdf import robots_folder as folder

    return folder()


# -- rigid dynamics against symbolic's ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["panda", "puma560", "emps"])
def test_built_in_robot_agrees_with_mujoco(tmp_path: Path, name: str) -> None:
    robot = quiet(symbolic.robots.load, name)
    values = PUMA_PHYSICAL if name == "puma560" else None
    if values:  # Corke's own values are refused before MuJoCo would refuse them
        with pytest.raises(symbolic.SymbolicError, match=r"\[\[body\]\] on frame '1': cannot be written as MJCF: "
                                                          r"principal inertias 0 0 0.35 break A \+ B >= C"):
            mjcf(robot)
    assert worst_relative_error(robot, load(robot, tmp_path, values), values) < TOLERANCE


SLOW_ARMS = ("kinova", "so101", "xarm7")
"""Derived in 3–6 s each on a cold cache: marked slow so that this file stays under 30 s of one core."""


@pytest.mark.parametrize("arm", [pytest.param(a, marks=pytest.mark.slow) if a in SLOW_ARMS else a for a in sorted(URDF_ARMS)])
def test_urdf_arm_agrees_with_mujoco(tmp_path: Path, arm: str) -> None:
    path, tip = URDF_ARMS[arm]
    robot = quiet(symbolic.load, robots_folder() / path, tip=tip)
    assert worst_relative_error(robot, load(robot, tmp_path)) < TOLERANCE


# -- drives and friction --------------------------------------------------------------------------------------------
def with_drives_and_friction(robot: symbolic.Robot) -> symbolic.Robot:
    """``robot`` with a drive (ratio, rotor inertia) and viscous and Coulomb friction on every coordinate."""
    n = len(robot.coordinates)
    drives = tuple(Drive(c, ratio=50.0 + 10 * i, rotor_inertia=1e-4 * (i + 1)) for i, c in enumerate(robot.coordinates))
    frictions = tuple(Friction(c, viscous=0.5 + 0.1 * i, coulomb=2.0 - 0.2 * i) for i, c in enumerate(robot.coordinates))
    assert n == len(drives)
    return symbolic.validate(dataclasses.replace(robot, drives=drives, frictions=frictions, validated=False))


def test_armature_damping_frictionloss_and_gear(tmp_path: Path) -> None:
    """Armature = Ia·ratio² adds to D's diagonal (MuJoCo's M equals symbolic's D, rotors included); damping gives
    the passive force −Fv·q̇; frictionloss holds Fc; each motor's gear is the drive's ratio. The rigid τ still
    agrees with the rotors inside both."""
    robot = with_drives_and_friction(quiet(symbolic.robots.load, "panda"))
    m = load(robot, tmp_path)
    ratios = np.array([50.0 + 10 * i for i in range(7)])
    index = dof_index(m, robot.coordinates)
    # Ia·ratio² computed exactly and rounded once: within an ulp of the product in doubles
    assert np.allclose(m.dof_armature[index], 1e-4 * np.arange(1, 8) * ratios**2, rtol=1e-15, atol=0)
    assert np.array_equal(m.dof_damping[index], 0.5 + 0.1 * np.arange(7))
    assert np.array_equal(m.dof_frictionloss[index], 2.0 - 0.2 * np.arange(7))
    assert np.array_equal(m.actuator_gear[:, 0], ratios)
    num = numeric_model(symbolic.derive(robot))
    rng = np.random.default_rng(5)
    q, qd = rng.uniform(-1.5, 1.5, (2, 7))
    d = mujoco.MjData(m)
    d.qpos[index], d.qvel[index] = q, qd
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    D = num.inertia(q)
    assert np.abs(M[np.ix_(index, index)] - D).max() < TOLERANCE * np.abs(D).max()
    assert np.abs(d.qfrc_passive[index] + (0.5 + 0.1 * np.arange(7)) * qd).max() < 1e-14
    assert worst_relative_error(robot, m) < TOLERANCE


def test_direction_dependent_friction_is_the_mean_and_offset_left_out_with_warnings(tmp_path: Path) -> None:
    from symbolic.description.robot import Directional

    axis = quiet(symbolic.robots.load, "emps")
    robot = symbolic.validate(dataclasses.replace(axis, frictions=(
        Friction("q", viscous=Directional(100.0, 300.0), coulomb="Fc", offset="offset"),), validated=False))
    with pytest.warns(symbolic.ModelWarning) as notes:
        text = mjcf(robot)
    messages = sorted(str(n.message) for n in notes)
    assert len(messages) == 2 and "direction-dependent damping" in messages[0] and "offset" in messages[1], messages
    assert 'damping="200.0"' in text and "<!-- not in this file: [[friction]] 'q': the offset" in text


# -- URDF → model → MJCF against Pinocchio's model of the URDF -------------------------------------------------------
@pytest.mark.parametrize("arm", ["ur5", "z1"])
def test_mjcf_of_a_urdf_agrees_with_pinocchio(tmp_path: Path, arm: str) -> None:
    from reference_pinocchio import UrdfReference

    path = robots_folder() / URDF_ARMS[arm][0]
    robot = quiet(symbolic.load, path)
    m = load(robot, tmp_path)
    rigid_only(m)
    reference = UrdfReference(path, robot.coordinates)
    index = dof_index(m, robot.coordinates)
    rng = np.random.default_rng(23)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-1.5, 1.5, (3, len(robot.coordinates)))
        tau = reference.rnea(q, qd, qdd)
        tau_mj, bias_mj = mujoco_dynamics(m, index, q, qd, qdd)
        assert np.abs(tau_mj - tau).max() < TOLERANCE * np.abs(tau).max()
        bias = reference.rnea(q, qd, np.zeros_like(q))
        assert np.abs(bias_mj - bias).max() < TOLERANCE * np.abs(bias).max()


# -- refusals, the command line, determinism ------------------------------------------------------------------------
def stribeck_emps(folder: Path) -> Path:
    """EMPS's model file with a Stribeck rise of its Coulomb level (Fs = 30 N, vs = 0.01 m/s)."""
    text = (Path(symbolic.robots.__file__).parent / "emps.toml").read_text()
    text = text.replace('offset = "offset"', 'offset = "offset"\nstribeck = { static = "30", velocity = "0.01" }')
    path = folder / "emps_stribeck.toml"
    path.write_text(text)
    return path


REFUSED = {
    "flexible": ("single_flexible_link", "[[beam]] 'link': cannot be written as MJCF: flexible links"),
    "closed loop": ("janot_branch", "[[constraint]] 'q3': cannot be written as MJCF: closed loops"),
    "several coordinates": ("omni", "cannot be written as MJCF"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_cli_refuses_what_mjcf_cannot_hold_in_one_line_and_writes_nothing(tmp_path: Path, case: str, capsys) -> None:
    from symbolic.cli import main

    name, message = REFUSED[case]
    out = tmp_path / "robot.xml"
    assert main(["-q", "export-mjcf", name, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and f"{name}.toml: " in err and message in err, err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_stribeck_friction_is_refused_in_one_line_and_nothing_written(tmp_path: Path, capsys) -> None:
    from symbolic.cli import main

    model = stribeck_emps(tmp_path)
    out = tmp_path / "emps.xml"
    assert main(["-q", "export-mjcf", str(model), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == (f"error: {model}: [[friction]] 'q' stribeck: cannot be written as MJCF: MuJoCo's frictionloss is "
                   "one level; a Coulomb level rising to a static one at rest (Stribeck) has no MJCF form\n"), err
    assert not out.exists()


def test_cli_writes_the_same_bytes_in_any_process(tmp_path: Path) -> None:
    """export-mjcf in two processes with different hash seeds, and the library call: byte-identical."""
    texts = []
    for seed in ("0", "12345"):
        out = tmp_path / f"panda_{seed}.xml"
        environment = {**os.environ, "PYTHONHASHSEED": seed}
        subprocess.run([sys.executable, "-m", "symbolic", "-q", "export-mjcf", "panda", "--out", str(out)],
                       check=True, env=environment, capture_output=True)
        texts.append(out.read_bytes())
    assert texts[0] == texts[1] == mjcf(symbolic.robots.load("panda")).encode()
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "panda_0.xml")).nu == 7


def test_values_are_checked_by_name_and_finiteness() -> None:
    panda = symbolic.robots.load("panda")
    with pytest.raises(symbolic.SymbolicError, match=r"unknown parameter\(s\) \['mass_of_nothing'\]"):
        mjcf(panda, {"mass_of_nothing": 1.0})
    with pytest.raises(symbolic.SymbolicError, match="not finite: m1"):
        mjcf(panda, {"m1": float("nan")})
    assert '<inertial pos="0.003875 0.002081 -0.04762" mass="2.5"' in mjcf(panda, {"m1": 2.5})


def test_cli_refuses_an_out_that_is_not_an_xml_file(tmp_path: Path, capsys) -> None:
    from symbolic.cli import main

    assert main(["export-mjcf", "panda", "--out", str(tmp_path / "panda.urdf")]) == 2
    assert "name the MJCF file to write" in capsys.readouterr().err


# -- the identified EMPS axis simulated in MuJoCo --------------------------------------------------------------------
EMPS_WINDOW = (2.5, 3.5)
"""s: one second of the estimation log that holds a velocity reversal (at 3.11 s) and a near stop (2.65 s)."""

SUBSTEPS = 10
"""MuJoCo steps per log sample (timestep 0.1 ms, the logged force held over each 1 ms sample)."""


def mujoco_replay(path: Path, cut, offset: float, q0: float, qd0: float) -> tuple[np.ndarray, float]:
    """MuJoCo's velocity at the log's samples with the logged force replayed (the offset, which MJCF cannot hold,
    taken off the input: τ = M q̈ + Fv q̇ + Fc sign q̇ + offset), and the time its friction-loss force was below Fc."""
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.timestep = float(cut.t[1] - cut.t[0]) / SUBSTEPS
    d = mujoco.MjData(m)
    d.qpos[0], d.qvel[0] = q0, qd0
    velocity, unsaturated = [qd0], 0.0
    for k in range(len(cut.t) - 1):
        d.ctrl[0] = (cut.tau[k, 0] - offset) / m.actuator_gear[0, 0]
        for _ in range(SUBSTEPS):
            mujoco.mj_step(m, d)
            unsaturated += m.opt.timestep * (abs(d.qfrc_constraint[0]) < m.dof_frictionloss[0] * (1 - 1e-9))
        velocity.append(d.qvel[0])
    return np.array(velocity), unsaturated


def test_identified_emps_simulates_in_mujoco_with_its_friction(tmp_path: Path, emps, capsys) -> None:
    """``symbolic identify emps … --out emps.xml`` and 1 s of the logged force replayed open loop in MuJoCo and in
    symbolic's simulation (RK4, friction Fc·tanh(v/ε), ε = 1e-4 m/s).

    The two friction laws are ±Fc alike in sliding; they differ only while MuJoCo's friction loss, a soft
    constraint that drives q̇ towards 0 with solref's time constant (0.02 s), is not saturated at ±Fc (near a
    stop), or while |q̇| < 5ε in ours, or the two velocities have opposite signs. Viscous friction only contracts
    a velocity difference, so |Δq̇(t)| ≤ 2·Fc·T/M + δ, T the time spent in those phases, measured, and δ the
    integrators' difference, measured with Fc = 0 (7.8e-6 m/s: MuJoCo's Euler at 0.1 ms against RK4). Seen:
    Δq̇ up to 2.9e-3 m/s (2.3 % of the 0.125 m/s reached; Δq 1.2 mm) against a bound of 8.5e-3 m/s (T = 20 ms);
    a missing damping (ΔF = Fv·q̇ ≈ 25 N in sliding), friction loss (ΔF = Fc = 20 N in sliding) or offset (a
    steady Δq̇ = offset/Fv = 1.6e-2 m/s) breaks the bound within the second."""
    import json

    from symbolic.cli import main
    from symbolic.simulation import simulate

    experiment = Path(symbolic.robots.__file__).parent / "emps_estimation.experiment.toml"
    out = tmp_path / "emps.xml"
    from symbolic.errors import ModelWarning

    with pytest.warns(ModelWarning, match="the offset"):  # MJCF joints hold no constant force: said, left out
        assert main(["-q", "identify", "emps", str(experiment), "--out", str(out), "--json"]) == 0
    values = {k: v["value"] for k, v in json.loads(capsys.readouterr().out)["parameters"].items()}
    text = out.read_text()
    assert f'mass="{values["M"]!r}"' in text and f'damping="{values["Fv"]!r}" frictionloss="{values["Fc"]!r}"' in text
    model = symbolic.derive(quiet(symbolic.robots.load, "emps"))
    log = symbolic.data.load(experiment, model=model.robot)
    start = int(np.searchsorted(log.t, EMPS_WINDOW[0]))
    cut = log.slice(start, start + int(round((EMPS_WINDOW[1] - EMPS_WINDOW[0]) / log.sample_period)) + 1)
    gaps = {}
    for name, fc in (("friction", values["Fc"]), ("no Coulomb friction", 0.0)):
        ours = simulate(model, cut, controller={"kind": "torque"}, parameters={**values, "Fc": fc}).simulated
        v = ours.qd[:, 0]
        path = tmp_path / f"emps_{fc}.xml"
        path.write_text(quiet(mjcf, model.robot, {**values, "Fc": fc}))
        v_mujoco, unsaturated = mujoco_replay(path, cut, values["offset"], ours.q[0, 0], v[0])
        ours_smooth = np.abs(v) < 5 * 1e-4
        opposite = np.sign(v) != np.sign(v_mujoco)
        T = unsaturated + float(np.sum(ours_smooth | opposite)) * log.sample_period
        gaps[name] = (np.abs(v_mujoco - v).max(), T, np.abs(v).max())
    integration = gaps["no Coulomb friction"][0]
    assert integration < 2e-5, gaps
    gap, T, _ = gaps["friction"]
    bound = 2 * values["Fc"] * T / values["M"] + integration
    assert gap <= bound and T < 0.05, (gap, bound, gaps)
    assert 100 * integration < gap  # the friction laws' difference, not the integrators', is what is bounded


def test_general_frames_limits_and_a_welded_frame_agree_with_mujoco(tmp_path: Path) -> None:
    """URDF-style frames of every type (revolute with limits, continuous about −y, prismatic on a turned origin,
    a fixed frame between, an oblique axis): the rigid dynamics agree and the limits are MuJoCo's ranges."""
    from models import general_frames

    robot = quiet(symbolic.loads, general_frames(), "general.toml")
    m = load(robot, tmp_path)
    q1 = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "q1")
    assert m.jnt_limited[q1] and list(m.jnt_range[q1]) == [-3.0, 3.0]
    assert not m.jnt_limited[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "q2")]  # continuous
    assert worst_relative_error(robot, m) < TOLERANCE


def test_applied_forces_are_left_out_with_a_warning_naming_the_time_varying_one() -> None:
    from symbolic.description.robot import Force

    axis = quiet(symbolic.robots.load, "emps")
    robot = symbolic.validate(dataclasses.replace(axis, frictions=(), validated=False, forces=(
        Force("spring", "q", "-1000*q"), Force("mains", "q", "2*sin(2*pi*50*t)"))))
    with pytest.warns(symbolic.ModelWarning) as notes:
        text = mjcf(robot)
    messages = [str(n.message) for n in notes]
    assert sorted(m.split("leaves out ")[1] for m in messages) == [
        "[[force]] 'mains': a time-varying applied force (MJCF has no such term)",
        "[[force]] 'spring': an applied force (MJCF has no such term)"], messages
    assert text.count("<!-- not in this file: [[force]]") == 2


def test_quaternion_is_mujocos_for_any_rotation() -> None:
    """Shepperd's quaternion against MuJoCo's mju_mat2Quat, half-turns (where the trace is −1) included."""
    from scipy.spatial.transform import Rotation

    from symbolic.export.mjcf import quaternion

    turns = [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0]), np.eye(3)]
    for R in turns + list(Rotation.random(50, random_state=4).as_matrix()):
        expected = np.zeros(4)
        mujoco.mju_mat2Quat(expected, np.ascontiguousarray(R).reshape(-1))
        expected = -expected if expected[0] < 0 else expected
        q = quaternion(R)
        assert np.abs(q - expected).max() < 1e-15 or (q[0] == 0 and np.abs(q + expected).max() < 1e-15), (R, q, expected)


def test_limits_of_a_joint_variable_written_as_an_expression_bound_the_coordinate(tmp_path: Path) -> None:
    """``coordinate = "0.5 - q1"`` with limit [-3, 3] on the joint variable θ = 0.5 − q1: MuJoCo's qpos is q1,
    so its range is [0.5 − 3, 0.5 + 3] (it was [-3, 3], the limit of θ written as one of q1)."""
    from models import general_frames

    text = general_frames().replace('coordinate = "q1"', 'coordinate = "0.5 - q1"', 1)
    robot = quiet(symbolic.loads, text, "general.toml")
    m = load(robot, tmp_path)
    q1 = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "q1")
    assert m.jnt_limited[q1] and list(m.jnt_range[q1]) == [-2.5, 3.5]
    assert worst_relative_error(robot, m) < TOLERANCE


def test_an_unvalidated_robot_is_validated_before_its_text_is_read() -> None:
    """A Robot built in Python with a string the safe parser refuses (a call): mjcf validates it (ModelError
    naming the key) instead of handing the text to sympify, which would evaluate it."""
    panda = symbolic.robots.load("panda")
    frames = (dataclasses.replace(panda.frames[0], d="Symbol('x')"), *panda.frames[1:])
    robot = dataclasses.replace(panda, frames=frames, validated=False)
    with pytest.raises(symbolic.ModelError):
        mjcf(robot)
    assert mjcf(dataclasses.replace(panda, validated=False)) == mjcf(panda)
