"""Each fact in one place (issue 33): no constant copied between modules, no second list of the effect catalogue.

A module-level constant of the same name and the same literal value in two modules is a copy that can drift
(``MIN_GAIN`` beside ``MIN_HELD_OUT_GAIN``, two ``UNIFORM_TOLERANCE``s, each "as the other"): one imports it from
the other. A literal list, tuple, set or dict naming five or more of the catalogue's effects outside
symbolic/workflow/effects/ is a second catalogue: the effects declare what concerns them (units, exclusions,
groups, ranks) and everything else reads the registry. (Five: the model file's friction keys viscous, coulomb,
offset and stribeck are four of the effects' names, and are the model format's, not the catalogue.)
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

from symbolic.workflow.effects import EFFECTS

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "symbolic"


def module_constants() -> dict[tuple[str, object], list[str]]:
    """(name, value) → modules defining the upper-case module-level constant with that literal value."""
    found: dict[tuple[str, object], list[str]] = defaultdict(list)
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Assign):
                targets, value = [t.id for t in node.targets if isinstance(t, ast.Name)], node.value
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None:
                targets, value = [node.target.id], node.value
            else:
                continue
            if isinstance(value, ast.Constant):
                for name in targets:
                    if name.isupper():
                        found[(name, value.value)].append(str(path.relative_to(ROOT)))
    return found


def copies(found: dict[tuple[str, object], list[str]]) -> list[str]:
    return [f"{name} = {value!r} in {', '.join(modules)}" for (name, value), modules in found.items() if len(modules) > 1]


def test_no_constant_is_copied_between_modules() -> None:
    assert copies(module_constants()) == []


def catalogue_lists(source: str, names: set[str]) -> list[int]:
    """Lines of the literal containers in ``source`` whose string elements (or dict keys) name ≥ 5 effects."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
            items = node.elts
        elif isinstance(node, ast.Dict):
            items = [k for k in node.keys if k is not None]
        else:
            continue
        named = {e.value for e in items if isinstance(e, ast.Constant) and isinstance(e.value, str)} & names
        if len(named) >= 5:
            lines.append(node.lineno)
    return lines


def test_the_catalogue_is_listed_once() -> None:
    names = set(EFFECTS)
    effects = PACKAGE / "workflow" / "effects"
    second = {str(p.relative_to(ROOT)): catalogue_lists(p.read_text(), names)
              for p in sorted(PACKAGE.rglob("*.py")) if effects not in p.parents}
    assert {k: v for k, v in second.items() if v} == {}


def test_the_checks_see_copies() -> None:
    assert copies({("MIN_GAIN", 0.1): ["a.py", "b.py"], ("ALPHA", 1e-3): ["a.py"]}) == ["MIN_GAIN = 0.1 in a.py, b.py"]
    source = ('UNITS = {"coulomb": 1, "viscous": 2, "offset": 3, "spring": 4, "gravity": 5}\n'
              'KEYS = ("viscous", "coulomb", "offset", "stribeck")\n')
    assert catalogue_lists(source, set(EFFECTS)) == [1]
