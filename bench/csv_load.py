"""CSV loading benchmark: time and peak memory of reading a 5-million-row log, streamed and (for comparison)
decoded whole as before.

The file: ``t,q_q,tau_q,ref_q`` at 1 kHz, 5,000,000 rows written as :func:`symbolic.data.write` writes
them (17 significant digits), about 370 MB as in issue 22. It is generated once into ``--file`` (default a
temporary folder) and kept when ``--keep`` is given. Each measurement runs in a fresh Python process: the
peak resident memory is read from ``/proc/self/status`` (VmHWM, reset through ``/proc/self/clear_refs``
after the imports) minus the resident memory before the call, and is compared with the data's float64 size
(rows × columns × 8 bytes). Readers measured:

* ``streamed``: :func:`symbolic.data.files.read_csv`, the streaming reader;
* ``load``: :func:`symbolic.data.load` of the same file (the streaming reader, then the checks and the
  arrangement into :class:`~symbolic.data.Measurements`);
* ``whole file``: the reader before it streamed (tests/csv_reference.py), skipped with ``--no-reference``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ROWS = 5_000_000
COLUMNS = ("t", "q_q", "tau_q", "ref_q")


def generate(path: Path, rows: int) -> None:
    """The log, written in chunks (17 significant digits, as symbolic.data.write writes numbers)."""
    rng = np.random.default_rng(0)
    chunk = 100_000
    with open(path, "w", encoding="ascii") as f:
        f.write(",".join(COLUMNS) + "\n")
        for start in range(0, rows, chunk):
            k = np.arange(start, min(start + chunk, rows))
            t = k / 1000.0
            q = 0.1 * np.sin(2 * np.pi * 0.5 * t) + rng.normal(0, 1e-6, len(k))
            tau = 35.15 * rng.normal(0, 1, len(k))
            ref = 0.1 * np.sin(2 * np.pi * 0.5 * t)
            f.write("\n".join(",".join("%.17g" % v for v in row) for row in zip(t, q, tau, ref)) + "\n")


def status(field: str) -> int:
    """A /proc/self/status field in bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) * 1024
    raise LookupError(field)


def measure(which: str, path: Path) -> dict:
    """One reading in this process: seconds and peak resident bytes above the resident size before it."""
    sys.path.insert(0, str(ROOT / "tests"))
    import symbolic.data
    from symbolic.data import files

    import csv_reference

    readers = {"streamed": files.read_csv, "whole file": csv_reference.read_csv, "load": symbolic.data.load}
    reader = readers[which]
    Path("/proc/self/clear_refs").write_text("5")  # reset VmHWM to the current resident size
    before = status("VmRSS")
    start = time.perf_counter()
    result = reader(path)
    seconds = time.perf_counter() - start
    peak = status("VmHWM") - before
    held = status("VmRSS") - before
    samples = result.samples if which == "load" else len(next(iter(result.vectors.values())))
    return {"reader": which, "seconds": seconds, "peak": peak, "held": held, "rows": samples}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/csv_load.md")
    parser.add_argument("--file", type=Path, default=None, help="the CSV file (generated when missing)")
    parser.add_argument("--rows", type=int, default=ROWS)
    parser.add_argument("--keep", action="store_true", help="keep the generated file")
    parser.add_argument("--no-reference", action="store_true", help="skip the whole-file reader (46 s, 3.5 GB)")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure(args.one, args.file)))
        return 0
    folder = None
    path = args.file
    if path is None:
        folder = tempfile.mkdtemp(prefix="symbolic-bench-csv-")
        path = Path(folder) / "log.csv"
    if not path.exists():
        started = time.perf_counter()
        generate(path, args.rows)
        print(f"generated {path} ({path.stat().st_size / 1e6:.0f} MB) in {time.perf_counter() - started:.0f} s",
              flush=True)
    size = path.stat().st_size
    data = args.rows * len(COLUMNS) * 8
    readers = ["streamed", "load"] + ([] if args.no_reference else ["whole file"])
    rows = []
    load_before = os.getloadavg()[0]
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    for which in readers:
        done = subprocess.run([sys.executable, __file__, "--one", which, "--file", str(path)], env=environment,
                              check=True, capture_output=True, text=True)
        r = json.loads(done.stdout.strip().splitlines()[-1])
        assert r["rows"] == args.rows, r
        rows.append(f"| {which} | {r['seconds']:.1f} | {r['peak'] / 1e6:.0f} | {r['peak'] / data:.2f}× | "
                    f"{r['held'] / 1e6:.0f} | {size / 1e6 / r['seconds']:.0f} |")
        print(rows[-1], flush=True)
    lines = [
        "# Loading a large CSV log: time and peak memory",
        "",
        f"`bench/csv_load.py`: {args.rows:,} rows × {len(COLUMNS)} columns ({', '.join(COLUMNS)}) at 17 significant "
        f"digits, {size / 1e6:.0f} MB; the data's float64 size is {data / 1e6:.0f} MB. Each reader in a fresh "
        f"process on {platform.machine()}, Python {platform.python_version()}, NumPy {np.__version__}; peak = the "
        "highest resident memory during the call minus the resident memory before it; held = what stays resident "
        "after it (the result). A 2-core machine shared with other work: the load average was "
        f"{load_before:.1f} before and {os.getloadavg()[0]:.1f} after the runs, and the times stretch with it (the "
        "memory does not).",
        "",
        "| reader | seconds | peak (MB) | peak / float64 size | held (MB) | MB/s |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        "The streaming reader holds one block of text (4 Mi characters) and one float64 vector per column, sized "
        "beforehand from the file's line count; `load` adds the checks and the (t, q, τ, ref) arrays of "
        "Measurements. The whole-file reader held the bytes, the decoded text, a list of every line and a "
        "second copy of the rows' text at once.",
        "",
    ]
    Path(args.out).write_text("\n".join(lines))
    if folder is not None and not args.keep:
        path.unlink()
        os.rmdir(folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())
