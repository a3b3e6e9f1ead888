"""A payload on an arm whose inertial parameters are all kept at their values (``fixed = true``, issue 39).

Fixed parameters are not free: their columns are known, so a payload's columns are not in the span of the
model's free parameters (there are none among the links' inertial ones) and the payload can be named. Before,
the payload's structure counted every inertial column as free and answered "the model's free parameters already
hold it", so the payload showed only as gravity terms on each joint.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
import workflow_cases as cases

import symbolic
from symbolic.workflow import diagnose
from symbolic.workflow.payload import structure
from symbolic.workflow.terms import model_terms

INERTIAL = {"m1": 3.0, "m2": 2.0, "c1": 0.2, "c2": 0.15, "I1": 0.04, "I2": 0.02}
PAYLOAD = 0.5
"""The payload of the truth (kg), at the tip of link 2."""


def fixed_arm() -> str:
    """The two-link arm with an end effector at the tip of link 2 and every inertial parameter declared
    ``fixed = true`` (CAD values the user trusts); friction free."""
    text = cases.arm(end_effector=True)
    for name, value in INERTIAL.items():
        line = f"{name} = {value!r}\n"
        assert line in text, line
        text = text.replace(line, f"{name} = {{ value = {value!r}, fixed = true }}\n")
    return text


def test_fixed_parameters_are_not_free_columns_of_the_payload() -> None:
    """The payload's structure against the model's terms with the fixed parameters known: a payload is
    separable (its mass determined); against every parameter free it is not (the links' own hold it)."""
    model = symbolic.derive(symbolic.loads(fixed_arm(), "<arm>"))
    from symbolic.identify.known import fixed_symbols

    fixed = model_terms(model, fixed_symbols(model))
    assert not any(n.startswith(("m", "I", "M")) for n in fixed.free_names), fixed.free_names
    known = structure(model, "2", "q2", fixed)
    assert known.reason is None and known.determined[0], known.reason
    assert structure(model, "2", "q2").reason is not None  # every inertial parameter free: nothing separable


@pytest.mark.slow
def test_payload_named_on_an_arm_with_every_inertial_value_fixed(tmp_path: Path) -> None:
    truth = fixed_arm() + f'\n[[body]]\nname = "tool"\nframe = "2"\nmass = "{PAYLOAD!r}"\n'
    data = cases.measurements(truth, 4, 0.01, seconds=20.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        d = diagnose(cases.model_file(tmp_path, fixed_arm()), data, out=tmp_path / "out", figures=False)
    assert [(f.effect, f.coordinate) for f in d.found] == [("payload", "q2")], [(f.effect, f.coordinate) for f in d.found]
    assert d.found[0].parameters["mass"] == pytest.approx(PAYLOAD, rel=0.10), d.found[0].parameters
