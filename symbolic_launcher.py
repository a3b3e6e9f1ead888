"""The ``symbolic`` console command: the CLI, with Ctrl-C during start-up answered like Ctrl-C later.

Importing the package takes a second or two (SymPy); a Ctrl-C in that time used to end in a traceback.
This module lives outside the package so that importing it imports nothing heavy.
"""

from __future__ import annotations

import sys


def main() -> int:
    try:
        from symbolic.cli import main as run
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130  # 128 + SIGINT, as symbolic.cli.main answers later
    return run()


if __name__ == "__main__":
    sys.exit(main())
