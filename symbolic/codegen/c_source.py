"""Generated C (docs/contracts.md, "Generated C"): ``NAME.h`` and ``NAME.c``, C99, no allocation, only <math.h>."""

from __future__ import annotations

import logging
import time

import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.codegen.c_printer import CPrinter, c_double
from symbolic.codegen.exported import (
    batched_programs, function_specs, input_symbols, model_regressor, programs, solved_specs,
)
from symbolic.codegen.naming import check_c_name, comment_text
from symbolic.codegen.templates import render


def c_sources(model: DynamicModel, banner: str) -> dict[str, str]:
    """{file name: text} of the C header and source."""
    name = check_c_name(model.name, model.robot.source)
    symbols = input_symbols(model)
    places = {s: (array, i) for array, group in symbols.items() for i, s in enumerate(group)}
    slots = {s: f"{array}[{i}]" for s, (array, i) in places.items()}
    functions = []
    built = programs(model)
    start = time.perf_counter()
    batched_all = batched_programs(model)
    for spec in function_specs(model):
        batched = batched_all[spec.name]
        program = batched.program
        trig_slots = {s: f"sn[{k}]" for k, s in enumerate(batched.sines)} | {c: f"cs[{k}]" for k, c in enumerate(batched.cosines)}
        printer = CPrinter(slots | trig_slots)
        used = set().union(*(a.free_symbols for a in batched.angles))
        for _, e in program.statements:
            used |= e.free_symbols
        for e in program.outputs:
            used |= e.free_symbols
        unused = [a for a in spec.inputs if not used & set(symbols[a])]
        if not program.outputs:  # nothing to write (a massless model's regressor and theta): no unused parameter
            unused.append(spec.output)
        functions.append(
            {
                "name": spec.name,
                "doc": spec.doc,
                "signature": ", ".join(f"const double *{a}" for a in spec.inputs) + f", double *{spec.output}",
                "layout": ", ".join(_layout(a, model) for a in spec.inputs) + f"; output {spec.output}[{spec.rows * spec.cols}]",
                "operations": built[spec.name].operations,
                "angles": [printer.doprint(a) for a in batched.angles],
                "angle_run": _input_run(batched.angles, places),
                "unused": unused,
                "statements": [{"name": str(s), "value": printer.doprint(e)} for s, e in program.statements],
                "outputs": [{"name": f"{spec.output}[{i}]", "value": printer.doprint(e)} for i, e in enumerate(program.outputs)],
            }
        )
    context = {
        "banner": banner,
        "name": name,
        "guard": f"{name.upper()}_H",
        "description": comment_text(model.robot.description or model.name),
        "nq": model.n,
        "np": len(model.robot.parameters),
        "coordinates": [{"index": i, "name": c} for i, c in enumerate(model.robot.generalized_coordinates)],
        "parameters": [
            {
                "index": i,
                "name": p.name,
                "value": repr(p.value),
                "literal": c_double(sp.Rational(repr(p.value))),
                "unit": comment_text(p.unit),
                "description": comment_text(p.description),
            }
            for i, p in enumerate(model.robot.parameters)
        ],
        "functions": functions,
        "solved": [
            {"name": f.name, "doc": f.doc, "status": f.status,
             "signature": ", ".join(f"const double *{a}" for a in f.inputs) + f", double *{f.output}"}
            for f in solved_specs(model)
        ],
        "end_effector": model.robot.end_effector is not None,
        "time_varying": model.time_varying,
        "theta": [{"index": i, "name": t} for i, t in enumerate(model_regressor(model).names)],
    }
    sources = {f"{name}.h": render("model.h.j2", **context), f"{name}.c": render("model.c.j2", **context)}
    logging.getLogger(__name__).info("%s: C source printed in %.1f s", model.name, time.perf_counter() - start)
    return sources


def _input_run(angles: tuple[sp.Expr, ...], places: dict[sp.Symbol, tuple[str, int]]) -> str | None:
    """``"q + 1"`` when the angles are q[1], q[2], ... in a row (passed to NAME_sincos as they are), else None.

    Passing the caller's array instead of a local copy saves the copy and, for vector loads wider
    than the copy's stores, a failed store-to-load forwarding (about 20 % of Panda's gravity time).
    """
    if not angles or any(a not in places for a in angles):
        return None
    array, first = places[angles[0]]
    if [places[a] for a in angles] != [(array, first + k) for k in range(len(angles))]:
        return None
    return f"{array} + {first}" if first else array


def _layout(array: str, model: DynamicModel) -> str:
    if array == "p":
        return f"p[{len(model.robot.parameters)}] (see {model.name}_parameter_names)"
    if array == "t":
        return "t[1] (time, s)"
    return f"{array}[{model.n}] ({', '.join(model.robot.generalized_coordinates)})"
