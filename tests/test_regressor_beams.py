"""The parameter regressor of models with flexible links (Madill 3.4–3.8): a beam's density ρ, bending
stiffnesses EI_v, EI_w and tip mass m_p are standard parameters.

Checks:

* linearity as the model files declare them: D, V_g and V_s of the derived model have no second
  derivative in ρ, EI, m_p, and Y does not depend on them;
* Y·θ(p) = τ(p) of the derived model (its Lagrangian route, D Q̈ + (I⊗Q̇ᵀ)CQ̇ + g + k) at random states and
  random parameters, for every built-in beam model (hypothesis; 1e-9 relative);
* the beam's columns against a derivation by hand for Madill's experimental beam (a hub turning about the
  vertical with a horizontal beam, Lagrange's equations written out below), with the modal constants
  computed here by quadrature of the clamped-free shapes, not by symbolic.derivation.mode_shapes (1e-9);
  also bending in the horizontal plane only (modes_w = 0);
* the base parameters keep ρ, EI_v, EI_w and m_p as parameters of their own;
* the exported C regressor and standard parameters, the CasADi regressor and the compiled batch loop
  agree with Python (1e-12 relative).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest
import scipy.integrate
import scipy.optimize
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import symbolic
from c_library import CModel, compile_shared
from conftest import derived
from symbolic.derivation.regressor import regressor
from symbolic.identify.model import geometric_parameters, model_base
from symbolic.numeric import numeric_model
from symbolic.numeric.base_parameters import regressor_function, theta_values

BEAMS = ["single_flexible_link", "madill_beam", "fivebar_flexible"]
GENERATED = symbolic.robots.path("madill_beam").parents[2] / "generated"


def beam_parameters(model: symbolic.DynamicModel) -> set[sp.Symbol]:
    """The model-file parameters in the beams' density, stiffnesses and tip mass."""
    out: set[sp.Symbol] = set()
    for beam in model.robot.beams:
        for value in (beam.density, beam.EI_v, beam.EI_w, beam.tip_mass):
            out |= set() if value is None else value.free_symbols
    return out


@pytest.mark.parametrize("name", ["single_flexible_link", "madill_beam"])
def test_beam_parameters_enter_linearly(name: str) -> None:
    """∂²/∂p² of D (3.76), V_g (3.79) and V_s (3.80) vanish for ρ, EI, m_p (the mode shapes depend on the
    boundary condition and the length only), and the regressor does not depend on them."""
    model = derived(name)
    beam = beam_parameters(model)
    assert beam, "no beam parameters"
    for p in beam:
        for a in beam:
            assert all(sp.diff(e, p, a) == 0 for e in model.D), (p, a)
            assert sp.diff(model.potential_energy, p, a) == 0 and sp.diff(model.strain_energy, p, a) == 0
    reg, _ = model_base(model)
    assert not geometric_parameters(model, reg) & beam
    assert {"rho", "EIv", "EIw"} <= {k.split("_")[0] for k in reg.names if reg.kinds[reg.names.index(k)] == "beam"}


@pytest.mark.parametrize("name", BEAMS)
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_regressor_times_theta_is_the_inverse_dynamics(name: str, data) -> None:
    model = derived(name)
    reg, _ = model_base(model)
    Y, num = regressor_function(model, reg), numeric_model(model)
    modal = np.array(["_nu" in c or "_eta" in c for c in model.robot.generalized_coordinates])
    floats = lambda low, high, n: np.array(data.draw(st.lists(st.floats(low, high), min_size=n, max_size=n)))  # noqa: E731
    q = np.where(modal, 0.05, np.pi) * floats(-1, 1, model.n)
    qd, qdd = floats(-3, 3, model.n), floats(-10, 10, model.n)
    p = num.p0 * floats(0.5, 2.0, num.p0.size)  # every parameter, lengths and gravity included
    tau = num.inverse_dynamics(q, qd, qdd, p)
    assert np.linalg.norm(Y(q, qd, qdd, p) @ theta_values(model, reg, p) - tau) <= 1e-9 * np.linalg.norm(tau)


def test_theta_of_a_beam_is_what_the_file_declares() -> None:
    """θ are the file's expressions: a density written as a mass over the length stays m_b/L, linear in m_b,
    and the identified base parameter gives m_b back (the length is geometry, fixed)."""
    text = symbolic.robots.path("madill_beam").read_text().replace('density = "rho"', 'density = "m_b/L"')
    text = text.replace('rho = { value = 0.163, unit = "kg/m", description = "linear mass density" }',
                        'm_b = { value = 0.0732, unit = "kg", description = "beam mass" }')
    robot = symbolic.loads(text, "beam by its mass")
    reg = regressor(robot)
    theta = dict(zip(reg.names, reg.theta_expressions))
    m_b, L, EI, M_p = sp.symbols("m_b L EI M_p", real=True)
    assert theta["rho_beam"] == m_b / L and theta["EIv_beam"] == EI == theta["EIw_beam"] and theta["mp_beam"] == M_p
    assert reg.kinds[reg.names.index("rho_beam")] == "beam"


# -- the beam's columns by hand ---------------------------------------------------------------------------
#
# Madill's experimental beam (madill_beam.toml): frame e turns with q0 about the vertical z axis, the beam
# lies along x_e, v along y_e (horizontal), w along z_e (vertical), gravity −g z. A point x of the beam is at
# (x, φᵀν, ψᵀη) in frame e; its velocity there is (−ω v, ω x + v̇, ẇ), ω = q̇0. With ∫φφᵀ = I, β = ∫xφ,
# α_w = ∫ψ, Λ = diag ∫(φ'')², a = φ(l), b = ψ(l):
#   T = ½ρ(ω²(νᵀν + l³/3) + 2ωβᵀν̇ + ν̇ᵀν̇ + η̇ᵀη̇) + ½m_p(ω²(aᵀν)² + (ωl + aᵀν̇)² + (bᵀη̇)²),
#   V = ρ g α_wᵀη + m_p g bᵀη + ½EI_v νᵀΛ_vν + ½EI_w ηᵀΛ_wη.
# Lagrange's equations, column by column (ω̇ = q̈0):
#   ρ:   hub  ω̇(νᵀν + l³/3) + 2ω νᵀν̇ + βᵀν̈;   ν  ν̈ + ω̇β − ω²ν;   η  η̈ + g α_w
#   m_p: hub  ω̇((aᵀν)² + l²) + 2ω (aᵀν)(aᵀν̇) + l aᵀν̈;   ν  a(aᵀν̈ + ω̇l − ω² aᵀν);   η  b(bᵀη̈ + g)
#   EI_v: ν  Λ_vν;   EI_w: η  Λ_wη;   the hub's ZZ: hub  ω̇.


def clamped_free(n: int, length: float) -> dict[str, np.ndarray]:
    """α, β, Λ and the tip values of the first ``n`` clamped-free modes, by root finding and quadrature of
    Φ(ξ) = cosh kξ − cos kξ − σ(sinh kξ − sin kξ) normalised here (∫φ² dx = 1 on [0, l])."""
    out: dict[str, list[float]] = {"alpha": [], "beta": [], "lam": [], "tip": []}
    for i in range(1, n + 1):
        centre = (2 * i - 1) * np.pi / 2
        k = scipy.optimize.brentq(lambda k: np.cos(k) * np.cosh(k) + 1, centre - 1, centre + 1, xtol=1e-15)
        s = (np.cosh(k) + np.cos(k)) / (np.sinh(k) + np.sin(k))
        shape = lambda x: np.cosh(k * x) - np.cos(k * x) - s * (np.sinh(k * x) - np.sin(k * x))  # noqa: E731
        curvature = lambda x: k**2 * (np.cosh(k * x) + np.cos(k * x) - s * (np.sinh(k * x) + np.sin(k * x)))  # noqa: E731
        quad = lambda f: scipy.integrate.quad(f, 0, 1, epsabs=1e-14, epsrel=1e-12, limit=200)[0]  # noqa: E731
        norm = np.sqrt(quad(lambda x: shape(x) ** 2))  # φ(x) = Φ(x/l)/(norm·√l)
        out["alpha"].append(np.sqrt(length) * quad(shape) / norm)
        out["beta"].append(length**1.5 * quad(lambda x: x * shape(x)) / norm)
        out["lam"].append(quad(lambda x: curvature(x) ** 2) / norm**2 / length**4)
        out["tip"].append(shape(1.0) / norm / np.sqrt(length))
    return {key: np.array(value) for key, value in out.items()}


@lru_cache(maxsize=None)
def madill_beam(modes_v: int, modes_w: int) -> symbolic.DynamicModel:
    """Madill's experimental beam with ``modes_v``, ``modes_w`` modes (0: it bends in one plane only)."""
    text = symbolic.robots.path("madill_beam").read_text()
    text = text.replace("modes_v = 3", f"modes_v = {modes_v}").replace("modes_w = 1", f"modes_w = {modes_w}")
    return symbolic.derive(symbolic.loads(text, f"madill_beam ({modes_v}, {modes_w} modes)"))


@pytest.mark.parametrize("modes", [(3, 1), (2, 0)])
def test_beam_columns_match_lagrange_by_hand(modes: tuple[int, int]) -> None:
    """Madill's beam as shipped (3 horizontal, 1 vertical mode) and bending in the horizontal plane only."""
    model = madill_beam(*modes)
    reg, _ = model_base(model)
    Y, num = regressor_function(model, reg), numeric_model(model)
    values = {s.name: v for s, v in model.parameters.items()}
    l, g = values["L"], values["g"]
    beam = model.robot.beams[0]
    v, w = clamped_free(beam.modes_v, l), clamped_free(beam.modes_w, l)
    nv = beam.modes_v
    rng = np.random.default_rng(8)
    column = {name: k for k, name in enumerate(reg.names)}
    for _ in range(10):
        q, qd, qdd = rng.uniform(-0.05, 0.05, model.n), rng.uniform(-3, 3, model.n), rng.uniform(-10, 10, model.n)
        q[0] = rng.uniform(-np.pi, np.pi)
        omega, accel = qd[0], qdd[0]
        nu, nud, nudd = q[1:1 + nv], qd[1:1 + nv], qdd[1:1 + nv]
        eta, etad, etadd = q[1 + nv:], qd[1 + nv:], qdd[1 + nv:]
        a, b = v["tip"], w["tip"]
        expected = {
            "rho_beam": np.concatenate([[accel * (nu @ nu + l**3 / 3) + 2 * omega * nu @ nud + v["beta"] @ nudd],
                                        nudd + accel * v["beta"] - omega**2 * nu, etadd + g * w["alpha"]]),
            "mp_beam": np.concatenate([[accel * ((a @ nu) ** 2 + l**2) + 2 * omega * (a @ nu) * (a @ nud) + l * a @ nudd],
                                       a * (a @ nudd + accel * l - omega**2 * (a @ nu)), b * (b @ etadd + g)]),
            "EIv_beam": np.concatenate([[0.0], v["lam"] * nu, np.zeros(beam.modes_w)]),
            "EIw_beam": np.concatenate([[0.0], np.zeros(nv), w["lam"] * eta]),
            "ZZ_e": np.concatenate([[accel], np.zeros(model.n - 1)]),
        }
        if not beam.modes_w:  # no vertical bending: no η, no EI_w (it would act on nothing)
            assert "EIw_beam" not in column
            del expected["EIw_beam"]
        ours = Y(q, qd, qdd, num.p0)
        for name, reference in expected.items():
            got = ours[:, column[name]]
            assert np.linalg.norm(got - reference) <= 1e-9 * np.linalg.norm(reference), (name, got, reference)
        others = [k for k, name in enumerate(reg.names) if name not in expected]
        assert not ours[1:, others].any()  # rigid parameters act on the hub's row only


@pytest.mark.parametrize("name", BEAMS)
def test_beam_parameters_are_base_parameters(name: str) -> None:
    """Each beam's ρ, EI_v, EI_w (and m_p) acts on the modal rows as no rigid parameter does: a base parameter
    of its own, not regrouped, with an unambiguous rank."""
    model = derived(name)
    reg, base = model_base(model)
    for beam in model.robot.beams:
        own = [f"{kind}_{beam.name}" for kind in ("rho", "EIv", "EIw")] + ([f"mp_{beam.name}"] if beam.tip_mass is not None else [])
        assert set(own) <= set(base.names), base.names
        for parameter in own:
            assert str(base.expressions[base.names.index(parameter)]) == parameter
    assert base.gap[1] == 0.0 or base.gap[0] > 1e6 * base.gap[1]


# -- exported and compiled paths ----------------------------------------------------------------------------


def test_exported_c_and_casadi_regressor_of_a_beam_model(tmp_path) -> None:
    """generated/madill_beam: NAME_regressor · NAME_standard_parameters = NAME_inverse_dynamics, and both equal
    Python's, in C and in CasADi."""
    casadi = pytest.importorskip("casadi")
    name = "madill_beam"
    model = derived(name)
    reg, _ = model_base(model)
    num = numeric_model(model)
    c = CModel(compile_shared(GENERATED / name / f"{name}.c", tmp_path / f"lib{name}.so"), name, model.n, len(model.robot.parameters))
    fn = casadi.Function.load(str(GENERATED / name / f"{name}_regressor.casadi"))
    Y = regressor_function(model, reg)
    rng = np.random.default_rng(21)
    for _ in range(10):
        q = np.where([("_nu" in x or "_eta" in x) for x in model.robot.generalized_coordinates], 0.02, np.pi) * rng.uniform(-1, 1, model.n)
        qd, qdd = rng.uniform(-2, 2, model.n), rng.uniform(-5, 5, model.n)
        p = num.p0 * rng.uniform(0.5, 2.0, num.p0.size)
        reference = Y(q, qd, qdd, p)
        ours = c._call("regressor", [q, qd, qdd, p], model.n * len(reg.theta)).reshape(model.n, len(reg.theta))
        theta = c._call("standard_parameters", [p], len(reg.theta))
        scale = np.linalg.norm(reference)
        assert np.linalg.norm(ours - reference) <= 1e-12 * scale
        assert np.linalg.norm(np.array(fn(q, qd, qdd, p)) - reference) <= 1e-12 * scale
        assert np.linalg.norm(theta - theta_values(model, reg, p)) <= 1e-14 * np.linalg.norm(theta)
        tau = c.inverse_dynamics(q, qd, qdd, p)
        assert np.linalg.norm(ours @ theta - tau) <= 1e-10 * np.linalg.norm(tau)


def test_compiled_batch_regressor_of_a_beam_model() -> None:
    from symbolic.codegen.compiled import compiler
    from symbolic.identify.model import base_regressor

    if compiler() is None:
        pytest.skip("needs a C compiler (gcc, cc or clang)")
    model = derived("fivebar_flexible")
    rng = np.random.default_rng(3)
    scale = np.where([("_nu" in x or "_eta" in x) for x in model.robot.generalized_coordinates], 0.02, 2.0)
    q, qd, qdd = scale * rng.uniform(-1, 1, (257, model.n)), rng.uniform(-2, 2, (257, model.n)), rng.uniform(-2, 2, (257, model.n))
    p = np.array(list(model.parameters.values())) * rng.uniform(0.5, 1.5, len(model.parameters))
    fast = base_regressor(model, p, compiled=True)(q, qd, qdd)
    slow = base_regressor(model, p, compiled=False)(q, qd, qdd)
    np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-12 * np.abs(slow).max())
