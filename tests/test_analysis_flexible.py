"""Madill 4.2.1 on the flexible five-bar: the sag of link 5 breaks the gravity balance (h contains α_vᵀν·C₂),
and for the thesis's beam the residual torque is negligible."""

from __future__ import annotations

import numpy as np
import sympy as sp

from conftest import derived
from symbolic.derivation.analysis import decoupling, flexible_conditions
from symbolic.numeric.statics import residual_imbalance


def test_balancing_conditions_broken_by_modal_coordinates() -> None:
    model = derived("fivebar_flexible")
    analysis = decoupling(model, kinds=["balancing"])
    rigid_only = [c for c in analysis.conditions if c not in flexible_conditions(analysis)]
    assert rigid_only and all(c.check(analysis.values).holds for c in rigid_only)  # balanced when undeflected
    flexible = flexible_conditions(analysis)
    nu = sp.Symbol("link5_nu1", real=True)
    q2 = sp.Symbol("q2", real=True)
    assert any(nu * sp.cos(q2) in c.functions for c in flexible)  # the α_vᵀν C₂ term of h (3.13)
    assert all(not c.check(analysis.values).holds for c in flexible)  # the sag unbalances the nominal robot
    first = [c for c in flexible if nu * sp.cos(q2) in c.functions]
    assert first[0].feasible is False  # ρα_v1 + m_p φ1(l) > 0: no counterbalance removes the first mode's term
    # (the second mode's coefficient ρα_v2 − m_p·2/√l has mixed signs: a tip mass could cancel it)
    eta = sp.Symbol("link5_eta1", real=True)
    assert not any(f.has(eta) for c in flexible for f in c.functions)  # h is independent of η (3.13)


def test_thesis_sag_is_negligible_in_torque() -> None:
    """Madill 4.2.1: balanced at home (q2 = π, where the sag moves the centre of mass along the vertical
    through joint 1-4), not in an intermediate position (q2 = 3π/4): there the static sag of link 5
    (sub-millimetre, the thesis's 0.0114 cm order) leaves a gravity torque on q2 of order 1e-4 N·m,
    below 0.1 % of the beam's own gravity moment about joint 1-4."""
    model = derived("fivebar_flexible")
    home = residual_imbalance(model, [0.0, np.pi / 2, np.pi])
    assert max(abs(t) for t in home.torques.values()) < 1e-15
    sag = residual_imbalance(model, [0.0, np.pi / 2, 3 * np.pi / 4])
    values = {s.name: v for s, v in model.parameters.items()}
    tip = sum(2 * (-1) ** i / np.sqrt(values["l5"]) * sag.modal[f"link5_nu{i + 1}"] for i in range(2))
    assert 0 < abs(tip) < 0.0005  # sub-millimetre, the order of the thesis's 0.0114 cm (with the 43 g tip mass)
    own_moment = 9.81 * (values["rho"] * values["l5"] * (values["l4"] + values["l5"] / 2) + values["m_p"] * (values["l4"] + values["l5"]))
    worst = max(abs(t) for t in sag.torques.values())
    assert 1e-6 < worst < 1e-3 * own_moment


def test_residual_for_a_given_deflection() -> None:
    """A given deflection: ν₁ = 1 mm·√l₅/2 (tip ≈ 1 mm) at q2 = 3π/4 gives the q2 torque of the moved centre of
    mass, −m_f g ∂h/∂q2 with h's α_vᵀν C₂ term: ρ g α_v1 ν₁ S₂ (3.13), plus the tip mass's share."""
    model = derived("fivebar_flexible")
    values = {s.name: v for s, v in model.parameters.items()}
    nu1 = 1e-3 * np.sqrt(values["l5"]) / 2
    sag = residual_imbalance(model, [0.0, np.pi / 2, 3 * np.pi / 4], deflection={"link5_nu1": nu1})
    alpha1 = 0.78299175603962567 * np.sqrt(values["l5"])  # 2σ₁/k₁ √l (3.62), checked against quadrature elsewhere
    tip1 = 2 / np.sqrt(values["l5"])
    s2 = np.sin(3 * np.pi / 4)
    expected = 9.81 * (values["rho"] * alpha1 + values["m_p"] * tip1) * nu1 * s2
    assert abs(abs(sag.torques["q2"]) - abs(expected)) <= 1e-9 * abs(expected)
