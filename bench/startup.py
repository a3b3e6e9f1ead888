"""Start-up cost of the command line (issue 23 §3: ``symbolic --help`` and the first line of any command under
0.3 s of CPU).

Each figure is the median of :data:`RUNS` fresh processes (``python -m symbolic ...``), wall and CPU time (user +
system) of the process:

* ``import symbolic`` alone, and ``symbolic --help``;
* ``symbolic SUBCOMMAND --help`` for every subcommand (its parser and the imports it needs);
* the first line of a working command: ``symbolic derive panda`` (and ``identify``, ``diagnose``) with an empty
  cache folder writes its first progress line (``symbolic: panda: reading the model``) on stderr; the process's
  CPU time at that moment is read from ``/proc/PID/stat`` (Linux) as the line arrives.

The figures depend on the machine's load only through the wall times; its load average is printed with them.

    python bench/startup.py --out bench/results/startup.md
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNS = 7
"""Fresh processes per figure; the medians are reported."""
GOAL = 0.3
"""CPU seconds (issue 23)."""
SUBCOMMANDS = ("derive", "generate", "analyze", "identify", "simulate", "diagnose", "campaign", "reproduce",
               "first-peak", "export-urdf", "list")


def environment(cache: Path) -> dict[str, str]:
    return {**os.environ, "SYMBOLIC_CACHE_DIR": str(cache),
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}


def whole(arguments: list[str], env: dict[str, str]) -> tuple[float, float]:
    """(wall, CPU) of one fresh process running to its end."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run([sys.executable, *arguments], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   check=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def first_line(arguments: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """(wall, CPU, the line) when the process writes its first line on stderr; the process is then stopped."""
    ticks = os.sysconf("SC_CLK_TCK")
    started = time.perf_counter()
    process = subprocess.Popen([sys.executable, *arguments], env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)
    try:
        line = process.stderr.readline()
        wall = time.perf_counter() - started
        fields = Path(f"/proc/{process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        cpu = (int(fields[11]) + int(fields[12])) / ticks  # utime, stime (fields 14 and 15 of proc(5))
    finally:
        process.kill()
        process.wait()
    return wall, cpu, line.strip()


def median(rows: list[tuple[float, ...]]) -> tuple[float, float]:
    return statistics.median(r[0] for r in rows), statistics.median(r[1] for r in rows)


def measure() -> dict:
    with tempfile.TemporaryDirectory(prefix="symbolic-bench-startup-") as tmp:
        env = environment(Path(tmp) / "warm")
        out = {"import symbolic": median([whole(["-c", "import symbolic"], env) for _ in range(RUNS)]),
               "symbolic --help": median([whole(["-m", "symbolic", "--help"], env) for _ in range(RUNS)])}
        for name in SUBCOMMANDS:
            out[f"symbolic {name} --help"] = median([whole(["-m", "symbolic", name, "--help"], env) for _ in range(RUNS)])
        data = Path(tmp) / "panda.csv"  # never read: the processes are stopped at their first line
        data.write_text("t," + ",".join(f"q{i}" for i in range(1, 8)) + "\n", encoding="utf-8")
        for command in (["derive", "panda"], ["identify", "panda", str(data)],
                        ["diagnose", "panda", str(data), "--out", str(Path(tmp) / "out")]):
            firsts = [first_line(["-m", "symbolic", *command], environment(Path(tmp) / f"cold{k}")) for k in range(RUNS)]
            shown = " ".join(command[:2] + ["DATA"] * (len(command) > 2) + ["--out DIR"] * (len(command) > 3))
            out[f"first line of `symbolic {shown}`, cold cache ({firsts[0][2]!r})"] = median([f[:2] for f in firsts])
    return out


def markdown(figures: dict, load: tuple[float, float]) -> str:
    lines = ["# Start-up of the command line (issue 23 §3)", "",
             f"{platform.machine()}, Python {platform.python_version()}, {os.cpu_count()} processors; load "
             f"average {load[0]:.2f} at the start, {load[1]:.2f} at the end. Median of {RUNS} fresh processes each "
             "(`bench/startup.py`). Goal: under "
             f"{GOAL:g} s of CPU for `symbolic --help` and the first line of any command.", "",
             "| | wall (s) | CPU (s) | within the goal |", "|---|---|---|---|"]
    for label, (wall, cpu) in figures.items():
        lines.append(f"| {label} | {wall:.3f} | {cpu:.3f} | {'yes' if cpu < GOAL else '**no**'} |")
    return "\n".join(lines + [""])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="write the results as Markdown here")
    args = parser.parse_args()
    start = os.getloadavg()[0]
    text = markdown(measure(), (start, os.getloadavg()[0]))
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
