"""Printed constants are exact values rounded once, so generated code is the same on every machine.

Modal constants of beams used to come from numpy/scipy/libm (cosh, sin, brentq), whose last bit
differs between processors: `make check-generated` failed on another x86-64 machine (0.43393589511071917
against 0.4339358951107193). Now they are computed with mpmath at mode_shapes.PRECISION digits and
rounded to a double when printed. Checked here: (1) the generated C and report print the same
constants when the precision goes from 50 to 80 digits, i.e. every printed constant is the double
nearest to its exact value, not an artefact of the working precision; (2) the modal constants in the committed C equal
the nearest doubles of an independent mpmath computation (100 digits, other root bracketing, other
form of the characteristic equation); (3) generating the flexible models calls no numpy, scipy or
math transcendental function at all.
"""

from __future__ import annotations

import math
import re
import warnings
from fractions import Fraction
from functools import lru_cache
from pathlib import Path

import mpmath
import numpy as np
import pytest
import scipy.optimize
import sympy as sp

import symbolic
import symbolic.export as export
from symbolic.derivation import mode_shapes

GENERATED = Path(__file__).resolve().parents[1] / "generated"
FLEXIBLE = ["single_flexible_link", "madill_beam", "fivebar_flexible"]
LITERAL = re.compile(r"(?<![\w.])\d+\.\d+(?:e[-+]?\d+)?")


def load(name: str) -> symbolic.Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return symbolic.robots.load(name)


def nearest_double(value: mpmath.mpf) -> float:
    """Round an mpmath number to the nearest double exactly (Fraction division rounds correctly)."""
    sign, mantissa, exponent, _ = value._mpf_
    exact = Fraction(int(mantissa)) * (Fraction(2) ** int(exponent))
    return float(-exact if sign else exact)


@lru_cache(maxsize=None)
def reference_constants(n: int = 3) -> dict[float, str]:
    """Doubles nearest to r·c for each modal constant c of the first n modes and small rationals r.

    c is 1, σᵢ/kᵢ (α), 1/kᵢ² (β) or kᵢ⁴ (Λ); kᵢ from cos k cosh k = −1 and σᵢ in its equivalent form
    (sinh k − sin k)/(cosh k + cos k), at 100 digits (the package uses 50 digits, cos k + 1/cosh k = 0
    and (cosh k + cos k)/(sinh k + sin k)). Products with rationals are the l³/3, 2α, 12β of the equations.
    """
    out: dict[float, str] = {}
    with mpmath.workdps(100):
        bases = {"1": mpmath.mpf(1)}
        for i in range(1, n + 1):
            guess = (2 * i - 1) * mpmath.pi / 2 + (mpmath.mpf("0.3") if i == 1 else 0)
            k = mpmath.findroot(lambda k: mpmath.cos(k) * mpmath.cosh(k) + 1, guess)
            sigma = (mpmath.sinh(k) - mpmath.sin(k)) / (mpmath.cosh(k) + mpmath.cos(k))
            bases |= {f"sigma{i}/k{i}": sigma / k, f"1/k{i}^2": 1 / k**2, f"k{i}^4": k**4}
        for name, base in bases.items():
            for p in range(1, 49):
                for q in range(1, 49):
                    out.setdefault(nearest_double(base * p / q), f"{p}/{q}*{name}")
    return out


@pytest.mark.slow
def test_printed_constants_do_not_depend_on_the_working_precision(monkeypatch) -> None:
    """At 80 digits the C and the report print the same constants as the committed files (made at 50).

    The constants are compared as sets, not the files byte for byte: SymPy orders terms by the
    Floats' exact values, so the order of intermediate statements (not their values) may change with
    the working precision; at a fixed precision it is fixed, like the constants themselves.
    """
    digits = []
    exact_modes = mode_shapes.exact_modes

    def spy(n: int, precision: int):
        digits.append(precision)
        return exact_modes(n, precision)

    monkeypatch.setattr(mode_shapes, "exact_modes", spy)
    monkeypatch.setattr(mode_shapes, "PRECISION", 80)
    monkeypatch.setenv("SYMBOLIC_NO_CACHE", "1")  # derived again at 80 digits, not read back from the cache
    for name in FLEXIBLE:
        targets = ["c"] if name == "fivebar_flexible" else ["c", "report"]  # that report takes seconds
        files = export.render(symbolic.derive(load(name)), targets, command="make generate")
        for file, content in files.items():
            if file.endswith((".c", ".md")):
                ours, committed = content.decode(), (GENERATED / name / file).read_text()
                assert set(LITERAL.findall(ours)) == set(LITERAL.findall(committed)), f"{file}: other constants at 80 digits"
    assert digits and set(digits) == {80}


def test_constants_in_generated_c_are_the_nearest_doubles() -> None:
    """Every literal of the flexible models' C is an independently computed constant rounded once,
    a decimal of the model file (printed exactly) or a constant of the fixed sincos kernel."""
    reference = reference_constants()
    kernel = set(LITERAL.findall((GENERATED / "fivebar" / "fivebar.c").read_text()))  # a model without beams
    modal = 0
    for name in FLEXIBLE:
        for text in set(LITERAL.findall((GENERATED / name / f"{name}.c").read_text())) - kernel:
            if len(text.replace(".", "").strip("0")) <= 10:
                continue  # a short decimal: the model file's number, printed exactly (c_double)
            assert float(text) in reference, f"{name}.c: {text} is not the double nearest to an exact constant"
            modal += "k" in reference[float(text)]
    assert modal >= 15
    printed = LITERAL.findall((GENERATED / "single_flexible_link" / "single_flexible_link.c").read_text())
    for key in ("2/1*sigma1/k1", "2/1*sigma2/k2", "2/1*1/k1^2", "2/1*1/k2^2", "1/1*k1^4", "1/1*k2^4"):  # α, β, Λ
        assert any(reference.get(float(t)) == key for t in printed), key


def test_generation_calls_no_numpy_scipy_or_libm_transcendental(monkeypatch) -> None:
    """Derive and render the small flexible models (and emps, with friction laws) with those functions
    replaced by ones that fail; the output is still the committed one."""

    def forbidden(*args, **kwargs):
        raise AssertionError("a numpy/scipy/libm transcendental function was called")

    # SymPy's lambdify copies math's and numpy's functions into a namespace cached for the process on
    # first use: loaded here before the patch, so that derive's value check (an evaluation of the
    # equations, not generation) keeps the real functions, and no later test in this worker inherits
    # the failing stand-ins, whatever the order the tests run in.
    for module in ("math", "numpy"):
        sp.lambdify([], 0, modules=module)

    for function in ("sin", "cos", "tan", "sinh", "cosh", "tanh", "exp", "log", "arctan2", "power", "sqrt"):
        monkeypatch.setattr(np, function, forbidden)
    for module in (math, cmath := __import__("cmath")):  # libm through Python, as the package's own modules see it
        for function in ("sin", "cos", "tan", "sinh", "cosh", "tanh", "exp"):
            monkeypatch.setattr(module, function, forbidden)
    monkeypatch.setattr(scipy.optimize, "brentq", forbidden)
    monkeypatch.setenv("SYMBOLIC_NO_CACHE", "1")  # the derivation itself runs under the patch
    mode_shapes.exact_modes.cache_clear()
    try:
        for name in ("single_flexible_link", "madill_beam", "emps"):
            files = export.render(symbolic.derive(load(name)), ["c", "report"], command="make generate")
            assert files[f"{name}.c"] == (GENERATED / name / f"{name}.c").read_bytes()
    finally:
        mode_shapes.exact_modes.cache_clear()
