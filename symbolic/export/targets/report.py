"""The Markdown report NAME.md, with the apparent-mass figure NAME_apparent_mass.png on request
(docs/contracts.md, "Generated report")."""

from __future__ import annotations

import logging
import time
import warnings
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from symbolic.derivation.dynamics import DynamicModel

SUMMARY = "Markdown report (NAME.md): D(Q), Christoffel symbols, gravity, friction, decoupling conditions"


def render(model: DynamicModel, head: str, figures: bool, precision: str = "double") -> dict[str, bytes]:
    """``figures``: also ``NAME_apparent_mass.png`` for a model with an end effector
    (:mod:`symbolic.export.apparent_mass_figure`; needs matplotlib), linked from the report. ``precision="float"``:
    a section with the float C's error against the double C (:func:`symbolic.codegen.c_accuracy.float_accuracy`)."""
    from symbolic.codegen.exported import batched_programs, programs
    from symbolic.derivation.analysis import decoupling
    from symbolic.errors import ModelWarning
    from symbolic.export.markdown import SMALL_MODEL, report_markdown
    from symbolic.version import __version__

    start = time.perf_counter()
    files: dict[str, bytes] = {}
    batched = batched_programs(model)
    ops = {name: (p.operations, len(batched[name].angles)) for name, p in programs(model).items()}
    analysis = None
    if model.n <= SMALL_MODEL:  # larger models: `symbolic analyze` (minutes of simplification)
        analysis = decoupling(model, kinds=["decoupling", "constant_inertia", "balancing"])
    figure = None
    if figures and model.robot.end_effector is not None:
        from symbolic.export.apparent_mass_figure import NoFigure, file_name, png

        try:
            files[file_name(model)] = png(model)
            figure = file_name(model)
        except NoFigure as why:  # nothing to draw: no figure, no link, and the reason
            warnings.warn(f"no apparent-mass figure: {why}", ModelWarning, stacklevel=3)
    accuracy = None
    if precision == "float":
        from symbolic.codegen.c_accuracy import float_accuracy

        accuracy = float_accuracy(model)
    files[f"{model.name}.md"] = report_markdown(model, head, ops, __version__, analysis, figure, accuracy).encode()
    logging.getLogger("symbolic.export").info("%s: report in %.1f s", model.name, time.perf_counter() - start)
    return files
