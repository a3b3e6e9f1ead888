"""Time-localised residual events within one log: windows where the residual of the robot's own model bursts
(a collision, a contact, a lost payload), with the time, the coordinates and the size (docs/fleet.md, "Events").

:func:`bursts` finds them in the residual τ_meas − τ_model of the model identified on the log itself (so that
a slow drift of the robot does not enter) and returns plain dicts, JSON-ready; :func:`describe` puts one in a
line. :func:`examine` gives every burst (:func:`candidates`, those that recur within the log marked) and the
residual's :func:`profile`, from which the campaign judges each burst against the siblings' logs
(:mod:`symbolic.fleet.siblings`).
"""

from __future__ import annotations

import base64
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from symbolic.fleet.campaign import Events

MEDIAN_CHI2_1 = 0.45493642311957283
"""Median of a χ² variable with one degree of freedom (scipy.stats.chi2.median(1))."""

WINDOW_P = 1e-3
"""Probability that a white Gaussian residual gives one event in a log (before the size rule): Bonferroni over the
log's windows and coordinates."""

RECUR = 0.25
"""Distance, in standard deviations over the log of each position and velocity, within which two bursts' states
are the same state (:func:`bursts`)."""

MOST = 20
"""Events kept per log (the largest): a log that bursts everywhere is a bad log, not a list of collisions."""


def robust_level(r: np.ndarray) -> np.ndarray:
    """Per column, s = sqrt(median(r²) / median of χ²₁): the residual's σ for a Gaussian residual (the median
    of a χ²₁ variable is 0.45494), robust to isolated spikes and to a burst itself."""
    return np.sqrt(np.median(np.asarray(r, float) ** 2, axis=0) / MEDIAN_CHI2_1)


def windowed(r2: np.ndarray, m: int) -> np.ndarray:
    """Centred moving median of each column of ``r2`` over ``m`` samples (the ends reflected)."""
    from scipy.ndimage import median_filter

    return median_filter(r2, size=(m, 1), mode="reflect")


def bursts(t: np.ndarray, residual: np.ndarray, coordinates: Sequence[str], settings: Events,
           states: np.ndarray | None = None) -> list[dict[str, Any]]:
    """The events of one log by its own evidence, in time order: :func:`candidates` without the bursts that
    recur at one state (the campaign then judges each against the siblings' logs: :mod:`.siblings`)."""
    return [e for e in candidates(t, residual, coordinates, settings, states) if not e.get("recurs")]


def candidates(t: np.ndarray, residual: np.ndarray, coordinates: Sequence[str], settings: Events,
               states: np.ndarray | None = None) -> list[dict[str, Any]]:
    """The bursts of one log, in time order, those that recur at one state marked ``"recurs": True``.

    The rule, per coordinate j with residual r_j (robust to isolated spikes — a Coulomb step at a velocity
    reversal, one bad sample — and to the burst itself):

    * the log's typical squared residual is the median of r_j² (:func:`robust_level`);
    * the windowed level E_j(k) = median of r_j² over the ``window`` seconds centred on sample k, divided by
      median(r_j²): the residual's typical size there against its typical size over the log, squared;
    * a sample is in a burst when E_j(k) ≥ ratio² on some coordinate: more than half of the window's samples
      are ``ratio`` times the log's typical residual, so a burst must last half a window. For a white
      Gaussian residual each sample exceeds with probability p₀ = P(χ²₁ ≥ 0.45494·ratio²) (0.007 at ratio
      4), a window with probability P(Binomial(m, p₀) ≥ m/2); a window too short to make that below
      :data:`WINDOW_P` divided by the log's windows and coordinates (Bonferroni) — a few samples — is
      lengthened until it does;
    * runs of such samples closer than one window are one event; its interval is that of the samples inside
      the run (widened by half a window) whose own residual exceeds ``ratio`` times the typical one on a
      triggering coordinate, so that the reported interval is the burst's, not the window's.

    A burst that recurs is not an event: when ``states`` are given, two bursts on a coordinate whose states
    at their peaks are within :data:`RECUR` standard deviations of each other in every position and velocity
    are the model's misfit of that state (a coarse encoder's quantisation near a velocity reversal, a
    friction law the model lacks: docs/workflow.md names those), which a periodic excitation repeats every
    period, while a collision happens once; both are marked (:func:`_mark_recurring`).

    The size of an event, per coordinate that triggered: the peak r_j (force units) and its time, the RMS of
    r_j over the event, and ``ratio`` = that RMS / s_j.

    Parameters
    ----------
    t
        Sample times (s), uniform.
    residual
        τ_meas − τ_model, ``samples × N``.
    coordinates
        The N coordinate names.
    settings
        Window length (s) and size ratio.
    states
        Positions and velocities at the same samples (``samples × 2N``, any order), or None (no recurrence test).

    Returns
    -------
    list of dict
        Per burst: ``start``, ``end``, ``peak_time`` (s, the log's time), ``coordinates``, ``ratio``, ``size``
        (per coordinate), ``state`` (the states at the peak, or None) and ``recurs``.
    """
    seen = scan(t, residual, settings)
    return [] if seen is None else _candidates(seen, coordinates, settings, states)


@dataclass(frozen=True)
class Scan:
    """One log's residual examined (:func:`scan`): the samples' times, the residual, the window (samples), each
    coordinate's robust level s_j, the squared ratios r_j²/median(r_j²) and their windowed median E_j."""

    t: np.ndarray
    r: np.ndarray
    m: int
    level: np.ndarray
    ratio2: np.ndarray
    energy: np.ndarray


def scan(t: np.ndarray, residual: np.ndarray, settings: Events) -> Scan | None:
    """The windowed levels of a log's residual (:func:`candidates`' rule), or None when it has fewer than 3
    samples or no coordinate with a residual."""
    from scipy.stats import binom, chi2

    t = np.asarray(t, float)
    r = np.asarray(residual, float).reshape(len(t), -1)
    if len(t) < 3:
        return None
    dt = float(np.median(np.diff(t)))
    m = max(2, int(round(settings.window / dt)))
    level = robust_level(r)
    usable = level > 0
    if not usable.any():
        return None
    trials = max(1.0, len(t) / m) * int(usable.sum())
    p0 = chi2.sf(MEDIAN_CHI2_1 * settings.ratio**2, 1)
    while binom.sf(math.ceil(m / 2) - 1, m, p0) >= WINDOW_P / trials and m < len(t):
        m += 1  # a window of a few samples cannot tell a burst from noise: the shortest that can
    typical = np.ones_like(level)
    typical[usable] = level[usable] ** 2 * MEDIAN_CHI2_1  # median(r²)
    ratio2 = np.where(usable, r**2 / typical, 0.0)
    return Scan(t, r, m, level, ratio2, windowed(ratio2, m))


def _candidates(seen: Scan, coordinates: Sequence[str], settings: Events,
                states: np.ndarray | None) -> list[dict[str, Any]]:
    t, m = seen.t, seen.m
    hot = seen.energy >= settings.ratio**2
    rows = np.flatnonzero(hot.any(axis=1))
    found = [_event(t, seen.r, seen.level, seen.ratio2, hot, run, m, settings, coordinates) for run in _runs(rows, m)]
    x = None if states is None else np.asarray(states, float).reshape(len(t), -1)
    for event in found:
        event["recurs"] = False
        event["state"] = None if x is None else [float(v) for v in x[int(np.argmin(np.abs(t - event["peak_time"])))]]
    if x is not None:
        _mark_recurring(found, t, x)
    found.sort(key=lambda e: -e["ratio"])
    return sorted(found[:MOST], key=lambda e: e["start"])


def examine(t: np.ndarray, residual: np.ndarray, coordinates: Sequence[str], settings: Events,
            states: np.ndarray) -> tuple[list[dict[str, Any]], dict[str, Any] | None]:
    """A log's :func:`candidates` and its :func:`profile`, from one :func:`scan`.

    Parameters
    ----------
    t, residual, coordinates, settings
        As :func:`candidates`'.
    states
        Positions and velocities at the samples (``samples × 2N``: q then q̇).

    Returns
    -------
    tuple
        The bursts (:func:`candidates`), and the profile with the coordinates' names (``coordinates``), or None
        when the residual cannot be scanned.
    """
    seen = scan(t, residual, settings)
    if seen is None:
        return [], None
    return _candidates(seen, coordinates, settings, states), {**profile(seen, states), "coordinates": list(coordinates)}


def profile(seen: Scan, states: np.ndarray) -> dict[str, Any]:
    """The log's residual level and state along its time, in bins of half a window, for the campaign's judgement
    against the siblings (:mod:`symbolic.fleet.siblings`).

    Per bin: ρ_j = sqrt(max of E_j over the bin), the windowed RMS ratio of coordinate j (a burst is where
    ρ_j ≥ ``ratio``), and the states (q, q̇) at the bin's middle sample. Stored compactly: ρ as float16 (clipped
    at 60 000), the states as float16 z-scores with their mean and standard deviation (a resolution of about
    10⁻³ of a standard deviation), each array in base64: about 5 KB for 20 s of a two-coordinate log.

    Parameters
    ----------
    seen
        The scan of the log's residual.
    states
        Positions and velocities at the samples (``samples × 2N``).

    Returns
    -------
    dict
        ``t0`` (the log's first time), ``bin`` (s), ``bins``, ``levels`` and ``states`` (base64), ``mean`` and
        ``spread`` of the states.
    """
    width = max(1, seen.m // 2)
    n = len(seen.t)
    starts = np.arange(0, n, width)
    rho = np.sqrt(np.maximum.reduceat(seen.energy, starts, axis=0))
    x = np.asarray(states, float).reshape(n, -1)
    middle = np.minimum(starts + width // 2, n - 1)
    mean, spread = x.mean(axis=0), x.std(axis=0)
    z = (x[middle] - mean) / np.where(spread > 0, spread, 1.0)
    dt = float(np.median(np.diff(seen.t)))
    return {"t0": float(seen.t[0]), "bin": width * dt, "bins": len(starts),
            "levels": _pack(np.minimum(rho, 6e4)), "states": _pack(np.clip(z, -6e4, 6e4)),
            "mean": [float(v) for v in mean], "spread": [float(v) for v in spread]}


def _pack(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f2").tobytes()).decode("ascii")


def unpack(text: str, bins: int) -> np.ndarray:
    """A :func:`profile`'s array as float32 (half the memory of float64 for a campaign's profiles), ``bins`` rows."""
    return np.frombuffer(base64.b64decode(text), dtype="<f2").astype(np.float32).reshape(bins, -1)


def _mark_recurring(found: list[dict[str, Any]], t: np.ndarray, x: np.ndarray) -> bool:
    """Mark (``"recurs": True``) the bursts whose state at the peak another burst on a shared coordinate has."""
    spread = x.std(axis=0)
    z = (x - x.mean(axis=0)) / np.where(spread > 0, spread, 1.0)
    at = [z[int(np.argmin(np.abs(t - e["peak_time"])))] for e in found]
    marked = False
    for i in range(len(found)):
        for j in range(i + 1, len(found)):
            shared = set(found[i]["coordinates"]) & set(found[j]["coordinates"])
            if shared and np.max(np.abs(at[i] - at[j])) < RECUR:
                found[i]["recurs"] = found[j]["recurs"] = marked = True
    return marked


def _runs(rows: np.ndarray, gap: int) -> list[np.ndarray]:
    """Groups of sorted row indices, split where two neighbours are ``gap`` or more rows apart."""
    if rows.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(rows) >= gap) + 1
    return np.split(rows, cuts)


def _event(t, r, level, ratio2, hot, run, m, settings: Events, coordinates) -> dict[str, Any]:
    triggering = np.flatnonzero(hot[run].any(axis=0))
    lo, hi = max(0, run[0] - m // 2), min(len(t), run[-1] + m // 2 + 1)
    inside = np.flatnonzero((ratio2[lo:hi][:, triggering] >= settings.ratio**2).any(axis=1)) + lo
    first, last = (inside[0], inside[-1]) if inside.size else (run[0], run[-1])
    span = slice(first, last + 1)
    sizes = {}
    for j in triggering:
        rms = float(np.sqrt(np.mean(r[span, j] ** 2)))
        peak = int(np.argmax(np.abs(r[span, j]))) + first
        sizes[coordinates[j]] = {"peak": float(r[peak, j]), "peak_time": float(t[peak]), "rms": rms,
                                 "ratio": rms / float(level[j]), "level": float(level[j])}
    strongest = max(sizes.values(), key=lambda s: s["ratio"])
    return {"start": float(t[first]), "end": float(t[last]), "peak_time": strongest["peak_time"],
            "coordinates": list(sizes), "ratio": strongest["ratio"], "size": sizes}


def describe(event: dict[str, Any]) -> str:
    """``12.31–12.52 s on q1, q2 (peak −3.2 on q1, 14× the log's residual)``: one event in a line."""
    coordinate = max(event["size"], key=lambda c: event["size"][c]["ratio"])
    size = event["size"][coordinate]
    return (f"{event['start']:.3f}–{event['end']:.3f} s on {', '.join(event['coordinates'])} "
            f"(peak {size['peak']:.4g} on {coordinate}, RMS {event['ratio']:.3g}× the log's residual)")
