"""The package's layers import one way only (docs/architecture.md, "Layers").

Every ``import`` in every module of ``symbolic/`` is parsed with :mod:`ast` — including imports inside
functions, which a lazy import would otherwise hide — and refused when it reaches a higher layer.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "symbolic"

# Lowest first. A module may import its own layer and the layers before it.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("symbolic.errors", "symbolic.version", "symbolic.writing", "symbolic.plotting"),
    ("symbolic.spec",),
    ("symbolic.data",),
    ("symbolic.derive",),
    ("symbolic.numeric",),
    ("symbolic.emit",),
    ("symbolic.identify",),
    ("symbolic.workflow",),
    ("symbolic.reproduction",),  # the seeds' numbers recomputed through the layers below
    ("symbolic", "symbolic.cli", "symbolic.__main__", "symbolic.builtin_outputs"),  # applications on top
)


def layer(module: str) -> int:
    """Rank of ``module``: the layer whose longest prefix matches it."""
    best, rank = -1, None
    for i, prefixes in enumerate(LAYERS):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
                best, rank = len(prefix), i
    if rank is None:
        raise LookupError(f"module {module} belongs to no layer: add it to LAYERS and docs/architecture.md")
    return rank


def imported_modules(source: str, module: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import of a ``symbolic`` module in ``source``."""
    found = []
    package = module if is_package else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            # "from symbolic import emit" imports the module symbolic.emit
            found += [(node.lineno, f"{base}.{a.name}" if base == "symbolic" else base) for a in node.names]
    return [(line, name) for line, name in found if name == "symbolic" or name.startswith("symbolic.")]


def upward_imports(source: str, module: str, is_package: bool = False) -> list[str]:
    """Messages for each import in ``source`` (module ``module``) of a higher layer."""
    own = layer(module)
    return [
        f"{module}:{line} imports {name} (layer {layer(name)} > {own})"
        for line, name in imported_modules(source, module, is_package)
        if layer(name) > own
    ]


def modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out.append((name, path))
    return out


def test_every_module_belongs_to_a_layer() -> None:
    for name, _ in modules():
        layer(name)


def test_no_module_imports_a_higher_layer() -> None:
    problems = []
    for name, path in modules():
        problems += upward_imports(path.read_text(), name, path.name == "__init__.py")
    assert not problems, "upward imports:\n" + "\n".join(problems)


@pytest.mark.parametrize(
    "module, source",
    [
        ("symbolic.spec.robot", "from symbolic.derive.mode_shapes import BOUNDARIES\n"),
        ("symbolic.derive.dynamics", "def f():\n    from symbolic.numeric import numeric_model\n"),
        ("symbolic.emit.report", "from symbolic import __version__\n"),
        ("symbolic.numeric.casadi", "import symbolic.emit.templates\n"),
        ("symbolic.derive.analysis", "from ..numeric import statics\n"),
    ],
)
def test_a_deliberately_upward_import_is_caught(module: str, source: str) -> None:
    assert upward_imports(source, module), f"{source!r} in {module} was not caught"


def test_downward_and_sibling_imports_pass() -> None:
    source = "from symbolic.spec.robot import Robot\nfrom symbolic.derive import christoffel\nfrom . import exported\n"
    assert upward_imports(source, "symbolic.numeric.casadi") == []
