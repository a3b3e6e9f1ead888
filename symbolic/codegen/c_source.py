"""Generated C (docs/contracts.md, "Generated C"): ``NAME.h`` and ``NAME.c``, C99, no allocation, only <math.h>.

In single precision (``precision="float"``) the same functions, with the same names, compute in ``float``:
``NAME_float.h`` and ``NAME_float.c`` (docs/contracts.md, "Single-precision C").
"""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Callable

import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.products import Product
from symbolic.derivation.subexpressions import symbols_in
from symbolic.codegen.c_printer import PRECISIONS, CPrinter, c_double, c_float, check_precision
from symbolic.codegen.exported import (
    batched_programs, function_specs, input_symbols, model_regressor, programs, solved_specs,
)
from symbolic.codegen.naming import check_c_name, comment_text
from symbolic.codegen.templates import render


DISPATCH_OPERATIONS = 2000
"""Functions of at least this many operations get, on x86-64 built without AVX, a second copy compiled for AVX and
chosen at run time, giving the same bits: why and what it gains, docs/contracts.md ("Generated C"). Smaller
functions gain nothing measurable and are not doubled."""


ALONGSIDE_DERIVATIVES = ("inertia", "inverse_dynamics")
"""The functions that ``NAME_forward_dynamics_derivatives`` (and ``NAME_A``) run in every call together with
``NAME_inverse_dynamics_derivatives`` (D(q) and τ at q̈ = 0 for the q̈ = D⁻¹(τ − h) the derivatives are taken at)."""


def _dispatched(name: str, built: dict) -> bool:
    """Whether function ``name`` gets the AVX copy (:data:`DISPATCH_OPERATIONS`): when it is that long, or when it
    runs alongside a derivative function that has one (:data:`ALONGSIDE_DERIVATIVES`).

    What decides the forward-dynamics derivatives' time is whether the code of all the functions they call fits
    the instruction cache together, and the AVX copies are about a fifth shorter: for the Panda, the three
    functions in AVX instead of only the derivatives take it from 1.66 to 1.52 µs (C harness, gcc -O3).
    """
    long = built[name].operations >= DISPATCH_OPERATIONS
    derivatives = built["inverse_dynamics_derivatives"].operations >= DISPATCH_OPERATIONS
    return long or (name in ALONGSIDE_DERIVATIVES and derivatives)


def c_file_stem(model: DynamicModel, precision: str = "double") -> str:
    """``NAME`` (double) or ``NAME_float``: the name of the generated header and source without extension."""
    return model.name if check_precision(precision) == "double" else f"{model.name}_float"


def c_sources(model: DynamicModel, banner: str, precision: str = "double", accuracy: list[str] | None = None) -> dict[str, str]:
    """{file name: text} of the C header and source.

    Parameters
    ----------
    model : the derived model
    banner : the first comment line of each file
    precision : ``"double"`` (``NAME.h``, ``NAME.c``) or ``"float"`` (``NAME_float.h``, ``NAME_float.c``)
    accuracy : comment lines the float header carries (its measured error against the double functions)

    Returns
    -------
    dict
        File name → text.
    """
    return render_c(c_context(model, precision), banner, accuracy or [])


def render_c(context: dict, banner: str, accuracy: list[str]) -> dict[str, str]:
    """The header and source of a :func:`c_context` under ``banner``, the header with the ``accuracy`` lines."""
    stem = context["stem"]
    context = {**context, "banner": banner, "accuracy": [comment_text(line) for line in accuracy]}
    return {f"{stem}.h": render("model.h.j2", **context), f"{stem}.c": render("model.c.j2", **context)}


def c_context(model: DynamicModel, precision: str = "double") -> dict:
    """What the C templates print, every expression already printed in ``precision`` (printed once per model:
    the float C is printed for the measurement of its error and for the files, with the same text)."""
    return model.products.get(_CONTEXTS[check_precision(precision)])


def _build_context(model: DynamicModel, precision: str) -> dict:
    """The templates' context (without banner and accuracy lines): names, signatures, printed statements."""
    single = precision == "float"
    real = "float" if single else "double"
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
        # a large program's sums and products print in the order they hold (SymPy's canonical order of the
        # derivation's names, fixed by the expressions): sorting each again was half of printing its C
        settings = {"order": "none"} if program.large else None
        printer = CPrinter(slots | trig_slots, settings, precision=precision)
        used = set().union(*(symbols_in(a) for a in batched.angles))
        for _, e in program.statements:
            used |= symbols_in(e)
        for e in program.outputs:
            used |= symbols_in(e)
        unused = [a for a in spec.inputs if not used & set(symbols[a])]
        if not program.outputs:  # nothing to write (a massless model's regressor and theta): no unused parameter
            unused += [array for array, _, _ in spec.arrays]
        functions.append(
            {
                "name": spec.name,
                "doc": spec.doc,
                "signature": _signature(spec.inputs, spec.arrays, real),
                "layout": ", ".join(_layout(a, model) for a in spec.inputs)
                + f"; output{'s' if len(spec.arrays) > 1 else ''} " + ", ".join(f"{a}[{r * c}]" for a, r, c in spec.arrays),
                "operations": built[spec.name].operations,
                "dispatch": _dispatched(spec.name, built),
                "arguments": ", ".join([*spec.inputs, *(array for array, _, _ in spec.arrays)]),
                "angles": [printer.doprint(a) for a in batched.angles],
                "angle_run": _input_run(batched.angles, places),
                "unused": unused,
                "lines": _interleaved(program.statements, program.outputs, _output_slots(spec.arrays), printer.doprint),
            }
        )
    stem = c_file_stem(model, precision)
    context = {
        "name": name,
        "stem": stem,
        "guard": f"{stem.upper()}_H",
        "double_guard": f"{name.upper()}_H",
        "single": single,
        "real": real,
        "fs": "f" if single else "",  # suffix of libm's functions and of literals: sqrtf, 0.0f
        # a Cholesky pivot of J D^-1 J^T below this fraction of its trace is singular: 1e-12 is ~5000
        # double epsilons; in float, rounding alone leaves pivots of ~1e-6 of the trace, hence 1e-5
        "pivot": "1e-5f" if single else "1e-12",
        "description": comment_text(model.robot.description or model.name),
        "nq": model.n,
        "dispatch_operations": DISPATCH_OPERATIONS,
        "np": len(model.robot.parameters),
        "coordinates": [{"index": i, "name": c} for i, c in enumerate(model.robot.generalized_coordinates)],
        "parameters": [
            {
                "index": i,
                "name": p.name,
                "value": repr(p.value),
                "literal": (c_float if single else c_double)(sp.Rational(repr(p.value))),
                "unit": comment_text(p.unit),
                "description": comment_text(p.description),
            }
            for i, p in enumerate(model.robot.parameters)
        ],
        "functions": functions,
        "solved": [
            {"name": f.name, "doc": f.doc, "status": f.status, "signature": _signature(f.inputs, f.arrays, real)}
            for f in solved_specs(model)
        ],
        "end_effector": model.robot.end_effector is not None,
        "time_varying": model.time_varying,
        "theta": [{"index": i, "name": t} for i, t in enumerate(model_regressor(model).names)],
    }
    logging.getLogger(__name__).info("%s: C source printed in %.1f s", model.name, time.perf_counter() - start)
    return context


_CONTEXTS: dict[str, Product[dict]] = {
    precision: Product(f"C text ({precision})", functools.partial(_build_context, precision=precision))
    for precision in PRECISIONS
}


def _signature(inputs: tuple[str, ...], arrays: tuple[tuple[str, int, int], ...], real: str) -> str:
    """``const double *q, ..., double *out1, double *out2``: the inputs, then every output array."""
    return ", ".join([f"const {real} *{a}" for a in inputs] + [f"{real} *{name}" for name, _, _ in arrays])


def _interleaved(statements: tuple[tuple[sp.Symbol, sp.Expr], ...], outputs: tuple[sp.Expr, ...], slots: list[str],
                 doprint: Callable[[sp.Expr], str]) -> list[dict]:
    """The body of a function: its statements in evaluation order, each output written right after the last
    statement it uses (outputs that use none first).

    Written all at the end, every output keeps its operands live to the end of the function: in the Panda's
    ``inverse_dynamics_derivatives`` up to 399 values at once (372 written early; mean live range 287 statements,
    218 written early), nearly all spilled to the stack. Written early, its AVX machine code is 57.3 kB instead
    of 62.0 kB at gcc -O3, short enough to share the instruction cache with ``inertia`` (bench/runtime.py's
    third derivative row: 1.23 µs to 0.64 µs in a C harness) and, with :func:`_dispatched`, a step towards
    the forward-dynamics derivatives' doing so. The same expressions in the same order: the same bits.
    An output is thus written before later inputs are read: output arrays must not overlap inputs
    (docs/contracts.md, "Generated C").

    Returns
    -------
    list of dict
        ``name``, ``value`` (printed) and ``const`` (True for a local, False for an output slot), in order.
    """
    position = {symbol: k for k, (symbol, _) in enumerate(statements)}
    after: dict[int, list[dict]] = {}
    for slot, expr in zip(slots, outputs):
        last = max((position[s] for s in symbols_in(expr) if s in position), default=-1)
        after.setdefault(last, []).append({"name": slot, "value": doprint(expr), "const": False})
    lines = list(after.get(-1, []))
    for k, (symbol, expr) in enumerate(statements):
        lines.append({"name": str(symbol), "value": doprint(expr), "const": True})
        lines += after.get(k, [])
    return lines


def _output_slots(arrays: tuple[tuple[str, int, int], ...]) -> list[str]:
    """``["D[0]", ..., "D[8]"]``: the C lvalue of each flat output, the arrays one after the other."""
    return [f"{name}[{i}]" for name, rows, cols in arrays for i in range(rows * cols)]


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
