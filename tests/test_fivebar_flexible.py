"""Madill 3.13: the five-bar robot with link 5 flexible — Jacobian J(Q, x), the terms of D_f (3.76),
Π (3.75) and the height h of the beam's centre of mass, reproduced symbolically (one mode per
direction; the identities are linear in the modal vectors, so one mode exercises every term).

One printed equation disagrees: entry (1,1) of (J^v)ᵀRΞ₁J^Ω is printed (l₁C₁ − l₄C₂)(½l₅²C₂ − α_vᵀν);
the derivation gives (l₁C₁ − l₄C₂)(½l₅²C₂ − α_vᵀν S₂). Independently, by hand: J^v's first column is
(l₁C₁ − l₄C₂)(−S₀, C₀, 0)ᵀ, J^Ω's is (−S₂, −C₂, 0)ᵀ, Ξ₁J^Ω's first column is
(α_wᵀηC₂, −α_wᵀηS₂, α_vᵀνS₂ − ½l₅²C₂)ᵀ, and with R of (3.118) the α_w terms cancel (C₂² + S₂² = 1),
leaving (l₁C₁ − l₄C₂)(½l₅²C₂ − α_vᵀνS₂): the thesis dropped the factor S₂ (a typo; at the home
position q₂ = π it makes no difference, which may be how it went unnoticed). The test below checks
the corrected entry and that the printed one differs.
"""

from __future__ import annotations

import pytest
import sympy as sp

import symbolic
from symbolic.derivation.flexible import beam_jacobian, geometry, xi_matrices
from symbolic.derivation.simplify import reduce_pythagoras, trig_zero


@pytest.fixture(scope="module")
def setup():
    text = symbolic.robots.path("fivebar_flexible").read_text().replace("modes_v = 2", "modes_v = 1").replace("modes_w = 2", "modes_w = 1")
    model = symbolic.derive(symbolic.loads(text, "fivebar_flexible (1 mode)"))
    beam = model.robot.beams[0]
    return model, beam, geometry(beam)


def symbols(model, g):
    q0, q1, q2 = model.coordinates[:3]
    trig = (sp.cos(q0), sp.sin(q0), sp.cos(q1), sp.sin(q1), sp.cos(q2), sp.sin(q2), sp.cos(q2 - q1), sp.sin(q2 - q1))
    l1, l4, l5 = sp.symbols("l1 l4 l5", real=True)
    return trig, (l1, l4, l5)


def zero(matrix: sp.Matrix) -> bool:
    """Identically zero, up to rounding of the modal constants: they are 50-digit Floats, so where
    terms cancel a coefficient of that order (about 1e-50 times the terms') can remain."""
    return all(trig_zero(chop(reduce_pythagoras(e))) for e in matrix)


def chop(expr: sp.Expr) -> sp.Expr:
    return expr.xreplace({f: 0 for f in expr.atoms(sp.Float) if abs(f) < 1e-40})


def test_terms_of_flexible_inertia(setup) -> None:
    model, beam, g = setup
    kin, E = model.kinematics, model.expand
    (C0, S0, C1, S1, C2, S2, C21, S21), (l1, l4, l5) = symbols(model, g)
    xi1, xi2, xi3, calligraphic_a = xi_matrices(g)
    Jv, JO, R = E(kin.jacobian_v("e")), E(kin.jacobian_omega("e")), E(kin.rotation("e"))
    nu, eta = g.nu, g.eta
    a_nu, a_eta = (sp.Matrix(g.v.alpha).T * nu)[0], (sp.Matrix(g.w.alpha).T * eta)[0]
    bv, bw, av, aw = g.v.beta[0], g.w.beta[0], g.v.alpha[0], g.w.alpha[0]
    gamma = g.gamma
    nn, ee = (nu.T * nu)[0], (eta.T * eta)[0]
    jvjv = sp.Matrix([[(l1 * C1 - l4 * C2) ** 2 * l5, 0, 0], [0, l1**2 * l5, -l1 * l4 * l5 * C21], [0, -l1 * l4 * l5 * C21, l4**2 * l5]])
    assert zero(Jv.T * Jv * l5 - jvjv)
    printed = sp.Matrix(
        [
            [(l1 * C1 - l4 * C2) * (l5**2 / 2 * C2 - a_nu), 0, 0],
            [l1 * a_eta * S1, 0, l1 * (l5**2 / 2 * C21 - a_nu * S21)],
            [-l4 * a_eta * S2, 0, -l4 * l5**2 / 2],
        ]
    )
    corrected = printed.copy()
    corrected[0, 0] = (l1 * C1 - l4 * C2) * (l5**2 / 2 * C2 - a_nu * S2)
    ours = Jv.T * R * xi1 * JO
    assert zero(ours - corrected)
    assert not trig_zero((ours - printed)[0, 0])  # the printed entry is the typo described above
    jo_xi3_jo = sp.Matrix(
        [
            [ee + nn * S2**2 - 2 * bv * nu[0] * S2 * C2 + l5**3 / 3 * C2**2, 0, (bw * S2 * eta + C2 * (nu.T * gamma * eta))[0]],
            [0, 0, 0],
            [(bw * S2 * eta + C2 * (nu.T * gamma * eta))[0], 0, l5**3 / 3 + nn],
        ]
    )
    assert zero(JO.T * xi3 * JO - jo_xi3_jo)
    pi = sp.Matrix(
        [
            [(gamma * eta)[0] * S2, -l1 * av * C21, l4 * av + bv],
            [-(l1 * C1 - l4 * C2) * aw - (gamma.T * nu)[0] * S2 + bw * C2, 0, 0],
        ]
    )
    assert zero(calligraphic_a * R.T * Jv - xi2 * JO - pi)


def test_height_of_centre_of_mass(setup) -> None:
    """h = l₁S₁ − (l₄ + ½l₅)S₂ − (1/l₅)α_vᵀν C₂ (3.13, from (3.78)); no η: vertical sag is along y_e here."""
    model, beam, g = setup
    (C0, S0, C1, S1, C2, S2, C21, S21), (l1, l4, l5) = symbols(model, g)
    kin, E = model.kinematics, model.expand
    p_cm = sp.Matrix([l5 / 2, (sp.Matrix(g.v.alpha).T * g.nu)[0] / l5, (sp.Matrix(g.w.alpha).T * g.eta)[0] / l5])
    h = (E(kin.rotation("e")) * p_cm + E(kin.translation("e")))[2]
    expected = l1 * S1 - (l4 + l5 / 2) * S2 - (sp.Matrix(g.v.alpha).T * g.nu)[0] / l5 * C2
    assert trig_zero(h - expected)


def test_jacobian_along_the_beam(setup) -> None:
    """J(Q, x) of 3.13 with l_x = l₄ + x (3.122), v = φᵀν, w = ψᵀη."""
    model, beam, g = setup
    (C0, S0, C1, S1, C2, S2, C21, S21), (l1, l4, l5) = symbols(model, g)
    x = sp.Symbol("x", positive=True)
    J = model.expand(beam_jacobian(model.kinematics, beam, x, model.coordinates))
    p = g.point(x)
    v, w = p[1], p[2]
    phi_v, phi_w = g.modal_block(x)[1, 0], g.modal_block(x)[2, 1]
    lx = l4 + x
    expected = sp.Matrix(
        [
            [-(l1 * C1 - lx * C2 + v * S2) * S0 + w * C0, -l1 * S1 * C0, (v * C2 + lx * S2) * C0, phi_v * S2 * C0, phi_w * S0],
            [(l1 * C1 - lx * C2 + v * S2) * C0 + w * S0, -l1 * S1 * S0, (v * C2 + lx * S2) * S0, phi_v * S2 * S0, -phi_w * C0],
            [0, l1 * C1, v * S2 - lx * C2, -phi_v * C2, 0],
        ]
    )
    assert all(trig_zero(sp.expand(e)) for e in (J - expected))
