"""Predicted uncertainty of the base parameters before the robot moves (docs/data.md, "Predicted σ").

IDIM-LS (:mod:`symbolic.identify.least_squares`) estimates β from y = Wβ + ρ; with noise of covariance
Σ = diag(σ_j²) per coordinate, white at the sample rate f_s, weighted least squares gives
Cov(β̂) = (Σ_k W_kᵀ Σ⁻¹ W_k)⁻¹ = M⁻¹ over the samples k the treatment keeps (the log minus its borders), W_k
the regressor as identify reduces it (low-passed by the decimation filter: :func:`predict`), and the predicted
σ%_i = 100·√(M⁻¹)_ii / |β_i| at the model's nominal β.

The treatment's filters enter as an **effective noise bandwidth** (the approximation stated here):

* *Force noise* σ_τ,j per sample: the decimation filter (:mod:`symbolic.data.filters`) passes it unchanged
  below its edge f_b = 0.8·(f_s/2)/d, so its density there is that of white noise of variance σ_τ,j² at f_s;
  the regressor, low-passed by the same filter, keeps only its content below f_b, and each decimated row stands
  for d samples (the σ that ``identify`` prints from the decimated residual is 0.85–0.9 times this spread,
  docs/data.md).
* *Encoder quantisation* of resolution δ_i: white position noise of variance δ_i²/12, low-passed by the
  zero-phase Butterworth (|H(f)|⁴ in power, forward and backward) and differentiated twice by central
  differences ((f_s sin(2πf/f_s))⁴ in power), becomes acceleration noise; its mean density over [0, f_b] is
  replaced by white noise of that density at f_s, of variance
  v_i = (δ_i²/12)·(1/f_b)∫₀^{f_b} |H(f)|⁴ (f_s sin(2πf/f_s))⁴ df,
  and enters the force through the inertia matrix: σ_eq,j² = σ_τ,j² + Σ_i D_ji² v_i, with D_ji² the mean
  over the trajectory. This overstates the (f⁴-shaped, mostly high-frequency) noise at the few harmonics of
  the excitation and ignores the bias of errors in the variables; the velocity noise (through friction) is
  left out. The quantisation term is a correction: with force noise dominant the prediction is exact up to
  the decimation's edge effects (tests/test_excitation.py compares it with a Monte-Carlo of ``identify``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from symbolic.data.filters import DECIMATION_CUTOFF
from symbolic.data.settings import Processing, Settings
from symbolic.derivation.dynamics import DynamicModel
from symbolic.errors import IdentificationError


@dataclass(frozen=True)
class Noise:
    """Declared noise: force σ per sample and encoder resolution per coordinate, at sample ``rate`` (Hz)."""

    coordinates: tuple[str, ...]
    force: np.ndarray
    resolution: np.ndarray
    rate: float

    def at_rate(self, rate: float) -> Noise:
        """The same noise densities sampled at ``rate``: force σ² scales with the rate (white noise)."""
        return Noise(self.coordinates, self.force * math.sqrt(rate / self.rate), self.resolution, rate)

    def to_dict(self) -> dict[str, Any]:
        return {"rate": self.rate, "force_noise": dict(zip(self.coordinates, map(float, self.force))),
                "resolution": dict(zip(self.coordinates, map(float, self.resolution)))}


def resolve_noise(model: DynamicModel, rate: float | None, *sources: tuple[str, Mapping[str, Mapping[str, Any]]]) -> Noise:
    """The declared noise (``force_noise``, ``resolution``; later ``sources`` replace earlier ones); a missing
    force noise or rate is refused with what to declare. Resolution defaults to 0 (no quantisation)."""
    names = tuple(model.robot.generalized_coordinates)
    merged: dict[str, dict[str, float]] = {"force_noise": {}, "resolution": {}}
    for _, declared in sources:
        for kind in merged:
            merged[kind].update(declared.get(kind) or {})
    missing = [c for c in names if c not in merged["force_noise"] or not merged["force_noise"][c] > 0]
    if missing:
        raise IdentificationError(f"no force noise for coordinate{'s' if len(missing) > 1 else ''} {', '.join(missing)}: "
                                  f"declare σ of the force measurement per sample (> 0) in the experiment's [excitation] "
                                  f"table (force_noise = {{ {missing[0]} = 0.1 }}, or one number) or with --force-noise")
    if rate is None or not rate > 0:
        raise IdentificationError("no sample rate for the log to be recorded: declare rate = <Hz> in the experiment's "
                                  "[excitation] table or give --rate")
    return Noise(names, np.array([merged["force_noise"][c] for c in names], float),
                 np.array([merged["resolution"].get(c, 0.0) for c in names], float), float(rate))


def decimation_edge(processing: Processing) -> float:
    """f_b: the upper edge of the band the decimated system keeps (Hz)."""
    nyquist = processing.rate / 2.0
    return nyquist if processing.decimation <= 1 else DECIMATION_CUTOFF * nyquist / processing.decimation


def acceleration_noise(resolution: np.ndarray, processing: Processing, points: int = 4001) -> np.ndarray:
    """v_i, the white-equivalent variance of the acceleration noise from quantisation (module docstring)."""
    fs, fb = processing.rate, decimation_edge(processing)
    f = np.linspace(0.0, fb, points)
    h4 = 1.0 if processing.cutoff is None else 1.0 / (1.0 + (f / processing.cutoff) ** (2 * processing.order)) ** 2
    shape = h4 * (fs * np.sin(2.0 * np.pi * f / fs)) ** 4
    mean = float(np.sum((shape[1:] + shape[:-1]) * 0.5 * np.diff(f))) / fb
    return np.asarray(resolution, float) ** 2 / 12.0 * mean


def equivalent_noise(model: DynamicModel, noise: Noise, processing: Processing, q: np.ndarray) -> np.ndarray:
    """σ_eq,j per coordinate: force noise and quantisation through D(q) (module docstring); ``q`` a few
    positions of the trajectory (the mean of D_ji² is taken over them)."""
    variance = noise.force ** 2
    v = acceleration_noise(noise.resolution, processing)
    if np.any(v > 0):
        from symbolic.numeric import numeric_model

        numeric = numeric_model(model)
        d2 = np.mean([np.asarray(numeric.inertia(x)) ** 2 for x in q], axis=0)
        variance = variance + d2 @ v
    return np.sqrt(variance)


def treatment(rate: float, samples: int, settings: Settings | None = None) -> Processing:
    """The treatment identify would apply to a log of ``samples`` samples at ``rate`` (its defaults, or the
    experiment's ``[identification]``)."""
    return (settings or Settings()).resolve(rate, samples, "<excitation>")


@dataclass(frozen=True, eq=False)
class Prediction:
    """Predicted σ of the base parameters for one trajectory.

    ``information`` is M = Σ_k W_kᵀΣ⁻¹W_k over the kept samples; ``condition_number`` cond(Σ^(−1/2)W) =
    √(λ_max/λ_min) of M (what identify reports as cond(W) for WLS)."""

    label: str
    names: tuple[str, ...]
    values: np.ndarray
    sigmas: np.ndarray
    information: np.ndarray
    samples: int
    noise: np.ndarray
    duration: float

    @property
    def relative(self) -> np.ndarray:
        with np.errstate(divide="ignore"):
            return np.where(self.values != 0, 100.0 * self.sigmas / np.abs(self.values), np.inf)

    @property
    def log_det(self) -> float:
        sign, value = np.linalg.slogdet(self.information)
        return float(value) if sign > 0 else -math.inf

    def pair(self, i: int, j: int) -> tuple[float, float, float]:
        """σ % of base parameters ``i`` and ``j`` and their correlation ρ_ij = C_ij/√(C_ii C_jj) in C = M⁻¹ (M⁺ for a
        singular M); ρ is NaN when either is not estimable (σ = ∞: the data cannot separate it)."""
        relative = self.relative
        if not (math.isfinite(self.sigmas[i]) and math.isfinite(self.sigmas[j])):
            return float(relative[i]), float(relative[j]), math.nan
        C = np.linalg.pinv(0.5 * (self.information + self.information.T), hermitian=True)  # noqa: N806
        return float(relative[i]), float(relative[j]), float(C[i, j] / math.sqrt(C[i, i] * C[j, j]))

    @property
    def condition_number(self) -> float:
        values = np.linalg.eigvalsh(self.information)
        return float(math.sqrt(values[-1] / values[0])) if values[0] > 0 else math.inf

    def to_dict(self) -> dict[str, Any]:
        def finite(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {"label": self.label, "samples": self.samples, "duration": self.duration,
                "log_det_information": finite(self.log_det), "condition_number": finite(self.condition_number),
                "equivalent_force_noise": [float(s) for s in self.noise],
                "parameters": {n: {"nominal": float(v), "sigma": float(s), "relative_sigma": finite(r)}
                               for n, v, s, r in zip(self.names, self.values, self.sigmas, self.relative)}}


def predict(model: DynamicModel, label: str, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, sigma: Sequence[float],
            duration: float, processing: Processing) -> Prediction:
    """The predicted σ of the base parameters from the states of every sample (rows of q, q̇, q̈, before the
    border is dropped), the equivalent noise ``sigma`` per coordinate and identify's treatment ``processing``.

    The regressor is identify's own (:func:`symbolic.identify.model.base_regressor`), reduced as identify reduces it
    (:meth:`Processing.reduce`: border dropped, low-passed and decimated by d): the decimation filter removes the
    regressor's content above its edge (the square-wave harmonics of a Coulomb column) and keeps the noise density
    below it, so M = d·Σ_k W_d,kᵀ Σ⁻¹ W_d,k over the decimated rows, with Σ the noise per sample at the log's rate.
    """
    from symbolic.identify.model import base_regressor, model_base

    _, base = model_base(model)
    reduced = processing.reduce(base_regressor(model)(q, qd, qdd))
    weights = 1.0 / np.asarray(sigma, float) ** 2
    M = processing.decimation * np.einsum("kjp,j,kjr->pr", reduced, weights, reduced)  # noqa: N806
    M = 0.5 * (M + M.T)  # noqa: N806
    sigmas = covariance_sigmas(M)
    kept = len(q) - processing.border[0] - processing.border[1]
    return Prediction(label, tuple(base.names), np.asarray(base.values, float), sigmas, M, kept,
                      np.asarray(sigma, float), float(duration))


def covariance_sigmas(M: np.ndarray) -> np.ndarray:  # noqa: N803
    """√diag(M⁻¹), and for a singular M (data that cannot separate some parameters) ∞ for the parameters in its
    null space and √diag(M⁺) for the others.

    β_i is estimable from the data when the unit vector e_i is orthogonal to the null space of M (a linear
    function cᵀβ is estimable iff c lies in the range of M; Searle, *Linear Models*, 1971, §5.4); its variance is
    then e_iᵀM⁺e_i. The null space: the eigenvectors of M whose eigenvalues are at most λ_max·b·ε (NumPy's
    ``matrix_rank`` tolerance); e_i is taken as orthogonal to it when its component there is below 1e-6."""
    M = 0.5 * (M + M.T)  # noqa: N806
    b = M.shape[0]
    values, vectors = np.linalg.eigh(M)
    if not np.all(np.isfinite(values)) or values[-1] <= 0:
        return np.full(b, np.inf)
    null = values <= values[-1] * b * np.finfo(float).eps
    if not null.any():
        return np.sqrt(np.abs(np.diag(np.linalg.inv(M))))
    kept = vectors[:, ~null]
    pseudo = (kept / values[~null]) @ kept.T
    inestimable = np.linalg.norm(vectors[:, null], axis=1) > 1e-6
    return np.where(inestimable, np.inf, np.sqrt(np.abs(np.diag(pseudo))))
