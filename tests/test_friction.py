"""Friction, drives and applied forces: the laws against their written forms, signs, dissipation,
Janot (16)–(17) through (12), rotor inertia in D, springs as stiffness, and bad input.

Tolerances: exact identities 1e-12 relative (numbers of order 1–100); forward dynamics inverts
inverse dynamics to 1e-10 relative away from q̇ = 0.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import models
import symbolic
from conftest import derived
from symbolic.derivation.friction import friction_force
from symbolic.errors import ModelError
from symbolic.numeric import natural_frequencies, numeric_model
from symbolic.description import Directional, Drive, Force, Friction, Parameter, Stribeck

def axis(tmp_path: Path, extra: str, parameters: str = "") -> symbolic.DynamicModel:
    """:func:`models.slider` with more ``parameters`` and the ``extra`` entries, written to tmp_path and derived."""
    path = tmp_path / "axis.toml"
    path.write_text(models.slider(parameters, extra))
    return symbolic.derive(symbolic.load(path))


def test_emps_friction_is_the_published_model() -> None:
    """EMPS: τ = M q̈ + Fv q̇ + Fc sign(q̇) + offset (Janot–Gautier–Brunot 2019), gravity across the axis."""
    model = derived("emps")
    M, Fv, Fc, offset = sp.symbols("M Fv Fc offset", real=True)
    q, qd, qdd = model.coordinates[0], model.velocities[0], model.accelerations[0]
    expected = M * qdd + Fv * qd + Fc * sp.sign(qd) + offset
    assert sp.simplify(model.inverse_dynamics[0] - expected) == 0
    assert model.gravity[0] == 0
    num = numeric_model(model)
    for v, a in [(0.1, 2.0), (-0.3, -1.0), (0.0, 0.5)]:
        published = 95.1089 * a + 203.5034 * v + 20.3935 * np.sign(v) - 3.1648
        assert num.inverse_dynamics([0.2], [v], [a]) == pytest.approx([published], rel=1e-12)


def test_directional_and_stribeck_laws(tmp_path: Path) -> None:
    """f = Fv±·q̇ + (Fc± + (Fs − Fc±)·exp(−(q̇/vs)²))·sign(q̇): each direction on its own coefficients."""
    model = axis(
        tmp_path,
        '\n[[friction]]\ncoordinate = "x"\nviscous = { positive = "Fvp", negative = "Fvn" }\n'
        'coulomb = { positive = "Fcp", negative = "Fcn" }\nstribeck = { static = "Fs", velocity = "vs" }\n',
        "Fvp = 1.7\nFvn = 2.4\nFcp = 2.0\nFcn = 2.6\nFs = 3.5\nvs = 0.05\n",
    )
    num = numeric_model(model)
    for v in (0.01, 0.2, -0.03, -0.4):
        fv, fc = (1.7, 2.0) if v > 0 else (2.4, 2.6)
        written = fv * v + (fc + (3.5 - fc) * math.exp(-((v / 0.05) ** 2))) * math.copysign(1.0, v)
        assert num.friction([0.0], [v]) == pytest.approx([written], rel=1e-12)
    assert num.friction([0.0], [0.0]) == pytest.approx([0.0], abs=0)  # sign(0) = 0: no force at rest


def test_janot_passive_joint_friction_is_16_and_17() -> None:
    """Janot (16)–(17): Γ_t2 = F_V2 q̇2 + F_C2 sign q̇2 + Γ_fc, Γ_t5 = F_V5R q̇5 + F_C5R sign q̇5 − Γ_fc,
    Γ_fc = F_V3R (q̇2 − q̇5) + F_C3R sign(q̇2 − q̇5), from friction declared at the passive joint q3 = q5 − q2
    and mapped by Lᵀ of (12)."""
    model = derived("janot_branch")
    s = {n: sp.Symbol(n, real=True) for n in ("fv1", "fc1", "off1", "fv2", "fc2", "off2", "fv5", "fc5", "off5", "fv3r", "fc3r")}
    qd1, qd2, qd5 = model.velocities
    gamma_fc = s["fv3r"] * (qd2 - qd5) + s["fc3r"] * sp.sign(qd2 - qd5)
    expected = [
        s["fv1"] * qd1 + s["fc1"] * sp.sign(qd1) + s["off1"],
        s["fv2"] * qd2 + s["fc2"] * sp.sign(qd2) + gamma_fc + s["off2"],
        s["fv5"] * qd5 + s["fc5"] * sp.sign(qd5) - gamma_fc + s["off5"],
    ]
    num = numeric_model(model)
    rng = np.random.default_rng(16)
    for _ in range(10):
        qd = rng.uniform(-2, 2, 3)
        p = num.p0 * rng.uniform(0.5, 2, num.p0.size) + rng.uniform(0.01, 0.1, num.p0.size)  # passive friction non-zero
        values = dict(zip(model.velocities, qd)) | dict(zip(model.parameter_symbols, p))
        written = np.array([float(e.xreplace(values)) for e in expected])
        assert np.allclose(num.friction(np.zeros(3), qd, p), written, rtol=1e-12, atol=0)


def test_rotor_inertia_enters_d_as_ia_ratio_squared(tmp_path: Path) -> None:
    plain = axis(tmp_path, "")
    driven = axis(tmp_path, '\n[[drive]]\ncoordinate = "x"\nratio = "N"\nrotor_inertia = "Ia"\ngain = "kt"\n',
                  "N = 12.5\nIa = 3.0e-4\nkt = 0.8\n")
    assert sp.simplify(driven.D[0, 0] - plain.D[0, 0] - sp.Symbol("Ia", real=True) * sp.Symbol("N", real=True) ** 2) == 0
    assert driven.robot.drives[0].gain == sp.Symbol("kt", real=True)


def test_cable_spring_is_a_stiffness(tmp_path: Path) -> None:
    """A [[force]] −k(x − x0) acts ON the system: τ = M ẍ + … + k(x − x0), and the linearised axis rings
    at √(k/M) (the textbook spring–mass frequency, an independent check of the sign)."""
    model = axis(tmp_path, '\n[[force]]\nname = "cable"\ncoordinate = "x"\nexpression = "-k*(x - x0) - d*qd_x"\n',
                 "k = 800.0\nx0 = 0.1\nd = 0.0\n")
    x, xd = model.coordinates[0], model.velocities[0]
    k, x0, d = sp.symbols("k x0 d", real=True)
    assert sp.simplify(model.applied[0] - (-k * (x - x0) - d * xd)) == 0
    num = numeric_model(model)
    assert num.inverse_dynamics([0.3], [0.0], [0.0]) == pytest.approx([800.0 * 0.2], rel=1e-12)
    omega, _ = natural_frequencies(model, q0=[0.1])
    assert omega == pytest.approx([math.sqrt(800.0 / 2.0)], rel=1e-12)


def test_forward_dynamics_inverts_inverse_dynamics_with_every_term(tmp_path: Path) -> None:
    """Away from q̇ = 0 (where sign switches), with friction of every kind, a drive and a force."""
    model = axis(
        tmp_path,
        '\n[[friction]]\ncoordinate = "x"\nviscous = "Fv"\ncoulomb = "Fc"\noffset = "off"\nstribeck = { static = "Fs", velocity = "vs" }\n'
        '\n[[drive]]\ncoordinate = "x"\nratio = "N"\nrotor_inertia = "Ia"\n'
        '\n[[force]]\nname = "spring"\ncoordinate = "x"\nexpression = "-k*x*abs(x) - d*qd_x"\n',
        "Fs = 2.5\nvs = 0.02\nN = 10.0\nIa = 1.0e-3\nk = 50.0\nd = 0.4\n",
    )
    num = numeric_model(model)
    rng = np.random.default_rng(3)
    for _ in range(20):
        q, qd, qdd = rng.uniform(-1, 1, 1), rng.choice([-1, 1]) * rng.uniform(0.01, 2, 1), rng.uniform(-5, 5, 1)
        tau = num.inverse_dynamics(q, qd, qdd)
        assert np.linalg.norm(num.forward_dynamics(q, qd, tau) - qdd) <= 1e-10 * (np.linalg.norm(qdd) + np.linalg.norm(tau))


coefficient = st.floats(0.0, 50.0)


@settings(max_examples=60, deadline=None)
@given(fvp=coefficient, fvn=coefficient, fcp=coefficient, fcn=coefficient, fs=coefficient,
       vs=st.floats(1e-3, 10.0), offset=st.floats(-10, 10), v=st.floats(-100, 100))
def test_friction_without_offset_dissipates(fvp, fvn, fcp, fcn, fs, vs, offset, v) -> None:
    """q̇·(f − offset) ≥ 0 for non-negative coefficients, whatever the law (plain, direction-dependent, Stribeck)."""
    velocity = sp.Symbol("v", real=True)
    entries = [
        Friction("v", fvp, fcp, offset),
        Friction("v", Directional(fvp, fvn), Directional(fcp, fcn), offset),
        Friction("v", Directional(fvp, fvn), fcp, offset, Stribeck(fs, vs)),
    ]
    for entry in entries:
        f = float(friction_force(entry, velocity).xreplace({velocity: sp.Float(v)}))
        assert v * (f - offset) >= 0.0


# -- bad input -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "extra, key, problem",
    [
        ('[[friction]]\ncoordinate = "y"\nviscous = "Fv"\n', "[[friction]] 'y' coordinate", "unknown coordinate 'y'"),
        ('[[friction]]\ncoordinate = "x"\nviscous = "Fv"\n[[friction]]\ncoordinate = "x"\ncoulomb = "Fc"\n',
         "[[friction]] 'x' coordinate", "two [[friction]] tables"),
        ('[[friction]]\ncoordinate = "x"\nviscous = "off"\n', "[[friction]] 'x' viscous", "must be >= 0"),
        ('[[friction]]\ncoordinate = "x"\ncoulomb = { positive = "Fc", negative = "-Fc" }\n',
         "[[friction]] 'x' coulomb.negative", "must be >= 0"),
        ('[[friction]]\ncoordinate = "x"\ncoulomb = "Fc"\nstribeck = { static = "Fc", velocity = "0" }\n',
         "[[friction]] 'x' stribeck.velocity", "must be > 0"),
        ('[[friction]]\ncoordinate = "x"\ncoulomb = "Fc"\nstribeck = { static = "Fc", velocity = "off" }\n',
         "[[friction]] 'x' stribeck.velocity", "must be > 0"),
        ('[[friction]]\ncoordinate = "x"\nviscous = "Fv"\ndamping = "Fv"\n', "[[friction]] #1", "unknown key(s) ['damping']"),
        ('[[force]]\nname = "spring"\ncoordinate = "x"\nexpression = "-kk*x"\n', "[[force]] 'spring' expression", "kk"),
        ('[[force]]\nname = "spring"\ncoordinate = "x"\nexpression = "-Fv*qd_y"\n', "[[force]] 'spring' expression", "qd_y"),
        ('[[force]]\nname = "spring"\ncoordinate = "z"\nexpression = "-Fv*x"\n', "[[force]] 'spring' coordinate", "unknown coordinate 'z'"),
        ('[[drive]]\ncoordinate = "x"\nrotor_inertia = "off"\n', "[[drive]] 'x' rotor_inertia", "must be >= 0"),
        ('[[drive]]\ncoordinate = "x"\nratio = "0"\n', "[[drive]] 'x' ratio", "must not be zero"),
    ],
)
def test_bad_friction_drive_and_force_entries(tmp_path: Path, extra: str, key: str, problem: str) -> None:
    path = tmp_path / "axis.toml"
    path.write_text(models.slider(extra="\n" + extra))
    with pytest.raises(ModelError) as info:
        symbolic.load(path)
    message = str(info.value)
    assert str(path) in message and key in message and problem in message, message
    assert "\n" not in message


def test_cli_reports_a_bad_friction_entry_in_one_line(tmp_path: Path) -> None:
    from symbolic.cli import main

    path = tmp_path / "axis.toml"
    path.write_text(models.slider(extra='\n[[friction]]\ncoordinate = "x"\nviscous = "-Fv"\n'))
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main(["-q", "derive", str(path)]) == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and "viscous" in lines[0] and str(path) in lines[0], lines


def test_python_spec_with_friction_drive_and_force() -> None:
    """The same entries built in Python validate to SymPy and derive like the file form."""
    raw = symbolic.Robot(
            name="axis",
            coordinates=("x",),
            parameters=(Parameter("M", 2.0), Parameter("Fv", 3.0), Parameter("k", 5.0), Parameter("Ia", 0.1)),
            frames=(symbolic.Frame("s", "base", d="x"),),
            bodies=(symbolic.Body("s", "s", "M"),),
            frictions=(Friction("x", viscous="Fv"),),
            drives=(Drive("x", ratio=2, rotor_inertia="Ia"),),
            forces=(Force("spring", "x", "-k*x"),),
            gravity=(0, "-9.81", 0),
    )
    robot = symbolic.validate(raw)
    assert raw.frictions[0].viscous == "Fv" and not raw.validated  # validation copies, never mutates
    assert robot.frictions[0].viscous == sp.Symbol("Fv", real=True) and robot.validated
    model = symbolic.derive(robot)
    x, xd, xdd = model.coordinates[0], model.velocities[0], model.accelerations[0]
    M, Fv, k, Ia = sp.symbols("M Fv k Ia", real=True)
    assert sp.simplify(model.inverse_dynamics[0] - ((M + 4 * Ia) * xdd + Fv * xd + k * x)) == 0
