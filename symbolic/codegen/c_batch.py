"""A C function evaluating one straight-line program over many samples (for compiled identification).

:func:`batch_source` prints the program of a derivation's intermediates (the base regressor) once,
inside a loop over samples: identification evaluates it at tens of thousands of samples, where a Python
or NumPy loop pays an interpreter cost per statement, while the exported ``NAME_regressor`` evaluates one
sample per call. When it is used and how it is compiled: docs/data.md, "IDIM-LS".
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from symbolic.derivation.subexpressions import Subexpressions
from symbolic.codegen.c_printer import CPrinter


def batch_source(
    name: str,
    sub: Subexpressions,
    varying: Sequence[Sequence[sp.Symbol]],
    fixed: Sequence[sp.Symbol],
    outputs: Sequence[sp.Expr],
) -> str:
    """C99 source of ``name`` evaluating ``outputs`` for each sample.

    .. code-block:: c

        void NAME(long samples, const double *a0, const double *a1, ..., const double *fixed, double *out);

    Varying inputs are ``samples × len(group)`` row-major arrays; the last group (parameters) is the
    same for every sample, and statements that depend on it alone are computed once before the loop.

    Parameters
    ----------
    name : C identifier of the function
    sub : the intermediates ``outputs`` are written in
    varying : per-sample input groups (e.g. q, q̇, q̈), each an array ``samples × len(group)``
    fixed : inputs shared by all samples (the model's parameters)
    outputs : the expressions, written row-major into ``out + sample·len(outputs)``
    """
    outputs = [sp.sympify(e) for e in outputs]
    # no CSE here: the derivation's intermediates already share the work (a SymPy ``cse`` over the
    # Panda's base regressor saves 6 % of the operations and costs 2 s)
    definitions = sub.program(outputs)
    fixed_set = set(fixed)
    slots = {s: f"a{g}[{i}]" for g, group in enumerate(varying) for i, s in enumerate(group)}
    slots |= {s: f"fixed[{i}]" for i, s in enumerate(fixed)}
    constant: set[sp.Symbol] = set()
    hoisted, looped = [], []
    for symbol, expr in definitions:
        if expr.free_symbols <= fixed_set | constant:
            constant.add(symbol)
            hoisted.append((symbol, expr))
        else:
            looped.append((symbol, expr))
    locals_ = {s: f"v{k}" for k, (s, _) in enumerate(hoisted + looped)}
    printer = CPrinter(slots | locals_)
    groups = ", ".join(f"const double *restrict x{g}" for g in range(len(varying)))
    lines = [
        "#include <math.h>",
        "",
        f"void {name}(long samples, {groups}, const double *restrict fixed, double *restrict out)",
        "{",
    ]
    lines += [f"    const double {locals_[s]} = {printer.doprint(e)};" for s, e in hoisted]
    lines += ["    for (long k = 0; k < samples; ++k) {"]
    lines += [f"        const double *a{g} = x{g} + k * {len(group)};" for g, group in enumerate(varying)]
    lines += [f"        double *o = out + k * {len(outputs)};"]
    lines += [f"        const double {locals_[s]} = {printer.doprint(e)};" for s, e in looped]
    lines += [f"        o[{i}] = {printer.doprint(e)};" for i, e in enumerate(outputs)]
    lines += ["    }", "}", ""]
    return "\n".join(lines)
