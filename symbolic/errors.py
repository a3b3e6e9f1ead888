"""Errors raised for bad model input.

Every message names where the problem is (file and key), what is wrong and, where it helps,
what is allowed, so that a user can fix a model file without reading our source.
"""

from __future__ import annotations

from collections.abc import Iterable

SHOWN = 60
"""Characters of a long piece of user text shown in a message (see :func:`shorten`)."""


def shorten(text: str, limit: int = 80) -> str:
    """``text`` quoted (``repr``) for a one-line message; text longer than ``limit`` shows its first
    :data:`SHOWN` characters and its length, so an 8 KB expression does not flood the terminal."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:SHOWN]!r}… ({len(text)} characters)"


def shown(value: object, limit: int = 80) -> str:
    """Any user value for a one-line message: a string as :func:`shorten` quotes it, anything else by
    its ``repr``, shortened the same way."""
    if isinstance(value, str):
        return shorten(value, limit)
    return one_line(repr(value), limit)


def listing(names: Iterable[object], separator: str = ", ", most: int = 12) -> str:
    """User-given names for a one-line message: a short plain name as it is, a long one by its first
    24 characters, at most ``most`` of them and then how many more, so that a file with thousands of
    long frame names still gets a short error."""
    items = list(names)
    texts = []
    for n in items[:most]:
        text = n if isinstance(n, str) else repr(n)
        plain = text.isprintable() and len(text) <= 32
        texts.append(text if plain else f"{one_line(text[:24])!r}…")
    if len(items) > most:
        texts.append(f"… and {len(items) - most} more")
    return separator.join(texts)


def one_line(text: str, limit: int | None = None) -> str:
    """``text`` with line breaks and other control characters escaped (a key built from a TOML key may
    contain any character), so that every error is one line; shortened past ``limit`` characters."""
    if not text.isprintable():
        text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    if limit is not None and len(text) > limit:
        return f"{text[:SHOWN]}… ({len(text)} characters)"
    return text


class ModelError(ValueError):
    """A model description (TOML file or Python spec) is invalid.

    Parameters
    ----------
    source
        The model file's path, or ``"<python>"`` for a spec built in Python.
    key
        Where in the model the problem is, e.g. ``"[[frame]] 'c3' dh.theta"``.
    problem
        What is wrong and what is allowed.
    """

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source = source
        self.key = key
        self.problem = problem
        super().__init__(f"{one_line(str(source))}: {one_line(key, 200)}: {one_line(problem)}")


class ModelWarning(UserWarning):
    """A model is usable but physically suspicious (e.g. an inertia violating the triangle inequality)."""
