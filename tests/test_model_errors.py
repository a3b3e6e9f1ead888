"""Bad model input: each problem refused (or warned about) with a message naming file, key and problem."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

import symbolic
from symbolic.errors import ModelError, ModelWarning
from symbolic.spec.expressions import parse_expression

VALID = """
name = "arm"
coordinates = ["q1", "q2"]
gravity = ["0", "0", "-g"]

[parameters]
g = 9.81
l1 = { value = 0.5, unit = "m" }
m1 = { value = 1.0, unit = "kg" }
m2 = 0.5

[[frame]]
name = "1"
parent = "base"
dh = { theta = "q1", d = "0", a = "l1", alpha = "0" }

[[frame]]
name = "2"
parent = "1"
dh = { theta = "q2", d = "0", a = "l1", alpha = "0" }

[[body]]
name = "link1"
frame = "1"
mass = "m1"
com = ["-l1/2", "0", "0"]
inertia = { xx = "0.001", yy = "0.02", zz = "0.02" }

[[body]]
name = "tip"
frame = "2"
mass = "m2"
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "model.toml"
    path.write_text(text)
    return path


def refused(tmp_path: Path, text: str) -> ModelError:
    path = write(tmp_path, text)
    with pytest.raises(ModelError) as info:
        symbolic.load(path)
    assert str(path) in str(info.value), "the message must name the file"
    return info.value


def test_valid_model_loads(tmp_path: Path) -> None:
    robot = symbolic.load(write(tmp_path, VALID))
    assert robot.coordinates == ("q1", "q2") and len(robot.bodies) == 2


def test_undeclared_symbol(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace('a = "l1", alpha = "0" }\n\n[[frame]]', 'a = "l7", alpha = "0" }\n\n[[frame]]', 1))
    assert "[[frame]] '1' dh.a" in str(error) and "undeclared symbol 'l7'" in str(error)


def test_negative_mass(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace("m2 = 0.5", "m2 = -0.5"))
    assert "[[body]] 'tip' mass" in str(error) and "non-negative" in str(error)


def test_inertia_not_positive_semidefinite(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace('xx = "0.001", yy = "0.02", zz = "0.02"', 'xx = "0.01", yy = "0.02", zz = "0.02", xy = "0.05"'))
    assert "[[body]] 'link1' inertia" in str(error) and "not positive semidefinite" in str(error)


def test_triangle_inequality_only_warns(tmp_path: Path) -> None:
    text = VALID.replace('xx = "0.001", yy = "0.02", zz = "0.02"', 'xx = "0", yy = "0.35", zz = "0"')  # Corke's PUMA link 1
    with pytest.warns(ModelWarning, match=r"\[\[body\]\] 'link1' inertia.*triangle inequality"):
        symbolic.load(write(tmp_path, text))


def test_puma_link1_warns() -> None:
    """Corke's PUMA 560: link 1 (0, 0.35, 0) and link 3 (0.066, 0.086, 0.0125) violate the triangle inequality."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        symbolic.robots.load("puma560")
    messages = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
    assert len(messages) == 2
    assert "'link1' inertia" in messages[0] and "'link3' inertia" in messages[1]


def test_missing_parent(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace('parent = "1"', 'parent = "7"'))
    assert "[[frame]] '2' parent" in str(error) and "'7' does not exist" in str(error)


def test_cycle(tmp_path: Path) -> None:
    text = VALID.replace('name = "1"\nparent = "base"', 'name = "1"\nparent = "2"')
    error = refused(tmp_path, text)
    assert "cycle" in str(error) and "[[frame]]" in str(error)


def test_unused_coordinate(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace('coordinates = ["q1", "q2"]', 'coordinates = ["q1", "q2", "q3"]'))
    assert "coordinates" in str(error) and "'q3' is not used by any frame" in str(error)


@pytest.mark.parametrize(
    "text, problem",
    [
        ("__import__('os')", "call of '__import__' is not allowed"),
        ("l1.__class__", "attribute access is not allowed"),
        ("(lambda: 1)()", "call of"),
        ("lambda: 1", "lambda is not allowed"),
        ("l1[0]", "subscript is not allowed"),
        ("l1 if q1 else 0", "conditional expression is not allowed"),
        ("'text'", "is not a number"),
        ("sin(q1, q2)", "takes 1 argument"),
        ("sin(x=q1)", "keyword arguments"),
        ("l1 < 2", "comparison is not allowed"),
        ("q1 +", "cannot parse"),
    ],
)
def test_forbidden_syntax(tmp_path: Path, text: str, problem: str) -> None:
    error = refused(tmp_path, VALID.replace('theta = "q2"', f'theta = "{text}"' if '"' not in text else f"theta = '{text}'"))
    assert "[[frame]] '2' dh.theta" in str(error)
    assert problem in str(error)


def test_parser_refuses_calls_of_builtins(capsys) -> None:
    symbols = {"q": __import__("sympy").Symbol("q")}
    with pytest.raises(ModelError, match="boolean operator is not allowed"):
        parse_expression("print('x') or q", symbols, "<test>", "key")
    with pytest.raises(ModelError, match="call of 'print' is not allowed"):
        parse_expression("print('x')", symbols, "<test>", "key")
    assert capsys.readouterr().out == ""


def test_parser_builds_exact_expressions() -> None:
    import sympy as sp

    q = sp.Symbol("q", real=True)
    expr = parse_expression("0.0825*cos(q - pi/2) + 2**-1", {"q": q}, "<test>", "key")
    assert expr == sp.Rational(33, 400) * sp.sin(q) + sp.Rational(1, 2)


def test_unknown_key_is_refused(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace('mass = "m2"', 'mass = "m2"\nmas = "m2"'))
    assert "unknown key(s) ['mas']" in str(error)


def test_model_name_must_be_identifier(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace('name = "arm"', 'name = "Arm-2"'))
    assert "name" in str(error) and "lower-case identifier" in str(error)


def test_coordinate_in_link_length_is_refused(tmp_path: Path) -> None:
    error = refused(tmp_path, VALID.replace('a = "l1", alpha = "0" }\n\n[[body]]', 'a = "q1", alpha = "0" }\n\n[[body]]'))
    assert "dh.a" in str(error) and "may not depend on ['q1']" in str(error)


def test_python_spec_is_validated_too() -> None:
    with pytest.raises(ModelError, match=r"<python>: \[\[body\]\] 'b' mass: mass must be non-negative"):
        symbolic.validate(symbolic.Robot(
            name="p",
            coordinates=("q",),
            parameters=(symbolic.Parameter("m", -1.0),),
            frames=(symbolic.Frame("f", "base", theta="q"),),
            bodies=(symbolic.Body("b", "f", mass="m"),),
        ))


def test_python_spec_equals_file(tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        robot = symbolic.validate(symbolic.Robot(
            name="arm",
            coordinates=("q1", "q2"),
            parameters=(
                symbolic.Parameter("g", 9.81),
                symbolic.Parameter("l1", 0.5, "m"),
                symbolic.Parameter("m1", 1.0, "kg"),
                symbolic.Parameter("m2", 0.5),
            ),
            frames=(symbolic.Frame("1", "base", theta="q1", a="l1"), symbolic.Frame("2", "1", theta="q2", a="l1")),
            bodies=(
                symbolic.Body("link1", "1", "m1", com=("-l1/2", 0, 0), inertia={"xx": "0.001", "yy": "0.02", "zz": "0.02"}),
                symbolic.Body("tip", "2", "m2"),
            ),
            gravity=(0, 0, "-g"),
        ))
    assert robot == symbolic.load(write(tmp_path, VALID))
