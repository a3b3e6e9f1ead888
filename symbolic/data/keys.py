"""The one way an experiment file's unknown keys are refused (every table: top level, [window],
[identification], [controller]).

A misspelt key is one line naming the file, the table and key, what the table allows, and the
nearest allowed key (:func:`difflib.get_close_matches`, cut-off 0.6)::

    run.experiment.toml: [controller] kpp: unknown key (allowed for 'pd': kind, coordinates, ...); did you mean 'kp'?
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from symbolic.data.errors import DataError
from symbolic.errors import one_line

CLOSE_MATCH = 0.6
"""Similarity (difflib's ratio) above which an allowed key is suggested for a misspelt one."""


def suggestion(key: str, allowed: Iterable[str]) -> str:
    """``"; did you mean 'kp'?"`` for the allowed key nearest ``key``, or ``""`` when none is near."""
    close = difflib.get_close_matches(str(key), list(allowed), n=1, cutoff=CLOSE_MATCH)
    return f"; did you mean {close[0]!r}?" if close else ""


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
