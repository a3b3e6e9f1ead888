"""Golden files for the generated text (C header and source, CasADi loader, report) of a small model.

A template or printer change shows up here as a readable diff. After checking the diff, accept it
with ``python3 -m pytest tests/test_golden.py --update-golden`` and commit tests/golden/.
"""

from __future__ import annotations

from pathlib import Path

import sympy as sp

import symbolic
import symbolic.export as export
from symbolic.derivation.simplify import trig_zero

GOLDEN = Path(__file__).parent / "golden"
TEXT = ("double_pendulum.h", "double_pendulum.c", "double_pendulum.md", "double_pendulum_casadi.py")


def test_golden_files(update_golden: bool) -> None:
    model = symbolic.derive(symbolic.load(GOLDEN / "double_pendulum.toml"))
    files = export.render(model, command="pytest tests/test_golden.py --update-golden")
    for name in TEXT:
        path = GOLDEN / name
        if update_golden:
            path.write_bytes(files[name])
        assert path.exists(), f"missing golden file {path}; run pytest --update-golden"
        assert files[name].decode() == path.read_text(), f"{name} differs from tests/golden/{name} (pytest --update-golden accepts)"


def test_golden_model_is_the_textbook_double_pendulum() -> None:
    """D of point masses at the link ends: d11 = m1 l1² + m2(l1² + l2² + 2 l1 l2 cos q2), d12 = m2(l2² + l1 l2 cos q2), d22 = m2 l2²."""
    model = symbolic.derive(symbolic.load(GOLDEN / "double_pendulum.toml"))
    q1, q2, l1, l2, m1, m2 = sp.symbols("q1 q2 l1 l2 m1 m2", real=True)
    expected = sp.Matrix(
        [
            [m1 * l1**2 + m2 * (l1**2 + l2**2 + 2 * l1 * l2 * sp.cos(q2)), m2 * (l2**2 + l1 * l2 * sp.cos(q2))],
            [m2 * (l2**2 + l1 * l2 * sp.cos(q2)), m2 * l2**2],
        ]
    )
    assert all(trig_zero(e) for e in (model.D - expected))


def test_templates_are_package_data() -> None:
    """pip-installed users export too: the templates ship inside the package (symbolic.templates)."""
    from importlib import resources

    names = {p.name for p in resources.files("symbolic.templates").iterdir()}
    assert {"model.h.j2", "model.c.j2", "report.md.j2", "loader.py.j2"} <= names
