"""Madill's rigid five-bar robot (sections 3.13 and 4.2.3): symbolic equality with the thesis.

Every comparison here is exact: the difference is reduced to zero symbolically
(:func:`symbolic.simplify.trig_zero`), not sampled numerically.
"""

from __future__ import annotations

import sympy as sp

from symbolic.derivation.christoffel import block
from symbolic.derivation.simplify import collect_monomials, compact, trig_zero

q0, q1, q2 = sp.symbols("q0 q1 q2", real=True)
qd0, qd1, qd2 = sp.symbols("q0_dot q1_dot q2_dot", real=True)
S = {k: v for k, v in zip("g l1 l2 l4 l5 l_c1 l_c2 l_c3 l_cr m1 m2 m3 m_r I1 I2 I3 I_r J0".split(),
                          sp.symbols("g l1 l2 l4 l5 l_c1 l_c2 l_c3 l_cr m1 m2 m3 m_r I1 I2 I3 I_r J0", real=True))}
C0, S0, C1, S1, C2, S2 = sp.cos(q0), sp.sin(q0), sp.cos(q1), sp.sin(q1), sp.cos(q2), sp.sin(q2)

# Madill (4.7)–(4.9)
ALPHA1 = S["I1"] + S["I3"] + S["m1"] * S["l_c1"] ** 2 + S["m3"] * S["l_c3"] ** 2 + S["m_r"] * S["l1"] ** 2
ALPHA2 = S["I2"] + S["I_r"] + S["m2"] * S["l_c2"] ** 2 + S["m_r"] * S["l_cr"] ** 2 + S["m3"] * S["l2"] ** 2
ALPHA3 = S["m3"] * S["l_c3"] * S["l2"] - S["m_r"] * S["l_cr"] * S["l1"]

# Madill (4.10); J0 (turntable, base rotor) is the one term the thesis leaves out, on the q0 diagonal
D_410 = sp.Matrix(
    [
        [ALPHA1 * C1**2 + ALPHA2 * C2**2 + 2 * ALPHA3 * C1 * C2 + S["J0"], 0, 0],
        [0, ALPHA1, ALPHA3 * sp.cos(q2 - q1)],
        [0, ALPHA3 * sp.cos(q2 - q1), ALPHA2],
    ]
)


def test_inertia_matrix_is_madill_4_10(fivebar) -> None:
    difference = fivebar.D - D_410
    assert all(trig_zero(e) for e in difference)


def test_compact_form_shows_alphas(fivebar) -> None:
    """The reviewer's form: entries collected so that α1, α2, α3 of (4.7)–(4.9) appear as such."""
    D = fivebar.D
    assert compact(D[1, 1], fivebar.coordinates) == ALPHA1
    assert compact(D[2, 2], fivebar.coordinates) == ALPHA2
    coefficient, trig = compact(D[1, 2], fivebar.coordinates).as_independent(q1, q2)
    assert trig == sp.cos(q1 - q2) and sp.expand(coefficient - ALPHA3) == 0
    monomials = collect_monomials(compact(D[0, 0], fivebar.coordinates), fivebar.coordinates)
    assert set(monomials) == {C1**2, C2**2, C1 * C2, sp.Integer(1)}
    assert sp.expand(monomials[C1**2] - ALPHA1) == 0
    assert sp.expand(monomials[C2**2] - ALPHA2) == 0
    assert sp.expand(monomials[C1 * C2] - 2 * ALPHA3) == 0
    assert monomials[sp.Integer(1)] == S["J0"]


def test_coriolis_vector_under_decoupling(fivebar) -> None:
    """Madill 4.2.3: with α3 = 0 the Coriolis/centripetal vector is the printed one."""
    decoupled = {S["l_c3"]: S["m_r"] * S["l_cr"] * S["l1"] / (S["m3"] * S["l2"])}
    alpha1 = ALPHA1.xreplace(decoupled)
    alpha2 = ALPHA2.xreplace(decoupled)
    expected = sp.Matrix(
        [
            -2 * (alpha1 * C1 * S1 * qd1 + alpha2 * C2 * S2 * qd2) * qd0,
            alpha1 * C1 * S1 * qd0**2,
            alpha2 * C2 * S2 * qd0**2,
        ]
    )
    h = fivebar.coriolis_vector.xreplace(decoupled)
    assert all(trig_zero(sp.together(e)) for e in (h - expected))
    # rows q1, q2 free of each other's coordinate and velocity (derivatives vanish identically)
    for row, other in ((1, (q2, qd2)), (2, (q1, qd1))):
        assert all(trig_zero(sp.together(sp.diff(h[row], x))) for x in other)


def test_coriolis_vector_general_alpha3(fivebar) -> None:
    """Without decoupling, (3.82) with the Christoffel symbols of D(4.10) (computed here from (4.10))."""
    q = [q0, q1, q2]
    qd = sp.Matrix([qd0, qd1, qd2])
    expected = []
    for k in range(3):
        Ck = sp.Matrix(3, 3, lambda i, j: (sp.diff(D_410[k, j], q[i]) + sp.diff(D_410[k, i], q[j]) - sp.diff(D_410[i, j], q[k])) / 2)
        expected.append((qd.T * Ck * qd)[0])
    assert all(trig_zero(e) for e in (fivebar.coriolis_vector - sp.Matrix(expected)))


def test_potential_energy_is_madill(fivebar) -> None:
    """V = g((m1 l_c1 + m3 l_c3 + m_r l1) S1 + (m2 l_c2 + m3 l2 − m_r l_cr) S2), section 4.2.3."""
    g, s = S["g"], S
    V = g * ((s["m1"] * s["l_c1"] + s["m3"] * s["l_c3"] + s["m_r"] * s["l1"]) * S1 + (s["m2"] * s["l_c2"] + s["m3"] * s["l2"] - s["m_r"] * s["l_cr"]) * S2)
    assert trig_zero(fivebar.potential_energy - V)
    assert all(trig_zero(e) for e in (fivebar.gravity - sp.Matrix([sp.diff(V, x) for x in (q0, q1, q2)])))


def test_transform_and_jacobians_of_frame_e(fivebar) -> None:
    """H_0^e (3.118), J^v (3.120), J^Ω (3.121)."""
    l1, l4 = S["l1"], S["l4"]
    H = sp.Matrix(
        [
            [-C0 * C2, C0 * S2, S0, (l1 * C1 - l4 * C2) * C0],
            [-S0 * C2, S0 * S2, -C0, (l1 * C1 - l4 * C2) * S0],
            [-S2, -C2, 0, l1 * S1 - l4 * S2],
            [0, 0, 0, 1],
        ]
    )
    Jv = sp.Matrix(
        [
            [-(l1 * C1 - l4 * C2) * S0, -l1 * S1 * C0, l4 * S2 * C0],
            [(l1 * C1 - l4 * C2) * C0, -l1 * S1 * S0, l4 * S2 * S0],
            [0, l1 * C1, -l4 * C2],
        ]
    )
    JO = sp.Matrix([[-S2, 0, 0], [-C2, 0, 0], [0, 0, 1]])
    kin = fivebar.kinematics
    assert all(trig_zero(e) for e in (fivebar.expand(kin.transform("e")) - H))
    assert all(trig_zero(e) for e in (fivebar.expand(kin.jacobian_v("e")) - Jv))
    assert all(trig_zero(e) for e in (fivebar.expand(kin.jacobian_omega("e")) - JO))


def test_rigid_beam_jacobian(fivebar) -> None:
    """J(Q, x) of 3.13 with v = w = 0 at the tip x = l5 (l_x = l4 + x, (3.122))."""
    lx = S["l4"] + S["l5"]
    l1 = S["l1"]
    J = sp.Matrix(
        [
            [-(l1 * C1 - lx * C2) * S0, -l1 * S1 * C0, lx * S2 * C0],
            [(l1 * C1 - lx * C2) * C0, -l1 * S1 * S0, lx * S2 * S0],
            [0, l1 * C1, -lx * C2],
        ]
    )
    assert all(trig_zero(e) for e in (fivebar.jacobian() - J))


def test_literal_381_has_same_quadratic_form(fivebar) -> None:
    """C = Z·∂D/∂Qᵀ as printed (3.81) and the symmetric Christoffel form give the same (3.82).

    docs/contracts.md: the literal blocks are not symmetric; their symmetric part is c_ijk.
    """
    literal = fivebar.christoffel_literal()
    symmetric = fivebar.christoffel
    qd = sp.Matrix([qd0, qd1, qd2])
    asymmetric = False
    for k in range(3):
        Lk, Ck = block(literal, k), block(symmetric, k)
        assert all(trig_zero(e) for e in ((Lk + Lk.T) / 2 - Ck))
        assert trig_zero((qd.T * (Lk - Ck) * qd)[0])
        asymmetric |= not all(trig_zero(e) for e in (Lk - Lk.T))
    assert asymmetric, "the literal (3.81) blocks were expected to be non-symmetric for this robot"


def test_christoffel_symbol_formula(fivebar) -> None:
    """c_ijk of Madill 3.9.1 from (4.10) directly, e.g. c_011 = ½ ∂d_10/∂q0 + ... ; all 27 symbols."""
    q = [q0, q1, q2]
    for i in range(3):
        for j in range(3):
            for k in range(3):
                expected = (sp.diff(D_410[k, j], q[i]) + sp.diff(D_410[k, i], q[j]) - sp.diff(D_410[i, j], q[k])) / 2
                assert trig_zero(fivebar.christoffel_symbol(i, j, k) - expected)
