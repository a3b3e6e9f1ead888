"""URDF import (symbolic/description/urdf.py) and general joint frames, against Pinocchio.

The references are independent: Pinocchio parses the same URDF itself (``buildModelFromUrdf``, mimic joints as
mimics) and computes crba, rnea, computeGeneralizedGravity and computeJointTorqueRegressor; symbolic derives
its own expressions. Real URDFs of fixed-base arms come from the ``example-robot-data`` package (BSD-3-Clause,
in the ``dev`` extra), read where it is installed; tests that need them skip, saying so, when it is absent.
Tolerance 1e-10 absolute at random states (the differences seen are ~1e-14: round-off of doubles).
"""

from __future__ import annotations

import importlib.metadata
import warnings
from pathlib import Path

import numpy as np
import pytest

import symbolic
from models import general_frames, general_frames_urdf
from reference_pinocchio import UrdfReference
from symbolic.derivation.regressor import frame_label, regressor
from symbolic.errors import ModelError
from symbolic.numeric import numeric_model
from symbolic.numeric.base_parameters import regressor_function, theta_values

TOLERANCE = 1e-10

ARMS = [
    "ur_description/urdf/ur5_robot.urdf",
    "panda_description/urdf/panda.urdf",  # fingers: a prismatic joint and its <mimic>
    "kinova_description/robots/kinova.urdf",
    "xarm_description/urdf/xarm7.urdf",  # angles rounded to 1.5708: kept as written
    "z1_description/urdf/z1.urdf",
    "so_arm_description/urdf/so101.urdf",  # rpy of 1e-15 and 1e-33 written for zero
]


def robots_folder() -> Path:
    """Where example-robot-data keeps its robots; skips the calling test when the package is absent."""
    try:
        distribution = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed (pip install -e '.[dev]' brings it): the real URDFs come from it")
    folder = Path(distribution.locate_file("cmeel.prefix/share/example-robot-data/robots"))
    if not folder.is_dir():
        pytest.skip(f"example-robot-data has no robots folder at {folder}")
    return folder


def compare(robot: symbolic.Robot, reference: UrdfReference, states: int = 4, seed: int = 3) -> None:
    """D, g, C·q̇ and the rigid τ (friction removed) of ``robot`` against ``reference`` at random states."""
    model = symbolic.derive(robot)
    num = numeric_model(model)
    rng = np.random.default_rng(seed)
    for _ in range(states):
        q, qd, qdd = rng.uniform(-1.5, 1.5, model.n), rng.uniform(-2, 2, model.n), rng.uniform(-3, 3, model.n)
        assert np.abs(num.inertia(q) - reference.inertia(q)).max() < TOLERANCE
        assert np.abs(num.gravity(q) - reference.gravity(q)).max() < TOLERANCE
        assert np.abs(num.coriolis(q, qd) - reference.coriolis_vector(q, qd)).max() < TOLERANCE
        rigid = num.inverse_dynamics(q, qd, qdd) - num.friction(q, qd)
        assert np.abs(rigid - reference.rnea(q, qd, qdd)).max() < TOLERANCE


PINOCCHIO_COLUMNS = {"M": 0, "MX": 1, "MY": 2, "MZ": 3, "XX": 4, "XY": 5, "YY": 6, "XZ": 7, "YZ": 8, "ZZ": 9}
"""Pinocchio's dynamic parameters of a body: m, m·c, then I about the joint origin as xx, xy, yy, xz, yz, zz."""


def compare_regressor(robot: symbolic.Robot, path: Path | None, states: int = 3, xml: str | None = None) -> None:
    """Every inertial column of symbolic's Y equals Pinocchio's column for the same frame and parameter.

    Pinocchio's regressor has no mimic joints: they are built as independent joints at rest there, and the
    columns of the frames a mimic joint or its leader moves (which differ by the mimic's Lᵀ) are left out.
    """
    reference = UrdfReference(path, robot.coordinates, xml=xml, mimic=False)
    coupled = {c.coordinate for c in robot.constraints} | {s.name for c in robot.constraints for s in c.expression.free_symbols}
    model = symbolic.derive(robot)
    reg = regressor(robot)
    Y = regressor_function(model, reg)
    joint_of = {f.name: str((f.theta if f.joint.type != "prismatic" else f.d)) for f in robot.frames
                if f.joint.type != "fixed"}
    names = list(reference.model.names)
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(states):
        q, qd, qdd = rng.uniform(-1.5, 1.5, model.n), rng.uniform(-2, 2, model.n), rng.uniform(-3, 3, model.n)
        ours, theirs = Y(q, qd, qdd, numeric_model(model).p0), reference.regressor(q, qd, qdd)
        for k, (name, kind) in enumerate(zip(reg.names, reg.kinds)):
            if kind != "inertial":
                continue
            match = [(p, f) for p in PINOCCHIO_COLUMNS for f in joint_of if name == p + frame_label(f)]
            if not match or joint_of[match[0][1]] in coupled:
                continue  # a fixed frame's columns (Pinocchio merges it into its joint) or a mimic's
            (prefix, frame), = match
            column = 10 * (names.index(joint_of[frame]) - 1) + PINOCCHIO_COLUMNS[prefix]
            assert np.abs(ours[:, k] - theirs[:, column]).max() < TOLERANCE, name
            checked += 1
    assert checked > 0
    p0 = numeric_model(model).p0
    tau = numeric_model(model).inverse_dynamics(q, qd, qdd)
    assert np.abs(Y(q, qd, qdd, p0) @ theta_values(model, reg, p0) - tau).max() < TOLERANCE


@pytest.mark.parametrize("arm", ARMS)
def test_real_arm_agrees_with_pinocchio(arm: str) -> None:
    path = robots_folder() / arm
    robot = symbolic.load(path)
    reference = UrdfReference(path, robot.coordinates)
    compare(robot, reference)
    compare_regressor(robot, path)


# -- general frames written by hand (models.general_frames), and the import of the same robot ------------


def test_general_frames_agree_with_pinocchio() -> None:
    """Any axis (±x, ±y, z, and (0, 0.6, 0.8)), prismatic, continuous, a fixed frame, rpy of all kinds."""
    robot = symbolic.loads(general_frames(), "general.toml")
    compare(robot, UrdfReference(None, robot.coordinates, xml=general_frames_urdf()))


@pytest.mark.parametrize("merge", [True, False])
def test_urdf_import_merged_or_kept_fixed_joints_agree_with_pinocchio(tmp_path: Path, merge: bool) -> None:
    path = tmp_path / "general.urdf"
    path.write_text(general_frames_urdf())
    from symbolic.description.urdf import load

    robot = load(path, merge_fixed=merge)
    assert len(robot.frames) == (4 if merge else 5)
    reference = UrdfReference(path, robot.coordinates)
    compare(robot, reference)
    compare_regressor(robot, path)


def test_urdf_parameters_friction_and_limits(tmp_path: Path) -> None:
    path = tmp_path / "general.urdf"
    path.write_text(general_frames_urdf())
    robot = symbolic.load(path)
    values = {p.name: p.value for p in robot.parameters}
    assert values["m_a"] == 1.3 and values["cz_a"] == 0.1 and values["xz_a"] == -0.002 and values["yz_a"] == 0.0015
    # the fixed joint's rotation Ry(π/2) carries link f's inertia into frame c's axes: xx <-> zz, com rotated too
    assert np.isclose(values["xx_f"], 0.0015, atol=1e-16) and np.isclose(values["zz_f"], 0.001, atol=1e-16)
    assert np.allclose([values["cx_f"], values["cy_f"], values["cz_f"]], [0.05 + 0.03, 0.02 + 0.02, -0.01], atol=1e-16)
    assert (values["fv_q2"], values["fc_q2"]) == (0.2, 0.1)
    friction = {f.coordinate: f for f in robot.frictions}
    assert set(friction) == {"q2"} and str(friction["q2"].viscous) == "fv_q2"
    limits = {f.name: f.joint.limits for f in robot.frames}
    assert limits["a"] == {"lower": -3.0, "upper": 3.0, "velocity": 2.0, "effort": 10.0} and limits["b"] == {}


def test_panda_urdf_and_dh_give_the_same_dynamics() -> None:
    """franka_description's URDF (link 7 as the tip: no hand) and the modified-DH Panda with the same values."""
    dh = symbolic.derive(symbolic.robots.load("panda"))
    robot = symbolic.load(robots_folder() / "panda_description/urdf/panda.urdf", tip="panda_link7")
    urdf = symbolic.derive(robot)
    a, b = numeric_model(dh), numeric_model(urdf)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, (3, 7))
        assert np.abs(a.inertia(q) - b.inertia(q)).max() < 1e-12
        assert np.abs(a.gravity(q) - b.gravity(q)).max() < 1e-12
        assert np.abs(a.coriolis(q, qd) - b.coriolis(q, qd)).max() < 1e-12
        assert np.abs(a.inverse_dynamics(q, qd, qdd) - (b.inverse_dynamics(q, qd, qdd) - b.friction(q, qd))).max() < 1e-12


CHAIN_URDF = '''<robot name="branch">
 <link name="world"/><link name="l1"><inertial><origin xyz="0.1 0 0"/><mass value="2"/><inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <link name="l2"><inertial><origin xyz="0 0.2 0"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <link name="side"><inertial><origin xyz="0 0 0.1"/><mass value="0.5"/><inertia ixx="0.002" iyy="0.002" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <link name="past"><inertial><origin xyz="0.1 0 0"/><mass value="3"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <joint name="j1" type="revolute"><parent link="world"/><child link="l1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
 <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.3 0 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
 <joint name="js" type="revolute"><parent link="l1"/><child link="side"/><origin xyz="0.1 0.1 0"/><axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
 <joint name="jp" type="revolute"><parent link="l2"/><child link="past"/><origin xyz="0 0.4 0"/><axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>'''


def test_tip_locks_branches_and_drops_what_lies_past_it(tmp_path: Path) -> None:
    """--tip l2: j1, j2 move; the side branch js is locked at 0 and carried; link 'past' is left out.

    Reference: Pinocchio's model of the file without link 'past', with js locked by buildReducedModel."""
    pin = pytest.importorskip("pinocchio", reason="the reference is Pinocchio: pip install pin")

    path = tmp_path / "branch.urdf"
    path.write_text(CHAIN_URDF)
    robot = symbolic.load(path, tip="l2")
    assert robot.coordinates == ("j1", "j2") and "past" not in {b.name for b in robot.bodies}
    cut = CHAIN_URDF.replace('<mass value="3"/>', '<mass value="0"/>').replace(
        '<inertia ixx="0.1" iyy="0.1" izz="0.1"', '<inertia ixx="0" iyy="0" izz="0"')
    full = pin.buildModelFromXML(cut)
    reduced = pin.buildReducedModel(full, [full.getJointId("js"), full.getJointId("jp")], pin.neutral(full))
    compare(robot, UrdfReference(None, robot.coordinates, model=reduced))


# -- hostile and broken files: one line each, naming the element --------------------------------------------
LINK = '<link name="{0}"><inertial><mass value="{1}"/><inertia ixx="{2}" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
JOINT = '<joint name="{0}" type="{3}"><parent link="{1}"/><child link="{2}"/><axis xyz="0 0 1"/></joint>'


def arm(mass: str = "1", ixx: str = "0.1", extra: str = "", kind: str = "revolute", parent: str = "l0") -> str:
    return (f'<robot name="r"><link name="l0"/>{LINK.format("l1", mass, ixx)}{JOINT.format("j1", parent, "l1", kind)}'
            f'{extra}</robot>')


BILLION_LAUGHS = '''<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
<!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">]>
<robot name="&lol3;"><link name="l0"/></robot>'''

EXTERNAL = '''<?xml version="1.0"?>
<!DOCTYPE robot [<!ENTITY secret SYSTEM "file:///etc/passwd">]>
<robot name="r"><link name="&secret;"/></robot>'''

HOSTILE = {
    "malformed": ("<robot name='r'><link name='l0'></robot>", "XML", "not well-formed"),
    "not a robot": ("<sdf/>", "XML", "root element is <sdf>"),
    "entity expansion": (BILLION_LAUGHS, "XML", "DTD"),
    "external entity": (EXTERNAL, "XML", "DTD"),
    "missing child": (arm(extra=JOINT.format("j2", "l1", "nowhere", "revolute")), "<joint 'j2'> <child>", "does not exist"),
    "missing parent": (arm(parent="ghost"), "<joint 'j1'> <parent>", "does not exist"),
    "cycle": (arm(extra=LINK.format("l2", "1", "0.1") + JOINT.format("j2", "l1", "l2", "revolute")
                  + JOINT.format("j3", "l2", "l0", "revolute")), "<joint", "cycle"),
    "negative mass": (arm(mass="-1"), "<link 'l1'> <inertial> <mass> value", "non-negative"),
    "not PSD": (arm(ixx="-0.5"), "<link 'l1'> <inertial> <inertia>", "not positive semidefinite"),
    "NaN": (arm(ixx="nan"), "<link 'l1'> <inertial> <inertia> ixx", "not finite"),
    "infinity": (arm(mass="inf"), "<link 'l1'> <inertial> <mass> value", "not finite"),
    "not a number": (arm(mass="heavy"), "<link 'l1'> <inertial> <mass> value", "not a number"),
    "floating base": (arm(kind="floating"), "<joint 'j1'> type", "fixed-base"),
    "unknown type": (arm(kind="spherical"), "<joint 'j1'> type", "unknown joint type"),
    "two parents": (arm(extra=JOINT.format("j2", "l0", "l1", "revolute")), "<joint 'j2'> <child>", "already the child"),
    "nothing moves": (arm(kind="fixed"), "<joint>", "nothing moves"),
    "duplicate link": (arm(extra=LINK.format("l1", "1", "0.1")), "<link 'l1'>", "defined twice"),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_urdf_gets_one_line_error(tmp_path: Path, case: str) -> None:
    text, key, problem = HOSTILE[case]
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    with pytest.raises(ModelError) as error:
        symbolic.load(path)
    message = str(error.value)
    assert "\n" not in message and str(path) in message and key in message and problem in message, message


def test_tip_and_root_that_do_not_exist_are_named(tmp_path: Path) -> None:
    path = tmp_path / "branch.urdf"
    path.write_text(CHAIN_URDF)
    with pytest.raises(ModelError, match="--tip: link 'hand' does not exist"):
        symbolic.load(path, tip="hand")
    with pytest.raises(ModelError, match="--root: link 'torso' does not exist"):
        symbolic.load(path, root="torso")
    with pytest.raises(ModelError, match="only in a URDF"):
        symbolic.load(Path(symbolic.robots.__file__).parent / "panda.toml", tip="7")


# -- export ----------------------------------------------------------------------------------------------------
def same_dynamics(a: symbolic.Robot, b: symbolic.Robot, tolerance: float = 1e-12, rigid: bool = False) -> None:
    """D, g, C·q̇ and τ of two robots with the same coordinates agree at random states."""
    x, y = numeric_model(symbolic.derive(a)), numeric_model(symbolic.derive(b))
    rng = np.random.default_rng(17)
    n = len(a.coordinates)
    for _ in range(4):
        q, qd, qdd = rng.uniform(-2, 2, (3, n))
        assert np.abs(x.inertia(q) - y.inertia(q)).max() < tolerance
        assert np.abs(x.gravity(q) - y.gravity(q)).max() < tolerance
        assert np.abs(x.coriolis(q, qd) - y.coriolis(q, qd)).max() < tolerance
        tau_x, tau_y = x.inverse_dynamics(q, qd, qdd), y.inverse_dynamics(q, qd, qdd)
        if rigid:
            tau_x, tau_y = tau_x - x.friction(q, qd), tau_y - y.friction(q, qd)
        assert np.abs(tau_x - tau_y).max() < tolerance


@pytest.mark.parametrize("name", ["panda", "puma560"])
def test_dh_model_exported_as_urdf_has_the_same_dynamics(tmp_path: Path, name: str) -> None:
    """Modified (Panda) and standard (PUMA 560) DH written as URDF: read back by symbolic and by Pinocchio."""
    from symbolic.export.urdf import urdf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        dh = symbolic.robots.load(name)
        path = tmp_path / f"{name}.urdf"
        path.write_text(urdf(dh))
        back = symbolic.load(path)
    assert back.coordinates == dh.coordinates
    same_dynamics(dh, back)
    compare(dh, UrdfReference(path, dh.coordinates))


def test_urdf_round_trip_keeps_the_dynamics(tmp_path: Path) -> None:
    """URDF → model → URDF → model: the same dynamics to 1e-12, friction included (Panda with its mimic finger)."""
    from symbolic.export.urdf import urdf

    first = symbolic.load(robots_folder() / "panda_description/urdf/panda.urdf")
    path = tmp_path / "again.urdf"
    path.write_text(urdf(first))
    again = symbolic.load(path)
    assert again.coordinates == first.coordinates and len(again.constraints) == 1
    same_dynamics(first, again)
    assert {p.name: p.value for p in again.parameters if p.name.startswith("fv_")} == \
           {p.name: p.value for p in first.parameters if p.name.startswith("fv_")}


def test_export_writes_given_values_and_refuses_what_urdf_cannot_hold(tmp_path: Path) -> None:
    from symbolic.errors import ExportError
    from symbolic.export.urdf import urdf

    robot = symbolic.loads(general_frames(), "general.toml")
    text = urdf(robot, {"m1": 2.5})
    assert '<mass value="2.5"/>' in text and '<mass value="1.3"/>' not in text
    with pytest.raises(ExportError, match="several coordinates"):
        urdf(symbolic.robots.load("fivebar"))
    with pytest.raises(ExportError, match="flexible links"):
        urdf(symbolic.robots.load("single_flexible_link"))
    with pytest.warns(symbolic.ModelWarning) as notes:  # what URDF cannot hold: the offset, EMPS's gravity along −y
        urdf(symbolic.robots.load("emps"))
    assert sorted(("offset" in str(n.message), "gravity" in str(n.message)) for n in notes) == [(False, True), (True, False)]


# -- the command line and generated C --------------------------------------------------------------------------
def test_cli_derives_generates_and_exports_a_urdf(tmp_path: Path, capsys) -> None:
    """``symbolic derive robot.urdf``, ``generate`` (C compiled with the strict flags, values checked against
    the numeric model) and ``export-urdf`` on the UR5 of example-robot-data."""
    from c_library import STRICT, CModel, compile_shared

    from symbolic.cli import main

    path = robots_folder() / "ur_description/urdf/ur5_robot.urdf"
    assert main(["derive", str(path), "--tip", "wrist_3_link"]) == 0
    assert "coordinates (6): shoulder_pan_joint" in capsys.readouterr().out
    assert main(["generate", str(path), "--out", str(tmp_path / "out"), "--targets", "c"]) == 0
    robot = symbolic.load(path)
    name = robot.name
    library = CModel(compile_shared(tmp_path / "out" / f"{name}.c", tmp_path / f"lib{name}.so", STRICT), name, 6, len(robot.parameters))
    num = numeric_model(symbolic.derive(robot))
    q = np.linspace(-1, 1, 6)
    assert np.abs(library.inertia(q, library.defaults) - num.inertia(q)).max() < 1e-12
    assert np.abs(library.gravity(q, library.defaults) - num.gravity(q)).max() < 1e-12
    out = tmp_path / "ur5_again.urdf"
    assert main(["export-urdf", str(path), "--out", str(out)]) == 0
    same_dynamics(robot, symbolic.load(out))
    assert main(["derive", str(path), "--root", "nowhere"]) == 2
    assert "--root: link 'nowhere' does not exist" in capsys.readouterr().err


FRAME_ERRORS = {
    "both": ('dh = { theta = "q1", d = "0", a = "0", alpha = "0" }\norigin = { xyz = [0, 0, 1] }',
             "[[frame]] 'a'", "either dh or origin"),
    "type": ('joint = { type = "ball", axis = [0, 0, 1] }\ncoordinate = "q1"', "[[frame]] 'a' joint.type", "unknown joint type"),
    "axis": ('joint = { type = "revolute", axis = [0, 0, 0] }\ncoordinate = "q1"', "[[frame]] 'a' joint.axis", "must not be zero"),
    "no coordinate": ('joint = { type = "revolute" }', "[[frame]] 'a' coordinate", "needs a coordinate"),
    "fixed with coordinate": ('joint = { type = "fixed" }\ncoordinate = "q1"', "[[frame]] 'a' coordinate", "has no coordinate"),
    "limits": ('joint = { type = "revolute", limit = { lower = 2, upper = 1 } }\ncoordinate = "q1"', "[[frame]] 'a' joint lower", "above upper"),
    "rpy": ('origin = { rpy = [0, "q1", 0] }\njoint = { type = "revolute" }\ncoordinate = "q1"', "[[frame]] 'a' origin.rpy[1]", "may not depend on"),
}


@pytest.mark.parametrize("case", sorted(FRAME_ERRORS))
def test_general_frame_errors_name_the_key(case: str) -> None:
    table, key, problem = FRAME_ERRORS[case]
    text = f'name = "e"\ncoordinates = ["q1"]\n[[frame]]\nname = "a"\nparent = "base"\n{table}\n'
    with pytest.raises(ModelError) as error:
        symbolic.loads(text, "e.toml")
    assert key in str(error.value) and problem in str(error.value), str(error.value)


def test_general_frame_from_python() -> None:
    from symbolic.description.robot import Body, Frame, Joint, Robot

    robot = symbolic.validate(Robot(
        name="pendulum", coordinates=("q",),
        frames=(Frame("link", "base", theta="q", joint=Joint("revolute", axis=(1, 0, 0), xyz=(0, 0, 1))),),
        bodies=(Body("bob", "link", 2.0, com=(0, 0, -0.5)),),
    ))
    num = numeric_model(symbolic.derive(robot))
    # a point mass 2 kg at 0.5 m below an x axis, gravity −z: D = m l², g = m g l sin q
    assert np.isclose(num.inertia([0.3])[0, 0], 2.0 * 0.25, rtol=1e-14)
    assert np.isclose(num.gravity([0.3])[0], 2.0 * 9.81 * 0.5 * np.sin(0.3), rtol=1e-14)


def test_identification_on_a_urdf_model_and_its_values_written_back(tmp_path: Path) -> None:
    """IDIM-LS on a model read from URDF: exact synthetic data (hidden scaled inertials and friction) give
    the base parameters to 1e-8; the identified values go back into a URDF that loads with them."""
    from test_identify_model import hidden_truth, measurements, model_base

    from symbolic.export.urdf import urdf
    from symbolic.identify.model import identify_model

    path = tmp_path / "general.urdf"
    path.write_text(general_frames_urdf())
    model = symbolic.derive(symbolic.load(path))
    reg, base = model_base(model)
    p = hidden_truth(model, seed=3)
    truth = base.from_theta(theta_values(model, reg, p))
    result = identify_model(model, measurements(model, p, seed=5, noise=0.0, seconds=8.0))
    assert np.linalg.norm(result.identification.values - truth) <= 1e-8 * np.linalg.norm(truth)
    out = tmp_path / "identified.urdf"
    out.write_text(urdf(model.robot, result.values()))
    again = {q.name: q.value for q in symbolic.load(out).parameters}
    assert again["fv_q2"] == pytest.approx(result.values()["fv_q2"], rel=1e-12)
