"""symbolic.description.joint_limits: a joint's limits bound its variable θ; the coordinate q of θ = s·q + c (s = ±1)
gets sorted(s·(limit − c)). The three readers (excite's limits, the float C's sampled states, MJCF's range) agree."""

from __future__ import annotations

import warnings

import pytest

import symbolic
from models import general_frames
from symbolic.codegen.c_accuracy import state_ranges
from symbolic.description.joint_limits import coordinate_limits
from symbolic.identify.excitation import model_file_limits


def _robot(variable: str, limit: str = "lower = -3, upper = 3, velocity = 2, effort = 40"):
    text = general_frames().replace('coordinate = "q1"', f'coordinate = "{variable}"', 1)
    text = text.replace("limit = { lower = -3, upper = 3 }", f"limit = {{ {limit} }}", 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return symbolic.loads(text, "general.toml")


@pytest.mark.parametrize("variable, lower, upper", [("q1", -3.0, 3.0), ("0.5 - q1", -2.5, 3.5), ("q1 + l", -3.25, 2.75),
                                                   ("-q1", -3.0, 3.0)])
def test_limits_of_the_joint_variable_bound_the_coordinate(variable, lower, upper):
    limits = coordinate_limits(_robot(variable))["q1"]
    assert (limits.kind, limits.velocity, limits.effort) == ("revolute", 2.0, 40.0)
    assert (limits.lower, limits.upper) == pytest.approx((lower, upper), rel=1e-15)


def test_a_scaled_variable_declares_no_box_on_its_coordinate():
    limits = coordinate_limits(_robot("2*q1"))["q1"]
    assert limits == type(limits)("revolute")


def test_excite_and_the_float_c_read_the_same_limits():
    robot = _robot("0.5 - q1")
    model = symbolic.derive(robot)
    assert model_file_limits(model)["position"]["q1"] == pytest.approx((-2.5, 3.5))
    assert model_file_limits(model)["torque"]["q1"] == 40.0
    lower, upper, velocity = state_ranges(model)
    k = model.robot.generalized_coordinates.index("q1")
    assert (lower[k], upper[k], velocity[k]) == pytest.approx((-2.5, 3.5, 2.0))
