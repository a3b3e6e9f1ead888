"""Milne et al.'s sinusoidal steady-state identification (2.2.4–2.2.5) and yaw-inertia model (2.1.2, 2.2.6).

Truth is made here, independently of the code under test: the steady state of Milne (13) in closed
form, θ = A_r|H| sin(ωt + ψ + ∠H) with H(jω) = β/(β − ω² + jCω), written as samples (and as an
experiment file with a ``[controller]``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import symbolic
from symbolic import data
from symbolic.data import DataError, Experiment, Measurements
from symbolic.derivation import DynamicModel, derive
from symbolic.reproduction.milne.yaw_inertia import inertia_form
from symbolic.errors import ModelError
from symbolic.reproduction.milne import sine
from symbolic.reproduction.milne.inertia_model import damping_ratio, fit_inertia_model, inertia
from symbolic.simulation import simulate
from symbolic.reproduction.milne import items as milne
from symbolic.reproduction.milne import sine_items as milne_sine
from symbolic import robots

FREQUENCIES = (1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0)  # Milne 2.4.2
C_TRUE, BETA_TRUE = 6.275, 445.6  # Milne Table 9 (fitted), for plausible magnitudes
AR = 0.07


def closed_form(t: np.ndarray, frequency: float, *, C: float = C_TRUE, beta: float = BETA_TRUE, ar: float = AR,
                psi: float = 0.4, bias: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(reference, response) of Milne (13) in steady state, the reference A_r sin(ωt + ψ)."""
    w = 2 * np.pi * frequency
    H = beta / (beta - w**2 + 1j * C * w)
    return ar * np.sin(w * t + psi), ar * abs(H) * np.sin(w * t + psi + np.angle(H)) + bias


def expected_a1_a2(frequency: float, C: float = C_TRUE, beta: float = BETA_TRUE, ar: float = AR) -> tuple[float, float]:
    w = 2 * np.pi * frequency
    H = beta / (beta - w**2 + 1j * C * w)
    return ar * abs(H) * math.sin(np.angle(H)), ar * abs(H) * math.cos(np.angle(H))


# ------------------------------------------------------------------------------------- sine fits


def test_fit_sine_recovers_coefficients_over_whole_periods() -> None:
    t = np.arange(0, 4, 1e-3)
    y = 0.3 * np.cos(2 * np.pi * 2.5 * t) - 0.2 * np.sin(2 * np.pi * 2.5 * t) + 0.05
    y[:1000] += np.exp(-t[:1000] * 5)  # a transient in the discarded half
    fit = sine.fit_sine(t, y, 2.5)
    assert (fit.a_cos, fit.a_sin, fit.offset) == pytest.approx((0.3, -0.2, 0.05), abs=1e-12)
    assert fit.periods == 5  # 2 s after the default transient (half) at 2.5 Hz
    assert fit.stop == t[-1] and fit.start == pytest.approx(t[-1] - 2.0 + 1e-3, abs=1e-12)


def test_response_rotated_into_the_reference_phase() -> None:
    t = np.arange(0, 6, 1e-3)
    for psi in (0.0, 0.4, -2.0):
        r, q = closed_form(t, 3.0, psi=psi, bias=0.02)
        response = sine.steady_state_response(t, q, r, 3.0)
        assert (response.a1, response.a2) == pytest.approx(expected_a1_a2(3.0), abs=1e-13)
        assert response.reference_amplitude == pytest.approx(AR, rel=1e-12)
        assert response.offset == pytest.approx(0.02, abs=1e-12)


@pytest.mark.parametrize("frequency", FREQUENCIES)
def test_local_parameters_exact_without_noise(frequency: float) -> None:
    t = np.arange(0, 8, 1e-3)
    r, q = closed_form(t, frequency)
    p = sine.response_parameters(sine.steady_state_response(t, q, r, frequency))
    assert p.valid
    assert p.C == pytest.approx(C_TRUE, rel=1e-9)
    assert p.beta == pytest.approx(BETA_TRUE, rel=1e-9)


@pytest.mark.parametrize("frequency", [1.5, 3.5, 7.0])
def test_local_parameters_exact_from_a_simulation_from_rest(frequency: float) -> None:
    """(13) integrated from rest (DOP853, rtol 1e-12): after 8 s the transient is e^(−C·8/2) ≈ 1e-11."""
    w = 2 * np.pi * frequency
    t = np.arange(0, 16, 1e-3)

    def rhs(time: float, x: np.ndarray) -> list[float]:
        return [x[1], -C_TRUE * x[1] - BETA_TRUE * x[0] + BETA_TRUE * AR * np.sin(w * time)]

    q = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-12, atol=1e-14, method="DOP853").y[0]
    p = sine.response_parameters(sine.steady_state_response(t, q, AR * np.sin(w * t), frequency, transient=8.0))
    assert p.C == pytest.approx(C_TRUE, rel=1e-9)
    assert p.beta == pytest.approx(BETA_TRUE, rel=1e-9)


def test_local_parameters_satisfy_corrected_18() -> None:
    """(19)–(20) solve (18) with −ωA₁C in its second row (Milne prints +)."""
    w = 2 * np.pi * 2.0
    a1, a2 = expected_a1_a2(2.0)
    p = sine.local_parameters(2.0, a1, a2, AR)
    assert -w**2 * a1 + w * a2 * p.C + a1 * p.beta == pytest.approx(0, abs=1e-12)
    assert -w**2 * a2 - w * a1 * p.C + (a2 - AR) * p.beta == pytest.approx(0, abs=1e-12)
    # with the printed +ωA₁C the same C, β leave a residual of 2ωA₁C
    assert abs(-w**2 * a2 + w * a1 * p.C + (a2 - AR) * p.beta) > 1e-3


def test_exclusion_rule() -> None:
    """A_r A₂ > A₁² + A₂² (too much phase lag for the amplitude): C_data, β_data < 0, excluded."""
    p = sine.local_parameters(1.5, -0.01, 0.06, 0.07)  # 0.07·0.06 > 0.01² + 0.06²
    assert not p.valid and p.C < 0 and p.beta < 0
    assert sine.local_parameters(1.5, -0.01, 0.08, 0.07).valid


def test_global_fit_exact_without_noise() -> None:
    pairs = [expected_a1_a2(f) for f in FREQUENCIES]
    fit = sine.global_linear_fit(FREQUENCIES, [a for a, _ in pairs], [b for _, b in pairs], AR)
    assert fit.C == pytest.approx(C_TRUE, rel=1e-12)
    assert fit.beta == pytest.approx(BETA_TRUE, rel=1e-12)
    assert fit.sigma_C < 1e-9 * C_TRUE


def test_global_fit_within_its_statistics_with_noise() -> None:
    """Position noise of σ_q: the errors of C_linear, β_linear, in units of the stated σ, have unit spread."""
    rng = np.random.default_rng(14)
    t = np.arange(0, 6, 2e-3)
    clean = [closed_form(t, f, psi=0.0) for f in FREQUENCIES]
    z_C, z_beta = [], []
    for _ in range(300):
        responses = [sine.steady_state_response(t, q + rng.normal(0, 2e-3, t.size), r, f)
                     for f, (r, q) in zip(FREQUENCIES, clean)]
        fit = sine.fit_responses(responses)
        z_C.append((fit.C - C_TRUE) / fit.sigma_C)
        z_beta.append((fit.beta - BETA_TRUE) / fit.sigma_beta)
    for z in (np.array(z_C), np.array(z_beta)):
        assert abs(z.mean()) < 0.25  # no bias beyond 0.25 σ
        assert 0.8 < z.std() < 1.25  # σ estimated from 16 degrees of freedom per fit; 300 fits


# ----------------------------------------------------------------------------------- logs and files


def write_run(folder: Path, frequency: float, *, kd: float = 0.0, kp: float = 2.0, constants: bool = True,
              controller: str | None = None, t: np.ndarray | None = None) -> Path:
    """A CSV of the closed-form steady state and an experiment file with a pd [controller]."""
    t = np.arange(0, 8, 1e-3) if t is None else t
    # With kd on the measurement the loop's damping is C + β kd/kp (Milne (12)).
    r, q = closed_form(t, frequency, C=C_TRUE + BETA_TRUE * kd / kp)
    csv = folder / f"run_{frequency:g}.csv"
    m = Measurements.from_arrays(t, ["yaw"], q[:, None], np.zeros((t.size, 1)), ref=r[:, None])
    data.write(m, csv)
    table = controller if controller is not None else (
        f'[controller]\nkind = "pd"\nkp = [{kp}]\nkd = [{kd}]\nreference = "ref"\n')
    text = f'data = "{csv.name}"\n[signals]\nt = "t"\nq_yaw = "q_yaw"\ntau_yaw = "tau_yaw"\nref_yaw = "ref_yaw"\n'
    if constants:
        text += f"[constants]\nfrequency = {frequency}\n"
    path = folder / f"run_{frequency:g}.experiment.toml"
    path.write_text(text + table)
    return path


def test_identify_joint_from_experiment_files(tmp_path: Path) -> None:
    logs = [data.load(write_run(tmp_path, f)) for f in FREQUENCIES]
    result = sine.identify_joint(logs)  # frequencies from [constants] frequency
    assert result.kp == 2.0 and result.coordinate == "yaw"
    assert [p.C for p in result.local] == pytest.approx([C_TRUE] * len(FREQUENCIES), rel=1e-9)
    assert result.linear.C == pytest.approx(C_TRUE, rel=1e-9)
    assert result.beta_tilde == pytest.approx(BETA_TRUE / 2.0, rel=1e-9)


def test_identify_joint_removes_derivative_on_measurement(tmp_path: Path) -> None:
    logs = [data.load(write_run(tmp_path, f, kd=0.01, constants=False)) for f in FREQUENCIES[:4]]
    result = sine.identify_joint(logs, FREQUENCIES[:4], "yaw")
    assert result.linear.C == pytest.approx(C_TRUE, rel=1e-9)
    assert [p.C for p in result.local] == pytest.approx([C_TRUE] * 4, rel=1e-9)


# ------------------------------------------------------------------------------------------ bad input


def one_line(error: pytest.ExceptionInfo) -> str:
    text = str(error.value)
    assert "\n" not in text
    return text


def test_too_few_periods() -> None:
    t = np.arange(0, 1, 1e-3)
    r, q = closed_form(t, 1.5)
    with pytest.raises(DataError) as e:
        sine.steady_state_response(t, q, r, 1.5)
    assert "at least 2 whole periods" in one_line(e)


def test_non_uniform_time() -> None:
    t = np.arange(0, 4, 1e-3)
    t[100:] += 5e-4
    r, q = closed_form(t, 2.0)
    with pytest.raises(DataError) as e:
        sine.steady_state_response(t, q, r, 2.0)
    assert "uniform" in one_line(e)


@pytest.mark.parametrize("frequency", [None, 0.0, -2.0, math.nan, "2"])
def test_bad_frequency(frequency: object) -> None:
    t = np.arange(0, 4, 1e-3)
    with pytest.raises(DataError) as e:
        sine.fit_sine(t, np.sin(t), frequency)  # type: ignore[arg-type]
    assert "frequency" in one_line(e)


def test_frequency_not_given(tmp_path: Path) -> None:
    logs = [data.load(write_run(tmp_path, 2.0, constants=False))]
    with pytest.raises(DataError) as e:
        sine.identify_joint(logs)
    assert "frequency: not given" in one_line(e)
    with pytest.raises(DataError) as e:
        sine.identify_joint(logs, [2.0, 3.0])
    assert "2 given for 1 log" in one_line(e)


@pytest.mark.parametrize("controller, message", [
    ("", "[controller]: missing"),
    ('[controller]\nkind = "cascade"\nkp = [1.0]\nkv = [1.0]\nreference = "ref"\n', "needs a proportional loop"),
    ('[controller]\nkind = "pid"\nkp = [1.0]\nkd = [0.0]\nki = [3.0]\nreference = "ref"\n', "integral term"),
    ('[controller]\nkind = "pd"\nkp = [0.0]\nkd = [0.0]\nreference = "ref"\n', "must be > 0"),
])
def test_bad_controller(tmp_path: Path, controller: str, message: str) -> None:
    log = data.load(write_run(tmp_path, 2.0, controller=controller))
    with pytest.raises(DataError) as e:
        sine.identify_joint([log])
    assert message in one_line(e)


def test_reference_without_the_frequency() -> None:
    t = np.arange(0, 4, 1e-3)
    with pytest.raises(DataError) as e:
        sine.steady_state_response(t, np.sin(t), np.sin(2 * np.pi * 3.0 * t), 2.0)
    assert "no component at 2 Hz" in one_line(e)


# ------------------------------------------------------------------------------ yaw-inertia model (6)

TABLE3_TRUE_ANGLES = [(21.54, 69.54), (20.55, 88.54), (19.31, 112.44), (40.68, 68.52), (39.83, 87.63),
                      (39.16, 111.98), (60.68, 67.62), (60.08, 87.00), (59.56, 111.45)]  # Milne Table 3, degrees


@pytest.fixture(scope="module")
def omni() -> DynamicModel:
    return derive(robots.load("omni"))


def test_omni_yaw_inertia_is_milne_5(omni: DynamicModel) -> None:
    """The extraction gives the thin-rod coefficients of Milne (5), expanded by hand."""
    form = inertia_form(omni, "theta", "gamma1", "gamma2", "gamma_offs")
    by_name = {p.name: p for p in omni.parameter_symbols}
    L1, L2, m1, m2, I_base = (by_name[n] for n in ("L1", "L2", "m1", "m2", "I_base"))
    hand = (I_base, m1 * L1**2 / 3 + m2 * L1**2, m2 * L2**2 / 12 + m2 * L2**2 / 4, m2 * L1 * L2)
    assert [sp.simplify(a - b) for a, b in zip(form.coefficients, hand)] == [0, 0, 0, 0]


def test_omni_yaw_inertia_agrees_with_D_numerically(omni: DynamicModel) -> None:
    form = inertia_form(omni, "theta", "gamma1", "gamma2", "gamma_offs")
    symbols = [*omni.coordinates, *omni.parameter_symbols]
    d = sp.lambdify(symbols, omni.D[0, 0], "math")
    e = sp.lambdify(symbols, form.expression(), "math")
    rng = np.random.default_rng(6)
    for _ in range(50):
        q = rng.uniform(-np.pi, np.pi, 3)
        p = [v * rng.uniform(0.5, 2.0) for v in omni.parameters.values()]
        p[-1] = rng.uniform(-0.5, 0.5)  # gamma_offs, 0 in the model file
        assert abs(d(*q, *p) - e(*q, *p)) <= 1e-12 * abs(d(*q, *p))


def test_inertia_form_refuses_other_forms(omni: DynamicModel) -> None:
    with pytest.raises(ModelError) as e:
        inertia_form(omni, "theta", "gamma1", "gamma2")  # without the offset γ_offs remains
    assert "not of Milne's form (6)" in one_line(e)
    with pytest.raises(ModelError) as e:
        inertia_form(omni, "gamma1", "theta", "gamma2")
    assert "D[gamma1, gamma1]: not of Milne's form (6)" in one_line(e)
    with pytest.raises(ModelError) as e:
        inertia_form(omni, "yaw", "gamma1", "gamma2")
    assert "unknown coordinate 'yaw'" in one_line(e)
    with pytest.raises(ModelError) as e:
        inertia_form(omni, "theta", "gamma1", "gamma2", "offset")
    assert "unknown parameter 'offset'" in one_line(e)


def test_inertia_model_recovered_from_the_omni_D(omni: DynamicModel) -> None:
    """β̃ = 1/D[yaw, yaw], C = 1/(C̄₀ D[yaw, yaw]) of the derived model at Table 1's configurations."""
    values = dict(omni.parameters)
    values.update({sp.Symbol("m1"): 0.045, sp.Symbol("m2"): 0.052, sp.Symbol("I_base"): 1.4e-3,
                   sp.Symbol("gamma_offs"): math.radians(9.931)})
    values = {next(p for p in omni.parameter_symbols if p.name == str(k)): v for k, v in values.items()}
    d = sp.lambdify(omni.coordinates, omni.D[0, 0].subs(values), "numpy")
    g1, g2 = np.radians(np.array(TABLE3_TRUE_ANGLES)).T
    inertia_values = d(np.zeros_like(g1), g1, g2)
    c0 = 36.7
    fit = fit_inertia_model(g1, g2, 1 / (c0 * inertia_values), 1 / inertia_values)
    expected = inertia_form(omni, "theta", "gamma1", "gamma2", "gamma_offs").values(values)
    assert fit.model.coefficients == pytest.approx(expected, rel=0.02)
    assert fit.model.offset == pytest.approx(math.radians(9.931), rel=0.02)
    assert fit.model.c0 == pytest.approx(c0, rel=0.02)
    assert fit.model.valid


def test_damping_ratio_is_regression_through_origin() -> None:
    C = np.array([5.0, 6.0, 7.0])
    assert damping_ratio(C, 36.0 * C) == pytest.approx(36.0, rel=1e-15)
    assert damping_ratio([1.0, 2.0], [30.0, 80.0]) == pytest.approx((30 + 160) / 5)


def test_inertia_fit_bad_input() -> None:
    with pytest.raises(DataError) as e:
        fit_inertia_model([0.1] * 5, [0.2] * 5, [1.0] * 5, [1.0] * 5)
    assert "at least 6" in one_line(e)
    with pytest.raises(DataError) as e:
        fit_inertia_model([0.1] * 6, [0.2] * 6, [1.0] * 5 + [-1.0], [1.0] * 6)
    assert "must be positive" in one_line(e)


# ---------------------------------------------------------------------------------- reproduction


def test_table5_determines_table4_one_row_up() -> None:
    """Table 5's modelled β̃ = 1/I fix the inertias of (6) linearly: Table 4's values, one row up."""
    g1, g2 = np.radians([[float(r[2]), float(r[3])] for r in milne_sine.TABLE3]).T
    inertia_values = 1 / np.array([float(b) for _, b in milne_sine.TABLE5_MODELLED])
    offset = math.radians(float(milne_sine.TABLE4["gamma_offs"]))
    basis = np.column_stack([inertia([1, 0, 0, 0], offset, g1, g2), inertia([0, 1, 0, 0], offset, g1, g2),
                             inertia([0, 0, 1, 0], offset, g1, g2), inertia([0, 0, 0, 1], offset, g1, g2)])
    coefficients, *_ = np.linalg.lstsq(basis, inertia_values, rcond=None)
    assert np.max(np.abs(basis @ coefficients / inertia_values - 1)) < 1e-4  # Table 5's rounding
    printed = milne_sine.TABLE4
    assert coefficients[:3] == pytest.approx([float(printed[k]) for k in ("I1", "I2", "I3")], rel=1e-3)
    assert all(abs(c / float(printed["I_base"]) - 1) > 0.1 for c in coefficients)  # 1.063e-3 fits none (nearest: I2, 12 % off)


def test_sine_identification_items() -> None:
    found = {i.item: i for i in milne.sine_identification_items()}
    assert all(i.source == "milne" for i in found.values())
    assert found["Table 3 C̄0 ratio"].status == "matches"
    assert found["Table 5 modelled C_linear, β̃_linear"].status.startswith("matches after correcting Table 4")
    assert len(found["Table 5 modelled C_linear, β̃_linear"].ours) == 18
    assert found["3.3 linear resonant frequency"].status == "matches"
    assert found["Table 4 I_base, I1, I2, γ_offs, C̄0 fitted to Table 3"].status == "differs"
    assert found["Table 3 fitted C_linear, β̃_linear (22)"].status.startswith("not reproducible")


def test_table4_as_printed_does_not_give_table5() -> None:
    printed = np.array([float(x) for row in milne_sine.TABLE5_MODELLED for x in row])
    assert np.max(np.abs(milne_sine._as_printed_table5() / printed - 1)) > 0.5


def test_rounding_tolerance_of_a_sum() -> None:
    """x + y from "1.00" and "2.0": half units 0.005 + 0.05, plus the output's own 0.05 for "3.0"."""
    tolerance = milne_sine.rounding_tolerance(lambda v: v["x"] + v["y"], {"x": "1.00", "y": "2.0"}, ["3.0"])
    assert tolerance == pytest.approx((0.005 + 0.05 + 0.05) / 3.0)


# ------------------------------------------------------------------ end to end on the simulated Omni


@pytest.mark.slow
def test_milne_experiment_on_the_simulated_omni(tmp_path: Path) -> None:
    """Milne's whole chain on the built-in omni with viscous friction, simulated by symbolic.numeric.

    Yaw under P control (kp = 0.4), γ₁, γ₂ held by PD loops that sag under gravity (as on the real
    Omni, the true angles differ from the set angles). Per configuration identify_joint gives
    β̃_linear = 1/D[yaw, yaw] and C_linear = Fv/D[yaw, yaw]; the fit of (27)–(29) must return the
    symbolic extraction's I's and γ_offs within 2 % (they come within 0.6 %). The discrete loop (zero-order hold at 2 kHz) acts
    as a half-sample delay: C_loop = C − β·T/2, so C̄0 = 1/(Fv − kp·T/2).
    """
    fv, kp, rate = 0.01, 0.4, 2_000.0
    text = robots.path("omni").read_text().replace("gamma_offs = { value = 0.0,", "gamma_offs = { value = 0.17,")
    text = text.replace("[parameters]\n", f"[parameters]\nFv = {{ value = {fv} }}\nFv1 = {{ value = 0.05 }}\n")
    text += "".join(f'\n[[friction]]\ncoordinate = "{c}"\nviscous = "{v}"\n'
                    for c, v in (("theta", "Fv"), ("gamma1", "Fv1"), ("gamma2", "Fv1")))
    (tmp_path / "omni_friction.toml").write_text(text)
    model = derive(symbolic.load(tmp_path / "omni_friction.toml"))
    d = sp.lambdify(model.coordinates[1:], model.D[0, 0].subs(model.parameters), "math")
    t = np.arange(0, 5, 1 / rate)  # C = Fv/I ≈ 7–15 1/s: after 3 s the transient is below e^(−10)
    frequencies = [2.0, 3.5, 5.0]
    controller = {"kind": "pd", "kp": [kp, 2.0, 2.0], "kd": [0.0, 0.02, 0.02], "reference": "ref"}
    g1, g2, C, beta_tilde = [], [], [], []
    for set1, set2 in ((25, 70), (25, 90), (25, 115), (45, 70), (45, 90), (45, 115), (65, 70), (65, 90), (65, 115)):
        logs, angles = [], []
        for f in frequencies:
            ref = np.column_stack([0.01 * np.sin(2 * np.pi * f * t), np.full_like(t, math.radians(set1)),
                                   np.full_like(t, math.radians(set2))])
            log = Measurements.from_arrays(t, ["theta", "gamma1", "gamma2"], ref, np.zeros_like(ref), ref=ref)
            q = simulate(model, log, controller=controller).simulated.q
            angles.append(q[t.size // 2:, 1:].mean(axis=0))
            yaw = Measurements.from_arrays(t, ["theta"], q[:, :1], np.zeros((t.size, 1)), ref=ref[:, :1])
            logs.append(Experiment.of(yaw, controller={"kind": "pd", "kp": [kp], "kd": [0.0], "reference": "ref"}))
        result = sine.identify_joint(logs, frequencies, transient=3.0)
        measured = np.mean(angles, axis=0)
        assert result.beta_tilde == pytest.approx(1 / d(*measured), rel=5e-3)
        g1.append(measured[0]), g2.append(measured[1]), C.append(result.linear.C), beta_tilde.append(result.beta_tilde)
    fit = fit_inertia_model(g1, g2, C, beta_tilde)
    expected = inertia_form(model, "theta", "gamma1", "gamma2", "gamma_offs").values(model.parameters)
    assert fit.model.coefficients == pytest.approx(expected, rel=0.02)
    assert fit.model.offset == pytest.approx(0.17, rel=0.02)
    assert fit.model.c0 == pytest.approx(1 / (fv - kp / rate / 2), rel=0.01)
