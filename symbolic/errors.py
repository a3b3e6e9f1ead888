"""The errors ``symbolic`` raises, all under one root, :class:`SymbolicError`.

Every message names where the problem is (file and key), what is wrong and, where it helps,
what is allowed, so that a user can fix a model file without reading our source.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

PROGRESS_EVERY = 2.0
"""Seconds between two progress lines of long work (logging INFO: stderr under the command line, silenced by -q):
no wait longer than this passes without a line (a campaign's logs, a bag's messages)."""

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


CLOSE_MATCH = 0.6
"""Similarity (difflib's ratio) above which a known name is suggested for a misspelt one."""


def suggestion(name: str, allowed: Iterable[str]) -> str:
    """``"; did you mean 'kp'?"`` for the allowed name nearest ``name``, or ``""`` when none is near: the one
    "did you mean" of every message about a misspelt key or name (model and experiment files, options)."""
    close = difflib.get_close_matches(str(name), list(allowed), n=1, cutoff=CLOSE_MATCH)
    return f"; did you mean {close[0]!r}?" if close else ""


class SymbolicError(Exception):
    """The root of every error ``symbolic`` raises for a user's input or environment.

    The command line catches it and prints its message on one line with exit status 2; any other exception
    is a bug of ``symbolic`` and is reported as one. ``source`` (a file, or ``"<python>"``/``"<arrays>"``) and
    ``key`` (where in it) are set when the error points at a place in a file, else ``None``.
    """

    source: str | None = None
    key: str | None = None


class _Located(SymbolicError):
    """An error at a place of an input file: the message is ``FILE: KEY: what is wrong (what is allowed)``."""

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source = source
        self.key = key
        self.problem = problem
        super().__init__(f"{one_line(str(source))}: {one_line(key, 200)}: {one_line(problem)}")

    def __reduce__(self):  # picklable with its three parts (a worker process may raise it)
        return (type(self), (self.source, self.key, self.problem))


class ModelError(_Located, ValueError):
    """A model description (TOML file or Python description) is invalid.

    Parameters
    ----------
    source
        The model file's path, or ``"<python>"`` for a description built in Python.
    key
        Where in the model the problem is, e.g. ``"[[frame]] 'c3' dh.theta"``.
    problem
        What is wrong and what is allowed.
    """


class DataError(_Located, ValueError):
    """A data file or an experiment file is unusable.

    Parameters
    ----------
    source
        The data or experiment file (or ``"<arrays>"`` for data given in Python).
    key
        Where: a column (``"column 'tau_q'"``), an experiment key (``"[signals] tau_q"``), ...
    problem
        What is wrong and what is allowed.
    """


class IdentificationError(SymbolicError, ValueError):
    """The data cannot determine the parameters (rank-deficient observation matrix, too few rows, ...)."""


class ExportError(SymbolicError, OSError):
    """Output cannot be written (directory missing, not writable, not a directory, disk full, ...)."""


class SimulationError(SymbolicError, RuntimeError):
    """A simulation cannot run or did not stay finite (divergence, an algebraic loop without a solution)."""


class ClusterError(SymbolicError, RuntimeError):
    """A Dask cluster cannot be reached or started, or ``dask.distributed`` is not installed (``symbolic campaign``)."""


class MatplotlibMissing(SymbolicError, RuntimeError):
    """Figures were asked for and matplotlib is not installed (``pip install 'symbolic[plot]'``)."""


class PlotlyMissing(SymbolicError, RuntimeError):
    """An HTML report (``--html``) was asked for and plotly is not installed (``pip install 'symbolic[html]'``)."""


class ModelWarning(UserWarning):
    """A model is usable but physically suspicious (e.g. an inertia violating the triangle inequality)."""
