"""The C printer against Python: expressions with powers in numerators and denominators, exact decimals,
compiled with gcc and evaluated through ctypes (a precedence bug here once printed a/x**4 as a/x*x*x*x)."""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np
import sympy as sp

from c_library import compile_shared
from symbolic.codegen.c_printer import CPrinter, c_double

x, y, z = sp.symbols("x y z", real=True)
EXPRESSIONS = [
    x / y**4,
    x**3 / (y**2 + 1),
    1 / y**2,
    -(x**2) * y / z**3,
    sp.Rational(33, 400) * x - sp.Rational(1, 3) * y,
    sp.sqrt(z) * x**2 / (y**3 * z**2),
    sp.sin(x) ** 2 + sp.cos(y) ** 3 / x,
    (x + y) ** 2 / (x - y) ** 2,
    x ** sp.Rational(3, 2) / y,
    sp.E * x + sp.pi / y,  # constants as literals: M_E and M_PI are POSIX, not C99
]


def test_printed_expressions_evaluate_like_python(tmp_path: Path) -> None:
    printer = CPrinter({x: "a[0]", y: "a[1]", z: "a[2]"})
    body = "\n".join(f"    out[{i}] = {printer.doprint(e)};" for i, e in enumerate(EXPRESSIONS))
    source = tmp_path / "exprs.c"
    source.write_text(f"#include <math.h>\nvoid f(const double *a, double *out);\nvoid f(const double *a, double *out)\n{{\n{body}\n}}\n")
    lib = ctypes.CDLL(str(compile_shared(source, tmp_path / "libexprs.so")))
    rng = np.random.default_rng(0)
    for _ in range(50):
        a = rng.uniform(0.3, 2.0, 3)
        out = np.zeros(len(EXPRESSIONS))
        pointer = ctypes.POINTER(ctypes.c_double)
        lib.f(a.ctypes.data_as(pointer), out.ctypes.data_as(pointer))
        expected = [float(e.subs({x: a[0], y: a[1], z: a[2]})) for e in EXPRESSIONS]
        np.testing.assert_allclose(out, expected, rtol=1e-14)


def test_exact_decimals() -> None:
    assert c_double(sp.Rational(33, 400)) == "0.0825"
    assert c_double(sp.Rational(-1, 8)) == "-0.125"
    assert c_double(sp.Integer(3)) == "3.0"
    assert float(c_double(sp.Rational(1, 3))) == 1 / 3


def test_outputs_are_written_right_after_the_last_statement_they_use() -> None:
    """c_source._interleaved: an output that uses no local comes first, the others right after their last
    local; the statements keep their order (docs/contracts.md, "Generated C": outputs written early)."""
    from symbolic.codegen.c_source import _interleaved

    v0, v1, v2 = sp.symbols("v0 v1 v2", real=True)
    statements = ((v0, x * y), (v1, v0 + z), (v2, v1 * v0))
    outputs = (v2 + 1, v0 * z, x + 2, v1 - v0)
    lines = _interleaved(statements, outputs, ["o[0]", "o[1]", "o[2]", "o[3]"], str)
    assert [line["name"] for line in lines] == ["o[2]", "v0", "o[1]", "v1", "o[3]", "v2", "o[0]"]
    assert [line["const"] for line in lines] == [False, True, False, True, False, True, False]
