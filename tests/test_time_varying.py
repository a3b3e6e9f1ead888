"""Time t in [[force]] expressions (a disturbance periodic in time, e.g. mains interference), end to end.

A two-link arm with a time-dependent force on each joint: the model format refuses ``t`` everywhere
else; the derived model, NumericModel, the regressor and identification, the generated C and CasADi
and the simulator all carry the time, checked against closed forms written here (the force's own
formula evaluated with NumPy) and against an independent integration (SciPy's solve_ivp of
NumericModel's state derivative).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import casadi
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import models
import symbolic
import symbolic.export as export
import workflow_cases as cases
from c_library import CModel, compile_shared
from symbolic.cli import main
from symbolic.data import Measurements
from symbolic.identify.model import base_regressor, identify_model, model_base
from symbolic.numeric import numeric_model
from symbolic.numeric.base_parameters import regressor_function, theta_values
from symbolic.codegen.exported import function_specs, solved_specs
from symbolic.simulation.simulator import simulate

F1, F2 = 8.35, 50.0
MAINS = f'''
[[force]]
name = "mains"
coordinate = "q2"
expression = "-(Ps*sin(2*pi*{F1}*t) + Pc*cos(2*pi*{F1}*t))"

[[force]]
name = "hum"
coordinate = "q1"
expression = "-H*q1*sin(2*pi*{F2}*t)"
'''
VALUES = {"Ps": 0.07, "Pc": -0.03, "H": 0.2}


def mains_text() -> str:
    parameters = models.ARM_PARAMETERS + "".join(f"{k} = {v}\n" for k, v in VALUES.items())
    return models.arm(parameters=parameters, extra=MAINS)


def load(text: str, name: str = "<mains>"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return symbolic.loads(text, name)


@pytest.fixture(scope="module")
def model():
    return symbolic.derive(load(mains_text()))


def disturbance(q: np.ndarray, t: float) -> np.ndarray:
    """Q(q, t) of the two forces, from their formulas (on the system: τ = … − Q)."""
    w1, w2 = 2 * np.pi * F1 * t, 2 * np.pi * F2 * t
    return np.array([-VALUES["H"] * q[0] * np.sin(w2), -(VALUES["Ps"] * np.sin(w1) + VALUES["Pc"] * np.cos(w1))])


# -- the model format ---------------------------------------------------------------------------------

@pytest.mark.parametrize("edit, key, problem", [
    (("l1 = 0.4", "t = 0.4"), "[parameters]", "'t' is reserved for time in [[force]] expressions"),
    (('coordinates = ["q1", "q2"]', 'coordinates = ["q1", "t"]'), "coordinates", "'t' is reserved for time"),
    (('viscous = "Fv1"', 'viscous = "Fv1*t"'), "[[friction]] 'q1' viscous", "time 't' is allowed only in [[force]] expressions"),
    (('a = "0.3"', 'a = "0.3 + t"'), "[[frame]] '2' dh.a", "time 't' is allowed only in [[force]] expressions"),
    (('mass = "m2"', 'mass = "m2*t"'), "[[body]] 'link2' mass", "time 't' is allowed only in [[force]] expressions"),
])
def test_time_is_reserved_outside_forces(edit, key, problem) -> None:
    text = mains_text()
    assert text.count(edit[0]) >= 1
    with pytest.raises(symbolic.ModelError) as error:
        load(text.replace(edit[0], edit[1], 1), "m.toml")
    assert error.value.key == key and problem in error.value.problem, (error.value.key, error.value.problem)


def test_cli_refuses_time_outside_forces_in_one_line(tmp_path: Path, capsys) -> None:
    path = cases.model_file(tmp_path, mains_text().replace('viscous = "Fv2"', 'viscous = "Fv2*t"'))
    assert main(["derive", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "[[friction]] 'q2' viscous" in err and "only in [[force]]" in err


# -- derive and NumericModel ----------------------------------------------------------------------------

def test_the_derived_model_holds_time(model) -> None:
    assert model.time_varying and model.time.name == "t"
    assert not symbolic.derive(load(models.arm())).time_varying
    assert model.time in model.applied.free_symbols and model.time in model.inverse_dynamics.free_symbols
    assert model.time not in model.D.free_symbols and model.time not in model.gravity.free_symbols


def test_numeric_model_takes_the_time(model) -> None:
    num = numeric_model(model)
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-1, 1, (3, 2))
        t1, t2 = rng.uniform(0, 40, 2)
        np.testing.assert_allclose(num.applied(q, qd, t=t1), disturbance(q, t1), rtol=1e-12, atol=1e-14)
        # τ(t₁) − τ(t₂) at one state is Q(t₂) − Q(t₁): everything else is the same
        difference = num.inverse_dynamics(q, qd, qdd, t=t1) - num.inverse_dynamics(q, qd, qdd, t=t2)
        np.testing.assert_allclose(difference, disturbance(q, t2) - disturbance(q, t1), rtol=1e-10, atol=1e-13)
        tau = num.inverse_dynamics(q, qd, qdd, t=t1)
        np.testing.assert_allclose(num.forward_dynamics(q, qd, tau, t=t1), qdd, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(num.state_derivative(np.r_[q, qd], tau, t=t1), np.r_[qd, qdd], rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(num.bias(q, qd, t=t1), num.inverse_dynamics(q, qd, np.zeros(2), t=t1), rtol=1e-12)
        # ∂Q/∂q₁ = −H·sin(2π·F2·t) enters A; the mains force (no q) does not
        A1, _ = num.linearize(np.r_[q, qd], tau, t=t1)
        A2, _ = num.linearize(np.r_[q, qd], tau, t=t2)
        D = num.inertia(q)
        column = np.linalg.solve(D, [-VALUES["H"] * (np.sin(2 * np.pi * F2 * t1) - np.sin(2 * np.pi * F2 * t2)), 0.0])
        np.testing.assert_allclose((A1 - A2)[2:, 0], column, rtol=1e-8, atol=1e-10)


def test_a_model_without_time_is_unchanged() -> None:
    model = symbolic.derive(load(models.arm()))
    specs = {s.name: s.inputs for s in function_specs(model)}
    assert specs["applied"] == ("q", "qd", "p") and specs["inverse_dynamics"] == ("q", "qd", "qdd", "p")
    assert specs["regressor"] == ("q", "qd", "qdd", "p")
    assert solved_specs(model)[0].inputs == ("q", "qd", "tau", "p")
    assert base_regressor(model).time_varying is False
    num = numeric_model(model)
    q, qd = np.array([0.3, -0.2]), np.array([0.5, 0.1])
    assert np.array_equal(num.bias(q, qd, t=12.0), num.bias(q, qd))


# -- regressor and identification ---------------------------------------------------------------------------

def test_regressor_carries_the_time_columns(model) -> None:
    reg, base = model_base(model)
    assert {"Ps", "Pc", "H"} <= set(reg.names)  # a force coefficient that is one parameter keeps its name (docs/model-format.md)
    Y, theta = regressor_function(model, reg), theta_values(model, reg)
    num = numeric_model(model)
    rng = np.random.default_rng(2)
    samples = rng.uniform(-1, 1, (50, 3, 2))
    times = rng.uniform(0, 40, 50)
    for (q, qd, qdd), t in zip(samples, times):
        np.testing.assert_allclose(Y(q, qd, qdd, num.p0, t=t) @ theta, num.inverse_dynamics(q, qd, qdd, t=t), rtol=1e-10, atol=1e-12)
    beta = np.asarray(base.values, float)
    expected = np.array([num.inverse_dynamics(*s, t=t) for s, t in zip(samples, times)])
    for compiled in (False, True):
        evaluate = base_regressor(model, compiled=compiled)
        assert evaluate.time_varying
        got = evaluate(samples[:, 0], samples[:, 1], samples[:, 2], t=times) @ beta
        np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12)
    with pytest.raises(ValueError, match="depend on time: give the 50 sample times"):
        base_regressor(model)(samples[:, 0], samples[:, 1], samples[:, 2])


def test_identification_recovers_the_disturbance(model) -> None:
    """Noise-free forces of the model along a smooth trajectory: IDIM-LS (the regressor at each sample's
    time) recovers the force's parameters."""
    num = numeric_model(model)
    t = np.arange(0.0, 20.0, 1e-3)
    q, qd, qdd = cases.trajectory(2, t, seed=3)
    tau = np.array([num.inverse_dynamics(a, b, c, t=s) for a, b, c, s in zip(q, qd, qdd, t)])
    data = Measurements.from_arrays(t, ("q1", "q2"), q, tau, qd=qd, qdd=qdd)
    result = identify_model(model, data)
    for name, value in VALUES.items():
        assert result.parameters[name].value == pytest.approx(value, rel=1e-4), name


# -- generated C and CasADi -------------------------------------------------------------------------------

def test_c_and_casadi_take_the_time(model, tmp_path: Path) -> None:
    export.generate(model, tmp_path, ["c", "casadi"])
    header = (tmp_path / "arm.h").read_text()
    assert "void arm_applied(const double *q, const double *qd, const double *t, const double *p, double *Q);" in header
    assert "int arm_forward_dynamics(const double *q, const double *qd, const double *tau, const double *t, " \
           "const double *p, double *qdd);" in header
    assert "void arm_gravity(const double *q, const double *p, double *g);" in header
    num = numeric_model(model)
    lib = CModel(compile_shared(tmp_path / "arm.c", tmp_path / "libarm.so"), "arm", model.n, len(num.p0))
    fns = {f: casadi.Function.load(str(tmp_path / f"arm_{f}.casadi")) for f in ("applied", "inverse_dynamics", "forward_dynamics")}
    assert fns["applied"].name_in() == ["q", "qd", "t", "p"]
    rng = np.random.default_rng(4)
    for _ in range(10):
        q, qd, qdd = rng.uniform(-1, 1, (3, 2))
        # within 2 s: sin(2π·50·t) at t = 40 s has an angle of 12 566 rad, whose last bit (1.8e-12 rad)
        # depends on the order of the products 2·π·50·t, which the C, CasADi and NumPy each choose
        t = np.array([rng.uniform(0, 2)])
        p = num.p0 * rng.uniform(0.5, 2.0, num.p0.size)
        Q, tau = num.applied(q, qd, p, t=t[0]), num.inverse_dynamics(q, qd, qdd, p, t=t[0])
        # np.array(...).ravel(), not np.ravel(...): a NumPy function on a CasADi DM warns (casadi 3.7, #2959)
        for ours in (lib._call("applied", [q, qd, t, p], 2), np.array(fns["applied"](q, qd, t, p)).ravel()):
            assert np.linalg.norm(ours - Q) <= 1e-12 * np.linalg.norm(Q)
        for ours in (lib._call("inverse_dynamics", [q, qd, qdd, t, p], 2), np.array(fns["inverse_dynamics"](q, qd, qdd, t, p)).ravel()):
            assert np.linalg.norm(ours - tau) <= 1e-12 * np.linalg.norm(tau)
        expected = num.forward_dynamics(q, qd, tau, p, t=t[0])
        for ours in (lib._call("forward_dynamics", [q, qd, tau, t, p], 2), np.array(fns["forward_dynamics"](q, qd, tau, t, p)).ravel()):
            assert np.linalg.norm(ours - expected) <= 1e-10 * np.linalg.norm(qdd)
        A, B = num.linearize(np.r_[q, qd], tau, p, t=t[0])  # the derivative functions take t before p too
        for function, expected, size in (("A", A, 16), ("B", B, 8)):
            ours = lib._call(function, [q, qd, tau, t, p], size).reshape(expected.shape)
            assert np.linalg.norm(ours - expected) <= 1e-9 * np.linalg.norm(expected), function


# -- the simulator ---------------------------------------------------------------------------------------------

def test_the_simulator_applies_the_force_at_each_instant() -> None:
    """Replaying a torque (zero-order hold) on an axis with a disturbance in time: the simulator's RK4
    agrees with solve_ivp of NumericModel.state_derivative(t=…) to 1e-8 of the motion; started 3 s later
    (other phases of the disturbance), the motion differs."""
    text = models.axis(parameters="Fv = 0.3\nA = 0.12\n", friction='viscous = "Fv"',
                       extra=f'[[force]]\nname = "mains"\ncoordinate = "q"\nexpression = "-A*sin(2*pi*{F1}*t + 0.4)"\n')
    model = symbolic.derive(load(text))
    num = numeric_model(model)
    runs = []
    for start in (0.0, 3.0):
        t = start + np.arange(0, 2.0, 2e-3)
        tau = (0.05 * np.sin(2 * np.pi * 0.7 * (t - start)))[:, None]
        drive = Measurements.from_arrays(t, ("q",), np.zeros_like(tau), tau)
        simulated = np.asarray(simulate(model, drive, initial=(np.zeros(1), np.zeros(1))).simulated.q)[:, 0]
        x, reference = np.zeros(2), [0.0]
        for k in range(len(t) - 1):
            solution = solve_ivp(lambda s, y: num.state_derivative(y, tau[k], t=s), (t[k], t[k + 1]), x, rtol=1e-11, atol=1e-13)
            x = solution.y[:, -1]
            reference.append(x[0])
        reference = np.array(reference)
        assert np.max(np.abs(simulated - reference)) <= 1e-8 * np.max(np.abs(reference))
        runs.append(simulated)
    assert np.max(np.abs(runs[0] - runs[1])) > 1e-3 * np.max(np.abs(runs[0]))
