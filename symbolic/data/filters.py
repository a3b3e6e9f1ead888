"""Zero-phase low-pass filtering, central differences and decimation of sampled signals.

The data treatments of the inverse-dynamics identification (IDIM-LS) as Gautier and Janot apply them,
and of the comparison of simulated with measured motion, in the data layer so that identification and
simulation use the same ones. :func:`lowpass` and :func:`decimate` follow MATLAB's ``filtfilt`` and
``decimate``, with which the published EMPS results were computed (Janot, Gautier, Brunot 2019), so that
those numbers are reproduced to their printed digits (docs/data.md, "IDIM-LS" and "EMPS"). Every
function works along ``axis`` (default 0, the sample axis) of arrays of any shape.

NumPy only, on purpose: importing :mod:`scipy.signal` costs about 0.8 s of wall time (it imports
:mod:`scipy.stats`), the largest part of a warm ``symbolic simulate`` (issue 23 §3). The filters are
designed here as SciPy's ``butter`` and ``cheby1`` design them (the same second-order sections, to
rounding) and run as ``sosfiltfilt`` runs them, by a block state-space form of the sections, faster
than ``sosfilt`` on thousands of columns (bench/filters.py) and closer to the exact recursion
(tests/test_filters_numpy.py). SciPy is the reference of the tests, not a dependency of this module.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

DECIMATION_ORDER = 8
"""Order of the Chebyshev type I anti-aliasing filter of :func:`decimate` (MATLAB's and SciPy's)."""

DECIMATION_RIPPLE = 0.05
"""Pass-band ripple in dB of that filter."""

DECIMATION_CUTOFF = 0.8
"""The decimation filter's cut-off as a fraction of the new Nyquist frequency (the band the decimated rows keep)."""


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


def spectrum(r: np.ndarray, rate: float, axis: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Welch power spectral density of ``r`` along ``axis`` (segments of up to 256 samples): the residual spectra
    of the diagnosis and of the HTML reports."""
    import scipy.signal

    length = np.shape(r)[axis]
    segment = int(min(256, max(16, length // 4)))
    return scipy.signal.welch(r, fs=rate, nperseg=min(segment, length), detrend="constant", axis=axis)


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
    return _filtfilt(_chebyshev(factor), x, 3 * DECIMATION_ORDER, axis, kept_indices(x.shape[axis], factor))


def kept_indices(samples: int, factor: int) -> np.ndarray:
    """Indices of the samples :func:`decimate` keeps out of ``samples``."""
    return np.arange((samples - 1) % factor, samples, factor)


@functools.lru_cache(maxsize=32)
def _butterworth(order: int, cutoff: float) -> np.ndarray:
    """Second-order sections of the digital Butterworth low-pass, as ``scipy.signal.butter(order, cutoff,
    output="sos")``: analog poles ``−exp(iπm/(2·order))``, m = −order+1, −order+3, …, order−1, on the unit
    circle (gain 1), then :func:`_digital_lowpass`."""
    m = np.arange(-order + 1, order, 2)
    return _digital_lowpass(-np.exp(1j * np.pi * m / (2 * order)), 1.0, cutoff)


@functools.lru_cache(maxsize=32)
def _chebyshev(factor: int) -> np.ndarray:
    """Sections of :func:`decimate`'s filter, ``scipy.signal.cheby1(8, 0.05, 0.8/factor, output="sos")``."""
    return _chebyshev_sections(DECIMATION_ORDER, DECIMATION_RIPPLE, DECIMATION_CUTOFF / factor)


def _chebyshev_sections(order: int, ripple: float, cutoff: float) -> np.ndarray:
    """Chebyshev type I low-pass of ``ripple`` dB, as ``scipy.signal.cheby1`` (its ``cheb1ap`` prototype).

    Analog poles on an ellipse, ``−sinh(μ + iθ_m)`` with ``θ_m = πm/(2·order)``, ``μ = asinh(1/ε)/order``
    and ``ε = sqrt(10^(ripple/10) − 1)``; gain ``Π(−p)``, divided by ``sqrt(1 + ε²)`` for an even order,
    so that the DC gain is 1 for an odd order and ``10^(−ripple/20)`` (the bottom of the ripple) for an
    even one (the equiripple pass band starts at its bottom; Oppenheim and Schafer, *Discrete-Time Signal
    Processing*, 3rd ed., appendix B; SciPy's ``cheb1ap``).
    """
    epsilon = math.sqrt(10 ** (ripple / 10) - 1)
    mu = math.asinh(1 / epsilon) / order
    poles = -np.sinh(mu + 1j * np.pi * np.arange(-order + 1, order, 2) / (2 * order))
    gain = float(np.prod(-poles).real)
    if order % 2 == 0:
        gain /= math.sqrt(1 + epsilon**2)
    return _digital_lowpass(poles, gain, cutoff)


def _digital_lowpass(poles: np.ndarray, gain: float, cutoff: float) -> np.ndarray:
    """Second-order sections of an analog all-pole low-pass prototype (cut-off 1 rad/s) moved to the
    cut-off ``cutoff`` (a fraction of the Nyquist frequency) by the bilinear transform, as SciPy's
    ``iirfilter`` and ``zpk2sos(pairing="nearest")`` do.

    With fs = 2 (SciPy's normalisation), the cut-off is pre-warped to ``ω = 2·fs·tan(π·cutoff/fs)``,
    the poles scaled to ``s = ω·p`` and the gain to ``gain·ω^n``; the bilinear transform maps ``s`` to
    ``z = (2fs + s)/(2fs − s)``, puts the n zeros at z = −1 and multiplies the gain by ``1/Π(2fs − s)``
    (Oppenheim and Schafer, *Discrete-Time Signal Processing*, 3rd ed., §7.2.2). Sections as
    ``zpk2sos`` (``pairing="nearest"``) pairs them: filled from the last, each section takes the pole
    left nearest the unit circle and its conjugate (``a = [1, −2·Re z, |z|²]``), or an odd order's real
    pole and the origin (``a = [1, −z, 0]``), with the two zeros left nearest that pole: two at −1
    (``b = [1, 2, 1]``), or −1 and the origin's zero (``b = [1, 1, 0]``), which goes to the first pole
    nearer to the origin than to −1 (one of the two sections is then first-order in effect). The gain is
    put in the first section, the one farthest from the unit circle.
    """
    n = len(poles)
    fs2 = 4.0
    warped = fs2 * math.tan(math.pi * cutoff / 2.0)
    s = poles * warped
    z = (fs2 + s) / (fs2 - s)
    gain = gain * warped**n * (1.0 / np.prod(fs2 - s)).real
    # the prototype lists its poles with m = −n+1 … n−1: the first half (m < 0) holds one of each pair and
    # an odd order's real pole is the middle one; that pole gets a pole and a zero at the origin (which
    # cancel) to fill a section, as zpk2sos adds them
    poles = list(z[: n // 2]) + ([z[n // 2].real] if n % 2 else [])
    zeros = [-1.0] * n + [0.0] * (n % 2)
    sos = np.empty(((n + 1) // 2, 6))
    for section in range(len(sos) - 1, -1, -1):
        p = poles.pop(int(np.argmin([abs(1.0 - abs(q)) for q in poles])))
        pair = [p, p.conjugate()] if np.iscomplex(p) else [p, 0.0]
        nearest = [zeros.pop(int(np.argmin([abs(q - p) for q in zeros]))) for _ in range(2)]
        sos[section] = np.concatenate((np.poly(nearest).real, np.poly(pair).real))
    sos[0, :3] *= gain
    return sos


BLOCK = 48
"""Samples per block of :func:`_filtfilt`'s block state-space filter: the Toeplitz product costs
``BLOCK`` multiply-adds per sample and column, the sequential loop runs over ``samples/BLOCK`` blocks."""

GROUP = 16
"""Blocks per group: the states at the groups' starts are carried from group to group in extended precision
(``np.longdouble``), those inside a group in double precision from its start (see :func:`_states`)."""

COLUMNS = 64
"""Columns filtered at once: the two working arrays of 20 000 samples then hold some 20 MB, which the caches keep
closer than 512 columns' 160 MB (the Panda's 301 regressor columns: 60 ms instead of 85 ms; each column's result
is the same whatever the lot)."""


@dataclass(frozen=True)
class _Blocks:
    """The sections ``sos`` as a block state-space system over ``BLOCK`` samples.

    The state ``s`` is the cascade's, the two transposed-direct-form-II delays of each section (those of
    ``scipy.signal.sosfilt``). Over one block of inputs ``u`` (``BLOCK`` samples), starting from ``s``:
    outputs ``y = T·u + O·s`` and next state ``s' = A·s + C·u``, with ``T`` the lower-triangular Toeplitz
    matrix of the impulse response, ``O`` the free responses to each state, ``A`` the transition over a
    block (A^BLOCK) and ``C`` the states an impulse at each sample leaves at the block's end.
    """

    forward: np.ndarray
    """``[T | O]``, BLOCK × (BLOCK + n): the outputs of a block from its inputs stacked over its start state."""
    backward: np.ndarray
    """The same for the time-reversed block, ``[J·T·J | J·O]`` (J reverses the samples)."""
    inputs: np.ndarray
    """``C``, n × BLOCK."""
    inputs_reversed: np.ndarray
    """``C·J``, n × BLOCK."""
    transition: np.ndarray
    """``A``, n × n."""
    weights: np.ndarray
    """``A^(GROUP−1−i)`` for i = 0 … GROUP−1, GROUP × n × n: a group's end state from its blocks' ``C·u``."""
    leap: np.ndarray
    """``A^GROUP`` in extended precision (``np.longdouble``), n × n."""
    rest: np.ndarray
    """State of the sections at rest under a constant unit input (``scipy.signal.sosfilt_zi``), n."""
    gain: float
    """Gain at DC, ``Π Σb/Σa`` over the sections."""


@functools.lru_cache(maxsize=32)
def _blocks(sos: bytes, sections: int) -> _Blocks:
    """:class:`_Blocks` of the sections whose float64 bytes are ``sos`` (a hashable key), n = 2·sections.

    ``T``, ``O``, ``A`` and ``C`` are measured by running the sections sample by sample (the recursion
    ``sosfilt`` runs) on ``BLOCK`` impulses from rest and on zero inputs from each unit state, in
    extended precision and rounded once: for poles near the unit circle, ``A`` rounded after many steps
    of double-precision arithmetic would move the slow modes (with ``np.longdouble`` the same as
    ``float``, as on some platforms, that error of about 1e-10 at 1e-3 of the Nyquist frequency stays).
    """
    coefficients = np.frombuffer(sos).reshape(sections, 6)
    n = 2 * sections
    impulses = np.zeros((BLOCK, BLOCK + n))
    impulses[:, :BLOCK] = np.eye(BLOCK)
    states = np.zeros((n, BLOCK + n))
    states[:, BLOCK:] = np.eye(n)
    y, end = _recursion(*(m.astype(np.longdouble) for m in (coefficients, impulses, states)))
    toeplitz, free, transition = y[:, :BLOCK].astype(float), y[:, BLOCK:].astype(float), end[:, BLOCK:]
    powers = [np.eye(n, dtype=np.longdouble)]
    for _ in range(GROUP):
        powers.append(transition @ powers[-1])
    return _Blocks(np.hstack((toeplitz, free)), np.hstack((toeplitz[::-1, ::-1], free[::-1])),
                   np.ascontiguousarray(end[:, :BLOCK], dtype=float),
                   np.ascontiguousarray(end[:, BLOCK - 1 :: -1], dtype=float), transition.astype(float),
                   np.array(powers[GROUP - 1 :: -1], dtype=float), powers[GROUP], *_rest(coefficients))


def _recursion(sos: np.ndarray, u: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sections run sample by sample on the columns of ``u`` (samples × columns) from ``state``
    (2·sections × columns), transposed direct form II: ``y = b0·v + s1``, ``s1 ← b1·v − a1·y + s2``,
    ``s2 ← b2·v − a2·y``, each section's ``y`` the next one's ``v``. Returns the outputs and the end state.
    A Python loop over samples: for the short blocks of :func:`_blocks` only."""
    state = state.copy()
    y = np.empty_like(u)
    for t in range(u.shape[0]):
        v = u[t]
        for j, (b0, b1, b2, _, a1, a2) in enumerate(sos):
            out = b0 * v + state[2 * j]
            state[2 * j] = b1 * v - a1 * out + state[2 * j + 1]
            state[2 * j + 1] = b2 * v - a2 * out
            v = out
        y[t] = v
    return y, state


def _rest(sos: np.ndarray) -> tuple[np.ndarray, float]:
    """The sections' state at rest under a unit constant input (``scipy.signal.sosfilt_zi``), and their
    gain at DC.

    Section j sees the constant ``c_j`` (``c_0 = 1``, ``c_{j+1} = G_j·c_j``, ``G_j = Σb/Σa`` its DC gain);
    its output is ``G_j·c_j`` and the recursion of :func:`_recursion` held still gives
    ``s2 = (b2 − a2·G_j)·c_j`` and ``s1 = (b1 + b2 − (a1 + a2)·G_j)·c_j``.
    """
    rest = np.empty(2 * len(sos))
    level = 1.0
    for j, (b0, b1, b2, a0, a1, a2) in enumerate(sos):
        dc = (b0 + b1 + b2) / (a0 + a1 + a2)
        rest[2 * j] = (b1 + b2 - (a1 + a2) * dc) * level
        rest[2 * j + 1] = (b2 - a2 * dc) * level
        level *= dc
    return rest, level


def _filtfilt(sos: np.ndarray, x: np.ndarray, padlen: int, axis: int, keep: np.ndarray | None = None) -> np.ndarray:
    """``scipy.signal.sosfiltfilt(sos, x, axis=axis, padtype="odd", padlen=padlen)`` in NumPy only, or only
    its samples ``keep`` (increasing indices along ``axis``): :func:`decimate` writes no more than it keeps.

    The signal is extended at each end by its odd reflection over ``padlen`` samples; the sections run
    forward from rest on the first sample (the state ``sosfilt_zi·x[0]`` a constant input would hold),
    then backward over the result from rest on its last sample, and the extension is cut off. Each pass
    is a block state-space filter (:class:`_Blocks`): the states at the blocks' starts follow from one
    short loop over the blocks, ``s_{k+1} = A·s_k + C·u_k``; then every output is one matrix product
    ``[T | O]·[u_k; s_k]`` over all blocks and columns (block state-space realisation, Burrus, "Block
    realization of digital filters", IEEE Trans. Audio Electroacoust. 20(4), 1972), the states carried
    from group to group of blocks in extended precision (:func:`_states`). It is the same linear map as
    sosfilt's recursion and the two differ by rounding only: 3e-14 of the signal for cut-offs from 0.1 of
    the Nyquist frequency, 1e-12 at 1e-2, 3e-11 at 1e-3, where this one is 1.3e-11 from the exact recursion
    of the same sections and sosfilt's 3.5e-11 (tests/test_filters_numpy.py).
    """
    if x.shape[axis] <= padlen:
        raise ValueError(f"{x.shape[axis]} samples are too few for this filter: it needs more than {padlen}")
    x = np.moveaxis(x, axis, 0)
    shape = x.shape
    x = x.reshape(shape[0], -1)
    blocks = _blocks(np.ascontiguousarray(sos, dtype=float).tobytes(), len(sos))
    keep = np.arange(shape[0]) if keep is None else keep
    out = np.empty((len(keep), x.shape[1]))
    # one working memory for every lot of columns: fresh pages cost as much as the filtering
    count = _layout(shape[0], padlen)[2]
    work = np.empty(2 * (BLOCK + len(blocks.rest)) * count * min(COLUMNS, x.shape[1]))
    for first in range(0, x.shape[1], COLUMNS):
        columns = slice(first, first + COLUMNS)
        _filtfilt_columns(blocks, x[:, columns], padlen, keep, out[:, columns], work)
    return np.moveaxis(out.reshape((len(keep),) + shape[1:]), 0, axis)


def _filtfilt_columns(blocks: _Blocks, x: np.ndarray, padlen: int, keep: np.ndarray, out: np.ndarray,
                      work: np.ndarray) -> None:
    """:func:`_filtfilt` of the columns of ``x`` (samples × columns), its samples ``keep`` written into
    ``out`` (kept samples × columns); ``work`` is room for two arrays of the layout below.

    Layout: sample ``t = k·BLOCK + i`` of column c at ``[i, k, c]`` of a (BLOCK + n) × blocks × columns
    array whose last n rows hold the state at each block's start, so that a pass is one matrix product.
    The filters run on the deviation from the extended signal's first sample ``x₀`` (a constant passes
    both passes scaled by the DC gain G, added back as ``G²·x₀``: an offset costs no precision). That
    deviation is preceded by ``lead`` zeros so that the data start on a block boundary (at rest on a
    constant, the sections stay at rest: the output is unchanged), and the blocks run to a whole number
    of groups; the forward output is continued after its last sample by copies of it (the backward pass
    then reaches that sample still at rest on it).
    """
    samples, width = x.shape
    n = len(blocks.rest)
    lead, total, count = _layout(samples, padlen)
    head = 2 * x[0] - x[padlen:0:-1]
    tail = 2 * x[-1] - x[-2 : -(padlen + 2) : -1]
    start = head[0].copy()
    size = (BLOCK + n) * count * width
    one, two = work[:size].reshape(BLOCK + n, count, width), work[size : 2 * size].reshape(BLOCK + n, count, width)
    data = one[:BLOCK].transpose(1, 0, 2)  # count × BLOCK × width view, sample order
    data[0] = 0.0  # the lead: the first sample less itself
    data[total // BLOCK :] = 0.0  # after the end: any value (the forward outputs there are replaced)
    _put(data, lead, head, start)
    _put(data, lead + padlen, x, start)
    _put(data, lead + padlen + samples, tail, start)
    _pass(blocks, blocks.forward, blocks.inputs, one, two, False, 0.0 * start)
    data = two[:BLOCK].transpose(1, 0, 2)
    end = data[(total - 1) // BLOCK, (total - 1) % BLOCK].copy()
    _put(data, total, np.broadcast_to(end, (count * BLOCK - total, width)))
    _pass(blocks, blocks.backward, blocks.inputs_reversed, two, one, True, end)
    data, offset = one[:BLOCK].transpose(1, 0, 2), -blocks.gain**2 * start
    if len(keep) == samples:
        _get(data, lead + padlen, out, offset)
    else:
        index = lead + padlen + keep
        np.subtract(data[index // BLOCK, index % BLOCK], offset, out=out)


def _layout(samples: int, padlen: int) -> tuple[int, int, int]:
    """The lead (zeros before the extended signal, to start it on a block boundary), the samples to the
    extended signal's end, and the blocks (a whole number of groups) of :func:`_filtfilt_columns`."""
    lead = -padlen % BLOCK
    total = lead + samples + 2 * padlen
    return lead, total, -(-total // (BLOCK * GROUP)) * GROUP


def _pass(blocks: _Blocks, matrix: np.ndarray, inputs: np.ndarray, source: np.ndarray, target: np.ndarray,
          reverse: bool, first: np.ndarray) -> None:
    """One pass of the block filter, ``matrix`` and ``inputs`` its ``[T | O]`` and ``C``: the inputs in
    ``source[:BLOCK]`` (BLOCK × blocks × columns), the blocks taken from the last if ``reverse``, starting
    at rest on ``first``; the states go to ``source[BLOCK:]`` and the outputs to ``target[:BLOCK]``."""
    _, count, width = source.shape
    flat = source.reshape(source.shape[0], count * width)
    driven = (inputs @ flat[:BLOCK]).reshape(-1, count, width)
    order = slice(None, None, -1 if reverse else 1)
    source[BLOCK:, order] = _states(blocks, driven[:, order], first)
    np.matmul(matrix, flat, out=target[:BLOCK].reshape(BLOCK, count * width))


def _states(blocks: _Blocks, driven: np.ndarray, first: np.ndarray) -> np.ndarray:
    """The states at the blocks' starts, ``s_{k+1} = A·s_k + d_k`` from ``s_0`` at rest on ``first``
    (``driven`` holds ``d_k = C·u_k``, n × blocks × columns, blocks a multiple of GROUP).

    From group to group, ``s_{K+1} = A^GROUP·s_K + Σ_i A^(GROUP−1−i)·d_{K·GROUP+i}``, in extended precision:
    with poles near the unit circle the carried state's rounding errors decay only over many blocks, and
    in double precision they reach 1e-10 of the signal at 1e-3 of the Nyquist frequency. Inside each
    group, the GROUP − 1 steps from its start are double precision, all groups at once.
    """
    n, count, width = driven.shape
    groups = count // GROUP
    # the inputs by their block's place in its group, each place's an n × (groups·width) matrix: one copy for all
    # places, and one stacked product (the same products as place by place, summed in the same order)
    d = driven.reshape(n, groups, GROUP, width).transpose(2, 0, 1, 3).reshape(GROUP, n, groups * width)
    grouped = np.add.reduce(np.matmul(blocks.weights, d), axis=0).reshape(n, groups, width)
    # the loops below are short but run for every few columns filtered (a scan's single values): each step does
    # the least it can, into arrays made beforehand (the same numbers as the plain recursion)
    carried = grouped.astype(blocks.leap.dtype).transpose(1, 0, 2)  # groups × n × width
    starts = np.empty((groups, n, width), blocks.leap.dtype)
    state = (blocks.rest[:, None] * first).astype(blocks.leap.dtype)
    for k in range(groups):
        starts[k] = state
        state = blocks.leap @ state
        state += carried[k]
    states = np.empty((GROUP, n, groups * width))
    states[0] = starts.transpose(1, 0, 2).reshape(n, -1)
    for i in range(GROUP - 1):  # the state after a group's last block is the next group's start, carried above
        np.add(blocks.transition @ states[i], d[i], out=states[i + 1])
    return states.reshape(GROUP, n, groups, width).transpose(1, 2, 0, 3).reshape(n, count, width)


def _put(blocks: np.ndarray, start: int, data: np.ndarray, offset: np.ndarray | float = 0.0) -> None:
    """Write ``data − offset`` (samples × columns) from sample ``start`` into ``blocks`` (blocks × BLOCK ×
    columns)."""
    done = 0
    while done < len(data):
        k, i = divmod(start + done, BLOCK)
        whole = (len(data) - done) // BLOCK if i == 0 else 0
        if whole:
            np.subtract(data[done : done + whole * BLOCK].reshape(whole, BLOCK, -1), offset, out=blocks[k : k + whole])
            done += whole * BLOCK
        else:
            step = min(BLOCK - i, len(data) - done)
            np.subtract(data[done : done + step], offset, out=blocks[k, i : i + step])
            done += step


def _get(blocks: np.ndarray, start: int, out: np.ndarray, offset: np.ndarray) -> None:
    """Write ``len(out)`` samples from sample ``start`` of ``blocks`` (blocks × BLOCK × columns), minus
    ``offset``, to ``out``."""
    done, samples = 0, len(out)
    while done < samples:
        k, i = divmod(start + done, BLOCK)
        whole = (samples - done) // BLOCK if i == 0 else 0
        if whole:
            np.subtract(blocks[k : k + whole], offset, out=out[done : done + whole * BLOCK].reshape(whole, BLOCK, -1))
            done += whole * BLOCK
        else:
            step = min(BLOCK - i, samples - done)
            np.subtract(blocks[k, i : i + step], offset, out=out[done : done + step])
            done += step
