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


@contextmanager
def replacing(path: str | os.PathLike, suffix: str = ".tmp") -> Iterator[Path]:
    """A temporary path in ``path``'s folder that replaces ``path`` when the block succeeds."""
    path = Path(path)
    descriptor, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(descriptor)
    try:
        yield Path(temporary)
        os.chmod(temporary, default_file_mode())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def safe_stem(name: str) -> str:
    """``name`` with anything but letters, digits, ``_`` and ``-`` replaced by ``_`` (for file names)."""
    return "".join(ch if ch.isalnum() or ch in "_-" else "_" for ch in name)
