"""Compiled libraries are loaded only from the user's own folders, after a digest check (issue 39, security).

Loading a shared library runs its constructors. A library planted by another user (in the per-user folder
under the temporary directory, used when the cache folder cannot be created) or changed after it was built
must never be loaded: the planted libraries here write a marker file from ``__attribute__((constructor))``,
so a load would leave the marker behind. The run must still give the right numbers (built again in a
folder that passes the check). Real gcc, real files, real ``dlopen``.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import subprocess
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from symbolic import cache
from symbolic.codegen import compiled

pytestmark = [
    pytest.mark.skipif(compiled.compiler() is None, reason="needs a C compiler (gcc, cc or clang)"),
    pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX owners and modes"),
]

PLANTED = r"""
#include <stdio.h>
__attribute__((constructor)) static void planted(void) {
    FILE *marker = fopen("%s", "w");
    if (marker) { fputs("the planted library ran\n", marker); fclose(marker); }
}
"""


@pytest.fixture
def planted(tmp_path: Path) -> tuple[bytes, Path]:
    """The bytes of a library that writes ``marker`` when it is loaded, and the marker's path."""
    marker = tmp_path / "marker"
    (tmp_path / "planted.c").write_text(PLANTED % marker)
    subprocess.run([compiled.compiler(), "-shared", "-fPIC", str(tmp_path / "planted.c"), "-o",
                    str(tmp_path / "planted.so")], check=True, capture_output=True)
    return (tmp_path / "planted.so").read_bytes(), marker


def function(k: float) -> ca.Function:
    """A small CasADi function of its own per test (compile_casadi keeps what it loaded per process)."""
    x = ca.SX.sym("x", 2)
    return ca.Function(f"f{int(k * 1000)}", [x], [ca.sin(x) * k + x[0] * x[1]])


def plant(folder: Path, f: ca.Function, content: bytes, digest: bool = True) -> Path:
    """``content`` under the name ``compile_casadi`` looks for in ``folder`` (with its digest recorded)."""
    folder.mkdir(parents=True, exist_ok=True)
    library = folder / f"{compiled.library_name(compiled.casadi_source(f), 'simulate', compiled.compiler())}.so"
    library.write_bytes(content)
    if digest:
        compiled.digest_file(library).write_text(hashlib.sha256(content).hexdigest() + "\n")
    return library


def assert_right(f: ca.Function) -> None:
    """``compile_casadi(f)`` is compiled code that gives the numbers of CasADi's virtual machine."""
    fast = compiled.compile_casadi(f)
    assert fast is not None
    np.testing.assert_allclose(np.array(fast([0.3, -1.2])), np.array(f([0.3, -1.2])), rtol=1e-14)


@pytest.fixture
def cached(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The ``libraries/`` folder of a cache folder of the test's own."""
    monkeypatch.setenv("SYMBOLIC_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("SYMBOLIC_NO_CACHE", raising=False)
    return tmp_path / "cache" / "libraries"


@pytest.fixture
def fallback(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The per-user folder under the temporary directory, used because the cache folder cannot be created."""
    cache.private_folder()  # made once per process, in the real temporary folder
    (tmp_path / "a-file").write_text("")
    monkeypatch.setenv("SYMBOLIC_CACHE_DIR", str(tmp_path / "a-file" / "cache"))  # under a file: mkdir fails
    monkeypatch.delenv("SYMBOLIC_NO_CACHE", raising=False)
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    folder = cache.library_folders()[1]
    assert folder == tmp_path / "tmp" / f"symbolic-{os.getuid()}"
    return folder


def test_the_planted_library_runs_when_loaded(planted: tuple[bytes, Path], tmp_path: Path) -> None:
    """The control: loading the planted library does write the marker (so its absence below means not loaded)."""
    content, marker = planted
    (tmp_path / "control.so").write_bytes(content)
    ctypes.CDLL(str(tmp_path / "control.so"))
    assert marker.exists()


def test_a_library_planted_in_a_writable_fallback_folder_is_not_loaded(
        fallback: Path, planted: tuple[bytes, Path], caplog: pytest.LogCaptureFixture) -> None:
    content, marker = planted
    f = function(1.1)
    library = plant(fallback, f, content)  # its digest recorded too: the folder alone refuses it
    fallback.chmod(0o777)
    with caplog.at_level(logging.WARNING, logger="symbolic.codegen.compiled"):
        assert_right(f)
    assert not marker.exists()
    refusal = [r.getMessage() for r in caplog.records if "is not loaded from" in r.getMessage()]
    assert refusal == [f"compiled code is not loaded from {fallback}: group or others may write to it (mode 0o777); "
                       "it is built in a private temporary folder for this run instead (fix: chmod go-w, or remove "
                       "the folder, or set SYMBOLIC_CACHE_DIR)"]
    assert library.read_bytes() == content  # nothing was written into the refused folder either
    assert sorted(p.name for p in fallback.iterdir()) == sorted([library.name, compiled.digest_file(library).name])


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0, reason="only root can give a file to another user")
def test_a_fallback_folder_or_library_of_another_user_is_not_loaded(
        fallback: Path, planted: tuple[bytes, Path], caplog: pytest.LogCaptureFixture) -> None:
    content, marker = planted
    f, g = function(1.2), function(1.3)
    fallback.mkdir(mode=0o700)
    os.chown(fallback, 65534, 65534)  # another user's folder, closed to others
    plant(fallback, f, content)
    with caplog.at_level(logging.WARNING, logger="symbolic.codegen.compiled"):
        assert_right(f)
    assert not marker.exists() and "it belongs to user 65534, not to you (user 0)" in caplog.text
    os.chown(fallback, 0, 0)  # the user's folder, but the library and its digest are another user's
    library = plant(fallback, g, content)
    for path in library, compiled.digest_file(library):
        os.chown(path, 65534, 65534)
        path.chmod(0o644)
    assert_right(g)
    assert not marker.exists() and library.read_bytes() != content  # built again over it


def test_a_library_without_a_recorded_digest_is_built_again(fallback: Path, planted: tuple[bytes, Path]) -> None:
    """The user's own folder, a library of the right name whose digest was never recorded: not loaded."""
    content, marker = planted
    f = function(1.4)
    fallback.mkdir(mode=0o700)
    library = plant(fallback, f, content, digest=False)
    assert_right(f)
    assert not marker.exists()
    rebuilt = library.read_bytes()
    assert rebuilt != content and compiled.digest_file(library).read_text() == hashlib.sha256(rebuilt).hexdigest() + "\n"


def test_a_library_changed_after_it_was_built_is_built_again(
        cached: Path, planted: tuple[bytes, Path], caplog: pytest.LogCaptureFixture) -> None:
    content, marker = planted
    f = function(1.5)
    source = compiled.casadi_source(f)
    assert compiled.load_library(source, "simulate", ctypes.CDLL) is not None  # built and recorded
    (library,) = cached.glob("*.so")
    built = library.read_bytes()
    library.write_bytes(content)  # same file, same owner and mode, other bytes
    with caplog.at_level(logging.WARNING, logger="symbolic.codegen.compiled"):
        assert_right(f)
    assert not marker.exists()
    assert f"{library} is not loaded: its content differs from the digest recorded when it was built" in caplog.text
    assert library.read_bytes() == built


@pytest.mark.parametrize("what", ["folder", "library"])
def test_a_cache_folder_or_library_others_may_write_is_refused(
        cached: Path, planted: tuple[bytes, Path], caplog: pytest.LogCaptureFixture, what: str) -> None:
    content, marker = planted
    f = function(1.6 if what == "folder" else 1.7)
    cached.mkdir(parents=True, mode=0o700)
    library = plant(cached, f, content)
    (cached if what == "folder" else library).chmod(0o770 if what == "folder" else 0o666)
    with caplog.at_level(logging.WARNING, logger="symbolic.codegen.compiled"):
        assert_right(f)
    assert not marker.exists()
    if what == "folder":
        assert (f"compiled code is not loaded from {cached}: group or others may write to it (mode 0o770); "
                "it is built in a private temporary folder") in caplog.text
        assert library.read_bytes() == content  # refused: neither read nor written
    else:
        assert f"{library} is not loaded: group or others may write to it (mode 0o666); it is built again" in caplog.text
        assert library.read_bytes() != content and library.stat().st_mode & 0o777 == 0o700
    assert all("\n" not in r.getMessage() for r in caplog.records)


def test_a_library_is_reused_as_built_even_under_a_group_writable_umask(cached: Path) -> None:
    """Normal reuse: the second load reads the same files (same inode and time: not compiled nor recorded again)."""
    f = function(1.8)
    source = compiled.casadi_source(f)
    previous = os.umask(0o002)  # the compiler then writes mode 0o775, which the check would refuse
    try:
        assert compiled.load_library(source, "simulate", ctypes.CDLL) is not None
        (library,) = cached.glob("*.so")
        files = (library, compiled.digest_file(library))
        before = [(p.stat().st_ino, p.stat().st_mtime_ns) for p in files]
        loaded = compiled.load_library(source, "simulate", lambda path: ca.external(f.name(), path))
    finally:
        os.umask(previous)
    assert [(p.stat().st_ino, p.stat().st_mtime_ns) for p in files] == before
    np.testing.assert_allclose(np.array(loaded([0.3, -1.2])), np.array(f([0.3, -1.2])), rtol=1e-14)
    assert not list(cache.private_folder().glob(f"{library.stem}-*"))  # the copy loaded is removed once loaded
