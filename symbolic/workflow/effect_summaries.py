"""The effect catalogue's keys and one-line summaries read from the effect files' text, without importing them.

``diagnose --help`` lists the effects and must stay immediate (importing the catalogue brings NumPy and SymPy,
a second or more): it reads each module of symbolic/workflow/effects/ with :mod:`ast` and takes the classes that
assign ``name`` and ``summary`` as string literals, as every effect of the package does (a test checks that
this reading equals the registry's). Anything else — ``--list-effects``, the search — uses the registry.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from pathlib import Path

FOLDER = Path(__file__).with_name("effects")


def summaries(folder: Path = FOLDER) -> dict[str, str]:
    """{registry key: summary} of the effects declared in ``folder``'s modules, in the catalogue's order (by
    ``rank`` when written as a literal, else the default 1000, then by key)."""
    return _declared(folder, "name", 1000, lambda node: True, skip=("base",))


def response_summaries(folder: Path = FOLDER) -> dict[str, str]:
    """{identifier: summary} of the effects judged on the response (classes deriving from ``ResponseEffect``
    that assign ``identifier`` and ``summary`` as string literals), in the registry's order (``rank``, then key)."""
    return _declared(folder, "identifier", 100,
                     lambda node: any(isinstance(b, ast.Name) and b.id == "ResponseEffect" for b in node.bases))


def _declared(folder: Path, key: str, default_rank: int, chosen: Callable[[ast.ClassDef], bool],
              skip: tuple[str, ...] = ()) -> dict[str, str]:
    """{``key``: summary} of the classes of ``folder``'s modules (not ``_``-prefixed, not ``skip``) that ``chosen``
    accepts and that assign ``key`` and ``summary`` as string literals, ordered by ``rank`` (a literal, else
    ``default_rank``), then by key."""
    found: dict[str, tuple[int, str]] = {}
    for path in sorted(folder.glob("*.py")):
        if path.name.startswith("_") or path.stem in skip:
            continue
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.ClassDef) and chosen(node):
                values = _literals(node)
                if isinstance(values.get(key), str) and isinstance(values.get("summary"), str):
                    rank = values.get("rank")
                    found[values[key]] = (rank if isinstance(rank, int) else default_rank, values["summary"])
    return {name: summary for name, (_, summary) in sorted(found.items(), key=lambda item: (item[1][0], item[0]))}


def two_encoder_summaries(folder: Path = FOLDER) -> dict[str, str]:
    """{name: summary} of the two-encoder test (``SUMMARIES`` of joint_elasticity.py, a dict literal)."""
    for node in ast.parse((folder / "joint_elasticity.py").read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "SUMMARIES" for t in node.targets):
            return dict(ast.literal_eval(node.value))
    return {}


def _literals(cls: ast.ClassDef) -> dict[str, object]:
    """The class's attributes assigned string literals, also by tuple unpacking (``name, roles = "x", (...)``)."""
    out: dict[str, object] = {}
    for statement in cls.body:
        if not isinstance(statement, ast.Assign):
            continue
        for target in statement.targets:
            if isinstance(target, ast.Name) and isinstance(statement.value, ast.Constant):
                out[target.id] = statement.value.value
            elif isinstance(target, ast.Tuple) and isinstance(statement.value, ast.Tuple):
                for t, v in zip(target.elts, statement.value.elts):
                    if isinstance(t, ast.Name) and isinstance(v, ast.Constant):
                        out[t.id] = v.value
    return out
