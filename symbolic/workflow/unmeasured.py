"""Diagnosis of a model whose coordinates the data do not all measure, judged on its response alone.

docs/workflow.md, "Coordinates the data do not measure". A model file may hold coordinates no sensor reads: an
elastic joint's link seen through its motor encoder alone (Spong's two coordinates, the link's deflection
unmeasured), a beam's modal coordinates without strain gauges. The inverse dynamics at the measured states cannot
be written for it (the unmeasured accelerations are unknown), so neither IDIM-LS nor the equation-error search
applies. What remains is the response: the model as written, simulated in the experiment's ``[controller]`` loop
with its unmeasured coordinates from rest, compared with the log on the coordinates it measures. The search
judged on the response (:mod:`symbolic.workflow.response`) then runs from the model file's own values — each
candidate (a model file's stiffness or damping, a delay, a drive gain, a sensor bias) fitted by output error on
the estimation data and named only when it lowers the **held-out** simulation error by the effect size and
passes the physical and σ rules; a wrong stiffness is named as a correction of that stiffness.

The model file's values are the start and the reference: nothing is re-identified wholesale (the response of a
two-mass system does not determine every inertial parameter, and a refit of all of them would move the ones it
cannot see). The gaps after are those of the patched model simulated again, with the signal values named
declared, before report.md and the JSON are written.
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from symbolic.data import DataError, Measurements, load, signal_layer
from symbolic.data.bags import alignments
from symbolic.derivation.dynamics import DynamicModel, derive
from symbolic.description.modelfile import loads
from symbolic.errors import ModelWarning
from symbolic.identify.output_error import simulated, simulation_errors
from symbolic.workflow.corrections import check_loads, modes_at, modes_sentence, physical_values
from symbolic.workflow.dataset import held_out_split
from symbolic.workflow.effects.on_response import RESPONSE_EFFECTS, ResponseEffect
from symbolic.workflow.records import SearchSettings
from symbolic.workflow.response import ResponseSearch, search_response

log = logging.getLogger("symbolic")

Errors = dict[str, dict[str, dict[str, float]]]
"""Per data set ("estimation", "validation"), per signal ("force", "position"), per coordinate: error (%)."""


@dataclass(frozen=True, eq=False)
class ResponseDiagnosis:
    """What :func:`diagnose_on_response` found; :meth:`to_dict` is its ``--json`` contract.

    ``before`` are the simulation errors of the model as written, ``after`` those of the patched model simulated
    again with the signal values named declared (both 100·‖measured − simulated‖/‖measured − mean‖, %)."""

    model: DynamicModel = field(repr=False)
    unmeasured: tuple[str, ...]
    measured: tuple[str, ...]
    held_out: str
    response: ResponseSearch = field(repr=False)
    before: Errors
    after: Errors
    patched_text: str | None = field(repr=False)
    patched_path: Path | None
    kept: tuple[dict[str, Any], ...] = ()
    modes: dict[str, Any] | None = None
    notes: tuple[str, ...] = ()
    seconds: dict[str, float] = field(default_factory=dict)
    figures: tuple[Path, ...] = ()
    alignment: dict[str, Any] | None = None
    """How the bags read were aligned, by data set (:func:`symbolic.data.bags.alignments`); ``None`` for other data."""
    judged_on = "response"

    @property
    def found(self) -> tuple[dict[str, Any], ...]:
        """Every named effect and correction, as the JSON's ``found`` lists them."""
        named = [j.to_dict() for j in self.response.named]
        labels = {n["label"] for n in named}
        return tuple(named + [dict(c) for c in self.response.corrections if c["label"] not in labels])

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model.name, "judged_on": self.judged_on, "unmeasured": list(self.unmeasured),
                "measured": list(self.measured), "held_out": self.held_out, "before": self.before,
                "after": self.after, "found": list(self.found), "corrections": list(self.response.corrections),
                "experiment_lines": self.response.experiment_lines(), "response": self.response.to_dict(),
                "patched_model": None if self.patched_path is None else str(self.patched_path),
                "kept": list(self.kept), "modes": self.modes, "notes": list(self.notes), "seconds": self.seconds,
                "alignment": self.alignment, "figures": [str(p) for p in self.figures]}

    def summary(self) -> list[str]:
        """The lines ``symbolic diagnose`` prints."""
        lines = [f"judged on the response alone: the data do not measure {', '.join(self.unmeasured)}",
                 f"held-out simulation error before: {_errors_text(self.before['validation'])}"]
        lines += [f"found {f['label']}: " + _values_text(f) for f in self.found] or ["no significant missing effect"]
        lines.append(f"held-out simulation error after:  {_errors_text(self.after['validation'])}")
        if self.modes is not None and self.modes.get("summary"):
            lines.append(f"modes (linearised at rest): {self.modes['summary']}")
        return lines


def _errors_text(errors: Mapping[str, Mapping[str, float]]) -> str:
    return ", ".join(f"{signal} {c} {value:.4g} %" for signal, by in errors.items() for c, value in by.items())


def _values_text(found: Mapping[str, Any]) -> str:
    if "parameter" in found:  # a correction of the refit's, not a candidate's
        return f"{found['parameter']} {found['idim_ls']:.6g} -> {found['value']:.6g} ± {found['sigma']:.2g}"
    return ", ".join(f"{k} = {v:.6g}" for k, v in found["parameters"].items() if isinstance(v, (int, float)))


def unmeasured_coordinates(model: DynamicModel, measurements: Measurements) -> tuple[str, ...]:
    """The model's coordinates that ``measurements`` hold no position of, in the model's order."""
    have = set(measurements.coordinates)
    return tuple(c for c in model.robot.generalized_coordinates if c not in have)


def diagnose_on_response(
    model: DynamicModel,
    data: str | Path | Measurements,
    *,
    experiment: str | Path | None = None,
    validation: str | Path | Measurements | None = None,
    out: str | Path | None = None,
    search: SearchSettings | None = None,
    effects: Sequence[Any] | None = None,
    figures: bool = True,
    fix: Sequence[str] = (),
    html: bool = False,
) -> ResponseDiagnosis:
    """Diagnose ``model`` on the response alone (module docstring); the arguments are :func:`diagnose`'s
    (``html``: ``report.html`` into ``out`` too, :func:`symbolic.workflow.html_report.render_response`).

    Raises
    ------
    DataError
        When the experiment declares no ``[controller]`` (the response needs the machine's loop), or the data
        measure every coordinate (use :func:`symbolic.workflow.diagnose`).
    """
    started = time.perf_counter()
    measurements = load(data, None, model=model.robot, experiment=experiment, validation=validation)
    source = str(measurements.source)
    unmeasured = unmeasured_coordinates(model, measurements)
    if not unmeasured:
        raise DataError(source, "signals", f"the data measure every coordinate of model {model.name}: diagnose it "
                                           "with symbolic.workflow.diagnose (the equation error and the response)")
    if getattr(measurements, "controller", None) is None:
        raise DataError(source, "[controller]",
                        f"model {model.name}'s coordinates {', '.join(unmeasured)} are not in the data (no q_<c> "
                        "signal): such a model can only be judged on its response, simulated in the loop the machine "
                        "ran; declare it as the experiment's [controller] (docs/data.md), or log those coordinates")
    foreign = [c for c in measurements.controller.coordinates if c not in measurements.coordinates]
    if foreign:
        raise DataError(source, "[controller] coordinates",
                        f"{', '.join(foreign)} of the loop are not measured coordinates of model {model.name} (measured: "
                        f"{', '.join(measurements.coordinates)}): the response cannot be simulated in that loop")
    estimation, held, held_from, held_out = _sets(measurements)
    chosen = list(RESPONSE_EFFECTS.values()) if effects is None else [e for e in effects if isinstance(e, ResponseEffect)]
    min_gain = (search or SearchSettings()).min_gain
    log.info("diagnose %s: %s not measured: judged on the response alone", model.name, ", ".join(unmeasured))
    response = search_response(model, estimation, held, held_from=held_from, effects=chosen, fix=fix,
                               min_gain=min_gain, determined=[])
    seconds = {"response": time.perf_counter() - started}
    notes = [f"the data do not measure {', '.join(unmeasured)}: neither IDIM-LS nor the equation-error search "
             "applies (the inverse dynamics needs every coordinate's acceleration); the model was simulated in the "
             "experiment's loop with those coordinates from rest, its values the model file's, and only what lowers "
             "the held-out simulation error was named (docs/workflow.md, \"Coordinates the data do not measure\")",
             *response.notes]
    patched_text, patched_path, patched, kept = _patched(model, response, out, source, notes)
    layer = response.layer_values()
    after_model = patched if patched is not None else model
    after = _errors(after_model, estimation, held, held_from, layer, response.signals, source)
    seconds["patch and shrink"] = time.perf_counter() - started - seconds["response"]
    mean = {c: float(np.mean(estimation.q[:, k])) for k, c in enumerate(estimation.coordinates)}
    found_modes = None
    if patched is not None:
        found_modes = modes_at(model, patched, patched.parameter_vector.by_name(), mean, estimation.controller,
                               float(estimation.sample_period), notes)
        if found_modes is not None:
            found_modes["summary"] = modes_sentence(found_modes)
    result = ResponseDiagnosis(model, unmeasured, tuple(estimation.coordinates), held_out, response,
                               dict(response.before), after, patched_text, patched_path, tuple(kept), found_modes,
                               tuple(notes), seconds,
                               alignment=alignments(("estimation", measurements),
                                                    ("validation", getattr(measurements, "validation", None))))
    if out is not None:
        result = _write(result, Path(out), figures, (estimation, held, held_from, layer, after_model), html)
    return result


def _sets(measurements: Measurements) -> tuple[Measurements, Measurements, int, str]:
    """(estimation, held-out record, the sample its held-out part starts at, a sentence saying where it is)."""
    held = getattr(measurements, "validation", None)
    if held is not None:
        return replace(measurements, validation=None), held, 0, f"the validation data {held.source}"
    first, _, where = held_out_split(measurements, ", simulated from the record's start")
    return first, measurements, first.samples, where


def _patched(model: DynamicModel, response: ResponseSearch, out: str | Path | None, source: str,
             notes: list[str]) -> tuple[str | None, Path | None, DynamicModel | None, list[dict[str, Any]]]:
    """The model file with the values the response corrected (text, where it is written, the model derived)."""
    values = response.parameter_values()
    path = Path(str(model.robot.source))
    if not values:
        return None, None, None, []
    if not path.is_file() or path.suffix.lower() == ".urdf":
        notes.append(f"the model has no TOML file to patch ({model.robot.source}): the corrected values are in the "
                     "JSON and report.md only")
        return None, None, None, []
    target = (Path(out) if out is not None else Path(".")) / f"{model.name}_patched.toml"
    text, _, kept = physical_values(path.read_text(encoding="utf-8"), values, str(target),
                                    f"corrected by the output error of symbolic diagnose on {Path(source).name}",
                                    model.robot)
    notes += [f"{k['parameter']} is kept at the model file's value: the fitted {k['value']:.6g} is not physical "
              f"({k['reason']})" for k in kept]
    check_loads(text, target, path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        patched = derive(loads(text, str(target)))
    return text, target if out is not None else None, patched, kept


def _declared(measurements: Measurements, layer: Mapping[Any, float], source: str) -> Measurements:
    return signal_layer.fixed(measurements, layer, source) if layer else measurements


def _errors(model: DynamicModel, estimation: Measurements, held: Measurements, held_from: int,
            layer: Mapping[Any, float], signals: str, source: str) -> Errors:
    """The simulation errors of ``model`` with the signal values ``layer`` declared, on both sets."""
    return {"estimation": simulation_errors(model, _declared(estimation, layer, source), signals=signals),
            "validation": simulation_errors(model, _declared(held, layer, source), signals=signals,
                                            start=held_from)}


def _write(result: ResponseDiagnosis, folder: Path, figures: bool,
           runs: tuple[Measurements, Measurements, int, Mapping[Any, float], DynamicModel],
           html: bool = False) -> ResponseDiagnosis:
    """report.md, the figures (and report.html) and the patched model into ``folder``, all or nothing."""
    from symbolic.workflow.report import response_markdown, write_folder

    pictures: dict[str, bytes] = {}
    notes = list(result.notes)
    # the held-out simulations are run once, for the PNGs and the page alike
    drawn = curves(result, *runs) if figures or html else None
    if figures:
        from symbolic.plotting import MatplotlibMissing
        try:
            pictures = _figures(drawn)
        except MatplotlibMissing as missing:
            notes.append(str(missing))
    result = replace(result, figures=tuple(folder / name for name in pictures), notes=tuple(notes))
    files = {"report.md": response_markdown(result).encode("utf-8"), **pictures}
    if html:  # from the dictionary --json prints (symbolic.htmlpage, "One source")
        from symbolic.workflow import html_report

        files[html_report.NAME] = html_report.render_response(result, result.to_dict(), drawn).encode("utf-8")
    write_folder(folder, files, result.patched_text, result.patched_path)
    return result


def curves(result: ResponseDiagnosis, estimation: Measurements, held: Measurements, held_from: int,
           layer: Mapping[Any, float], after_model: DynamicModel) -> dict[str, Any]:
    """What the figures draw, on the held-out data (from ``held_from`` on): ``{"t", "rate", "coordinates": {c:
    {"measured": {signal: x}, "simulated": {run: {signal: x}}}}}`` for the signals ``position`` and ``force`` and
    the runs ``model file`` (as written) and ``patched`` (with the signal values named); ``force`` simulated is
    the loop's controller output."""
    source = str(held.source)
    runs = {"model file": simulated(result.model, held)[:2],
            "patched": simulated(after_model, _declared(held, layer, source))[:2]}
    out: dict[str, Any] = {"t": np.asarray(held.t)[held_from:], "rate": 1.0 / float(held.sample_period),
                           "coordinates": {}}
    for k, c in enumerate(held.coordinates):
        measured = {"position": np.asarray(held.q)[held_from:, k], "force": np.asarray(held.tau)[held_from:, k]}
        simulated_ = {}
        for label, (y, loop) in runs.items():
            j = list(loop.names).index(c)
            simulated_[label] = {"position": y[held_from:, j], "force": y[held_from:, j + 3 * len(loop.names)]}
        out["coordinates"][c] = {"measured": measured, "simulated": simulated_}
    return out


def _figures(drawn: dict[str, Any]) -> dict[str, bytes]:
    """Per measured coordinate, on the held-out data (:func:`curves`): ``response_<c>.png`` (measured and simulated
    position and force, the model as written and patched) and ``response_spectrum_<c>.png`` (the force error's
    spectrum)."""
    from symbolic.plotting import figure_class, png_bytes
    from symbolic.workflow.where import spectrum
    from symbolic.writing import safe_stem

    Figure = figure_class()
    t, rate = drawn["t"], drawn["rate"]
    out: dict[str, bytes] = {}
    for c, signals in drawn["coordinates"].items():
        measured = signals["measured"]
        fig = Figure(figsize=(9, 6))
        for row, signal in enumerate(("position", "force")):
            ax = fig.add_subplot(2, 1, row + 1)
            # the measured signal drawn last (on top): the simulations it should cover are dashed
            for label, y in signals["simulated"].items():
                ax.plot(t, y[signal], lw=1.0, ls="--", label=f"simulated, {label}")
            ax.plot(t, measured[signal], color="black", lw=0.7, label="measured (as logged)")
            ax.set_ylabel(f"{signal} of {c}")
            ax.legend(loc="upper right", fontsize=7)
        ax.set_xlabel("time (s)")
        fig.suptitle(f"Held-out response of {c}: the model file's values and the patched model's")
        fig.tight_layout()
        stem = safe_stem(c)
        out[f"response_{stem}.png"] = png_bytes(fig)
        fig = Figure(figsize=(8, 4))
        ax = fig.add_subplot(1, 1, 1)
        ax.set_yscale("log")
        for label, y in signals["simulated"].items():
            f, psd = spectrum(measured["force"] - y["force"], rate)
            shown = psd > 0
            ax.plot(f[shown], psd[shown], lw=0.8, label=f"measured − simulated, {label}")
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel(f"PSD of the force error on {c}")
        ax.set_title(f"Held-out simulated force error on {c} (Welch)")
        ax.legend(loc="upper right")
        fig.tight_layout()
        out[f"response_spectrum_{stem}.png"] = png_bytes(fig)
    return out
