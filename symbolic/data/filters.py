"""Zero-phase low-pass filtering, central differences and decimation of sampled signals.

The data treatments of the inverse-dynamics identification (IDIM-LS) as Gautier and Janot apply them,
and of the comparison of simulated with measured motion, in the data layer so that identification and
simulation use the same ones. :func:`lowpass` and :func:`decimate` follow MATLAB's ``filtfilt`` and
``decimate``, with which the published EMPS results were computed (Janot, Gautier, Brunot 2019), so that
those numbers are reproduced to their printed digits (docs/data.md, "IDIM-LS" and "EMPS"). Every
function works along ``axis`` (default 0, the sample axis) of arrays of any shape.
"""

from __future__ import annotations

import functools

import numpy as np

DECIMATION_ORDER = 8
"""Order of the Chebyshev type I anti-aliasing filter of :func:`decimate` (MATLAB's and SciPy's)."""

DECIMATION_RIPPLE = 0.05
"""Pass-band ripple in dB of that filter."""


def lowpass(x: np.ndarray, cutoff: float, rate: float, order: int = 4, axis: int = 0) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` sampled at ``rate``.

    Forward and backward (zero phase, squared magnitude), in second-order sections for numerical
    robustness, the signal extended at each end by its odd reflection over ``3·order`` samples
    (MATLAB's ``3*(nfilt-1)``; SciPy's own default is ``3·(order+1)``).

    Parameters
    ----------
    x
        Samples along ``axis``.
    cutoff
        Cut-off frequency in Hz (the −3 dB point of one pass; forward and backward it is −6 dB).
    rate
        Sampling rate in Hz.
    order
        Order of the Butterworth filter of one pass.

    Raises
    ------
    ValueError
        If the cut-off is not below the Nyquist frequency or ``x`` is too short to pad.
    """
    nyquist = rate / 2.0
    if not 0.0 < cutoff < nyquist:
        raise ValueError(f"cut-off {cutoff:g} Hz must lie between 0 and the Nyquist frequency {nyquist:g} Hz")
    return _filtfilt(_butterworth(order, cutoff / nyquist), np.asarray(x, dtype=float), 3 * order, axis)


def central_difference(x: np.ndarray, step: float, axis: int = 0) -> np.ndarray:
    """Derivative of ``x`` sampled every ``step`` seconds by central differences.

    ``(x[k+1] − x[k−1]) / (2·step)`` for inner samples, forward and backward differences at the first
    and last sample (those are inside the border that the identification drops). Its error on a
    sinusoid of angular frequency ω is a relative ``(ω·step)²/6``.
    """
    x = np.moveaxis(np.asarray(x, dtype=float), axis, 0)
    if x.shape[0] < 2:
        raise ValueError("central differences need at least 2 samples")
    d = np.empty_like(x)
    d[1:-1] = (x[2:] - x[:-2]) / (2.0 * step)
    d[0] = (x[1] - x[0]) / step
    d[-1] = (x[-1] - x[-2]) / step
    return np.moveaxis(d, 0, axis)


def decimate(x: np.ndarray, factor: int, axis: int = 0) -> np.ndarray:
    """Low-pass ``x`` and keep every ``factor``-th sample, the last sample always kept.

    The low-pass is a Chebyshev type I filter (order 8, 0.05 dB ripple, cut-off 0.8 of the new Nyquist
    frequency) run forward and backward with a ``3·8``-sample odd reflection; the samples kept are
    counted back from the last one (MATLAB keeps the last sample, ``scipy.signal.decimate`` the first).
    ``factor = 1`` returns a copy of ``x`` unfiltered. Applied with the same ``factor`` to the
    torques and to every column of the regressor ("parallel decimation"), the filter, which is linear,
    keeps ``τ = W·β`` exact sample by sample (its border transients included).
    """
    if factor < 1:
        raise ValueError(f"decimation factor must be a positive integer, got {factor}")
    x = np.asarray(x, dtype=float)
    if factor == 1:
        return x.copy()
    filtered = _filtfilt(_chebyshev(factor), x, 3 * DECIMATION_ORDER, axis)
    return np.take(filtered, kept_indices(x.shape[axis], factor), axis=axis)


def kept_indices(samples: int, factor: int) -> np.ndarray:
    """Indices of the samples :func:`decimate` keeps out of ``samples``."""
    return np.arange((samples - 1) % factor, samples, factor)


@functools.lru_cache(maxsize=32)
def _butterworth(order: int, cutoff: float) -> np.ndarray:
    return _signal().butter(order, cutoff, output="sos")


@functools.lru_cache(maxsize=32)
def _chebyshev(factor: int) -> np.ndarray:
    return _signal().cheby1(DECIMATION_ORDER, DECIMATION_RIPPLE, 0.8 / factor, output="sos")


def _filtfilt(sos: np.ndarray, x: np.ndarray, padlen: int, axis: int) -> np.ndarray:
    """``scipy.signal.sosfiltfilt(sos, x, axis=axis, padtype="odd", padlen=padlen)``, step by step as SciPy
    does it (odd extension, forward pass from rest on the first sample, backward pass from rest on the
    last output), with the sections' rest state computed once per filter instead of at every call (its
    linear solves cost as much as filtering a short signal; the search filters thousands of columns)."""
    if x.shape[axis] <= padlen:
        raise ValueError(f"{x.shape[axis]} samples are too few for this filter: it needs more than {padlen}")
    signal = _signal()
    x = np.moveaxis(x, axis, 0)
    ext = np.concatenate((2 * x[:1] - x[padlen:0:-1], x, 2 * x[-1:] - x[-2:-(padlen + 2):-1]), axis=0)
    zi = _rest(sos.tobytes(), sos.shape).reshape((len(sos), 2) + (1,) * (x.ndim - 1))
    y, _ = signal.sosfilt(sos, ext, axis=0, zi=zi * ext[:1])
    y, _ = signal.sosfilt(sos, y[::-1], axis=0, zi=zi * y[-1:])
    return np.moveaxis(y[::-1][padlen:-padlen], 0, axis)


@functools.lru_cache(maxsize=32)
def _rest(sos: bytes, shape: tuple[int, ...]) -> np.ndarray:
    """``scipy.signal.sosfilt_zi`` of the sections ``sos`` (their bytes and shape: a hashable key)."""
    return _signal().sosfilt_zi(np.frombuffer(sos).reshape(shape))


def _signal():
    """:mod:`scipy.signal`, imported on first use: importing it takes about a second (it imports
    :mod:`scipy.stats`), which a command would otherwise pay before its work starts."""
    import scipy.signal

    return scipy.signal
