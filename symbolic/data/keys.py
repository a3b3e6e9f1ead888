"""The one way an experiment file's unknown keys are refused (every table: top level, [window],
[identification], [controller]).

A misspelt key is one line naming the file, the table and key, what the table allows, and the
nearest allowed key (:func:`symbolic.errors.suggestion`, shared with the model files)::

    run.experiment.toml: [controller] kpp: unknown key (allowed for 'pd': kind, coordinates, ...); did you mean 'kp'?
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from symbolic.data.errors import DataError
from symbolic.errors import CLOSE_MATCH, one_line, suggestion

__all__ = ["CLOSE_MATCH", "check_keys", "suggestion", "unknown_key"]


def unknown_key(source: str, table: str, key: str, allowed: Sequence[str], what: str = "unknown key",
                allowed_for: str = "") -> DataError:
    """The error for ``key`` of ``table`` (``""`` for the top level, else ``"[controller]"``, ...)."""
    where = f"{table} {one_line(str(key), 80)}" if table else one_line(str(key), 80)
    scope = f" for {allowed_for}" if allowed_for else ""
    return DataError(source, where, f"{what} (allowed{scope}: {', '.join(allowed)}){suggestion(key, allowed)}")


def check_keys(table: Mapping[str, Any], allowed: Sequence[str], source: str, name: str = "") -> None:
    """Refuse the first key of ``table`` that is not in ``allowed`` (:func:`unknown_key`)."""
    for key in table:
        if key not in allowed:
            raise unknown_key(source, name, key, allowed)
