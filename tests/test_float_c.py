"""Single-precision C (``symbolic generate --precision float``; docs/contracts.md, "Single-precision C"), with gcc
and ctypes.

* The float C compiles with the strict flags of the double C plus ``-Wdouble-promotion``, warnings as errors: the
  Panda and the five-bar here, every built-in robot and every URDF arm of tests/test_urdf.py in the slow test.
* The Panda's float functions against its double ones (generated/panda/panda.c), measured here with this file's
  own ctypes calls and norms at the package's 1000 states (seed 36, inside the joint limits): the worst of
  ‖f_float − f_double‖₂ / ‖f_double‖₂ over the states (D: Frobenius) is at most 1e-5 for D, g and τ, and the
  header states the same figures (two significant digits).
* Literals are rounded once from the exact value; ``precision`` other than "double" and "float" is refused by the
  API and by the command line; the float C runs clean under ASan and UBSan; the double output does not change.
"""

from __future__ import annotations

import ctypes
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import symbolic
import symbolic.export as export
from c_library import STRICT, CModel, compile_shared, gcc
from conftest import derived
from symbolic.codegen.c_accuracy import sample_states
from symbolic.codegen.c_printer import c_float, nearest_float32

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "generated"
FLOAT_STRICT = (*STRICT, "-Wdouble-promotion")
"""The double C's strict flags (-std=c99 -Wall -Wextra -Werror -pedantic -O2) and no promotion to double."""

DOUBLE_FUNCTIONS = re.compile(r"\b(sin|cos|tan|asin|acos|atan|atan2|sinh|cosh|tanh|sqrt|cbrt|exp|log|pow|fabs|fma|fmin|fmax)\(")
"""A C99 math function in its double form (the float forms end in f: sinf, sqrtf, ...)."""


class FloatModel:
    """ctypes wrapper of a generated single-precision library (float arrays in and out)."""

    def __init__(self, library: Path, name: str) -> None:
        self.lib = ctypes.CDLL(str(library))  # RTLD_LOCAL: its NAME_* symbols do not meet the double library's
        self.name = name

    def call(self, function: str, inputs: list[np.ndarray], size: int) -> tuple[np.ndarray, int]:
        pointer = ctypes.POINTER(ctypes.c_float)
        arrays = [np.ascontiguousarray(a, dtype=np.float32) for a in inputs]
        out = np.zeros(size, dtype=np.float32)
        fn = getattr(self.lib, f"{self.name}_{function}")
        fn.restype = ctypes.c_int if function == "forward_dynamics" else None
        status = fn(*[a.ctypes.data_as(pointer) for a in arrays], out.ctypes.data_as(pointer))
        return out.astype(np.float64), status or 0

    def defaults(self, n_p: int) -> np.ndarray:
        return np.ctypeslib.as_array((ctypes.c_float * n_p).in_dll(self.lib, f"{self.name}_parameter_defaults")).copy()


def float_files(name: str, out: Path) -> dict[str, str]:
    """The float C (and report) of built-in robot ``name``, as ``symbolic.export.render`` gives them, written to ``out``."""
    files = export.render(derived(name), ["c", "report"], precision="float")
    out.mkdir(parents=True, exist_ok=True)
    for file, content in files.items():
        (out / file).write_bytes(content)
    return {file: content.decode() for file, content in files.items()}


def stated(header: str, function: str) -> float:
    """The worst error the header states for ``function``."""
    match = re.search(rf"\b{function} ([0-9.e+-]+|inf)\b", header)
    assert match, f"the header states no error for {function}"
    return float(match.group(1))


# -- literals and the precision argument -----------------------------------------------------------------------

def test_float_literals_are_rounded_once_from_the_exact_value() -> None:
    """Just above a float midpoint, rounding to double first lands on the midpoint and then on the wrong float."""
    midpoint = 1 + sp.Rational(1, 2**24)  # halfway between 1 and the next float, 1 + 2**-23
    above = midpoint + sp.Rational(1, 2**60)
    assert np.float32(float(above)) == np.float32(1.0)  # double rounding: wrong
    assert nearest_float32(above) == np.float32(1 + 2.0**-23)  # once: right
    assert nearest_float32(midpoint) == np.float32(1.0)  # a true tie goes to even
    assert c_float(sp.Rational(33, 400)) == "0.0825f"  # exact decimals print as written
    assert c_float(sp.Integer(-3)) == "-3.0f"
    for value in (sp.Rational(1, 3), sp.Rational(sp.pi.evalf(60)), sp.Rational(10**20, 7), sp.Rational(1, 7 * 10**9), above):
        text = c_float(value)
        assert text.endswith("f") and np.float32(text[:-1]) == nearest_float32(value), text
    with pytest.raises(ValueError, match="beyond the range of float"):
        c_float(sp.Integer(10) ** 39)


@pytest.mark.parametrize("precision", ["half", "Float", "single", None, 32])
def test_precision_other_than_double_or_float_is_refused(precision, tmp_path: Path, capsys) -> None:
    from symbolic.cli import main

    with pytest.raises(ValueError, match=re.escape(f"precision must be 'double' or 'float', not {precision!r}")):
        export.render(derived("emps"), ["c"], precision=precision)
    if isinstance(precision, str):
        assert main(["generate", "emps", "--out", str(tmp_path / "out"), "--precision", precision]) == 2
        assert f"error: --precision: precision must be 'double' or 'float', not {precision!r}" in capsys.readouterr().err
        assert not (tmp_path / "out").exists()  # refused before anything was derived or written


def test_without_a_c_compiler_float_c_is_refused_saying_why(tmp_path: Path, monkeypatch) -> None:
    """The stated error is measured by compiling: with no compiler on the PATH there is no float C, and the error says so."""
    from symbolic.codegen.c_accuracy import measure_float_accuracy
    from symbolic.errors import ExportError

    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))  # an empty folder: no cc, gcc or clang
    with pytest.raises(ExportError, match=r"could not be compiled and loaded: no C compiler \(\$CC, cc, gcc or clang"):
        measure_float_accuracy(derived("emps"), count=3)


def test_double_output_is_unchanged() -> None:
    """precision="double" (the default) renders exactly the committed generated/ files."""
    files = export.render(derived("emps"), ["c"], command="make generate", precision="double")
    assert files == {f: (GENERATED / "emps" / f).read_bytes() for f in ("emps.c", "emps.h")}


# -- the Panda: strict compilation and the measured error -------------------------------------------------------

@pytest.fixture(scope="module")
def panda_libraries(tmp_path_factory) -> tuple[FloatModel, CModel, dict[str, str]]:
    out = tmp_path_factory.mktemp("panda_float")
    files = float_files("panda", out)
    single = FloatModel(compile_shared(out / "panda_float.c", out / "libpanda_float.so", FLOAT_STRICT), "panda")
    model = derived("panda")
    double = CModel(compile_shared(GENERATED / "panda" / "panda.c", out / "libpanda.so"), "panda", model.n,
                    len(model.robot.parameters))
    return single, double, files


def worst_error(single: FloatModel, double: CModel, function: str, inputs: tuple[str, ...], size: int) -> float:
    """max over the package's states of ‖f_float − f_double‖₂ / ‖f_double‖₂, computed here."""
    model = derived("panda")
    states = sample_states(model)
    p32 = single.defaults(len(model.robot.parameters))
    worst = 0.0
    for k in range(len(states["q"])):
        args = [states[a][k] for a in inputs]
        value, _ = single.call(function, [*args, p32], size)
        reference = getattr(double, function)(*[a.astype(np.float64) for a in args], double.defaults).ravel()
        worst = max(worst, np.linalg.norm(value - reference) / np.linalg.norm(reference))
    return worst


@pytest.mark.parametrize("function, inputs", [("inertia", ("q",)), ("gravity", ("q",)),
                                              ("inverse_dynamics", ("q", "qd", "qdd"))])
def test_panda_float_error_is_within_1e_5_and_stated_in_the_header(function: str, inputs: tuple[str, ...],
                                                                   panda_libraries) -> None:
    single, double, files = panda_libraries
    size = 49 if function == "inertia" else 7
    measured = worst_error(single, double, function, inputs, size)
    assert 0 < measured <= 1e-5, measured
    # the package measured the same states with its own build (-O1) of the same sources: the same figure
    assert stated(files["panda_float.h"], function) == pytest.approx(measured, rel=0.06)
    assert f"| {function} | {stated(files['panda_float.h'], function):.1e} |" in files["panda.md"]


def test_panda_float_source_is_all_float(panda_libraries) -> None:
    _, _, files = panda_libraries
    source, header = files["panda_float.c"], files["panda_float.h"]
    code = re.sub(r"/\*.*?\*/", "", source, flags=re.S)  # the comments may say "double"
    assert not re.search(r"\bdouble\b", code) and not DOUBLE_FUNCTIONS.search(code)
    assert "sinf(x[i])" in code and "sqrtf(s)" in code
    assert "void panda_inverse_dynamics(const float *q, const float *qd, const float *qdd, const float *p, float *tau);" in header
    assert "extern const float panda_parameter_defaults[panda_NP];" in header
    assert "1000 random states (seed 36)" in header and "## Single-precision C" in files["panda.md"]
    assert "regenerate with: symbolic generate panda.toml --out <dir> --precision float" in header


def test_panda_float_forward_dynamics_inverts_the_double_inverse_dynamics(panda_libraries) -> None:
    single, double, _ = panda_libraries
    model = derived("panda")
    p32 = single.defaults(len(model.robot.parameters))
    rng = np.random.default_rng(7)
    for _ in range(20):
        q, qd, qdd = (rng.uniform(-2, 2, 7).astype(np.float32) for _ in range(3))
        tau = double.inverse_dynamics(q.astype(float), qd.astype(float), qdd.astype(float), double.defaults)
        back, status = single.call("forward_dynamics", [q, qd, tau, p32], 7)
        assert status == 0
        assert np.linalg.norm(back - qdd) <= 1e-3 * np.linalg.norm(qdd)  # measured: 1.1e-5 at worst (the header)


# -- a small robot through the command line: files, sanitizers, the two headers ------------------------------

def test_cli_writes_float_c_that_runs_clean_under_sanitizers(tmp_path: Path) -> None:
    from symbolic.cli import main

    out = tmp_path / "out"
    assert main(["-q", "generate", "fivebar", "--out", str(out), "--precision", "float", "--targets", "c,report"]) == 0
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["fivebar.md", "fivebar_float.c", "fivebar_float.h"]
    header = (out / "fivebar_float.h").read_text()
    assert stated(header, "inertia") < 1e-6 and "## Single-precision C" in (out / "fivebar.md").read_text()
    program = tmp_path / "main.c"
    program.write_text("""#include <math.h>
#include "fivebar_float.h"
int main(void)
{
    float q[fivebar_NQ] = { 0.1f, 0.2f, -0.3f }, qd[fivebar_NQ] = { 0.5f, -0.4f, 0.3f }, qdd[fivebar_NQ] = { 1.0f, 2.0f, 3.0f };
    float tau[fivebar_NQ], back[fivebar_NQ], D[fivebar_NQ * fivebar_NQ], Lambda[9], m;
    const float u[3] = { 1.0f, 0.0f, 0.0f };
    int i;
    fivebar_inertia(q, fivebar_parameter_defaults, D);
    fivebar_inverse_dynamics(q, qd, qdd, fivebar_parameter_defaults, tau);
    if (fivebar_forward_dynamics(q, qd, tau, fivebar_parameter_defaults, back) != 0) return 1;
    for (i = 0; i < fivebar_NQ; ++i) if (fabsf(back[i] - qdd[i]) > 1e-3f * fabsf(qdd[i]) + 1e-4f) return 2;
    if (fivebar_operational_inertia(q, fivebar_parameter_defaults, Lambda) > 2) return 3;
    if (fivebar_apparent_mass(q, u, fivebar_parameter_defaults, &m) > 3 || D[0] <= 0.0f) return 4;
    return 0;
}
""")
    exe = tmp_path / "check"
    flags = [*STRICT[:-1], "-Wdouble-promotion", "-O1", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
    build = subprocess.run([gcc(), *flags, "-I", str(out), "-o", str(exe), str(program), str(out / "fivebar_float.c"), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1"})
    assert run.returncode == 0, run.stderr


def test_including_both_headers_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "fivebar_float.h").write_bytes(export.render(derived("fivebar"), ["c"], precision="float")["fivebar_float.h"])
    (tmp_path / "fivebar.h").write_bytes((GENERATED / "fivebar" / "fivebar.h").read_bytes())
    (tmp_path / "both.c").write_text('#include "fivebar.h"\n#include "fivebar_float.h"\n')
    build = subprocess.run([gcc(), *STRICT, "-fsyntax-only", str(tmp_path / "both.c")], capture_output=True, text=True, cwd=tmp_path)
    assert build.returncode != 0 and "declare the same functions, in float and in double" in build.stderr


def test_time_varying_model_takes_float_time(tmp_path: Path) -> None:
    """Forces in t (tests/test_time_varying.py's arm, with friction): t is a float input too, and it compiles strictly."""
    from test_time_varying import load, mains_text

    model = symbolic.derive(load(mains_text()))
    files = export.render(model, ["c"], precision="float")
    for file, content in files.items():
        (tmp_path / file).write_bytes(content)
    name = f"{model.name}_float"
    header = files[f"{name}.h"].decode()
    assert f"void {model.name}_applied(const float *q, const float *qd, const float *t, const float *p, float *Q);" in header
    assert stated(header, "inertia") <= 1e-6 and stated(header, "friction") <= 1e-6
    build = subprocess.run([gcc(), *FLOAT_STRICT, "-c", "-o", str(tmp_path / f"{name}.o"), str(tmp_path / f"{name}.c")],
                           capture_output=True, text=True)
    assert build.returncode == 0 and not build.stderr, build.stderr


def test_model_without_parameters_and_a_singular_operational_inertia(tmp_path: Path) -> None:
    """P = 0 (the parameter arrays hold one unused entry) and one coordinate: J D^-1 J^T is singular at every state,
    so the operational inertia has no figure, and the header says why instead of printing 0."""
    import models

    text = models.pendulum("pendulum1", ("q1",), (2.0,), (0.5,), 9.81, inline=True, end_effector=True)
    model = symbolic.derive(symbolic.loads(text, "pendulum1.toml"))
    files = export.render(model, ["c", "report"], precision="float")
    header = files["pendulum1_float.h"].decode()
    assert "extern const float pendulum1_parameter_defaults[1];" in header
    assert "operational_inertia not measured (a non-zero status at every state)" in header
    assert "| operational_inertia | not measured (a non-zero status at every state) |" in files["pendulum1.md"].decode()
    (tmp_path / "pendulum1_float.h").write_bytes(files["pendulum1_float.h"])
    (tmp_path / "pendulum1_float.c").write_bytes(files["pendulum1_float.c"])
    build = subprocess.run([gcc(), *FLOAT_STRICT, "-c", "-o", str(tmp_path / "p.o"), str(tmp_path / "pendulum1_float.c")],
                           capture_output=True, text=True)
    assert build.returncode == 0 and not build.stderr, build.stderr


@pytest.mark.slow
def test_float_generation_is_byte_identical_across_hash_seeds(tmp_path: Path) -> None:
    outputs = []
    for seed in ("1", "2"):
        out = tmp_path / seed
        env = {**os.environ, "PYTHONHASHSEED": seed}
        subprocess.run([sys.executable, "-m", "symbolic", "-q", "generate", "fivebar", "--out", str(out), "--precision", "float",
                        "--targets", "c,report"], check=True, env=env, cwd=tmp_path, capture_output=True)
        outputs.append({p.name: p.read_bytes() for p in out.iterdir() if not p.name.startswith(".")})
    assert outputs[0] == outputs[1] and len(outputs[0]) == 3


# -- every built-in robot and every URDF arm of the tests ------------------------------------------------------

def robots_and_arms() -> list[str]:
    from test_urdf import ARMS

    return [*symbolic.robots.names(), *ARMS]


@pytest.mark.slow
@pytest.mark.parametrize("robot", robots_and_arms())
def test_float_c_compiles_with_the_strict_flags(robot: str, tmp_path: Path) -> None:
    """The float C of each robot, compiled with -Wdouble-promotion -Werror; its measured errors printed (pytest -s)."""
    if robot.endswith(".urdf"):
        from test_urdf import robots_folder

        model = symbolic.derive(symbolic.load(robots_folder() / robot))
    else:
        model = derived(robot)
    files = export.render(model, ["c"], precision="float")
    for file, content in files.items():
        (tmp_path / file).write_bytes(content)
    name = f"{model.name}_float"
    build = subprocess.run([gcc(), *FLOAT_STRICT, "-c", "-o", str(tmp_path / f"{name}.o"), str(tmp_path / f"{name}.c")],
                           capture_output=True, text=True)
    assert build.returncode == 0 and not build.stderr, build.stderr
    header = files[f"{name}.h"].decode()
    errors = header.split("parameters the nominal values:")[1].split(" *\n")[0]
    print(f"\n{robot}: " + " ".join(line.strip(" *") for line in errors.splitlines()))
    assert stated(header, "inertia") <= 1e-5  # D is a sum of positive-definite terms: no cancellation to fear


def test_stated_error_of_a_function_zero_at_most_states() -> None:
    """A worst error above NOTED where ‖f_double‖ is zero at most states (median 0): stated, not a division by 0."""
    from symbolic.codegen.c_accuracy import FunctionError

    error = FunctionError("stiffness", 3e-3, 10, scale_at_worst=2.0, median_scale=0.0)
    assert error.text() == "stiffness 3.0e-03 (where ||f_double|| is 2.0e+00, its median 0)"
    assert FunctionError("inertia", 3e-3, 10, 0.5, 1000.0).text() == "inertia 3.0e-03 (where ||f_double|| is 1/2000 of its median)"
    assert FunctionError("gravity", 0.0, 10, 0.0, 0.0).figure("‖f_double‖") == "0"
