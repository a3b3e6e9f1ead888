"""Export: generated C (gcc, ctypes), CasADi (.casadi files) and SymPy agree; C builds alone and
runs clean under the sanitizers; CasADi files load without this package; output is deterministic.

Round trip tolerance: ‖C − SymPy‖ ≤ 1e-12 ‖SymPy‖ and ‖CasADi − SymPy‖ ≤ 1e-12 ‖SymPy‖ per function,
20 seeded states per robot; forward dynamics inverts inverse dynamics to 1e-10 relative to the size of
q̈ and of D⁻¹(bias forces) (the terms that cancel).
The committed generated/ directory is what is tested (``make check-generated`` keeps it current).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import casadi
import numpy as np
import pytest

import symbolic
import symbolic.export as export
from c_library import STRICT, CModel, compile_shared, gcc
from conftest import derived
from symbolic.numeric import numeric_model

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "generated"
ROBOTS = ["fivebar", "puma560", "panda", "janot_branch", "omni", "single_flexible_link", "madill_beam", "fivebar_flexible", "emps"]


def close(ours, reference, rtol):
    scale = max(np.linalg.norm(reference), 1e-300)
    assert np.linalg.norm(np.asarray(ours) - reference) <= rtol * scale, np.linalg.norm(np.asarray(ours) - reference) / scale


@pytest.fixture(scope="module")
def libraries(tmp_path_factory) -> dict[str, CModel]:
    out = tmp_path_factory.mktemp("lib")
    libs = {}
    for name in ROBOTS:
        model = derived(name)
        library = compile_shared(GENERATED / name / f"{name}.c", out / f"lib{name}.so")
        libs[name] = CModel(library, name, model.n, len(model.robot.parameters))
    return libs


@pytest.mark.parametrize("name", ROBOTS)
def test_c_and_casadi_match_sympy(name: str, libraries) -> None:
    model = derived(name)
    num = numeric_model(model)
    c = libraries[name]
    np.testing.assert_array_equal(c.defaults, num.p0)
    fns = {f: casadi.Function.load(str(GENERATED / name / f"{name}_{f}.casadi")) for f in
           ("inertia", "coriolis", "coriolis_matrix", "gravity", "friction", "applied", "inverse_dynamics", "forward_dynamics",
            "A", "B")}
    rng = np.random.default_rng(42)
    # beam deflections (modal coordinates) at physical amplitudes, angles anywhere
    amplitude = np.array([0.01 if ("_nu" in c or "_eta" in c) else np.pi for c in model.robot.generalized_coordinates])
    for _ in range(20):
        q, qd, qdd = amplitude * rng.uniform(-1, 1, model.n), rng.uniform(-2, 2, model.n), rng.uniform(-2, 2, model.n)
        p = num.p0 * rng.uniform(0.5, 2.0, num.p0.size)
        reference = {
            "inertia": num.inertia(q, p),
            "coriolis": num.coriolis(q, qd, p),
            "coriolis_matrix": num.coriolis_matrix(q, qd, p),
            "gravity": num.gravity(q, p),
            "friction": num.friction(q, qd, p),
            "applied": num.applied(q, qd, p),
            "inverse_dynamics": num.inverse_dynamics(q, qd, qdd, p),
        }
        close(c.inertia(q, p), reference["inertia"], 1e-12)
        close(c.coriolis(q, qd, p), reference["coriolis"], 1e-12)
        close(c.coriolis_matrix(q, qd, p), reference["coriolis_matrix"], 1e-12)
        close(c.gravity(q, p), reference["gravity"], 1e-12)
        close(c.inverse_dynamics(q, qd, qdd, p), reference["inverse_dynamics"], 1e-12)
        close(c.stiffness(q, p), num.stiffness(q, p), 1e-12) if num.stiffness(q, p).any() else None
        for part in ("friction", "applied"):
            if reference[part].any():
                close(getattr(c, part)(q, qd, p), reference[part], 1e-12)
                close(np.array(fns[part](q, qd, p)).ravel(), reference[part], 1e-12)
            else:  # no entries: exactly zero everywhere
                assert not getattr(c, part)(q, qd, p).any() and not np.array(fns[part](q, qd, p)).any()
        close(np.array(fns["inertia"](q, p)), reference["inertia"], 1e-12)
        close(np.array(fns["coriolis"](q, qd, p)).ravel(), reference["coriolis"], 1e-12)
        close(np.array(fns["coriolis_matrix"](q, qd, p)), reference["coriolis_matrix"], 1e-12)
        close(np.array(fns["gravity"](q, p)).ravel(), reference["gravity"], 1e-12)
        close(np.array(fns["inverse_dynamics"](q, qd, qdd, p)).ravel(), reference["inverse_dynamics"], 1e-12)
        tau = reference["inverse_dynamics"]
        qdd_c, status = c.forward_dynamics(q, qd, tau, p)
        assert status == 0
        # relative to the accelerations τ and the bias forces would produce on their own: elastic forces
        # of a stiff beam cancel in τ − bias, and no solver recovers q̈ better than that cancellation
        bias = np.linalg.solve(reference["inertia"], tau - reference["inertia"] @ qdd)
        scale = np.linalg.norm(qdd) + np.linalg.norm(bias)
        assert np.linalg.norm(qdd_c - qdd) <= 1e-10 * scale
        assert np.linalg.norm(np.array(fns["forward_dynamics"](q, qd, tau, p)).ravel() - qdd) <= 1e-10 * scale


@pytest.mark.parametrize("name", ["fivebar", "panda"])
def test_casadi_linearisation_matches_sympy(name: str) -> None:
    """A(q,qd,tau,p), B(q,qd,tau,p) from the .casadi files against NumericModel.linearize (exact derivatives)."""
    model = derived(name)
    num = numeric_model(model)
    A_fn = casadi.Function.load(str(GENERATED / name / f"{name}_A.casadi"))
    B_fn = casadi.Function.load(str(GENERATED / name / f"{name}_B.casadi"))
    rng = np.random.default_rng(8)
    for _ in range(5):
        q, qd, tau = rng.uniform(-np.pi, np.pi, model.n), rng.uniform(-2, 2, model.n), rng.uniform(-2, 2, model.n)
        u = np.r_[tau, np.zeros(3)] if num.has_force else tau
        A, B = num.linearize(np.r_[q, qd], u)
        close(np.array(A_fn(q, qd, tau, num.p0)), A, 1e-9)
        close(np.array(B_fn(q, qd, tau, num.p0)), B[:, : model.n], 1e-9)


@pytest.mark.parametrize("name", ["puma560", "fivebar_flexible"])
def test_libm_trigonometry_switch_gives_the_same_dynamics(name: str, tmp_path: Path) -> None:
    """-DSYMBOLIC_LIBM_SINCOS (libm sin/cos instead of the batched kernel) changes nothing beyond rounding."""
    model = derived(name)
    n, n_p = model.n, len(model.robot.parameters)
    source = GENERATED / name / f"{name}.c"
    fast = CModel(compile_shared(source, tmp_path / "libfast.so", (*STRICT, "-O3")), name, n, n_p)
    libm = CModel(compile_shared(source, tmp_path / "liblibm.so", (*STRICT, "-O3", "-DSYMBOLIC_LIBM_SINCOS")), name, n, n_p)
    amplitude = np.array([0.01 if ("_nu" in c or "_eta" in c) else np.pi for c in model.robot.generalized_coordinates])
    rng = np.random.default_rng(5)
    for _ in range(20):
        q, qd, qdd = amplitude * rng.uniform(-1, 1, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)
        close(fast.inverse_dynamics(q, qd, qdd, fast.defaults), libm.inverse_dynamics(q, qd, qdd, fast.defaults), 1e-14)
        close(fast.inertia(q, fast.defaults), libm.inertia(q, fast.defaults), 1e-14)
        close(fast.gravity(q, fast.defaults), libm.gravity(q, fast.defaults), 1e-14)


def test_forward_dynamics_reports_indefinite_inertia(libraries) -> None:
    c = libraries["fivebar"]
    p = c.defaults.copy()
    names = symbolic.robots.load("fivebar").parameters
    for i, parameter in enumerate(names):
        if parameter.name in ("J0", "I1", "I2", "I3", "I_r", "m1", "m2", "m3", "m_r"):
            p[i] = -abs(p[i])
    _, status = c.forward_dynamics(np.zeros(3), np.zeros(3), np.ones(3), p)
    assert status == 1


def test_c_builds_from_generated_directory_alone_and_runs_clean_under_sanitizers(tmp_path: Path) -> None:
    """Copy only generated/<name>/ files, build a test program with gcc and ASan/UBSan, run it."""
    program = tmp_path / "main.c"
    calls = []
    for name in ROBOTS:
        for suffix in (".c", ".h"):
            (tmp_path / f"{name}{suffix}").write_bytes((GENERATED / name / f"{name}{suffix}").read_bytes())
        calls.append(
            f"""    {{
        double q[{name}_NQ], qd[{name}_NQ], qdd[{name}_NQ], tau[{name}_NQ], D[{name}_NQ * {name}_NQ], C[{name}_NQ * {name}_NQ];
        double h[{name}_NQ], g[{name}_NQ], k[{name}_NQ], f[{name}_NQ], back[{name}_NQ];
        int i;
        for (i = 0; i < {name}_NQ; ++i) {{ q[i] = 0.1 * (i + 1); qd[i] = -0.2 * i; qdd[i] = 0.3; }}
        {name}_inertia(q, {name}_parameter_defaults, D);
        {name}_coriolis(q, qd, {name}_parameter_defaults, h);
        {name}_coriolis_matrix(q, qd, {name}_parameter_defaults, C);
        {name}_gravity(q, {name}_parameter_defaults, g);
        {name}_stiffness(q, {name}_parameter_defaults, k);
        {name}_friction(q, qd, {name}_parameter_defaults, f);
        {name}_inverse_dynamics(q, qd, qdd, {name}_parameter_defaults, tau);
        if ({name}_forward_dynamics(q, qd, tau, {name}_parameter_defaults, back) != 0) return 1;
        for (i = 0; i < {name}_NQ; ++i) if (fabs(back[i] - qdd[i]) > 1e-9) return 2;
        if (D[0] <= 0.0 || {name}_coordinate_names[0] == 0 || {name}_parameter_names[0] == 0) return 3;
        (void)C; (void)h; (void)g; (void)k; (void)f;
    }}"""
        )
    includes = "".join(f'#include "{n}.h"\n' for n in ROBOTS)
    program.write_text("#include <math.h>\n" + includes + "int main(void)\n{\n" + "\n".join(calls) + "\n    return 0;\n}\n")
    sources = [str(tmp_path / f"{n}.c") for n in ROBOTS]
    exe = tmp_path / "check"
    flags = [*STRICT[:-1], "-O1", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
    build = subprocess.run([gcc(), *flags, "-o", str(exe), str(program), *sources, "-lm"], capture_output=True, text=True, cwd=tmp_path)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1"})
    assert run.returncode == 0, run.stderr


def test_casadi_loads_without_symbolic(tmp_path: Path) -> None:
    script = (
        "import sys\n"
        f"sys.path.insert(0, {str(GENERATED / 'panda')!r})\n"
        "import panda_casadi as m\n"
        "D = m.load('inertia')([0.1] * 7, m.PARAMETER_DEFAULTS)\n"
        "assert D.shape == (7, 7) and float(D[0, 0]) > 0\n"
        "assert 'symbolic' not in sys.modules, 'symbolic was imported'\n"
        "print('ok')\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr


@pytest.mark.slow
def test_generation_is_byte_identical_across_hash_seeds(tmp_path: Path) -> None:
    outputs = []
    for seed in ("1", "2"):
        out = tmp_path / seed
        env = {**os.environ, "PYTHONHASHSEED": seed}
        subprocess.run([sys.executable, "-m", "symbolic.builtin_outputs", str(out), "fivebar", "janot_branch"], check=True, env=env, capture_output=True)
        outputs.append({p.relative_to(out): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()})
    assert outputs[0] == outputs[1]
    for path, content in outputs[0].items():
        assert (GENERATED / path).read_bytes() == content, f"generated/{path} differs from a fresh generation"


# -- bad input --------------------------------------------------------------------------


def small_robot(name: str = "arm", parameter: str = "m") -> symbolic.Robot:
    return symbolic.validate(symbolic.Robot(
        name=name,
        coordinates=("q",),
        parameters=(symbolic.Parameter(parameter, 1.0), symbolic.Parameter("l", 0.5)),
        frames=(symbolic.Frame("1", "base", theta="q", a="l"),),
        bodies=(symbolic.Body("b", "1", parameter),),
        gravity=(0, "-9.81", 0),
    ))


def test_model_name_that_is_a_c_keyword_is_refused() -> None:
    """Refused when the model is validated (so `derive` refuses it too), not first by `generate`."""
    with pytest.raises(symbolic.ModelError, match="model name 'int' is a C keyword"):
        small_robot("int")


def test_parameter_name_that_is_not_an_identifier_is_refused() -> None:
    """Names reach C as NAME_P_<parameter> macros; the spec only admits C identifiers, so none can collide."""
    with pytest.raises(symbolic.ModelError, match=r"\[parameters\]: \"m'1\" is not an identifier"):
        small_robot(parameter="m'1")


def test_unwritable_output_is_refused_and_nothing_half_written(tmp_path: Path) -> None:
    model = symbolic.derive(small_robot())
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises(export.ExportError, match="cannot create output directory|not a writable directory"):
        export.generate(model, blocker / "out")
    with pytest.raises(export.ExportError):
        export.generate(model, blocker)
    assert blocker.read_text() == "not a directory"


def test_failed_export_leaves_previous_output_intact(tmp_path: Path, monkeypatch) -> None:
    model = symbolic.derive(small_robot())
    out = tmp_path / "out"
    first = export.generate(model, out, ["c", "report"])
    before = {p.name: p.read_bytes() for p in first}

    def broken(*args, **kwargs):
        raise RuntimeError("simulated failure while rendering")

    monkeypatch.setattr("symbolic.export.markdown.report_markdown", broken)
    with pytest.raises(RuntimeError):
        export.generate(model, out, ["c", "report"])
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.name != ".symbolic-manifest.json"} == before


def test_cli_generate(tmp_path: Path) -> None:
    result = subprocess.run([sys.executable, "-m", "symbolic", "-q", "generate", "omni", "--out", str(tmp_path), "--targets", "c,report"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [".symbolic-manifest.json", "omni.c", "omni.h", "omni.md"]
    bad = subprocess.run([sys.executable, "-m", "symbolic", "-q", "generate", "omni", "--out", str(tmp_path), "--targets", "fortran"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "unknown target(s) ['fortran']" in bad.stderr
