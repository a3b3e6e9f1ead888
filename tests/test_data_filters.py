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
