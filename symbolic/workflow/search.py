"""Forward selection of catalogue effects (docs/workflow.md, "Name").

Each round starts from the current model — the nominal model's free base parameters and the effects
accepted so far — fitted by IDIM-LS weighted least squares on the estimation data; the weights
1/σ_j of that fit are used for every candidate of the round. A candidate is one effect on one
coordinate. It is fitted jointly with everything in the current model (re-identification: the
residual alone would be wrong when the effect is partly collinear with the model's own terms), and
scored by:

* the F-test of the added parameters (a nonlinear parameter counts as one), with the sample count
  divided by the residual's integrated autocorrelation time (:mod:`symbolic.workflow.statistics`);
  the p-value must be below ``alpha / m``, Bonferroni over the m trials of the round (a nonlinear
  effect's grid counts as many trials as it has independent values);
* the held-out error: residual power on the validation data (``--validate``) or by cross-validation
  over ``FOLDS`` contiguous time blocks of the estimation data; it must fall by at least
  ``min_gain`` (a fraction of what is left);
* ΔBIC = n_eff·ln(RSS₁/RSS₀) + k·ln(n_eff), which must be negative; it ranks the eligible candidates
  (one n_eff for the round: that of the best-explained candidate's residual);
* its parameters must be physical (friction opposing motion, a positive stiffness, ...).

Among the eligible candidates the lowest ΔBIC wins. Candidates that explain the data equally — twice
their log-likelihood difference n_eff·|ln(RSS₁/RSS₂)| at most ``TIE_TOLERANCE`` — tie: the one with
fewer parameters (roles) is named and the others are reported. Columns already in the span of the current model are
not candidates (an optional column, a spring's constant beside an offset, is dropped instead).

The rounds repeat on the new residual until no candidate is eligible. Then backward elimination: an
accepted effect that later ones made insignificant (partial F-test in the joint fit, p not below
``alpha`` over the number accepted) is removed, the least significant first, and reported as such.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize

from symbolic.identify.least_squares import Identification
from symbolic.workflow.dataset import DataSet
from symbolic.workflow.effects import EFFECTS, Context, Effect, Signals
from symbolic.workflow.statistics import f_test, pooled_autocorrelation_time
from symbolic.workflow.terms import ModelTerms, wls

ALPHA = 1e-3
"""Family-wise significance level of one round (Bonferroni over its trials)."""
MIN_HELD_OUT_GAIN = 0.10
"""An effect must remove at least this fraction of the held-out residual power that is left: an effect
size, not a significance level. On long closed-loop records the measurement chain's own systematic
errors are significant — the encoder's quantisation fed back through the controller makes the logged
force partly a filter of the position error, which a resonance or a narrow Stribeck rise fits — but
with 16 to 20 bits per turn they removed at most 7.4 % of the held-out residual power over the null
data sets of ``bench/diagnose.py`` (most below 3 %), while a missing effect that the workflow must name
removes most of what is left (a gap that halves is 75 % of its power)."""
TIE_TOLERANCE = 2.0
"""Two candidates tie when n_eff·|ln(RSS₁/RSS₂)| (twice their log-likelihood difference) is at most this:
a difference of 2 on the BIC scale is "not worth more than a bare mention" (Kass and Raftery 1995)."""
FOLDS = 5
"""Contiguous time blocks of the cross-validation (without validation data)."""
COLLINEAR = 1e-6
"""A column whose part outside the current model's span is below this fraction of its norm is in the model."""
REFERENCE = 1e-9
"""A model column equal to an effect's reference column up to this relative difference holds its coefficient."""


@dataclass(frozen=True)
class SearchSettings:
    """The search's thresholds (module docstring)."""

    alpha: float = ALPHA
    min_gain: float = MIN_HELD_OUT_GAIN
    tie: float = TIE_TOLERANCE
    folds: int = FOLDS
    max_effects: int = 12


@dataclass(eq=False)
class Candidate:
    """One effect on one coordinate, fitted in one round."""

    effect: Effect
    j: int
    coordinate: str
    status: str = "tested"
    """``tested``, ``not applicable``, ``in the model`` or ``needs <term>``."""
    reason: str = ""
    value: float | None = None
    trials: float = 1.0
    kept: tuple[int, ...] = ()
    width: int = 0
    added: int = 0
    rss0: float = 0.0
    rss1: float = 0.0
    tau: float = 1.0
    F: float = 0.0
    p_value: float = 1.0
    delta_bic: float = 0.0
    held_out0: float = 0.0
    held_out1: float = 0.0
    coefficients: np.ndarray | None = field(default=None, repr=False)
    model_coefficients: np.ndarray | None = field(default=None, repr=False)
    reference: float | None = None
    roles: dict[str, float | None] = field(default_factory=dict)
    invalid: str | None = None
    failed: list[str] = field(default_factory=list)

    @property
    def explained(self) -> float:
        return self.rss0 - self.rss1

    @property
    def share(self) -> float:
        """Fraction of the remaining (weighted) residual power the effect explains."""
        return self.explained / self.rss0 if self.rss0 > 0 else 0.0

    @property
    def gain(self) -> float:
        """Fraction of the held-out residual power removed."""
        return 1.0 - self.held_out1 / self.held_out0 if self.held_out0 > 0 else 0.0

    @property
    def eligible(self) -> bool:
        return self.status == "tested" and not self.failed

    def label(self) -> str:
        return f"{self.effect.label()} on {self.coordinate}"

    def summary(self) -> dict[str, Any]:
        """Plain data for the report and the JSON."""
        out: dict[str, Any] = {"effect": self.effect.identifier, **variant_of(self.effect), "coordinate": self.coordinate,
                               "status": self.status}
        if self.status != "tested":
            out["reason"] = self.reason
            return out
        out.update({
            "parameters": dict(self.roles),
            "explained_share": self.share,
            "F": self.F,
            "p_value": self.p_value,
            "trials": self.trials,
            "autocorrelation_time": self.tau,
            "delta_bic": self.delta_bic,
            "held_out_gain": self.gain,
            "accepted_if": [] if not self.failed else self.failed,
        })
        return out


def variant_of(effect: Effect) -> dict[str, str]:
    """``{"variant": ...}`` for the JSON of an effect that is one variant of its identifier, else empty."""
    return {"variant": effect.variant} if effect.variant else {}


@dataclass(eq=False)
class Accepted:
    """An accepted effect: the candidate as accepted, its columns, and what tied with it."""

    candidate: Candidate
    round: int
    columns: dict[str, np.ndarray] = field(repr=False)
    """Per data-set role, the reduced columns that were kept, ``samples × N × k``."""
    alternatives: list[Candidate] = field(default_factory=list)
    threshold: float = 0.0

    @property
    def effect(self) -> Effect:
        return self.candidate.effect


@dataclass(eq=False)
class Round:
    """One round: every candidate considered and what was accepted (``None`` at the end)."""

    number: int
    candidates: list[Candidate]
    accepted: Accepted | None
    threshold: float


@dataclass(eq=False)
class CurrentModel:
    """The current model on both data sets: columns (unweighted, reduced), the weights and the fit."""

    terms: ModelTerms
    sets: dict[str, DataSet]
    accepted: list[Accepted]
    columns: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    known: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    identification: Identification | None = None
    weights: np.ndarray | None = None
    _stacked: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        free = self.terms.free
        for role, data in self.sets.items():
            parts = [self.terms.columns(data)[:, :, free]] + [a.columns[role] for a in self.accepted]
            self.columns[role] = np.concatenate(parts, axis=2)
            self.known[role] = self.terms.known(data)
        names = list(self.terms.free_names) + [f"{a.effect.name}:{a.candidate.coordinate}:{k}"
                                               for a in self.accepted for k in range(a.columns["estimation"].shape[2])]
        self.identification = wls(self.sets["estimation"], self.columns["estimation"], self.known["estimation"], names)
        self.weights = 1.0 / np.asarray(self.identification.coordinate_sigmas)

    @property
    def size(self) -> int:
        return self.columns["estimation"].shape[2]

    def stacked(self) -> np.ndarray:
        """The estimation columns stacked (unweighted), computed once."""
        if self._stacked is None:
            self._stacked = self.sets["estimation"].stack(self.columns["estimation"])
        return self._stacked

    def predicted(self, role: str) -> np.ndarray:
        """τ of the current model on a data set (fixed terms included), ``samples × N``."""
        data = self.sets[role]
        return data.tau - self.known[role] + self.columns[role] @ self.identification.values

    def weighted(self, role: str, x: np.ndarray) -> np.ndarray:
        """``samples × N [× k]`` weighted by coordinate and stacked."""
        data = self.sets[role]
        w = self.weights.reshape((1, -1) + (1,) * (x.ndim - 2))
        return data.stack(x * w)


class Search:
    """Forward selection over ``effects`` (module docstring)."""

    def __init__(self, terms: ModelTerms, estimation: DataSet, validation: DataSet, *, cross_validate: bool,
                 effects: Sequence[Effect] | None = None, settings: SearchSettings | None = None) -> None:
        self.terms = terms
        self.sets = {"estimation": estimation, "validation": validation}
        self.cross_validate = cross_validate
        self.effects = list(EFFECTS.values()) if effects is None else list(effects)
        self.settings = settings or SearchSettings()
        s = estimation.states
        p = s.processing
        inner = slice(p.border[0], len(s.q) - p.border[1])
        passband = 0.4 * p.rate / p.decimation
        if p.cutoff is not None:
            passband = min(passband, p.cutoff)
        self.context = Context(terms.model.robot, estimation.coordinates, s.q[inner], s.qd[inner], s.qdd[inner], passband,
                               p.decimation / p.rate, float(estimation.t[-1] - estimation.t[0]), float(p.rate), terms.model)
        self.rounds: list[Round] = []
        self.accepted: list[Accepted] = []

    # -- the loop -----------------------------------------------------------------------------
    def run(self) -> list[Accepted]:
        """Rounds until no candidate is eligible (or ``max_effects`` are accepted), then backward
        elimination of the accepted effects that later ones made insignificant."""
        while len(self.accepted) < self.settings.max_effects:
            design = CurrentModel(self.terms, self.sets, self.accepted)
            chosen = self.round(design)
            if chosen is None:
                break
            self.accepted.append(chosen)
        self.eliminate()
        self.final = CurrentModel(self.terms, self.sets, self.accepted)
        return self.accepted

    def round(self, design: CurrentModel) -> Accepted | None:
        number = len(self.rounds) + 1
        state = _RoundState(self, design)
        candidates = [state.evaluate(effect, j) for effect in self.effects for j in range(len(self.context.coordinates))]
        tested = [c for c in candidates if c.status == "tested"]
        trials = sum(c.trials for c in tested)
        threshold = self.settings.alpha / max(trials, 1.0)
        # one effective sample count for the round, from the best-explained residual: BIC compares
        # models of the same data, and a candidate that leaves a coloured residual must not gain by it
        effective = len(state.y) / min(tested, key=lambda c: c.rss1).tau if tested else 1.0
        for c in tested:
            c.delta_bic = effective * math.log(max(c.rss1, 1e-300) / c.rss0) + c.added * math.log(effective)
            state.judge(c, threshold)
        pool = [c for c in tested if c.eligible]
        if not pool:
            self.rounds.append(Round(number, candidates, None, threshold))
            return None
        best = min(pool, key=lambda c: c.delta_bic)
        ties = [c for c in tested if c is not best and c.invalid is None
                and effective * abs(math.log(max(c.rss1, 1e-300) / max(best.rss1, 1e-300))) <= self.settings.tie]
        order = {e.name: k for k, e in enumerate(self.effects)}
        group = [best] + [c for c in ties if c.eligible]
        chosen = min(group, key=lambda c: (len(c.effect.roles), c.delta_bic, order.get(c.effect.name, 0)))
        alternatives = [c for c in [best] + ties if c is not chosen]
        columns = {role: state.columns(chosen.effect, chosen.j, chosen.value, role)[:, :, list(chosen.kept)]
                   for role in self.sets}
        accepted = Accepted(chosen, number, columns, alternatives, threshold)
        self.rounds.append(Round(number, candidates, accepted, threshold))
        return accepted

    def eliminate(self) -> None:
        """Remove, one at a time, the accepted effect least significant in the joint fit of all of them
        while its partial F-test's p is not below ``alpha`` / (number accepted)."""
        self.removed: list[tuple[Accepted, float, str]] = []
        while self.accepted:
            design = CurrentModel(self.terms, self.sets, self.accepted)
            tests = [self.partial(design, k) for k in range(len(self.accepted))]
            worst = int(np.argmax(tests))
            if tests[worst] < self.settings.alpha / len(self.accepted):
                return
            gone = self.accepted.pop(worst)
            others = ", ".join(a.candidate.label() for a in self.accepted) or "nothing else"
            self.removed.append((gone, tests[worst], others))

    def partial(self, design: CurrentModel, k: int) -> float:
        """p-value of accepted effect ``k`` in ``design``: the autocorrelation-corrected F-test of removing it."""
        y = design.weighted("estimation", design.known["estimation"])
        X = design.weighted("estimation", design.columns["estimation"])
        residual = y - X @ design.identification.values
        rss = float(residual @ residual)
        tau = pooled_autocorrelation_time(residual.reshape(len(design.weights), -1).T)
        block = self.block(k)
        rest = [i for i in range(X.shape[1]) if i not in block]
        coef = np.linalg.lstsq(X[:, rest], y, rcond=None)[0]
        rss_without = float(np.sum((y - X[:, rest] @ coef) ** 2))
        c = self.accepted[k].candidate
        added = len(block) + (1 if c.effect.nonlinear else 0)
        return f_test(rss_without, rss, len(y), X.shape[1] - added, added, tau)[1]

    def block(self, k: int) -> list[int]:
        """Columns of accepted effect ``k`` in the design."""
        start = len(self.terms.free_names) + sum(a.columns["estimation"].shape[2] for a in self.accepted[:k])
        return list(range(start, start + self.accepted[k].columns["estimation"].shape[2]))

    # -- the final model ----------------------------------------------------------------------
    def final_effects(self) -> list[dict[str, Any]]:
        """For each accepted effect: roles and σ from the final joint fit, and its partial test there."""
        design = self.final
        ident = design.identification
        y = design.weighted("estimation", design.known["estimation"])
        X = design.weighted("estimation", design.columns["estimation"])
        tau = pooled_autocorrelation_time((y - X @ ident.values).reshape(len(design.weights), -1).T)
        out = []
        for k, a in enumerate(self.accepted):
            c = a.candidate
            block = self.block(k)
            reference_map = _reference_map(self, design, c.effect, c.j)
            roles, sigmas = _roles_with_sigma(c, ident.values, ident.covariance * tau, block, reference_map)
            out.append({"roles": roles, "sigmas": sigmas, "coefficients_full": _expand(c, ident.values[block]),
                        "p_value": self.partial(design, k), "reference": _reference_value(reference_map, ident.values)})
        return out


def _roles_with_sigma(c: Candidate, values: np.ndarray, covariance: np.ndarray, block: list[int],
                      reference_map: list[tuple[int, float]] | None) -> tuple[dict, dict]:
    """Roles at ``values`` and their σ by the delta method (numerical Jacobian over the coefficients)."""
    def roles(v: np.ndarray) -> dict[str, float | None]:
        coefficients = _expand(c, v[block])
        return c.effect.roles_of(coefficients, c.value, _reference_value(reference_map, v))

    centre = roles(values)
    involved = sorted(set(block) | {i for i, _ in (reference_map or [])})
    sigmas: dict[str, float | None] = {}
    jac = {name: np.zeros(len(values)) for name in centre}
    for i in involved:
        step = 1e-6 * max(abs(values[i]), 1e-12) + 1e-12
        shifted = values.copy()
        shifted[i] += step
        moved = roles(shifted)
        for name in centre:
            if centre[name] is not None and moved[name] is not None:
                jac[name][i] = (moved[name] - centre[name]) / step
    for name, value in centre.items():
        sigmas[name] = None if value is None else float(np.sqrt(max(jac[name] @ covariance @ jac[name], 0.0)))
    return centre, sigmas


def _solve(gram: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Least-squares coefficients from the normal equations, columns scaled to unit norm (the candidate
    systems are small and well conditioned once scaled; the SVD is kept for the identification itself)."""
    scale = np.sqrt(np.clip(np.diag(gram), 1e-300, None))
    scaled = gram / np.outer(scale, scale)
    try:
        x = scipy.linalg.solve(scaled, right / scale, assume_a="pos", check_finite=False)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgError):
        x = np.linalg.lstsq(scaled, right / scale, rcond=None)[0]
    return x / scale


def _expand(c: Candidate, kept_values: np.ndarray) -> np.ndarray:
    """The effect's coefficient vector with NaN for the columns it did not keep."""
    full = np.full(c.width, np.nan)
    full[list(c.kept)] = kept_values
    return full


def _reference_value(reference_map: list[tuple[int, float]] | None, values: np.ndarray) -> float | None:
    if reference_map is None:
        return None
    return float(sum(values[i] * scale if i >= 0 else scale for i, scale in reference_map))


def _reference_map(search: Search, design: CurrentModel, effect: Effect, j: int) -> list[tuple[int, float]] | None:
    """How the effect's reference coefficient follows from the design's coefficients: pairs (column,
    factor); a fixed column contributes (−1, its fixed value × factor). ``None`` when no column matches."""
    data = design.sets["estimation"]
    s = data.states
    column = effect.reference_column(s.q, s.qd, s.qdd, j)
    if column is None:
        return None
    r = data.stack(data.reduce(column))
    support = r != 0
    if not support.any():
        return None
    pairs: list[tuple[int, float]] = []
    for i, factor in _proportional(design.stacked(), r, support):
        pairs.append((i, factor))
    terms = search.terms
    fixed = np.flatnonzero(~terms.free)
    if fixed.size:
        F = data.stack(terms.columns(data)[:, :, fixed])
        for k, factor in _proportional(F, r, support):
            pairs.append((-1, factor * terms.nominal[fixed[k]]))
    return pairs or None


def _proportional(X: np.ndarray, r: np.ndarray, support: np.ndarray) -> list[tuple[int, float]]:
    """(i, α) for the columns of X equal to α·r (to :data:`REFERENCE`); only columns that vanish where r
    does are compared in full."""
    norms = np.sqrt(np.einsum("ij,ij->j", X, X))
    outside = np.sqrt(np.einsum("ij,ij->j", X[~support], X[~support]))
    rr = float(r @ r)
    out = []
    for i in np.flatnonzero((norms > 0) & (outside <= REFERENCE * norms)):
        x = X[support, i]
        alpha = float(x @ r[support]) / rr
        if np.linalg.norm(x - alpha * r[support]) <= REFERENCE * norms[i]:
            out.append((int(i), alpha))
    return out


class _RoundState:
    """The weighted arrays of one round and the evaluation of its candidates.

    A candidate's columns act on few rows of the stacked system (those of its coordinate), so every
    product with them is taken on those rows only; the model's part is handled through the
    orthonormal basis Q of its columns (``r0 ⊥ Q``) and small Gram matrices.
    """

    CHUNK = 64
    """Grid values whose columns are filtered together."""

    def __init__(self, search: Search, design: CurrentModel) -> None:
        self.search = search
        self.design = design
        self.y = design.weighted("estimation", design.known["estimation"])
        self.X = design.weighted("estimation", design.columns["estimation"])
        self.coef = np.asarray(design.identification.values)
        self.r0 = self.y - self.X @ self.coef
        self.rss0 = float(self.r0 @ self.r0)
        self.Q = np.linalg.qr(self.X)[0]
        self.gram, self.right = self.X.T @ self.X, self.X.T @ self.y
        data = design.sets["estimation"]
        self.n_samples, self.n = data.samples, len(data.coordinates)
        if search.cross_validate:
            blocks = np.array_split(np.arange(self.n_samples), search.settings.folds)
            self.fold_of = np.empty(len(self.y), int)
            for f, b in enumerate(blocks):
                for j in range(self.n):
                    self.fold_of[j * self.n_samples + b] = f
            self.folds = [np.flatnonzero(self.fold_of == f) for f in range(len(blocks))]
            self.fold_gram = [(self.X[rows].T @ self.X[rows], self.X[rows].T @ self.y[rows]) for rows in self.folds]
            self.held_out0 = self.cross_validated(None)
        else:
            self.yv = design.weighted("validation", design.known["validation"])
            self.Xv = design.weighted("validation", design.columns["validation"])
            self.held_out0 = float(np.sum((self.yv - self.Xv @ self.coef) ** 2))
        self._cache: dict = {}
        self._signals: dict[str, Signals] = {}
        self._spectra: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    # columns of an effect on one data set, reduced (samples × N × k)
    def columns(self, effect: Effect, j: int, value: float | None, role: str) -> np.ndarray:
        key = (effect.name, j, value, role)
        if key not in self._cache:
            self._cache[key] = self.batch(effect, j, [value], role)[0]
        return self._cache[key]

    def batch(self, effect: Effect, j: int, values: Sequence[float | None], role: str) -> list[np.ndarray]:
        """Reduced columns for several values of the nonlinear parameter, filtered in one pass; only the
        coordinates an effect acts on are filtered (the others stay zero)."""
        signals = self.signals(role)
        raw = [effect.columns_at(signals, j, v) for v in values]
        widths = [r.shape[2] for r in raw]
        stacked = np.concatenate(raw, axis=2)
        rows = np.flatnonzero(np.any(stacked != 0, axis=(0, 2)))
        if rows.size == 0:
            rows = np.array([j])
        reduced = self.design.sets[role].reduce(stacked[:, rows, :])
        out = np.zeros((reduced.shape[0], stacked.shape[1], stacked.shape[2]))
        out[:, rows, :] = reduced
        return np.split(out, np.cumsum(widths)[:-1], axis=2)

    def signals(self, role: str) -> Signals:
        """The data set's filtered states at every sample, with time and rate (for :meth:`Effect.columns_at`)."""
        if role not in self._signals:
            data = self.design.sets[role]
            record = None if data.record is None else self._signals_of(data.record)
            self._signals[role] = self._signals_of(data, record)
        return self._signals[role]

    def _signals_of(self, data: DataSet, record: Signals | None = None) -> Signals:
        s = data.states
        return Signals(s.q, s.qd, s.qdd, np.asarray(data.measurements.t), float(s.processing.rate),
                       self.search.context.robot, record, data.start)

    def cross_validated(self, extra: tuple[np.ndarray, np.ndarray] | None) -> float:
        """Residual power of the held-out blocks, each predicted by the fit on the others (normal
        equations: a fold only subtracts its own small Gram blocks). ``extra`` = (rows, Z[rows]) adds a
        candidate's columns, non-zero on ``rows`` only."""
        total = 0.0
        if extra is not None:
            rows, Zr = extra
            cross, zz, zy = self.X[rows].T @ Zr, Zr.T @ Zr, Zr.T @ self.y[rows]
            gram = np.block([[self.gram, cross], [cross.T, zz]])
            right = np.concatenate([self.right, zy])
        for f, fold in enumerate(self.folds):
            g, b = self.fold_gram[f]
            if extra is None:
                coef = _solve(self.gram - g, self.right - b)
                e = self.y[fold] - self.X[fold] @ coef
            else:
                inside = rows[self.fold_of[rows] == f]
                Zf = Zr[self.fold_of[rows] == f]
                cf = self.X[inside].T @ Zf
                gf = np.block([[g, cf], [cf.T, Zf.T @ Zf]])
                bf = np.concatenate([b, Zf.T @ self.y[inside]])
                coef = _solve(gram - gf, right - bf)
                p = self.X.shape[1]
                e = self.y[fold] - self.X[fold] @ coef[:p]
                position = np.searchsorted(fold, inside)
                e[position] -= Zf @ coef[p:]
            total += float(e @ e)
        return total

    def project(self, Z: np.ndarray, optional: tuple[int, ...]):
        """The candidate's columns outside the model's span: (rows, kept columns, a = QᵀZ, G = Z⊥ᵀZ⊥,
        b = Zᵀr0) on the kept columns, or (None, reason) when a required column is already in the model."""
        rows = np.flatnonzero(np.any(Z != 0, axis=1))
        Zr = Z[rows]
        a = self.Q[rows].T @ Zr
        G = Zr.T @ Zr - a.T @ a
        norms = np.einsum("ij,ij->j", Zr, Zr)
        kept: list[int] = []
        for i in range(Z.shape[1]):
            rest = G[i, i]
            if kept and norms[i] > 0:
                g = G[i, kept]
                rest -= g @ np.linalg.solve(G[np.ix_(kept, kept)], g)
            if norms[i] == 0 or rest <= COLLINEAR**2 * norms[i]:
                if i in optional:
                    continue
                why = "its column vanishes on these data" if norms[i] == 0 else \
                    "the model already holds it (its column is in the span of the model's terms)"
                return None, why
            kept.append(i)
        if not kept:
            return None, "the model already holds it"
        return (rows, tuple(kept), a[:, kept], G[np.ix_(kept, kept)], Zr[:, kept].T @ self.r0[rows]), ""

    def explained(self, effect: Effect, j: int, value: float | None, columns: np.ndarray | None = None) -> float:
        """Residual power the effect explains at ``value`` (jointly with the model's terms)."""
        if columns is None:
            columns = self.batch(effect, j, [value], "estimation")[0]
        parts, _ = self.project(self.design.weighted("estimation", columns), effect.optional)
        if parts is None:
            return 0.0
        _, _, _, G, b = parts
        return float(b @ np.linalg.solve(G, b))

    def explained_on_row(self, effect: Effect, j: int, columns: list[np.ndarray]) -> list[float]:
        """:meth:`explained` for many column sets at once, when they all act on coordinate ``j`` only and
        none is optional (a grid of values): the same quantities b = Zᵀr0 and G = ZᵀZ − (QᵀZ)ᵀ(QᵀZ) on
        coordinate j's rows, for every set in one matrix product. A set with a column in the model's span
        (its part outside below :data:`COLLINEAR` of its norm) explains 0, as :meth:`project` has it."""
        others = [i for i in range(self.n) if i != j]
        if effect.optional or any(np.any(z[:, others, :]) for z in columns):
            return [self.explained(effect, j, None, z) for z in columns]
        rows = slice(j * self.n_samples, (j + 1) * self.n_samples)
        k = columns[0].shape[2]
        Z = np.stack([z[:, j, :] for z in columns], axis=1) * self.design.weights[j]  # samples × sets × k
        a = np.einsum("sp,smk->pmk", self.Q[rows], Z)
        b = np.einsum("smk,s->mk", Z, self.r0[rows])
        zz = np.einsum("smk,sml->mkl", Z, Z)
        G = zz - np.einsum("pmk,pml->mkl", a, a)
        diagonal = np.einsum("mkk->mk", G)
        norms = np.einsum("mkk->mk", zz)
        fine = np.all((norms > 0) & (diagonal > COLLINEAR**2 * norms), axis=1) if k else np.zeros(len(columns), bool)
        out = np.zeros(len(columns))
        if fine.any():
            out[fine] = np.einsum("mk,mk->m", b[fine], np.linalg.solve(G[fine], b[fine][:, :, None])[:, :, 0])
        return [float(x) for x in out]

    def evaluate(self, effect: Effect, j: int) -> Candidate:
        search = self.search
        coordinate = search.context.coordinates[j]
        c = Candidate(effect, j, coordinate)
        taken = [a for a in search.accepted if a.candidate.j == j]
        if any(a.effect.name == effect.name for a in taken) and not getattr(effect, "repeatable", False):
            c.status, c.reason = "in the model", "accepted in an earlier round"
            return c
        exclusive = {"stribeck": "asymmetric_coulomb", "asymmetric_coulomb": "stribeck"}
        if any(a.effect.name == exclusive.get(effect.name) for a in taken):
            c.status, c.reason = "not applicable", f"{exclusive[effect.name]} was accepted on {coordinate}"
            return c
        reason = effect.applicable(search.context, j)
        if reason:
            c.status, c.reason = "not applicable", reason
            return c
        reference_map = _reference_map(search, self.design, effect, j)
        if effect.refines and reference_map is None:
            c.status, c.reason = f"needs {effect.refines}", f"the model has no {effect.refines} friction on {coordinate}"
            return c
        scanned = None
        if effect.nonlinear:
            grid = effect.grid(search.context, j)
            if grid is None:
                c.status, c.reason = "not applicable", f"the data give no range for its {effect.nonlinear}"
                return c
            values, c.trials = grid
            c.value = self.scan(effect, j, values)
            scanned = self._scanned if np.ndim(values) == 1 else None
        else:
            c.value = effect.setting(search.context, j)
        Z = self.design.weighted("estimation", self.columns(effect, j, c.value, "estimation"))
        parts, why = self.project(Z, effect.optional)
        if parts is None:
            c.status, c.reason = "in the model", why
            return c
        rows, kept, a, G, b = parts
        c.kept, c.width = kept, Z.shape[1]
        c.added = len(kept) + (1 if effect.nonlinear else 0)
        step = np.linalg.solve(G, b)
        r1 = self.r0 - self.Q @ (-(a @ step))
        r1[rows] -= Z[np.ix_(rows, kept)] @ step
        c.rss0, c.rss1 = self.rss0, float(r1 @ r1)
        c.tau = pooled_autocorrelation_time(r1.reshape(self.n, self.n_samples).T)
        c.F, c.p_value = f_test(c.rss0, c.rss1, len(self.y), self.X.shape[1], c.added, c.tau)
        Zr = Z[np.ix_(rows, kept)]
        cross = self.X[rows].T @ Zr
        coef = _solve(np.block([[self.gram, cross], [cross.T, Zr.T @ Zr]]), np.concatenate([self.right, Zr.T @ self.y[rows]]))
        c.model_coefficients = coef
        c.coefficients = _expand(c, coef[self.X.shape[1]:])
        if search.cross_validate:
            c.held_out0, c.held_out1 = self.held_out0, self.cross_validated((rows, Zr))
        else:
            Zv = self.design.weighted("validation", self.columns(effect, j, c.value, "validation"))[:, list(kept)]
            e = self.yv - np.concatenate([self.Xv, Zv], axis=1) @ coef
            c.held_out0, c.held_out1 = self.held_out0, float(e @ e)
        c.reference = _reference_value(reference_map, coef)
        c.roles = effect.roles_of(c.coefficients, c.value, c.reference)
        c.invalid = effect.check(c.roles, c.reference, search.context, j) or \
            effect.check_residual(c.roles, *self.residual_spectrum(j), c.share)
        if c.invalid is None and effect.nonlinear and scanned is not None:
            c.invalid = effect.scan_verdict(*scanned, search.context)
        return c

    def residual_spectrum(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Welch spectrum of the round's residual on coordinate ``j`` (at the kept samples' rate)."""
        if j not in self._spectra:
            from symbolic.workflow.where import spectrum

            p = self.design.sets["estimation"].states.processing
            residual = self.r0.reshape(self.n, self.n_samples)[j]
            self._spectra[j] = spectrum(residual, p.rate / p.decimation)
        return self._spectra[j]

    def scan(self, effect: Effect, j: int, values: np.ndarray) -> float | tuple[float, ...]:
        """The nonlinear parameter explaining most: the best grid value, refined between its neighbours
        (several parameters: the best grid row, refined by a simplex search within the grid's box)."""
        if np.ndim(values) == 2:
            return self.scan_several(effect, j, np.asarray(values, float))
        explained = []
        kept = self.design.sets["estimation"].t

        def quick(v: float) -> np.ndarray | None:  # the effect's shortcut (Effect.scan_columns), if it has one
            z = effect.scan_columns(kept, self.n, j, [v])
            return None if z is None else z[0]

        for chunk in np.array_split(values, max(1, math.ceil(len(values) / self.CHUNK))):
            points = [float(v) for v in chunk]
            columns = effect.scan_columns(kept, self.n, j, points) or self.batch(effect, j, points, "estimation")
            explained += self.explained_on_row(effect, j, columns)
        self._scanned = (np.asarray(values, float), np.asarray(explained))
        best = int(np.argmax(explained))
        low, high = values[max(best - 1, 0)], values[min(best + 1, len(values) - 1)]
        if high <= low:
            return float(values[best])
        result = scipy.optimize.minimize_scalar(
            lambda x: -self.explained(effect, j, float(math.exp(x)), quick(float(math.exp(x)))),
            bounds=(math.log(low), math.log(high)), method="bounded", options={"xatol": effect.refinement})
        return float(math.exp(result.x)) if -result.fun >= explained[best] else float(values[best])

    def scan_several(self, effect: Effect, j: int, values: np.ndarray) -> tuple[float, ...]:
        rows = [tuple(float(x) for x in row) for row in values]
        explained = []
        for start in range(0, len(rows), self.CHUNK):
            chunk = rows[start:start + self.CHUNK]
            columns = self.batch(effect, j, chunk, "estimation")
            explained += [self.explained(effect, j, v, z) for v, z in zip(chunk, columns)]
        best = int(np.argmax(explained))
        low, high = np.log(values.min(axis=0)), np.log(values.max(axis=0))

        def loss(x: np.ndarray) -> float:
            if np.any(x < low) or np.any(x > high):
                return 0.0
            return -self.explained(effect, j, tuple(float(v) for v in np.exp(x)))

        start = np.log(np.asarray(rows[best]))
        steps = np.diag(np.maximum((high - low) / max(len(rows) ** (1 / values.shape[1]), 1.0), 1e-3))
        result = scipy.optimize.minimize(loss, start, method="Nelder-Mead",
                                         options={"initial_simplex": np.vstack([start, start + steps]),
                                                  "xatol": 1e-4, "fatol": 1e-9 * max(explained[best], 1e-300),
                                                  "maxfev": 120})
        if -result.fun >= explained[best]:
            return tuple(float(v) for v in np.exp(result.x))
        return rows[best]

    def judge(self, c: Candidate, threshold: float) -> None:
        s = self.search.settings
        if c.invalid:
            c.failed.append(f"physical: {c.invalid}")
        if not c.p_value < threshold:
            c.failed.append(f"significance: p = {c.p_value:.3g} is not below {threshold:.3g}")
        if c.gain < s.min_gain:
            c.failed.append(f"held-out: removes {100 * c.gain:.3g} % of the held-out residual power "
                            f"(at least {100 * s.min_gain:g} % needed)")
        if not c.delta_bic < 0:
            c.failed.append(f"BIC: ΔBIC = {c.delta_bic:.3g} is not negative")
