"""Apparent mass, stiffness and friction at the end effector (symbolic.numeric.operational, Janot (18)–(20)).

References: Pinocchio's operational-space inertia (computeMinverse and the frame Jacobian, built
independently from the model file's numbers), the kinetic energy of the least-energy joint velocity
found from its own optimality (KKT) system, the package's forward dynamics under a point force, and
the generated C and CasADi functions.
"""

from __future__ import annotations

import math
import os
import subprocess
import warnings
from pathlib import Path

import casadi
import numpy as np
import pytest
import sympy as sp

import symbolic
from symbolic.errors import ModelWarning
from symbolic.numeric import operational as op
from symbolic.codegen.exported import solved_specs
from c_library import STRICT, compile_shared, gcc
from reference_pinocchio import _rot_x, _trans, build, pin

GENERATED = Path(__file__).resolve().parent.parent / "generated"
HANDLES = ["panda", "janot_branch", "fivebar", "omni", "puma560", "fivebar_flexible"]
_MODELS: dict[str, symbolic.DynamicModel] = {}


def derived(name: str) -> symbolic.DynamicModel:
    if name not in _MODELS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            _MODELS[name] = symbolic.derive(symbolic.robots.load(name))
    return _MODELS[name]


def relative(ours, reference) -> float:
    return float(np.linalg.norm(np.asarray(ours) - reference) / np.linalg.norm(reference))


def pinocchio_operational_inertia(robot, q) -> np.ndarray:
    """Λ from Pinocchio: M⁻¹ by computeMinverse, J from an operational frame at the end-effector point."""
    model = build(robot)
    values = robot.parameter_values
    frame = robot.frame(robot.end_effector.frame)
    index = [f.name for f in robot.frames].index(frame.name) + 1  # build adds one joint per frame, in order
    d, a, alpha = (float(getattr(frame, k).xreplace(values)) for k in ("d", "a", "alpha"))
    post = _trans(0, 0, d) if robot.convention == "modified" else _trans(0, 0, d) * _trans(a, 0, 0) * _rot_x(alpha)
    point = np.array([float(sp.sympify(x).xreplace(values)) for x in robot.end_effector.point])
    placement = post * pin.SE3(np.eye(3), point)
    frame_id = model.addFrame(pin.Frame("handle", index, 0, placement, pin.FrameType.OP_FRAME))
    data = model.createData()
    minv = pin.computeMinverse(model, data, q)
    minv = np.triu(minv) + np.triu(minv, 1).T
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    J = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    return np.linalg.inv(J @ minv @ J.T)


def test_panda_operational_inertia_equals_pinocchio() -> None:
    model = derived("panda")
    rng = np.random.default_rng(11)
    for _ in range(10):
        q = rng.uniform(-np.pi, np.pi, 7)
        reference = pinocchio_operational_inertia(model.robot, q)
        assert relative(op.operational_inertia(model, q), reference) < 1e-9
        for u in rng.normal(size=(3, 3)):
            assert op.apparent_mass(model, q, u) == pytest.approx((u @ u) / (u @ np.linalg.inv(reference) @ u), rel=1e-9)


@pytest.mark.parametrize("name", ["panda", "janot_branch"])
def test_kinetic_energy_of_the_least_energy_joint_velocity(name: str) -> None:
    """½ẋᵀΛẋ equals ½Q̇ᵀDQ̇ for the Q̇ of least kinetic energy with JQ̇ = ẋ (its KKT system, solved directly),
    and that Q̇ is J̄ẋ; any other Q̇ realising ẋ has more energy."""
    model = derived(name)
    num = symbolic.numeric_model(model)
    rng = np.random.default_rng(3)
    n = model.n
    for _ in range(5):
        q = rng.uniform(-1.2, 1.2, n)
        xd = rng.normal(size=3)
        D, J = num.inertia(q), num.jacobian(q)
        kkt = np.block([[D, J.T], [J, np.zeros((3, 3))]])
        qd = np.linalg.solve(kkt, np.r_[np.zeros(n), xd])[:n]
        energy = 0.5 * qd @ D @ qd
        assert 0.5 * xd @ op.operational_inertia(model, q) @ xd == pytest.approx(energy, rel=1e-10)
        assert relative(op.least_energy_velocity(model, q, xd), qd) < 1e-10
        if n > 3:  # a null-space motion keeps ẋ and adds energy
            null = np.linalg.svd(J)[2][-1]
            other = qd + 0.1 * null
            assert np.allclose(J @ other, xd) and 0.5 * other @ D @ other > energy


def test_apparent_mass_is_the_inverse_acceleration_under_a_point_force() -> None:
    """From rest, with gravity compensated, a unit force along u accelerates the point by Φu (forward dynamics)."""
    model = derived("janot_branch")
    num = symbolic.numeric_model(model)
    q = np.array([0.2, 0.5, 1.4])
    zero = np.zeros(3)
    for u in np.eye(3):
        qdd = num.forward_dynamics(q, zero, num.bias(q, zero), force=-u)  # force enters as −JᵀF
        assert 1.0 / (u @ num.jacobian(q) @ qdd) == pytest.approx(op.apparent_mass(model, q, u), rel=1e-12)


def test_janot_matrices_for_a_square_jacobian() -> None:
    """janot_branch (J square): Λ = J⁻ᵀDJ⁻¹, B_op = J⁻ᵀF_vJ⁻¹, K_op = J⁻ᵀK_totJ⁻¹, F_cop = J⁻ᵀF_c as printed in
    Janot (18), with F_v and F_c read from the model's own friction function (passive-joint friction on)."""
    model = derived("janot_branch")
    num = symbolic.numeric_model(model)
    names = [p.name for p in model.robot.parameters]
    p = num.p0.copy()
    p[names.index("fv3r")], p[names.index("fc3r")] = 0.004, 0.01
    q = np.array([0.3, 0.6, 1.7])
    Ji = np.linalg.inv(num.jacobian(q, p))
    h = op.handle_characteristics(model, q, p, joint_stiffness=[1.0, 2.0, 3.0])
    assert relative(h.mass, Ji.T @ num.inertia(q, p) @ Ji) < 1e-12
    assert relative(h.stiffness, Ji.T @ np.diag([1.0, 2.0, 3.0]) @ Ji) < 1e-12
    # viscous matrix from the friction function itself: f(2 e_k) − f(e_k) = F_v e_k (Coulomb and offset cancel)
    viscous = np.column_stack([num.friction(q, 2 * e, p) - num.friction(q, e, p) for e in np.eye(3)])
    assert relative(h.viscous, Ji.T @ viscous @ Ji) < 1e-12
    # the dry force resisting a handle motion ẋ is J⁻ᵀ times the Coulomb part of f at Q̇ = J⁻¹ẋ
    xd = np.array([0.3, -0.2, 0.5])
    qd = Ji @ xd
    coulomb = num.friction(q, 1e-9 * qd, p) - num.friction(q, np.zeros(3), p)  # viscous part 1e-9 smaller
    assert np.allclose(h.coulomb_force(xd), Ji.T @ coulomb, rtol=1e-7, atol=1e-9)


def test_dynamically_consistent_inverse_for_a_redundant_arm() -> None:
    model = derived("panda")
    q = np.array([0.1, -0.4, 0.3, -1.9, 0.2, 1.1, -0.5])
    jbar = op.dynamically_consistent_inverse(model, q)
    num = symbolic.numeric_model(model)
    assert np.allclose(num.jacobian(q) @ jbar, np.eye(3), atol=1e-12)
    stiffness = op.handle_characteristics(model, q, joint_stiffness=np.full(7, 100.0)).stiffness
    assert np.allclose(stiffness, stiffness.T, atol=1e-9) and np.all(np.linalg.eigvalsh(stiffness) > 0)


def test_series_stiffness_is_janot_19() -> None:
    assert op.series_stiffness(2.0, 2.0) == 1.0
    assert op.series_stiffness(3.0, 6.0) == pytest.approx(2.0, rel=1e-15)
    with pytest.raises(ValueError, match="positive"):
        op.series_stiffness(2.0, 0.0)


def test_singular_configuration_and_immovable_directions() -> None:
    model = derived("janot_branch")
    q = np.zeros(3)  # q3 = q5 − q2 = 0: arm and forearm aligned, the point cannot move along x
    with pytest.raises(op.SingularConfiguration, match="singular"):
        op.operational_inertia(model, q)
    assert op.apparent_mass(model, q, [1, 0, 0]) == math.inf
    assert math.isfinite(op.apparent_mass(model, q, [0, 1, 0]))
    with pytest.raises(ValueError, match="zero"):
        op.apparent_mass(model, q, [0, 0, 0])


def test_model_without_end_effector_is_refused_clearly() -> None:
    model = derived("emps")
    assert model.robot.end_effector is None
    with pytest.raises(op.NoEndEffector, match=r"'emps' declares no \[end_effector\]"):
        op.apparent_mass(model, [0.0], [1, 0, 0])
    assert [s.name for s in solved_specs(model)] == ["forward_dynamics", "forward_dynamics_derivatives", "A", "B"]
    header = (GENERATED / "emps" / "emps.h").read_text()
    assert "apparent_mass" not in header and "end_effector_jacobian" not in header
    assert not list((GENERATED / "emps").glob("*apparent_mass*"))


class _Handle:
    """The generated C handle functions, compiled and called through ctypes."""

    def __init__(self, name: str, out: Path) -> None:
        import ctypes

        self.lib = ctypes.CDLL(str(compile_shared(GENERATED / name / f"{name}.c", out / f"lib{name}.so")))
        self.name = name
        self.pointer = ctypes.POINTER(ctypes.c_double)

    def _call(self, function: str, inputs, size: int) -> tuple[np.ndarray, int]:
        import ctypes

        args = [np.ascontiguousarray(x, dtype=float) for x in inputs]
        out = np.full(size, np.nan)
        fn = getattr(self.lib, f"{self.name}_{function}")
        fn.restype = ctypes.c_int
        status = fn(*[a.ctypes.data_as(self.pointer) for a in args], out.ctypes.data_as(self.pointer))
        return out, status

    def operational_inertia(self, q, p):
        lam, status = self._call("operational_inertia", [q, p], 9)
        return lam.reshape(3, 3), status

    def apparent_mass(self, q, u, p):
        m, status = self._call("apparent_mass", [q, u, p], 1)
        return m[0], status


@pytest.fixture(scope="module")
def handles(tmp_path_factory) -> dict[str, _Handle]:
    out = tmp_path_factory.mktemp("handles")
    return {name: _Handle(name, out) for name in HANDLES}


@pytest.mark.parametrize("name", HANDLES)
def test_c_and_casadi_exports_agree_with_python(name: str, handles) -> None:
    model = derived(name)
    num = symbolic.numeric_model(model)
    c = handles[name]
    lam_fn = casadi.Function.load(str(GENERATED / name / f"{name}_operational_inertia.casadi"))
    mass_fn = casadi.Function.load(str(GENERATED / name / f"{name}_apparent_mass.casadi"))
    rng = np.random.default_rng(17)
    # beam deflections (modal coordinates) at physical amplitudes, angles anywhere
    amplitude = np.array([0.01 if ("_nu" in c or "_eta" in c) else np.pi for c in model.robot.generalized_coordinates])
    conditioned = 0
    for _ in range(10):
        q = amplitude * rng.uniform(-1, 1, model.n)
        p = num.p0 * rng.uniform(0.8, 1.25, num.p0.size)
        u = rng.normal(size=3)
        reference = op.operational_inertia(model, q, p)
        # 1e-12, or the rounding bound where the configuration is near-singular: D and J evaluated by two
        # programs differ in the last bits, and inverting Φ = J D⁻¹Jᵀ multiplies that by its condition number
        eigenvalues = np.linalg.eigvalsh(op.mobility(model, q, p))
        lam_tolerance = max(1e-12, 1e-15 * eigenvalues[-1] / eigenvalues[0])
        lam_c, status = c.operational_inertia(q, p)
        assert status == 0 and relative(lam_c, reference) < lam_tolerance
        assert relative(np.array(lam_fn(q, p)), reference) < lam_tolerance
        m = op.apparent_mass(model, q, u, p)
        tolerance = max(1e-12, 1e-15 * m * eigenvalues[-1] / (u @ u))  # the largest mobility over the one along u
        m_c, status = c.apparent_mass(q, u, p)
        assert status == 0 and m_c == pytest.approx(m, rel=tolerance)
        assert float(mass_fn(q, u, p)) == pytest.approx(m, rel=tolerance)
        conditioned += lam_tolerance == tolerance == 1e-12
    assert conditioned >= 5  # most configurations are checked at 1e-12


def test_c_status_codes(handles) -> None:
    c = handles["janot_branch"]
    p = symbolic.numeric_model(derived("janot_branch")).p0
    q = np.zeros(3)
    assert c.operational_inertia(q, p)[1] == 2  # singular: the point cannot move along x
    assert c.apparent_mass(q, [1.0, 0.0, 0.0], p) == (math.inf, 3)
    assert c.apparent_mass(q, [0.0, 0.0, 0.0], p)[1] == 2
    negative = p.copy()
    for i, parameter in enumerate(derived("janot_branch").robot.parameters):
        if parameter.name.startswith(("m", "zz", "xx", "yy", "ia")):
            negative[i] = -abs(negative[i])
    assert c.apparent_mass(np.array([0.2, 0.5, 1.4]), [1.0, 0.0, 0.0], negative)[1] == 1
    assert c.operational_inertia(np.array([0.2, 0.5, 1.4]), negative)[1] == 1


def test_c_handle_functions_run_clean_under_sanitizers(tmp_path: Path) -> None:
    """ASan/UBSan over every path of the two C functions (success, singular, zero u, immovable direction)."""
    name = "janot_branch"
    for suffix in (".c", ".h"):
        (tmp_path / f"{name}{suffix}").write_bytes((GENERATED / name / f"{name}{suffix}").read_bytes())
    (tmp_path / "main.c").write_text(f"""#include <math.h>
#include "{name}.h"
int main(void)
{{
    const double *p = {name}_parameter_defaults;
    const double q[3] = {{ 0.2, 0.5, 1.4 }}, zero[3] = {{ 0.0, 0.0, 0.0 }}, x[3] = {{ 1.0, 0.0, 0.0 }};
    double L[9], m;
    if ({name}_operational_inertia(q, p, L) != 0 || !(L[0] > 0.0)) return 1;
    if ({name}_apparent_mass(q, x, p, &m) != 0 || !(m > 0.0)) return 2;
    if ({name}_operational_inertia(zero, p, L) != 2) return 3;
    if ({name}_apparent_mass(zero, x, p, &m) != 3 || !isinf(m)) return 4;
    if ({name}_apparent_mass(q, zero, p, &m) != 2) return 5;
    return 0;
}}
""")
    exe = tmp_path / "check"
    flags = [*STRICT[:-1], "-O1", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
    build_run = subprocess.run([gcc(), *flags, "-o", str(exe), str(tmp_path / "main.c"), str(tmp_path / f"{name}.c"), "-lm"],
                               capture_output=True, text=True, cwd=tmp_path)
    assert build_run.returncode == 0, build_run.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1"})
    assert run.returncode == 0, (run.returncode, run.stderr)


def test_report_lists_the_apparent_mass_over_the_workspace() -> None:
    text = (GENERATED / "janot_branch" / "janot_branch.md").read_text()
    assert "## Apparent mass at the end effector" in text
    model = derived("janot_branch")
    q = op.workspace_samples(model, 9)[1]
    row = "| " + " | ".join(f"{x:.2f}" for x in q) + " | " + f"{op.apparent_mass(model, q, [1, 0, 0]):.4g} |"
    assert row in text
    assert "## Apparent mass" not in (GENERATED / "emps" / "emps.md").read_text()
