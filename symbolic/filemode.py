"""The permissions a new file gets: what ``open()`` would give (0o666 without the umask's bits).

Files are written to a temporary name and renamed into place; :func:`tempfile.mkstemp` creates them
0o600, which would make a model file, a data file or a figure unreadable to the user's group.
"""

from __future__ import annotations

import os


def default_file_mode() -> int:
    """0o666 & ~umask (the umask is read by setting it and putting it back)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask
