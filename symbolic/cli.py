"""Command line of symbolic: derive, generate, identify, simulate and diagnose robot models (also python -m symbolic).

MODEL is a model file path or the name of a built-in robot (``symbolic list``). User mistakes are
reported on stderr with exit code 2 and no traceback.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
import traceback
import warnings
from pathlib import Path

from typing import TYPE_CHECKING

from symbolic.errors import (IdentificationError, ModelError, ModelWarning, SimulationError, SymbolicError, one_line,
                             suggestion)
from symbolic.reproduction.item import SOURCES as REPRODUCTION_SOURCES
from symbolic.version import __version__

if TYPE_CHECKING:
    import sympy as sp

    from symbolic.derivation.dynamics import DynamicModel
    from symbolic.description.robot import Robot

# SymPy, NumPy and the layers are imported by the commands that use them, not here: `symbolic --help` and a
# mistyped command answer at once (docs/contracts.md, "Command line").


def derive(robot: Robot) -> DynamicModel:
    from symbolic.derivation.dynamics import derive as derived

    return derived(robot)


class _Robots:
    """:mod:`symbolic.robots`, imported on first use."""

    def __getattr__(self, name: str):
        import symbolic.robots

        return getattr(symbolic.robots, name)


robots = _Robots()


def strict_json(value: object) -> str:
    """``value`` as JSON that strict parsers accept: a value that is not finite (NaN, ±inf) becomes ``null``,
    and the top-level ``"not_finite"`` lists where each was and what it was (``{"path": "gap.q7", "value": "nan"}``)."""
    import json
    import math

    found: list[dict[str, str]] = []

    def clean(x: object, path: str) -> object:
        if isinstance(x, dict):
            return {k: clean(v, f"{path}.{k}" if path else str(k)) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v, f"{path}[{i}]") for i, v in enumerate(x)]
        if isinstance(x, float) and not math.isfinite(x):
            found.append({"path": path, "value": repr(float(x))})
            return None
        if type(x).__module__ == "numpy" and hasattr(x, "item"):  # NumPy scalars
            return clean(x.item(), path)
        return x

    cleaned = clean(value, "")
    if found and isinstance(cleaned, dict):
        cleaned["not_finite"] = found
    return json.dumps(cleaned, indent=2, allow_nan=False)


def resolve(model: str, args: argparse.Namespace | None = None) -> Robot:
    """MODEL of a command: a model file (TOML or URDF, with ``args.root``/``args.tip`` for a URDF chain) or a
    built-in robot name, by the one precedence of :func:`symbolic.robots.resolve`."""
    return robots.resolve(model, getattr(args, "root", None), getattr(args, "tip", None))


def cmd_list(args: argparse.Namespace) -> int:
    names = robots.names()
    width = max(len(n) for n in names)
    for name in names:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            robot = robots.load(name)
        print(f"{name:{width}s}  {len(robot.generalized_coordinates):2d} DOF  {robot.description}")
    return 0


def cmd_derive(args: argparse.Namespace) -> int:
    robot = resolve(args.model, args)
    model = derive(robot)
    print(model.summary())
    if args.show or (args.show is None and model.n <= 3):
        show(model)
    return 0


def show(model) -> None:
    """Print D(Q) and V_g(Q) compacted; entries too large to expand (above ``SIZE_LIMIT``) in
    intermediates, whose definitions follow."""
    import sympy as sp

    from symbolic.derivation.simplify import SIZE_LIMIT, compact, tree_size

    log = logging.getLogger(__name__)
    large: list[sp.Expr] = []

    def text(label: str, reduced: sp.Expr, expanded: sp.Expr) -> str:
        size = tree_size(expanded)
        if size > SIZE_LIMIT:
            large.append(reduced)
            return f"{sp.sstr(reduced)}    [expanded size {size} > {SIZE_LIMIT}: in intermediates, defined below]"
        start = time.perf_counter()
        form = sp.sstr(compact(expanded, model.coordinates))
        log.log(logging.INFO if time.perf_counter() - start > 1 else logging.DEBUG,
                "%s: %s compacted in %.1f s", model.name, label, time.perf_counter() - start)
        return form

    log.info("%s: compacting D(Q) and V_g(Q)", model.name)
    print("\nD(Q) (compact, upper triangle):")
    for i in range(model.n):
        for j in range(i, model.n):
            print(f"  D[{i},{j}] = {text(f'D[{i},{j}]', model.reduced.D[i, j], model.D[i, j])}")
    print("\nV_g(Q) =", text("V_g", model.reduced.potential, model.potential_energy))
    if large:
        print(f"\nIntermediates of the entries above {SIZE_LIMIT} (compacting them would take minutes):")
        for symbol, definition in model.sub.program(large):
            print(f"  {symbol} = {sp.sstr(definition)}")


def cmd_generate(args: argparse.Namespace) -> int:
    from symbolic import export

    targets = [t.strip() for t in args.targets.split(",") if t.strip()]
    unknown = set(targets) - set(export.TARGETS)
    if unknown or not targets:
        print(f"error: --targets: unknown target(s) {sorted(unknown)} (allowed: {', '.join(export.TARGETS)})", file=sys.stderr)
        return 2
    from symbolic.codegen.c_printer import check_precision

    try:
        check_precision(args.precision)  # before the derivation, like --out
    except ValueError as error:
        print(f"error: --precision: {error}", file=sys.stderr)
        return 2
    try:
        export.check_output_directory(args.out)  # before the derivation: seconds for a large model
    except export.ExportError as error:
        print(f"error: --out: {error}", file=sys.stderr)
        return 2
    if args.figures:
        import importlib.util

        if importlib.util.find_spec("matplotlib") is None:  # before the derivation: seconds for a large model
            print("error: --figures needs matplotlib (pip install 'symbolic[plot]')", file=sys.stderr)
            return 2
    robot = resolve(args.model, args)
    model = derive(robot)
    command = export.regenerate_command(args.model, targets, args.precision)
    try:
        written = export.generate(model, args.out, targets, command=command, figures=args.figures, precision=args.precision)
    except export.ExportError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0


def cmd_analyze(args: argparse.Namespace) -> int:
    from symbolic.derivation.analysis import KINDS, counterbalance, decoupling

    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    unknown = set(kinds) - set(KINDS)
    if unknown or not kinds:
        print(f"error: --kinds: unknown kind(s) {sorted(unknown)} (allowed: {', '.join(KINDS)})", file=sys.stderr)
        return 2
    model = derive(resolve(args.model, args))
    if args.design:
        free = [f.strip() for f in args.design.split(",") if f.strip()]
        try:
            design = counterbalance(model, free)
        except ValueError as error:
            print(f"error: --design: {error}", file=sys.stderr)
            return 2
        print(design.summary())
        problem = design.problem(free)
        if problem:  # a design that solves nothing or leaves conditions unmet is a failure, not a result
            print(f"error: --design: {problem}", file=sys.stderr)
            return 2
        return 0
    analysis = decoupling(model, kinds=kinds)
    if args.json:
        print(strict_json(analysis.to_dict()))
    else:
        print(analysis.summary())
    return 0


def write_text_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename."""
    from symbolic.writing import replacing

    try:
        with replacing(path) as temporary:
            temporary.write_text(text, encoding="utf-8")
    except OSError as error:
        raise ModelError(str(path), "--out", f"cannot write: {error.strerror}") from None


def write_model_atomically(path: Path, text: str) -> None:
    """:func:`write_text_atomically` for a model file: the written file is loaded before it replaces
    ``path``, so a file that :func:`symbolic.load` refuses is never left there."""
    from symbolic.description.modelfile import load
    from symbolic.writing import replacing

    try:
        with replacing(path) as temporary:
            temporary.write_text(text, encoding="utf-8")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ModelWarning)
                load(temporary)
    except OSError as error:
        raise ModelError(str(path), "--out", f"cannot write: {error.strerror}") from None


def fix_names(text: str | None) -> list[str]:
    """The names of ``--fix A,B``."""
    return [n.strip() for n in (text or "").split(",") if n.strip()]


def _check_targets(args: argparse.Namespace) -> None:
    """``identify``'s --figures must be a folder (or creatable as one) and --out a file, checked before the work."""
    from symbolic.errors import ExportError

    if args.figures is not None:
        if not str(args.figures).strip():
            raise ExportError("--figures is empty: name a folder for the figures (e.g. --figures figures)")
        figures = Path(args.figures)
        if figures.exists() and not figures.is_dir():
            raise ExportError(f"--figures {figures}: exists and is not a folder (name a folder for the PNG files)")
    if args.out is not None:
        out = Path(args.out)
        if not str(args.out).strip() or out.is_dir():
            raise ExportError(f"--out {args.out!r}: name the model file to write (e.g. --out identified.toml)")
    if getattr(args, "html", None) is not None:
        if not str(args.html).strip() or Path(args.html).is_dir():
            raise ExportError(f"--html {args.html!r}: name the HTML file to write (e.g. --html report.html)")
        if not Path(args.html).resolve().parent.is_dir():
            raise ExportError(f"--html {args.html!r}: its folder {Path(args.html).parent} does not exist")
        _check_html(args)


def _identify_output_error(args: argparse.Namespace, model) -> int:
    """``identify --method didim``: the output error of the experiment's closed loop from the IDIM-LS start
    (:mod:`symbolic.identify.output_error`); --out writes the model file as IDIM-LS's does."""
    from symbolic.description.modelfile import with_loadable_values
    from symbolic.identify.output_error import output_error

    if args.figures or args.validate or args.html or args.out and Path(args.out).suffix.lower() in (".urdf", ".xml"):
        raise ModelError(args.model, "--method didim", "--figures, --validate, --html and a URDF or MJCF --out are not "
                                                       "available with the output error yet (allowed: --out FILE.toml, --json)")
    fit = output_error(model, args.data, experiment=args.experiment, signals=args.signals,
                       weights=(args.force_weight, args.position_weight), fix=fix_names(args.fix),
                       consistent=args.consistent, max_iterations=args.max_iterations)
    kept: dict[str, str] = {}
    if args.out:
        source = Path(model.robot.source)
        if not source.is_file() or source.suffix.lower() == ".urdf":
            raise ModelError(args.model, "--out", "the model has no TOML file to update")
        text, kept = with_loadable_values(source.read_text(encoding="utf-8"), fit.values(), str(source),
                                          provenance=f"identified by symbolic identify --method didim from "
                                                     f"{Path(args.data).name}")
        write_model_atomically(Path(args.out), text)
    if args.json:
        print(strict_json({**fit.to_dict(), "patched_model": args.out, "kept": kept}))
    else:
        print(fit.table())
        for name, reason in kept.items():
            print(f"not written: {name} keeps its value in the model file: {reason}")
        if args.out:
            print(f"wrote {args.out}")
    if not fit.converged:
        print(f"warning: the output-error fit did not converge: {fit.message}", file=sys.stderr)
    return 0


def cmd_identify(args: argparse.Namespace) -> int:
    from symbolic.identify.model import identify_model
    from symbolic.description.modelfile import with_loadable_values

    _check_targets(args)  # before the work: a mistyped --out or --figures is reported at once
    model = derive(resolve(args.model, args))
    if args.method == "didim":
        return _identify_output_error(args, model)
    result = identify_model(model, args.data, experiment=args.experiment, validation=args.validate,
                            method=args.method, consistent=args.consistent, fix=fix_names(args.fix))
    kept: dict[str, str] = {}
    if args.out and Path(args.out).suffix.lower() == ".urdf":
        from symbolic.export.urdf import urdf

        write_text_atomically(Path(args.out), urdf(model.robot, result.values()))
    elif args.out and Path(args.out).suffix.lower() == ".xml":
        from symbolic.export.mjcf import mjcf

        write_text_atomically(Path(args.out), mjcf(model.robot, result.values()))
    elif args.out:
        source = Path(model.robot.source)
        if not source.is_file() or source.suffix.lower() == ".urdf":
            raise ModelError(args.model, "--out", "the model has no TOML file to update (write --out FILE.urdf or "
                                                 "FILE.xml for a URDF model)")
        text, kept = with_loadable_values(source.read_text(encoding="utf-8"), result.values(), str(source),
                                          provenance=f"identified by symbolic identify from {Path(args.data).name}")
        write_model_atomically(Path(args.out), text)
    figures: list[str] = []
    if args.figures:
        from symbolic.identify.figures import MatplotlibMissing

        try:
            figures = [str(path) for path in result.figures(args.figures)]
        except MatplotlibMissing as missing:
            print(f"warning: {missing}", file=sys.stderr)
    out = result.to_dict()
    out["patched_model"] = args.out
    out["kept"] = kept
    out["figures"] = figures
    if args.html:  # the page is built from the dictionary --json prints (symbolic.htmlpage, "One source")
        from symbolic.identify.html_report import render

        write_text_atomically(Path(args.html), render(result, out, data=Path(args.data).name))
        figures.append(str(args.html))
    if args.json:
        print(strict_json(out))
    else:
        print(result.table())
        for name, reason in kept.items():
            print(f"not written: {name} keeps its value in the model file: {reason}")
        for path in [args.out, *figures] if args.out else figures:
            print(f"wrote {path}")
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    from symbolic import data, export
    from symbolic.simulation import simulate
    from symbolic.simulation.simulator import EXPERIMENT_NAME, cached_model
    from symbolic.description.units import coordinate_units
    from symbolic.simulation.figures import MatplotlibMissing, draw

    try:
        if args.out:
            export.check_output_directory(args.out)  # before deriving and simulating
    except export.ExportError as error:
        print(f"error: --out: {error}", file=sys.stderr)
        return 2
    if args.html and not args.out:
        print("error: --html: name the folder of the report with --out DIR (report.html is written there)", file=sys.stderr)
        return 2
    _check_html(args)
    # the model's numbers and CasADi plant, read from the cache folder without SymPy when they are there
    model = cached_model(args.model, getattr(args, "root", None), getattr(args, "tip", None))
    measurements = data.load(args.experiment, model=model.robot)
    simulation = simulate(model, measurements, method=args.method, substeps=args.substeps,
                          friction_velocity=args.friction_velocity)
    comparison = simulation.compare(window=args.window)
    files, notes = [], [n for n in (comparison.treatment.note,) if n]
    if args.out:
        files.append(simulation.write(args.out))
        files.append(files[-1].with_name(EXPERIMENT_NAME))  # how to read it: the force held over each sample
        try:
            files += draw(comparison, Path(args.out), title=f"{model.robot.name}, {Path(args.experiment).name}",
                          units=coordinate_units(model.robot))
        except MatplotlibMissing as missing:
            notes.append(str(missing))
    document = {**simulation.to_dict(comparison), "files": [str(f) for f in files], "notes": notes}
    if getattr(measurements, "alignment", None) is not None:  # a bag: how its topics were aligned, as identify says
        document["alignment"] = measurements.alignment.to_dict()
    if args.html:  # the page is built from the dictionary --json prints (symbolic.htmlpage, "One source")
        from symbolic.simulation.html_report import NAME, render

        page = Path(args.out) / NAME
        write_text_atomically(page, render(comparison, document, f"{model.robot.name}, {Path(args.experiment).name}",
                                           coordinate_units(model.robot), notes))
        files.append(page)
        document["files"].append(str(page))
    if args.json:
        print(strict_json(document))
        return 0
    print(simulation.summary())
    print(comparison.summary())
    for line in [*map(str, files), *notes]:
        print(line)
    return 0


def cmd_excite(args: argparse.Namespace) -> int:
    from symbolic import export
    from symbolic.identify import excitation_report as excite
    from symbolic.identify.excitation import check_options

    separate = [] if args.separate is None else args.separate.split(",")
    if separate and args.criterion is not None:
        print(f"error: --criterion: not with --separate, which designs for the pair's own criterion (Ds-optimality: "
              f"the information about {args.separate} once the others are estimated); give one of them", file=sys.stderr)
        return 2
    args.criterion = args.criterion or "d"
    check_options(args.duration, args.harmonics, args.criterion, args.starts)  # before deriving: nothing written
    try:
        export.check_output_directory(args.out)
    except export.ExportError as error:
        print(f"error: --out: {error}", file=sys.stderr)
        return 2
    _check_html(args)
    model = derive(resolve(args.model, args))
    names = model.robot.generalized_coordinates
    limits = {kind: excite.option_values(kind, getattr(args, kind), names)
              for kind in ("position", "velocity", "acceleration", "torque")}
    noise = {kind: excite.option_values(kind, getattr(args, kind), names) for kind in ("force_noise", "resolution")}
    declared = excite.read_declarations(args.experiment, names)
    result = excite.excite(model, declared, args.duration, limits=limits, noise=noise, rate=args.rate,
                           harmonics=args.harmonics, criterion=args.criterion, starts=args.starts, seed=args.seed,
                           compare=args.compare, separate=separate)
    paths, notes = excite.write(result, args.out, figures=not args.no_figures, html=args.html)
    if args.json:
        print(strict_json({**result.to_dict(), "files": [str(p) for p in paths], "notes": notes}))
        return 0
    print(excite.summary(result))
    for line in [*(f"wrote {p}" for p in paths), *notes]:
        print(line)
    return 0


def cmd_diagnose(args: argparse.Namespace) -> int:
    from symbolic.workflow import SearchSettings, diagnose
    from symbolic.workflow.effects import EFFECTS, select
    from symbolic.workflow.effects.on_response import RESPONSE_EFFECTS

    effects = None
    if args.effects is not None:
        names = [n.strip() for n in args.effects.split(",") if n.strip()]
        try:
            effects = select([n for n in names if n not in RESPONSE_EFFECTS]) if names else None
        except KeyError as error:
            unknown = error.args[0]
        else:
            unknown = []
            effects = None if effects is None else [*effects, *(RESPONSE_EFFECTS[n] for n in names if n in RESPONSE_EFFECTS)]
        if unknown or not names:
            known = [*EFFECTS, *(e.identifier for e in EFFECTS.values()), *RESPONSE_EFFECTS]
            hint = suggestion(unknown[0], known) if unknown else ""
            print(f"error: --effects: unknown effect(s) {unknown} (catalogue: {', '.join([*EFFECTS, *RESPONSE_EFFECTS])}; "
                  f"periodic means both periodic in position and periodic_time){hint}", file=sys.stderr)
            return 2
    groups = {}
    for text in args.group or []:
        name, _, members = text.partition("=")
        coordinates = [c.strip() for c in members.split(",") if c.strip()]
        if not name.strip() or len(coordinates) < 2:
            print(f"error: --group {text!r}: expected NAME=C1,C2[,...] (a name and at least two coordinates)", file=sys.stderr)
            return 2
        groups[name.strip()] = tuple(coordinates)
    from symbolic import export

    export.check_output_directory(args.out)  # before the analysis: a mistyped --out is reported at once
    _check_html(args)
    model = derive(resolve(args.model, args))
    search = SearchSettings(groups=groups) if groups else None
    result = diagnose(model, args.data, experiment=args.experiment, validation=args.validate, out=args.out, effects=effects,
                      simulate=args.simulate or None, fix=fix_names(args.fix), search=search,
                      response=args.response, html=args.html)
    if args.json:
        print(strict_json(result.to_dict()))
        return 0
    if getattr(result, "judged_on", None) == "response":  # coordinates the data do not measure
        for line in result.summary():
            print(line)
        if args.out:
            written = [str(Path(args.out) / "report.md")] + ([str(Path(args.out) / "report.html")] if args.html else []) \
                + ([str(result.patched_path)] if result.patched_path else [])
            print(f"wrote {' and '.join(written)}")
        return 0
    gap = lambda fit: f"{fit.gap['estimation']:.4g} % (estimation), {fit.gap['validation']:.4g} % (held out)"  # noqa: E731
    for caveat in result.caveats:
        print(f"note: {caveat}")
    print(f"gap before: {gap(result.before)}")
    if not result.found:
        print("no significant missing effect")
    for f in result.found:
        values = ", ".join(f"{k} = {v:.6g}" if v is not None else f"{k} not determined" for k, v in f.parameters.items())
        group = f" (as one of {f.evidence['group']['name']})" if "group" in f.evidence else ""
        print(f"found {f.label()} on {f.coordinate}: {values}{group}")
    print(f"gap after:  {gap(result.after)}")
    for c in result.corrections:
        print(f"correction: {c['summary']}")
    changed = [c for c in result.changes if c["status"] == "re-identified"]
    if changed:
        print("values re-identified (model file -> patched): " + ", ".join(
            f"{c['parameter']} {c['nominal']:.6g} -> {c['value']:.6g}"
            + (f" ± {c['sigma']:.2g}" if c["sigma"] is not None else "")
            + ("" if c["relative_change"] is None else f" ({100 * c['relative_change']:+.3g} %)") for c in changed))
    for c in result.changes:
        if c["status"] == "removed":
            print(f"removed {c['parameter']} (was {c['nominal']:.6g}): no longer used by the patched model")
        elif c["status"] == "kept":
            print(f"kept {c['parameter']} = {c['nominal']:.6g}: the fitted {c['fitted']:.6g} is not physical ({c['reason']})")
    if result.modes is not None:
        modes = lambda ms: ", ".join(f"{m['frequency_hz']:.4g} Hz (ζ {m['damping_ratio']:.3g})" for m in ms) or "none"  # noqa: E731
        print(f"modes (linearised at rest): {modes(result.modes['before'])} -> {modes(result.modes['after'])}")
    for finding in result.data_findings:
        if finding["finding"] == "held_force" and finding.get("treated"):
            g = finding["patched"]["gap_validation"]
            print(f"the data: the force is held over each sample (zero-order hold): treated as held_force = true "
                  f"(with the force as logged the patched model's held-out gap is {g['as_logged']:.4g} %, so treated "
                  f"{g['held_force']:.4g} %); every number above is for the force so treated (report.md)")
        elif finding["finding"] == "held_force":
            g = finding["gap_validation"]
            print(f"the data: the logged force behaves as a command held over each sample; declared "
                  f"(held_force = true in [identification]) the held-out gap would be {g['held_force']:.4g} % "
                  f"instead of {g['as_logged']:.4g} % before any effect (report.md)")
    print(f"wrote {args.out}/report.md" + (f", {args.out}/report.html" if args.html else "")
          + (f" and {result.patched_path}" if result.patched_path else ""))
    return 0


class _DiagnoseHelp(argparse.Action):
    """``diagnose --help``: the usage, then the effects of the catalogue, read from the effect files' text
    (:mod:`symbolic.workflow.effect_summaries`: importing the catalogue takes a second or more)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace, values, option_string=None) -> None:
        from symbolic.workflow.effect_summaries import response_summaries, summaries, two_encoder_summaries

        effects, response, encoders = summaries(), response_summaries(), two_encoder_summaries()  # no SymPy, no NumPy
        width = max(map(len, [*effects, *response, *encoders]))
        parser.epilog = "effects (--effects NAMES; default: all; --list-effects: their parameters and units):\n" + \
            "\n".join(f"  {name:{width}s}  {summary}" for name, summary in effects.items()) + \
            "\njudged on the response (with --simulate; --no-response leaves them out):\n" + \
            "\n".join(f"  {name:{width}s}  {summary}" for name, summary in response.items()) + \
            "\nfrom a joint's motor-side and link-side encoders (tested wherever ql_<c> is logged):\n" + \
            "\n".join(f"  {name:{width}s}  {summary}" for name, summary in encoders.items())
        parser.print_help()
        parser.exit()


class _ListEffects(argparse.Action):
    """``diagnose --list-effects``: the catalogue from the registry, one line per effect (key, term, parameters
    with units, what it refines and excludes), without a model or data."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace, values, option_string=None) -> None:
        from symbolic.workflow.effects import listing
        from symbolic.workflow.effects.on_response import RESPONSE_EFFECTS

        print("\n".join(listing()))
        for key, e in RESPONSE_EFFECTS.items():
            roles = ", ".join(f"{r} ({unit})" for r, unit in e.roles.items())
            print(f"{key}  {e.summary}  [{roles}]  (judged on the response: --simulate)")
        from symbolic.workflow.effects.joint_elasticity import ROLES, SUMMARIES

        for key, summary in SUMMARIES.items():
            roles = ", ".join(f"{r} ({unit})" for r, unit in ROLES[key].items())
            print(f"{key}  {summary}  [{roles}]  (where ql_<c> is logged)")
        parser.exit()


def cmd_campaign(args: argparse.Namespace) -> int:
    from symbolic import export
    from symbolic.fleet import INSTALL, available

    if args.workers is not None and (args.workers < 0 or (args.workers == 0 and args.scheduler)):
        allowed = "a positive number of workers to wait for" if args.scheduler else \
            "0 (one log at a time in this process) or a positive number of worker processes"
        print(f"error: --workers {args.workers}: expected {allowed}", file=sys.stderr)
        return 2
    in_process = args.workers == 0 and not args.scheduler
    if not available() and not in_process:  # before reading anything: the one line that says how to get it
        print(f"error: {INSTALL} (or run it without Dask, one log at a time: --workers 0)", file=sys.stderr)
        return 2
    if not 0 < args.connect_timeout < float("inf"):
        print(f"error: --connect-timeout {args.connect_timeout:g}: expected a positive number of seconds", file=sys.stderr)
        return 2
    if args.scheduler:  # before anything is read or written: an address Dask cannot parse is one line
        from symbolic.fleet.execution import check_scheduler

        args.scheduler = check_scheduler(args.scheduler)
    try:
        export.check_output_directory(args.out)  # before the campaign: a mistyped --out is reported at once
    except export.ExportError as error:
        print(f"error: --out: {error}", file=sys.stderr)
        return 2
    _check_html(args)
    from symbolic import fleet
    from symbolic.fleet.report import summary

    campaign = fleet.load(args.campaign)
    outcome = fleet.run(campaign, args.out, scheduler=args.scheduler, workers=args.workers,
                        connect_timeout=args.connect_timeout, html=args.html)
    if args.json:
        print(strict_json(outcome.to_dict()))
        return 0
    for line in summary(outcome):
        print(line)
    pages = [f for f in outcome.files if f.suffix == ".html"]
    print(f"wrote {Path(args.out) / 'results.csv'}, {Path(args.out) / 'report.md'}"
          + (f", {len(pages)} HTML page(s) ({Path(args.out) / 'report.html'} and one per robot)" if pages else "")
          + f" and {len(outcome.files) - 2 - len(pages)} figure(s)")
    for note in outcome.notes:
        print(note)
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    from symbolic import reproduction
    from symbolic.reproduction import render
    from symbolic.writing import replacing

    sources = tuple(n.strip() for n in args.sources.split(",") if n.strip())
    unknown = sorted(set(sources) - set(REPRODUCTION_SOURCES))
    if unknown or not sources:
        print(f"error: --sources: unknown source(s) {unknown} (one of {', '.join(REPRODUCTION_SOURCES)})", file=sys.stderr)
        return 2
    items = reproduction.table(sources)
    if args.markdown:
        with replacing(args.markdown) as temporary:
            temporary.write_text(render.markdown(items), encoding="utf-8")
    if args.json:
        print(render.to_json(items))
    elif not args.markdown:
        for i in items:
            print(f"{i.source:7s} {i.item}: {i.status}")
        print(render.summary(items))
    return 0


def cmd_export_urdf(args: argparse.Namespace) -> int:
    from symbolic.export.urdf import urdf

    return _export_file(args, urdf, ".urdf", "URDF")


def cmd_export_mjcf(args: argparse.Namespace) -> int:
    from symbolic.export.mjcf import mjcf

    return _export_file(args, mjcf, ".xml", "MJCF")


def _export_file(args: argparse.Namespace, writer, suffix: str, kind: str) -> int:
    """``export-urdf`` and ``export-mjcf``: the model written by ``writer`` to ``--out``, a file named ``*suffix``."""
    from symbolic.errors import ExportError

    out = Path(args.out)
    if not str(args.out).strip() or out.is_dir() or out.suffix.lower() != suffix:
        raise ExportError(f"--out {args.out!r}: name the {kind} file to write (e.g. --out robot{suffix})")
    write_text_atomically(out, writer(resolve(args.model, args)))
    print(out)
    return 0


def cmd_first_peak(args: argparse.Namespace) -> int:
    from symbolic.reproduction.madill.first_peak import identify_experiment

    result = identify_experiment(args.experiment, args.coordinate)
    print(strict_json(result.to_dict()) if args.json else result.summary())
    return 0


HTML_HELP = ("also DIR/report.html: one self-contained page (tables and interactive figures; needs plotly: "
             "pip install 'symbolic[html]')")


def _check_html(args: argparse.Namespace) -> None:
    """``--html``: plotly must be importable, checked before the work (the error names the install command)."""
    if getattr(args, "html", None):
        from symbolic.htmlpage import require

        require()


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="symbolic", description=__doc__.splitlines()[0])
    p.add_argument("-q", "--quiet", action="store_true", help="no progress messages on stderr")
    p.add_argument("--version", action="version", version=f"symbolic {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("derive", help="derive D(Q), Christoffel C, g and τ and print a summary")
    d.add_argument("model", help="model file (.toml or .urdf) or built-in robot name")
    d.add_argument("--show", dest="show", action="store_true", default=None, help="print D(Q) and V(Q) in compact form")
    d.add_argument("--no-show", dest="show", action="store_false", help="summary only")
    d.set_defaults(func=cmd_derive)
    g = sub.add_parser("generate", help="write C, CasADi and Markdown for a model")
    g.add_argument("model", help="model file (.toml or .urdf) or built-in robot name")
    g.add_argument("--out", required=True, help="output directory (created if missing)")
    from symbolic.export.targets import NAMES as targets  # the folder's listing: no SymPy before --help

    g.add_argument("--targets", default=",".join(targets),
                   help=f"comma-separated subset of {','.join(targets)} (default: all)")
    g.add_argument("--figures", action="store_true",
                   help="with the report: the apparent mass over the workspace as NAME_apparent_mass.png (needs matplotlib)")
    g.add_argument("--precision", default="double", metavar="{double,float}",
                   help="C in double (default, NAME.h/NAME.c) or single precision (NAME_float.h/NAME_float.c, the same "
                        "functions in float; their error against double measured with a C compiler and stated in the "
                        "header and the report)")
    g.set_defaults(func=cmd_generate)
    a = sub.add_parser("analyze", help="decoupling and gravity-balancing conditions (Madill 4.2)")
    a.add_argument("model", help="model file (.toml or .urdf) or built-in robot name")
    a.add_argument("--json", action="store_true", help="machine-readable list of conditions")
    a.add_argument("--kinds", default="decoupling,constant_inertia,coriolis,balancing",
                   help="comma-separated families: decoupling, constant_inertia, coriolis, balancing")
    a.add_argument("--design", metavar="PARAMS", help="solve the balancing and decoupling conditions for these free parameters")
    a.set_defaults(func=cmd_analyze)
    i = sub.add_parser("identify", help="identify the model's parameters from measured data (IDIM-LS)")
    i.add_argument("model", help="model file (.toml or .urdf) or built-in robot name")
    i.add_argument("data", help="data file (CSV, .npz, .mat with canonical columns; a ROS 2 bag or MCAP file mapped by --experiment) "
                   "or experiment file (.toml)")
    i.add_argument("--experiment", metavar="FILE", help="experiment file mapping DATA's variables onto the canonical signals")
    i.add_argument("--validate", metavar="DATA2", help="cross-test data or experiment file")
    i.add_argument("--method", choices=["wls", "ols", "didim"], default="wls",
                   help="weighted (default) or ordinary least squares, or didim: the output error of the experiment's "
                   "closed loop from the IDIM-LS solution (docs/data.md, \"Output error\")")
    i.add_argument("--signals", choices=["force", "position", "both"], default="force",
                   help="didim: the signals compared, simulated against measured (default force)")
    i.add_argument("--force-weight", type=float, default=1.0, help="didim --signals both: weight of the force")
    i.add_argument("--position-weight", type=float, default=1.0, help="didim --signals both: weight of the position")
    i.add_argument("--max-iterations", type=int, default=30, help="didim: Levenberg-Marquardt iterations at most")
    i.add_argument("--consistent", action="store_true",
                   help="all the model file's parameters, physically consistent (log-Cholesky bodies) and closest to the "
                   "least-squares fit in its metric")
    i.add_argument("--fix", metavar="NAME[,NAME]", help="keep these parameters at their values in the model file "
                   "(as fixed = true in [parameters] does)")
    i.add_argument("--out", metavar="FILE.toml", help="write the model file with the identified values (a value the "
                   "model file cannot hold, e.g. a negative mass, is not written and the reason is printed; "
                   "FILE.urdf: as URDF; FILE.xml: as MuJoCo's MJCF)")
    i.add_argument("--figures", metavar="DIR", help="PNG figures: measured vs predicted force and the residual per coordinate")
    i.add_argument("--html", metavar="FILE.html", help="one self-contained HTML report: the fit, the parameters with σ and interactive "
                   "figures (needs plotly: pip install 'symbolic[html]')")
    i.add_argument("--json", action="store_true", help="machine-readable result")
    i.set_defaults(func=cmd_identify)
    s = sub.add_parser("simulate", help="simulate a model against a measured log with the machine's controller")
    s.add_argument("model", help="model file (.toml or .urdf) or built-in robot name")
    s.add_argument("experiment", help="experiment file (.toml, with [controller]) or data file")
    s.add_argument("--out", help="folder for simulated.csv and the figures")
    s.add_argument("--json", action="store_true", help="model, settings and relative errors (%%) as JSON")
    s.add_argument("--html", action="store_true", help="with --out: " + HTML_HELP)
    s.add_argument("--method", default="rk4", help="rk4 (fixed step, default) or a solve_ivp method: Radau, BDF, LSODA")
    s.add_argument("--substeps", type=int, help="RK4 sub-steps per sample (default: from the spectral radius)")
    s.add_argument("--friction-velocity", type=float, default=1e-4,
                   help="ε of the smoothed sign tanh(v/ε), in each coordinate's velocity unit: m/s for a prismatic "
                   "coordinate, rad/s for a revolute one (default 1e-4)")
    s.add_argument("--window", type=float, default=1.0, help="length of the worst window, seconds (default 1)")
    s.set_defaults(func=cmd_simulate)
    e = sub.add_parser("excite", help="design an exciting trajectory (Fourier series, D-optimal) and predict the σ it gives")
    e.add_argument("model", help="model file (.toml or .urdf) or built-in robot name")
    e.add_argument("--experiment", metavar="EXP.toml", help="experiment file with an [excitation] table (limits, noise, "
                   "rate) and [identification] settings; its data file is not read")
    e.add_argument("--duration", type=float, required=True, metavar="T", help="period and length of the reference (s)")
    e.add_argument("--out", metavar="DIR", required=True, help="folder for trajectory.csv, trajectory.experiment.toml, "
                   "excitation.json, report.md and the figures")
    e.add_argument("--harmonics", type=int, default=5, help="harmonics per coordinate (default 5)")
    e.add_argument("--criterion", help="d (D-optimality, default), a (A-optimality), condition, or dc (D-optimality "
                   "and the condition number together)")
    e.add_argument("--separate", metavar="A,B", help="design the motion that separates two parameters the data cannot "
                   "tell apart (base parameters, or model parameters alone in one): Ds-optimality for the pair, "
                   "instead of --criterion; the report gives their σ and correlation (and --compare LOG's)")
    e.add_argument("--starts", type=int, default=3, help="random starts (default 3)")
    e.add_argument("--seed", type=int, default=0, help="seed of the random starts (default 0)")
    e.add_argument("--compare", metavar="LOG", help="an existing log (data or experiment file identify reads): its "
                   "predicted σ beside the design's")
    for kind, example in (("position", "q1=-1:1"), ("velocity", "q1=2"), ("acceleration", "q1=10"), ("torque", "q1=50"),
                          ("force-noise", "q1=0.1"), ("resolution", "q1=1e-5")):
        e.add_argument(f"--{kind}", metavar="C=V,...", help=f"replaces the experiment's [excitation] {kind.replace('-', '_')}: "
                       f"{example}, or one value for every coordinate")
    e.add_argument("--rate", type=float, help="sample rate of the log to be recorded (Hz)")
    e.add_argument("--no-figures", action="store_true", help="write no PNG figures")
    e.add_argument("--html", action="store_true", help=HTML_HELP)
    e.add_argument("--json", action="store_true", help="machine-readable result")
    e.set_defaults(func=cmd_excite)
    w = sub.add_parser("diagnose", help="find the effects the model misses in measured data and patch the model file",
                       add_help=False, formatter_class=argparse.RawDescriptionHelpFormatter)
    w.add_argument("-h", "--help", action=_DiagnoseHelp, help="show this help message, with the effects, and exit")
    w.add_argument("--list-effects", action=_ListEffects, help="list the effect catalogue (key, term, parameters with "
                   "their units, what each refines and excludes) and exit")
    w.add_argument("model", help="model file (.toml or .urdf) or built-in robot name")
    w.add_argument("data", help="data file (CSV, .npz, .mat with canonical columns; a ROS 2 bag or MCAP file mapped by --experiment) "
                   "or experiment file (.toml)")
    w.add_argument("--experiment", metavar="FILE", help="experiment file mapping DATA's variables onto the canonical signals")
    w.add_argument("--validate", metavar="DATA2", help="held-out data or experiment file (default: the last fifth of DATA)")
    w.add_argument("--out", metavar="DIR", required=True, help="folder for report.md, the figures and <model>_patched.toml")
    w.add_argument("--fix", metavar="NAME[,NAME]", help="keep these parameters at their values when re-identifying "
                   "(as fixed = true in [parameters] does)")
    w.add_argument("--simulate", action="store_true",
                   help="measure the gap on the simulated controller output (the experiment's [controller]) instead of the inverse model")
    w.add_argument("--no-response", dest="response", action="store_false", default=None,
                   help="with --simulate (or a model with coordinates the data do not measure, which is judged on its response alone): do not search the effects judged on the response (delay, drive_gain, sensor_bias, "
                        "correction; by output error on held-out data, docs/workflow.md \"Judged on the response\")")
    w.add_argument("--effects", metavar="NAMES", help="search only these catalogue effects (comma-separated; default: all; periodic means both its "
                        "variants, periodic_time the one in time only)")
    w.add_argument("--group", metavar="NAME=C1,C2", action="append",
                   help="a named group of coordinates on which each effect is also tried as one grouped hypothesis "
                        "(besides every coordinate; repeatable)")
    w.add_argument("--html", action="store_true", help=HTML_HELP)
    w.add_argument("--json", action="store_true", help="machine-readable result")
    w.set_defaults(func=cmd_diagnose)
    c = sub.add_parser("campaign", help="identify, diagnose or simulate every log of a fleet on Dask; drift, outliers, events")
    c.add_argument("campaign", help="campaign file (.toml): robots, their models and logs, the task (docs/fleet.md)")
    c.add_argument("--out", metavar="DIR", required=True, help="folder for results.csv, report.md, the figures and "
                   "the cache of per-log results (cache/)")
    c.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask cluster (tcp://host:8786; also tls://, "
                   "ws://, wss://); default: a local cluster of worker processes on this machine")
    c.add_argument("--connect-timeout", type=float, default=10.0, metavar="S", help="seconds to wait for the "
                   "scheduler at --scheduler to connect and answer (default 10)")
    c.add_argument("--workers", type=int, metavar="N", help="worker processes of the local cluster (default: the "
                   "processors; 0: one log at a time in this process, without Dask); with --scheduler, the workers "
                   "to wait for")
    c.add_argument("--json", action="store_true", help="machine-readable summary (errors, drift, outliers, events)")
    c.add_argument("--html", action="store_true", help=HTML_HELP.replace("one self-contained page", "the campaign's page, "
                   "linking one page per robot (robot_<id>.html)"))
    c.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress on stderr")
    c.set_defaults(func=cmd_campaign)
    r = sub.add_parser("reproduce", help="recompute every checkable number of the seed documents and compare")
    r.add_argument("--json", action="store_true", help='{"items": [{"source", "item", "published", "ours", "unit", ...}]}')
    r.add_argument("--markdown", metavar="FILE", help="write the table as Markdown (docs/reproduction.md is this)")
    r.add_argument("--sources", default=",".join(REPRODUCTION_SOURCES),
                   help=f"comma-separated subset of {','.join(REPRODUCTION_SOURCES)} (default: all)")
    r.set_defaults(func=cmd_reproduce)
    fp = sub.add_parser("first-peak", help="Coulomb friction, inertia and damping of one joint from P-control step responses (Madill 5.3)")
    fp.add_argument("experiment", help='experiment file (.toml) with [controller] kind = "pd", kp, gain and the reference')
    fp.add_argument("--coordinate", help="the joint to identify (default: the controller's only coordinate)")
    fp.add_argument("--json", action="store_true", help="machine-readable result")
    fp.set_defaults(func=cmd_first_peak)
    u = sub.add_parser("export-urdf", help="write the model as a URDF file (inertials and friction at the parameter values)")
    u.add_argument("model", help="model file (.toml, .urdf) or built-in robot name")
    u.add_argument("--out", metavar="FILE.urdf", required=True, help="the URDF file to write")
    u.set_defaults(func=cmd_export_urdf)
    x = sub.add_parser("export-mjcf", help="write the model as a MuJoCo MJCF file (inertials, armature, damping, "
                       "frictionloss at the parameter values; a motor per coordinate)")
    x.add_argument("model", help="model file (.toml, .urdf) or built-in robot name")
    x.add_argument("--out", metavar="FILE.xml", required=True, help="the MJCF file to write")
    x.set_defaults(func=cmd_export_mjcf)
    for command in (d, g, a, i, s, e, w, u, x):
        command.add_argument("--root", metavar="LINK", help="URDF models: the fixed link the chain starts from (default: the tree's root)")
        command.add_argument("--tip", metavar="LINK", help="URDF models: the last link of the chain (default: the whole tree moves)")
    ls = sub.add_parser("list", help="list the built-in robots")
    ls.set_defaults(func=cmd_list)
    return p


def _located(error: SymbolicError, args: argparse.Namespace) -> str:
    """The error's message, preceded by the data file the command read when the error is about what those data
    can give (an identification or a simulation) and does not name a file itself."""
    data = getattr(args, "data", None) or getattr(args, "experiment", None)
    if error.source is None and data and isinstance(error, (IdentificationError, SimulationError)):
        return f"{data}: {error}"
    return str(error)


def _say_started(args: argparse.Namespace) -> None:
    """The first progress line of a command that reads a model or a campaign, written before SymPy, NumPy or Dask
    are imported (0.5 s or more of CPU): the user sees at once that the command has started."""
    log = logging.getLogger(__name__)
    if getattr(args, "model", None):
        log.info("%s: reading the model", args.model)
    elif getattr(args, "campaign", None):
        log.info("%s: reading the campaign", args.campaign)


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if not args.quiet:
        logging.basicConfig(level=logging.INFO, format="symbolic: %(message)s", stream=sys.stderr)
    warnings.simplefilter("default", ModelWarning)
    warnings.formatwarning = lambda message, category, *rest: f"warning: {message}\n"
    try:
        _say_started(args)
        return args.func(args)
    except SymbolicError as error:  # the user's input or environment: one line, exit 2
        print(f"error: {one_line(_located(error, args))}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: out of memory (the data or the model is too large for this machine)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130  # 128 + SIGINT, what a shell reports for a process ended by Ctrl-C
    except BrokenPipeError:
        # the reader went away (`symbolic list | head`): quiet, as a Unix filter would be; stdout is
        # pointed at /dev/null so that flushing it at exit does not raise again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as error:  # a file the command reads or writes: the system's own message names it
        print(f"error: {one_line(str(error))}", file=sys.stderr)
        return 2
    except Exception:  # noqa: BLE001 - anything else is a bug of symbolic, not of the user's input
        traceback.print_exc()
        print(f"symbolic {__version__}: this is a bug of symbolic, not of your input; please report it with the "
              "command and the files that caused it", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
