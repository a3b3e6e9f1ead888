"""Wrong values, not only missing effects: what the re-identification does to the model file's own values.

After the search, the model's own parameters are re-identified with the effects found (the patched model,
or the search's final joint fit when the patch adds a coordinate the data lack). This module reports

* **corrections**: the model-file parameters the data move far from the file's value — beyond
  :data:`SIGMAS` standard deviations *and* beyond :data:`RELATIVE` of the value — each with its evidence
  (how many σ, and the held-out gap if the value were kept at the file's while everything else is
  re-identified, which must be worse by the search's effect size, :data:`MIN_HELD_OUT_GAIN`), a physical value
  (within what the model's other values allow, :attr:`Value.physical`) and one that holds when the data
  are treated at half the bandwidth (:meth:`Value.holds_with`: not an artefact of differentiating
  quantised positions); a value failing one of these is noted with the reason. Only what the data identify can be named: a base parameter that is one model parameter
  up to known factors, β = a·p + b (p = (β − b)/a, σ_p = σ_β/|a|, as :func:`symbolic.identify.model.direct_parameters`);
  a base parameter that combines several model parameters (ZZR1 = I1 + m1·c1² + m2·l1²) is reported as that
  combination. σ is the fit's (IDIM-LS weighted least squares) × the residual's integrated
  autocorrelation time, as for the effects' parameters;
* **changes**: every value the patch writes, removes, or keeps at the file's value because the fitted one
  would not be physical (:func:`physical_values`: a patched model file always loads);
* **modes**: for a model with elastic coordinates (a ``[[force]]`` depending on a coordinate's position —
  a spring —, a ``[[beam]]``, or a coordinate the patch adds), the linearised modes with the file's values
  and with the patched ones (:func:`symbolic.workflow.modes.plant_modes`; closed-loop ones under the data's
  ``[controller]`` as well, :func:`symbolic.workflow.modes.closed_loop_modes`), and a sentence saying what a
  correction means ("stiffness Ks is 1.7× too high: 2.92 Hz → 2.24 Hz").
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.data import DataError
from symbolic.description.modelfile import loads, with_parameter_values
from symbolic.description.robot import Directional, Robot, coordinate_symbol, velocity_symbol
from symbolic.errors import ModelError, ModelWarning
from symbolic.identify.known import beta_bounds, parameter_bounds, polynomial_lower_bound
from symbolic.identify.least_squares import Identification, RankDeficient
from symbolic.identify.model import geometric_parameters
from symbolic.workflow.bandwidth import LOWERED, lowered_settings
from symbolic.workflow.dataset import DataSet, treat
from symbolic.workflow.statistics import MIN_HELD_OUT_GAIN, pooled_autocorrelation_time
from symbolic.workflow.terms import ModelTerms, fit_nominal, inseparable, own_rows, relative_gap, wls

SIGMAS = 3.0
"""A value is a correction when it moves by more than this many standard deviations ..."""
RELATIVE = 0.10
"""... and by more than this fraction of the model file's value, and keeping the file's value (the others
re-identified) leaves at least :data:`~symbolic.workflow.statistics.MIN_HELD_OUT_GAIN` more held-out residual
power, 1 − (gap/gap at the file's value)², the search's effect size. Without that, the arm with nothing wrong
behind a 14-bit encoder "corrected" ZZR2 by 10.04 % at 14σ (the quantisation left in q̈ biases the inertias
beyond their σ, docs/workflow.md), while keeping the file's value cost 2.9 % of the held-out power; the rig's
stiffness costs 99 %, EMPS's offset 16 % ..."""
AGREEMENT = 0.25
"""... and it holds with the data treated at the lowered band (:data:`~symbolic.workflow.bandwidth.LOWERED`,
:meth:`Value.holds_with`), the two estimates agreeing within SIGMAS·√(σ² + σ_low²) or within this fraction of the change."""


@dataclass(frozen=True, eq=False)
class FinalFit:
    """The re-identification the corrections are read from: ``terms``' free base parameters are the first
    columns of ``columns`` (the patched model's own fit, or the search's final joint fit with the effects'
    columns after them); ``known`` is τ minus the fixed terms, per data set."""

    terms: ModelTerms = field(repr=False)
    columns: Mapping[str, np.ndarray] = field(repr=False)
    known: Mapping[str, np.ndarray] = field(repr=False)
    identification: Identification
    sets: Mapping[str, DataSet] = field(repr=False)

    @classmethod
    def of_nominal(cls, nominal: Any, sets: Mapping[str, DataSet]) -> FinalFit:
        """From a model's own fit (:class:`symbolic.workflow.terms.NominalFit`)."""
        terms = nominal.terms
        return cls(terms, {role: terms.columns(data)[:, :, terms.free] for role, data in sets.items()},
                   {role: terms.known(data) for role, data in sets.items()}, nominal.identification, sets)

    @classmethod
    def of_design(cls, terms: ModelTerms, design: Any, sets: Mapping[str, DataSet]) -> FinalFit:
        """From the search's final joint fit (:class:`symbolic.workflow.search.CurrentModel`) of ``terms``
        and the effects accepted."""
        return cls(terms, design.columns, design.known, design.identification, sets)

    @property
    def free(self) -> np.ndarray:
        return np.flatnonzero(self.terms.free)

    def autocorrelation_time(self) -> float:
        """τ_int of the weighted estimation residual (the σ of the values are multiplied by its root)."""
        residual = self.known["estimation"] - self.columns["estimation"] @ self.identification.values
        return pooled_autocorrelation_time(residual / np.asarray(self.identification.coordinate_sigmas))

    def held_out_gap(self, held: int | None = None, value: float = 0.0) -> float:
        """The held-out gap (%) of the fit, or of the fit with column ``held`` kept at ``value`` and the
        other columns re-identified on the estimation data."""
        estimation, validation = self.sets["estimation"], self.sets["validation"]
        columns = self.columns["estimation"]
        if held is None:
            values, keep = np.asarray(self.identification.values), np.arange(columns.shape[2])
            shift = 0.0
        else:
            keep = np.array([i for i in range(columns.shape[2]) if i != held])
            shift = value
            known = self.known["estimation"] - columns[:, :, held] * value
            values = wls(estimation, columns[:, :, keep], known, [f"c{i}" for i in keep]).values
        X = self.columns["validation"]
        predicted = validation.tau - self.known["validation"] + X[:, :, keep] @ values
        if held is not None:
            predicted = predicted + X[:, :, held] * shift
        return relative_gap(validation.tau, predicted)


@dataclass(frozen=True)
class Value:
    """A model-file parameter (or a base combination of several) as the final fit determines it."""

    parameter: str
    nominal: float
    value: float
    sigma: float
    column: int
    """Its base parameter's column in :attr:`FinalFit.columns`."""
    scale: float
    """β = scale·p + offset: the base parameter's value at the file's value is scale·nominal + offset."""
    expression: str | None = None
    """For a combination: the base parameter in the model's parameters."""
    lower: float = -math.inf
    upper: float = math.inf
    """What the model's other parameters allow (:func:`symbolic.identify.known.beta_bounds`)."""
    at_bound: bool = False
    """The bounded fit holds the value at ``lower`` or ``upper``: the data alone want it beyond."""

    @property
    def physical(self) -> bool:
        """Within [lower, upper] (a rounding of 1e-9 of the scale allowed) and not held at a bound."""
        slack = 1e-9 * max(abs(self.nominal), abs(self.value), 1e-300)
        return not self.at_bound and self.lower - slack <= self.value <= self.upper + slack

    @property
    def relative_change(self) -> float | None:
        return None if self.nominal == 0 else (self.value - self.nominal) / abs(self.nominal)

    @property
    def significant(self) -> bool:
        """Beyond :data:`SIGMAS` σ and beyond :data:`RELATIVE` of the file's value."""
        change = abs(self.value - self.nominal)
        return change > SIGMAS * self.sigma and change > RELATIVE * abs(self.nominal)

    def holds_with(self, low: Value) -> bool:
        """Whether ``low``, the same value estimated from the data treated at the lowered bandwidth
        (:data:`LOWERED`), confirms this one: significant as well, moved in the same direction from the
        file's value, and agreeing with it,

            |v − v_low| ≤ max(SIGMAS·√(σ² + σ_low²), AGREEMENT·|v − v_file|).

        Why: the quantisation (or any white measurement) error e of the logged q enters q̈ as ë, whose
        power grows as the fifth power of the band kept, and a feedback loop puts the same e into the
        logged force: an errors-in-variables bias of the inertias that the held-out data share. A value
        that is wrong in the file is wrong at every bandwidth that holds the motion; a bias of the
        differentiation shrinks steeply with the band (≈ 1/8 at half the band for a cubic growth)."""
        change, low_change = self.value - self.nominal, low.value - low.nominal
        agree = abs(self.value - low.value) <= max(SIGMAS * math.hypot(self.sigma, low.sigma), AGREEMENT * abs(change))
        return low.significant and np.sign(change) == np.sign(low_change) and agree


def identified_values(fit: FinalFit, names: Sequence[str]) -> list[Value]:
    """The values the final fit determines among the model-file parameters ``names`` (the original model's):
    each free base parameter that is one of them up to known factors, or a combination of them only."""
    terms, ident = fit.terms, fit.identification
    model, reg, base = terms.model, terms.reg, terms.base
    fixed = geometric_parameters(model, reg)
    wanted = set(names)
    theta = dict(zip(reg.theta, reg.theta_expressions))
    tau = fit.autocorrelation_time()
    covariance = np.asarray(ident.covariance) * tau
    geometry = {s: v for s, v in model.parameters.items() if s in fixed}
    bounds = parameter_bounds(model)
    combined = beta_bounds(model, reg, base, base.names, fixed | terms.fixed)
    known_values = {s: v for s, v in model.parameters.items() if s in fixed | terms.fixed}
    held = ident.at_bound
    out = []
    for column, k in enumerate(fit.free):
        expression = sp.expand(base.expressions[k].xreplace(theta))
        unknown = expression.free_symbols - fixed
        if not unknown or not {s.name for s in unknown} <= wanted:
            continue  # moved by an effect's parameter as well: not the file's value alone
        beta, sigma = float(ident.values[column]), float(math.sqrt(max(covariance[column, column], 0.0)))
        nominal_beta = float(terms.nominal[k])
        if len(unknown) == 1:
            (p,) = unknown
            a = sp.diff(expression, p)
            if not a.free_symbols & {p}:
                scale = float(a.xreplace(geometry))
                offset = float(expression.xreplace({p: sp.Integer(0)}).xreplace(geometry))
                if scale != 0:
                    lower, upper = bounds.get(p, (-math.inf, math.inf))
                    out.append(Value(p.name, (nominal_beta - offset) / scale, (beta - offset) / scale,
                                     sigma / abs(scale), column, scale, None, lower, upper,
                                     base.names[k] in held))
                    continue
        text = str(expression.xreplace({s: sp.Float(v, 6) for s, v in geometry.items()}))
        lower, upper = combined.get(base.names[k], (-math.inf, math.inf))
        if base.names[k] not in combined:  # products of unknowns: the parallel-axis sums
            lower = polynomial_lower_bound(expression.xreplace(known_values), bounds)
        out.append(Value(base.names[k], nominal_beta, beta, sigma, column, 1.0, text, lower, upper,
                         base.names[k] in held))
    return out


def corrections(fit: FinalFit, values: Sequence[Value], robot: Robot, min_gain: float = MIN_HELD_OUT_GAIN,
                lowered: Sequence[Value] | None = None) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The corrections (module docstring) with their evidence, largest first (in σ), and the values that
    move beyond :data:`SIGMAS` σ and :data:`RELATIVE` but are not named, each with ``"why"``:

    * ``"held-out"``: the file's value predicts the held-out data as well (keeping it costs less than
      ``min_gain`` of the held-out residual power);
    * ``"unphysical"``: the value is outside what the model's other values allow (:attr:`Value.physical`):
      the data move it because the model misses something on these coordinates, not because the file's
      value is wrong;
    * ``"bandwidth"``: re-estimated from the data treated at the lowered bandwidth (``lowered``, the same
      parameters in the same order; ``None``: not checked) it does not hold (:meth:`Value.holds_with`):
      an artefact of the differentiation.
    """
    held_out = fit.held_out_gap()
    low = {v.parameter: v for v in lowered} if lowered is not None else None
    named, moved = [], []
    for v in sorted((v for v in values if v.significant), key=lambda v: -abs(v.value - v.nominal) / max(v.sigma, 1e-300)):
        kept = fit.held_out_gap(v.column, v.scale * v.nominal + (fit.identification.values[v.column] - v.scale * v.value))
        gain = 1.0 - (held_out / kept) ** 2 if kept > 0 else 0.0
        kind = "combination" if v.expression else parameter_kind(robot, v.parameter)
        evidence = {"sigmas": abs(v.value - v.nominal) / v.sigma if v.sigma > 0 else None,
                    "held_out_gap": held_out, "held_out_gap_at_nominal": kept, "held_out_gain": gain,
                    "kind": kind, "bounds": [b if math.isfinite(b) else None for b in (v.lower, v.upper)], **({"expression": v.expression} if v.expression else {})}
        other = low.get(v.parameter) if low is not None else None
        if other is not None:
            moved_by = abs(other.value - other.nominal) / other.sigma if other.sigma > 0 else None
            evidence["lowered_bandwidth"] = {"value": other.value, "sigma": other.sigma, "sigmas": moved_by}
        entry = {"parameter": v.parameter, "nominal": v.nominal, "value": v.value, "sigma": v.sigma,
                 "relative_change": v.relative_change, "evidence": evidence, "summary": sentence(v, kind)}
        if gain < min_gain:
            moved.append({**entry, "why": "held-out"})
        elif not v.physical:
            moved.append({**entry, "why": "unphysical"})
        elif low is not None and (other is None or not v.holds_with(other)):
            moved.append({**entry, "why": "bandwidth"})
        else:
            named.append(entry)
    return named, moved


def lowered_values(fit: FinalFit, names: Sequence[str], notes: list[str]) -> list[Value] | None:
    """:func:`identified_values` of the model's own fit on the estimation data treated at the lowered
    bandwidth (:func:`lowered_settings`); ``None`` (with a note) when the final fit holds an effect's
    columns, which the search computed for its own treatment only, or when the data are too short."""
    if fit.columns["estimation"].shape[2] != len(fit.free):
        notes.append("corrections are not checked at a lowered bandwidth: the final fit holds the effects' columns")
        return None
    data = fit.sets["estimation"]
    try:
        low = treat(data.measurements, "estimation", lowered_settings(data.states.processing))
    except (DataError, ValueError) as error:  # too few samples for the longer border, a filter that cannot run
        notes.append(f"corrections are not checked at a lowered bandwidth ({error})")
        return None
    try:
        refit = fit_nominal(fit.terms, low)
    except RankDeficient as error:  # fewer, smoother samples: what the full band separates may not be separable there
        notes.append("corrections are not checked at a lowered bandwidth: "
                     + inseparable(fit.terms, low, error.parameters, f"the data treated at {LOWERED:g}× the bandwidth"))
        return None
    if list(refit.terms.free_names) != list(fit.terms.free_names):
        notes.append("corrections are not checked at a lowered bandwidth: another scale is held there")
        return None
    return identified_values(FinalFit.of_nominal(refit, {"estimation": low}), names)


def moved_note(m: Mapping[str, Any], min_gain: float = MIN_HELD_OUT_GAIN) -> str:
    """The note for a value that moves but is not named a correction (:func:`corrections`' ``"why"``)."""
    e = m["evidence"]
    head = f"{m['summary']} — beyond {SIGMAS:g}σ and {100 * RELATIVE:g} %, but "
    if m["why"] == "unphysical":
        lower, upper = e["bounds"]
        allowed = f"≥ {lower:.4g}" if upper is None else f"≤ {upper:.4g}" if lower is None else \
            f"within [{lower:.4g}, {upper:.4g}]"
        return (head + f"moved to an unphysical value (the model's other values allow {allowed}): the model "
                "probably misses something on these coordinates; not named a correction")
    if m["why"] == "bandwidth":
        low = e.get("lowered_bandwidth")
        seen = "not estimated there" if low is None else f"{low['value']:.4g} ± {low['sigma']:.2g}"
        return (head + f"it does not hold with the data treated at {LOWERED:g}× the bandwidth ({seen}): an "
                "artefact of the differentiation (measurement noise in q̈); not named a correction")
    return (head + f"the file's value predicts the held-out data nearly as well ({e['held_out_gap_at_nominal']:.4g} % "
            f"against {e['held_out_gap']:.4g} %, {100 * e['held_out_gain']:.2g} % of the residual power "
            f"< {100 * min_gain:g} %): not named a correction")


def sentence(v: Value, kind: str) -> str:
    """"stiffness Ks is 1.7× too high (model file 1, data 0.5878 ± 0.0006)"."""
    what = f"{kind} {v.parameter}" if kind not in ("parameter", "combination") else (
        f"the base parameter {v.parameter} = {v.expression}" if v.expression else v.parameter)
    numbers = f"(model file {v.nominal:.4g}, data {v.value:.4g} ± {v.sigma:.2g})"
    if v.nominal != 0 and v.value != 0 and np.sign(v.nominal) == np.sign(v.value):
        ratio = v.nominal / v.value
        words = f"{ratio:.3g}× too high" if ratio > 1 else f"{1 / ratio:.3g}× too low"
        if v.nominal < 0:
            words = f"{abs(ratio) if ratio > 1 else 1 / abs(ratio):.3g}× too large in magnitude" if ratio > 1 else \
                f"{1 / ratio:.3g}× too small in magnitude"
        return f"{what} is {words} {numbers}"
    return f"{what} is wrong {numbers}"


def parameter_kind(robot: Robot, name: str) -> str:
    """What a parameter is in the model, for the words of a correction: ``stiffness`` (a [[force]] term in a
    coordinate's position, a beam's bending stiffness), ``damping`` (in a velocity), ``mass``, ``inertia``,
    ``rotor inertia``, ``friction``, ``density``, or ``parameter``."""
    symbol = next((p.symbol for p in robot.parameters if p.name == name), None)
    if symbol is None:
        return "parameter"
    positions = {coordinate_symbol(c) for c in robot.generalized_coordinates}
    velocities = {velocity_symbol(c) for c in robot.generalized_coordinates}
    for force in robot.forces:
        expression = sp.sympify(force.expression)
        if symbol not in expression.free_symbols:
            continue
        derivative = sp.diff(expression, symbol)
        if derivative.free_symbols & positions:
            return "stiffness"
        if derivative.free_symbols & velocities:
            return "damping"
    for beam in robot.beams:
        if symbol in sp.sympify(beam.EI_v).free_symbols | sp.sympify(beam.EI_w).free_symbols:
            return "stiffness"
        if symbol in sp.sympify(beam.density).free_symbols:
            return "density"
        if beam.tip_mass is not None and symbol in sp.sympify(beam.tip_mass).free_symbols:
            return "mass"
    for body in robot.bodies:
        if symbol in sp.sympify(body.mass).free_symbols:
            return "mass"
        if any(symbol in sp.sympify(e).free_symbols for e in body.inertia_tensor):
            return "inertia"
    for drive in robot.drives:
        if symbol in sp.sympify(drive.rotor_inertia).free_symbols:
            return "rotor inertia"
    for friction in robot.frictions:
        entries = [friction.viscous, friction.coulomb, friction.offset]
        entries += [friction.stribeck.static] if friction.stribeck is not None else []
        for entry in entries:
            parts = (entry.positive, entry.negative) if isinstance(entry, Directional) else (entry,)
            if any(e is not None and symbol in sp.sympify(e).free_symbols for e in parts):
                return "friction"
    return "parameter"


def review(model: DynamicModel, patched: DynamicModel, patched_values: Mapping[str, float], fit: FinalFit,
           written: Mapping[str, float], removed: Sequence[str], kept: Sequence[Mapping[str, Any]], data: DataSet,
           notes: list[str], min_gain: float = MIN_HELD_OUT_GAIN,
           elastic_rows: Sequence[int] = ()) -> tuple[list[dict[str, Any]], list[dict[str, Any]], dict[str, Any] | None]:
    """Corrections, changes and modes (module docstring) of a diagnosis: ``model`` the file's, ``patched``
    the patched one at ``patched_values``; ``written``, ``removed`` and ``kept`` what the patch did to the
    file's own parameters; ``data`` the estimation data (their mean position, their ``[controller]``).
    ``elastic_rows``: coordinates (indices) whose rows two encoders showed elastic: a value acting on them is
    not named a correction (the rigid fit there is not the machine's; the motor side's values are written)."""
    nominal = {p.name: p.value for p in model.robot.parameters}
    values = identified_values(fit, list(nominal))
    candidates = [v for v in values if v.significant and v.physical]
    lowered = lowered_values(fit, list(nominal), notes) if candidates else None
    found, moved = corrections(fit, values, model.robot, min_gain, lowered)
    if elastic_rows:
        columns, column_of = np.asarray(fit.columns["estimation"]), {v.parameter: v.column for v in values}
        rows = list(elastic_rows)

        def on_elastic_row(name: str) -> bool:
            k = column_of.get(name)
            return k is not None and bool(np.any(columns[:, rows, k] != 0))

        notes += [f"{c['parameter']} is not named a correction: it acts on the row of an elastic joint, where the rigid "
                  "fit absorbs the transmission" for c in found if on_elastic_row(c["parameter"])]
        found = [c for c in found if not on_elastic_row(c["parameter"])]
        moved = [m for m in moved if not on_elastic_row(m["parameter"])]
    notes += [moved_note(m, min_gain) for m in moved]
    notes += common_factor_notes(model, found)
    sigma = {v.parameter: v.sigma for v in values if v.expression is None}
    flagged = {c["parameter"] for c in found}
    why = {k["parameter"]: k["reason"] for k in kept}
    for c in found:
        if c["parameter"] in why:
            c["evidence"]["written"] = False
            c["summary"] += f"; not written: {why[c['parameter']]}"
    changes = []
    for name, value in written.items():
        if value != nominal[name]:
            change = None if nominal[name] == 0 else (value - nominal[name]) / abs(nominal[name])
            changes.append({"parameter": name, "nominal": nominal[name], "value": float(value), "sigma": sigma.get(name),
                            "relative_change": change, "status": "re-identified", "correction": name in flagged})
    changes += [{"parameter": name, "nominal": nominal[name], "value": None, "sigma": None, "relative_change": None,
                 "status": "removed", "correction": False} for name in removed if name in nominal]
    changes += [{"parameter": k["parameter"], "nominal": nominal[k["parameter"]], "value": nominal[k["parameter"]],
                 "sigma": sigma.get(k["parameter"]), "relative_change": 0.0, "status": "kept", "fitted": k["value"],
                 "reason": k["reason"], "correction": k["parameter"] in flagged} for k in kept]
    measurements = data.measurements
    found_modes = modes(model, patched, patched_values, data, measurements.controller,
                        float(measurements.sample_period), notes)
    if found_modes is not None:
        found_modes["summary"] = modes_sentence(found_modes)
        dynamic = [c for c in found if c["evidence"]["kind"] in ("stiffness", "mass", "inertia", "rotor inertia",
                                                                   "density", "damping", "combination")]
        if dynamic and found_modes["summary"] != "unchanged within 1 %":
            dynamic[0]["summary"] += f": {found_modes['summary']}"
            dynamic[0]["evidence"]["modes"] = found_modes["summary"]
    return found, changes, found_modes


COMMON_FACTOR = 0.05
"""Corrections of one coordinate's own values whose ratios to the file's differ by less than this (relative) share
one factor: the signature of a drive gain (:func:`common_factor_notes`)."""


def common_factor_notes(model: DynamicModel, found: Sequence[Mapping[str, Any]]) -> list[str]:
    """A note per coordinate where two or more corrections of values acting on its force alone (friction, rotor
    or first-link inertia: :func:`symbolic.workflow.terms.own_rows`) move them by one factor: a drive applying
    g × its logged command makes IDIM-LS fit each such value as θ/g, so one gain explains them all at once. On an
    axis whose every value is its own the data cannot tell the two apart (the search judged on the response then
    leaves the gain's σ unbounded); where a link couples the joints, that search names the gain. Measured: the
    axis of tests/reference_integrator.py whose drive applies 0.85 × its command: J, Fv and Fc each 1.18× the
    file's (1.177, 1.179, 1.171)."""
    ratios = {c["parameter"]: c["value"] / c["nominal"] for c in found if c.get("nominal") and c.get("value")}
    if len(ratios) < 2:
        return []
    by_coordinate: dict[str, list[str]] = {}
    for name, coordinate in own_rows(model, list(ratios)).items():
        by_coordinate.setdefault(coordinate, []).append(name)
    notes = []
    for coordinate, names in by_coordinate.items():
        values = [ratios[n] for n in names]
        if len(names) < 2 or min(values) <= 0 or max(values) / min(values) - 1 > COMMON_FACTOR:
            continue
        factor = float(np.median(values))
        notes.append(f"{', '.join(names)} — every corrected value acting on {coordinate}'s force alone — move by one "
                     f"factor, {factor:.3g}× the file's ({', '.join(f'{r:.4g}' for r in values)}): a drive applying "
                     f"{1 / factor:.3g} × its logged command on {coordinate} (`[drive] tau_{coordinate} = {{ gain = "
                     f"{1 / factor:.4g} }}` in the experiment) would explain them all at once; where these are the "
                     "coordinate's only values the data cannot tell the two apart")
    return notes


# -- a patched model file always loads -------------------------------------------------------------------

def physical_values(text: str, values: Mapping[str, float], source: str, provenance: str,
                    nominal: Robot) -> tuple[str, dict[str, float], list[dict[str, Any]]]:
    """``text`` with ``values`` written (:func:`symbolic.description.modelfile.with_parameter_values`), except
    those that would not be physical: the result must load (masses ≥ 0, inertia tensors positive
    semidefinite, friction ≥ 0, ...) and keep the sign of every spring and damper of the file (a
    ``[[force]]``'s −∂f/∂q and −∂f/∂q̇ at rest, :func:`elastic_signs`). All at once when that works; else
    one value at a time in order, each kept at the file's value when adding it fails. Returns the text,
    the values written and the values kept, each with the reason."""
    reference = elastic_signs(nominal, nominal.parameter_values)

    def attempt(chosen: Mapping[str, float]) -> tuple[str | None, str | None]:
        candidate = with_parameter_values(text, chosen, source, provenance=provenance)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                robot = loads(candidate, source)
        except ModelError as error:
            return None, str(error)
        signs = elastic_signs(robot, robot.parameter_values)
        flipped = [key for key, sign in reference.items() if sign > 0 and signs.get(key, 1.0) <= 0]
        if flipped:
            return None, "it would make " + ", ".join(flipped) + " negative"
        return candidate, None

    written, why = attempt(values)
    if written is not None:
        return written, dict(values), []
    chosen: dict[str, float] = {}
    kept: list[dict[str, Any]] = []
    for name, value in values.items():
        trial, why = attempt({**chosen, name: value})
        if trial is None:
            kept.append({"parameter": name, "value": float(value), "reason": why})
        else:
            chosen[name] = value
    written, _ = attempt(chosen)
    return written, chosen, kept


def elastic_signs(robot: Robot, values: Mapping[sp.Symbol, float]) -> dict[str, float]:
    """{"stiffness of [[force]] NAME on q": k, "damping of ...": c}: k = −∂f/∂q and c = −∂f/∂q̇ of each
    force f on its own coordinate, at rest (all positions and velocities 0) and ``values``."""
    rest = {coordinate_symbol(c): 0 for c in robot.generalized_coordinates}
    rest |= {velocity_symbol(c): 0 for c in robot.generalized_coordinates}
    out = {}
    for force in robot.forces:
        expression = sp.sympify(force.expression)
        for kind, symbol in (("stiffness", coordinate_symbol(force.coordinate)), ("damping", velocity_symbol(force.coordinate))):
            if symbol not in expression.free_symbols:
                continue
            value = -sp.diff(expression, symbol).xreplace(rest).xreplace(dict(values))
            if value.is_number:
                out[f"the {kind} of [[force]] {force.name!r} on {force.coordinate}"] = float(value)
    return out


# -- modes --------------------------------------------------------------------------------------------

def elastic(robot: Robot) -> bool:
    """Whether the model has elastic coordinates: a beam, or a [[force]] that depends on a position."""
    positions = {coordinate_symbol(c) for c in robot.generalized_coordinates}
    return bool(robot.beams) or any(sp.sympify(f.expression).free_symbols & positions for f in robot.forces)


def modes(before: DynamicModel, after: DynamicModel, after_values: Mapping[str, float], data: DataSet,
          controller: Mapping[str, Any] | None, period: float, notes: list[str]) -> dict[str, Any] | None:
    """The linearised modes with the file's values (``before``) and the patched model's (``after`` at
    ``after_values``), at rest at the data's mean position (module docstring); ``None`` for a model
    without elastic coordinates. A controller the closed-loop linearisation cannot take is noted."""
    mean = {c: float(np.mean(data.states.q[:, k])) for k, c in enumerate(data.coordinates)}
    return modes_at(before, after, after_values, mean, controller, period, notes)


def modes_at(before: DynamicModel, after: DynamicModel, after_values: Mapping[str, float],
             mean: Mapping[str, float], controller: Mapping[str, Any] | None, period: float,
             notes: list[str]) -> dict[str, Any] | None:
    """:func:`modes` at rest at ``mean`` (a coordinate it lacks at 0: one the data do not measure)."""
    from symbolic.workflow.modes import closed_loop_modes, plant_modes

    if not (elastic(before.robot) or elastic(after.robot)):
        return None

    def rest(model: DynamicModel) -> np.ndarray:
        return np.array([mean.get(c, 0.0) for c in model.robot.generalized_coordinates])

    nominal = {s.name: float(v) for s, v in before.parameters.items()}
    out: dict[str, Any] = {"before": None, "after": None, "position": dict(mean), "closed_loop": None}
    for role, model, values in (("before", before, nominal), ("after", after, after_values)):
        try:
            out[role] = [_mode(m) for m in plant_modes(model, values, rest(model))]
        except np.linalg.LinAlgError:  # unphysical values (a fit on data that do not determine them)
            which = "the model file's" if role == "before" else "the patched"
            notes.append(f"modes not computed: D(Q) is not positive definite at the data's mean position with "
                         f"{which} values")
            return None
    if controller is not None:
        try:
            out["closed_loop"] = {
                "before": [_mode(m) for m in closed_loop_modes(before, nominal, controller, period, rest(before))],
                "after": [_mode(m) for m in closed_loop_modes(after, after_values, controller, period, rest(after))]}
        except (ModelError, ValueError, KeyError) as error:  # np.linalg.LinAlgError is a ValueError
            notes.append(f"closed-loop modes not computed: the [controller] cannot be linearised ({error})")
    return out


def _mode(mode: tuple[float, float]) -> dict[str, float]:
    return {"frequency_hz": mode[0], "damping_ratio": mode[1]}


def modes_sentence(found: Mapping[str, Any]) -> str:
    """"2.92 Hz (ζ 0.021) → 2.24 Hz (ζ 0.019)" for the modes that moved, paired in order of frequency."""
    before, after = found["before"], found["after"]
    if not before and not after:
        return "no oscillatory mode"
    if len(before) != len(after):
        text = lambda ms: ", ".join(f"{m['frequency_hz']:.3g} Hz (ζ {m['damping_ratio']:.2g})" for m in ms) or "none"  # noqa: E731
        return f"{text(before)} → {text(after)}"
    pairs = [f"{b['frequency_hz']:.3g} Hz → {a['frequency_hz']:.3g} Hz" for b, a in zip(before, after)
             if abs(a["frequency_hz"] - b["frequency_hz"]) > 0.01 * max(b["frequency_hz"], 1e-12)]
    return ", ".join(pairs) if pairs else "unchanged within 1 %"


def check_loads(text: str, target: Path, source: Path) -> None:
    """Refuse to go on with a patched model file that :func:`symbolic.load` would refuse: it is never written."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            loads(text, str(target))
    except ModelError as error:
        raise ModelError(str(source), "patch", f"the patched model with its re-identified values does not load "
                                               f"({error}); nothing is written; this is a bug of the workflow") from None
