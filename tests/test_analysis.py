"""Decoupling and balancing analysis (Madill 4.2) and counterbalance design (4.2.4)."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np
import sympy as sp

import symbolic
from conftest import derived
from symbolic.derivation.analysis import counterbalance, decoupling
from symbolic.numeric import numeric_model
from symbolic.description.validation import with_parameters

S = {n: sp.Symbol(n, real=True) for n in "g l1 l2 l_c1 l_c2 l_c3 l_cr m1 m2 m3 m_r I1 I2 I3 I_r d3 d4 d6 m4 m6 mx3 my3 mx6".split()}
ALPHA3 = S["m3"] * S["l_c3"] * S["l2"] - S["m_r"] * S["l_cr"] * S["l1"]  # Madill (4.9)
BALANCE_43 = S["m1"] * S["l_c1"] + S["m3"] * S["l_c3"] + S["m_r"] * S["l1"]  # (4.3) as written after (4.10)
BALANCE_42 = S["m2"] * S["l_c2"] + S["m3"] * S["l2"] - S["m_r"] * S["l_cr"]  # (4.2) as written after (4.10)


def same_up_to_sign(a: sp.Expr, b: sp.Expr) -> bool:
    return sp.expand(a - b) == 0 or sp.expand(a + b) == 0


def test_fivebar_decoupling_is_alpha3(fivebar) -> None:
    analysis = decoupling(fivebar, kinds=["decoupling"])
    (condition,) = analysis.conditions
    assert condition.name == "D[q1,q2] = 0"
    assert same_up_to_sign(condition.expression, ALPHA3)
    assert condition.unit == "kg*m^2"
    assert condition.check(analysis.values).holds  # the nominal robot is decoupled


def test_fivebar_balancing_is_4_2_and_4_3(fivebar) -> None:
    analysis = decoupling(fivebar, kinds=["balancing"])
    expressions = [c.expression for c in analysis.conditions]
    assert len(expressions) == 2
    assert any(same_up_to_sign(e, BALANCE_43) for e in expressions)
    assert any(same_up_to_sign(e, BALANCE_42) for e in expressions)
    assert all(c.assuming_nonzero == (S["g"],) for c in analysis.conditions)
    # an unbalanced parameter set fails, by the amount of the combination
    unbalanced = decoupling(fivebar, {"l_c1": -0.1}, kinds=["balancing"])
    failing = unbalanced.offending("balancing")
    assert len(failing) == 1 and same_up_to_sign(failing[0].expression, BALANCE_43)
    check = failing[0].check(unbalanced.values)
    assert abs(abs(check.value) - 1.5 * 0.085) < 1e-12  # m1 · Δl_c1


def test_fivebar_constant_inertia_and_coriolis(fivebar) -> None:
    analysis = decoupling(fivebar, kinds=["constant_inertia", "coriolis"])
    by_name = {}
    for c in analysis.conditions:
        by_name.setdefault(c.name.split(" #")[0], []).append(c)
    assert "D[q1,q1] constant" not in by_name and "D[q2,q2] constant" not in by_name  # D11, D22 constant (4.10)
    d00 = by_name["D[q0,q0] constant"]
    assert any(c.feasible is False for c in d00)  # α1, α2 > 0: D00 keeps its q-dependence
    for row, other in (("q1", "q2"), ("q2", "q1")):
        for what in (other, f"{other}_dot"):
            conditions = by_name[f"coriolis row {row} free of {what}"]
            assert all(same_up_to_sign(c.expression, ALPHA3) for c in conditions)


def test_counterbalance_design_round_trip(fivebar) -> None:
    """Madill 4.2.4: l_cr from (4.2), l_c3 from (4.6), l_c1 from (4.3); re-derived model diagonal and gravity-free."""
    start = {"l_cr": 0.1, "l_c3": 0.2, "l_c1": -0.1}
    design = counterbalance(fivebar, ["l_cr", "l_c3", "l_c1"], parameters=start)
    assert design.feasible
    p = {k: v for k, v in fivebar.parameters.items()}
    m1, m2, m3, mr = (p[S[k]] for k in ("m1", "m2", "m3", "m_r"))
    l1, l2, lc2 = p[S["l1"]], p[S["l2"]], p[S["l_c2"]]
    l_cr = (m2 * lc2 + m3 * l2) / mr  # (4.2)
    l_c3 = mr * l_cr * l1 / (m3 * l2)  # (4.6)
    l_c1 = -(m3 * l_c3 + mr * l1) / m1  # (4.3)
    assert np.allclose([design.values["l_cr"], design.values["l_c3"], design.values["l_c1"]], [l_cr, l_c3, l_c1], rtol=1e-12)
    robot = with_parameters(fivebar.robot, **design.values)
    model = symbolic.derive(robot)
    again = decoupling(model, kinds=["decoupling", "balancing"])
    assert again.holds("decoupling") and again.holds("balancing")
    rng = np.random.default_rng(4)
    for _ in range(10):
        q = rng.uniform(-np.pi, np.pi, 3)
        D = numeric_model(model).inertia(q)
        assert abs(D[1, 2]) <= 1e-12 * np.abs(D).max()
        assert np.abs(numeric_model(model).gravity(q)).max() <= 1e-12 * 9.81 * (m1 + m2 + m3 + mr)


def test_counterbalance_reports_what_cannot_be_met(fivebar) -> None:
    design = counterbalance(fivebar, ["l_c1"], parameters={"l_cr": 0.1})
    assert not design.feasible
    assert any(same_up_to_sign(c.expression, BALANCE_42) for c in design.unmet)
    assert any(same_up_to_sign(c.expression, ALPHA3) for c in design.unmet)


def test_puma_cannot_be_decoupled() -> None:
    analysis = decoupling(derived("puma560"), kinds=["decoupling"])
    assert not analysis.holds("decoupling")
    offending = analysis.infeasible("decoupling")
    assert offending, "PUMA 560 has off-diagonal inertia terms that no parameter change keeping signs removes"
    assert all(not c.expression.free_symbols & set(derived("puma560").coordinates) for c in analysis.conditions)
    assert any(c.name.startswith("D[q1,q2]") for c in offending)


def test_janot_parallelogram_coupling_of_joints_2_and_5() -> None:
    """Independent physics: frame 3 sits at d3 along arm 2 (angle q2) and turns with q5 (q3 = q5 − q2);
    the handle support (link 4) translates with the end of link 3 (d4 at angle q5) but keeps its
    orientation (q4 = π/2 − q5); the rod (link 6) is carried by the lever at d6 (angle q5) and turns
    with q2. Cross terms in q̇2 q̇5 therefore come from m3·d3·(mx3, my3), m4·d3·d4 and m6·d6·mx6."""
    analysis = decoupling(derived("janot_branch"), kinds=["decoupling"])
    coupling = [c.expression for c in analysis.conditions if c.name.startswith("D[q2,q5]")]
    d3, d4, d6, m3, m4, m6, mx3, my3, mx6 = (S[k] for k in "d3 d4 d6 m3 m4 m6 mx3 my3 mx6".split())
    expected = [d3 * m3 * my3, d3 * d4 * m4 + d3 * m3 * mx3 + d6 * m6 * mx6]
    assert len(coupling) == 2
    assert all(any(same_up_to_sign(c, e) for c in coupling) for e in expected)


def test_analyze_json_contract() -> None:
    result = subprocess.run([sys.executable, "-m", "symbolic", "-q", "analyze", "fivebar", "--json", "--kinds", "decoupling,balancing"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["model"] == "fivebar"
    kinds = {c["kind"] for c in data["conditions"]}
    assert kinds == {"decoupling", "balancing"}
    for c in data["conditions"]:
        assert {"name", "kind", "expression", "holds"} <= set(c)
        assert c["holds"] is True
        with warnings.catch_warnings():
            expr = sp.sympify(c["expression"])  # our own output, a SymPy string form
        assert {s.name for s in expr.free_symbols} <= {p.name for p in symbolic.robots.load("fivebar").parameters}
