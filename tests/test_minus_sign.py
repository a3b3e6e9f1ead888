"""The derivation's sign test (symbolic.derivation.subexpressions.extracts_minus_sign) gives SymPy's
``could_extract_minus_sign`` answer on sums and products of the kind a derivation builds: monomials of symbols,
sines and cosines with rational coefficients, ties of positive and negative terms included (where it reads the
leading term's coefficient instead of comparing sort keys)."""

from __future__ import annotations

import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from symbolic.derivation.subexpressions import extracts_minus_sign

SYMBOLS = sp.symbols("m1 l2 q1 q2 x_0 x_1 I3")
FACTORS = [*SYMBOLS, sp.sin(SYMBOLS[2]), sp.cos(SYMBOLS[3]), sp.cos(SYMBOLS[2] + SYMBOLS[3])]

coefficients = st.sampled_from([sp.Integer(1), sp.Integer(-1), sp.Integer(2), sp.Integer(-3), sp.Rational(1, 2),
                                sp.Rational(-5, 4), sp.Float(0.25), sp.Float(-1.5)])
monomials = st.builds(lambda c, fs, ps: c * sp.Mul(*[f**p for f, p in zip(fs, ps)]), coefficients,
                      st.lists(st.sampled_from(FACTORS), min_size=1, max_size=3),
                      st.lists(st.integers(1, 3), min_size=3, max_size=3))


@settings(max_examples=400, deadline=None)
@given(st.lists(monomials, min_size=1, max_size=6), st.booleans())
def test_the_sign_test_is_sympys(terms: list[sp.Expr], with_number: bool) -> None:
    expr = sp.Add(*terms) + (sp.Integer(3) if with_number else 0)
    assert extracts_minus_sign(expr) == expr.could_extract_minus_sign(), expr
    assert extracts_minus_sign(-expr) == (-expr).could_extract_minus_sign(), -expr
