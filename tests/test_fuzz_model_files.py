"""Fuzzing the model loader, the derivation and the command line with hostile model files (issue 15).

Random TOML structures, random expression strings and the shapes that once hung or crashed the
tool (``10**10**10``, 3,300 nested additions, 9,000 unary minuses, ...) must each be answered within
a bounded time, either with a model or with the tool's own error: :class:`~symbolic.errors.ModelError`
from the library, exit status 2 and one line on stderr from the command line.
"""

from __future__ import annotations

import copy
import math
import re
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import symbolic
from deadline import within
from symbolic.errors import ModelError
from symbolic.description.expressions import FUNCTIONS, parse_expression

ISSUE_SHAPES = [
    "q2" + "+q2" * 3300,
    "-" * 9000 + "q2",
    "0*m1/0",
    "l2*2.0**100000",
    "l2/0",
    "l2*sqrt(-1)",
    "log(0)",
    "0**-1",
    "q2/0",
    "l2*10**10**10",
    "q2**10**10",
    "(" * 4000 + "q2" + ")" * 4000,
    "1" * 5000,
    "0x" + "f" * 1500,
    "exp(exp(exp(exp(9))))",
    "acos(2)",
    "1e400",
    "1e-400",
]
"""The failures found in issue 15, and relatives."""

NAMES = ["q1", "q2", "l1", "l2", "m1", "m2", "g", "pi", "x", "q1_dot", "qd_q2", *FUNCTIONS, "__import__", "lambda", "None", "True"]
NUMBERS = st.one_of(
    st.integers(-(10**40), 10**40).map(str),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.sampled_from(["0", "0.0", "1e30", "1e-30", "1e31", "1e-31", "2.0", "10", "100", "101", "1_000", "1j", "0b11", "0x1f"]),
)
ATOMS = st.one_of(NUMBERS, st.sampled_from(NAMES))


def _combine(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    binary = st.tuples(children, st.sampled_from(["+", "-", "*", "/", "**", " ** ", "%", "//", "<", " and ", ".", ","]), children)
    call = st.tuples(st.sampled_from([*FUNCTIONS, "print", "getattr"]), st.lists(children, max_size=3))
    return st.one_of(
        binary.map("".join),
        st.tuples(st.sampled_from(["-", "+", "~", "not "]), children).map("".join),
        children.map(lambda c: f"({c})"),
        call.map(lambda t: f"{t[0]}({', '.join(t[1])})"),
    )


GRAMMAR = st.recursive(ATOMS, _combine, max_leaves=25)


def _well_formed(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    binary = st.tuples(children, st.sampled_from(["+", "-", "*", "/", "**"]), children)
    calls = [st.tuples(st.just(name), st.lists(children, min_size=n, max_size=n)) for name, (_, n) in FUNCTIONS.items()]
    return st.one_of(
        binary.map(lambda t: f"({t[0]}){t[1]}({t[2]})"),
        children.map(lambda c: f"-({c})"),
        st.one_of(*calls).map(lambda t: f"{t[0]}({', '.join(t[1])})"),
    )


WELL_FORMED = st.recursive(
    st.sampled_from(["q1", "q2", "qd_q2", "l1", "l2", "m1", "g", "pi", "0", "1", "2", "0.5", "3", "-1"]), _well_formed, max_leaves=8
)
"""Expressions the whitelist accepts, which may still be infinite, complex or very large (``(0)**(-1)``)."""
REPEATED = st.builds(
    lambda head, piece, n, tail: head + piece * n + tail,
    st.sampled_from(["", "q2", "l2*", "sin("]),
    st.sampled_from(["+q2", "-", "(", "sin(", "q2**", "2**", "*q2", "10**", "1", "--", "*2.0", "/0.1", ")"]),
    st.integers(0, 6000),
    st.sampled_from(["", "q2", ")", "0", "2"]),
)
EXPRESSIONS = st.one_of(GRAMMAR, REPEATED, st.text(max_size=40), st.sampled_from(ISSUE_SHAPES))


def toml_value(value: Any) -> str:
    """``value`` as TOML (inline tables and arrays only, so any nesting fits on one line)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else {math.inf: "inf", -math.inf: "-inf"}.get(value, repr(value))
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{toml_string(k)} = {toml_value(v)}" for k, v in value.items()) + "}"


def toml_string(text: str) -> str:
    """A TOML basic string: control characters escaped, everything else as it is."""
    escaped = "".join(f"\\u{ord(c):04x}" if ord(c) < 0x20 or ord(c) == 0x7F or c in '"\\' else c for c in text)
    return f'"{escaped}"'


def toml_document(model: dict[str, Any]) -> str:
    return "".join(f"{toml_string(k)} = {toml_value(v)}\n" for k, v in model.items())


SCALARS = st.one_of(EXPRESSIONS, st.integers(-(2**70), 2**70), st.floats(), st.booleans())
VALUES = st.recursive(SCALARS, lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=6), c, max_size=4), max_leaves=12)
PLAUSIBLE = st.sampled_from(["q1", "q2", "l1", "l2", "0", "m1", "2*l2", "q2 - pi/2", "0.01", "m2 + m1"])
EXPR_OR_VALUE = st.one_of(*[PLAUSIBLE] * 6, EXPRESSIONS, VALUES)
"""Mostly plausible, so that a random model reaches the later checks, else anything."""
FRAME_NAMES = st.sampled_from(["1", "2", "3", "base", "1'"]) | st.sampled_from(["1", "2"]) | st.text(max_size=5)
FRAMES = st.fixed_dictionaries(
    {"name": FRAME_NAMES, "parent": FRAME_NAMES},
    optional={"dh": st.fixed_dictionaries({k: EXPR_OR_VALUE for k in ("theta", "d", "a", "alpha")}) | VALUES},
)
BODIES = st.fixed_dictionaries(
    {"name": st.sampled_from(["b1", "b2"]) | st.text(max_size=4), "frame": FRAME_NAMES, "mass": EXPR_OR_VALUE},
    optional={
        "com": st.lists(EXPR_OR_VALUE, max_size=4),
        "inertia": st.dictionaries(st.sampled_from(["xx", "yy", "zz", "xy", "xz", "yz", "zx"]), EXPR_OR_VALUE, max_size=6),
    },
)
BEAMS = st.fixed_dictionaries(
    {k: EXPR_OR_VALUE for k in ("length", "density", "EI_v", "EI_w")}
    | {"name": st.sampled_from(["beam"]) | st.text(max_size=4), "frame": FRAME_NAMES},
    optional={
        "modes_v": st.integers(-3, 10**18) | VALUES,
        "modes_w": st.integers(-3, 10**18) | VALUES,
        "tip_mass": EXPR_OR_VALUE,
        "boundary": st.sampled_from(["clamped-free", "pinned"]) | VALUES,
    },
)
PARAMETER_VALUES = st.one_of(
    st.floats(), st.integers(-(10**400), 10**400), st.fixed_dictionaries({"value": st.floats() | VALUES}, optional={"unit": VALUES}), VALUES
)
MODELS = st.fixed_dictionaries(
    {
        "name": st.just("arm") | st.sampled_from(["arm", "int", "main", "Arm", "a" * 300]) | st.text(max_size=8),
        "coordinates": st.just(["q1", "q2"]) | st.just(["q1", "q2"]) | st.just(["q1"]) | st.lists(st.sampled_from(["q1", "q2", "pi", "sin", "x_dot", "1q"]) | st.text(max_size=4), max_size=3) | VALUES,
    },
    optional={
        "parameters": st.dictionaries(st.sampled_from(["l1", "l2", "m1", "m2", "g"]), st.floats(0.1, 2.0), min_size=5)
        | st.dictionaries(st.sampled_from(["l1", "l2", "m1", "m2", "g"]) | st.text(max_size=4), PARAMETER_VALUES, max_size=5),
        "gravity": st.lists(EXPR_OR_VALUE, max_size=4),
        "frame": st.lists(FRAMES | VALUES, max_size=3),
        "body": st.lists(BODIES | VALUES, max_size=2),
        "beam": st.lists(BEAMS, max_size=1),
        "constraint": st.lists(st.fixed_dictionaries({"coordinate": st.sampled_from(["q3", "q1"]), "expression": EXPR_OR_VALUE}), max_size=1),
        "end_effector": st.fixed_dictionaries({"frame": FRAME_NAMES}, optional={"point": st.lists(EXPR_OR_VALUE, max_size=4)}),
        "convention": st.sampled_from(["standard", "modified", "other"]),
        "friction": st.lists(st.fixed_dictionaries({"coordinate": st.sampled_from(["q1", "q3", "x"])},
                                                   optional={k: EXPR_OR_VALUE for k in ("viscous", "coulomb", "offset", "stribeck")}), max_size=2),
        "drive": st.lists(st.fixed_dictionaries({"coordinate": st.sampled_from(["q1", "q2"])},
                                                optional={k: EXPR_OR_VALUE for k in ("ratio", "rotor_inertia", "gain")}), max_size=2),
        "force": st.lists(st.fixed_dictionaries({"name": st.sampled_from(["f", ""]) | VALUES, "coordinate": st.sampled_from(["q1", "q2"]),
                                                 "expression": EXPR_OR_VALUE}), max_size=2),
    },
)

BASE_MODEL: dict[str, Any] = {
    "name": "arm",
    "coordinates": ["q1", "q2"],
    "gravity": ["0", "0", "-g"],
    "parameters": {"g": 9.81, "l1": 0.5, "l2": {"value": 0.4, "unit": "m"}, "m1": 1.0, "m2": 0.5, "rho": 0.3, "EI": 2},
    "frame": [
        {"name": "1", "parent": "base", "dh": {"theta": "q1", "d": "0", "a": "l1", "alpha": "0"}},
        {"name": "2", "parent": "1", "dh": {"theta": "q2", "d": "0", "a": "l2", "alpha": "pi/2"}},
        {"name": "3", "parent": "2", "dh": {"theta": "q3", "d": 0, "a": 0, "alpha": 0}},
    ],
    "constraint": [{"coordinate": "q3", "expression": "q1/2"}],
    "body": [
        {"name": "link1", "frame": "1", "mass": "m1", "com": ["-l1/2", 0, 0], "inertia": {"xx": "0.001", "yy": "0.02", "zz": "0.02"}},
        {"name": "tip", "frame": "2", "mass": "m2"},
    ],
    "beam": [{"name": "flex", "frame": "3", "length": "l2", "density": "rho", "EI_v": "EI", "EI_w": "EI", "modes_v": 1, "modes_w": 2, "tip_mass": "m2"}],
    "end_effector": {"frame": "2", "point": ["l2", "0", "0"]},
    "friction": [{"coordinate": "q1", "viscous": "0.1", "coulomb": {"positive": "0.2", "negative": 0.3},
                  "stribeck": {"static": "0.3", "velocity": "0.01"}, "offset": "-0.01"}],
    "drive": [{"coordinate": "q2", "ratio": "50", "rotor_inertia": "1e-5", "gain": 0.1}],
    "force": [{"name": "spring", "coordinate": "q3", "expression": "-2*q3 - 0.1*qd_q1"}],
}
"""A valid model using every kind of entry; the fuzzer changes one to three places of it."""


def _paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix] if prefix else []
    if isinstance(value, dict):
        for k, v in value.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            out += _paths(v, prefix + (i,))
    return out


def _mutate(edits: list[tuple[tuple, str, Any]]) -> dict[str, Any]:
    model = copy.deepcopy(BASE_MODEL)
    for path, action, new in edits:
        parent = model
        try:
            for step in path[:-1]:
                parent = parent[step]
            if action == "delete":
                del parent[path[-1]]
            elif action == "add" and isinstance(parent, dict):
                parent[f"{path[-1]}_extra"] = new
            else:
                parent[path[-1]] = new
        except (KeyError, IndexError, TypeError):
            pass  # an earlier edit removed or retyped this place
    return model


MUTATED_BASE = st.lists(
    st.tuples(st.sampled_from(_paths(BASE_MODEL)), st.sampled_from(["replace", "replace", "replace", "delete", "add"]), EXPR_OR_VALUE | VALUES),
    min_size=1,
    max_size=3,
).map(_mutate)

TWO_LINK = """
name = "arm"
coordinates = ["q1", "q2"]
gravity = ["0", "0", "-g"]

[parameters]
g = 9.81
l1 = 0.5
l2 = 0.4
m1 = 1.0
m2 = 0.5

[[frame]]
name = "1"
parent = "base"
dh = { theta = "q1", d = "0", a = "l1", alpha = "0" }

[[frame]]
name = "2"
parent = "1"
dh = { theta = @THETA@, d = "0", a = @A@, alpha = "0" }

[[body]]
name = "link1"
frame = "1"
mass = @MASS@
com = ["-l1/2", "0", "0"]
inertia = { xx = "0.001", yy = "0.02", zz = "0.02" }

[[body]]
name = "tip"
frame = "2"
mass = "m2"

[[friction]]
coordinate = "q2"
viscous = @VISCOUS@

[[force]]
name = "spring"
coordinate = "q2"
expression = @FORCE@
"""
"""A valid 2-link model whose frame-2 angle and length, link-1 mass, joint-2 friction and force the fuzzer replaces."""

DEFAULTS = {"THETA": "q2", "A": "l2", "MASS": "m1", "VISCOUS": "0.1", "FORCE": "-q2"}
CHANGES = {
    "THETA": WELL_FORMED | WELL_FORMED | EXPRESSIONS,
    "A": WELL_FORMED | EXPRESSIONS,
    "MASS": WELL_FORMED | EXPR_OR_VALUE,
    "VISCOUS": WELL_FORMED | EXPR_OR_VALUE,
    "FORCE": WELL_FORMED | EXPRESSIONS,
}
MUTATED = st.lists(st.one_of([st.tuples(st.just(k), v) for k, v in CHANGES.items()]), min_size=1, max_size=2).map(
    lambda changes: _fill(TWO_LINK, DEFAULTS | dict(changes))
)
"""TWO_LINK with one or two of its fields changed (so that most examples get as far as deriving)."""


def _fill(text: str, fields: dict[str, Any]) -> str:
    for key, value in fields.items():
        text = text.replace(f"@{key}@", toml_value(value))
    return text


def load_or_refuse(text: str, seconds: float = 5.0) -> symbolic.Robot | None:
    """The robot, or None after a ModelError; any other exception, or taking too long, fails."""
    with within(seconds, text), warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        try:
            return symbolic.loads(text, "fuzz.toml")
        except ModelError as error:
            assert "\n" not in str(error) and str(error).startswith("fuzz.toml: "), str(error)
            assert len(str(error)) < 1000, "long user text must be shortened in messages"
            return None


FAST = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@settings(FAST, max_examples=1000)
@given(EXPRESSIONS)
def test_expression_parses_or_is_refused_quickly(text: str) -> None:
    symbols = {n: sp.Symbol(n, real=True) for n in ("q1", "q2", "l1", "l2", "m1", "m2", "g")}
    with within(2.0, text):
        try:
            expr = parse_expression(text, symbols, "fuzz.toml", "key")
        except ModelError as error:
            assert "\n" not in str(error) and len(str(error)) < 1000
            return
    assert not expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo, sp.I)


@settings(FAST, max_examples=400)
@given(MODELS | MUTATED_BASE | MUTATED_BASE)
def test_random_model_structure_loads_or_is_refused(model: dict[str, Any]) -> None:
    load_or_refuse(toml_document(model))


@settings(FAST, max_examples=300)
@given(st.lists(st.sampled_from([*'[]{}=",.#\n\\ abq12-+*/()e\'', "name", "[[frame]]", "dh", "coordinates"]), max_size=60).map("".join))
def test_random_toml_text_loads_or_is_refused(text: str) -> None:
    load_or_refuse(text)


@settings(FAST, max_examples=150)
@given(MUTATED)
def test_mutated_model_derives_or_is_refused(text: str) -> None:
    """What loads must also derive, or be refused (the values check at the nominal parameters)."""
    robot = load_or_refuse(text)
    if robot is None:
        return
    with within(20.0, text):
        try:
            model = symbolic.derive(robot)
        except ModelError as error:
            assert "\n" not in str(error) and str(error).startswith("fuzz.toml: "), str(error)
            return
    assert model.n == 2


@pytest.mark.slow
@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.one_of(MUTATED, MUTATED, MODELS.map(toml_document)))
def test_command_line_answers_with_a_model_or_one_error_line(tmp_path_factory: pytest.TempPathFactory, text: str) -> None:
    path = tmp_path_factory.mktemp("fuzz") / "model.toml"
    path.write_text(text, encoding="utf-8")
    try:
        result = subprocess.run(
            [sys.executable, "-m", "symbolic", "-q", "derive", "--no-show", str(path)],
            capture_output=True, text=True, timeout=60,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"symbolic derive took more than 60 s on {text[:300]!r}")
    assert "Traceback" not in result.stderr, result.stderr[-2000:]
    assert result.returncode in (0, 2), result.stderr
    if result.returncode == 2:
        lines = [line for line in result.stderr.splitlines() if not line.startswith("warning: ")]
        assert len(lines) == 1 and re.match(rf"error: {re.escape(str(path))}: ", lines[0]), result.stderr
