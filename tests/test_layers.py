"""The package's layers import one way only, and no modules import each other in a circle
(docs/architecture.md, "Layers").

Every ``import`` in every module of ``symbolic/`` is parsed with :mod:`ast` — including imports inside
functions, which a lazy import would otherwise hide — and refused when it reaches a higher layer or
closes a circle of modules.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "symbolic"

# Lowest first. A module may import its own layer and the layers before it.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("symbolic.errors", "symbolic.version", "symbolic.writing", "symbolic.plotting", "symbolic.htmlpage", "symbolic.cache",
     "symbolic.lazy"),
    ("symbolic.description", "symbolic.robots"),
    ("symbolic.data",),
    ("symbolic.derivation",),
    ("symbolic.codegen",),
    ("symbolic.numeric",),
    ("symbolic.simulation",),
    ("symbolic.export",),
    ("symbolic.identify",),
    ("symbolic.workflow",),
    ("symbolic.fleet",),  # campaigns over many logs on Dask: identify, diagnose, simulate per log
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
            # "from symbolic import export" imports the module symbolic.export
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
        ("symbolic.description.robot", "from symbolic.derivation.mode_shapes import BOUNDARIES\n"),
        ("symbolic.derivation.dynamics", "def f():\n    from symbolic.numeric import numeric_model\n"),
        ("symbolic.export.markdown", "from symbolic import __version__\n"),
        ("symbolic.codegen.casadi", "import symbolic.simulation.controller\n"),
        ("symbolic.numeric.statespace", "from symbolic.simulation import simulate\n"),
        ("symbolic.derivation.analysis", "from ..numeric import statics\n"),
    ],
)
def test_a_deliberately_upward_import_is_caught(module: str, source: str) -> None:
    assert upward_imports(source, module), f"{source!r} in {module} was not caught"


def test_downward_and_sibling_imports_pass() -> None:
    source = "from symbolic.description.robot import Robot\nfrom symbolic.derivation import christoffel\nfrom . import exported\n"
    assert upward_imports(source, "symbolic.codegen.casadi") == []


def import_graph() -> dict[str, set[str]]:
    """{module: the package modules it imports}, ``from package import module`` read as the module."""
    names = {name for name, _ in modules()}
    graph: dict[str, set[str]] = {}
    for name, path in modules():
        is_package = path.name == "__init__.py"
        targets = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                package = name if is_package else name.rpartition(".")[0]
                base = node.module or ""
                if node.level:
                    parts = package.split(".")
                    base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
                targets |= {f"{base}.{a.name}" if f"{base}.{a.name}" in names else base for a in node.names}
        graph[name] = {t for t in targets if t in names and t != name}
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_modules_import_each_other_in_a_circle() -> None:
    found = circles(import_graph())
    assert not found, "import circles:\n" + "\n".join(" -> ".join(c) for c in found)


def test_a_circle_is_found() -> None:
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
