"""symbolic.data.filters against SciPy's reference filters and the closed-form responses."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from symbolic.data import filters

RATE = 1000.0


def test_lowpass_equals_filtfilt_with_matlabs_padding() -> None:
    """Second-order sections, padded by 3·order odd-reflected samples, as MATLAB's filtfilt([b,a]) pads."""
    x = np.random.default_rng(0).normal(size=3000).cumsum()
    b, a = scipy.signal.butter(4, 100 / (RATE / 2))
    reference = scipy.signal.filtfilt(b, a, x, padtype="odd", padlen=12)
    np.testing.assert_allclose(filters.lowpass(x, 100.0, RATE), reference, rtol=0, atol=1e-10 * np.abs(x).max())


@pytest.mark.parametrize("frequency", [10.0, 100.0, 150.0])
def test_lowpass_is_zero_phase_with_squared_butterworth_gain(frequency: float) -> None:
    t = np.arange(20_000) / RATE
    x = np.sin(2 * np.pi * frequency * t)
    y = filters.lowpass(x, 100.0, RATE, order=4)
    gain = 1 / (1 + (np.tan(np.pi * frequency / RATE) / np.tan(np.pi * 100.0 / RATE)) ** 8)  # bilinear, both passes
    middle = slice(5000, 15000)
    np.testing.assert_allclose(y[middle], gain * x[middle], atol=1e-9)


def test_lowpass_refuses_a_cutoff_above_nyquist() -> None:
    with pytest.raises(ValueError, match="Nyquist frequency 500 Hz"):
        filters.lowpass(np.zeros(100), 600.0, RATE)


def test_central_difference_error_is_the_truncation_term() -> None:
    h, w = 1e-3, 2 * np.pi * 5.0
    t = np.arange(2000) * h
    d = filters.central_difference(np.sin(w * t), h)
    inner = slice(1, -1)
    factor = np.sin(w * h) / (w * h)  # exact for a sinusoid: 1 − (ωh)²/6 + ...
    np.testing.assert_allclose(d[inner], factor * w * np.cos(w * t[inner]), atol=1e-9)
    assert 1 - factor == pytest.approx((w * h) ** 2 / 6, rel=1e-3)
    assert d[0] == pytest.approx((np.sin(w * h) - 0) / h) and d.shape == t.shape


@pytest.mark.parametrize("samples", [3001, 3005])
def test_decimate_matches_scipy_away_from_the_ends_and_keeps_the_last_sample(samples: int) -> None:
    x = np.random.default_rng(1).normal(size=samples).cumsum()
    y = filters.decimate(x, 10)
    kept = filters.kept_indices(samples, 10)
    assert kept[-1] == samples - 1 and np.all(np.diff(kept) == 10) and kept[0] < 10
    assert len(y) == len(kept)
    shift = kept[0]
    reference = scipy.signal.decimate(x[shift:], 10, ftype="iir", zero_phase=True)  # keeps the first sample
    # SciPy pads 27 samples, MATLAB and we 24: the two differ near the ends only (the filter's tail)
    middle = slice(100, -100)
    np.testing.assert_allclose(y[middle], reference[middle], rtol=0, atol=1e-10 * np.abs(x).max())


def test_decimate_passes_slow_signals_within_the_ripple() -> None:
    t = np.arange(10_000) / RATE
    x = np.sin(2 * np.pi * 3.0 * t)
    y = filters.decimate(x, 10)
    kept = filters.kept_indices(len(t), 10)
    ratio = y[50:-50] @ x[kept][50:-50] / (x[kept][50:-50] @ x[kept][50:-50])
    assert 10 ** (-0.1 / 20) - 1e-6 <= ratio <= 1 + 1e-6  # 0.05 dB ripple, twice
    assert np.array_equal(filters.decimate(x, 1), x)


def _log(samples: int, identification: dict | None) -> "Measurements":
    from symbolic.data import Experiment, Settings
    from symbolic.data.measurements import Source, assemble

    t = np.arange(samples) / 1000.0
    signals = {"t": t, "q_q": np.sin(3 * t), "tau_q": np.cos(3 * t)}
    measurements = assemble(signals, Source("log.csv", lambda name: f"column {name}"))
    return Experiment.of(measurements, settings=Settings.from_table(identification, "log.csv"))


@pytest.mark.parametrize("table", [None, {"bandwidth": 10.0}, {"cutoff": 80.0, "order": 2},
                                   {"filter_positions": False}, {"border": [7, 30]}])
def test_simulation_comparison_and_identification_share_one_treatment(table) -> None:
    """The comparison's q̇, q̈ and border are identification's (symbolic.data.treatment), for every key."""
    from symbolic.data.treatment import states
    from symbolic.simulation.comparison import measured_motion

    log = _log(2000, table)
    ours, theirs = measured_motion(log), states(log)
    assert ours.treatment.cutoff == theirs.processing.cutoff
    assert ours.treatment.border == max(theirs.processing.border)
    assert np.array_equal(ours.qd, theirs.qd) and np.array_equal(ours.qdd, theirs.qdd)


def test_comparison_refuses_what_identification_refuses_in_the_same_words() -> None:
    """The [identification] table is checked once, where the experiment is read (Settings.from_table):
    identification and the comparison of a simulation take the same checked settings."""
    from symbolic.data import DataError

    with pytest.raises(DataError, match=r"\[identification\] smoothing: unknown key \(allowed: bandwidth, cutoff"):
        _log(200, {"smoothing": 3})
    with pytest.raises(DataError, match=r"\[identification\] ordre: unknown key .*; did you mean 'order'\?$"):
        _log(200, {"ordre": 3})
    with pytest.raises(DataError, match=r"\[identification\] order: expected a positive integer"):
        _log(200, {"order": 0})


def test_comparison_of_a_short_log_runs_unfiltered_where_identification_refuses() -> None:
    from symbolic.data import DataError
    from symbolic.data.treatment import states
    from symbolic.simulation.comparison import treatment

    how = treatment(_log(10, None))
    assert how.cutoff is None and how.border == 2 and "too few for the low-pass" in how.note
    with pytest.raises(DataError, match="too few"):
        states(_log(10, None))


def test_a_held_force_is_compared_as_its_mean_over_the_sample() -> None:
    """held_force: (τ_{k−1} + τ_k)/2 against the states at t_k; the key is checked like the others."""
    from symbolic.data import DataError
    from symbolic.data.treatment import Settings

    p = Settings(held_force=True).resolve(1000.0, 2000)
    tau = np.array([[1.0], [3.0], [5.0], [4.0]])
    assert p.forces(tau)[:, 0].tolist() == [1.0, 2.0, 4.0, 4.5]
    assert np.array_equal(Settings().resolve(1000.0, 2000).forces(tau), tau)
    with pytest.raises(DataError, match=r"\[identification\] held_force: expected true or false"):
        Settings().merged({"held_force": "yes"}, "exp.toml")
