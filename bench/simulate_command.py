"""The whole ``symbolic simulate`` command of a 20 s, 1 kHz Panda PD run, cold and warm, against a Pinocchio loop.

Issue 23 §3 ("nothing derived twice"). The command runs in a fresh process
(``python -m symbolic -q simulate panda run.toml --json``) with ``SYMBOLIC_CACHE_DIR`` pointing to a folder
of its own: empty for the cold run, filled by the runs before for the warm ones (the model's numbers and
CasADi plant, kept under the model file's digest, and the compiled closed loop are read from it: no SymPy). The experiment is the one of
``bench/simulate.py``: the Panda from q⁰ under a discrete PD (kp = D_ii(q⁰)·ω², kd = 2ζ·D_ii(q⁰)·ω,
ω = 2π·5 rad/s, ζ = 0.7) following q⁰ + 0.3·sin(2π·f_i·t), written as a CSV log and an experiment file
with a ``[controller]`` table in a temporary folder.

The anchor, measured in the same run: Pinocchio's ``aba`` in a Python loop over the same steps
(``bench/simulate.py``, :func:`pinocchio_loop`). Figures: medians of ``--repeat`` runs of each; wall time
(what a user waits for) and CPU time (the machine is shared: the CPU time is what repeats from run to
run), and the command's own integration time (``timings.integrate`` of its JSON, wall). Goals (issue 38 §2): the warm
command within 2× the loop's wall time, the integration within 0.5×.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

Q0 = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


def experiment(folder: Path):
    """The log and experiment files; returns the measurements and PD table for the Pinocchio loop."""
    import symbolic
    from simulate import log_and_table

    model = symbolic.derive(symbolic.robots.load("panda"))
    names = [f"q{i}" for i in range(1, 8)]
    log, table = log_and_table(model, Q0, names)
    columns = ["t"] + names + [f"tau{i}" for i in range(1, 8)] + [f"r{i}" for i in range(1, 8)]
    rows = np.column_stack([log.t, log.q, log.tau, log.ref])
    np.savetxt(folder / "log.csv", rows, delimiter=",", header=",".join(columns), comments="", fmt="%.17g")
    signals = ['t = "t"'] + [f'q_{c} = "{c}"' for c in names] + [f'tau_{c} = "tau{i}"' for i, c in enumerate(names, 1)]
    signals += [f'ref_{c} = "r{i}"' for i, c in enumerate(names, 1)]
    (folder / "run.toml").write_text(
        'data = "log.csv"\nmodel = "panda"\n\n[signals]\n' + "\n".join(signals) + "\n\n[controller]\n"
        f'kind = "pd"\ncoordinates = {json.dumps(names)}\nkp = {json.dumps(table["kp"])}\n'
        f'kd = {json.dumps(table["kd"])}\nreference = "ref"\n')
    return model, log, table


def command(folder: Path, cache: Path) -> tuple[float, float, float]:
    """One fresh process running the command: (wall, CPU, integration wall) in seconds."""
    env = dict(os.environ, SYMBOLIC_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "symbolic", "-q", "simulate", "panda", str(folder / "run.toml"), "--json"],
                          env=env, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, float(json.loads(done.stdout)["timings"]["integrate"])


def import_cpu(module: str) -> float:
    """CPU time of a fresh process importing NumPy and ``module``, less that of one importing NumPy alone."""
    def cpu(code: str) -> float:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-c", code], check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)

    return statistics.median(cpu(f"import numpy, {module}") - cpu("import numpy") for _ in range(3))


LIBRARIES = ("sympy", "numpy", "scipy", "casadi", "matplotlib", "jinja2")
"""The libraries whose import a command can feel."""


def imported(folder: Path, cache: Path) -> dict[str, float]:
    """The :data:`LIBRARIES` a warm command imports, with their cumulative import wall time (s: what they import
    included, so NumPy also counts inside SymPy), from ``python -X importtime`` (one run)."""
    env = dict(os.environ, SYMBOLIC_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-X", "importtime", "-m", "symbolic", "-q", "simulate", "panda",
                           str(folder / "run.toml"), "--json"], env=env, capture_output=True, text=True, check=True)
    out: dict[str, float] = {}
    for line in done.stderr.splitlines():
        parts = line.split("|")
        if len(parts) == 3 and parts[0].startswith("import time:") and parts[1].strip().isdigit():
            name = parts[2].strip()
            if name in LIBRARIES:  # wherever it is first imported (its line is nested under its importer's)
                out[name] = int(parts[1]) / 1e6
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/simulate_command.md")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    from simulate import pinocchio_loop

    folder = Path(tempfile.mkdtemp(prefix="symbolic-bench-simulate-"))
    cache = folder / "cache"
    try:
        model, log, table = experiment(folder)
        cold = command(folder, cache)
        warm = [command(folder, cache) for _ in range(args.repeat)]
        anchor = []
        for _ in range(args.repeat):
            start, used = time.perf_counter(), time.process_time()
            pinocchio_loop(model.robot, Q0, log, table, 1)
            anchor.append((time.perf_counter() - start, time.process_time() - used))
        imports = {m: import_cpu(m) for m in ("sympy", "casadi", "scipy.signal")}
        packages = imported(folder, cache)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    median = lambda rows, k: statistics.median(r[k] for r in rows)  # noqa: E731
    a_wall, a_cpu = median(anchor, 0), median(anchor, 1)
    w_wall, w_cpu, w_run = median(warm, 0), median(warm, 1), median(warm, 2)
    absent = [note for library, note in (("sympy", "no SymPy"),
                                         ("scipy", "no SciPy: the comparison's low-pass is NumPy's, symbolic.data.filters"))
              if library not in packages]
    lines = [
        "# `symbolic simulate`: the whole command against a Pinocchio loop (issue 23 §3)", "",
        f"Panda, 20 s at 1 kHz, discrete PD (`bench/simulate_command.py`). {platform.machine()}, Python "
        f"{platform.python_version()}, {os.cpu_count()} cores (shared: CPU time is the figure that repeats). "
        f"Medians of {args.repeat} runs; the command in a fresh process each time.", "",
        "| | wall (s) | CPU (s) | integration, wall (s) | wall / anchor | CPU / anchor | integration / anchor wall |",
        "|---|---|---|---|---|---|---|",
        f"| command, cold cache (one run) | {cold[0]:.2f} | {cold[1]:.2f} | {cold[2]:.2f} | {cold[0] / a_wall:.1f}× | "
        f"{cold[1] / a_cpu:.1f}× | {cold[2] / a_wall:.2f}× |",
        f"| command, warm cache | {w_wall:.2f} | {w_cpu:.2f} | {w_run:.2f} | **{w_wall / a_wall:.1f}×** | "
        f"{w_cpu / a_cpu:.1f}× | **{w_run / a_wall:.2f}×** |",
        f"| anchor: Pinocchio `aba` loop in Python | {a_wall:.2f} | {a_cpu:.2f} | | 1 | 1 | |", "",
        "Goals (issue 38 §2): the warm command within 2× the loop's wall time, the integration within 0.5×. Warm, the "
        "model's numbers and CasADi plant (kept under the model file's digest: the file is not parsed) and the "
        "compiled closed loop are read from the cache folder; what is left is the imports, reading the log, the "
        "integration and the comparison. Packages the warm command imports (`-X importtime`, cumulative wall time): "
        + ", ".join(f"{m} {v:.2f} s" for m, v in packages.items())
        + (f" ({'; '.join(absent)})" if absent else "") + ". CPU time of some imports in a fresh process in this "
        "run, for scale: "
        + ", ".join(f"{m} {v:.2f} s" for m, v in imports.items()) + ".", "",
    ]
    Path(args.out).write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
