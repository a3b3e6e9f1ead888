"""Numerical evaluation of derived expressions (for tests, simulation and linearisation).

Expressions in intermediate symbols are turned into Python functions by :func:`sympy.lambdify`,
passing the intermediate definitions as its common-subexpression list, so evaluation follows the
same straight-line program the code generators print.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import sympy as sp

from symbolic.derivation.subexpressions import Subexpressions


def _lambdified(sub: Subexpressions, arguments, outputs, shape, module: str):
    """lambdify of ``outputs`` with the intermediates' straight-line program as its CSE list; the flat
    outputs and the result shape (default that of ``outputs``, a column giving 1-D)."""
    matrix = sp.Matrix(outputs)
    if shape is None:
        shape = matrix.shape if matrix.shape[1] != 1 else (matrix.shape[0],)
    flat = list(matrix)
    program = sub.program(flat)
    symbols = [list(group) for group in arguments]
    return sp.lambdify(symbols, flat, modules=module, cse=lambda exprs: (program, exprs)), flat, shape


def compile_function(
    sub: Subexpressions,
    arguments: Sequence[Sequence[sp.Symbol]],
    outputs: sp.Matrix | Sequence[sp.Expr],
    shape: tuple[int, ...] | None = None,
) -> Callable[..., np.ndarray]:
    """A function of array arguments (one per group of symbols) returning ``outputs`` as an array.

    The returned array has ``shape``; by default that of ``outputs``, a column giving a 1-D array
    (pass ``shape=(n, n)`` for a matrix that may be 1×1).
    """
    raw, flat, shape = _lambdified(sub, arguments, outputs, shape, "math")
    sizes = [len(group) for group in arguments]
    names = [", ".join(s.name for s in group[:3]) + (", …" if len(group) > 3 else "") for group in arguments]

    def function(*values: Sequence[float]) -> np.ndarray:
        flat_values = [list(map(float, np.ravel(v))) for v in values]
        if len(flat_values) != len(sizes) or any(len(v) != k for v, k in zip(flat_values, sizes)):
            given = [len(v) for v in flat_values]
            wanted = "; ".join(f"{k} ({n})" for k, n in zip(sizes, names))
            raise ValueError(f"expected arguments of sizes {wanted}, got sizes {given}")
        result = raw(*flat_values)
        return np.array(result, dtype=float).reshape(shape)

    return function


def compile_vectorized(
    sub: Subexpressions,
    arguments: Sequence[Sequence[sp.Symbol]],
    outputs: sp.Matrix | Sequence[sp.Expr],
    shape: tuple[int, ...] | None = None,
) -> Callable[..., np.ndarray]:
    """Like :func:`compile_function`, evaluated on many samples at once with NumPy.

    Each argument is an array ``samples × len(group)`` (a group that does not vary, such as the
    parameters, may be a 1-D array); the result is ``samples × shape``. The straight-line program runs
    once, each statement on whole arrays, so the Python overhead is paid per statement, not per sample.
    """
    raw, flat, shape = _lambdified(sub, arguments, outputs, shape, "numpy")

    def function(*values) -> np.ndarray:
        arrays = [np.asarray(v, dtype=float) for v in values]
        samples = max((a.shape[0] for a in arrays if a.ndim == 2), default=1)
        columns = [[a[:, k] if a.ndim == 2 else a[k] for k in range(a.shape[-1])] for a in arrays]
        out = np.empty((samples, len(flat)))
        for k, value in enumerate(raw(*columns)):
            out[:, k] = value  # constants broadcast
        return out.reshape((samples, *shape))

    return function
