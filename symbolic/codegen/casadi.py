"""CasADi functions of a model (docs/contracts.md, "Generated CasADi"): one ``NAME_<function>.casadi`` per function.

Expressions are translated into ``casadi.SX`` by evaluating the same straight-line program as the
C code (SymPy's lambdify with CasADi's functions as the numeric module), so both targets share one
source. Inputs are named q, qd, qdd, tau, p; outputs as in the C ABI. Forward dynamics solves
D q̈ = τ − h − g − k − f; its derivatives are −D⁻¹∂τ/∂(q, q̇) at that q̈ and D⁻¹ (as in the C); the
linearisation A = ∂ẋ/∂x, B = ∂ẋ/∂τ (x = [q; q̇], Madill 3.9.4) is CasADi's exact algorithmic derivative of that.
"""

from __future__ import annotations

import logging
import time

import casadi as ca
import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from symbolic.derivation.dynamics import DynamicModel
from symbolic.codegen.c_printer import FastPrecedence, handle_unevaluated
from symbolic.codegen.exported import (
    SOLVED_INPUT_SIZES, FunctionSpec, function_specs, input_symbols, programs, solved_specs, timed,
)

CASADI_MODULE = {
    "sin": ca.sin,
    "cos": ca.cos,
    "tan": ca.tan,
    "asin": ca.asin,
    "acos": ca.acos,
    "atan": ca.atan,
    "atan2": ca.atan2,
    "sinh": ca.sinh,
    "cosh": ca.cosh,
    "tanh": ca.tanh,
    "sqrt": ca.sqrt,
    "exp": ca.exp,
    "log": ca.log,
    "Abs": ca.fabs,
    "sign": ca.sign,
    "pi": ca.pi,
}


class _CasadiPrinter(FastPrecedence, PythonCodePrinter):
    """lambdify's default printer for a module dictionary, except that sign(x) is a call (the default
    writes a Python conditional, which needs a number, not a CasADi expression)."""

    def __init__(self, large: bool = False) -> None:
        # a large program's sums and products in the order they hold, as in its C (codegen/c_source.py)
        super().__init__({"fully_qualified_modules": False, "inline": True, "allow_unknown_functions": True,
                          "user_functions": {name: name for name in CASADI_MODULE}, **({"order": "none"} if large else {})})

    def _handle_UnevaluatedExpr(self, expr: sp.Expr) -> sp.Expr:
        return handle_unevaluated(expr, super()._handle_UnevaluatedExpr)

    def _print_Mul(self, expr: sp.Mul) -> str:
        return self._fast_print_Mul(expr)

    def _print_sign(self, expr: sp.sign) -> str:
        return f"sign({self._print(expr.args[0])})"


def _to_sx(model: DynamicModel, spec: FunctionSpec, inputs: dict[str, ca.SX]) -> list[ca.SX]:
    """The output arrays of ``spec`` (:attr:`FunctionSpec.arrays`) as CasADi matrices, from its program."""
    symbols = input_symbols(model)
    program = programs(model)[spec.name]
    args = [list(symbols[a]) for a in spec.inputs]
    flat = list(program.outputs)
    fn = sp.lambdify(args, flat, modules=[CASADI_MODULE], printer=_CasadiPrinter(program.large),
                     cse=lambda exprs: (list(program.statements), exprs))
    values = fn(*[[inputs[a][i] for i in range(inputs[a].shape[0])] for a in spec.inputs])
    out, k = [], 0
    for _, rows, cols in spec.arrays:
        matrix = ca.SX(rows, cols)
        for i in range(rows * cols):
            matrix[i // cols, i % cols] = values[k + i]
        out.append(matrix)
        k += rows * cols
    return out


def cholesky_solve(D: ca.SX, b: ca.SX) -> ca.SX:
    """D⁻¹b by the same fixed-size Cholesky factorisation as the generated C (better conditioned than
    CasADi's default symbolic QR for SX, and the two targets then agree to rounding)."""
    return cholesky_solve_columns(D, b)


def cholesky_solve_columns(D: ca.SX, B: ca.SX) -> ca.SX:
    """D⁻¹B for every column of B with one Cholesky factor D = L Lᵀ (L y = b, then Lᵀ x = y; the generated C's order)."""
    L = _lower_factor(D)
    return ca.horzcat(*[ca.vertcat(*_back_substitution(L, _forward_substitution(L, B[:, c]))) for c in range(B.shape[1])])


def _lower_factor(D: ca.SX) -> list[list]:
    """The Cholesky factor L of D = L Lᵀ as nested lists (lower triangle), in the order of the generated C."""
    n = D.shape[0]
    L = [[None] * n for _ in range(n)]
    for j in range(n):
        s = D[j, j]
        for k in range(j):
            s = s - L[j][k] * L[j][k]
        L[j][j] = ca.sqrt(s)
        for i in range(j + 1, n):
            t = D[i, j]
            for k in range(j):
                t = t - L[i][k] * L[j][k]
            L[i][j] = t / L[j][j]
    return L


def _forward_substitution(L: list[list], b: ca.SX) -> list:
    """L⁻¹b for the factor of :func:`_lower_factor`."""
    y = []
    for i in range(len(L)):
        t = b[i]
        for k in range(i):
            t = t - L[i][k] * y[k]
        y.append(t / L[i][i])
    return y


def _back_substitution(L: list[list], y: list) -> list:
    """L⁻ᵀy for the factor of :func:`_lower_factor`."""
    n = len(L)
    x = [None] * n
    for i in reversed(range(n)):
        t = y[i]
        for k in range(i + 1, n):
            t = t - L[k][i] * x[k]
        x[i] = t / L[i][i]
    return x


def handle_functions(inertia: ca.SX, jacobian: ca.SX, u: ca.SX) -> tuple[ca.SX, ca.SX]:
    """(Λ, m_u) at the end effector from D(q) and J(q), with the arithmetic of the generated C:
    W = L⁻¹Jᵀ (D = L Lᵀ), Φ = WᵀW, Λ = Φ⁻¹ by a 3×3 Cholesky factor, m_u = uᵀu/|Wu|²
    (:mod:`symbolic.numeric.operational`)."""
    L = _lower_factor(inertia)
    columns = [ca.vertcat(*_forward_substitution(L, jacobian[c, :].T)) for c in range(3)]
    W = ca.horzcat(*columns)
    phi = ca.mtimes(W.T, W)
    M = _lower_factor(phi)
    R = [[ca.SX(0)] * 3 for _ in range(3)]  # R = M⁻¹ (lower triangular), column by column
    for b in range(3):
        for a in range(b, 3):
            t = ca.SX(1.0 if a == b else 0.0)
            for k in range(b, a):
                t = t - M[a][k] * R[k][b]
            R[a][b] = t / M[a][a]
    Rm = ca.vertcat(*[ca.horzcat(*row) for row in R])
    lam = ca.mtimes(Rm.T, Rm)
    wu = ca.mtimes(W, u)
    mass = ca.dot(u, u) / ca.dot(wu, wu)
    return lam, mass


def casadi_functions(model: DynamicModel) -> dict[str, ca.Function]:
    """{function name: casadi.Function} for every function of the C ABI plus A and B."""
    start = time.perf_counter()
    out = _casadi_functions(model)
    logging.getLogger(__name__).info("%s: %d CasADi functions in %.1f s", model.name, len(out), time.perf_counter() - start)
    return out


def _casadi_functions(model: DynamicModel) -> dict[str, ca.Function]:
    n, n_p = model.n, len(model.robot.parameters)
    inputs = {name: ca.SX.sym(name, n) for name in ("q", "qd", "qdd", "tau")}
    inputs["p"] = ca.SX.sym("p", n_p)
    inputs["t"] = ca.SX.sym("t", 1)
    out: dict[str, ca.Function] = {}
    values: dict[str, ca.SX] = {}
    for spec in function_specs(model):
        arrays = _to_sx(model, spec, inputs)
        values[spec.name] = arrays[0]
        args = [inputs[a] for a in spec.inputs]
        out[spec.name] = ca.Function(spec.name, args, arrays, list(spec.inputs), [a for a, _, _ in spec.arrays])
    q, tau, p = inputs["q"], inputs["tau"], inputs["p"]
    bias = ca.substitute(values["inverse_dynamics"], inputs["qdd"], ca.SX.zeros(n))
    qdd = cholesky_solve(values["inertia"], tau - bias)
    names = list(timed(model, "q", "qd", "tau", "p"))  # with t before p for a time-varying model
    args = [inputs[a] for a in names]
    out["forward_dynamics"] = ca.Function("forward_dynamics", args, [qdd], names, ["qdd"])
    derivatives = _forward_dynamics_derivatives(model, out["inverse_dynamics_derivatives"], inputs, values["inertia"], qdd)
    out["forward_dynamics_derivatives"] = ca.Function("forward_dynamics_derivatives", args, derivatives, names,
                                                      ["dqdd_dq", "dqdd_dqd", "dqdd_dtau"])
    dqdd_dq, dqdd_dqd, dqdd_dtau = derivatives  # A and B of (2), as the C builds them (Madill 3.9.4)
    zero, eye = ca.SX.zeros(n, n), ca.SX.eye(n)
    out["A"] = ca.Function("A", args, [ca.vertcat(ca.horzcat(zero, eye), ca.horzcat(dqdd_dq, dqdd_dqd))], names, ["A"])
    out["B"] = ca.Function("B", args, [ca.vertcat(zero, dqdd_dtau)], names, ["B"])
    solved = {spec.name for spec in solved_specs(model)}
    if {"operational_inertia", "apparent_mass"} <= solved:  # declared with the end effector's Jacobian
        u = ca.SX.sym("u", SOLVED_INPUT_SIZES["u"])
        lam, mass = handle_functions(values["inertia"], values["end_effector_jacobian"], u)
        out["operational_inertia"] = ca.Function("operational_inertia", [q, p], [lam], ["q", "p"], ["Lambda"])
        out["apparent_mass"] = ca.Function("apparent_mass", [q, u, p], [mass], ["q", "u", "p"], ["m"])
    return out


def _forward_dynamics_derivatives(model: DynamicModel, id_derivatives: ca.Function, inputs: dict[str, ca.SX], inertia: ca.SX,
                                  qdd: ca.SX) -> list[ca.SX]:
    """[∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂τ] = [−D⁻¹ ∂τ/∂q, −D⁻¹ ∂τ/∂q̇, D⁻¹], the inverse dynamics derivatives taken at the
    q̈ of forward dynamics (docs/contracts.md, "Derivatives of the dynamics", (2)): the C's equations, solved here
    with one Cholesky factor and triangular solves (the C multiplies by D⁻¹ = RᵀR instead; equal to rounding)."""
    names = timed(model, "q", "qd", "qdd", "p")
    dtau_dq, dtau_dqd = id_derivatives(*[qdd if a == "qdd" else inputs[a] for a in names])
    n = model.n
    solved = cholesky_solve_columns(inertia, ca.horzcat(-dtau_dq, -dtau_dqd, ca.SX.eye(n)))  # one factor for all
    return [solved[:, :n], solved[:, n:2 * n], solved[:, 2 * n:]]


def program_to_sx(sub, outputs: sp.Matrix, groups: list, values: list, module: dict | None = None) -> ca.SX:
    """``outputs`` (expressions in the intermediate symbols of ``sub``) as one CasADi column, the symbols of
    each group in ``groups`` replaced by the entries of the matching CasADi column in ``values``: the same
    straight-line program as the C code and the simulation plant, so CasADi's AD differentiates exactly that.
    ``module`` replaces functions of :data:`CASADI_MODULE` (e.g. ``sign`` by a smooth one)."""
    flat = list(outputs)
    program = sub.program(flat)
    function = sp.lambdify([list(g) for g in groups], flat, modules=[{**CASADI_MODULE, **(module or {})}],
                           printer=_CasadiPrinter(),
                           cse=lambda exprs: (program, exprs))
    return ca.vertcat(*[ca.SX(v) if not isinstance(v, ca.SX) else v
                        for v in function(*[[v[i] for i in range(v.shape[0])] for v in values])])
