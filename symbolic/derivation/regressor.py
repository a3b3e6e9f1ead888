"""The dynamic model linear in its parameters: τ = Y(Q, Q̇, Q̈)·θ (Khalil & Dombre 14.2; Janot (2)–(3)).

θ, the standard parameters, collects in this order:

* per frame that carries bodies (frame j, in frame order), Khalil's ten inertial parameters about
  the frame's origin in its axes: XXj XYj XZj YYj YZj ZZj (the inertia tensor ʲJ_j, xy being the
  tensor's (x, y) entry), MXj MYj MZj (first moments m·c) and Mj (mass) — the sums over the frame's
  bodies;
* per [[beam]] (in file order; Madill 3.4–3.8), with the beam's name as label: rho_<beam> (the linear
  density ρ), EIv_<beam> and EIw_<beam> (the bending stiffnesses, for a direction with modes) and, when
  a tip mass is declared, mp_<beam> (m_p). The beam's D_f (3.76) is ρ times a matrix of Q and the length, plus m_p·J_tipᵀJ_tip;
  its gravitational energy (3.79) is ρ and m_p times functions of Q; its strain energy (3.80) is
  ½EI_v νᵀΛ_vν + ½EI_w ηᵀΛ_wη. The mode shapes (Appendix B) depend only on the boundary condition
  and the length, so all three are linear in these four numbers, and so is the beam's part of τ,
  D_f Q̈ + (I⊗Q̇ᵀ)C_f Q̇ + ∂(V_g + V_s)/∂Qᵀ (3.82)–(3.83), which is derived from them with θ in
  their place. The length stays a fixed parameter of Y, like the DH lengths;
* per [[drive]] with a rotor inertia: Ia·ratio², the rotor's inertia at its coordinate;
* per [[friction]]: its viscous, Coulomb and offset coefficients (each direction's for direction-dependent
  ones) and the static level of a Stribeck rise (its velocity scale vs stays a fixed parameter of Y,
  the law being linear in Fc and Fs for a given vs);
* per [[force]]: one parameter per monomial of the model's parameters in its expression (e.g.
  ``-k1*(q1 - q10)`` gives k1 and k1·q10); a force that is not polynomial in its parameters cannot be
  written this way and is refused.

The drive, friction and force parameters are named by :func:`symbolic.description.names.coefficient_names`
(docs/model-format.md, "Names of identified coefficients"): one that is exactly one model parameter keeps
its name (EMPS's ``Fc``), the others are ``<stem>_<coordinate>`` (``Fc_q``, ``Fvp_q``, ``Fs_q``, ``Ia_q``)
or, for a force's monomial, ``<force>:<monomial>``.

Y is derived by a Newton–Euler pass in which each frame's wrench is written in these parameters,

    f = M a + U·(MX, MY, MZ),   n = J ω̇ + ω × J ω + (MX, MY, MZ) × a,   U = S(ω̇) + S(ω)²,

which is linear in them (Khalil's formulation), plus each beam's part from its energies (above);
column θ_k of Y is ∂τ/∂θ_k, taken by the chain rule
through the intermediate symbols. Y also depends on the fixed model parameters (lengths of the DH
table, gravity, Stribeck velocities); :attr:`Regressor.theta_expressions` maps the model file's
parameters to θ, so that Y(p)·θ(p) = τ(p) for every p.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

import sympy as sp

from symbolic.derivation import christoffel as ch
from symbolic.derivation.flexible import beam_energy
from symbolic.derivation.friction import friction_force
from symbolic.derivation.inertia import SpatialInertia
from symbolic.derivation.kinematics import Kinematics, cross
from symbolic.derivation.newton_euler import inverse_dynamics
from symbolic.derivation.subexpressions import Subexpressions
from symbolic.derivation.transmission import map_to_generalized
from symbolic.errors import ModelError
from symbolic.description.names import (ROTOR_STEM, STRIBECK_STEM, Coefficient, coefficient_name, coefficient_names,
                                        friction_stem)
from symbolic.description.robot import Beam, Directional, Friction, Robot, Stribeck, acceleration_symbol, coordinate_symbol, velocity_symbol
from symbolic.description.validation import validate

INERTIAL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")


class StandardParameter(sp.Symbol):
    """A standard parameter θ_k: a symbol of its own class, so that θ named like a model parameter
    (an Fv1 in both) never equals it in an expression."""


@dataclass(frozen=True)
class Regressor:
    """τ = Y·θ for one robot.

    Attributes
    ----------
    theta
        The standard parameters θ (symbols), in the order described in the module docstring.
    theta_expressions
        θ as expressions of the model file's parameters (same order).
    Y
        N×len(θ) matrix in intermediates of :attr:`sub` (and Q, Q̇, Q̈ and the model's parameters).
    sub
        The intermediate registry of Y.
    kinds
        For each θ: ``"inertial"``, ``"beam"``, ``"drive"``, ``"friction"`` or ``"force"``.
    """

    robot: Robot
    theta: tuple[sp.Symbol, ...]
    theta_expressions: tuple[sp.Expr, ...]
    Y: sp.Matrix
    sub: Subexpressions
    kinds: tuple[str, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(t.name for t in self.theta)

    def expand(self) -> sp.Matrix:
        """Y in Q, Q̇, Q̈ and the model's parameters."""
        return self.Y.applyfunc(self.sub.expand)


def frame_label(name: str) -> str:
    """Frame name as it follows a parameter kind: '2' -> '2', 'c1' -> '_c1', "0'" -> '_0p'."""
    clean = re.sub(r"[^A-Za-z0-9_]", "p", name)
    return clean if clean.isdigit() else f"_{clean}"


def regressor(robot: Robot) -> Regressor:
    """Derive Y and θ for ``robot`` (see the module docstring).

    Y is built in two blocks: the inertial and beam columns (the rigid part, the same for every description
    with this skeleton: reused, :func:`symbolic.derivation.rigid_stage.reused`), then the drive, friction and
    force columns, on a private copy of the rigid part's intermediates."""
    from symbolic.derivation.rigid_stage import reused

    robot = validate(robot)
    rigid = reused("rigid regressor", robot, lambda: _rigid_block(robot))
    drives, frictions, forces = _drive_parameters(robot), _friction_parameters(robot), _force_parameters(robot)
    extra = drives + frictions + forces
    expressions = rigid.expressions + tuple(e for _, _, e in extra)
    kinds = rigid.kinds + tuple(kind for kind, part in (("drive", drives), ("friction", frictions), ("force", forces))
                                for _ in part)
    # the columns hold no θ (∂(column·θ)/∂θ is the column itself): θ are named once all are known
    proposed = rigid.theta + tuple(t for t, _, _ in extra)
    names = coefficient_names([Coefficient(t.name, e, kind not in ("inertial", "beam"))
                               for t, e, kind in zip(proposed, expressions, kinds)], robot.parameter_symbols)
    theta = tuple(t if t.name == name else StandardParameter(name, real=True) for t, name in zip(proposed, names))
    sub = rigid.sub.copy()
    sub.variables = sub.variables | set(theta[len(rigid.theta):])
    Y_extra = sp.Matrix(rigid.Y.rows, len(extra), lambda i, k: sub.add(extra[k][1][i]))
    return Regressor(robot, theta, expressions, sp.Matrix(rigid.Y).row_join(Y_extra), sub, kinds)


@dataclass(frozen=True)
class _RigidBlock:
    """The inertial and beam columns of Y (the rigid part of τ differentiated by its θ) and their registry."""

    theta: tuple[sp.Symbol, ...]
    expressions: tuple[sp.Expr, ...]
    kinds: tuple[str, ...]
    Y: sp.ImmutableMatrix
    sub: Subexpressions


def _rigid_block(robot: Robot) -> _RigidBlock:
    """Newton–Euler in the frames' standard parameters plus each beam's part, differentiated by θ (Khalil)."""
    inertial = _inertial_parameters(robot)
    beams = _beam_parameters(robot)
    theta = tuple(t for frame in inertial.values() for t, _ in frame) + tuple(t for _, pairs in beams for t, _ in pairs)
    names = robot.generalized_coordinates
    q = tuple(coordinate_symbol(c) for c in names)
    qd = tuple(velocity_symbol(c) for c in names)
    qdd = tuple(acceleration_symbol(c) for c in names)
    sub = Subexpressions(q + qd + qdd + theta)
    kin = Kinematics(robot, sub)
    symbols = {frame: [t for t, _ in parameters] for frame, parameters in inertial.items()}
    rigid = inverse_dynamics(kin, dict(zip(q, qd)), dict(zip(q, qdd)), gravity=True,
                             frame_wrench=lambda frame, w, dw, a, U, add: _standard_wrench(symbols.get(frame), w, dw, a, U, add))
    tau = sp.zeros(len(names), 1)
    tau[: len(rigid), 0] = rigid  # the rigid coordinates come first; modal rows get the beams' terms only
    for beam, _ in beams:
        tau += _beam_forces(kin, beam, q, qd, qdd)
    Y = sp.ImmutableMatrix(len(names), len(theta), lambda i, k: sub.add(sub.diff(tau[i], theta[k])))
    expressions = tuple(e for frame in inertial.values() for _, e in frame) + tuple(e for _, pairs in beams for _, e in pairs)
    kinds = ("inertial",) * sum(len(f) for f in inertial.values()) + ("beam",) * sum(len(pairs) for _, pairs in beams)
    return _RigidBlock(theta, expressions, kinds, Y, sub)


def _inertial_parameters(robot: Robot) -> dict[str, list[tuple[sp.Symbol, sp.Expr]]]:
    """{frame: [(θ, its expression in the model's parameters)] * 10} for frames carrying bodies."""
    out: dict[str, list[tuple[sp.Symbol, sp.Expr]]] = {}
    for frame in robot.frames:
        bodies = [b for b in robot.bodies if b.frame == frame.name]
        if not bodies:
            continue
        total = SpatialInertia.total([SpatialInertia.of_body(body) for body in bodies])
        J, h = total.rotational, total.moment
        values = (J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2], h[0], h[1], h[2], total.mass)
        label = frame_label(frame.name)
        out[frame.name] = [(StandardParameter(f"{k}{label}", real=True), sp.expand(v)) for k, v in zip(INERTIAL, values)]
    return out  # bodies on the base frame never move: they contribute nothing to τ


def _standard_wrench(theta, w, dw, a, U, add) -> tuple[sp.Matrix, sp.Matrix]:
    """Wrench about the frame origin, linear in the frame's ten standard parameters (Khalil)."""
    if theta is None:
        return sp.zeros(3, 1), sp.zeros(3, 1)
    xx, xy, xz, yy, yz, zz, mx, my, mz, m = theta
    J = sp.Matrix([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    h = sp.Matrix([mx, my, mz])
    f = (m * a + U * h).applyfunc(add)
    Jw = (J * w).applyfunc(add)
    n = (J * dw + cross(w, Jw) + cross(h, a)).applyfunc(add)
    return n, f


def _beam_parameters(robot: Robot) -> list[tuple[Beam, list[tuple[sp.Symbol, sp.Expr]]]]:
    """Per beam: the beam with θ symbols in place of ρ, EI_v, EI_w (and m_p), and [(θ, its expression)]."""
    out = []
    for beam in robot.beams:
        label = frame_label(beam.name)
        fields = ([("density", "rho")] + [(field, kind) for field, kind, modes in (("EI_v", "EIv", beam.modes_v), ("EI_w", "EIw", beam.modes_w))
                                           if modes] + ([("tip_mass", "mp")] if beam.tip_mass is not None else []))
        pairs = [(StandardParameter(f"{kind}{label}", real=True), getattr(beam, field)) for field, kind in fields]
        # a direction without modes has no strain energy: its stiffness stays as written (it acts on nothing)
        written = dataclasses.replace(beam, **{field: t for (field, _), (t, _) in zip(fields, pairs)})
        out.append((written, pairs))
    return out


def _beam_forces(kin: Kinematics, beam: Beam, q: tuple[sp.Symbol, ...], qd: tuple[sp.Symbol, ...],
                 qdd: tuple[sp.Symbol, ...]) -> sp.Matrix:
    """The beam's part of τ: D_f Q̈ + (I⊗Q̇ᵀ)C_f Q̇ + ∂(V_g + V_s)/∂Qᵀ (Madill (3.81)–(3.83)), over all of Q,
    for ``beam`` written in its θ symbols (linear in them: module docstring)."""
    sub = kin.sub
    energy = beam_energy(kin, beam, q)
    C = ch.christoffel_symbols(ch.inertia_derivatives(energy.inertia, q, sub), sub)
    potential = energy.gravity_potential + energy.strain
    gradient = sp.Matrix([sub.diff(potential, x) for x in q])
    return energy.inertia * sp.Matrix(qdd) + ch.coriolis_vector(C, qd) + gradient


def _drive_parameters(robot: Robot) -> list[tuple[sp.Symbol, sp.Matrix, sp.Expr]]:
    names = robot.generalized_coordinates
    out = []
    for drive in robot.drives:
        if drive.rotor_inertia == 0:
            continue  # no rotor declared: nothing to identify
        theta = StandardParameter(coefficient_name(ROTOR_STEM, drive.coordinate), real=True)
        column = sp.zeros(len(names), 1)
        column[names.index(drive.coordinate), 0] = acceleration_symbol(drive.coordinate)
        out.append((theta, column, drive.rotor_inertia * drive.ratio**2))
    return out


def _friction_parameters(robot: Robot) -> list[tuple[sp.Symbol, sp.Matrix, sp.Expr]]:
    """θ for each friction coefficient, its column (∂f/∂θ over the generalized coordinates) and value."""
    out = []
    for entry in robot.frictions:
        c = entry.coordinate
        pairs: list[tuple[str, sp.Expr]] = []

        def coefficient(value, key):
            if value is None:
                return None
            if isinstance(value, Directional):
                pos, neg = (StandardParameter(coefficient_name(friction_stem(key, d), c), real=True)
                            for d in ("positive", "negative"))
                pairs.extend([(pos, value.positive), (neg, value.negative)])
                return Directional(pos, neg)
            symbol = StandardParameter(coefficient_name(friction_stem(key), c), real=True)
            pairs.append((symbol, value))
            return symbol

        viscous = coefficient(entry.viscous, "viscous")
        coulomb = coefficient(entry.coulomb, "coulomb")
        if entry.stribeck is not None and coulomb is None:
            coulomb = sp.Integer(0)
        offset = coefficient(entry.offset, "offset")
        stribeck = None
        if entry.stribeck is not None:
            fs = StandardParameter(coefficient_name(STRIBECK_STEM, c), real=True)
            pairs.append((fs, entry.stribeck.static))
            stribeck = Stribeck(fs, entry.stribeck.velocity)
        law = friction_force(Friction(c, viscous, coulomb, offset, stribeck), velocity_symbol(c))
        shares = map_to_generalized(robot, c, law)
        for theta, value in pairs:
            out.append((theta, _column(robot, {k: sp.diff(v, theta) for k, v in shares.items()}), value))
    return out


def _force_parameters(robot: Robot) -> list[tuple[sp.Symbol, sp.Matrix, sp.Expr]]:
    """One θ per monomial of the model's parameters in each [[force]] expression (Q enters τ as −Q)."""
    params = set(robot.parameter_symbols)
    out = []
    for force in robot.forces:
        present = sorted(force.expression.free_symbols & params, key=sp.default_sort_key)
        try:
            poly = sp.Poly(sp.expand(force.expression), *present) if present else None
        except sp.PolynomialError:
            poly = None
        if poly is None or any(not c.free_symbols.isdisjoint(params) for c in poly.coeffs()):
            raise ModelError(robot.source, f"[[force]] {force.name!r} expression",
                             "is not polynomial in its parameters, so it cannot enter the linear regressor")
        for monomial, coeff in zip(poly.monoms(), poly.coeffs()):
            value = sp.Mul(*[p**k for p, k in zip(present, monomial)])
            if value == 1:
                raise ModelError(robot.source, f"[[force]] {force.name!r} expression",
                                 f"has a term without parameters ({coeff}); write it with a parameter to identify it")
            theta = StandardParameter(f"{force.name}:{value}", real=True)
            shares = map_to_generalized(robot, force.coordinate, -coeff)
            out.append((theta, _column(robot, shares), value))
    return out


def _column(robot: Robot, shares: dict[str, sp.Expr]) -> sp.Matrix:
    names = robot.generalized_coordinates
    column = sp.zeros(len(names), 1)
    for coordinate, value in shares.items():
        column[names.index(coordinate), 0] += value
    return column
