"""Regenerate ``generated/`` for the built-in robots (``make generate``).

Each robot gets ``generated/<name>/``: ``<name>.h``/``<name>.c`` (C), ``<name>_<function>.casadi`` with
the loader ``<name>_casadi.py`` (CasADi) and ``<name>.md`` (report). The content depends only on the
model files and this package, never on time, host, path or hash seed. Each ``generated/<name>/`` is
replaced as one set (:func:`symbolic.export.write_files` with ``owned=True``, see
:mod:`symbolic.export.output`): at every instant it holds exactly the previous generation or exactly
the new one, so files no longer produced disappear with the previous set; an interrupted run
leaves each robot's directory complete (some robots regenerated, the rest not).
"""

from __future__ import annotations

import logging
import sys
import warnings
from pathlib import Path

from symbolic import export, robots
from symbolic.derivation.dynamics import derive
from symbolic.errors import ModelWarning

log = logging.getLogger(__name__)
COMMAND = "make generate"


def generate(out: Path, names: list[str] | None = None) -> list[Path]:
    written: list[Path] = []
    for name in names or robots.names():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            robot = robots.load(name)
        log.info("generating %s", name)
        files = export.render(derive(robot), command=COMMAND)
        written += export.write_files(files, out / name, owned=True)
    return written


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    logging.basicConfig(level=logging.INFO, format="symbolic: %(message)s", stream=sys.stderr)
    out = Path(argv[0] if argv else "generated")
    generate(out, argv[1:] or None)
    return 0


if __name__ == "__main__":
    sys.exit(main())
