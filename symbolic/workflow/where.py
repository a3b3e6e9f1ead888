"""Where the residual is: by coordinate, state, time and frequency; whether anything is left to explain.

Input: the estimation data and the model's prediction at the decimated samples. Output, per coordinate
of the residual τ_meas − τ_model (:func:`coordinate_report`): its power share; its dependence on
position, velocity and acceleration (:data:`BINS` quantile bins, η² and the one-way ANOVA F-test on n/τ_int
samples) and on the sign of the velocity; rms near velocity reversals (:data:`REVERSAL`) and in
:data:`WINDOWS` time windows; the Welch spectrum's peaks (:data:`PEAK_RATIO` above the median); whiteness
(Ljung–Box) and τ_int. :func:`localise` adds the verdict: *explained* when white at ``alpha`` and no state
dependence significant at ``alpha``/(number of tests). The rules and why: docs/workflow.md, "2. Where".
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import scipy.signal
import scipy.stats

from symbolic.data.filters import central_difference, lowpass
from symbolic.data.filters import spectrum  # noqa: F401  (here since the search and the figures import it from here)
from symbolic.workflow.dataset import DataSet
from symbolic.workflow.statistics import ALPHA, autocorrelation_time, ljung_box

BINS = 10
WINDOWS = 10
REVERSAL = 0.05
PEAK_RATIO = 10.0


QUANTISATION_DRAWS = 8
"""Draws of the encoders' rounding averaged in :func:`quantisation_floor` (seeded: the floor is the same each run)."""


def quantisation_floor(data: DataSet, steps: Sequence[float], inertia: Callable[[np.ndarray], np.ndarray]
                       ) -> list[np.ndarray] | None:
    """Per coordinate j, the Welch spectrum (as :func:`spectrum` of j's residual) of the force error that encoders
    of quanta ``steps`` leave in the inverse dynamics through q̈: each position's rounding, uniform on ±step/2 and
    white at the log's rate, through the data's own treatment — the zero-phase low-pass, the two central
    differences, the border and the decimation (:mod:`symbolic.data.treatment`) — times D_ji(q) at the kept
    samples; the mean over :data:`QUANTISATION_DRAWS` seeded draws. Differentiated twice, the rounding's power
    grows as f⁴ up to the decimation's edge, where the decimation filter cuts it: a hump just below the kept
    band's edge, which a spectrum's median does not anticipate. ``None`` where nothing is quantised or the log
    gives its own velocities (their errors are not the rounding's)."""
    steps = np.asarray(steps, dtype=float)
    measurements, p = data.measurements, data.states.processing
    if not np.any(steps > 0) or measurements.qd is not None or measurements.qdd is not None:
        return None
    h, rate = measurements.sample_period, measurements.rate
    D = np.array([np.asarray(inertia(q)) for q in data.q])  # D at each kept sample
    rng = np.random.default_rng(0)
    total = 0.0
    for _ in range(QUANTISATION_DRAWS):
        e = rng.uniform(-0.5, 0.5, (measurements.samples, len(steps))) * steps
        if p.cutoff is not None:
            e = lowpass(e, p.cutoff, rate, p.order)
        qdd = p.reduce(central_difference(central_difference(e, h), h))
        total = total + spectrum(np.einsum("kji,ki->kj", D, qdd), rate / p.decimation, axis=0)[1]
    return list((total / QUANTISATION_DRAWS).T)


def _binned(state: np.ndarray, r: np.ndarray, tau: float) -> dict[str, Any]:
    """Means of ``r`` in quantile bins of ``state``, η² and its p-value."""
    edges = np.unique(np.quantile(state, np.linspace(0, 1, BINS + 1)))
    if len(edges) < 3:
        return {"edges": edges.tolist(), "means": [], "eta_squared": 0.0, "p_value": 1.0}
    index = np.clip(np.searchsorted(edges, state, side="right") - 1, 0, len(edges) - 2)
    groups = len(edges) - 1
    counts = np.bincount(index, minlength=groups)
    sums = np.bincount(index, weights=r, minlength=groups)
    means = np.divide(sums, counts, out=np.zeros(groups), where=counts > 0)
    total = float(np.sum((r - r.mean()) ** 2))
    between = float(np.sum(counts * (means - r.mean()) ** 2))
    eta = between / total if total > 0 else 0.0
    n_eff = len(r) / tau
    dof = n_eff - groups
    if eta >= 1.0 or dof <= 0:
        p = 0.0 if eta >= 1.0 else 1.0
    else:
        p = float(scipy.stats.f.sf((eta / (groups - 1)) / ((1 - eta) / dof), groups - 1, dof))
    return {"edges": edges.tolist(), "means": means.tolist(), "eta_squared": eta, "p_value": p}


def peaks(frequency: np.ndarray, psd: np.ndarray, count: int = 3) -> list[dict[str, float]]:
    """Spectral peaks standing :data:`PEAK_RATIO` times above the median level, strongest first."""
    level = float(np.median(psd[1:])) if len(psd) > 2 else 0.0
    if level <= 0:
        return []
    found, _ = scipy.signal.find_peaks(psd, height=PEAK_RATIO * level)
    found = sorted(found, key=lambda k: -psd[k])[:count]
    return [{"frequency_hz": float(frequency[k]), "ratio_to_median": float(psd[k] / level)} for k in found]


def coordinate_report(data: DataSet, residual: np.ndarray, j: int) -> dict[str, Any]:
    """The localisation of the residual of coordinate ``j`` (docs/workflow.md, "2. Where")."""
    r = residual[:, j]
    tau = autocorrelation_time(r)
    q, qd, qdd = data.q[:, j], data.qd[:, j], data.qdd[:, j]
    measured = data.tau[:, j]
    out: dict[str, Any] = {
        "rms": float(np.sqrt(np.mean(r**2))),
        "relative": float(100 * np.linalg.norm(r) / np.linalg.norm(measured)) if np.any(measured) else 0.0,
        "autocorrelation_time": tau,
        "position": _binned(q, r, tau),
        "velocity": _binned(qd, r, tau),
        "acceleration": _binned(qdd, r, tau),
    }
    positive, negative = r[qd > 0], r[qd < 0]
    if len(positive) > 1 and len(negative) > 1:
        difference = float(positive.mean() - negative.mean())
        error = np.sqrt(tau * (positive.var() / len(positive) + negative.var() / len(negative)))
        p = float(2 * scipy.stats.norm.sf(abs(difference) / error)) if error > 0 else 0.0
        out["sign"] = {"positive_mean": float(positive.mean()), "negative_mean": float(negative.mean()),
                       "difference": difference, "p_value": p}
    else:
        out["sign"] = {"positive_mean": None, "negative_mean": None, "difference": None, "p_value": 1.0}
    scale = np.percentile(np.abs(qd), 95)
    near = np.abs(qd) < REVERSAL * scale if scale > 0 else np.zeros(len(qd), bool)
    out["reversals"] = {
        "fraction": float(near.mean()),
        "rms_near": float(np.sqrt(np.mean(r[near] ** 2))) if near.any() else None,
        "rms_away": float(np.sqrt(np.mean(r[~near] ** 2))) if (~near).any() else None,
    }
    windows = np.array_split(np.arange(len(r)), min(WINDOWS, len(r)))
    out["time"] = [{"start": float(data.t[w[0]]), "stop": float(data.t[w[-1]]), "rms": float(np.sqrt(np.mean(r[w] ** 2)))}
                   for w in windows if len(w)]
    rate = 1.0 / float(np.mean(np.diff(data.t))) if len(data.t) > 1 else 1.0
    frequency, psd = spectrum(r, rate)
    out["spectrum"] = {"peaks": peaks(frequency, psd), "resolution_hz": float(frequency[1] - frequency[0]) if len(frequency) > 1 else None}
    q_stat, p_white, lags = ljung_box(r)
    out["whiteness"] = {"ljung_box_q": q_stat, "lags": lags, "p_value": p_white}
    return out


def localise(data: DataSet, predicted: np.ndarray, alpha: float = ALPHA) -> dict[str, Any]:
    """Residual localisation on every coordinate and the verdict (docs/workflow.md, "2. Where")."""
    residual = data.tau - predicted
    total = float(np.sum(residual**2))
    coordinates = {}
    tests = []
    for j, c in enumerate(data.coordinates):
        report = coordinate_report(data, residual, j)
        report["share"] = float(np.sum(residual[:, j] ** 2) / total) if total > 0 else 0.0
        coordinates[c] = report
        tests += [(c, kind, report[kind]["p_value"]) for kind in ("position", "velocity", "acceleration", "sign")]
    limit = alpha / max(len(tests), 1)
    dependent = [f"{kind} on {c} (p = {p:.2g})" for c, kind, p in tests if p < limit]
    coloured = [f"{c} (Ljung–Box p = {r['whiteness']['p_value']:.2g}, τ_int = {r['autocorrelation_time']:.3g})"
                for c, r in coordinates.items() if r["whiteness"]["p_value"] < alpha]
    left = bool(dependent or coloured)
    if left:
        parts = []
        if dependent:
            parts.append("depends on " + ", ".join(dependent))
        if coloured:
            parts.append("is not white on " + ", ".join(coloured))
        verdict = "something is left to explain: the residual " + "; ".join(parts)
    else:
        verdict = "nothing is left to explain: the residual is white and does not depend on the states"
    return {"coordinates": coordinates, "left": left, "verdict": verdict, "dependent": dependent, "coloured": coloured}
