"""The public API: every package lists it in ``__all__``, each listed name exists, docs/api.md documents each,
and no submodule shadows a function of its package (``symbolic.export.c`` stays callable)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

import symbolic

API_DOC = Path(__file__).resolve().parents[1] / "docs" / "api.md"
PUBLIC = ("symbolic", "symbolic.description", "symbolic.robots", "symbolic.data", "symbolic.derivation", "symbolic.codegen",
          "symbolic.numeric", "symbolic.simulation", "symbolic.export", "symbolic.identify", "symbolic.workflow",
          "symbolic.fleet", "symbolic.reproduction")


def documented(package: str) -> set[str]:
    """Names in backticks in the table of docs/api.md's section ``## `package` ``."""
    text = API_DOC.read_text()
    match = re.search(rf"^## `{re.escape(package)}`\n(.*?)(?=^## |\Z)", text, flags=re.S | re.M)
    assert match, f"docs/api.md has no section for {package}"
    return set(re.findall(r"^\| `([^`]+)` \|", match.group(1), flags=re.M))


@pytest.mark.parametrize("package", PUBLIC)
def test_all_names_exist_and_are_documented(package: str) -> None:
    module = importlib.import_module(package)
    names = getattr(module, "__all__", None)
    assert names, f"{package} has no __all__"
    missing = [n for n in names if not hasattr(module, n)]
    assert not missing, f"{package}.__all__ lists names it does not have: {missing}"
    undocumented = sorted(set(names) - documented(package))
    assert not undocumented, f"docs/api.md does not document {package}: {undocumented}"
    stale = sorted(documented(package) - set(names))
    assert not stale, f"docs/api.md documents names {package}.__all__ does not list: {stale}"


def packages() -> list[str]:
    found = ["symbolic"]
    for name in found:
        module = importlib.import_module(name)
        found += [f"{name}.{m.name}" for m in pkgutil.iter_modules(module.__path__) if m.ispkg]
    return found


KNOWN_CLASHES: set[str] = set()
"""None left: the package ``symbolic.derive`` became ``symbolic.derivation`` and the module
``symbolic.workflow.diagnose`` became ``symbolic.workflow.diagnosis``, so the functions ``symbolic.derive`` and
``symbolic.workflow.diagnose`` are never replaced by a submodule."""


def test_no_submodule_shadows_a_function_of_its_package() -> None:
    """A name the package binds to a function must not also be one of its submodules: importing that submodule
    later would replace the function (``symbolic.export.c(...)`` raised "'module' object is not callable")."""
    clashes = []
    for name in packages():
        module = importlib.import_module(name)
        submodules = {m.name for m in pkgutil.iter_modules(module.__path__)}
        for attribute in sorted(submodules & set(vars(module))):
            if not inspect.ismodule(getattr(module, attribute)):
                clashes.append(f"{name}.{attribute}")
    assert set(clashes) <= KNOWN_CLASHES, f"functions named like a submodule of their package: {clashes}"


def test_no_aliases_of_old_layer_names() -> None:
    """``symbolic.spec`` and ``symbolic.emit`` bridged a release that never shipped; they are gone, not half-there."""
    for name in ("symbolic.spec", "symbolic.emit"):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(name)
