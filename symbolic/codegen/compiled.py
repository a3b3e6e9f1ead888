"""CasADi functions compiled to machine code with the system's C compiler, cached on disk.

CasADi's virtual machine evaluates a function instruction by instruction; the same function
generated as C (``casadi.CodeGenerator``) and compiled with ``-O1`` runs 5 to 30 times faster, which
is what makes a 20 s, 1 kHz simulation of a 7-DOF model take a fraction of a second. The shared
library is named by the SHA-256 of the generated source and the compiler command (its name is its
content) and kept in the ``libraries/`` folder of the cache folder (:mod:`symbolic.cache`:
``$SYMBOLIC_CACHE_DIR``, else ``$XDG_CACHE_HOME/symbolic``, else ``~/.cache/symbolic``; a temporary
folder when that is not writable; a folder of the process's own, removed at exit, with
``SYMBOLIC_NO_CACHE``), so a model is compiled once per machine (about 1 s for the Panda); libraries
are written under a temporary name and renamed, so concurrent processes never load a half-written
file. Without a C compiler (``$CC``, ``cc``, ``gcc`` or ``clang`` on the PATH) or when compiling
fails, :func:`compile_casadi` returns ``None`` and callers fall back to the virtual machine.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

from symbolic import cache

LOG = logging.getLogger(__name__)

FLAGS = ("-O1", "-shared", "-fPIC")
"""Compiler flags: -O1 compiles the long straight-line functions several times faster than -O2 and
runs them as fast (measured on the Panda and the flexible five-bar)."""

_LOADED: dict[str, ca.Function] = {}


def compiler() -> str | None:
    """The C compiler to use, or ``None``."""
    for candidate in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(candidate):
            return shutil.which(candidate)
    return None


def cache_folder() -> Path:
    """Where compiled libraries are kept when the cache is on (module docstring)."""
    return cache.library_folders()[0]


def compile_casadi(function: ca.Function) -> ca.Function | None:
    """``function`` as compiled code (same inputs and outputs), or ``None`` without a working compiler."""
    generator = ca.CodeGenerator(f"{function.name()}.c", {"with_header": False})
    generator.add(function)
    library = shared_library(generator.dump(), "simulate")
    if library is None:
        return None
    if str(library) not in _LOADED:
        _LOADED[str(library)] = ca.external(function.name(), str(library))
    return _LOADED[str(library)]


def shared_library(source: str, prefix: str) -> Path | None:
    """``source`` (C99) compiled to a shared library in the cache folder, or ``None`` without a compiler.

    The file is ``<prefix>_<hash>.so``, the hash of the source and the compiler command, so an unchanged
    source is compiled once per machine.
    """
    cc = compiler()
    if cc is None:
        LOG.info("no C compiler found: %s is evaluated without compiled code (slower)", prefix)
        return None
    key = hashlib.sha256("\0".join([source, Path(cc).name, *FLAGS]).encode()).hexdigest()[:24]
    return _build(cc, source, key, prefix)


def _build(cc: str, source: str, key: str, prefix: str) -> Path | None:
    for folder in cache.library_folders():
        library = folder / f"{prefix}_{key}.so"
        if library.is_file():
            return library
        try:
            cache.make_folder(folder)
            return _compile(cc, source, library)
        except OSError as error:
            LOG.info("cannot write compiled code to %s (%s)", folder, error)
        except subprocess.CalledProcessError as error:
            LOG.warning("compiling %s failed (%s); it is evaluated without compiled code", prefix,
                        error.stderr.strip().splitlines()[-1:] if error.stderr else error)
            return None
    return None


def _compile(cc: str, source: str, library: Path) -> Path:
    with tempfile.TemporaryDirectory(dir=library.parent) as work:
        c_file = Path(work) / "function.c"
        c_file.write_text(source)
        built = Path(work) / "function.so"
        subprocess.run([cc, *FLAGS, str(c_file), "-o", str(built), "-lm"], check=True, capture_output=True, text=True)
        os.replace(built, library)
    return library
