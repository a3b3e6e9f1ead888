"""URDF files that are valid but hostile or odd (issue 39): numbers Python reads and URDF does not, a
massless robot's generated C under the strict flags, thousands of links on fixed joints, joints named
after Python keywords.

Each ends in one of two ways: a model whose dynamics are right (its generated C compiles with the
documented strict flags), or one :class:`~symbolic.errors.ModelError` line naming the file, the element,
the attribute and what is allowed.
"""

from __future__ import annotations

import ctypes
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import symbolic
from c_library import STRICT, CModel, compile_shared
from symbolic.cli import main
from symbolic.description import urdf
from symbolic.errors import ModelError

INERTIAL = ('<inertial><origin xyz="{com}" rpy="{irpy}"/><mass value="{mass}"/>'
            '<inertia ixx="{ixx}" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>')


def two_links(**values: str) -> str:
    """A revolute joint j1 (limits, dynamics) and a prismatic j2 mimicking it; ``values`` replace any
    number written (keys as in the format strings below)."""
    v = {"com": "0.1 0 0", "irpy": "0 0 0", "mass": "1", "ixx": "0.1", "xyz": "0 0 0.5", "rpy": "0 0 0",
         "axis": "0 0 1", "lower": "-1", "upper": "1", "effort": "10", "velocity": "2", "damping": "0.1",
         "friction": "0.2", "multiplier": "0.5", "offset": "0"} | values
    link = INERTIAL.format(**v)
    return (f'<robot name="r"><link name="l0"/><link name="l1">{link}</link><link name="l2">{link}</link>'
            f'<joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/>'
            f'<origin xyz="{v["xyz"]}" rpy="{v["rpy"]}"/><axis xyz="{v["axis"]}"/>'
            f'<limit lower="{v["lower"]}" upper="{v["upper"]}" effort="{v["effort"]}" velocity="{v["velocity"]}"/>'
            f'<dynamics damping="{v["damping"]}" friction="{v["friction"]}"/></joint>'
            f'<joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/><axis xyz="1 0 0"/>'
            f'<mimic joint="j1" multiplier="{v["multiplier"]}" offset="{v["offset"]}"/></joint></robot>')


def refusal(text: str, tmp_path: Path) -> str:
    """The one-line message of loading ``text`` as robot.urdf (which must be refused)."""
    path = tmp_path / "robot.urdf"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError) as error:
        symbolic.load(path)
    message = str(error.value)
    assert "\n" not in message and message.startswith(f"{path}: "), message
    return message


# -- numbers: XML Schema's decimal form, not whatever Python's float() reads ------------------------------------
PLACES = {
    "mass": "<link 'l1'> <inertial> <mass> value",
    "ixx": "<link 'l1'> <inertial> <inertia> ixx",
    "com": "<link 'l1'> <inertial> <origin> xyz",
    "irpy": "<link 'l1'> <inertial> <origin> rpy",
    "xyz": "<joint 'j1'> <origin> xyz",
    "rpy": "<joint 'j1'> <origin> rpy",
    "axis": "<joint 'j1'> <axis> xyz",
    "lower": "<joint 'j1'> <limit> lower",
    "upper": "<joint 'j1'> <limit> upper",
    "effort": "<joint 'j1'> <limit> effort",
    "velocity": "<joint 'j1'> <limit> velocity",
    "damping": "<joint 'j1'> <dynamics> damping",
    "friction": "<joint 'j1'> <dynamics> friction",
    "multiplier": "<joint 'j2'> <mimic> multiplier",
    "offset": "<joint 'j2'> <mimic> offset",
}


@pytest.mark.parametrize("place", sorted(PLACES))
def test_a_number_with_an_underscore_is_refused_wherever_urdf_has_a_number(tmp_path: Path, place: str) -> None:
    """``1_000`` was read as 1000 (Python's float takes underscores; URDF numbers have none)."""
    original = {"com": "0.1 0 0", "irpy": "0 0 0", "xyz": "0 0 0.5", "rpy": "0 0 0", "axis": "0 0 1"}
    written = original[place].replace("0", "1_0", 1) if place in original else "1_000"
    message = refusal(two_links(**{place: written}), tmp_path)
    assert f"{PLACES[place]}: '1_0" in message and "is not a number" in message, message
    assert "optional sign, digits" in message, message


@pytest.mark.parametrize("written, problem", [
    ("1_000", "is not a number"),
    ("١", "is not a number"),  # an Arabic-Indic digit: float() reads 1
    ("0x10", "is not a number"),
    ("1e", "is not a number"),
    ("1..0", "is not a number"),
    ("INF", "is not finite"),
    ("-inf", "is not finite"),
    ("Infinity", "is not finite"),
    ("NaN", "is not finite"),
    ("1e999", "is not finite"),
    ("1e31", "is out of range"),
])
def test_numbers_that_are_not_urdf_numbers_are_refused(tmp_path: Path, written: str, problem: str) -> None:
    message = refusal(two_links(mass=written), tmp_path)
    assert f"<link 'l1'> <inertial> <mass> value: {written!r} {problem}" in message, message


def test_numbers_in_every_urdf_form_are_read() -> None:
    """Sign, no integer part, no fraction, exponent, surrounding XML whitespace: all URDF numbers."""
    robot = urdf.loads(two_links(mass="+.5e1", ixx=" 1.E-1\t", com="\n0.1  -0 +0 ", lower="-1.", upper="1"))
    values = {p.name: p.value for p in robot.parameters}
    assert values["m_l1"] == 5.0 and values["xx_l1"] == 0.1 and values["cx_l1"] == 0.1
    assert robot.frames[0].joint.limits == {"lower": -1.0, "upper": 1.0, "effort": 10.0, "velocity": 2.0}


def test_a_non_breaking_space_does_not_separate_numbers(tmp_path: Path) -> None:
    """XML whitespace is space, tab, CR and LF; Python's split() also splits on U+00A0."""
    message = refusal(two_links(xyz="0\u00a00 0.5"), tmp_path)
    assert "<joint 'j1'> <origin> xyz: expected 3 number(s)" in message, message


def test_a_robot_without_links_is_refused(tmp_path: Path) -> None:
    """StopIteration escaped before (no link to start the cycle search from)."""
    assert "<robot>: no <link>" in refusal('<robot name="r"/>', tmp_path)


# -- a massless robot: its generated C compiles with the documented strict flags ---------------------------------
MASSLESS = ('<robot name="massless"><link name="l0"/><link name="l1"/><link name="l2"/>'
            '<joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/><axis xyz="0 0 1"/></joint>'
            '<joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/><axis xyz="1 0 0"/>'
            '<origin xyz="0.5 0 0"/></joint></robot>')


def test_the_c_of_a_massless_urdf_compiles_with_the_strict_flags(tmp_path: Path) -> None:
    """No body, no parameter: the regressor and theta(p) have nothing to write, and gcc -Wextra -Werror
    refused their unused output arguments Y and theta."""
    path = tmp_path / "massless.urdf"
    path.write_text(MASSLESS)
    assert main(["-q", "generate", str(path), "--out", str(tmp_path / "out"), "--targets", "c"]) == 0
    library = CModel(compile_shared(tmp_path / "out" / "massless.c", tmp_path / "libmassless.so", STRICT), "massless", 2, 0)
    q = np.array([0.3, 0.1])
    assert not library.inertia(q, np.zeros(1)).any()
    assert not library.inverse_dynamics(q, q, q, np.zeros(1)).any()
    getattr(library.lib, "massless_regressor")  # present, and callable with its zero-size output
    library._call("regressor", [q, q, q, np.zeros(1)], 0)


# -- many links on fixed joints ---------------------------------------------------------------------------------
def fixed_chain(links: int) -> str:
    """A revolute joint, then ``links`` links with an inertial on fixed joints (all merged onto one frame)."""
    inertial = INERTIAL.format(com="0.01 0 0", irpy="0 0 0", mass="0.1", ixx="0.001")
    parts = ['<robot name="fixed"><link name="base"/>', f'<link name="l0">{inertial}</link>',
             '<joint name="j0" type="revolute"><parent link="base"/><child link="l0"/><axis xyz="0 0 1"/></joint>']
    for k in range(1, links + 1):
        parts.append(f'<link name="l{k}">{inertial}</link>'
                     f'<joint name="f{k}" type="fixed"><parent link="l{k - 1}"/><child link="l{k}"/>'
                     '<origin xyz="0.01 0 0" rpy="0 0 0.1"/></joint>')
    return "\n".join(parts + ["</robot>"])


def test_3000_links_merged_onto_one_frame_are_refused_with_the_reason(tmp_path: Path) -> None:
    """A 0.8 MB file (under the 20 MB limit) still derived after 120 s: its links' sums grew quadratically,
    and past about 1,000 links Python could not compile them. Now refused when read, saying why and what
    to do; the limit is far above real robots (PR2 merges 12)."""
    text = fixed_chain(3000)
    assert 0.5e6 < len(text) < urdf.MAX_BYTES
    message = refusal(text, tmp_path)
    assert f"<link 'l{urdf.MAX_MERGED}'> <inertial>: more than {urdf.MAX_MERGED} links" in message, message
    assert "onto frame 'l0'" in message and "combine them in one <inertial>" in message, message


@pytest.mark.slow
def test_links_merged_up_to_the_limit_load_and_derive(tmp_path: Path) -> None:
    """MAX_MERGED links on one frame: loaded and derived (8 s; the frame's sums are formed once, not one
    term at a time), and the dynamics are those of the links' total inertia."""
    robot = urdf.loads(fixed_chain(urdf.MAX_MERGED - 1))
    assert len(robot.bodies) == urdf.MAX_MERGED and {b.frame for b in robot.bodies} == {"l0"}
    model = symbolic.derive(robot)
    from symbolic.numeric import numeric_model

    values = {p.name: p.value for p in robot.parameters}
    expected = sum(values[f"zz_l{k}"] + values[f"m_l{k}"] * (values[f"cx_l{k}"] ** 2 + values[f"cy_l{k}"] ** 2)
                   for k in range(urdf.MAX_MERGED))
    assert numeric_model(model).inertia(np.zeros(1))[0, 0] == pytest.approx(expected, rel=1e-12)


# -- joints and links named after Python keywords ---------------------------------------------------------------
KEYWORDS = ('<robot name="kw"><link name="l0"/><link name="class">{inertial}</link><link name="int">{inertial}</link>'
            '<joint name="lambda" type="revolute"><parent link="l0"/><child link="class"/><axis xyz="0 0 1"/>'
            '<dynamics damping="0.1" friction="0.2"/></joint>'
            '<joint name="if" type="revolute"><parent link="class"/><child link="int"/><axis xyz="0 1 0"/>'
            '<origin xyz="0.5 0 0"/><mimic joint="lambda" multiplier="2"/></joint>'
            '<joint name="None" type="fixed"><parent link="int"/><child link="extra"/></joint>'
            '<link name="extra"/></robot>').format(inertial=INERTIAL.format(com="0.1 0 0", irpy="0 0 0", mass="1", ixx="0.1"))


def test_joints_named_after_python_keywords_load_and_export(tmp_path: Path) -> None:
    """A joint named lambda gave "cannot parse expression '2.0*lambda'" about the model file: now its
    coordinate is lambda_ (as t becomes t_), and the C (strict flags) and CasADi exports work."""
    path = tmp_path / "kw.urdf"
    path.write_text(KEYWORDS)
    robot = symbolic.load(path)
    assert robot.coordinates == ("lambda_",)
    assert [c.coordinate for c in robot.constraints] == ["if_"]
    assert {"m_class", "fv_lambda", "fc_lambda"} <= {p.name for p in robot.parameters}
    assert main(["-q", "generate", str(path), "--out", str(tmp_path / "out"), "--targets", "c,casadi"]) == 0
    library = CModel(compile_shared(tmp_path / "out" / "kw.c", tmp_path / "libkw.so", STRICT), "kw", 1,
                     len(robot.parameters))
    names = (ctypes.c_char_p * 1).in_dll(library.lib, "kw_coordinate_names")
    assert names[0] == b"lambda_"
    from symbolic.numeric import numeric_model

    num = numeric_model(symbolic.derive(robot))
    q = np.array([0.4])
    assert np.abs(library.inertia(q, library.defaults) - num.inertia(q)).max() < 1e-12
    script = (f"import sys; sys.path.insert(0, {str(tmp_path / 'out')!r}); import kw_casadi as m; "
              "print(float(m.load('inertia')([0.4], m.PARAMETER_DEFAULTS)))")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert float(result.stdout) == pytest.approx(num.inertia(q)[0, 0], rel=1e-12)


def test_a_model_file_naming_a_coordinate_after_a_python_keyword_is_told_so(tmp_path: Path) -> None:
    """In a model file the name is the user's to change: one line saying why, not "invalid syntax"."""
    text = (Path(symbolic.robots.__file__).parent / "emps.toml").read_text().replace('"q"', '"lambda"')
    path = tmp_path / "kw.toml"
    path.write_text(text)
    with pytest.raises(ModelError, match="coordinates: 'lambda' is a Python keyword.*'lambda_'"):
        symbolic.load(path)
