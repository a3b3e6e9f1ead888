"""The error of the single-precision C against the double-precision C, measured (docs/contracts.md,
"Single-precision C").

``symbolic generate --precision float`` states in ``NAME_float.h`` and in the report how far each float
function is from its double twin. The number is measured, not estimated: both sources are compiled with the
system's C compiler (:func:`symbolic.codegen.compiled.load_library`: cached and checked libraries, ``-O1``)
and called through ctypes at :data:`STATES` random states inside the joint limits (:func:`state_ranges`),
drawn with the fixed seed :data:`SEED`. The states are drawn as floats and given to both (so the inputs are the
same numbers); the parameters are the nominal values, as each library holds them (``NAME_parameter_defaults``:
rounded to float in the float one, so that their rounding is part of the error a float controller sees).

The error of a function at a state is ``‖f_float − f_double‖₂ / ‖f_double‖₂`` over all its outputs (the
Frobenius norm for a matrix: relative to the whole matrix, not entry by entry, so that an entry that is zero
up to rounding does not dominate), and its worst error is the maximum over the states.
"""

from __future__ import annotations

import ctypes
import math
import textwrap
from dataclasses import dataclass

import numpy as np

from symbolic.description.joint_limits import coordinate_limits
from symbolic.codegen import compiled
from symbolic.codegen.c_source import c_context, c_file_stem, render_c
from symbolic.codegen.exported import function_specs, solved_specs
from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.products import Product
from symbolic.errors import ExportError

STATES = 1000
"""How many random states the error is measured at."""

SEED = 36
"""Seed of the states (NumPy's PCG64: the same states on every machine)."""

VELOCITY = 2.0
"""|q̇| bound (rad/s or m/s) of a coordinate whose joint gives no velocity limit."""

ACCELERATION = 5.0
"""|q̈| bound (rad/s², m/s²) of every coordinate (URDF has no acceleration limit)."""

PRISMATIC = 0.5
"""|q| bound (m) of a prismatic coordinate without position limits."""

MODAL = 0.01
"""|q| bound of a beam's modal coordinate (physical deflections; tests/test_export.py uses the same)."""

TIME = 10.0
"""Time (s) of a time-varying model, drawn in [0, TIME]."""

UNMEASURED = "a non-zero status at every state"
"""Why a solved function has no figure (e.g. the operational inertia of a robot whose end effector moves in fewer
than three directions: J D^-1 J^T is singular everywhere)."""

NOTED = 1e-5
"""A worst error above this is printed with the size of the output where it occurred (cancellation shows)."""


@dataclass(frozen=True)
class FunctionError:
    """The worst error of one float function against the double one.

    Attributes
    ----------
    name : the function's name without the model prefix (``inertia``)
    worst : max over the states of ‖f_float − f_double‖₂ / ‖f_double‖₂; None when f_double is exactly zero
        at every state or when no state was measured (``states`` 0) (the function has nothing to compute, e.g. the stiffness of a rigid model), ``inf``
        when f_double is zero at a state where f_float is not
    states : the states it was measured at (the solved functions skip those where either library reports
        a non-zero status, e.g. a singular J)
    scale_at_worst : ‖f_double‖ at the state of the worst error
    median_scale : the median of ‖f_double‖ over the states: a worst error at a state where ‖f_double‖ is far
        below it comes from cancellation (the output is a small difference of larger terms, each rounded)
    """

    name: str
    worst: float | None
    states: int
    scale_at_worst: float = 0.0
    median_scale: float = 0.0

    def text(self) -> str:
        """``inertia 3.1e-07`` (two significant digits), ``stiffness 0 (zero)``; above :data:`NOTED`, where."""
        if self.states == 0:
            return f"{self.name} not measured ({UNMEASURED})"
        return f"{self.name} {self.figure()}"

    def figure(self, where: str = "where ||f_double|| is") -> str:
        """The worst error alone: ``3.1e-07``, ``0 (zero)`` (f_double zero everywhere), ``0``, ``not measured``;
        above :data:`NOTED` followed by ``(<where> <:meth:`where`>)``."""
        if self.states == 0:
            return "not measured"
        if self.worst is None:
            return "0 (zero)"
        if self.worst == 0:
            return "0"
        place = self.where()
        return f"{self.worst:.1e}" + (f" ({where} {place})" if place else "")

    def where(self) -> str:
        """Above :data:`NOTED`, the size of ‖f_double‖ at the worst state against its median; else empty."""
        if self.worst is None or self.worst <= NOTED:
            return ""
        if self.scale_at_worst == 0:
            return f"0, its median {self.median_scale:.1e}"
        if self.median_scale == 0:  # zero at most states: no ratio to give
            return f"{self.scale_at_worst:.1e}, its median 0"
        ratio = self.scale_at_worst / self.median_scale
        return f"1/{_rounded(1 / ratio)} of its median" if ratio < 1 else f"{_rounded(ratio)} times its median"


@dataclass(frozen=True)
class FloatAccuracy:
    """The measured error of every function of the float C (:func:`float_accuracy`)."""

    states: int
    seed: int
    errors: tuple[FunctionError, ...]

    def worst(self, name: str) -> float | None:
        """The worst error of function ``name`` (``KeyError`` if it is not generated)."""
        return {e.name: e for e in self.errors}[name].worst

    def summary(self) -> str:
        """One sentence saying what was measured, how, and where (the header and the report print it)."""
        return (f"Worst relative error against the double functions, measured: max over {self.states} random states "
                f"(seed {self.seed}) inside the joint limits of ||f_float - f_double|| / ||f_double|| (2-norm over "
                "all outputs; matrices: Frobenius), inputs the same floats, parameters the nominal values:")

    def lines(self) -> list[str]:
        """:meth:`summary` and the functions' errors, as comment lines of about 100 characters."""
        lines, current = textwrap.wrap(self.summary(), 100), ""
        for error in self.errors:
            item = error.text()
            if current and len(current) + len(item) + 2 > 100:
                lines.append(current + ",")
                current = ""
            current = f"{current}, {item}" if current else f"  {item}"
        return lines + ([current + "."] if current else [])


def _rounded(x: float) -> str:
    """``x`` to two significant digits, without an exponent below a million (5100, 0.75, 1.4e+06)."""
    return f"{float(f'{x:.2g}'):g}"


def state_ranges(model: DynamicModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower and upper bounds of q, and the bound of |q̇|, per coordinate.

    A joint's ``limit`` (lower, upper, velocity) where the model file or URDF gives one; otherwise ±π for a
    rotation, ±:data:`PRISMATIC` for a translation, ±:data:`MODAL` for a beam's modal coordinate, and
    ±:data:`VELOCITY` for the velocity.

    Returns
    -------
    tuple
        ``(lower, upper, velocity)``, arrays of length N.
    """
    declared = coordinate_limits(model.robot)
    lower, upper, velocity = np.empty(model.n), np.empty(model.n), np.full(model.n, VELOCITY)
    for k, name in enumerate(model.robot.generalized_coordinates):
        limits = declared.get(name)
        kind = limits.kind if limits is not None else ("modal" if k >= len(model.robot.coordinates) else "revolute")
        default = {"prismatic": PRISMATIC, "modal": MODAL}.get(kind, math.pi)
        given = limits is not None and limits.lower is not None
        lower[k], upper[k] = (limits.lower, limits.upper) if given else (-default, default)
        velocity[k] = limits.velocity if limits is not None and limits.velocity else VELOCITY  # URDF's 0: not given
    return lower, upper, velocity


def sample_states(model: DynamicModel, count: int = STATES, seed: int = SEED) -> dict[str, np.ndarray]:
    """``count`` states drawn uniformly inside :func:`state_ranges`, as float32 arrays (one row per state).

    Keys: ``q``, ``qd``, ``qdd``, ``t`` (one column; used by time-varying models) and ``u`` (a unit direction,
    for the apparent mass). The draw order is fixed, so the states depend only on the model and the seed.
    """
    rng = np.random.default_rng(seed)
    lower, upper, velocity = state_ranges(model)
    n = model.n
    states = {
        "q": rng.uniform(lower, upper, (count, n)),
        "qd": rng.uniform(-velocity, velocity, (count, n)),
        "qdd": rng.uniform(-ACCELERATION, ACCELERATION, (count, n)),
        "t": rng.uniform(0.0, TIME, (count, 1)),
        "u": rng.normal(size=(count, 3)),
    }
    states["u"] /= np.linalg.norm(states["u"], axis=1, keepdims=True)
    return {key: value.astype(np.float32) for key, value in states.items()}


class _Library:
    """A generated model library of one precision, called through ctypes with NumPy arrays."""

    def __init__(self, library: ctypes.CDLL, name: str, dtype: type, n_p: int) -> None:
        self.library, self.name, self.dtype = library, name, dtype
        self.scalar = ctypes.c_float if dtype is np.float32 else ctypes.c_double
        self.p = np.ctypeslib.as_array((self.scalar * max(n_p, 1)).in_dll(library, f"{name}_parameter_defaults")).copy()

    def call(self, function: str, inputs: list[np.ndarray], size: int | tuple[int, ...], solved: bool = False
             ) -> tuple[np.ndarray, int]:
        """``NAME_function(inputs..., out...)``: the outputs (float64; several output arrays, of the sizes in the
        tuple ``size``, one after the other) and the status a solved function returns (0 for the others)."""
        sizes = (size,) if isinstance(size, int) else size
        pointer = ctypes.POINTER(self.scalar)
        arrays = [np.ascontiguousarray(a, dtype=self.dtype) for a in inputs]
        outs = [np.zeros(max(k, 1), dtype=self.dtype) for k in sizes]
        c_function = getattr(self.library, f"{self.name}_{function}")
        c_function.restype = ctypes.c_int if solved else None
        status = c_function(*[a.ctypes.data_as(pointer) for a in arrays], *[o.ctypes.data_as(pointer) for o in outs])
        return np.concatenate([o[:k] for o, k in zip(outs, sizes)]).astype(np.float64), status or 0


def measure_float_accuracy(model: DynamicModel, count: int = STATES, seed: int = SEED) -> FloatAccuracy:
    """Compile the double and the float C of ``model``, and measure the float's error (module docstring).

    Raises
    ------
    ExportError
        Without a working C compiler (``$CC``, ``cc``, ``gcc`` or ``clang``), which the measurement needs.
    """
    n_p = len(model.robot.parameters)
    double = _Library(_load(model, "double"), model.name, np.float64, n_p)
    single = _Library(_load(model, "float"), model.name, np.float32, n_p)
    states = sample_states(model, count, seed)
    functions = _functions(model)
    _, tau_inputs, _, _ = next(f for f in functions if f[0] == "inverse_dynamics")
    # forward dynamics is given the τ the double model needs for the drawn q̈ (rounded to float, as a float
    # controller would hold it), so that its q̈ is of the size the states say
    states["tau"] = np.array([double.call("inverse_dynamics", _inputs(tau_inputs, states, k, double.p), model.n)[0]
                              for k in range(count)]).astype(np.float32)
    errors = tuple(_function_error(f, states, double, single, count) for f in functions)
    return FloatAccuracy(count, seed, errors)


def _functions(model: DynamicModel) -> list[tuple[str, tuple[str, ...], tuple[int, ...], bool]]:
    """(name, inputs, output sizes, returns a status) of every generated function, in the header's order."""
    out = [(s.name, s.inputs, tuple(r * c for _, r, c in s.arrays), False) for s in function_specs(model)]
    return out + [(s.name, s.inputs, tuple(r * c for _, r, c in s.arrays), True) for s in solved_specs(model)]


def _inputs(names: tuple[str, ...], states: dict, k: int, p: np.ndarray) -> list[np.ndarray]:
    """The arrays a function of inputs ``names`` takes at state ``k`` (``p``: the library's own defaults)."""
    return [p if a == "p" else states[a][k] for a in names]


def _function_error(function: tuple[str, tuple[str, ...], tuple[int, ...], bool], states: dict, double: _Library, single: _Library,
                    count: int) -> FunctionError:
    """The worst relative error of one function over the states (module docstring)."""
    name, names, size, solved = function
    scales, errors = [], []
    for k in range(count):
        reference, status_double = double.call(name, _inputs(names, states, k, double.p), size, solved)
        value, status_single = single.call(name, _inputs(names, states, k, single.p), size, solved)
        if solved and (status_double != 0 or status_single != 0):
            continue  # no output to compare (D not positive definite, J singular): the status says so
        scale, difference = float(np.linalg.norm(reference)), float(np.linalg.norm(value - reference))
        scales.append(scale)
        errors.append(difference / scale if scale > 0 else (0.0 if difference == 0 else math.inf))
    if not errors or (max(scales) == 0 and max(errors) == 0):
        return FunctionError(name, None, len(errors))
    worst = int(np.argmax(errors))
    return FunctionError(name, errors[worst], len(errors), scales[worst], float(np.median(scales)))


def _load(model: DynamicModel, precision: str) -> ctypes.CDLL:
    """The model's C of ``precision`` as one translation unit, compiled (cached) and loaded."""
    files = render_c(c_context(model, precision), "the single-precision C's accuracy measured (symbolic.codegen.c_accuracy)", [])
    stem = c_file_stem(model, precision)
    include = f'#include "{stem}.h"\n'
    if include not in files[f"{stem}.c"]:  # a template change would otherwise surface as "no C compiler"
        raise RuntimeError(f"{stem}.c does not include {stem}.h: the one translation unit cannot be formed")
    text = files[f"{stem}.c"].replace(include, files[f"{stem}.h"], 1)
    library = compiled.load_library(text, f"{model.name}_{precision}", ctypes.CDLL)
    if library is None:
        raise ExportError("--precision float: the float C's error against the double C is measured by compiling both, "
                          f"and the {precision} C of {model.name} could not be compiled and loaded: no C compiler ($CC, "
                          "cc, gcc or clang on the PATH), or see the warning above")
    return library


FLOAT_ACCURACY: Product[FloatAccuracy] = Product("float accuracy", measure_float_accuracy)


def float_accuracy(model: DynamicModel) -> FloatAccuracy:
    """:func:`measure_float_accuracy` of ``model`` at :data:`STATES` states, measured once per model."""
    return model.products.get(FLOAT_ACCURACY)


__all__ = ["FloatAccuracy", "FunctionError", "SEED", "STATES", "float_accuracy", "measure_float_accuracy",
           "sample_states", "state_ranges"]
