"""The command line, run as a user would (a subprocess, installed entry point semantics)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "symbolic", *args], capture_output=True, text=True, cwd=cwd)


def test_derive_builtin_prints_compact_inertia() -> None:
    result = run("-q", "derive", "fivebar")
    assert result.returncode == 0, result.stderr
    assert "D[1,1] = I1 + I3 + l1**2*m_r + l_c1**2*m1 + l_c3**2*m3" in result.stdout
    assert "coordinates (3): q0, q1, q2" in result.stdout


def test_derive_file(tmp_path: Path) -> None:
    model = tmp_path / "pendulum.toml"
    model.write_text(
        'name = "pendulum"\ncoordinates = ["q"]\ngravity = ["0", "-g", "0"]\n[parameters]\nm = 1.0\nl = 0.5\ng = 9.81\n'
        '[[frame]]\nname = "1"\nparent = "base"\ndh = { theta = "q", d = "0", a = "l", alpha = "0" }\n'
        '[[body]]\nname = "bob"\nframe = "1"\nmass = "m"\n'
    )
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
