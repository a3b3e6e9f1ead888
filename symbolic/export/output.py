"""Writing a command's set of files into an output folder it does not own (:func:`symbolic.export.write_files`).

The command owns the files it writes and nothing else (docs/contracts.md, "Output folders"):

* the folder is created when missing and otherwise left as it is: never renamed, replaced, re-owned or
  chmod-ed; its sub-folders, mounts and every file the set does not name are never read, copied, moved or
  deleted, so files other processes write into it during a run stay;
* each file is written under a temporary name ``.NAME.symbolic-partial-XXXXXXXX`` beside its final name,
  flushed to disk, then renamed over it: a reader sees the old file or the new one, never a part; a file
  that exists keeps its permissions (and its owner, where the writer may set it);
* the set: the renames and removals are listed in a journal (``.symbolic-journal.json``) once every new
  file is on disk, and carried out after it. A run that dies before the journal leaves the previous set
  and temporary files that the next run into the folder removes; one that dies after it is completed by
  the next run (rolled forward) before anything else, so the folder returns to one complete set;
* the previous set is known from a manifest (``.symbolic-manifest.json``: each file's name and SHA-256):
  its files that the new set does not name are removed (the stale figures of an earlier diagnosis), unless
  they changed since they were written — then they are kept, with a warning;
* ``owned`` folders (``generated/NAME``: the folder belongs to this set alone) keep no manifest: every
  regular file the set does not name is removed; sub-folders are still left alone.

Concurrent runs into one folder take turns (an ``flock`` on the folder). Between the first and the last
rename of a run a reader may see files of both sets (milliseconds); :func:`recover` completes the set a
dead run left.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
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

PARTIAL = ".symbolic-partial-"
JOURNAL = ".symbolic-journal.json"
MANIFEST = ".symbolic-manifest.json"
# Sibling directories of the versions that replaced the whole folder (0.1): removed when found.
_OLD_SIBLINGS = (".symbolic-staging-", ".symbolic-previous-")
# Set only by tests/test_output.py: seconds to sleep before each step of the write phase, so that a
# test can interrupt the writer at chosen moments. Never set in normal use.
DELAY_VARIABLE = "SYMBOLIC_TEST_WRITE_DELAY"
# Temporary names of versions before the staging directory: ".NAME.XXXXXXXX.tmp" (tempfile.mkstemp).
_LEGACY_TEMPORARY = re.compile(r"\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp")


def replace_files(files: Mapping[str, bytes], directory: Path, *, owned: bool = False) -> None:
    """Make ``directory`` hold ``files`` (name: content) as one set (see the module doc).

    Raises OSError when the folder cannot be written; ValueError for a name that is not a plain file name.
    """
    for name in files:
        if not name or name in (".", "..") or "/" in name or "\0" in name or name in (JOURNAL, MANIFEST):
            raise ValueError(f"{name!r} is not a file name this writer may use")
    directory = Path(os.path.realpath(directory))  # write into the real folder, not a symlink's name
    directory.mkdir(parents=True, exist_ok=True)
    pace = _pace()
    with _locked(directory):
        recover(directory)
        _remove_debris(directory, files)
        journal = _stage(files, directory, owned, pace)
        pace()
        _roll_forward(directory, journal, pace)


def recover(directory: str | os.PathLike) -> None:
    """Complete the set a run that died after its journal left in ``directory`` (nothing to do otherwise)."""
    directory = Path(directory)
    try:
        journal = json.loads((directory / JOURNAL).read_text())
    except FileNotFoundError:
        return
    except (OSError, ValueError):
        log.warning("%s: unreadable journal of an interrupted run; removed", directory / JOURNAL)
        (directory / JOURNAL).unlink(missing_ok=True)
        return
    _roll_forward(directory, journal, lambda: None)


def _stage(files: Mapping[str, bytes], directory: Path, owned: bool, pace) -> dict:
    """Write every file under a temporary name, then the journal: nothing visible changes until it exists."""
    for name in files:
        if (directory / name).is_dir() and not (directory / name).is_symlink():
            raise IsADirectoryError(errno.EISDIR, "a folder has the name of an output file", str(directory / name))
    previous = {} if owned else _manifest(directory)
    staged: list[list[str]] = []
    try:
        for name in sorted(files):
            pace()
            temporary = _unique(directory, f".{name}{PARTIAL}")
            _write_file(temporary, files[name], like=directory / name)
            staged.append([temporary.name, name])
        _fsync(directory)
        if owned:
            stale = {n: None for n in _regular_files(directory) if n not in files and n != JOURNAL and PARTIAL not in n}
        else:
            stale = {n: digest for n, digest in previous.items() if n not in files}
        journal = {"renames": staged, "remove": stale, "owned": owned,
                   "files": {name: hashlib.sha256(content).hexdigest() for name, content in sorted(files.items())}}
        _write_json(directory / JOURNAL, journal)
    except BaseException:
        for temporary, _ in staged:
            (directory / temporary).unlink(missing_ok=True)
        raise
    return journal


def _roll_forward(directory: Path, journal: dict, pace) -> None:
    for temporary, name in journal["renames"]:
        if not _plain(temporary) or not _plain(name):
            continue  # a journal edited by hand: never follow a path out of the folder
        pace()
        with contextlib.suppress(FileNotFoundError):  # renamed before the previous run died
            os.replace(directory / temporary, directory / name)
    for name, digest in journal["remove"].items():
        if _plain(name):
            _remove_stale(directory / name, digest)
    _fsync(directory)
    if not journal.get("owned"):
        _write_json(directory / MANIFEST, {"files": journal["files"]})
    (directory / JOURNAL).unlink(missing_ok=True)
    _fsync(directory)


def _remove_stale(path: Path, digest: str | None) -> None:
    """Remove a file of the previous set, if it is still a regular file with the content written (or owned)."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return
    if not stat.S_ISREG(info.st_mode):
        return
    if digest is not None and hashlib.sha256(path.read_bytes()).hexdigest() != digest:
        log.warning("%s was written by an earlier run and changed since: kept", path)
        return
    path.unlink(missing_ok=True)


def _manifest(directory: Path) -> dict[str, str]:
    """{name: sha256} of the set an earlier run wrote (empty when there is none or it is unreadable)."""
    try:
        files = json.loads((directory / MANIFEST).read_text())["files"]
        return {str(n): str(d) for n, d in files.items() if _plain(str(n))}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


def _remove_debris(directory: Path, files: Mapping[str, bytes]) -> None:
    """Temporary files of runs that died before their journal, and the sibling folders of 0.1's writer."""
    for entry in os.scandir(directory):
        if _is_temporary(entry.name, files) and entry.is_file(follow_symlinks=False):
            os.unlink(entry.path)
    prefixes = tuple(f".{directory.name}{marker}" for marker in _OLD_SIBLINGS)
    with contextlib.suppress(OSError):
        for name in os.listdir(directory.parent):
            path = directory.parent / name
            if name.startswith(prefixes) and path.is_dir() and not path.is_symlink() and not _is_mount_point(path):
                shutil.rmtree(path, ignore_errors=True)


def _regular_files(directory: Path) -> list[str]:
    return sorted(e.name for e in os.scandir(directory) if e.is_file(follow_symlinks=False))


def _plain(name: str) -> bool:
    return bool(name) and name not in (".", "..") and "/" not in name and "\0" not in name


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


def _write_file(path: Path, content: bytes, like: Path | None = None) -> None:
    """``content`` into the new file ``path``, on disk; with the mode and owner of ``like`` when it exists."""
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies
    with os.fdopen(descriptor, "wb") as handle:
        handle.write(content)
        handle.flush()
        if like is not None:
            _keep_mode_and_owner(handle.fileno(), like)
        os.fsync(handle.fileno())


def _keep_mode_and_owner(descriptor: int, like: Path) -> None:
    try:
        info = os.stat(like, follow_symlinks=False)
    except FileNotFoundError:
        return
    if not stat.S_ISREG(info.st_mode):
        return
    os.fchmod(descriptor, stat.S_IMODE(info.st_mode))
    if (info.st_uid, info.st_gid) != (os.geteuid(), os.getegid()):
        with contextlib.suppress(PermissionError):  # only a privileged writer may give a file away
            os.fchown(descriptor, info.st_uid, info.st_gid)


def _write_json(path: Path, value: dict) -> None:
    temporary = _unique(path.parent, f"{path.name}{PARTIAL}")
    _write_file(temporary, json.dumps(value, sort_keys=True, indent=1).encode())
    os.replace(temporary, path)
    _fsync(path.parent)


def _fsync(directory: Path) -> None:
    descriptor = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    except OSError:  # some file systems cannot sync directories; the rename order still holds
        pass
    finally:
        os.close(descriptor)


def _is_mount_point(path: Path) -> bool:
    return os.stat(path).st_dev != os.stat(path.parent).st_dev


@contextlib.contextmanager
def _locked(directory: Path) -> Iterator[None]:
    """An exclusive flock on the folder for the duration of the run (where there is flock)."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock; concurrent runs into one folder are then unsupported
        yield
        return
    try:
        descriptor = os.open(directory, os.O_RDONLY)
    except OSError:  # a folder we may write but not read: no lock
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
