"""Every cross-reference in the package's docstrings and in docs/ names something that exists.

A docstring's ``:mod:``, ``:func:``, ``:class:``, ``:meth:``, ``:attr:``, ``:data:`` and ``:exc:`` targets, and the
``symbolic.…`` module paths and ``symbolic/….py`` file paths that docs/*.md and README.md name (except the path
an example file gives itself, ``# symbolic/….py`` on a fenced block's first line), are resolved
against the code: a module moved or renamed leaves no stale name behind (issue 33: docstrings still named the
modules of the flat layout). Unqualified targets are looked up as Sphinx does, in the module the docstring belongs
to (its globals, and the attributes of its classes); targets in other libraries are checked when the library
is installed.
"""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "symbolic"
ROLE = re.compile(r":(?:mod|func|class|meth|attr|data|exc|obj):`~?\.?([A-Za-z_][\w.]*)(?:\(\))?`")
DOTTED = re.compile(r"`(symbolic(?:\.[A-Za-z_]\w*)+)(?:\(\))?`")
FILE_PATH = re.compile(r"(?<![\w/.])(?<!# )((?:symbolic|tests|bench|templates)/[\w/]+\.(?:py|j2|toml))\b")
OTHER_LIBRARIES = ("numpy", "scipy", "sympy", "casadi", "jinja2", "dask", "distributed", "matplotlib", "pinocchio",
                   "tomllib", "tomlkit", "defusedxml", "ctypes", "concurrent", "multiprocessing", "os", "pathlib", "subprocess",
                   "warnings", "threading", "hashlib", "dataclasses", "typing", "collections", "functools", "mcap", "rosbags",
                   "plotly")


def module_names() -> list[str]:
    names = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "__main__.py":  # importing it runs the command line
            continue
        parts = path.relative_to(ROOT).with_suffix("").parts
        names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def resolve_dotted(target: str) -> bool:
    """Whether ``a.b.c`` names a module, or an attribute chain of the longest importable module prefix."""
    parts = target.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            obj = attribute(obj, name)
            if obj is MISSING:
                return False
        return True
    return False


MISSING = object()


def attribute(obj: object, name: str) -> object:
    """``getattr``, also finding annotated-only class members (dataclass fields, ``ClassVar``) and properties."""
    if hasattr(obj, name):
        return getattr(obj, name)
    if inspect.isclass(obj):
        for klass in obj.__mro__:
            if name in getattr(klass, "__annotations__", {}) or name in getattr(klass, "__dataclass_fields__", {}):
                return object()
            if klass.__module__.startswith("symbolic") and re.search(rf"\bself\.{name}\b[^=\n]*=", _source(klass)):
                return object()  # an instance attribute set in a method
    return MISSING


def _source(klass: type) -> str:
    try:
        return inspect.getsource(klass)
    except (OSError, TypeError):
        return ""


def resolve_local(target: str, module: ModuleType) -> bool:
    """An unqualified or class-qualified target: a builtin, a module beside ``module`` (or inside it, for a
    package), or a name in ``module``'s namespace or among its classes' members."""
    package = module.__name__ if hasattr(module, "__path__") else module.__name__.rpartition(".")[0]
    if resolve_dotted(f"builtins.{target}") or resolve_dotted(f"{package}.{target}"):
        return True
    head, *rest = target.split(".")
    obj = attribute(module, head)
    if obj is not MISSING:
        for name in rest:
            obj = attribute(obj, name)
            if obj is MISSING:
                return False
        return True
    if rest:
        return False
    classes = [v for v in vars(module).values() if inspect.isclass(v) and v.__module__ == module.__name__]
    return any(attribute(c, head) is not MISSING for c in classes)


def stale_in_module(name: str) -> list[str]:
    module = importlib.import_module(name)
    path = Path(module.__file__ or "")
    stale = []
    for target in sorted(set(ROLE.findall(path.read_text()))):
        if target.split(".")[0] in OTHER_LIBRARIES:
            known = resolve_dotted(target) if _installed(target.split(".")[0]) else True
        elif target.startswith("symbolic."):
            known = resolve_dotted(target)
        else:
            known = resolve_local(target, module)
        if not known:
            stale.append(target)
    return stale


def _installed(library: str) -> bool:
    try:
        importlib.import_module(library)
    except ImportError:
        return False
    return True


@pytest.mark.parametrize("name", module_names())
def test_docstring_references_resolve(name: str) -> None:
    stale = stale_in_module(name)
    assert not stale, f"{name}: docstring names what does not exist: {stale}"


def documents() -> list[Path]:
    return sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]


@pytest.mark.parametrize("document", documents(), ids=lambda p: p.name)
def test_documents_name_existing_modules_and_files(document: Path) -> None:
    text = document.read_text()
    stale = [t for t in sorted(set(DOTTED.findall(text))) if not resolve_dotted(t)]
    stale += [p for p in sorted(set(FILE_PATH.findall(text))) if not (ROOT / p).exists()]
    assert not stale, f"{document.relative_to(ROOT)} names what does not exist: {stale}"


def test_the_patterns_see_references() -> None:
    """The checks above read something: a made-up stale name is caught by each of them."""
    assert ROLE.findall("see :func:`symbolic.flat.old_module.f` and :meth:`~.Effect.columns`") == [
        "symbolic.flat.old_module.f", "Effect.columns"]
    assert not resolve_dotted("symbolic.flat.old_module.f")
    assert resolve_dotted("symbolic.derivation.dynamics.derive")
    assert FILE_PATH.findall("in symbolic/workflow/search.py, not ../symbolic/x.py") == ["symbolic/workflow/search.py"]
    assert FILE_PATH.findall("```python\n# symbolic/export/targets/new.py\n") == []  # an example file's own path
