"""Writing one file so that readers see the old content or the new, never a part (for all layers).

:func:`replacing` hands out a temporary path beside the target; when the block ends normally the
file gets the permissions ``open()`` would give (0o666 without the umask's bits: :func:`tempfile.mkstemp`
creates 0o600, which would hide a model file, a data file or a figure from the user's group) and is
renamed over the target; when it raises, the temporary file is removed. Sets of files are replaced
together by :mod:`symbolic.export.output`.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def default_file_mode() -> int:
    """0o666 & ~umask (the umask is read by setting it and putting it back)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


PARTIAL = ".symbolic-partial-"
"""Temporary files are ``.NAME.symbolic-partial-XXXXXXXX`` beside their target (also in :mod:`symbolic.export.output`)."""


@contextmanager
def replacing(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """A temporary path in ``path``'s folder that replaces ``path`` when the block succeeds.

    The temporary file is locked (``flock``) while it is written: a run killed before the rename leaves it
    unlocked, and the next write of ``path`` removes it, while a concurrent writer's file, still locked, stays.
    """
    path = Path(path)
    _remove_leftovers(path)
    descriptor, temporary = tempfile.mkstemp(prefix=f".{path.name}{PARTIAL}", suffix=suffix, dir=path.parent)
    try:
        _lock(descriptor)
        try:
            yield Path(temporary)
            os.chmod(temporary, default_file_mode())
            os.replace(temporary, path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise
    finally:
        os.close(descriptor)


def _lock(descriptor: int, blocking: bool = True) -> bool:
    try:
        import fcntl
    except ImportError:  # not POSIX: leftovers are not recognised
        return False
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
    except OSError:
        return False
    return True


def _remove_leftovers(path: Path) -> None:
    """Temporary files of ``path`` that no live writer holds (theirs died before renaming them)."""
    try:
        names = [n for n in os.listdir(path.parent) if n.startswith(f".{path.name}{PARTIAL}")]
    except OSError:
        return
    for name in names:
        leftover = path.parent / name
        try:
            descriptor = os.open(leftover, os.O_RDONLY | os.O_NOFOLLOW)
        except OSError:
            continue
        try:
            if _lock(descriptor, blocking=False):
                leftover.unlink(missing_ok=True)
        finally:
            os.close(descriptor)


def safe_stem(name: str) -> str:
    """``name`` with anything but letters, digits, ``_`` and ``-`` replaced by ``_`` (for file names)."""
    return "".join(ch if ch.isalnum() or ch in "_-" else "_" for ch in name)
