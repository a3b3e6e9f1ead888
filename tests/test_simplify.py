"""The canonical trigonometric form (reduce_pythagoras) against an independent reference, and its speed.

The reference reduces by polynomial division (``sympy.rem`` modulo sin² + cos² − 1, one angle at a
time), the method the fast sparse-polynomial path replaced; both must give the same SymPy
expression (exact comparison, no tolerance). Expressions with floats take the slower route through
``sympy.expand`` and must agree with the reference as polynomials.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import derived
from symbolic.derivation.simplify import compact, reduce_pythagoras, tree_size, trig_monomials, collect_monomials

a, b = sp.symbols("a b", real=True)
q1, q2 = sp.symbols("q1 q2", real=True)

LEAVES = [a, b, q1, sp.Integer(2), sp.Integer(-3), sp.Rational(1, 2), sp.sqrt(a), 1 / b, b ** sp.Rational(-3, 2), sp.pi,
          sp.sin(q1), sp.cos(q1), sp.sin(q2), sp.cos(q2), sp.sin(q1 + q2), sp.cos(q1 - q2), sp.sin(2 * q1),
          sp.cos(q2 + sp.pi / 3), sp.sin(q1) ** 3]


def reference(expr: sp.Expr, eliminate: str) -> sp.Expr:
    """Reduce modulo s_k² + c_k² − 1 by polynomial division, in the sine (or cosine) of each angle."""
    expanded = sp.expand(sp.expand_trig(sp.expand(expr)))
    angles = sorted({t.args[0] for t in expanded.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    names, back = {}, {}
    for k, angle in enumerate(angles):
        s, c = sp.Symbol(f"_s{k}"), sp.Symbol(f"_c{k}")
        names[sp.sin(angle)], names[sp.cos(angle)] = s, c
        back[s], back[c] = sp.sin(angle), sp.cos(angle)
    poly = sp.expand(expanded.xreplace(names))
    for k in range(len(angles)):
        s, c = sp.Symbol(f"_s{k}"), sp.Symbol(f"_c{k}")
        poly = sp.expand(sp.rem(poly, s**2 + c**2 - 1, s if eliminate == "sin" else c))
    return sp.expand(poly.xreplace(back))


expressions = st.recursive(
    st.sampled_from(LEAVES),
    lambda children: st.one_of(
        st.tuples(children, children).map(lambda t: t[0] + t[1]),
        st.tuples(children, children).map(lambda t: t[0] * t[1]),
        st.tuples(children, st.integers(2, 3)).map(lambda t: t[0] ** t[1]),
    ),
    max_leaves=8,
)


@settings(max_examples=80, deadline=None)
@given(expressions, st.sampled_from(["sin", "cos"]))
def test_reduction_is_the_remainder_by_division(expr: sp.Expr, eliminate: str) -> None:
    assert reduce_pythagoras(expr, eliminate) == reference(expr, eliminate)


@settings(max_examples=30, deadline=None)
@given(expressions, st.sampled_from(["sin", "cos"]))
def test_expressions_with_floats_agree_as_polynomials(expr: sp.Expr, eliminate: str) -> None:
    """Floats take the sympy.expand route; the division's floating domain may print 2 as 2.0."""
    expr = expr + sp.Float("0.25") * sp.sin(q1) ** 2 * a
    assert sp.expand(reduce_pythagoras(expr, eliminate) - reference(expr, eliminate)) == 0


@settings(max_examples=40, deadline=None)
@given(expressions)
def test_trig_monomials_is_collect_of_the_reduction(expr: sp.Expr) -> None:
    assert trig_monomials(expr, [q1, q2]) == collect_monomials(reduce_pythagoras(expr), [q1, q2])


@settings(max_examples=40, deadline=None)
@given(expressions)
def test_tree_size_counts_every_use(expr: sp.Expr) -> None:
    shared = expr * (expr + 1)
    assert tree_size(shared) == sum(1 for _ in sp.preorder_traversal(shared))


def test_pythagoras_identity_vanishes() -> None:
    s, c = sp.sin(q1 + q2), sp.cos(q1 + q2)
    assert reduce_pythagoras(s**4 + 2 * s**2 * c**2 + c**4 - 1) == 0
    assert reduce_pythagoras(sp.sin(q1) ** 2, "sin") == 1 - sp.cos(q1) ** 2
    assert reduce_pythagoras(sp.sin(q1) ** 2, "cos") == sp.sin(q1) ** 2


def test_fivebar_entries_match_the_division(fivebar) -> None:
    for entry in list(fivebar.D.upper_triangular()) + [fivebar.potential_energy]:
        for eliminate in ("sin", "cos"):
            assert reduce_pythagoras(entry, eliminate) == reference(entry, eliminate)


@pytest.mark.slow
def test_panda_inertia_compacts_in_seconds_and_keeps_its_value() -> None:
    """D[1,1] of the Panda (4,052 operations expanded) took minutes through sympy.rem; compacted form
    equal to the entry at random configurations and nominal parameters to 1e-12 relative."""
    panda = derived("panda")
    entry = panda.D[1, 1]
    start = time.perf_counter()
    form = compact(entry, panda.coordinates)
    assert time.perf_counter() - start < 20  # about 0.6 s unloaded; generous for a shared CI machine
    values = panda.parameters
    rng = np.random.default_rng(15)
    for _ in range(5):
        point = dict(values) | {x: float(v) for x, v in zip(panda.coordinates, rng.uniform(-np.pi, np.pi, panda.n))}
        expected = float(entry.xreplace(point))
        assert float(form.xreplace(point)) == pytest.approx(expected, rel=1e-12, abs=1e-15)
