"""symbolic.data.filters, NumPy only, against SciPy (the reference here, not a dependency of the module).

The designs are compared with ``scipy.signal.butter`` and ``cheby1`` (second-order sections and frequency
responses) and with the closed-form magnitudes of Butterworth and Chebyshev filters; the filtering with
``scipy.signal.sosfiltfilt(sos, x, padtype="odd", padlen=...)`` and, where the poles are near the unit
circle, with the same sections run sample by sample in extended precision (``np.longdouble``). Tolerances
are relative to the largest magnitude of the reference.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from symbolic.data import filters

ORDERS = range(1, 17)
CUTOFFS = (1e-3, 3e-3, 1e-2, 0.1, 0.3, 0.5, 0.8, 0.95)
"""Cut-offs as fractions of the Nyquist frequency."""


def _walk(samples: int, columns: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(samples, columns)).cumsum(axis=0)


def _close_rows(ours: np.ndarray, theirs: np.ndarray, rtol: float) -> None:
    """Sections equal to ``rtol`` of each section's largest coefficient (the first holds the gain)."""
    assert ours.shape == theirs.shape
    scale = np.abs(theirs).max(axis=1, keepdims=True)
    assert np.all(np.abs(ours - theirs) <= rtol * scale), np.abs(ours - theirs).max()


def _response(sos: np.ndarray, w: np.ndarray) -> np.ndarray:
    """H(e^{iw}) of second-order sections, evaluated directly (not by SciPy)."""
    z = np.exp(-1j * w)[:, None]
    b, a = sos[:, :3], sos[:, 3:]
    return np.prod((b[:, 0] + b[:, 1] * z + b[:, 2] * z**2) / (a[:, 0] + a[:, 1] * z + a[:, 2] * z**2), axis=1)


@pytest.mark.parametrize("order", ORDERS)
def test_butterworth_sections_are_scipys(order: int) -> None:
    for cutoff in CUTOFFS:
        ours = filters._butterworth(order, cutoff)
        theirs = scipy.signal.butter(order, cutoff, output="sos")
        _close_rows(ours, theirs, 1e-13)
        w, h_theirs = scipy.signal.sosfreqz(theirs, worN=512)
        _, h_ours = scipy.signal.sosfreqz(ours, worN=w)
        assert np.abs(h_ours - h_theirs).max() <= 1e-12


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("ripple", [0.05, 0.5, 3.0])
def test_chebyshev_sections_are_scipys(order: int, ripple: float) -> None:
    for cutoff in CUTOFFS:
        ours = filters._chebyshev_sections(order, ripple, cutoff)
        _close_rows(ours, scipy.signal.cheby1(order, ripple, cutoff, output="sos"), 1e-13)


@pytest.mark.parametrize("factor", [2, 3, 5, 10, 13, 20, 50, 100])
def test_decimation_filter_is_scipys(factor: int) -> None:
    theirs = scipy.signal.cheby1(filters.DECIMATION_ORDER, filters.DECIMATION_RIPPLE, 0.8 / factor, output="sos")
    _close_rows(filters._chebyshev(factor), theirs, 1e-13)


@pytest.mark.parametrize("order", [1, 2, 3, 8, 15, 16])
@pytest.mark.parametrize("cutoff", [1e-2, 0.3, 0.95])
def test_butterworth_magnitude_is_the_closed_form(order: int, cutoff: float) -> None:
    """|H|² = 1/(1 + (tan(w/2)/tan(π·cutoff/2))^(2·order)): the bilinear image of the maximally flat
    analog response (Oppenheim and Schafer, 3rd ed., §7.2.2 and appendix B)."""
    w = np.linspace(0.0, 0.99 * np.pi, 400)
    h = _response(filters._butterworth(order, cutoff), w)
    ratio = np.tan(w / 2) / np.tan(np.pi * cutoff / 2)
    np.testing.assert_allclose(np.abs(h) ** 2, 1 / (1 + ratio ** (2 * order)), rtol=0, atol=1e-11)


@pytest.mark.parametrize("order", [1, 2, 3, 8, 15, 16])
@pytest.mark.parametrize("ripple", [0.05, 1.0])
def test_chebyshev_magnitude_is_the_closed_form(order: int, ripple: float) -> None:
    """|H|² = 1/(1 + ε²·T_n(tan(w/2)/tan(π·cutoff/2))²), ε² = 10^(ripple/10) − 1, T_n the Chebyshev
    polynomial: DC gain 1 for an odd order, 10^(−ripple/20) for an even one, 10^(−ripple/20) at the cut-off."""
    cutoff = 0.2
    w = np.linspace(0.0, 0.99 * np.pi, 400)
    h = _response(filters._chebyshev_sections(order, ripple, cutoff), w)
    ratio = np.tan(w / 2) / np.tan(np.pi * cutoff / 2)
    chebyshev = np.polynomial.chebyshev.chebval(ratio, [0] * order + [1])
    expected = 1 / (1 + (10 ** (ripple / 10) - 1) * chebyshev**2)
    np.testing.assert_allclose(np.abs(h) ** 2, expected, rtol=0, atol=1e-11)
    assert abs(h[0]) == pytest.approx(1.0 if order % 2 else 10 ** (-ripple / 20), rel=1e-12)


def _scipy_filtfilt(sos: np.ndarray, x: np.ndarray, padlen: int, axis: int) -> np.ndarray:
    return scipy.signal.sosfiltfilt(sos, x, axis=axis, padtype="odd", padlen=padlen)


TOLERANCE = 1e-10
"""Of the largest |reference|. The two filters' rounding differs most at 1e-3 of the Nyquist frequency, where
the double poles nearest the unit circle (1 − |z| ≈ 3e-3) amplify it: measured 3.2e-11 there (orders 1–16,
20 000 samples), which is SciPy's own distance from the exact recursion of the same sections (3.5e-11 at order
16, long double; ours 1.3e-11); 1e-12 at 1e-2, 3e-14 above."""


@pytest.mark.parametrize("order", ORDERS)
def test_lowpass_is_sosfiltfilt_with_matlabs_padding(order: int) -> None:
    rate = 1000.0
    for i, cutoff in enumerate(CUTOFFS):
        x = _walk(4000, 3, seed=order * 10 + i)
        axis = i % 2
        x = x if axis == 0 else x.T.copy()
        sos = scipy.signal.butter(order, cutoff, output="sos")
        reference = _scipy_filtfilt(sos, x, 3 * order, axis)
        ours = filters.lowpass(x, cutoff * rate / 2, rate, order, axis=axis)
        tolerance = TOLERANCE * np.abs(reference).max()
        np.testing.assert_allclose(ours, reference, rtol=0, atol=tolerance)
        one = filters.lowpass(x.take(1, axis=1 - axis), cutoff * rate / 2, rate, order)  # 1-D
        np.testing.assert_allclose(one, reference.take(1, axis=1 - axis), rtol=0, atol=tolerance)


@pytest.mark.parametrize("factor", [2, 3, 7, 10, 20, 50])
@pytest.mark.parametrize("axis", [0, 1])
def test_decimate_is_sosfiltfilt_then_every_factorth_sample_from_the_last(factor: int, axis: int) -> None:
    x = _walk(3001, 4, seed=factor)
    x = x if axis == 0 else x.T.copy()
    sos = scipy.signal.cheby1(8, 0.05, 0.8 / factor, output="sos")
    reference = np.take(_scipy_filtfilt(sos, x, 24, axis), filters.kept_indices(3001, factor), axis=axis)
    np.testing.assert_allclose(filters.decimate(x, factor, axis=axis), reference, rtol=0,
                               atol=1e-10 * np.abs(reference).max())


def test_every_length_and_column_count_around_the_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Signals ending anywhere in a block and around a group of blocks, from the shortest the padding
    allows; columns filtered in several lots (COLUMNS lowered to 3 for 7 columns)."""
    monkeypatch.setattr(filters, "COLUMNS", 3)
    sos = scipy.signal.butter(4, 0.1, output="sos")
    group = filters.BLOCK * filters.GROUP
    lengths = [*range(13, 13 + 2 * filters.BLOCK + 2), *range(group - 26, group - 22), *range(2 * group - 2, 2 * group + 2)]
    for samples in lengths:
        x = _walk(samples, 7, seed=samples)
        reference = _scipy_filtfilt(sos, x, 12, 0)
        np.testing.assert_allclose(filters.lowpass(x, 50.0, 1000.0), reference, rtol=0,
                                   atol=1e-12 * np.abs(reference).max())


def test_arrays_of_any_shape_along_any_axis() -> None:
    x = _walk(600, 12, seed=3).reshape(600, 3, 4).transpose(1, 0, 2)  # samples on axis 1, not contiguous
    reference = _scipy_filtfilt(scipy.signal.butter(2, 0.05, output="sos"), x, 6, 1)
    ours = filters.lowpass(x, 25.0, 1000.0, order=2, axis=1)
    assert ours.shape == x.shape
    np.testing.assert_allclose(ours, reference, rtol=0, atol=1e-12 * np.abs(reference).max())
    assert filters.lowpass(np.zeros((600, 0)), 25.0, 1000.0).shape == (600, 0)


@pytest.mark.parametrize(("cutoff", "order"), [(1.0, 8), (1.0, 4), (20.0, 16)])
def test_poles_near_the_unit_circle_against_the_exact_recursion(cutoff: float, order: int) -> None:
    """1 Hz at 10 kHz (1 − |z| ≈ 6e-4 for order 8) and a 16th order at 20 Hz, against the same sections
    run sample by sample in long double. Measured at 1 Hz, order 8: ours 5.2e-11 of the signal (SciPy's
    sosfiltfilt 2.1e-10); on a signal with an offset 1e6 times its motion, ours 6e-10 of the motion
    (SciPy's 6e-6: ours filters the deviation from the first sample)."""
    if np.finfo(np.longdouble).eps > 1e-18:
        pytest.skip("long double is no more precise than double on this platform")
    rate, samples = 10_000.0, 20_000
    sos = filters._butterworth(order, cutoff / (rate / 2))
    x = _walk(samples, 1, seed=order)[:, 0]
    exact = _extended_filtfilt(sos, x, 3 * order)
    assert np.abs(filters.lowpass(x, cutoff, rate, order) - exact).max() <= 2e-10 * np.abs(exact).max()
    shifted = 1e3 + 1e-3 * x
    exact = _extended_filtfilt(sos, shifted, 3 * order)
    motion = np.abs(exact - 1e3).max()
    assert np.abs(filters.lowpass(shifted, cutoff, rate, order) - exact).max() <= 3e-9 * motion


def test_decimation_by_20_against_the_exact_recursion() -> None:
    x = _walk(20_000, 1, seed=20)[:, 0]
    exact = _extended_filtfilt(filters._chebyshev(20), x, 24)[filters.kept_indices(20_000, 20)]
    assert np.abs(filters.decimate(x, 20) - exact).max() <= 1e-12 * np.abs(exact).max()  # measured 1e-13


def _extended_filtfilt(sos: np.ndarray, x: np.ndarray, padlen: int) -> np.ndarray:
    """sosfiltfilt with odd padding, sample by sample in long double, the rest state solved per section
    from its fixed point (2 × 2, Cramer's rule)."""
    sos, x = sos.astype(np.longdouble), x.astype(np.longdouble)
    ext = np.concatenate((2 * x[0] - x[padlen:0:-1], x, 2 * x[-1] - x[-2 : -(padlen + 2) : -1]))
    y = _extended_sosfilt(sos, ext)
    return _extended_sosfilt(sos, y[::-1])[::-1][padlen:-padlen]


def _extended_sosfilt(sos: np.ndarray, u: np.ndarray) -> np.ndarray:
    y = u.copy()
    for b0, b1, b2, _, a1, a2 in sos:
        # fixed point of s1 = b1·c − a1·(b0·c + s1) + s2, s2 = b2·c − a2·(b0·c + s1) for the input c = y[0]
        c = y[0]
        m11, m12, m21, m22 = 1 + a1, -1, a2, 1
        r1, r2 = (b1 - a1 * b0) * c, (b2 - a2 * b0) * c
        det = m11 * m22 - m12 * m21
        s1, s2 = (r1 * m22 - m12 * r2) / det, (m11 * r2 - m21 * r1) / det
        out = np.empty_like(y)
        for t, v in enumerate(y):
            out[t] = b0 * v + s1
            s1, s2 = b1 * v - a1 * out[t] + s2, b2 * v - a2 * out[t]
        y = out
    return y


@settings(deadline=None, max_examples=60)
@given(order=st.integers(1, 16), cutoff=st.floats(1e-3, 0.95), value=st.floats(-1e6, 1e6),
       samples=st.integers(49, 400))
def test_a_constant_passes_unchanged(order: int, cutoff: float, value: float, samples: int) -> None:
    """Butterworth: DC gain 1, to the rounding of the sections' coefficients (measured 2e-11 at 1e-3 of
    the Nyquist frequency, order 16; SciPy's 4e-11)."""
    y = filters.lowpass(np.full((samples, 2), value), cutoff * 500.0, 1000.0, order)
    assert np.abs(y - value).max() <= 1e-10 * abs(value)


@settings(deadline=None, max_examples=30)
@given(factor=st.integers(2, 40), value=st.floats(-1e6, 1e6))
def test_decimate_scales_a_constant_by_the_ripple_floor(factor: int, value: float) -> None:
    """An even-order Chebyshev type I has DC gain 10^(−ripple/20), once per pass."""
    y = filters.decimate(np.full(1000, value), factor)
    assert np.abs(y - value * 10 ** (-2 * filters.DECIMATION_RIPPLE / 20)).max() <= 1e-12 * abs(value)


@settings(deadline=None, max_examples=40)
@given(order=st.integers(1, 16), cutoff=st.floats(1e-2, 0.95), a=st.floats(-1e3, 1e3, allow_subnormal=False),
       b=st.floats(-1e3, 1e3, allow_subnormal=False), seed=st.integers(0, 1000))
def test_lowpass_is_linear(order: int, cutoff: float, a: float, b: float, seed: int) -> None:
    x, y = _walk(300, 1, seed)[:, 0], _walk(300, 1, seed + 1)[:, 0] + 10.0
    both = filters.lowpass(a * x + b * y, cutoff * 500.0, 1000.0, order)
    apart = (a * filters.lowpass(x, cutoff * 500.0, 1000.0, order)
             + b * filters.lowpass(y, cutoff * 500.0, 1000.0, order))
    scale = abs(a) * np.abs(x).max() + abs(b) * np.abs(y).max()
    # relative to the signals' size, above the range where doubles lose relative precision (a = 2.2e-311 differed
    # by 9.5e-322: subnormal numbers hold a few digits)
    assert np.abs(both - apart).max() <= max(1e-12 * scale, 1e-290)


def test_too_short_a_signal_is_refused() -> None:
    with pytest.raises(ValueError, match="12 samples are too few for this filter: it needs more than 12"):
        filters.lowpass(np.zeros(12), 10.0, 1000.0, order=4)
    assert filters.lowpass(np.arange(13.0), 10.0, 1000.0, order=4).shape == (13,)


def test_the_module_imports_no_scipy() -> None:
    """The point of NumPy-only filters: a command that filters pays no scipy import (issue 23 §3)."""
    code = ("import sys, numpy as np; from symbolic.data import filters; "
            "filters.decimate(filters.lowpass(np.ones((200, 2)), 5.0, 100.0), 3); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))")
    env = {**os.environ, "PYTHONPATH": str(Path(filters.__file__).parents[2])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
    assert out.strip() == "[]"
