"""The parameter regressor τ = Y(q, q̇, q̈)·θ and the base parameters (Khalil & Dombre 14; Janot (2)–(7), V.D).

Checks: Y·θ(p) equals the inverse dynamics at random states and random parameters (1e-10 relative)
for every rigid built-in robot, friction, drives and forces included (models with beams:
tests/test_regressor_beams.py); the map from model-file parameters to θ on a body written by hand; the number of base parameters against the rank of
Pinocchio's joint-torque regressor (an independent implementation) for the Panda (43) and the
PUMA 560 (36); Janot's regrouped set of V.D.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import sympy as sp

import symbolic
from conftest import derived
from symbolic.derivation.regressor import regressor
from symbolic.errors import ModelError
from symbolic.numeric import numeric_model
from symbolic.numeric.base_parameters import base_parameters, regressor_function, theta_values

RIGID = ["fivebar", "puma560", "panda", "janot_branch", "omni", "emps"]


def load(name: str) -> symbolic.Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return symbolic.robots.load(name)


@pytest.mark.parametrize("name", RIGID)
def test_regressor_times_theta_is_the_inverse_dynamics(name: str) -> None:
    model = derived(name)
    reg = regressor(model.robot)
    Y = regressor_function(model, reg)
    num = numeric_model(model)
    rng = np.random.default_rng(11)
    for _ in range(10):
        q, qd, qdd = rng.uniform(-np.pi, np.pi, model.n), rng.uniform(-2, 2, model.n), rng.uniform(-5, 5, model.n)
        p = num.p0 * rng.uniform(0.5, 2.0, num.p0.size)
        tau = num.inverse_dynamics(q, qd, qdd, p)
        assert np.linalg.norm(Y(q, qd, qdd, p) @ theta_values(model, reg, p) - tau) <= 1e-10 * np.linalg.norm(tau)


def test_theta_of_a_body_written_by_hand() -> None:
    """Khalil's parameters about the frame origin: MX = m·cx, XX = Ixx_c + m(cy² + cz²), XY = Ixy_c − m·cx·cy."""
    m, cx, cy, I = sp.symbols("m cx cy I", real=True)
    robot = symbolic.validate(symbolic.Robot(
        name="arm", coordinates=("q",),
        parameters=tuple(symbolic.Parameter(s.name, v) for s, v in ((m, 2.0), (cx, 0.3), (cy, 0.1), (I, 0.01))),
        frames=(symbolic.Frame("1", "base", theta="q"),),
        bodies=(symbolic.Body("link", "1", "m", com=("cx", "cy", "0"), inertia={"xx": "I", "yy": "I", "zz": "2*I"}),),
    ))
    reg = regressor(robot)
    theta = dict(zip(reg.names, reg.theta_expressions))
    assert sp.simplify(theta["MX1"] - m * cx) == 0 and sp.simplify(theta["MY1"] - m * cy) == 0 and theta["MZ1"] == 0
    assert sp.simplify(theta["XX1"] - (I + m * cy**2)) == 0
    assert sp.simplify(theta["YY1"] - (I + m * cx**2)) == 0
    assert sp.simplify(theta["ZZ1"] - (2 * I + m * (cx**2 + cy**2))) == 0
    assert sp.simplify(theta["XY1"] - (-m * cx * cy)) == 0
    assert theta["M1"] == m


def test_emps_theta_and_base_parameters_are_the_published_model() -> None:
    model = derived("emps")
    reg = regressor(model.robot)
    base = base_parameters(model, reg)
    assert [str(e) for e in base.expressions] == ["M_carriage", "Fv", "Fc", "offset"]  # the model file's names
    assert np.allclose(base.values, [95.1089, 203.5034, 20.3935, -3.1648], rtol=1e-15)


def test_force_that_is_not_polynomial_in_its_parameters_is_refused() -> None:
    robot = load("emps")
    robot = symbolic.validate(dataclasses.replace(
        robot, validated=False, parameters=robot.parameters + (symbolic.Parameter("k", 1.0),),
        forces=(symbolic.description.Force("odd", "q", "-exp(k)*q"),)))
    with pytest.raises(ModelError, match="not polynomial"):
        regressor(robot)


def test_force_monomials_become_parameters() -> None:
    """A cable spring −k(q − q0) = −k·q + k·q0: θ = (k, k·q0), columns −q and 1 on τ's side (τ = … − Q); θ = k
    keeps the parameter's name, the product is named after the force."""
    robot = load("emps")
    robot = symbolic.validate(dataclasses.replace(
        robot, validated=False, parameters=robot.parameters + (symbolic.Parameter("k", 50.0), symbolic.Parameter("q0", 0.2)),
        forces=(symbolic.description.Force("cable", "q", "-k*(q - q0)"),)))
    reg = regressor(robot)
    columns = dict(zip(reg.names, reg.expand().row(0)))
    q = sp.Symbol("q", real=True)
    assert columns["k"] == q and columns["cable:k*q0"] == -1


def pinocchio_rank(name: str) -> int:
    pin = pytest.importorskip("pinocchio")
    from reference_pinocchio import build

    model = build(load(name))
    data = model.createData()
    rng = np.random.default_rng(1)
    rows = [pin.computeJointTorqueRegressor(model, data, rng.uniform(-np.pi, np.pi, model.nq), rng.uniform(-3, 3, model.nv),
                                            rng.uniform(-10, 10, model.nv)).copy() for _ in range(200)]
    W = np.vstack(rows)
    s = np.linalg.svd(W, compute_uv=False)
    return int(np.sum(s > 1e-8 * s[0]))


@pytest.mark.parametrize("name, expected", [("panda", 43), ("puma560", 36)])
def test_number_of_base_parameters_matches_pinocchio(name: str, expected: int) -> None:
    model = derived(name)
    base = base_parameters(model, regressor(model.robot))
    assert len(base.names) == expected == pinocchio_rank(name)
    assert base.gap[0] > 1e6 * max(base.gap[1], 1e-300) or base.gap[1] == 0.0  # an unambiguous rank


@pytest.mark.parametrize("name", RIGID)
def test_base_parameters_reproduce_the_inverse_dynamics(name: str) -> None:
    """Y_b·β = Y·θ = τ with β = θ_b + K θ_d, for any values of the parameters that enter θ only (K depends
    on the geometry, which Y fixes: those parameters stay nominal)."""
    model = derived(name)
    reg = regressor(model.robot)
    base = base_parameters(model, reg)
    Y = regressor_function(model, reg)
    num = numeric_model(model)
    in_y = set().union(*(e.free_symbols for _, e in reg.sub.program(list(reg.Y))), *(e.free_symbols for e in reg.Y))
    free = np.array([s not in in_y for s in model.parameter_symbols])
    assert free.any()
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-np.pi, np.pi, model.n), rng.uniform(-2, 2, model.n), rng.uniform(-5, 5, model.n)
        p = np.where(free, num.p0 * rng.uniform(0.5, 2.0, num.p0.size), num.p0)
        tau = num.inverse_dynamics(q, qd, qdd, p)
        beta = base.from_theta(theta_values(model, reg, p))
        assert np.linalg.norm(Y(q, qd, qdd, p)[:, list(base.independent)] @ beta - tau) <= 1e-9 * np.linalg.norm(tau)


JANOT_BASE = ("ZZ1R MX1 MY1R FV1 FS1 OFFSET1 XX2R XY2R XZ2R YZ2R ZZ2R MX2R MY2 FV2 FS2 OFFSET2 XX3R XY3R XZ3R YZ3R "
              "ZZ3R MX3R MY3 MX5R MY5 FV5R FS5R OFFSET5 MY6").split()
"""Janot V.D, verbatim: the 29 base parameters of the branch (passive-joint friction neglected)."""


def janot_name(ours: str) -> str:
    """Our names in the paper's spelling: ZZR1 -> ZZ1R, fc5 -> FS5(R), off2 -> OFFSET2 (the model file's names)."""
    import re

    m = re.match(r"^(XX|XY|XZ|YY|YZ|ZZ|MX|MY|MZ|M)(R?)(\d+)$", ours)
    if m:
        return f"{m.group(1)}{m.group(3)}{m.group(2)}"
    m = re.match(r"^(fv|fc|off)(\d+)$", ours)
    kind = {"fv": "FV", "fc": "FS", "off": "OFFSET"}[m.group(1)]
    return f"{kind}{m.group(2)}{'R' if m.group(2) == '5' and kind != 'OFFSET' else ''}"  # FV5R = FV5 + FV4 in the model


def test_janot_regrouped_set_of_the_paper() -> None:
    """With the passive-joint friction neglected as the paper concludes, our base set is V.D's list
    (same parameters, same ones regrouped), plus MY4: the first moment of link 4 along y4, which in our
    reading of Table 1 (frame 4 after the elbow, q4 = π/2 − q5 of (11)) moves link 4 in translation only
    and still acts through d3, d4 and q̈1; the paper regroups link 4 into link 1 entirely."""
    robot = load("janot_branch")
    robot = symbolic.validate(dataclasses.replace(robot, validated=False, frictions=tuple(f for f in robot.frictions if f.coordinate != "q3")))
    model = symbolic.derive(robot)
    base = base_parameters(model, regressor(robot))
    ours = {janot_name(n) for n in base.names}
    assert ours - set(JANOT_BASE) == {"MY4"}
    assert set(JANOT_BASE) - ours == set()


@pytest.mark.parametrize("name", RIGID)
def test_exported_regressor_in_c_and_casadi(name: str, tmp_path) -> None:
    """NAME_regressor · NAME_standard_parameters = NAME_inverse_dynamics in the committed C (gcc, ctypes)
    and the CasADi files, and both equal the SymPy Y to 1e-12 relative."""
    import ctypes
    from pathlib import Path

    import casadi

    from c_library import CModel, compile_shared

    model = derived(name)
    reg = regressor(model.robot)
    t = len(reg.theta)
    root = Path(__file__).resolve().parents[1] / "generated" / name
    c = CModel(compile_shared(root / f"{name}.c", tmp_path / f"lib{name}.so"), name, model.n, len(model.robot.parameters))
    names = (ctypes.c_char_p * t).in_dll(c.lib, f"{name}_theta_names")
    assert [x.decode() for x in names] == list(reg.names)
    Yc = casadi.Function.load(str(root / f"{name}_regressor.casadi"))
    thc = casadi.Function.load(str(root / f"{name}_standard_parameters.casadi"))
    Y = regressor_function(model, reg)
    rng = np.random.default_rng(2)
    num = numeric_model(model)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-np.pi, np.pi, model.n), rng.uniform(-2, 2, model.n), rng.uniform(-5, 5, model.n)
        p = num.p0 * rng.uniform(0.5, 2.0, num.p0.size)
        reference = Y(q, qd, qdd, p)
        theta = theta_values(model, reg, p)
        y_c = c._call("regressor", [q, qd, qdd, p], model.n * t).reshape(model.n, t)
        theta_c = c._call("standard_parameters", [p], t)
        assert np.linalg.norm(y_c - reference) <= 1e-12 * np.linalg.norm(reference)
        assert np.linalg.norm(np.array(Yc(q, qd, qdd, p)) - reference) <= 1e-12 * np.linalg.norm(reference)
        scale = 1e-13 * np.linalg.norm(theta)  # entries like I_xy − m·cx·cy cancel: relative to the whole vector
        # np.array(...).ravel(), not np.ravel(...): a NumPy function on a CasADi DM warns (casadi 3.7, #2959)
        assert np.abs(theta_c - theta).max() <= scale and np.abs(np.array(thc(p)).ravel() - theta).max() <= scale
        tau = c.inverse_dynamics(q, qd, qdd, p)
        assert np.linalg.norm(y_c @ theta_c - tau) <= 1e-12 * np.linalg.norm(tau)
