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
from reference_pinocchio import UrdfReference
from symbolic.derive.regressor import frame_label, regressor
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
            prefix = next(p for p in sorted(PINOCCHIO_COLUMNS, key=len, reverse=True)
                          if name.startswith(p) and any(name == p + frame_label(f) for f in joint_of))
            frame = next(f for f in joint_of if name == prefix + frame_label(f))
            if joint_of[frame] in coupled:
                continue
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
