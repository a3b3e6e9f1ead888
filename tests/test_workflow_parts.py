"""Parts of the discrepancy workflow against independent references: the residual statistics, the
localisation, the data split, byte-identical output, a model given without a file.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.stats

import models
import symbolic
import workflow_cases as cases
from symbolic.workflow import diagnose
from symbolic.data.times import time_windows
from symbolic.workflow.dataset import load_sets, split, time_slice
from symbolic.workflow.report import markdown
from symbolic.workflow.statistics import autocorrelation, autocorrelation_time, f_test, ljung_box


def ar1(n: int, phi: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = rng.normal(size=n + 200)
    x = np.zeros_like(e)
    for k in range(1, len(e)):
        x[k] = phi * x[k - 1] + e[k]
    return x[200:]


def test_autocorrelation_matches_the_direct_sum() -> None:
    x = np.random.default_rng(0).normal(size=500).cumsum()
    direct = np.correlate(x - x.mean(), x - x.mean(), "full")[499:] / np.sum((x - x.mean()) ** 2)
    assert np.allclose(autocorrelation(x, 40), direct[:41], atol=1e-12)


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.8])
def test_autocorrelation_time_of_an_ar1_series(phi: float) -> None:
    """τ_int = (1 + φ)/(1 − φ) for AR(1) (1, 3, 9), within 10 %."""
    assert autocorrelation_time(ar1(200_000, phi, 1)) == pytest.approx((1 + phi) / (1 - phi), rel=0.1)


def test_ljung_box_by_its_formula() -> None:
    x = ar1(2000, 0.3, 2)
    q, p, lags = ljung_box(x, 10)
    xc = x - x.mean()
    rho = [np.sum(xc[k:] * xc[:-k]) / np.sum(xc * xc) for k in range(1, 11)]
    expected = 2000 * 2002 * sum(r**2 / (2000 - k) for k, r in enumerate(rho, start=1))
    assert q == pytest.approx(expected, rel=1e-10)
    assert p == pytest.approx(scipy.stats.chi2.sf(expected, 10), rel=1e-9)


def test_corrected_f_test_holds_its_level_on_coloured_noise() -> None:
    """Adding a slowly varying regressor that does not act: with AR(1) noise (φ = 0.8) the plain F-test
    rejects far more often than its level; divided by τ_int it stays near 5 %."""
    rng = np.random.default_rng(3)
    n, trials = 2000, 300
    t = np.linspace(0, 1, n)
    X = np.column_stack([np.ones(n), np.sin(2 * np.pi * t)])
    plain = corrected = 0
    for trial in range(trials):
        y = ar1(n, 0.8, 100 + trial)
        z = np.sin(2 * np.pi * 3 * t + rng.uniform(0, 2 * np.pi))
        r0 = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
        X1 = np.column_stack([X, z])
        r1 = y - X1 @ np.linalg.lstsq(X1, y, rcond=None)[0]
        rss0, rss1 = r0 @ r0, r1 @ r1
        plain += f_test(rss0, rss1, n, 2, 1, 1.0)[1] < 0.05
        corrected += f_test(rss0, rss1, n, 2, 1, autocorrelation_time(r1))[1] < 0.05
    assert plain / trials > 0.3
    assert corrected / trials < 0.1


def test_split_and_slice_keep_every_signal() -> None:
    m = cases.measurements(models.axis(), 1, 0.0, seconds=2.0)
    first, last = split(m)
    assert first.samples + last.samples == m.samples
    assert last.t[0] > first.t[-1] and last.samples == round(0.2 * m.samples)
    cut = time_slice(m, 10, 20)
    assert np.array_equal(cut.q, m.q[10:20]) and np.array_equal(cut.tau, m.tau[10:20]) and cut.sample_period == m.sample_period


def test_where_points_at_velocity_for_a_missing_coulomb_term(tmp_path: Path) -> None:
    model, truth = models.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), models.axis()
    d = diagnose(cases.model_file(tmp_path, model), cases.measurements(truth, 1, 0.01), figures=False)
    where = d.where_before["coordinates"]["q"]
    eta = {kind: where[kind]["eta_squared"] for kind in ("position", "velocity", "acceleration")}
    assert max(eta, key=eta.get) == "velocity" and eta["velocity"] > 0.5, eta
    assert where["sign"]["difference"] > 0 and where["sign"]["p_value"] < 1e-6
    assert d.where_before["left"] and "velocity on q" in d.where_before["verdict"]
    assert not d.where_after["dependent"]


def test_output_is_byte_identical_from_run_to_run(tmp_path: Path) -> None:
    model, truth = models.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), models.axis()
    data, path = cases.measurements(truth, 1, 0.01), cases.model_file(tmp_path, model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        first = diagnose(path, data, out=tmp_path / "a")
        diagnose(path, data, out=tmp_path / "b")
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert "report.md" in names and "axis_patched.toml" in names
    assert names == sorted(p.name for p in (tmp_path / "b").iterdir())
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    assert sorted(f.name for f in first.figures) == [n for n in names if n.endswith(".png")]


def test_a_model_without_a_file_is_diagnosed_but_not_patched() -> None:
    robot = symbolic.loads(models.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), "<python>")
    d = diagnose(robot, cases.measurements(models.axis(), 1, 0.01))
    assert [f.effect for f in d.found] == ["coulomb"] and d.patched_path is None and d.patched_text is None
    assert d.after.gap["validation"] < 0.1 * d.before.gap["validation"]
    assert any("no file" in note for note in d.notes)


def test_the_held_out_tail_continues_the_record_for_a_resonance() -> None:
    """A load that still rings when the held-out tail begins (a move ended 1.4 s before it, ζ = 0.01): its
    column on the tail, computed through the record the tail continues, is the load's acceleration of the
    coupled ODE integrated from rest (within 0.1 % of its peak; bilinear transform at 500 Hz); started on
    the tail alone (no record), the load's ringing is lost and the column is wrong by far more."""
    import scipy.integrate

    from symbolic.workflow.effects import FlexibleMode, Signals

    rate, start, w, zeta = 500.0, 1000, 2 * np.pi * 5.0, 0.01
    t = np.arange(0.0, 6.0, 1.0 / rate)
    u = (t - 0.6) / 0.1
    q = np.exp(-(u**2))  # a smooth move and back, centred at 0.6 s
    qd = -2 * u / 0.1 * q
    qdd = (4 * u**2 - 2) / 0.01 * q

    def load(s: float, x: np.ndarray) -> np.ndarray:
        r = (s - 0.6) / 0.1
        p, v = np.exp(-(r**2)), -2 * r / 0.1 * np.exp(-(r**2))
        return np.array([x[1], w * w * (p - x[0]) + 2 * zeta * w * (v - x[1])])

    tail = t[start:]
    sol = scipy.integrate.solve_ivp(load, (0.0, t[-1]), [0.0, 0.0], t_eval=tail, rtol=1e-11, atol=1e-13, max_step=0.01)
    reference = np.array([load(s, x)[1] for s, x in zip(tail, sol.y.T)])
    whole = Signals(q[:, None], qd[:, None], qdd[:, None], t, rate)
    part = [x[start:, None] for x in (q, qd, qdd)]
    effect = FlexibleMode()
    continued = effect.columns_at(Signals(*part, tail, rate, None, whole, start), 0, (5.0, zeta))[:, 0, 0]
    alone = effect.columns_at(Signals(*part, tail, rate), 0, (5.0, zeta))[:, 0, 0]
    peak = np.max(np.abs(reference))
    assert peak > 1.0  # the load still rings on the tail
    assert np.max(np.abs(continued - reference)) < 1e-3 * peak
    assert np.max(np.abs(alone - reference)) > 0.5 * peak


def test_only_the_held_out_tail_of_the_record_continues_it() -> None:
    data = cases.measurements(models.axis(), 2, 0.01, seconds=10.0)
    estimation, held, _ = load_sets(("q",), data)
    assert estimation.record is None and held.record is not None and held.start == estimation.measurements.samples
    assert np.allclose(held.record.measurements.q[held.start:], held.measurements.q)
    other = load_sets(("q",), data, validation=data)[1]
    assert other.record is None


def test_diagnose_accepts_a_built_in_name_as_the_cli_does() -> None:
    """``diagnose("emps", ...)`` derives the built-in model (the CLI's MODEL argument is a path or a name)."""
    from symbolic.workflow.diagnosis import _derived

    assert _derived("emps").name == "emps"


def test_a_replaced_parameter_leaves_the_patched_file() -> None:
    """asymmetric_viscous replaces `viscous = "Fv"`: Fv, used before and no longer, is removed with a note;
    a parameter the original did not use either (the user's own) stays."""
    import tomllib

    from symbolic.workflow.patch import Editor

    text = models.axis(parameters="Fv = 0.3\nFc = 0.4\nspare = 1.0\n")
    robot = symbolic.loads(text, "axis.toml")
    editor = Editor(text, robot, "axis.toml")
    positive = editor.parameter("Fvp_q", 0.2, "test")
    negative = editor.parameter("Fvn_q", 0.4, "test")
    editor.set_friction("q", "viscous", {"positive": positive, "negative": negative}, "test")
    assert editor.drop_unused() == ["Fv"]
    patched = editor.text()
    parameters = tomllib.loads(patched)["parameters"]
    assert "Fv" not in parameters and {"Fc", "spare", "Fvp_q", "Fvn_q"} <= set(parameters)
    assert "removed Fv, no longer used" in patched
    symbolic.derive(symbolic.loads(patched, "axis.toml"))


def test_a_resonance_must_ring_in_the_residual() -> None:
    """FlexibleMode.check_residual: a damped 9 Hz oscillation in white noise is a peak near a 9 Hz (or
    8 Hz) load; no peak near 3 Hz, and white noise alone has none — unless the fit explains most of it."""
    from symbolic.workflow.effects import FlexibleMode
    from symbolic.workflow.where import spectrum

    rate, rng = 100.0, np.random.default_rng(3)
    t = np.arange(6000) / rate
    ringing = sum(np.exp(-2.0 * (t - t0)) * np.sin(2 * np.pi * 9.0 * (t - t0)) * (t >= t0) for t0 in range(0, 60, 2))
    noise = 0.05 * rng.normal(size=t.size)
    flex = FlexibleMode()
    for f in (9.0, 8.0):
        assert flex.check_residual({"frequency_hz": f}, *spectrum(ringing + noise, rate), 0.2) is None
    assert "no ringing" in flex.check_residual({"frequency_hz": 3.0}, *spectrum(ringing + noise, rate), 0.2)
    assert "no ringing" in flex.check_residual({"frequency_hz": 9.0}, *spectrum(noise, rate), 0.2)
    assert flex.check_residual({"frequency_hz": 9.0}, *spectrum(noise, rate), FlexibleMode.DOMINANT) is None


def test_periodic_time_scan_columns_match_sines_and_cosines() -> None:
    """The periodic-in-time grid's phasors by angle addition (issue 23 §2) are its sines and cosines, over an
    evenly spaced chunk of 64 frequencies near 20 Hz on 30 s of jittered time stamps: to 3e-12 of the values in
    extended precision, where the phases reach 3800 rad (sines of float64 phases are themselves good to
    about 3800 × 2.2e-16 ≈ 8e-13 there)."""
    from symbolic.workflow.effects import PeriodicTime

    rng = np.random.default_rng(6)
    t = np.cumsum(rng.uniform(0.009, 0.011, 3000))
    values = np.linspace(1.0, 40.0, 2000)[1000:1064]
    columns = PeriodicTime().scan_columns(t, 7, 2, values)
    if np.finfo(np.longdouble).eps >= np.finfo(float).eps:
        pytest.skip("no extended precision on this platform")
    x = 8 * np.arctan(np.longdouble(1)) * np.outer(values.astype(np.longdouble), t.astype(np.longdouble))
    assert columns.shape == (64, len(t), 2)
    assert np.max(np.abs(columns[:, :, 0] - np.sin(x))) < 3e-12 and np.max(np.abs(columns[:, :, 1] - np.cos(x))) < 3e-12


def test_report_time_windows_of_a_clock_near_1000_s() -> None:
    """A log whose clock starts at 1000 s: the report's time windows once read ``1e+03–1e+03 s``. Each
    header must give its window's own start and stop: the edges of the ten windows of the estimation set,
    to the decimals that resolve their width (3 significant digits of about 3.2 s: 2 decimals)."""
    data = cases.measurements(models.axis(), 1, 0.01)
    late = dataclasses.replace(data, t=data.t + 1000.0)
    d = diagnose(symbolic.loads(models.axis(), "<python>"), late)
    report = markdown(d)
    header = next(line for line in report.splitlines() if line.startswith("| coordinate | 1000"))
    spans = header.strip("| ").split(" | ")[1:]
    windows = d.where_before["coordinates"]["q"]["time"]
    assert len(spans) == len(windows) == 10
    for span, w in zip(spans, windows):
        start, stop = span.removesuffix(" s").split("–")
        assert len(start.partition(".")[2]) == 2 and len(stop.partition(".")[2]) == 2, span
        assert float(start) == pytest.approx(w["start"], abs=0.005) and float(stop) == pytest.approx(w["stop"], abs=0.005)
    assert spans[0].startswith("1000.") and len(set(spans)) == 10


def test_time_windows_resolve_the_narrowest_width() -> None:
    """Decimals from the width, not the clock: 3 significant digits of the narrowest window."""
    assert time_windows([(1000.0, 1000.0123)]) == ["1000.0000–1000.0123 s"]
    assert time_windows([(1e6, 1e6 + 250.0), (1e6 + 250.0, 1e6 + 255.5)]) == ["1000000.00–1000250.00 s",
                                                                           "1000250.00–1000255.50 s"]
    # instants: the step between them
    assert time_windows([(5.0, 5.0), (5.002, 5.002)]) == ["5.00000–5.00000 s", "5.00200–5.00200 s"]
    assert time_windows([(7.0, 7.0)]) == ["7.000–7.000 s"]


def test_a_normal_system_that_is_not_finite_explains_nothing() -> None:
    """Columns overflowing on hostile data give a Gram matrix with inf or NaN: the candidate gets zero coefficients
    (it explains nothing, so nothing is named) instead of a LinAlgError traceback (issue 39's fuzz found one)."""
    from symbolic.workflow.terms import solve_normal

    gram = np.array([[np.inf, 1.0], [1.0, 2.0]])
    assert solve_normal(gram, np.array([1.0, 2.0])).tolist() == [0.0, 0.0]
    assert solve_normal(np.eye(2), np.array([np.nan, 1.0])).tolist() == [0.0, 0.0]
    np.testing.assert_allclose(solve_normal(np.array([[4.0, 0.0], [0.0, 1.0]]), np.array([2.0, 3.0])), [0.5, 3.0])


def test_a_fold_does_not_fit_a_column_its_training_blocks_do_not_hold():
    """Cross-validation: a candidate's column that lives in the held-out block alone (a transient at the record's
    start) gets coefficient 0 on the other blocks — they cannot tell it — and the model's columns their own least
    squares there (to 1e-12); a column the training blocks hold is fitted as before."""
    from symbolic.workflow.search import _fold_solve

    rng = np.random.default_rng(3)
    X, y = rng.normal(size=(200, 2)), rng.normal(size=200)
    local = np.zeros(200)
    local[:20] = np.exp(-np.arange(20) / 3.0)
    local[20:] = 1e-9 * rng.normal(size=180)  # rounding-level leftovers on the training blocks
    train = slice(20, None)
    for Z, fitted in ((local, False), (rng.normal(size=200), True)):
        A = np.column_stack([X, Z])
        coef = _fold_solve(A[train].T @ A[train], A[train].T @ y[train], 2, np.array([Z @ Z]))
        expected = np.linalg.lstsq(A[train] if fitted else X[train], y[train], rcond=None)[0]
        assert coef == pytest.approx(expected if fitted else [*expected, 0.0], rel=1e-12, abs=1e-12)


def test_treated_columns_sent_in_one_piece_come_back_the_same() -> None:
    """The forked child's new treated columns travel as one array (search._packed) and are rebuilt exactly."""
    from symbolic.workflow.search import _packed, _unpacked

    rng = np.random.default_rng(4)
    store = {("periodic", 0, 0.5, "estimation"): (np.array([0]), rng.normal(size=(30, 1, 2))),
             ("payload", 1, None, "estimation"): (np.array([0, 1]), rng.normal(size=(30, 2, 4))),
             ("flexible_mode", 1, (2.0, 0.1), "validation"): (np.array([1]), rng.normal(size=(7, 1, 1)))}
    back = _unpacked(*_packed(store))
    assert list(back) == list(store)
    for key, (rows, part) in store.items():
        assert np.array_equal(back[key][0], rows) and back[key][0].dtype == rows.dtype
        assert np.array_equal(back[key][1], part) and back[key][1].shape == part.shape
    assert _unpacked(*_packed({})) == {}


def test_treated_columns_written_to_shared_memory_come_back_the_same() -> None:
    """With an arena (memory shared with the forked child) the numbers go there and only their count travels; an
    arena too small for them leaves them in the array sent."""
    import mmap

    from symbolic.workflow.search import _packed, _unpacked

    rng = np.random.default_rng(5)
    store = {("periodic", 0, 0.5, "estimation"): (np.array([0]), rng.normal(size=(30, 1, 2))),
             ("payload", 1, None, "estimation"): (np.array([0, 1]), rng.normal(size=(30, 2, 4)))}
    arena = mmap.mmap(-1, 8 * 300)
    packed = _packed(store, arena)
    assert packed[2] == 300
    back = _unpacked(*packed, arena=arena)
    for key, (rows, part) in store.items():
        assert np.array_equal(back[key][0], rows) and np.array_equal(back[key][1], part)
    small = _packed(store, mmap.mmap(-1, 8 * 299))
    assert isinstance(small[2], np.ndarray) and small[2].size == 300
    assert all(np.array_equal(_unpacked(*small)[key][1], part) for key, (_, part) in store.items())


def test_the_base_columns_are_shared_by_the_data_with_a_held_force() -> None:
    """The held-force check refits on the same states with τ treated otherwise: the model's columns are computed
    once (the same array), and equal those of a fresh computation."""
    from symbolic.workflow.dataset import with_held_force
    from symbolic.workflow.terms import model_terms

    data = cases.measurements(models.axis(), 3, 0.01, seconds=10.0)
    estimation, _, _ = load_sets(("q",), data)
    model = symbolic.derive(symbolic.loads(models.axis(), "axis.toml"))
    terms = model_terms(model)
    columns = terms.columns(estimation)
    held = with_held_force(estimation)
    assert held.states is not estimation.states and terms.columns(held) is columns
    s = estimation.states
    assert np.array_equal(columns, estimation.reduce(terms.regressor(s.q, s.qd, s.qdd, t=estimation.measurements.t)))


def test_quantisation_floor_is_the_differentiated_rounding() -> None:
    """where.quantisation_floor against its closed form: a 14-bit encoder's rounding, white of variance δ²/12 at
    f_s (one-sided density 2δ²/(12 f_s)), through the zero-phase Butterworth (|H|⁴ = 1/(1 + (f/f_c)^(2·order))²)
    and two central differences ((f_s·sin(2πf/f_s))⁴), times D = J² on the axis: over 20–80 % of the decimated
    band its mean ratio to the closed form is within 5 % of 1, every Welch bin within 0.7–1.4 (8 draws)."""
    from symbolic.workflow.dataset import treat
    from symbolic.workflow.where import quantisation_floor, spectrum

    data = treat(cases.measurements(models.axis(), 1, 0.01), "estimation")
    p, fs = data.states.processing, data.measurements.rate
    delta, J = 2 * np.pi / 2**14, 0.05
    floor = quantisation_floor(data, [delta], lambda q: np.array([[J]]))[0]
    f, _ = spectrum(data.tau[:, 0], p.rate / p.decimation)
    closed = J**2 * 2 * delta**2 / 12 / fs * (fs * np.sin(2 * np.pi * f / fs)) ** 4 / (1 + (f / p.cutoff) ** (2 * p.order)) ** 2
    edge = 0.8 * fs / 2 / p.decimation
    band = (f > 0.2 * edge) & (f < 0.8 * edge)
    ratio = floor[band] / closed[band]
    assert band.sum() > 40 and abs(ratio.mean() - 1) < 0.05 and 0.7 < ratio.min() and ratio.max() < 1.4
    assert quantisation_floor(data, [0.0], lambda q: np.array([[J]])) is None


def test_a_14_bit_arm_with_nothing_missing_names_no_resonance(tmp_path: Path) -> None:
    """The 2-link arm under PD at 500 Hz with 14-bit encoders and 0.05 N·m force noise (seed 5), its model the
    truth: the rounding differentiated twice makes a hump of the residual's spectrum below the kept band's edge
    (a 15.8 Hz peak 13× its median), and a load on q1 at 15.5 Hz was named there. The peak stands 1.9× above the
    encoders' rounding (where.quantisation_floor), under FlexibleMode.ABOVE_FLOOR: nothing is named."""
    from reference_integrator import write_arm_experiment

    experiment = write_arm_experiment(tmp_path / "arm", seconds=6.0, force_noise=0.05, seed=5, counts=2**14)
    model = tmp_path / "arm.toml"
    model.write_text(models.arm())
    d = diagnose(str(model), str(experiment), figures=False)
    assert [f.label() for f in d.found] == []
    flex = [c for r in d.search.rounds for c in r.candidates if c.effect.name == "flexible_mode" and c.coordinate == "q1"]
    assert flex and "rounding" in (flex[0].invalid or "")


@pytest.mark.slow
def test_arms_with_coarse_encoders_and_nothing_missing_name_nothing(tmp_path: Path) -> None:
    """Thirteen null cases of the equation error at coarse resolution: the 2-link arm of
    tests/reference_integrator.py under PD at 500 Hz, 14-bit encoders with seeds 0–9 and 12-bit ones with seeds 0–2,
    0.05 N·m force noise, its model the truth. Before a resonance's peak had to stand above the encoders' rounding,
    every one of the ten at 14 bits named a flexible_mode on q1 (and none of ten at 12 bits)."""
    from reference_integrator import write_arm_experiment

    model = tmp_path / "arm.toml"
    model.write_text(models.arm())
    named = {}
    for counts, seeds in ((2**12, 3), (2**14, 10)):
        for seed in range(seeds):
            experiment = write_arm_experiment(tmp_path / f"arm_{counts}_{seed}", seconds=6.0, force_noise=0.05,
                                              seed=seed, counts=counts)
            found = [f.label() for f in diagnose(str(model), str(experiment), figures=False).found]
            if found:
                named[(counts, seed)] = found
    assert named == {}
