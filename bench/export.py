"""Export benchmark: wall time of deriving and exporting every built-in robot (C, CasADi, report).

Each robot in a fresh subprocess (median of ``--repeat``); the issue's goal is the complete Panda
model exported in ≤ 30 s on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import json
import statistics
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import json, sys, tempfile, time, warnings
warnings.simplefilter("ignore")
import symbolic, symbolic.export as export
start = time.perf_counter()
model = symbolic.derive(symbolic.robots.load(sys.argv[1]))
derived = time.perf_counter()
times = {}
for target in export.TARGETS:
    t = time.perf_counter()
    export.render(model, [target])
    times[target] = time.perf_counter() - t
print(json.dumps({"derive": derived - start, **times, "total": time.perf_counter() - start}))
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/export.md")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    os.environ["SYMBOLIC_NO_CACHE"] = "1"  # the work is measured, not reading it back from the cache (bench/cache.py)
    lines = ["# Export time", "", f"Median of {args.repeat} fresh processes, seconds.", "",
             "| robot | derive | C | CasADi | report | total |", "|---|---|---|---|---|---|"]
    for name in ("fivebar", "omni", "janot_branch", "puma560", "panda"):
        runs = [json.loads(subprocess.run([sys.executable, "-c", CHILD, name], capture_output=True, text=True, check=True).stdout)
                for _ in range(args.repeat)]
        m = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        lines.append(f"| {name} | {m['derive']:.2f} | {m['c']:.2f} | {m['casadi']:.2f} | {m['report']:.2f} | {m['total']:.2f} |")
        print(lines[-1], flush=True)
    lines += ["", "Goal (issue 4): the complete Panda model exported (C, CasADi, report) in ≤ 30 s on 2 cores.", ""]
    Path(args.out).write_text("\n".join(lines))
    print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
