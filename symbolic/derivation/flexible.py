"""Flexible links by assumed modes (Madill 3.4–3.8, 3.11): beam kinetic, gravitational and strain energy.

A beam clamped at frame e with modal coordinates ν (deflection v along y_e) and η (w along z_e):

* position of a point (3.43): p = [x, φᵀν, ψᵀη]ᵀ in frame e;
* Jacobian (3.56): J(Q, x) = [J^v − R S(p) J^Ω, R Φᵀ];
* inertia (3.76): D_f = ρ [[l J_LᵀJ_L − J_ΩᵀΞ₁ᵀJ_L − J_LᵀΞ₁J_Ω + J_ΩᵀΞ₃J_Ω, Πᵀ], [Π, I]],
  with J_L = RᵀJ^v the clamp's velocity Jacobian in frame e, Ξ₁ (3.66), Ξ₂ (3.72), Ξ₃ (3.73), 𝒜 and
  Π = 𝒜J_L − Ξ₂J_Ω (3.75);
* a tip point mass m_p at x = l adds m_p J(Q, l)ᵀJ(Q, l);
* gravity (3.78)–(3.79): V = −m_f g₀ᵀ(R p_cm + d), p_cm = [l/2, ν ᵀα_v/l, ηᵀα_w/l]ᵀ (3.67), and the tip mass;
* strain (3.80): V_s = ½EI_v νᵀΛ_vν + ½EI_w ηᵀΛ_wη.

The small-deflection assumptions (as Madill's): docs/model-format.md, "Beams".
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from symbolic.derivation.kinematics import Kinematics, skew
from symbolic.derivation.mode_shapes import ModalConstants, modal_constants, phi
from symbolic.description.robot import Beam, coordinate_symbol


@dataclass
class BeamEnergy:
    """A beam's contributions, over the full generalized coordinates Q."""

    inertia: sp.Matrix
    gravity_potential: sp.Expr
    strain: sp.Expr


@dataclass
class BeamGeometry:
    """Modal symbols and constants of one beam."""

    beam: Beam
    nu: sp.Matrix
    eta: sp.Matrix
    v: ModalConstants
    w: ModalConstants

    @property
    def length(self) -> sp.Expr:
        return self.beam.length

    @property
    def gamma(self) -> sp.Matrix:
        """γ = ∫φψᵀdx (3.71): the identity on shared modes (identical orthonormal shapes)."""
        return sp.Matrix(len(self.nu), len(self.eta), lambda i, j: 1 if i == j else 0)

    def point(self, x: sp.Expr) -> sp.Matrix:
        """p(x) = [x, φ(x)ᵀν, ψ(x)ᵀη]ᵀ (3.43), in frame coordinates."""
        l = self.length
        v = sum((phi(s, x, l) * n for s, n in zip(self.v.shapes, self.nu)), sp.Integer(0))
        w = sum((phi(s, x, l) * e for s, e in zip(self.w.shapes, self.eta)), sp.Integer(0))
        return sp.Matrix([x, v, w])

    def modal_block(self, x: sp.Expr) -> sp.Matrix:
        """Φ(x)ᵀ (3×(n_v+n_w)) of (3.55)."""
        l = self.length
        row_v = [phi(s, x, l) for s in self.v.shapes] + [0] * len(self.eta)
        row_w = [0] * len(self.nu) + [phi(s, x, l) for s in self.w.shapes]
        return sp.Matrix([[0] * (len(self.nu) + len(self.eta)), row_v, row_w])

    def tip_block(self) -> sp.Matrix:
        row_v = list(self.v.tip) + [0] * len(self.eta)
        row_w = [0] * len(self.nu) + list(self.w.tip)
        return sp.Matrix([[0] * (len(self.nu) + len(self.eta)), row_v, row_w])

    def tip_point(self) -> sp.Matrix:
        return sp.Matrix([self.length, (column(self.v.tip).T * self.nu)[0], (column(self.w.tip).T * self.eta)[0]])


def column(values) -> sp.Matrix:
    """``values`` as an n×1 matrix, also for n = 0 (a direction without modes): ``sp.Matrix([])`` is 0×0,
    and products with it would not be the 1×1 zero the formulas need."""
    values = list(values)
    return sp.Matrix(len(values), 1, values)


def geometry(beam: Beam) -> BeamGeometry:
    return BeamGeometry(
        beam,
        column([coordinate_symbol(n) for n in beam.nu]),
        column([coordinate_symbol(n) for n in beam.eta]),
        modal_constants(beam.modes_v, beam.length, beam.boundary),
        modal_constants(beam.modes_w, beam.length, beam.boundary),
    )


def xi_matrices(g: BeamGeometry) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]:
    """Ξ₁ (3.66), Ξ₂ (3.72), Ξ₃ (3.73) and 𝒜 (3.75)."""
    l, nu, eta = g.length, g.nu, g.eta
    av, aw = column(g.v.alpha), column(g.w.alpha)
    bv, bw = column(g.v.beta), column(g.w.beta)
    gamma = g.gamma
    a_nu, a_eta = (av.T * nu)[0], (aw.T * eta)[0]
    xi1 = sp.Matrix([[0, -a_eta, a_nu], [a_eta, 0, -l**2 / 2], [-a_nu, l**2 / 2, 0]])
    nv, nw = len(nu), len(eta)
    xi2 = sp.Matrix.vstack(
        sp.Matrix.hstack(gamma * eta, sp.zeros(nv, 1), -bv),
        sp.Matrix.hstack(-gamma.T * nu, bw, sp.zeros(nw, 1)),
    )
    nn, ee, ng = (nu.T * nu)[0], (eta.T * eta)[0], (nu.T * gamma * eta)[0]
    b_nu, b_eta = (bv.T * nu)[0], (bw.T * eta)[0]
    xi3 = sp.Matrix(
        [
            [nn + ee, -b_nu, -b_eta],
            [-b_nu, l**3 / 3 + ee, -ng],
            [-b_eta, -ng, l**3 / 3 + nn],
        ]
    )
    calligraphic_a = sp.Matrix.vstack(
        sp.Matrix.hstack(sp.zeros(nv, 1), av, sp.zeros(nv, 1)),
        sp.Matrix.hstack(sp.zeros(nw, 1), sp.zeros(nw, 1), aw),
    )
    return xi1, xi2, xi3, calligraphic_a


def _clamp_jacobians(kin: Kinematics, frame: str) -> tuple[sp.Matrix, sp.Matrix]:
    """J_L = RᵀJ^v and J^Ω of the clamp frame over the rigid coordinates (3×m)."""
    return kin.jacobian_linear_body(frame), kin.jacobian_omega(frame)


def _columns(kin: Kinematics, g: BeamGeometry, coordinates: tuple[sp.Symbol, ...]) -> list[int]:
    """Positions in Q of the beam's local columns: rigid coordinates, then its ν and η."""
    index = {x: i for i, x in enumerate(coordinates)}
    return [index[x] for x in list(kin.coordinates) + list(g.nu) + list(g.eta)]


def beam_energy(kin: Kinematics, beam: Beam, coordinates: tuple[sp.Symbol, ...]) -> BeamEnergy:
    """D_f (3.76) with the tip mass, V_g (3.79) and V_s (3.80) of ``beam``, over all of Q."""
    sub = kin.sub
    g = geometry(beam)
    rho, l = beam.density, beam.length
    JL, JO = _clamp_jacobians(kin, beam.frame)
    xi1, xi2, xi3, calligraphic_a = xi_matrices(g)
    top = l * JL.T * JL - JO.T * xi1.T * JL - JL.T * xi1 * JO + JO.T * xi3 * JO
    pi = calligraphic_a * JL - xi2 * JO
    nf = len(g.nu) + len(g.eta)
    d_rigid_modes = sp.Matrix.vstack(sp.Matrix.hstack(top, pi.T), sp.Matrix.hstack(pi, sp.eye(nf))) * rho
    if beam.tip_mass is not None:
        tip = g.tip_point()
        J_tip = sp.Matrix.hstack(JL - skew(tip) * JO, g.tip_block())
        d_rigid_modes += beam.tip_mass * (J_tip.T * J_tip)
    columns = _columns(kin, g, coordinates)
    inertia = sp.zeros(len(coordinates), len(coordinates))
    for a, i in enumerate(columns):
        for b, j in enumerate(columns):
            if b >= a:
                inertia[i, j] = inertia[j, i] = sub.add(sp.expand(d_rigid_modes[a, b]))
    R, d = kin.rotation(beam.frame), kin.translation(beam.frame)
    g0 = sp.Matrix(kin.robot.gravity)
    p_cm = sp.Matrix([l / 2, (column(g.v.alpha).T * g.nu)[0] / l, (column(g.w.alpha).T * g.eta)[0] / l])
    potential = -rho * l * (g0.T * (R * p_cm + d))[0]
    if beam.tip_mass is not None:
        potential += -beam.tip_mass * (g0.T * (R * g.tip_point() + d))[0]
    strain = (
        beam.EI_v * sum(lam * x**2 for lam, x in zip(g.v.lam, g.nu)) + beam.EI_w * sum(lam * x**2 for lam, x in zip(g.w.lam, g.eta))
    ) / 2
    return BeamEnergy(inertia, sub.add(sp.expand(potential)), sub.add(strain))


def beam_jacobian(kin: Kinematics, beam: Beam, x: sp.Expr, coordinates: tuple[sp.Symbol, ...]) -> sp.Matrix:
    """J(Q, x) of (3.56) in base coordinates, columns over all of Q (3×N)."""
    g = geometry(beam)
    JL, JO = _clamp_jacobians(kin, beam.frame)
    R = kin.rotation(beam.frame)
    body = sp.Matrix.hstack(JL - skew(g.point(x)) * JO, g.modal_block(x))
    full = R * body
    out = sp.zeros(3, len(coordinates))
    for a, i in enumerate(_columns(kin, g, coordinates)):
        out[:, i] = full[:, a]
    return out


def beam_point(kin: Kinematics, beam: Beam, x: sp.Expr) -> sp.Matrix:
    """p₀ = R p(x) + d (3.43): a point of the deflected beam in base coordinates."""
    g = geometry(beam)
    return kin.rotation(beam.frame) * g.point(x) + kin.translation(beam.frame)


__all__ = ["BeamEnergy", "beam_energy", "beam_jacobian", "beam_point", "geometry", "xi_matrices"]
