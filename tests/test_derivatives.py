"""Derivatives of the dynamics in the generated C and CasADi (docs/contracts.md, "Derivatives of the dynamics").

``NAME_inverse_dynamics_derivatives``, ``NAME_forward_dynamics_derivatives``, ``NAME_A`` and ``NAME_B``, compiled
with gcc and the strict flags and called through ctypes, and the ``.casadi`` files loaded by casadi itself, against
two independent references:

* Pinocchio's ``computeRNEADerivatives`` and ``computeABADerivatives`` on the Panda and the PUMA 560 (built from
  the same DH numbers by tests/reference_pinocchio.py) and on the UR5 of example-robot-data (Pinocchio parses the
  URDF itself): ‖ours − Pinocchio‖ ≤ 1e-9 ‖Pinocchio‖ (Frobenius);
* central differences of the generated inverse and forward dynamics, on the same robots and on every built-in robot
  (closed loops, beams, friction, drives): ‖ours − differences‖ ≤ 1e-6 ‖differences‖ + the differences' own
  rounding, 10·ε·max|f|·√(entries)/h. Step h = 1e-4 in q (truncation h²/6 times a third derivative: ~1e-11 relative
  here) and 1e-2 in q̇ and τ: τ is quadratic in q̇ and q̈ affine in τ (friction apart, whose Coulomb sign is constant
  while |q̇| > h), so central differences are exact there up to rounding, and rounding is what limits them: a beam's
  elastic forces are ~10⁴ where ∂τ/∂q̇ is ~10⁻² (at h = 1e-6 the rounding alone is ~1e-5 of the derivative).

States: angles uniform in [−π, π] (beams' modal coordinates in [−0.01, 0.01]), velocities and accelerations in
[−2, 2] (|q̇| at least 0.1), τ the inverse dynamics of those accelerations.
"""

from __future__ import annotations

import ctypes
import platform
import subprocess
import warnings
from pathlib import Path

import casadi
import numpy as np
import pytest

import symbolic
import symbolic.export as export
from c_library import STRICT, CModel, compile_shared
from conftest import derived
from reference_pinocchio import Reference, UrdfReference, require_pinocchio

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "generated"
PINOCCHIO_RTOL = 1e-9
DIFFERENCE_RTOL = 1e-6
STEP = 1e-4
"""Central differences' step in q."""
RATE_STEP = 1e-2
"""Central differences' step in q̇ and τ (module docstring)."""
UR5 = "ur_description/urdf/ur5_robot.urdf"
BUILT_IN = ["fivebar", "puma560", "panda", "janot_branch", "omni", "single_flexible_link", "madill_beam", "fivebar_flexible", "emps"]


def close(ours: np.ndarray, reference: np.ndarray, rtol: float, floor: float = 0.0) -> None:
    error = np.linalg.norm(np.asarray(ours) - reference)
    assert error <= rtol * np.linalg.norm(reference) + floor, f"relative error {error / np.linalg.norm(reference):.3e}"


def differences_close(ours: np.ndarray, differences: tuple[np.ndarray, float]) -> None:
    """``ours`` against central differences and their rounding (:func:`central_differences`)."""
    close(ours, differences[0], DIFFERENCE_RTOL, differences[1])


class Derivatives(CModel):
    """The generated C's derivative functions (each output an N×N or 2N×… row-major array)."""

    def _outputs(self, function: str, inputs, shapes: list[tuple[int, int]]) -> tuple[list[np.ndarray], int]:
        pointer = ctypes.POINTER(ctypes.c_double)
        args = [np.ascontiguousarray(x, dtype=float) for x in inputs]
        outs = [np.full(rows * cols, np.nan) for rows, cols in shapes]
        fn = getattr(self.lib, f"{self.name}_{function}")
        fn.restype = None if function == "inverse_dynamics_derivatives" else ctypes.c_int
        status = fn(*[a.ctypes.data_as(pointer) for a in args], *[o.ctypes.data_as(pointer) for o in outs])
        return [o.reshape(shape) for o, shape in zip(outs, shapes)], status or 0

    def id_derivatives(self, q, qd, qdd, p) -> list[np.ndarray]:
        return self._outputs("inverse_dynamics_derivatives", [q, qd, qdd, p], [(self.n, self.n)] * 2)[0]

    def fd_derivatives(self, q, qd, tau, p) -> list[np.ndarray]:
        outs, status = self._outputs("forward_dynamics_derivatives", [q, qd, tau, p], [(self.n, self.n)] * 3)
        assert status == 0
        return outs

    def state_matrices(self, q, qd, tau, p) -> tuple[np.ndarray, np.ndarray]:
        (A,), status_a = self._outputs("A", [q, qd, tau, p], [(2 * self.n, 2 * self.n)])
        (B,), status_b = self._outputs("B", [q, qd, tau, p], [(2 * self.n, self.n)])
        assert status_a == status_b == 0
        return A, B


def central_differences(f, x: np.ndarray, h: float | np.ndarray = STEP) -> tuple[np.ndarray, float]:
    """[∂f/∂x_j] by central differences of step h (one per x_j, or one for all), and the size of their rounding in
    the Frobenius norm, 10·ε·max|f|·√(entries)/min h (f(x) a vector)."""
    steps = np.broadcast_to(h, x.shape)
    columns, largest = [], 0.0
    for j in range(len(x)):
        step = np.zeros(len(x))
        step[j] = steps[j]
        after, before = f(x + step), f(x - step)
        columns.append((after - before) / (2 * steps[j]))
        largest = max(largest, np.abs(after).max(initial=0.0), np.abs(before).max(initial=0.0))
    J = np.array(columns).T
    return J, 10 * np.finfo(float).eps * largest * np.sqrt(J.size) / steps.min()


def states(model: symbolic.DynamicModel, count: int, seed: int):
    """(q, q̇, q̈) at random: |q̇| in [0.1, 2] (away from Coulomb friction's switch; module docstring)."""
    amplitude = np.array([0.01 if ("_nu" in c or "_eta" in c) else np.pi for c in model.robot.generalized_coordinates])
    rng = np.random.default_rng(seed)
    for _ in range(count):
        speed = rng.uniform(0.1, 2, model.n) * rng.choice([-1.0, 1.0], model.n)
        yield amplitude * rng.uniform(-1, 1, model.n), speed, rng.uniform(-2, 2, model.n)


# -- the libraries and references ------------------------------------------------------------------------------------
def ur5_path() -> Path:
    from test_urdf import robots_folder

    return robots_folder() / UR5


@pytest.fixture(scope="module")
def arms(tmp_path_factory) -> dict:
    """name → (model, C library, {function: casadi.Function}, Pinocchio reference): Panda and PUMA 560 from
    generated/, the UR5 generated here from its URDF."""
    require_pinocchio()
    out = tmp_path_factory.mktemp("derivatives")
    found = {}
    for name in ("panda", "puma560"):
        model = derived(name)
        found[name] = (model, GENERATED / name, Reference(model.robot))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        robot = symbolic.load(ur5_path())
    model = symbolic.derive(robot)
    export.generate(model, out / "ur5", targets=["c", "casadi"])
    found["ur5"] = (model, out / "ur5", UrdfReference(ur5_path(), robot.coordinates))
    return {name: (model, _library(model, folder, out), _casadi(model.name, folder), reference)
            for name, (model, folder, reference) in found.items()}


def _library(model: symbolic.DynamicModel, folder: Path, out: Path) -> Derivatives:
    library = compile_shared(folder / f"{model.name}.c", out / f"lib{model.name}.so", STRICT)
    return Derivatives(library, model.name, model.n, len(model.robot.parameters))


def _casadi(name: str, folder: Path) -> dict[str, casadi.Function]:
    return {f: casadi.Function.load(str(folder / f"{name}_{f}.casadi"))
            for f in ("inverse_dynamics_derivatives", "forward_dynamics_derivatives", "A", "B")}


ARMS = ["panda", "puma560", "ur5"]


# -- against Pinocchio --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ARMS)
def test_c_derivatives_match_pinocchio(name: str, arms) -> None:
    model, c, _, reference = arms[name]
    p = c.defaults
    for q, qd, qdd in states(model, 20, seed=36):
        dtau_dq, dtau_dqd = c.id_derivatives(q, qd, qdd, p)
        pin_dq, pin_dqd = reference.rnea_derivatives(q, qd, qdd)
        close(dtau_dq, pin_dq, PINOCCHIO_RTOL)
        close(dtau_dqd, pin_dqd, PINOCCHIO_RTOL)
        tau = reference.rnea(q, qd, qdd)
        dqdd_dq, dqdd_dqd, dqdd_dtau = c.fd_derivatives(q, qd, tau, p)
        pin_dq, pin_dqd, minv = reference.aba_derivatives(q, qd, tau)
        close(dqdd_dq, pin_dq, PINOCCHIO_RTOL)
        close(dqdd_dqd, pin_dqd, PINOCCHIO_RTOL)
        close(dqdd_dtau, minv, PINOCCHIO_RTOL)
        A, B = c.state_matrices(q, qd, tau, p)
        n = model.n
        close(A, np.block([[np.zeros((n, n)), np.eye(n)], [pin_dq, pin_dqd]]), PINOCCHIO_RTOL)
        close(B, np.vstack([np.zeros((n, n)), minv]), PINOCCHIO_RTOL)


@pytest.mark.parametrize("name", ARMS)
def test_casadi_derivatives_match_pinocchio(name: str, arms) -> None:
    model, c, functions, reference = arms[name]
    p = c.defaults
    for q, qd, qdd in states(model, 5, seed=37):
        dq, dqd = (np.array(x) for x in functions["inverse_dynamics_derivatives"](q, qd, qdd, p))
        pin_dq, pin_dqd = reference.rnea_derivatives(q, qd, qdd)
        close(dq, pin_dq, PINOCCHIO_RTOL)
        close(dqd, pin_dqd, PINOCCHIO_RTOL)
        tau = reference.rnea(q, qd, qdd)
        ours = [np.array(x) for x in functions["forward_dynamics_derivatives"](q, qd, tau, p)]
        for mine, theirs in zip(ours, reference.aba_derivatives(q, qd, tau)):
            close(mine, theirs, PINOCCHIO_RTOL)
        A, B = c.state_matrices(q, qd, tau, p)
        close(np.array(functions["A"](q, qd, tau, p)), A, PINOCCHIO_RTOL)
        close(np.array(functions["B"](q, qd, tau, p)), B, PINOCCHIO_RTOL)


# -- against finite differences ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ARMS)
def test_arm_derivatives_match_finite_differences(name: str, arms) -> None:
    model, c, _, _ = arms[name]
    check_differences(model, c)


@pytest.fixture(scope="module")
def built_in(tmp_path_factory) -> dict[str, Derivatives]:
    out = tmp_path_factory.mktemp("built_in")
    return {name: _library(derived(name), GENERATED / name, out) for name in BUILT_IN}


@pytest.mark.parametrize("name", BUILT_IN)
def test_built_in_derivatives_match_finite_differences(name: str, built_in) -> None:
    """Closed loops (Lᵀ of Janot (12)), beams, friction and drives are differentiated through as τ is built."""
    check_differences(derived(name), built_in[name], count=3)


def check_differences(model: symbolic.DynamicModel, c: Derivatives, count: int = 5) -> None:
    """Every derivative function against central differences of the generated inverse and forward dynamics."""
    p = c.defaults
    forward = lambda q, qd, tau: c.forward_dynamics(q, qd, tau, p)[0]  # noqa: E731
    for q, qd, qdd in states(model, count, seed=38):
        dtau_dq, dtau_dqd = c.id_derivatives(q, qd, qdd, p)
        differences_close(dtau_dq, central_differences(lambda x: c.inverse_dynamics(x, qd, qdd, p), q))
        differences_close(dtau_dqd, central_differences(lambda x: c.inverse_dynamics(q, x, qdd, p), qd, RATE_STEP))
        tau = c.inverse_dynamics(q, qd, qdd, p)
        dqdd_dq, dqdd_dqd, dqdd_dtau = c.fd_derivatives(q, qd, tau, p)
        differences_close(dqdd_dq, central_differences(lambda x: forward(x, qd, tau), q))
        differences_close(dqdd_dqd, central_differences(lambda x: forward(q, x, tau), qd, RATE_STEP))
        differences_close(dqdd_dtau, central_differences(lambda x: forward(q, qd, x), tau, RATE_STEP))
        A, B = c.state_matrices(q, qd, tau, p)
        xdot = lambda x: np.r_[x[model.n:], forward(x[:model.n], x[model.n:], tau)]  # noqa: E731
        differences_close(A, central_differences(xdot, np.r_[q, qd], np.r_[np.full(model.n, STEP), np.full(model.n, RATE_STEP)]))
        differences_close(B, central_differences(lambda u: np.r_[qd, forward(q, qd, u)], tau, RATE_STEP))


def test_derivatives_report_a_matrix_that_is_not_positive_definite(built_in) -> None:
    """A NaN configuration makes D(q) fail the Cholesky test: status 1, as forward dynamics returns."""
    c = built_in["panda"]
    q = np.full(7, np.nan)
    for function, shapes in (("forward_dynamics_derivatives", [(7, 7)] * 3), ("A", [(14, 14)]), ("B", [(14, 7)])):
        assert c._outputs(function, [q, np.zeros(7), np.zeros(7), c.defaults], shapes)[1] == 1


def _has_avx() -> bool:
    flags = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    return platform.machine() == "x86_64" and " avx " in flags.replace("\n", " ")


def test_avx_copy_gives_the_same_bits(tmp_path) -> None:
    """Built for x86-64 without AVX, a function of DISPATCH_OPERATIONS or more (and inertia and inverse dynamics,
    which run alongside the derivatives) runs a copy compiled for AVX where the
    processor has it (docs/contracts.md, "Generated C"); AVX has no fused multiply-add, so the copy's results are
    the baseline copy's (SYMBOLIC_NO_DISPATCH) bit for bit. Sines and cosines from libm in both builds: the batched
    kernel's own AVX2+FMA copy may differ in the last bit (tests/test_sincos.py)."""
    if not _has_avx():
        pytest.skip("needs an x86-64 processor with AVX (the dispatch is compiled for x86-64 only)")
    model = derived("panda")
    source = GENERATED / "panda" / "panda.c"
    flags = (*STRICT[:-1], "-O3", "-DSYMBOLIC_LIBM_SINCOS")
    dispatched = compile_shared(source, tmp_path / "libdispatched.so", flags)
    baseline = compile_shared(source, tmp_path / "libbaseline.so", (*flags, "-DSYMBOLIC_NO_DISPATCH"))
    symbols = subprocess.run(["nm", str(dispatched)], capture_output=True, text=True, check=True).stdout
    assert "panda_inverse_dynamics_derivatives_avx" in symbols and "panda_coriolis_matrix_avx" in symbols
    # run alongside the derivatives by forward_dynamics_derivatives, these two get the AVX copy too (c_source._dispatched)
    assert "panda_inertia_avx" in symbols and "panda_inverse_dynamics_avx" in symbols
    a, b = (Derivatives(lib, model.name, model.n, len(model.robot.parameters)) for lib in (dispatched, baseline))
    p = a.defaults
    for q, qd, qdd in states(model, 50, seed=36):
        for x, y in zip(a.id_derivatives(q, qd, qdd, p), b.id_derivatives(q, qd, qdd, p)):
            assert np.array_equal(x, y)
        assert np.array_equal(a.coriolis_matrix(q, qd, p), b.coriolis_matrix(q, qd, p))
        tau = a.inverse_dynamics(q, qd, qdd, p)
        assert np.array_equal(tau, b.inverse_dynamics(q, qd, qdd, p))
        assert np.array_equal(a.inertia(q, p), b.inertia(q, p))
        for x, y in zip(a.fd_derivatives(q, qd, tau, p), b.fd_derivatives(q, qd, tau, p)):
            assert np.array_equal(x, y)
