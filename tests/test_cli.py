"""The command line, run as a user would (a subprocess, installed entry point semantics)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import models
from symbolic import cli, robots


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "symbolic", *args], capture_output=True, text=True, cwd=cwd)


def test_derive_builtin_prints_compact_inertia() -> None:
    result = run("-q", "derive", "fivebar")
    assert result.returncode == 0, result.stderr
    assert "D[1,1] = I1 + I3 + l1**2*m_r + l_c1**2*m1 + l_c3**2*m3" in result.stdout
    assert "coordinates (3): q0, q1, q2" in result.stdout


def test_derive_file(tmp_path: Path) -> None:
    model = tmp_path / "pendulum.toml"
    model.write_text(models.pendulum())  # m on a massless link of length l, gravity g
    result = run("-q", "derive", str(model))
    assert result.returncode == 0, result.stderr
    assert "D[0,0] = l**2*m" in result.stdout
    assert "V_g(Q) = g*l*m*sin(q)" in result.stdout


def test_user_error_has_no_traceback(tmp_path: Path) -> None:
    model = tmp_path / "bad.toml"
    model.write_text('name = "bad"\ncoordinates = ["q"]\n[[frame]]\nname = "1"\nparent = "nowhere"\ndh = { theta = "q", d = "0", a = "0", alpha = "0" }\n')
    result = run("derive", str(model))
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert f"error: {model}: [[frame]] '1' parent: parent frame 'nowhere' does not exist" in result.stderr


def test_readme_library_calls_need_only_import_symbolic() -> None:
    """The README's snippet uses symbolic.export and symbolic.analysis after a bare `import symbolic`."""
    code = "import symbolic; print(callable(symbolic.export.generate), callable(symbolic.analysis.decoupling))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0 and result.stdout.split() == ["True", "True"], result.stderr


def test_report_of_flexible_model_lists_elastic_terms() -> None:
    import symbolic

    model = symbolic.derive(symbolic.robots.load("single_flexible_link"))
    text = symbolic.export.render(model, ["report"])["single_flexible_link.md"].decode()
    assert "Rigid model" not in text and "$$V_s =" in text and r"\nu_{1}^{(\mathrm{link})}" in text


# -- issue 15: every refusal one line, exit status 2 -----------------------------------------------

FIELDS = {"THETA": ("theta", "[[frame]] '2' dh.theta"), "A": ("a", "[[frame]] '2' dh.a"), "MASS": ("mass", "[[body]] 'link1' mass")}


def two_link(tmp_path: Path, **fields: str) -> Path:
    """:func:`models.two_link` with THETA, A and MASS as given (default q2, l2, m1), written to tmp_path."""
    path = tmp_path / "arm.toml"
    path.write_text(models.two_link(**{FIELDS[name][0]: value for name, value in fields.items()}))
    return path


ISSUE_15 = [
    ("THETA", "q2" + "+q2" * 3300, "is longer than 2000 characters"),
    ("THETA", "-" * 9000 + "q2", "is longer than 2000 characters"),
    ("MASS", "0*m1/0", "is not finite"),
    ("A", "l2*2.0**100000", "is larger than 100 in magnitude"),
    ("A", "l2/0", "'l2/0' is not finite"),
    ("A", "l2*sqrt(-1)", "is not real"),
    ("A", "log(0)", "'log(0)' is not finite"),
    ("A", "0**-1", "divides by zero"),
    ("THETA", "q2/0", "'q2/0' is not finite"),
    ("A", "l2*10**10**10", "is larger than 100 in magnitude"),
    ("THETA", "q2**10**10", "is larger than 100 in magnitude"),
]


def one_error_line(err: str, path: Path, key: str) -> str:
    assert "Traceback" not in err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert err.startswith(f"error: {path}: {key}: "), err
    return err


@pytest.mark.parametrize("command", ["derive", "generate"])
@pytest.mark.parametrize("field, text, problem", ISSUE_15, ids=lambda v: v[:24] if isinstance(v, str) else None)
def test_issue_15_models_are_refused_with_one_line(tmp_path: Path, capsys, command: str, field: str, text: str, problem: str) -> None:
    path = two_link(tmp_path, **{field: text})
    out = tmp_path / "out"
    args = ["-q", "derive", "--no-show", str(path)] if command == "derive" else ["-q", "generate", str(path), "--out", str(out)]
    assert cli.main(args) == 2
    err = one_error_line(capsys.readouterr().err, path, FIELDS[field][1])
    assert problem in err
    assert not out.exists()


@pytest.mark.parametrize(
    "fields, key, problem",
    [
        ({"THETA": "q2 + 1/(l1 - 0.5)"}, "D[0,0]", "not finite (division by zero) at the nominal parameters, at q1 = 0, q2 = 0"),
        ({"THETA": "acos(10*l1 + q2**2)"}, "D[0,1]", "not finite or not real (math domain error"),
    ],
)
def test_model_not_finite_at_the_nominal_parameters_is_refused(tmp_path: Path, capsys, fields: dict, key: str, problem: str) -> None:
    path = two_link(tmp_path, **fields)
    assert cli.main(["-q", "generate", str(path), "--out", str(tmp_path / "out")]) == 2
    assert problem in one_error_line(capsys.readouterr().err, path, key)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "old, new, key, problem",
    [
        ('name = "arm"', 'name = "int"', "name", "model name 'int' is a C keyword"),
        ('name = "1"\nparent = "base"', 'name = "1"\nparent = "1"', "[[frame]] '1' parent", "frame '1' is its own parent"),
    ],
)
def test_name_and_frame_tree_refused_by_derive(tmp_path: Path, capsys, old: str, new: str, key: str, problem: str) -> None:
    path = two_link(tmp_path)
    path.write_text(path.read_text().replace(old, new))
    assert cli.main(["-q", "derive", str(path)]) == 2
    assert problem in one_error_line(capsys.readouterr().err, path, key)


def test_hostile_model_through_the_installed_command(tmp_path: Path) -> None:
    """The shape that made `derive` run for minutes, as a user runs it: answered at once with one error line,
    status 2; without -q the line that the command started (written before SymPy is imported) comes first."""
    path = two_link(tmp_path, A="l2*10**10**10")
    result = subprocess.run([sys.executable, "-m", "symbolic", "derive", str(path)], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    started, error = result.stderr.split("\n", 1)
    assert started == f"symbolic: {path}: reading the model"
    one_error_line(error, path, "[[frame]] '2' dh.a")


def test_ctrl_c_prints_interrupted_and_exits_130() -> None:
    """A real SIGINT half a second into analysing the Panda (minutes of work), after the imports."""
    code = (
        "import os, signal, sys\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)  # a background job starts with SIGINT ignored\n"
        "from symbolic import cli\n"
        "signal.signal(signal.SIGALRM, lambda *_: os.kill(os.getpid(), signal.SIGINT))\n"
        "signal.setitimer(signal.ITIMER_REAL, 0.5)\n"
        "sys.exit(cli.main(['-q', 'analyze', 'panda']))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert (result.returncode, result.stderr, result.stdout) == (130, "interrupted\n", "")


@pytest.mark.parametrize(
    "l_cr, design, status, message",
    [
        (None, "l_cr,l_c3,l_c1", 0, ""),
        (None, "g", 2, "error: --design: no balancing or decoupling condition determines g (parameters in the conditions: l1, l2, "),
        (None, "l_c1,J0", 2, "error: --design: no balancing or decoupling condition determines J0"),
        # Madill's five-bar with l_cr = 0.1: l_c1 alone cannot balance it (test_analysis)
        ("0.1", "l_c1", 2, "error: --design: 2 condition(s) cannot be met with the free parameters l_c1: D[q1,q2] = 0; V independent of Q #2"),
    ],
)
def test_analyze_design_that_solves_nothing_or_cannot_be_met_fails(
    tmp_path: Path, capsys, l_cr: str | None, design: str, status: int, message: str
) -> None:
    model = "fivebar"
    if l_cr is not None:
        text = (Path(robots.__file__).parent / "fivebar.toml").read_text()
        assert "l_cr = { value = 0.162," in text
        model = str(tmp_path / "fivebar.toml")
        Path(model).write_text(text.replace("l_cr = { value = 0.162,", f"l_cr = {{ value = {l_cr},"))
    assert cli.main(["-q", "analyze", model, "--design", design]) == status
    err = capsys.readouterr().err
    assert err.startswith(message) and err.count("\n") == (1 if status else 0), err


def test_ctrl_c_during_start_up_prints_interrupted_and_exits_130() -> None:
    """A SIGINT while the package is still importing (before symbolic.cli.main runs) is answered the same way."""
    code = (
        "import os, signal, sys, builtins\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)  # a background job starts with SIGINT ignored\n"
        "real = builtins.__import__\n"
        "def slow(name, *a, **k):\n"
        "    if name == 'sympy': os.kill(os.getpid(), signal.SIGINT)\n"
        "    return real(name, *a, **k)\n"
        "builtins.__import__ = slow\n"
        "import symbolic_launcher\n"
        "sys.exit(symbolic_launcher.main())\n"
    )
    result = subprocess.run([sys.executable, "-c", code, "list"], capture_output=True, text=True, timeout=120)
    assert (result.returncode, result.stderr, result.stdout) == (130, "interrupted\n", "")


def test_a_closed_pipe_ends_quietly() -> None:
    """`symbolic list | head -1`: the reader has gone; no traceback, status 1 (as Python's docs advise)."""
    import os

    read, write = os.pipe()
    os.close(read)
    try:
        result = subprocess.run([sys.executable, "-m", "symbolic", "list"], stdout=write, stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write)
    assert (result.returncode, result.stderr) == (1, "")


def test_a_misspelled_built_in_name_gets_a_suggestion(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["-q", "derive", "pandaa"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "did you mean 'panda'?" in err


def _one_line_exit_2(result: subprocess.CompletedProcess, *parts: str) -> None:
    """A user-facing failure: exit 2, one line on stderr naming where, no traceback."""
    assert result.returncode == 2, (result.returncode, result.stderr)
    lines = [line for line in result.stderr.splitlines() if not line.startswith(("symbolic: ", "warning: "))]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "Traceback" not in result.stderr
    for part in parts:
        assert part in lines[0], (part, lines[0])


def test_rank_deficient_identification_is_one_line(tmp_path: Path) -> None:
    """An axis that never moves cannot give its mass or friction: an IdentificationError, one line, exit 2
    (it printed a traceback and exited 1 before the one error root)."""
    t = [i * 1e-3 for i in range(2000)]
    data = tmp_path / "still.csv"
    data.write_text("t,q_q,tau_q\n" + "".join(f"{x:.6f},0.25,1.5\n" for x in t))
    _one_line_exit_2(run("-q", "identify", "emps", str(data)), f"error: {data}: ", "rank-deficient")


def test_export_c_after_generate(tmp_path: Path) -> None:
    """symbolic.export.c stays the function after symbolic.export.generate has run (no module of the package
    shadows it: the C sources are symbolic.codegen.c_source)."""
    import symbolic

    model = symbolic.derive(symbolic.robots.load("emps"))
    symbolic.export.generate(model, tmp_path / "all", targets=["c", "report"])
    written = symbolic.export.c(model, tmp_path / "c")
    assert [p.name for p in written] == ["emps.c", "emps.h"]
    assert callable(symbolic.export.report) and callable(symbolic.export.casadi)


def test_a_bug_is_reported_as_one(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    """Anything that is not a SymbolicError (nor the OS's own error) is a bug: a traceback and a line saying so."""
    def broken(args):
        raise ZeroDivisionError("an internal mistake")

    monkeypatch.setattr(cli, "cmd_list", broken)
    assert cli.main(["-q", "list"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and "ZeroDivisionError: an internal mistake" in err
    assert "this is a bug of symbolic, not of your input" in err


def test_every_error_class_is_under_the_root() -> None:
    import symbolic
    from symbolic import errors

    for name in ("ModelError", "DataError", "IdentificationError", "ExportError", "SimulationError", "MatplotlibMissing"):
        assert issubclass(getattr(errors, name), symbolic.SymbolicError), name
    from symbolic.numeric.operational import NoEndEffector, SingularConfiguration
    from symbolic.reproduction.milne.alpha_simulation import AlphaLoopError

    for cls in (NoEndEffector, SingularConfiguration, AlphaLoopError):
        assert issubclass(cls, symbolic.SymbolicError), cls


def test_json_output_is_strict_json_with_the_non_finite_values_listed() -> None:
    """issue 22 item 9: --json printed NaN and Infinity, which strict parsers refuse."""
    import math

    import numpy as np

    text = cli.strict_json({"gap": {"q1": float("nan"), "q2": 1.5}, "sigma": [np.float64("inf"), np.float32(2.0)]})
    value = json.loads(text, parse_constant=lambda name: pytest.fail(f"{name} in strict JSON"))
    assert value["gap"] == {"q1": None, "q2": 1.5} and value["sigma"] == [None, 2.0]
    assert value["not_finite"] == [{"path": "gap.q1", "value": "nan"}, {"path": "sigma[0]", "value": "inf"}]
    assert math.isfinite(value["sigma"][1])


def test_identify_checks_figures_and_out_before_the_work(tmp_path: Path) -> None:
    """issue 22 item 12: `identify --figures EXISTING_FILE` raised FileExistsError after the identification."""
    existing = tmp_path / "notes.txt"
    existing.write_text("mine")
    _one_line_exit_2(run("-q", "identify", "emps", str(tmp_path / "no_data.csv"), "--figures", str(existing)),
                     "--figures", "is not a folder")
    _one_line_exit_2(run("-q", "identify", "emps", str(tmp_path / "no_data.csv"), "--out", str(tmp_path)),
                     "--out", "name the model file")
    assert existing.read_text() == "mine"


# -- issue 39: --version, the effects in diagnose --help, "did you mean", units in the help ---------------

def _imports_after(argv: list[str]) -> tuple[str, list[str]]:
    """What ``symbolic ARGV`` prints on stdout, and which of SymPy, NumPy it imported (in a fresh process)."""
    code = ("import contextlib, io, sys\nfrom symbolic import cli\nout = io.StringIO()\n"
            "with contextlib.redirect_stdout(out):\n    try:\n        cli.main(sys.argv[1:])\n    except SystemExit:\n        pass\n"
            "print(out.getvalue(), end='')\nprint([m for m in ('sympy', 'numpy') if m in sys.modules])")
    result = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    *printed, imported = result.stdout.splitlines()
    return "\n".join(printed), json.loads(imported.replace("'", '"'))


def test_version_and_help_answer_without_importing_sympy() -> None:
    from symbolic.version import __version__

    assert _imports_after(["--version"]) == (f"symbolic {__version__}", [])
    printed, imported = _imports_after(["--help"])
    assert "--version" in printed and imported == []
    printed, imported = _imports_after(["simulate", "--help"])
    assert imported == []
    # the unit of ε: the velocity's, per coordinate (help text wrapped by argparse)
    assert "m/s for a prismatic coordinate, rad/s for a revolute one" in " ".join(printed.split())


def test_diagnose_help_lists_every_effect_of_the_catalogue() -> None:
    from symbolic.workflow.effects import EFFECTS

    result = run("diagnose", "--help")
    assert result.returncode == 0, result.stderr
    listed = result.stdout.split("effects (--effects NAMES; default: all; --list-effects: their parameters and units):\n")[1]
    listed = listed.split("\njudged on the response")[0].splitlines()  # then the response's (tests/test_response.py)
    assert [line.split()[0] for line in listed] == list(EFFECTS)
    assert all(EFFECTS[line.split()[0]].summary in line for line in listed)


def test_a_misspelt_effect_gets_a_suggestion(tmp_path: Path) -> None:
    result = run("-q", "diagnose", "emps", str(tmp_path / "log.csv"), "--out", str(tmp_path / "out"),
                 "--effects", "viscous,coulmb")
    _one_line_exit_2(result, "--effects: unknown effect(s) ['coulmb']", "; did you mean 'coulomb'?")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("change", "words", "wanted"),
    [
        (('mass = "m1"', 'mas = "m1"'), "unknown key(s) ['mas'] (allowed: ", "mass"),
        (('gravity = ["0", "0", "-g"]', 'gravty = ["0", "0", "-g"]'), "top level: unknown key(s) ['gravty']", "gravity"),
        (("m1 = 1.0", "m1 = { value = 1.0, fixd = true }"), "[parameters] m1: unknown key(s) ['fixd']", "fixed"),
        (('mass = "m1"', 'mass = "m11"'), "undeclared symbol 'm11'", "m1"),
        (('inertia = { xx = "0.001"', 'inertia = { xxx = "0.001"'), "unknown key(s) ['xxx']", "xx"),
    ],
)
def test_a_misspelt_model_file_key_gets_a_suggestion(tmp_path: Path, change: tuple[str, str], words: str,
                                                     wanted: str) -> None:
    text = models.two_link()
    assert change[0] in text
    path = tmp_path / "arm.toml"
    path.write_text(text.replace(*change, 1))
    _one_line_exit_2(run("-q", "derive", str(path)), words, f"did you mean {wanted!r}?")
