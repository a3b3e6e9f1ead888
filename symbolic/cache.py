"""The user's cache folder: derivations and compiled libraries kept between commands (for all layers).

Where it is, what is kept there and why pickles may be read from it: docs/architecture.md, "Derived products
and the cache". Derived SymPy products (``derived/``: a derivation, a regressor, base parameters,
straight-line programs) are named by :func:`entry_path`, written by :func:`save` and read by :func:`load`;
compiled libraries (:func:`library_folders`, :mod:`symbolic.codegen.compiled`) are named by the hash of their
C source and compiler command. Everything the package runs from disk passes :func:`untrusted`, checked on the
open file (:func:`read_trusted`); pickles are never read from anywhere else (data files refuse them:
docs/data.md).
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import logging
import os
import pickle
import platform
import shutil
import stat
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from symbolic.version import __version__
from symbolic.writing import safe_stem

LOG = logging.getLogger(__name__)

MAGIC = b"symbolic-cache 1\n"
"""First line of every derived entry (the entry format's own version)."""

PACKAGE = Path(__file__).resolve().parent


def disabled() -> bool:
    """Whether ``SYMBOLIC_NO_CACHE`` turns the cache off (any value but ``""`` and ``"0"``)."""
    return os.environ.get("SYMBOLIC_NO_CACHE", "") not in ("", "0")


def folder() -> Path:
    """The cache folder: ``$SYMBOLIC_CACHE_DIR``, else ``$XDG_CACHE_HOME/symbolic``, else ``~/.cache/symbolic``,
    whether or not it exists or is turned off (:func:`disabled`: nothing is then read from it or written to
    it, and compiled libraries go to :func:`private_folder`)."""
    given = os.environ.get("SYMBOLIC_CACHE_DIR")
    if given:
        return Path(given)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "symbolic"


@functools.lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 of the package's Python sources (relative path and bytes of each, sorted): changes with the code."""
    digest = hashlib.sha256()
    for path in sorted(PACKAGE.rglob("*.py")):
        digest.update(path.relative_to(PACKAGE).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.lru_cache(maxsize=1)
def stamp() -> dict[str, str]:
    """What an entry must have been written by: package version and sources, Python, SymPy, NumPy."""
    import numpy

    return {
        "symbolic": __version__,
        "sources": source_digest()[:32],
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "sympy": sympy_version(),
        "numpy": numpy.__version__,
    }


def sympy_version() -> str:
    """SymPy's ``__version__``, read from its ``release.py`` (where ``sympy/__init__.py`` takes it from) when
    SymPy is not imported yet: a command that finds its numbers in the cache does not import SymPy
    (``symbolic simulate``, docs/simulation.md)."""
    if "sympy" not in sys.modules:
        import importlib.util
        import re

        spec = importlib.util.find_spec("sympy")
        release = Path(spec.origin).with_name("release.py") if spec is not None and spec.origin else None
        try:
            found = re.search(r"^__version__\s*=\s*[\"']([^\"']+)[\"']\s*$", release.read_text(encoding="utf-8"),
                              re.MULTILINE) if release is not None else None
        except OSError:
            found = None
        if found:
            return found.group(1)
    import sympy

    return sympy.__version__


def entry_path(kind: str, key: str) -> Path:
    """The file of the derived entry (``kind``, ``key``) under the current :func:`stamp`: named by
    SHA-256(kind, key, stamp).

    ``key`` is the caller's digest of what the product is a function of (the robot description,
    :func:`symbolic.description.robot.digest`); the stamp names the package version, a digest of the
    package's own source files (a development checkout never reuses a product of other code), and the Python,
    SymPy and NumPy versions: an entry is never shared between versions.
    """
    name = hashlib.sha256(json.dumps([kind, key, stamp()]).encode()).hexdigest()[:32]
    return folder() / "derived" / f"{safe_stem(kind)}-{name}.pickle"


def _header(kind: str, key: str) -> bytes:
    return json.dumps({"kind": kind, "key": key, "stamp": stamp()}, sort_keys=True).encode() + b"\n"


def untrusted(status: os.stat_result) -> str:
    """What lets someone other than the user change the file or folder of ``status`` ("" when nothing).

    The one check of everything the package runs from disk (pickles here, compiled libraries and their
    folders in :mod:`symbolic.codegen.compiled`): it must belong to the user and neither group nor others
    may write it. POSIX only; elsewhere the folder's ACLs decide.
    """
    if not hasattr(os, "getuid"):
        return ""
    if status.st_uid != os.getuid():
        return f"it belongs to user {status.st_uid}, not to you (user {os.getuid()})"
    if status.st_mode & 0o022:
        return f"group or others may write to it (mode {stat.S_IMODE(status.st_mode):#o})"
    return ""


def read_trusted(path: Path) -> tuple[str, bytes]:
    """``("", content)`` of the regular file ``path`` when :func:`untrusted` finds nothing, else ``(problem, b"")``.

    The check is made on the open file (``fstat``), never on the name, and a symbolic link is not followed,
    so the bytes returned are those of the file checked, whatever is renamed meanwhile. Raises
    :class:`OSError` (e.g. :class:`FileNotFoundError`) when the file cannot be opened.
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NONBLOCK", 0)
    with open(os.open(path, flags), "rb") as file:  # O_NONBLOCK: a FIFO under the name does not hang the read
        status = os.fstat(file.fileno())
        if not stat.S_ISREG(status.st_mode):
            return "it is not a regular file", b""
        problem = untrusted(status)
        return (problem, b"") if problem else ("", file.read())


def load(kind: str, key: str, persistent_load: Callable[[str], Any] | None = None) -> tuple[Any] | None:
    """``(value,)`` of the entry (``kind``, ``key``), or ``None`` when it is absent, foreign or corrupt.

    Ignored, so that the caller builds the product again and overwrites it: an entry whose header differs (a
    foreign entry), whose payload does not match its digest (a truncated or corrupt file), that fails to
    unpickle, or that is not the user's own or that others may write (:func:`read_trusted`). Pickle runs code
    named in the file it loads: it is used here only because every entry is read from this folder, which the
    package creates for its own use (mode 0o700).

    ``persistent_load`` gives back the objects that :func:`save`'s ``persistent_id`` left out of the file
    (the caller's live objects, e.g. the robot description); an unknown name makes the entry corrupt.
    """
    if disabled():
        return None
    path = entry_path(kind, key)
    try:
        untrusted_entry, raw = read_trusted(path)
    except FileNotFoundError:
        return None
    except OSError as error:
        LOG.info("cache: cannot read %s (%s)", path, error)
        return None
    if untrusted_entry:
        LOG.info("cache: %s is ignored: %s", path, untrusted_entry)
        return None
    problem, payload = _payload(raw, kind, key)
    if problem:
        LOG.info("cache: %s: %s; it is built again", path, problem)
        return None
    try:
        return (_Unpickler(io.BytesIO(payload), persistent_load).load(),)
    except Exception as error:  # any failure to rebuild the objects: the entry is not usable, build again
        LOG.info("cache: %s cannot be loaded (%s: %s); it is built again", path, type(error).__name__, error)
        return None


def _payload(raw: bytes, kind: str, key: str) -> tuple[str, bytes]:
    """("", payload) of a valid entry, else (what is wrong, b"")."""
    if not raw.startswith(MAGIC):
        return "not a cache entry of this format", b""
    header, newline, rest = raw[len(MAGIC):].partition(b"\n")
    digest, newline2, payload = rest.partition(b"\n")
    if not newline or not newline2:
        return "truncated", b""
    if header + b"\n" != _header(kind, key):
        return "written for another model, kind or version", b""
    if hashlib.sha256(payload).hexdigest().encode() != digest:
        return "corrupt (its content does not match its digest)", b""
    return "", payload


def save(kind: str, key: str, value: Any, persistent_id: Callable[[Any], str | None] | None = None,
         reducer: Callable[[Any], Any] | None = None) -> Path | None:
    """Write ``value`` as the entry (``kind``, ``key``); the path, or ``None`` when turned off or not writable.

    The file holds :data:`MAGIC`, a header line (the kind, the key and the stamp, as JSON) and the SHA-256 of
    its payload, then the payload; it is written under a temporary name and renamed (:func:`write_private`),
    so a concurrent reader sees a whole entry or none.

    ``persistent_id(obj)`` names objects to leave out of the file (given back by :func:`load`'s
    ``persistent_load``); ``reducer(obj)`` may give a faster way to rebuild ``obj`` (``reducer_override``
    of :class:`pickle.Pickler`: a reduce tuple, or ``NotImplemented`` for the default).
    """
    if disabled():
        return None
    path = entry_path(kind, key)
    buffer = io.BytesIO()
    pickler = _Pickler(buffer, persistent_id, reducer)
    try:
        with _deep_recursion():
            pickler.dump(value)
    except (pickle.PicklingError, TypeError, AttributeError, RecursionError) as error:
        LOG.warning("cache: %s of %s cannot be kept (%s)", kind, key[:12], error)
        return None
    payload = buffer.getvalue()
    try:
        make_folder(path.parent)
        write_private(path, MAGIC + _header(kind, key) + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload)
    except OSError as error:
        LOG.info("cache: cannot write %s (%s)", path, error)
        return None
    return path


def write_private(path: Path, content: bytes) -> None:
    """Write ``content`` to ``path`` readable by the user only, through a temporary file and a rename."""
    descriptor, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)  # mode 0o600
    try:
        with os.fdopen(descriptor, "wb") as file:
            file.write(content)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def make_folder(path: Path) -> None:
    """``path`` and its parents, the new ones readable by the user only."""
    path.mkdir(mode=0o700, parents=True, exist_ok=True)


class _Pickler(pickle.Pickler):
    def __init__(self, file: io.BytesIO, persistent_id: Callable[[Any], str | None] | None,
                 reducer: Callable[[Any], Any] | None) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._persistent = persistent_id
        self._reducer = reducer

    def persistent_id(self, obj: Any) -> str | None:
        return None if self._persistent is None else self._persistent(obj)

    def reducer_override(self, obj: Any) -> Any:
        return NotImplemented if self._reducer is None else self._reducer(obj)


class _Unpickler(pickle.Unpickler):
    def __init__(self, file: io.BytesIO, persistent_load: Callable[[str], Any] | None) -> None:
        super().__init__(file)
        self._persistent = persistent_load

    def persistent_load(self, pid: Any) -> Any:
        if self._persistent is None or not isinstance(pid, str):
            raise pickle.UnpicklingError(f"unexpected reference {pid!r}")
        return self._persistent(pid)

    def load(self) -> Any:
        with _deep_recursion():
            return super().load()


class _deep_recursion:
    """Expression trees nest deeper than Python's default recursion limit allows pickle to follow."""

    LIMIT = 20_000

    def __enter__(self) -> None:
        self.previous = sys.getrecursionlimit()
        sys.setrecursionlimit(max(self.previous, self.LIMIT))

    def __exit__(self, *exc: object) -> None:
        sys.setrecursionlimit(self.previous)


@functools.lru_cache(maxsize=1)
def private_folder() -> Path:
    """A folder of this process's own (``tempfile.mkdtemp``: a new name, mode 0o700), removed at exit."""
    path = Path(tempfile.mkdtemp(prefix="symbolic-"))
    import atexit

    atexit.register(shutil.rmtree, path, ignore_errors=True)
    return path


def library_folders() -> list[Path]:
    """Where compiled libraries are kept, in order of preference: the cache's ``libraries/`` and a per-user
    temporary folder (when the cache is not writable); turned off, a per-process folder removed at exit.

    A folder is used only after the check of :func:`untrusted` (:mod:`symbolic.codegen.compiled`).
    """
    if disabled():
        return [private_folder()]
    uid = getattr(os, "getuid", lambda: 0)()
    return [folder() / "libraries", Path(tempfile.gettempdir()) / f"symbolic-{uid}"]
