"""Replacing a directory's generated files as one set (:func:`replace_files`, used by :func:`symbolic.export.write_files`).

At every instant the output path holds the complete previous set or the complete new one, whatever
interrupts the writer; files the new set does not name are kept unless the caller owns the directory.
The set is staged and fsync-ed in a sibling ``.OUT.symbolic-staging-XXXXXX`` and exchanged in one
``renameat2(RENAME_EXCHANGE)`` call, with two fallbacks (rename aside, then file by file with a
warning), under an ``flock`` on the parent; each run first removes or restores what an interrupted run
left. The guarantee, each step, the fallbacks and what a reader should do: docs/contracts.md, "Output
directories".
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import logging
import os
import re
import secrets
import shutil
import stat
import time
from collections.abc import Iterator, Mapping
from pathlib import Path

log = logging.getLogger(__name__)

STAGING = ".symbolic-staging-"
PREVIOUS = ".symbolic-previous-"
PARTIAL = ".symbolic-partial-"
# Set only by tests/test_output.py: seconds to sleep before each step of the write phase, so that a
# test can interrupt the writer at chosen moments. Never set in normal use.
DELAY_VARIABLE = "SYMBOLIC_TEST_WRITE_DELAY"
# Temporary names of versions before the staging directory: ".NAME.XXXXXXXX.tmp" (tempfile.mkstemp).
_LEGACY_TEMPORARY = re.compile(r"\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp")
_NO_EXCHANGE = {errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP, errno.ENOTSUP}
_NOT_RENAMEABLE = {errno.EXDEV, errno.EBUSY, errno.EACCES, errno.EPERM, errno.EROFS}


class _Unrenameable(Exception):
    """The output directory cannot be replaced by renaming; files must be replaced one at a time."""


def replace_files(files: Mapping[str, bytes], directory: Path, *, owned: bool = False) -> None:
    """Make ``directory`` hold ``files`` (name: content), all of them or none (see the module doc).

    ``owned``: the directory belongs to this set alone, so files it does not name are dropped rather
    than kept. Raises OSError when the directory cannot be written.
    """
    directory = Path(os.path.realpath(directory))  # swap the real directory, not a symlink to it
    parent = directory.parent
    parent.mkdir(parents=True, exist_ok=True)
    pace = _pace()
    with _locked(parent):
        _recover(directory)
        _remove_debris(directory, files)
        if directory.exists() and (not os.access(parent, os.W_OK | os.X_OK) or _is_mount_point(directory)):
            _replace_in_place(files, directory, owned, pace, "it is a mount point or its parent is not writable")
            return
        try:
            _replace_by_rename(files, directory, owned, pace)
        except _Unrenameable as reason:
            _replace_in_place(files, directory, owned, pace, str(reason))


def _replace_by_rename(files: Mapping[str, bytes], directory: Path, owned: bool, pace) -> None:
    parent = directory.parent
    staging = _unique(parent, f".{directory.name}{STAGING}")
    os.mkdir(staging, 0o777)  # the umask applies, as to a directory made by mkdir(1)
    try:
        if directory.exists():
            os.chmod(staging, stat.S_IMODE(os.stat(directory).st_mode))
        carried = _carry_over(directory, staging, files, owned, pace) if directory.exists() else []
        for name in sorted(files):
            pace()
            _write_file(staging / name, files[name])
        _fsync(staging)
        pace()
        if not directory.exists():
            os.rename(staging, directory)
        else:
            _swap(staging, directory, pace)
            pace()
            _move_late_arrivals(staging, directory, files, owned, set(carried))
        _fsync(parent)
        pace()
    finally:
        _remove_tree(staging)  # the unfinished new set, or after the swap the previous one


def _swap(staging: Path, directory: Path, pace) -> None:
    """Exchange the two directories (afterwards ``staging`` names the previous set)."""
    try:
        _exchange(staging, directory)
        return
    except OSError as error:
        if error.errno in _NOT_RENAMEABLE:
            raise _Unrenameable(f"renaming it fails ({os.strerror(error.errno)})") from None
        if error.errno not in _NO_EXCHANGE:
            raise
    # No atomic exchange: move the previous set aside, then the new one into place.
    previous = _unique(directory.parent, f".{directory.name}{PREVIOUS}")
    try:
        os.rename(directory, previous)
    except OSError as error:
        if error.errno in _NOT_RENAMEABLE:
            raise _Unrenameable(f"renaming it fails ({os.strerror(error.errno)})") from None
        raise
    pace()
    os.rename(staging, directory)
    os.rename(previous, staging)  # deleted with the staging directory by the caller


def _exchange(a: Path, b: Path) -> None:
    """renameat2(a, b, RENAME_EXCHANGE) through the C library; OSError(ENOSYS) where it has none."""
    try:
        function = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        raise OSError(errno.ENOSYS, "renameat2 is not available") from None
    at_fdcwd, rename_exchange = -100, 2
    function.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if function(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) != 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code), str(b))


def _carry_over(directory: Path, staging: Path, files: Mapping[str, bytes], owned: bool, pace) -> list[str]:
    """Hard-link (or copy) into ``staging`` the entries of ``directory`` that the new set does not replace."""
    if owned:
        return []
    carried = []
    for entry in sorted(os.scandir(directory), key=lambda e: e.name):
        if entry.name in files or _is_temporary(entry.name, files):
            continue
        pace()
        target = staging / entry.name
        if entry.is_symlink():
            os.symlink(os.readlink(entry.path), target)
        elif entry.is_dir():
            shutil.copytree(entry.path, target, symlinks=True, copy_function=_link_or_copy)
        else:
            _link_or_copy(entry.path, target)
        carried.append(entry.name)
    return carried


def _move_late_arrivals(previous: Path, directory: Path, files: Mapping[str, bytes], owned: bool, carried: set[str]) -> None:
    """Move entries created in the output directory while the new set was being staged."""
    if owned:
        return
    for entry in os.scandir(previous):
        if entry.name in files or entry.name in carried or _is_temporary(entry.name, files):
            continue
        try:
            os.rename(entry.path, directory / entry.name)
        except OSError as error:
            log.warning("%s was created during generation and could not be kept: %s", directory / entry.name, error.strerror)


def _replace_in_place(files: Mapping[str, bytes], directory: Path, owned: bool, pace, reason: str) -> None:
    """Fallback: replace the files one at a time (each file complete, the set not)."""
    log.warning("%s cannot be replaced as a whole (%s): replacing its files one at a time", directory, reason)
    staged: list[tuple[Path, Path]] = []
    try:
        for name in sorted(files):
            pace()
            temporary = _unique(directory, f".{name}{PARTIAL}")
            staged.append((temporary, directory / name))
            _write_file(temporary, files[name])
        for temporary, final in staged:
            pace()
            os.replace(temporary, final)
        if owned:
            for entry in os.scandir(directory):
                if entry.name not in files and entry.is_file(follow_symlinks=False):
                    os.unlink(entry.path)
        _fsync(directory)
    finally:
        for temporary, _ in staged:
            temporary.unlink(missing_ok=True)


def _recover(directory: Path) -> None:
    """After a run died between the two renames of the fallback: put the previous set back."""
    if directory.exists():
        return
    previous = sorted(_siblings(directory, PREVIOUS), key=lambda p: p.stat().st_mtime_ns)
    if previous:
        os.rename(previous[-1], directory)


def _remove_debris(directory: Path, files: Mapping[str, bytes]) -> None:
    """Delete what interrupted runs left: sibling staging/previous directories, temporary files."""
    for path in _siblings(directory, STAGING) + _siblings(directory, PREVIOUS):
        _remove_tree(path)
    if directory.is_dir():
        for entry in os.scandir(directory):
            if _is_temporary(entry.name, files) and entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)


def _siblings(directory: Path, marker: str) -> list[Path]:
    prefix = f".{directory.name}{marker}"
    return [directory.parent / name for name in os.listdir(directory.parent) if name.startswith(prefix)]


def _is_temporary(name: str, files: Mapping[str, bytes]) -> bool:
    """A temporary file name of this or an earlier version of the writer."""
    legacy = _LEGACY_TEMPORARY.fullmatch(name)
    return (name.startswith(".") and PARTIAL in name) or (legacy is not None and legacy["name"] in files)


def _unique(directory: Path, prefix: str) -> Path:
    """A name in ``directory`` starting with ``prefix`` that nothing has (random; created by the caller)."""
    while True:
        path = directory / f"{prefix}{secrets.token_hex(4)}"
        if not os.path.lexists(path):
            return path


def _write_file(path: Path, content: bytes) -> None:
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies
    with os.fdopen(descriptor, "wb") as handle:
        handle.write(content)
        handle.flush()
        os.fsync(handle.fileno())


def _link_or_copy(source: str, target: str) -> None:
    try:
        os.link(source, target, follow_symlinks=False)
    except OSError:  # no hard links here (file system, fs.protected_hardlinks): a copy will do
        shutil.copy2(source, target, follow_symlinks=False)


def _fsync(directory: Path) -> None:
    descriptor = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    except OSError:  # some file systems cannot sync directories; the rename order still holds
        pass
    finally:
        os.close(descriptor)


def _remove_tree(path: Path) -> None:
    if path.is_symlink() or path.is_file():
        path.unlink(missing_ok=True)
    elif path.exists():
        shutil.rmtree(path, ignore_errors=True)


def _is_mount_point(directory: Path) -> bool:
    return os.stat(directory).st_dev != os.stat(directory.parent).st_dev


@contextlib.contextmanager
def _locked(parent: Path) -> Iterator[None]:
    """An exclusive flock on the parent directory for the duration of the run (where there is flock)."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock; concurrent runs into one directory are then unsupported
        yield
        return
    try:
        descriptor = os.open(parent, os.O_RDONLY)
    except OSError:  # a directory we may write but not read: no lock
        yield
        return
    try:
        with contextlib.suppress(OSError):  # e.g. NFS without lock support
            fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)


def _pace():
    """The test hook (see DELAY_VARIABLE): a function called before each step of the write phase."""
    delay = float(os.environ.get(DELAY_VARIABLE, "0") or 0)
    if delay <= 0:
        return lambda: None
    return lambda: time.sleep(delay)
