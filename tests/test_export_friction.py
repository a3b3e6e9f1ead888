"""Every built-in robot with friction of every kind, drives and applied forces added: the generated C
(gcc, ctypes), the CasADi functions and the SymPy model agree to 1e-12 relative, and forward dynamics
inverts inverse dynamics to 1e-10 relative away from q̇ = 0 (docs/contracts.md, "Generated C").

The additions are made in Python on the loaded robot (a model file with the same entries validates
to the same Robot, see test_friction.py): on every rigid coordinate a direction-dependent viscous
and Coulomb law with an offset, a Stribeck rise on the first, a drive with ratio and rotor inertia;
on the first coordinate a nonlinear spring and damper as a [[force]] in q and q̇.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import casadi
import numpy as np
import pytest

import symbolic
import symbolic.export as export
from c_library import CModel, compile_shared
from symbolic.numeric import numeric_model
from symbolic.description import Directional, Drive, Force, Friction, Parameter, Stribeck

ROBOTS = ["fivebar", "puma560", "panda", "janot_branch", "omni", "single_flexible_link", "madill_beam", "fivebar_flexible", "emps"]


def with_every_term(robot: symbolic.Robot) -> symbolic.Robot:
    params, frictions, drives = list(robot.parameters), [], []
    existing = {f.coordinate for f in robot.frictions}
    for i, c in enumerate(robot.coordinates):
        names = {k: f"zz_{k}{i}" for k in ("fvp", "fvn", "fcp", "fcn", "off", "fs", "vs", "ia", "ratio")}
        values = {"fvp": 0.3 + 0.1 * i, "fvn": 0.5, "fcp": 0.2, "fcn": 0.35, "off": -0.05, "fs": 0.4, "vs": 0.1,
                  "ia": 1e-4, "ratio": 20.0 + i}
        params += [Parameter(names[k], values[k]) for k in names]
        if c not in existing:
            frictions.append(Friction(c, Directional(names["fvp"], names["fvn"]), Directional(names["fcp"], names["fcn"]),
                                      names["off"], Stribeck(names["fs"], names["vs"]) if i == 0 else None))
        if c not in {d.coordinate for d in robot.drives}:
            drives.append(Drive(c, names["ratio"], names["ia"]))
    params += [Parameter("zz_k", 3.0), Parameter("zz_d", 0.2)]
    c0 = robot.coordinates[0]
    force = Force("zz spring", c0, f"-zz_k*{c0}*(1 + {c0}**2) - zz_d*qd_{c0}*abs(qd_{c0})")
    return symbolic.validate(dataclasses.replace(
        robot, validated=False, parameters=tuple(params), frictions=robot.frictions + tuple(frictions),
        drives=robot.drives + tuple(drives), forces=robot.forces + (force,),
    ))


def close(ours, reference, rtol: float) -> None:
    scale = max(np.linalg.norm(reference), 1e-300)
    assert np.linalg.norm(np.asarray(ours, float).reshape(np.shape(reference)) - reference) <= rtol * scale


@pytest.mark.slow
@pytest.mark.parametrize("name", ROBOTS)
def test_c_casadi_and_sympy_agree_with_friction_drives_and_forces(name: str, tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        robot = with_every_term(symbolic.robots.load(name))
    model = symbolic.derive(robot)
    num = numeric_model(model)
    written = export.generate(model, tmp_path, ["c", "casadi"])
    assert written
    c = CModel(compile_shared(tmp_path / f"{name}.c", tmp_path / f"lib{name}.so"), name, model.n, len(robot.parameters))
    fns = {f: casadi.Function.load(str(tmp_path / f"{name}_{f}.casadi"))
           for f in ("inertia", "friction", "applied", "inverse_dynamics", "forward_dynamics")}
    amplitude = np.array([0.01 if ("_nu" in x or "_eta" in x) else 1.0 for x in robot.generalized_coordinates])
    rng = np.random.default_rng(10)
    for _ in range(10):
        q = amplitude * rng.uniform(-1, 1, model.n)
        qd = rng.choice([-1.0, 1.0], model.n) * rng.uniform(0.05, 2, model.n)  # away from the sign switch
        qdd = rng.uniform(-2, 2, model.n)
        p = num.p0 * rng.uniform(0.5, 2.0, num.p0.size)
        f, Q = num.friction(q, qd, p), num.applied(q, qd, p)
        assert np.abs(f).max() > 0 and np.abs(Q).max() > 0
        tau = num.inverse_dynamics(q, qd, qdd, p)
        for ours in (c.friction(q, qd, p), fns["friction"](q, qd, p)):
            close(ours, f, 1e-12)
        for ours in (c.applied(q, qd, p), fns["applied"](q, qd, p)):
            close(ours, Q, 1e-12)
        for ours in (c.inverse_dynamics(q, qd, qdd, p), fns["inverse_dynamics"](q, qd, qdd, p)):
            close(ours, tau, 1e-12)
        close(c.inertia(q, p), num.inertia(q, p), 1e-12)
        scale = np.linalg.norm(qdd) + np.linalg.norm(np.linalg.solve(num.inertia(q, p), tau))
        qdd_c, status = c.forward_dynamics(q, qd, tau, p)
        assert status == 0
        # np.array(...).ravel(), not np.ravel(...): a NumPy function on a CasADi DM warns (casadi 3.7, #2959)
        for ours in (qdd_c, np.array(fns["forward_dynamics"](q, qd, tau, p)).ravel(), num.forward_dynamics(q, qd, tau, p)):
            assert np.linalg.norm(np.asarray(ours) - qdd) <= 1e-10 * scale
