"""CasADi functions compiled to machine code with the system's C compiler, cached on disk.

CasADi's virtual machine evaluates a function instruction by instruction; the same function
generated as C (``casadi.CodeGenerator``) and compiled with ``-O1`` runs 5 to 30 times faster, which
is what makes a 20 s, 1 kHz simulation of a 7-DOF model take a fraction of a second. The shared
library is named by the SHA-256 of the generated source and the compiler command (its name is its
content) and kept in the ``libraries/`` folder of the cache folder (:mod:`symbolic.cache`:
``$SYMBOLIC_CACHE_DIR``, else ``$XDG_CACHE_HOME/symbolic``, else ``~/.cache/symbolic``; a per-user
temporary folder when that cannot be created; a folder of the process's own, removed at exit, with
``SYMBOLIC_NO_CACHE``), so a model is compiled once per machine (about 1 s for the Panda); libraries
are written under a temporary name and renamed, so concurrent processes never load a half-written
file. Without a C compiler (``$CC``, ``cc``, ``gcc`` or ``clang`` on the PATH) or when compiling
fails, :func:`compile_casadi` returns ``None`` and callers fall back to the virtual machine.

Loading a library runs its code, so nothing is loaded that another user could have written or changed:

* a folder is used only if it belongs to the user and neither group nor others may write to it
  (:func:`symbolic.cache.untrusted`, the check of the cached pickles); one that fails is refused with
  a warning naming it and what is wrong, and the libraries of the run are built in a private folder
  (``tempfile.mkdtemp``) instead;
* the library file must pass the same check, and its SHA-256 must equal the one recorded when this
  package built it (``<library>.sha256``, written beside it under a temporary name and renamed); a
  missing or different digest means the library is built again, never loaded;
* the bytes checked are the bytes run (:func:`_open_verified`).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TypeVar

import casadi as ca

from symbolic import cache
from symbolic.errors import one_line

LOG = logging.getLogger(__name__)

FLAGS = ("-O1", "-shared", "-fPIC")
"""Compiler flags: -O1 compiles the long straight-line functions several times faster than -O2 and
runs them as fast (measured on the Panda and the flexible five-bar)."""

_LOADED: dict[str, ca.Function] = {}

T = TypeVar("T")


def compiler() -> str | None:
    """The C compiler to use, or ``None``."""
    for candidate in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(candidate):
            return shutil.which(candidate)
    return None


def compile_casadi(function: ca.Function) -> ca.Function | None:
    """``function`` as compiled code (same inputs and outputs), or ``None`` without a working compiler."""
    source = casadi_source(function)
    cc = compiler()
    if cc is None:
        return None
    name = library_name(source, "simulate", cc)
    if name not in _LOADED:
        loaded = load_library(source, "simulate", lambda path: ca.external(function.name(), path))
        if loaded is None:
            return None
        _LOADED[name] = loaded
    return _LOADED[name]


def casadi_source(function: ca.Function) -> str:
    """The C source of ``function`` that :func:`compile_casadi` compiles."""
    generator = ca.CodeGenerator(f"{function.name()}.c", {"with_header": False})
    generator.add(function)
    return generator.dump()


def library_name(source: str, prefix: str, cc: str) -> str:
    """``<prefix>_<hash>``, the hash of ``source`` and the compiler command ``cc``."""
    key = hashlib.sha256("\0".join([source, Path(cc).name, *FLAGS]).encode()).hexdigest()[:24]
    return f"{prefix}_{key}"


def load_library(source: str, prefix: str, opener: Callable[[str], T]) -> T | None:
    """``opener(path)`` of ``source`` (C99) compiled to a shared library, or ``None`` without a compiler.

    The library is ``<prefix>_<hash>.so`` (:func:`library_name`) in the first usable folder of
    :func:`symbolic.cache.library_folders`, so an unchanged source is compiled once per machine; it is
    loaded only after the checks of the module docstring. ``opener`` loads a path (``ctypes.CDLL``,
    ``casadi.external``); the path it gets exists only while it runs.
    """
    cc = compiler()
    if cc is None:
        LOG.info("no C compiler found: %s is evaluated without compiled code (slower)", prefix)
        return None
    name = library_name(source, prefix, cc)
    content = _library(cc, source, name)
    return None if content is None else _open_verified(content, name, opener)


def _library(cc: str, source: str, name: str) -> bytes | None:
    """The checked bytes of library ``name``: the cached one if it passes the checks, else built again."""
    for folder in _folders():
        library = folder / f"{name}.so"
        try:
            return _verified(library) or _compile(cc, source, library)
        except OSError as error:
            LOG.info("cannot write compiled code to %s (%s)", folder, error)
        except subprocess.CalledProcessError as error:
            LOG.warning("compiling %s failed (%s); it is evaluated without compiled code", name,
                        error.stderr.strip().splitlines()[-1:] if error.stderr else error)
            return None
    return None


def _folders() -> Iterator[Path]:
    """The library folders that pass the ownership check, in order, then a private one.

    A folder that exists but fails the check is refused (one warning per folder and process) and the
    private folder is used at once: the next candidate may be the same kind of place."""
    for folder in cache.library_folders():
        try:
            cache.make_folder(folder)
            problem = cache.untrusted(folder.stat())
        except OSError as error:
            LOG.info("cannot write compiled code to %s (%s)", folder, error)
            continue
        if problem:
            _refuse(str(folder), problem)
            break
        yield folder
    try:
        private = cache.private_folder()
    except OSError as error:
        LOG.info("cannot make a private folder for compiled code (%s)", error)
        return
    yield private


@functools.lru_cache(maxsize=None)
def _refuse(folder: str, problem: str) -> None:
    LOG.warning("compiled code is not loaded from %s: %s; it is built in a private temporary folder for this "
                "run instead (fix: chmod go-w, or remove the folder, or set SYMBOLIC_CACHE_DIR)", folder, problem)


def digest_file(library: Path) -> Path:
    """The file holding the SHA-256 recorded when ``library`` was built."""
    return library.with_name(library.name + ".sha256")


def _verified(library: Path) -> bytes | None:
    """The bytes of ``library`` if it passes the checks of the module docstring, else ``None`` (build again)."""
    try:
        problem, content = cache.read_trusted(library)
        if not problem:
            problem, recorded = cache.read_trusted(digest_file(library))
    except FileNotFoundError:
        if library.exists() or library.is_symlink():
            LOG.info("%s has no digest recorded when it was built; it is built again", library)
        return None
    except OSError as error:
        LOG.info("cannot read %s (%s); it is built again", library, error)
        return None
    if problem:
        LOG.warning("%s is not loaded: %s; it is built again", library, problem)
        return None
    if hashlib.sha256(content).hexdigest().encode() != recorded.strip():
        LOG.warning("%s is not loaded: its content differs from the digest recorded when it was built; "
                    "it is built again", library)
        return None
    return content


def _compile(cc: str, source: str, library: Path) -> bytes:
    """Compile ``source`` to ``library`` and record its digest; the bytes built."""
    with tempfile.TemporaryDirectory(dir=library.parent) as work:  # mode 0o700: no one else enters
        c_file = Path(work) / "function.c"
        c_file.write_text(source)
        built = Path(work) / "function.so"
        subprocess.run([cc, *FLAGS, str(c_file), "-o", str(built), "-lm"], check=True, capture_output=True, text=True)
        os.chmod(built, 0o700)  # the compiler's mode follows the umask (0o775 under 002), which the check refuses
        content = built.read_bytes()
        os.replace(built, library)
    # library, then digest: a reader in between sees the digest of a build of the same source, and the
    # compiler writes the same bytes for the same source and command, so it never sees a false mismatch
    cache.write_private(digest_file(library), hashlib.sha256(content).hexdigest().encode() + b"\n")
    return content


def _open_verified(content: bytes, name: str, opener: Callable[[str], T]) -> T | None:
    """``opener`` of a copy of ``content`` made for this load alone.

    Why a copy: ``dlopen`` takes a path, and the path checked could be replaced between the check and the
    load by anyone who may rename one of the folders on it. The copy is written from the very bytes whose
    digest was checked, into this process's ``tempfile.mkdtemp`` folder (a new name of mode 0o700 in the
    system's temporary folder, where no other user may rename or replace entries), under a name unique to
    this load that starts with the content's digest (the dynamic loader takes a name it has loaded before
    for the same library, so a name must never stand for other bytes), and removed once loaded.
    """
    digest = hashlib.sha256(content).hexdigest()[:32]
    path = ""
    try:
        descriptor, path = tempfile.mkstemp(prefix=f"{name}-{digest}-", suffix=".so", dir=cache.private_folder())
        with os.fdopen(descriptor, "wb") as file:
            file.write(content)
        return opener(path)
    except (OSError, RuntimeError) as error:  # ctypes raises OSError, casadi RuntimeError
        LOG.warning("compiled code %s cannot be loaded from %s (%s; a temporary folder mounted noexec? set TMPDIR); "
                    "it is evaluated without compiled code", name, path or "the temporary folder",
                    one_line(str(error), 200))
        return None
    finally:
        if path:
            with contextlib.suppress(OSError):
                os.unlink(path)
