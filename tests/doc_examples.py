"""A documented extension module (an export target, an effect), taken from its doc and dropped alone into a copy
of the package, run as a user would run the command line on it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def example_module(doc: str, folder: str) -> tuple[str, str]:
    """(path, source) of the fenced ``python`` block of ``doc`` whose first line is ``# <folder>/NAME.py``."""
    text = (ROOT / doc).read_text()
    block = re.search(rf"```python\n# ({re.escape(folder)}/\w+\.py)\n(.*?)```", text, re.S)
    assert block, f"{doc} has no example module of {folder}/ (a fenced python block opening with its path)"
    return block.group(1), block.group(2)


def package_with(tmp_path: Path, path: str, source: str) -> Callable[..., subprocess.CompletedProcess]:
    """Copy the package into ``tmp_path``, add ``source`` at ``path``; return a runner of ``python -m symbolic``
    on that copy (in ``tmp_path``, the copy first on the path)."""
    shutil.copytree(ROOT / "symbolic", tmp_path / "symbolic", ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / path).write_text(source)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "SYMBOLIC_CACHE")} | {"PYTHONPATH": str(tmp_path)}

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "symbolic", *args], cwd=tmp_path, env=env, capture_output=True,
                              text=True, timeout=900)

    return run
