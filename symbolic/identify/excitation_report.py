"""``symbolic excite``: the experiment's declarations read, the design made, its σ predicted (and an existing
log's beside it), and the output folder written: trajectory.csv, trajectory.experiment.toml, excitation.json,
report.md and the figures (docs/data.md, "Excitation design").
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from symbolic.data import Measurements
from symbolic.data import files as data_files
from symbolic.data.errors import DataError
from symbolic.data.excitation import ExcitationTable, checked_value, parse
from symbolic.data.experiment import TOP_KEYS, sample_rate
from symbolic.data.keys import check_keys
from symbolic.data.settings import Settings
from symbolic.derivation.dynamics import DynamicModel
from symbolic.identify.least_squares import percent
from symbolic.identify.excitation import (FINER, HARMONICS, STARTS, Design, FourierTrajectory, check_options,
                                          design, reference_samples, resolve_limits)
from symbolic.identify.excitation_criteria import DESCRIPTIONS
from symbolic.identify.excitation_loop import LoopCheck, check_in_loop, refusal
from symbolic.identify.excitation_noise import Noise, Prediction, equivalent_noise, predict, resolve_noise, treatment

LOG = logging.getLogger(__name__)

TRAJECTORY = "trajectory.csv"
EXPERIMENT = "trajectory.experiment.toml"
REPORT = "report.md"
JSON = "excitation.json"
FIGURE_REFERENCES = "excitation_references.png"
FIGURE_SIGMA = "excitation_sigma.png"


@dataclass(frozen=True)
class Declared:
    """What an experiment file declares for a design: its ``[excitation]`` table and ``[identification]`` settings."""

    source: str
    table: ExcitationTable
    settings: Settings
    controller: Mapping[str, Any] | None = None


def read_declarations(path: str | Path | None, coordinates: Sequence[str]) -> Declared:
    """The experiment file's ``[excitation]`` and ``[identification]`` (its data file is not needed: the log does
    not exist yet). ``None``: nothing declared."""
    if path is None:
        return Declared("<none>", ExcitationTable(), Settings())
    source = str(path)
    spec = data_files.read_toml(Path(path), "experiment")
    check_keys(spec, TOP_KEYS, source)
    table = parse(spec.get("excitation", {}), coordinates, source)
    identification = spec.get("identification")
    settings = Settings.from_table(identification, source) if identification is not None else Settings()
    if table.rate is None:  # the experiment's own rate, checked as the experiment loader checks it
        rate = sample_rate(spec, {}, source)
        table = table if rate is None else ExcitationTable(table.values, rate)
    return Declared(source, table, settings, spec.get("controller"))


@dataclass(frozen=True, eq=False)
class Excitation:
    """A design with its predicted σ, and those of the compared log (``compare``, or ``None``)."""

    model: DynamicModel = field(repr=False)
    design: Design
    noise: Noise
    predicted: Prediction
    compare: Prediction | None
    settings: Settings
    controller: Mapping[str, Any] | None = None
    """The experiment's ``[controller]`` table as declared, carried into trajectory.experiment.toml."""
    loop: LoopCheck | None = None
    """The design run through that controller (:mod:`symbolic.identify.excitation_loop`); ``None`` without one."""
    separate: tuple[tuple[str, int], ...] = ()
    """``--separate A,B``: each name as given and the index of its base parameter (empty: no pair)."""

    def samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """t, q, q̇, q̈ of the reference at the declared rate over one period, both ends included."""
        return reference_samples(self.design.trajectory, self.noise.rate)

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model.name, "design": self.design.to_dict(), "noise": self.noise.to_dict(),
                "predicted": self.predicted.to_dict(),
                "compare": None if self.compare is None else self.compare.to_dict(),
                "loop": None if self.loop is None else self.loop.to_dict(),
                "separate": self.separation(),
                "collision_avoidance": "not checked: the design keeps each coordinate within its limits only"}

    def separation(self) -> dict[str, Any] | None:
        """The pair of ``--separate``: for the design (and the compared log) the σ % of each and their correlation
        (``None`` where not estimable); ``None`` without a pair."""
        if not self.separate:
            return None
        (a, i), (b, j) = self.separate
        names = self.predicted.names

        def side(p: Prediction | None) -> dict[str, Any] | None:
            if p is None:
                return None
            ra, rb, rho = p.pair(i, j)
            return {"sigma": [_number(p.sigmas[i]), _number(p.sigmas[j])], "relative_sigma": [_number(ra), _number(rb)],
                    "correlation": _number(rho)}

        return {"parameters": [a, b], "base_parameters": [names[i], names[j]], "design": side(self.predicted),
                "compare": side(self.compare)}


def _number(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def separation_indices(model: DynamicModel, names: Sequence[str]) -> tuple[tuple[str, int], ...]:
    """The base parameters of ``--separate A,B``: each name a base parameter's (``ZZR1``) or a model parameter's
    that is alone in one (``Fc``: the base parameter holds no other estimated parameter).

    Raises
    ------
    DataError
        One line: not two names, the same base parameter twice, a name the model does not have (with what is
        allowed and the nearest), or a model parameter that enters only combinations or is not estimated.
    """
    from symbolic.errors import suggestion
    from symbolic.identify.known import model_parameters_of
    from symbolic.identify.model import geometric_parameters, model_base

    if len(names) != 2 or not all(isinstance(n, str) and n.strip() for n in names):
        raise DataError("--separate", ",".join(map(str, names)), "expected two parameter names A,B")
    reg, base = model_base(model)
    known = geometric_parameters(model, reg)
    alone: dict[str, int] = {}
    within: dict[str, list[str]] = {}
    for k, name in enumerate(base.names):
        every, _ = model_parameters_of(model, reg, base, [name], known)
        if len(every) == 1:
            alone.setdefault(every[0], k)
        for parameter in every:
            within.setdefault(parameter, []).append(name)
    allowed = f"base parameters of {model.name}: {', '.join(base.names)}; model parameters alone in one: " \
              f"{', '.join(alone) or 'none'}"
    out = []
    for name in (n.strip() for n in names):
        if name in base.names:
            out.append((name, base.names.index(name)))
        elif name in alone:
            out.append((name, alone[name]))
        elif name in within:
            raise DataError("--separate", name, f"model parameter of {model.name} that enters only combinations "
                                                f"({', '.join(within[name])}): name base parameters (allowed: {allowed})")
        else:
            declared = {str(s) for s in model.parameter_symbols}
            what = "a parameter the regressor depends on (not estimated)" if name in declared else "unknown parameter"
            raise DataError("--separate", name, f"{what} (allowed: {allowed})"
                                                f"{suggestion(name, [*base.names, *alone])}")
    if out[0][1] == out[1][1]:
        raise DataError("--separate", f"{out[0][0]},{out[1][0]}",
                        f"the same base parameter {base.names[out[0][1]]} twice: name two different ones")
    return tuple(out)


def excite(model: DynamicModel, declared: Declared, duration: float, *, limits: Mapping[str, Mapping[str, Any]] | None = None,
           noise: Mapping[str, Mapping[str, Any]] | None = None, rate: float | None = None, harmonics: int = HARMONICS,
           criterion: str = "d", starts: int = STARTS, seed: int = 0, compare: str | Path | Measurements | None = None,
           grid_points: int | None = None, check_loop: bool = True, separate: Sequence[str] = ()) -> Excitation:
    """Design, check in the loop, predict, compare (module docstring). ``limits`` and ``noise``: ``{kind:
    {coordinate: value}}`` from the command line, replacing the experiment's; ``rate`` likewise. With a
    ``[controller]`` declared (and ``check_loop``), a design that saturates in that loop is refused
    (:func:`symbolic.identify.excitation_loop.refusal`: an :class:`IdentificationError`, nothing returned).
    ``separate``: two parameter names (:func:`separation_indices`) whose separation is designed for
    (Ds-optimality, :func:`symbolic.identify.excitation_criteria.ds_optimal`) instead of ``criterion``."""
    check_options(duration, harmonics, criterion, starts)
    pair = separation_indices(model, separate) if separate else ()
    if compare is not None:  # a log that cannot be read is refused before the design, not after it
        from symbolic.data import load

        compare = load(compare, model=model.robot)
    where = ("experiment", declared.table.values)
    given = ("command line", {**(limits or {}), **(noise or {})})
    bounds = resolve_limits(model, where, given)
    declared_noise = resolve_noise(model, rate or declared.table.rate, where, given)
    count = int(round(duration * declared_noise.rate)) + 1
    processing = treatment(declared_noise.rate, count, declared.settings)
    mid = 0.5 * np.where(np.isfinite(bounds.lower + bounds.upper), bounds.lower + bounds.upper, 0.0)
    sigma = equivalent_noise(model, declared_noise, processing, [mid])
    made = design(model, bounds, duration, weights=1.0 / sigma**2, harmonics=harmonics, criterion=criterion,
                  starts=starts, seed=seed, grid_points=grid_points, separate=[k for _, k in pair])
    loop = None
    if declared.controller and check_loop:
        LOG.info("excitation: the design in the loop of [controller] (%s)", declared.controller.get("kind", "?"))
        loop = check_in_loop(model, made.trajectory, declared_noise.rate, bounds, declared.controller)
        if loop.refused:
            raise refusal(loop)
    predicted = _predict_reference(model, made.trajectory, declared_noise, declared.settings, "design")
    compared = None if compare is None else predict_log(model, compare, declared_noise, declared.settings)
    return Excitation(model, made, declared_noise, predicted, compared, declared.settings, declared.controller, loop,
                      pair)


def _predict_reference(model: DynamicModel, trajectory: FourierTrajectory, noise: Noise, settings: Settings,
                       label: str) -> Prediction:
    t, q, qd, qdd = reference_samples(trajectory, noise.rate)
    p = treatment(noise.rate, len(t), settings)
    sigma = equivalent_noise(model, noise, p, q[:: max(1, len(t) // 50)])
    return predict(model, label, q, qd, qdd, sigma, trajectory.period, p)


def predict_log(model: DynamicModel, path: str | Path | Measurements, noise: Noise,
                settings: Settings | None = None) -> Prediction:
    """The predicted σ for an existing log (a data or experiment file identify reads, or its measurements): its
    states as identify treats them (filtered positions, central differences, borders dropped), the declared noise
    at its rate."""
    from symbolic.data import load
    from symbolic.data.treatment import states

    measured = path if isinstance(path, Measurements) else load(path, model=model.robot)
    path = measured.source
    treated = states(measured, settings)
    p = treated.processing
    at_rate = noise.at_rate(measured.rate)
    sigma = equivalent_noise(model, at_rate, p, treated.q[:: max(1, measured.samples // 50)])
    return predict(model, f"log {Path(str(path)).name}", treated.q, treated.qd, treated.qdd, sigma,
                   float(measured.t[-1] - measured.t[0]), p)


# -- the files -----------------------------------------------------------------------------------------------


def output_files(result: Excitation, figures: bool = True, html: bool = False) -> tuple[dict[str, bytes], list[str]]:
    """{name: bytes} of the output folder, and notes (a figure skipped without matplotlib); ``html``: report.html
    too (:mod:`symbolic.identify.excitation_html`, from the dictionary ``--json`` prints)."""
    out = {TRAJECTORY: trajectory_csv(result).encode(), EXPERIMENT: experiment_text(result).encode(),
           JSON: (json.dumps(_finite(result.to_dict()), indent=2, allow_nan=False) + "\n").encode()}
    notes: list[str] = []
    drawn: list[str] = []
    if figures:
        from symbolic.errors import MatplotlibMissing

        try:
            out[FIGURE_REFERENCES], out[FIGURE_SIGMA] = draw(result)
            drawn = [FIGURE_REFERENCES, FIGURE_SIGMA]
        except MatplotlibMissing as missing:
            notes.append(str(missing))
    out[REPORT] = report(result, drawn, notes).encode()
    if html:
        from symbolic.identify import excitation_html

        out[excitation_html.NAME] = excitation_html.render(result, {**result.to_dict(), "notes": notes}).encode()
    return out, notes


def _finite(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def trajectory_csv(result: Excitation) -> str:
    """t, ref_<c>, qd_<c>, qdd_<c> of the reference at the declared rate (17 significant digits)."""
    t, q, qd, qdd = result.samples()
    names = result.design.trajectory.coordinates
    header = ["t", *(f"ref_{c}" for c in names), *(f"qd_{c}" for c in names), *(f"qdd_{c}" for c in names)]
    rows = np.column_stack([t, q, qd, qdd])
    lines = [f"# excitation reference of {result.model.name}: period {result.design.trajectory.period:g} s, "
             f"{result.design.trajectory.harmonics} harmonics, criterion {result.design.criterion} (symbolic excite)",
             ",".join(header)]
    lines += [",".join(f"{v:.17g}" for v in row) for row in rows]
    return "\n".join(lines) + "\n"


def experiment_text(result: Excitation) -> str:
    """An experiment file mapping trajectory.csv: the reference as ``ref_<c>`` (and the reference as the initial
    positions ``q_<c>``, zero forces), with the design's ``[excitation]``, ``[identification]`` and ``[controller]``
    when the input declared them, so that ``symbolic simulate`` runs it through the controller."""
    names = result.design.trajectory.coordinates
    signals = ["t = \"t\""] + [f"q_{c} = \"ref_{c}\"" for c in names] + [f"tau_{c} = \"0\"" for c in names] + \
              [f"ref_{c} = \"ref_{c}\"" for c in names] + [f"refd_{c} = \"qd_{c}\"" for c in names]
    lines = [f"# The excitation reference of {result.model.name} (symbolic excite): t, ref_<c> and the reference's",
             "# qd_<c>, qdd_<c> in trajectory.csv. A trajectory player reads ref_<c> (and qd_<c>, qdd_<c>); `symbolic",
             "# simulate MODEL trajectory.experiment.toml` runs it through a [controller] (the input's, below, when it",
             "# declared one; positions and forces here are placeholders: the reference as position, zero force).",
             "# After the robot has run it,",
             "# map the recorded log instead and run `symbolic identify`.",
             f"data = {json.dumps(TRAJECTORY)}", *_model_line(result.model), "", "[signals]", *signals, ""]
    given = result.settings.given()
    if given:
        lines += ["[identification]", *(f"{k} = {_toml(v)}" for k, v in given.items()), ""]
    if result.controller:
        lines += ["[controller]", *(f"{k} = {_toml(v)}" for k, v in result.controller.items()), ""]
    return "\n".join(lines)


def _model_line(model: DynamicModel) -> list[str]:
    """``model = "NAME"`` for a built-in robot (a model file's path is the user's to give: MODEL on the command line)."""
    from symbolic import robots

    builtin = model.name in robots.names() and Path(str(model.robot.source)).resolve() == robots.path(model.name).resolve()
    return [f"model = {json.dumps(model.name)}"] if builtin else []


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{json.dumps(str(k))} = {_toml(v)}" for k, v in value.items()) + " }"
    return json.dumps(str(value))


def report(result: Excitation, figures: Sequence[str], notes: Sequence[str]) -> str:
    """report.md: the design, its limits and how close it comes to them, and the predicted σ side by side."""
    d, traj = result.design, result.design.trajectory
    lines = [f"# Excitation design: {result.model.name}", "",
             f"Period T = {traj.period:g} s, {traj.harmonics} harmonics per coordinate (Swevers et al. 1997 Fourier "
             f"series, at rest at t = 0 and T), criterion `{d.criterion}` "
             f"({DESCRIPTIONS[d.criterion]}): "
             f"{d.value:.6g} after the solve, {d.start_value:.6g} at the best start; {len(d.starts)} start(s), "
             f"{d.grid_points} grid points, verified on {FINER * d.grid_points}; {d.seconds:.1f} s.",
             "", "Collision avoidance is not checked: each coordinate stays within its own limits only.", "",
             "## Limits and the design's peak (ratio to the limit on the verification grid)", "",
             "| coordinate | position | velocity | acceleration | torque |", "|---|---|---|---|---|"]
    for i, c in enumerate(traj.coordinates):
        cells = []
        for kind, bound in (("position", f"[{d.limits.lower[i]:g}, {d.limits.upper[i]:g}]"),
                            ("velocity", f"{d.limits.velocity[i]:g}"), ("acceleration", f"{d.limits.acceleration[i]:g}"),
                            ("torque", f"{d.limits.torque[i]:g}")):
            cells.append(f"{bound} ({d.worst[kind][i]:.3f}; {d.limits.origin.get(f'{kind} {c}', '?')})")
        lines.append(f"| {c} | " + " | ".join(cells) + " |")
    lines += ["", "## Checked in the loop", ""]
    lines += result.loop.table() if result.loop is not None else [
        "Not checked: the experiment declares no [controller] (run trajectory.experiment.toml through `symbolic "
        "simulate` with one before the robot moves)."]
    lines += ["", "## Predicted uncertainty", "",
              f"From the declared noise at {result.noise.rate:g} Hz (force σ, encoder resolution; equivalent force noise "
              f"per coordinate {', '.join(f'{s:.4g}' for s in result.predicted.noise)}), the treatment's filters as an "
              "effective noise bandwidth (docs/data.md, \"Predicted σ\"). σ % = 100·σ/|β| at the nominal β.", ""]
    lines += _sigma_table(result.predicted, result.compare)
    lines += _separation_lines(result)
    lines += ["", *(f"![{name}]({name})" for name in figures), *notes]
    return "\n".join(lines) + "\n"


def _sigma_table(design: Prediction, compare: Prediction | None) -> list[str]:
    head = "| base parameter | nominal | σ design | σ % design |" + (" σ % " + compare.label + " |" if compare else "")
    rule = "|---|---|---|---|" + ("---|" if compare else "")
    rows = [head, rule]
    for k, name in enumerate(design.names):
        row = f"| {name} | {design.values[k]:.6g} | {design.sigmas[k]:.4g} | {percent(design.relative[k])} |"
        if compare is not None:
            row += f" {'∞ (not separable)' if math.isinf(compare.sigmas[k]) else percent(compare.relative[k])} |"
        rows.append(row)
    rows.append("")
    for p in (design, compare):
        if p is not None:
            rows.append(f"* {p.label}: {p.samples} samples kept, {p.duration:g} s; log det M = {p.log_det:.6g}, "
                        f"cond(Σ^(−1/2)W) = {p.condition_number:.6g}")
    if compare is not None and math.isfinite(design.log_det) and math.isfinite(compare.log_det):
        b = len(design.names)
        rows.append(f"* design against {compare.label}: det M × e^{design.log_det - compare.log_det:.4g} "
                    f"(geometric mean σ × {math.exp(-(design.log_det - compare.log_det) / (2 * b)):.4g}), condition "
                    f"number × {design.condition_number / compare.condition_number:.4g}")
    return rows


def _separation_lines(result: Excitation) -> list[str]:
    """The pair of ``--separate``: σ % of each and their correlation, for the design and the compared log."""
    pair = result.separation()
    if pair is None:
        return []
    a, b = pair["parameters"]
    lines = ["", f"## Separating {a} and {b}", "",
             f"Designed for the pair (base parameters {', '.join(pair['base_parameters'])}): Ds-optimality, the "
             "information about the two once the others are estimated. |ρ| near 1: the data cannot tell them apart.", "",
             f"| | σ % {a} | σ % {b} | correlation ρ |", "|---|---|---|---|"]
    for label, side in (("design", pair["design"]), (None if result.compare is None else result.compare.label,
                                                       pair["compare"])):
        if side is None:
            continue
        cells = ["∞ (not separable)" if sigma is None else percent(math.inf if v is None else v)
                 for sigma, v in zip(side["sigma"], side["relative_sigma"])]
        rho = "±1 (not separable)" if side["correlation"] is None else f"{side['correlation']:.4f}"
        lines.append(f"| {label} | {cells[0]} | {cells[1]} | {rho} |")
    return lines


def draw(result: Excitation) -> tuple[bytes, bytes]:
    """PNG bytes of the references (q, q̇, q̈ per coordinate) and of the predicted σ % per base parameter."""
    from symbolic.plotting import figure_class, png_bytes

    Figure = figure_class()  # noqa: N806
    t, q, qd, qdd = result.samples()
    names = result.design.trajectory.coordinates
    fig = Figure(figsize=(9, 7))
    axes = fig.subplots(3, 1, sharex=True)
    for ax, values, label in zip(axes, (q, qd, qdd), ("q", "q̇", "q̈")):
        for i, c in enumerate(names):
            ax.plot(t, values[:, i], label=c, linewidth=1)
        ax.set_ylabel(label)
    axes[0].legend(ncol=min(len(names), 7), fontsize="small")
    axes[-1].set_xlabel("t (s)")
    fig.suptitle(f"{result.model.name}: excitation reference")
    references = png_bytes(fig, dpi=90)
    fig = Figure(figsize=(max(6, 0.25 * len(result.predicted.names)), 4))
    ax = fig.subplots()
    x = np.arange(len(result.predicted.names))
    width = 0.4 if result.compare is not None else 0.8
    ax.bar(x, np.minimum(result.predicted.relative, 1e6), width, label="design")
    if result.compare is not None:
        ax.bar(x + width, np.minimum(result.compare.relative, 1e6), width, label=result.compare.label)
    ax.set_yscale("log")
    ax.set_xticks(x + (width / 2 if result.compare is not None else 0))
    ax.set_xticklabels(result.predicted.names, rotation=90, fontsize="x-small")
    ax.set_ylabel("predicted σ %")
    ax.legend()
    fig.tight_layout()
    return references, png_bytes(fig, dpi=90)


def write(result: Excitation, out: str | Path, figures: bool = True, html: bool = False) -> tuple[list[Path], list[str]]:
    """Write the output folder as one set (docs/contracts.md, "Output folders"): paths and notes."""
    from symbolic.export import write_files

    contents, notes = output_files(result, figures, html)
    return write_files(contents, out), notes


def refuse_unknown(coordinate: str, names: Sequence[str], where: str) -> DataError:
    """A coordinate the model does not have, named on the command line."""
    from symbolic.errors import suggestion

    return DataError(where, "coordinate", f"unknown coordinate {coordinate!r} (the model's: {', '.join(names)})"
                                          f"{suggestion(coordinate, names)}")


def option_values(kind: str, text: str | None, coordinates: Sequence[str]) -> dict[str, Any]:
    """A command-line limit or noise option: ``VALUE`` (every coordinate) or ``C=VALUE,C=VALUE``; a position is
    ``LOWER:UPPER``. ``{}`` for ``None``.

    Raises
    ------
    DataError
        ``--KIND``: an unknown coordinate or a value that is not a number, one line.
    """
    if text is None:
        return {}
    option = f"--{kind.replace('_', '-')}"
    entries = [e.strip() for e in text.split(",") if e.strip()]
    if len(entries) == 1 and "=" not in entries[0]:
        return {c: _option_value(kind, entries[0], option) for c in coordinates}
    out = {}
    for entry in entries:
        name, sep, value = entry.partition("=")
        if not sep:
            raise DataError(option, name, f"expected C=VALUE (or one VALUE for every coordinate), got {entry!r}")
        if name.strip() not in coordinates:
            raise refuse_unknown(name.strip(), coordinates, option)
        out[name.strip()] = _option_value(kind, value, option)
    return out


def _option_value(kind: str, text: str, option: str) -> Any:
    try:
        if kind == "position":
            lower, sep, upper = text.partition(":")
            if not sep:
                raise ValueError
            value: Any = [float(lower), float(upper)]
        else:
            value = float(text)
    except ValueError:
        expected = "LOWER:UPPER" if kind == "position" else "a number"
        raise DataError(option, "value", f"expected {expected}, got {text!r}") from None
    return checked_value(value, kind, "value", option)


def summary(result: Excitation) -> str:
    """Lines for the terminal: the criterion, the worst ratio to a limit, the predicted σ % (and the compared log's)."""
    d = result.design
    worst = max(float(v.max()) for v in d.worst.values())
    lines = [f"excitation of {result.model.name}: T = {d.trajectory.period:g} s, {d.trajectory.harmonics} harmonics, "
             f"criterion {d.criterion} {d.value:.6g} (best start {d.start_value:.6g}), worst ratio to a limit {worst:.4f}, "
             f"{d.seconds:.1f} s"]
    if result.loop is not None:
        lines += [line for line in result.loop.table() if line]
    lines += [line for line in _sigma_table(result.predicted, result.compare) if line]
    lines += [line for line in _separation_lines(result) if line]
    return "\n".join(lines)
