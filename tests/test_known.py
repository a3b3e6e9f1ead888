"""Known values stay known, results stay physical (issue 21 §3; symbolic.identify.known).

* A hub with a link on a torsional spring, the truth built here: the hub angle follows a Fourier series,
  the deflection a1 the spring's own equation J_l(q̈1 + ä1) + Ks·a1 + Ds·ȧ1 = 0 (integrated to 1e-10),
  and the hub's torque is (J_h + J_l)q̈1 + J_l·ä1 + Fv·q̇1 + Fc·sign(q̇1) with 5 % current-like noise;
  both angles are read by 17-bit encoders. a1 has no actuator: τ_a1 = 0.
* ``fixed = true``, ``--fix`` and the values written inline give the same fit (1e-12).
* Identification refuses the homogeneous equation of a1 and names what to fix; with the inertias fixed
  the stiffness is recovered within 3σ; the workflow holds the link's inertia and says so.
* A ``max`` that the estimate would cross is active: the value is the bound, the others are the least
  squares with it held there (an independent lstsq), and the report says so.
* A fit that would give a negative mass writes a file that loads (the mass at its bound 0); a value the
  loader refuses for a reason no bound covers is not written and the reason is printed.
* Every refusal is one line.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import symbolic
from symbolic.cli import main
from symbolic.data import Measurements, write
from symbolic.description.modelfile import with_loadable_values
from symbolic.identify.known import fixed_symbols, polynomial_lower_bound
from symbolic.identify.least_squares import solve
from symbolic.identify.model import identify_model
from symbolic.workflow import diagnose
from symbolic.workflow.dataset import load_sets
from symbolic.workflow.terms import fit_nominal, model_terms

from models import carriage, hub_spring

TRUTH = {"J_h": 0.02, "J_l": 0.004, "Ks": 0.7, "Ds": 0.003, "Fv1": 0.01, "Fc1": 0.02}
COUNTS = 2**17  # encoder counts per revolution


def hub_model(tmp_path: Path, **kind: bool) -> symbolic.DynamicModel:
    path = tmp_path / f"hub_{'_'.join(k for k, v in kind.items() if v) or 'plain'}.toml"
    path.write_text(hub_spring(**kind), encoding="utf-8")
    return symbolic.derive(symbolic.load(path))


def hub_motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q1, q̇1, q̈1: seven harmonics of 0.2 Hz with amplitudes falling as 1/k."""
    rng = np.random.default_rng(1)
    wf, k = 2 * np.pi * 0.2, np.arange(1, 8)
    a, b = rng.normal(0, 1, 7) / k, rng.normal(0, 1, 7) / k
    phase = np.outer(np.atleast_1d(t), k * wf)
    q = np.sin(phase) @ (a / (wf * k)) - np.cos(phase) @ (b / (wf * k))
    return q, np.cos(phase) @ a + np.sin(phase) @ b, -(np.sin(phase) * k * wf) @ a + (np.cos(phase) * k * wf) @ b


@pytest.fixture(scope="module")
def hub_data() -> Measurements:
    seconds, rate = 30.0, 1000.0
    t = np.arange(0.0, seconds, 1.0 / rate)
    J_h, J_l, Ks, Ds, Fv, Fc = (TRUTH[k] for k in ("J_h", "J_l", "Ks", "Ds", "Fv1", "Fc1"))  # noqa: N806

    def deflection(time: float, x: np.ndarray) -> list[float]:
        qdd = hub_motion(time)[2][0]
        return [x[1], -qdd - (Ks * x[0] + Ds * x[1]) / J_l]

    a, ad = solve_ivp(deflection, (0.0, seconds), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, method="DOP853").y
    q1, qd1, qdd1 = hub_motion(t)
    add = -qdd1 - (Ks * a + Ds * ad) / J_l
    tau1 = (J_h + J_l) * qdd1 + J_l * add + Fv * qd1 + Fc * np.sign(qd1)
    tau1 = tau1 + 0.05 * np.std(tau1) * np.random.default_rng(11).normal(size=len(t))
    step = 2 * np.pi / COUNTS
    q = np.round(np.column_stack([q1, a]) / step) * step
    return Measurements.from_arrays(t, ["q1", "a1"], q, np.column_stack([tau1, np.zeros_like(t)]))


def test_homogeneous_equation_is_refused_with_what_to_fix(tmp_path: Path, hub_data: Measurements) -> None:
    model = hub_model(tmp_path)
    with pytest.raises(symbolic.IdentificationError) as caught:
        identify_model(model, hub_data)
    message = str(caught.value)
    assert "\n" not in message
    assert "coordinate a1 has no actuator" in message
    for name in ("ZZ_link", "Ds", "Ks", "J_l"):  # θ = Ds, Ks exactly: the parameters' names
        assert name in message
    assert "--fix J_l" in message


def test_the_refusal_is_warranted(tmp_path: Path, hub_data: Measurements) -> None:
    """Without the check, weighted least squares on these data puts the stiffness far from the truth while
    its σ claims a few per cent: the homogeneous rows' noise pulls the scale of J_l, Ds, Ks towards zero."""
    from symbolic.identify.model import base_regressor, model_base
    from symbolic.identify.processing import observe

    model = hub_model(tmp_path)
    _, base = model_base(model)
    plain = solve(observe(hub_data, base_regressor(model), len(base.names)), base.names)
    ks = plain["Ks"]
    assert abs(ks.value - TRUTH["Ks"]) > 10 * ks.sigma
    assert abs(ks.value - TRUTH["Ks"]) > 0.3 * TRUTH["Ks"]


def test_fixing_the_inertias_recovers_the_stiffness(tmp_path: Path, hub_data: Measurements) -> None:
    result = identify_model(hub_model(tmp_path), hub_data, fix=["J_h", "J_l"])
    assert result.fixed == {"J_h": 0.02, "J_l": 0.004}
    assert set(result.parameters) == {"Ks", "Ds", "Fv1", "Fc1"}
    for name in ("Ks", "Ds", "Fv1", "Fc1"):
        p = result.parameters[name]
        assert abs(p.value - TRUTH[name]) <= 3 * p.sigma, (name, p.value, p.sigma)
    assert result.parameters["Ks"].relative_sigma < 1.0
    assert result.identification.fixed == ("ZZ_hub", "ZZ_link")
    assert result.identification["ZZ_link"].sigma == 0.0


def test_fixed_true_fix_and_inline_agree(tmp_path: Path, hub_data: Measurements) -> None:
    by_file = identify_model(hub_model(tmp_path, fixed=True), hub_data)
    by_flag = identify_model(hub_model(tmp_path), hub_data, fix=["J_h", "J_l"])
    inline = hub_model(tmp_path, inline=True)
    estimation = load_sets(inline.robot.generalized_coordinates, hub_data, None, hub_data, None)[0]  # all the data
    written = fit_nominal(model_terms(inline), estimation)
    kept = fit_nominal(model_terms(hub_model(tmp_path, fixed=True), fixed_symbols(hub_model(tmp_path, fixed=True))),
                       estimation)
    assert set(written.parameters) == {"Ks", "Ds", "Fv1", "Fc1"}
    for name, reference in written.parameters.items():
        for other in (by_file.parameters[name], by_flag.parameters[name], kept.parameters[name]):
            assert other.value == pytest.approx(reference.value, rel=1e-12, abs=0)
            assert other.sigma == pytest.approx(reference.sigma, rel=1e-12, abs=0)
    data = tmp_path / "hub.csv"
    write(hub_data, data)
    model = tmp_path / "hub_plain.toml"
    own = identify_model(hub_model(tmp_path), data, fix=["J_h", "J_l"])  # the CSV's round trip
    code, out = _run(["identify", str(model), str(data), "--fix", "J_h,J_l", "--json"])
    assert code == 0
    reported = json.loads(out)
    assert reported["fixed"] == {"J_h": 0.02, "J_l": 0.004}
    for name, p in own.parameters.items():
        assert reported["parameters"][name]["value"] == pytest.approx(p.value, rel=1e-12, abs=0)


@pytest.mark.filterwarnings("ignore:divide by zero")  # a1's per-coordinate gap: ‖τ_a1‖ = 0, relative to nothing
def test_the_workflow_holds_the_link_inertia_and_says_so(tmp_path: Path, hub_data: Measurements) -> None:
    estimation = load_sets(("q1", "a1"), hub_data, None, None, None)[0]
    fit = fit_nominal(model_terms(hub_model(tmp_path)), estimation)
    assert len(fit.notes) == 1 and "ZZ_link (J_l) is held at the model file's value 0.004" in fit.notes[0]
    assert "J_l" not in fit.parameters
    ks = fit.parameters["Ks"]
    assert abs(ks.value - TRUTH["Ks"]) <= 3 * ks.sigma
    result = diagnose(hub_model(tmp_path), hub_data, fix=["J_l"], effects=[])
    assert not any("no actuator" in n for n in result.notes)
    # the file's Ks (1.2) is named a correction: the gap before holds it at the file's value, the patched model's
    # fit (after) identifies it, with J_l held there too
    assert [c["parameter"] for c in result.corrections] == ["Ks"] and "Ks" not in result.before.nominal.parameters
    ks = result.after.nominal.parameters["Ks"]
    assert abs(ks.value - TRUTH["Ks"]) <= 3 * ks.sigma


# -- bounds -----------------------------------------------------------------------------------------


def axis(tmp_path: Path, mass: str = "", viscous: str = "", body_mass: str = "M", extra: str = "") -> Path:
    path = tmp_path / "axis.toml"
    path.write_text(carriage(mass, viscous, body_mass, extra), encoding="utf-8")
    return path


def axis_data(M: float, Fv: float, Fc: float, noise: float = 0.01) -> Measurements:  # noqa: N803
    t = np.arange(0.0, 20.0, 1e-3)
    w = 2 * np.pi * np.array([0.3, 0.7, 1.3])
    q = np.sin(np.outer(t, w)) @ np.array([0.2, 0.05, 0.01])
    qd = (np.cos(np.outer(t, w)) * w) @ np.array([0.2, 0.05, 0.01])
    qdd = -(np.sin(np.outer(t, w)) * w**2) @ np.array([0.2, 0.05, 0.01])
    tau = M * qdd + Fv * qd + Fc * np.sign(qd)
    tau = tau + noise * np.std(tau) * np.random.default_rng(3).normal(size=len(t))
    return Measurements.from_arrays(t, ["q"], q[:, None], tau[:, None], qd=qd[:, None], qdd=qdd[:, None])


def test_a_max_that_becomes_active(tmp_path: Path) -> None:
    model = symbolic.derive(symbolic.load(axis(tmp_path, viscous=", max = 1.5")))
    data = axis_data(3.0, 2.0, 0.4)
    result = identify_model(model, data)
    ident = result.identification
    assert ident.at_bound == {"Fv": "max"}  # θ = Fv exactly: the model parameter's name
    assert ident["Fv"].value == 1.5
    assert abs(ident.unconstrained["Fv"] - 2.0) <= 3 * ident["Fv"].sigma  # what the data alone say
    assert result.parameters["Fv"].bound == "max" and result.parameters["Fv"].value == 1.5
    # the others: least squares with Fv held at 1.5, computed independently
    observation = result.observation
    k = list(ident.names).index("Fv")
    rest = [j for j in range(len(ident.names)) if j != k]
    reference = np.linalg.lstsq(observation.W[:, rest], observation.y - 1.5 * observation.W[:, k], rcond=None)[0]
    np.testing.assert_allclose(ident.values[rest], reference, rtol=1e-10)
    assert "(at its max; the data alone give 2" in ident.table()
    assert result.to_dict()["parameters"]["Fv"]["at_bound"] == "max"


def test_a_negative_mass_is_not_written(tmp_path: Path) -> None:
    """The data's 'mass' is negative: the role of M (a body's mass) bounds it at 0, and the file written
    loads."""
    path = axis(tmp_path)
    data = tmp_path / "axis.csv"
    write(axis_data(-0.5, 1.0, 0.5), data)
    out = tmp_path / "identified.toml"
    code, text = _run(["identify", str(path), str(data), "--out", str(out)])
    assert code == 0
    assert "(at its min)" in text
    written = symbolic.load(out)
    assert {p.name: p.value for p in written.parameters}["M"] == 0.0


def test_a_value_the_loader_refuses_is_kept_with_its_reason(tmp_path: Path) -> None:
    """The body's mass is M·s with s fixed: M has no sign by its role (the mass expression holds two
    parameters), so the fit is not bounded; the negative value is not written, and the output says why."""
    path = axis(tmp_path, body_mass="M*s", extra="s = { value = 1.0, fixed = true }\n")
    data = tmp_path / "axis.csv"
    write(axis_data(-0.5, 1.0, 0.5), data)
    out = tmp_path / "identified.toml"
    code, text = _run(["identify", str(path), str(data), "--out", str(out), "--json"])
    assert code == 0
    report = json.loads(text)
    assert report["parameters"]["M"]["value"] < 0
    assert set(report["kept"]) == {"M"} and "mass" in report["kept"]["M"]
    written = {p.name: p.value for p in symbolic.load(out).parameters}
    assert written["M"] == 2.0 and written["Fv"] == pytest.approx(report["parameters"]["Fv"]["value"])


def test_with_loadable_values_never_returns_unloadable_text(tmp_path: Path) -> None:
    text = axis(tmp_path).read_text()
    out, kept = with_loadable_values(text, {"M": -1.0, "Fv": 3.0, "Fc": -0.1})
    assert set(kept) == {"M", "Fc"}
    loaded = {p.name: p.value for p in symbolic.loads(out).parameters}
    assert loaded == {"M": 2.0, "Fv": 3.0, "Fc": 0.5}
    assert "\n" not in kept["M"] and "\n" not in kept["Fc"]


# -- the model file and the command line ------------------------------------------------------------

@pytest.mark.parametrize("entry, problem", [
    ('M = { value = 2.0, min = 3 }', "value 2 is below min = 3"),
    ('M = { value = 2.0, max = 1 }', "value 2 is above max = 1"),
    ('M = { value = 2.0, min = 3, max = 1 }', "min = 3 is not below max = 1"),
    ('M = { value = 2.0, min = 2, max = 2 }', "min = 2 is not below max = 2 (to keep a value, write fixed = true)"),
    ('M = { value = 2.0, fixed = "yes" }', "expected true or false"),
    ('M = { value = 2.0, min = "0" }', "min must be a number"),
    ('M = { value = 2.0, lower = 0 }', "unknown key(s) ['lower']"),
])
def test_bad_entries_are_one_line_errors(tmp_path: Path, entry: str, problem: str) -> None:
    text = axis(tmp_path).read_text().replace('M = { value = 2.0, unit = "kg" }', entry)
    with pytest.raises(symbolic.ModelError) as caught:
        symbolic.loads(text, "axis.toml")
    assert problem in str(caught.value) and "\n" not in str(caught.value)
    assert str(caught.value).startswith("axis.toml: [parameters] M")


def test_unknown_fix_names_are_refused(tmp_path: Path) -> None:
    path = axis(tmp_path)
    data = tmp_path / "axis.csv"
    write(axis_data(2.0, 1.0, 0.5), data)
    for command in ("identify", "diagnose"):
        extra = ["--out", str(tmp_path / "d")] if command == "diagnose" else []
        code, _, err = _run([command, str(path), str(data), "--fix", "M,mass", *extra], errors=True)
        assert code == 2
        assert err.count("\n") == 1 and "--fix: unknown parameter(s) mass (the model's parameters: M, Fv, Fc)" in err


def test_the_not_separable_error_is_one_line_on_the_command_line(tmp_path: Path, hub_data: Measurements) -> None:
    hub_model(tmp_path)
    data = tmp_path / "hub.csv"
    write(hub_data, data)
    code, _, err = _run(["identify", str(tmp_path / "hub_plain.toml"), str(data)], errors=True)
    assert code == 2 and err.count("\n") == 1 and "--fix J_l" in err


def _run(argv: list[str], errors: bool = False):
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["-q", *argv])
    return (code, out.getvalue(), err.getvalue()) if errors else (code, out.getvalue())


def test_the_lower_bound_of_a_parallel_axis_sum() -> None:
    """A base parameter with products of unknowns, I + m2·c2² + m3·(c3² + 2·0.316·c3 + 0.316²) + 0.1·m4
    (inertia I and masses ≥ 0, centres c free): each mass's polynomial in its centre is a square, ≥ 0, so the
    sum is ≥ 0 — and ≥ 1.5·0.1 + 2·0.2 = 0.55 when m4 ≥ 1.5 and m2 ≥ 2 with the square shifted by 0.2; a
    negative inertia term or a cross product of centres leaves it unbounded (−∞), as does a mass whose
    polynomial dips below 0 without an upper bound on the mass."""
    inertia, m2, m3, m4, c2, c3, other = sp.symbols("I m2 m3 m4 c2 c3 J")
    free = (0.0, np.inf)
    bounds = {inertia: free, m2: free, m3: free, m4: free, other: free}
    square = m3 * (c3**2 + 0.632 * c3 + 0.099856)  # 0.316² = 0.099856: a square with rounded numbers
    assert polynomial_lower_bound(inertia + m2 * c2**2 + square + 0.1 * m4, bounds) == 0.0
    shifted = {**bounds, m4: (1.5, np.inf), m2: (2.0, np.inf)}
    assert polynomial_lower_bound(inertia + m2 * (c2**2 + 0.2) + square + 0.1 * m4, shifted) == pytest.approx(0.55)
    assert polynomial_lower_bound(inertia - other + m2 * c2**2, bounds) == -np.inf
    assert polynomial_lower_bound(inertia + m2 * c2 * c3, bounds) == -np.inf
    assert polynomial_lower_bound(m2 * (c2**2 - 1), bounds) == -np.inf
    assert polynomial_lower_bound(m2 * (c2**2 - 1), {m2: (0.0, 3.0)}) == pytest.approx(-3.0)
