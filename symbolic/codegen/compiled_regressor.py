"""The base regressor compiled to a C loop over samples (called through ctypes).

IDIM-LS evaluates the regressor at every sample of a log: 20 000 samples of the Panda are 140 000 rows
of 43 columns. NumPy evaluates the straight-line program statement by statement over whole arrays
(about 0.14 s for the Panda, 500 statements); the same program printed as one C loop
(:func:`symbolic.codegen.c_batch.batch_source`), compiled once per machine (cached, and checked
before it is loaded: :mod:`symbolic.codegen.compiled`), takes about a tenth of that. Without a C
compiler the NumPy evaluator is used; results agree to rounding (tests/test_compiled_regressor.py).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence

import numpy as np
import sympy as sp

from symbolic.derivation.subexpressions import Subexpressions
from symbolic.codegen.c_batch import batch_source
from symbolic.codegen.compiled import load_library

FUNCTION = "symbolic_batch"


def compiled_batch(
    sub: Subexpressions,
    varying: Sequence[Sequence[sp.Symbol]],
    fixed: Sequence[sp.Symbol],
    outputs: sp.Matrix,
    source: str | None = None,
) -> Callable[..., np.ndarray] | None:
    """``evaluate(*varying_arrays, fixed_values) -> samples × outputs.shape``, or ``None`` without a compiler.

    Each varying array is ``samples × len(group)``; ``fixed_values`` has ``len(fixed)`` numbers. ``source``:
    :func:`batch_source` of these arguments with ``FUNCTION``'s name, when the caller kept it (printing it takes
    0.2 s for the Panda, more than loading the compiled library).
    """
    shape = outputs.shape
    flat = list(outputs)
    if source is None:
        source = batch_source(FUNCTION, sub, varying, fixed, flat)
    library = load_library(source, "batch", ctypes.CDLL)
    if library is None:
        return None
    function = getattr(library, FUNCTION)
    function.restype = None
    function.argtypes = [ctypes.c_long] + [ctypes.c_void_p] * (len(varying) + 2)
    widths = [len(group) for group in varying]

    def evaluate(*values: np.ndarray) -> np.ndarray:
        *arrays, p = values
        arrays = [np.ascontiguousarray(a, dtype=float) for a in arrays]
        samples = arrays[0].shape[0]
        for a, width in zip(arrays, widths):
            if a.shape != (samples, width):
                raise ValueError(f"expected an array of {samples} × {width}, got {a.shape}")
        p = np.ascontiguousarray(p, dtype=float)
        if p.shape != (len(fixed),):
            raise ValueError(f"expected {len(fixed)} parameter values, got {p.shape}")
        out = np.empty((samples, len(flat)))
        function(samples, *(a.ctypes.data for a in arrays), p.ctypes.data, out.ctypes.data)
        return out.reshape((samples, *shape))

    return evaluate
