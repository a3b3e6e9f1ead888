"""Statistics of residuals: integrated autocorrelation time, the F-test it corrects, Ljung–Box.

Residuals of a model fitted to measured data are rarely white: a missing effect, the decimation
filter and the dynamics of the loop colour them. A test that counts every sample as independent then
calls tiny improvements significant. Each test here divides the sample count by the residual's
integrated autocorrelation time τ_int = 1 + 2·Σ ρ_k (Sokal's automatic window: the sum stops at the
first lag M ≥ 5·τ_int(M)), i.e. works with n_eff = n/τ_int effective samples. This is exact for a
slowly varying regressor and conservative otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.stats

ALPHA = 1e-3
"""Family-wise significance level of one round of the search (Bonferroni over its trials) and of the
localisation's tests (:mod:`symbolic.workflow.where`)."""
MIN_HELD_OUT_GAIN = 0.10
"""An effect must remove at least this fraction of its own coordinates' held-out residual power that is
left (the search), and a correction or a treatment of the data as much of what keeping the file's value or
the data as logged leaves (:mod:`symbolic.workflow.corrections`): an effect size, not a significance level. On long closed-loop records the measurement chain's own
systematic errors are significant — the encoder's quantisation fed back through the controller makes the
logged force partly a filter of the position error, which a resonance or a narrow Stribeck rise fits — but
with 16 to 20 bits per turn they removed at most 7.4 % of the held-out residual power over the null
data sets of ``bench/diagnose.py`` (most below 3 %), while a missing effect that the workflow must name
removes most of what is left (a gap that halves is 75 % of its power)."""

MIN_FORCE_SHARE = 1e-3
"""An effect must remove from its coordinates' held-out residual at least this fraction of their measured force's
spread (RMS about the mean; in power, its square): 0.1 %, below what any force or current sensor resolves. On data
without noise the residual is what the treatment's filters leave, of the order 1e-4 of the force, and it repeats
between the estimation and the held-out data, so an effect fitted to it passes the relative rules (the 7-DOF Panda
simulated under PD, nothing missing: a joint stiffness of 4e-5 N·m/rad, 0.0004 % of the joint's force, was
named)."""

MIN_SIGMAS = 5.0
"""A fitted value is named only this many of its σ away from its null value (a delay from 0, a gain from 1, a
stiffness from 0). The σ of a coloured residual are a lower bound of the spread: a necessary condition beside
the held-out gain, not a sufficient one (the response search, the two-encoder test)."""

SOKAL_WINDOW = 5.0


def autocorrelation(x: np.ndarray, lags: int | None = None) -> np.ndarray:
    """Sample autocorrelation ρ_0 … ρ_lags of a series (mean removed; biased estimator, ρ_0 = 1)."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = len(x)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(x, size)
    acf = np.fft.irfft(spectrum * np.conj(spectrum), size)[:n]
    if acf[0] <= 0:
        out = np.zeros(n)
        out[0] = 1.0
        return out[: (lags or n - 1) + 1]
    acf = acf / acf[0]
    return acf[: (lags or n - 1) + 1]


def autocorrelation_time(x: np.ndarray) -> float:
    """τ_int of a series (module docstring); at least 1 (anti-correlated residuals are not credited)."""
    acf = autocorrelation(x)
    if len(acf) < 3:
        return 1.0
    tau = 1.0 + 2.0 * np.cumsum(acf[1:])
    lags = np.arange(1, len(acf))
    stop = np.flatnonzero(lags >= SOKAL_WINDOW * tau)
    value = tau[stop[0]] if stop.size else tau[-1]
    return float(max(value, 1.0))


def score_inflation(z: np.ndarray, residual: np.ndarray, b: np.ndarray) -> float:
    """How much the residual's autocorrelation inflates the variance of the score b = zᵀe of columns ``z``
    (``samples × k``, outside the model's span) in the direction of ``b``: bᵀG⁻¹b / bᵀV⁻¹b with G = zᵀz and
    V = Σ_{|l|≤M} ρ_l·Σ_t z_t z_{t+l}ᵀ (Bartlett 1946; ρ the residual's autocorrelation, M Sokal's window of
    :func:`autocorrelation_time`). It equals τ_int for slowly varying columns and differs where the residual's
    power is not at zero frequency: less for fast columns, more for columns at a residual's resonance, whose
    integrated autocorrelation time is small because its lobes cancel. 1 where V is not positive definite
    (a truncated estimate)."""
    z = np.asarray(z, dtype=float).reshape(len(z), -1)
    acf = autocorrelation(residual)
    tau = 1.0 + 2.0 * np.cumsum(acf[1:])
    lags = np.arange(1, len(acf))
    stop = np.flatnonzero(lags >= SOKAL_WINDOW * tau)
    window = int(lags[stop[0]]) if stop.size else len(acf) - 1
    n = len(z)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spectra = np.fft.rfft(z, size, axis=0)
    k = z.shape[1]
    V = np.empty((k, k))
    for i in range(k):
        for j in range(k):
            cross = np.fft.irfft(spectra[:, i] * np.conj(spectra[:, j]), size)  # Σ_t z_i[t+l] z_j[t] at lag l
            V[i, j] = cross[0] + acf[1:window + 1] @ (cross[1:window + 1] + cross[size - window:][::-1])
    V = 0.5 * (V + V.T)
    G = z.T @ z
    try:
        np.linalg.cholesky(V)
        return float((b @ np.linalg.solve(G, b)) / (b @ np.linalg.solve(V, b)))
    except np.linalg.LinAlgError:
        return 1.0


def pooled_autocorrelation_time(residual: np.ndarray) -> float:
    """τ_int of a ``samples × N`` residual: the coordinates' values weighted by their residual power."""
    residual = np.asarray(residual, dtype=float).reshape(len(residual), -1)
    power = np.sum(residual**2, axis=0)
    if power.sum() <= 0:
        return 1.0
    taus = [autocorrelation_time(residual[:, j]) if power[j] > 0 else 1.0 for j in range(residual.shape[1])]
    return float(np.dot(taus, power) / power.sum())


def f_test(rss0: float, rss1: float, rows: float, parameters: float, added: int, tau: float) -> tuple[float, float]:
    """(F, p) of adding ``added`` parameters to a model of ``parameters``, corrected for autocorrelation.

    F = ((RSS₀ − RSS₁)/k) / (RSS₁/(n − p − k)) divided by τ_int, against F(k, n/τ_int − p − k).
    """
    dof = rows - parameters - added
    if rss1 <= 0 or dof <= 0 or added <= 0:
        return float("inf"), 0.0
    statistic = ((rss0 - rss1) / added) / (rss1 / dof) / tau
    effective = rows / tau - parameters - added
    if effective <= 0:
        return statistic, 1.0
    return float(statistic), float(scipy.stats.f.sf(statistic, added, effective))


def combined_f_test(parts: Sequence[tuple[float, float, float, float, int, float]]) -> tuple[float, float]:
    """(F, p) of parameters added on several coordinates at once, each part a coordinate (or rows pooled)
    with its own noise level and autocorrelation: (RSS₀, RSS₁, rows n, model parameters p, added k, τ_int).

    χ² = Σ_c ((RSS₀,c − RSS₁,c)/(RSS₁,c/(n_c − p_c − k_c)))/τ_c, F = χ²/K with K = Σ k_c, against
    F(K, Σ_c (n_c/τ_c − p_c − k_c)); with one part this is :func:`f_test` (docs/workflow.md, "Name").
    ``p`` may be fractional: the model's parameters counted by their leverage on the part's rows.
    """
    chi2, added, effective = 0.0, 0, 0.0
    for rss0, rss1, rows, parameters, k, tau in parts:
        dof = rows - parameters - k
        if rss1 <= 0 or dof <= 0 or k <= 0:
            return float("inf"), 0.0
        chi2 += (rss0 - rss1) / (rss1 / dof) / tau
        added += k
        effective += rows / tau - parameters - k
    if added <= 0:
        return float("inf"), 0.0
    statistic = chi2 / added
    if effective <= 0:
        return float(statistic), 1.0
    return float(statistic), float(scipy.stats.f.sf(statistic, added, effective))


def ljung_box(x: np.ndarray, lags: int | None = None) -> tuple[float, float, int]:
    """Ljung–Box Q over ``lags`` lags (default min(20, n/5)) and its p-value against χ²(lags)."""
    n = len(x)
    lags = lags or max(1, min(20, n // 5))
    rho = autocorrelation(x, lags)[1:]
    q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, lags + 1))))
    return q, float(scipy.stats.chi2.sf(q, lags)), lags


def correlation(x: np.ndarray, y: np.ndarray, tau: float = 1.0) -> tuple[float, float]:
    """Pearson r of two series and its two-sided p-value with n/τ effective samples."""
    x = np.asarray(x, float) - np.mean(x)
    y = np.asarray(y, float) - np.mean(y)
    denominator = np.sqrt((x @ x) * (y @ y))
    if denominator <= 0:
        return 0.0, 1.0
    r = float(np.clip((x @ y) / denominator, -1.0, 1.0))
    effective = max(len(x) / tau, 3.0)
    if abs(r) >= 1.0:
        return r, 0.0
    t = r * np.sqrt((effective - 2) / (1 - r * r))
    return r, float(2 * scipy.stats.t.sf(abs(t), effective - 2))
