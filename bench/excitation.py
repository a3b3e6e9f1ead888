"""Excitation design benchmark (issue 35): the Panda's design time, and the PUMA 560's design against random
Fourier references within the same limits.

* **Panda** (built-in ``panda``, no friction; ``symbolic/robots/panda_excitation.experiment.toml``: Franka's
  published limits, assumed noise): ``symbolic.identify.excitation_report.excite`` of a 20 s reference, 5
  harmonics × 7 joints, the default 3 random starts (seed 0), ``--repeat`` times in this process after one
  design that warms the caches (the derivation, the base parameters and the compiled ∂τ/∂(q, q̇, q̈) are read from
  the cache folder, as a second ``symbolic excite`` reads them); the median of the design's seconds (the starts and
  their verification) and of each start's, and the process's CPU time (the machine is shared: wall time scales with
  the load). Goal: at most 60 s on 2 cores.
* **PUMA 560** (built-in ``puma560``; ``symbolic/robots/puma560_excitation.experiment.toml``: the Robotics
  Toolbox's joint limits, assumed speed, acceleration, torque and noise): the D-optimal 20 s design (5 harmonics,
  3 starts) against ``--references`` random Fourier series of the same period and harmonics (the design's own
  random starts, :func:`symbolic.identify.excitation.random_start`, from other seeds, each scaled until a position,
  velocity, acceleration or torque limit is reached: ``fill`` 0.999), at rest at both ends: there is no published
  exciting trajectory for the PUMA 560 to compare with, and a random reference within the same limits is what a
  user without a design would run. The D-criterion is log det M and the condition number cond(Σ^(−1/2)W) of the
  predicted information of the base parameters at the declared rate and noise (as ``symbolic excite`` reports them).

The load average of the machine (``os.getloadavg``) is written before and after: the machine is shared, and the
times scale with what else runs.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def panda(repeat: int) -> tuple[list[str], dict]:
    import symbolic
    from symbolic.identify.excitation_report import excite, read_declarations
    from symbolic.robots import example_path

    model = symbolic.derive(symbolic.robots.load("panda"))
    declared = read_declarations(example_path("panda_excitation"), model.robot.generalized_coordinates)
    excite(model, declared, 20.0, starts=1)  # warm: the compiled ∂τ/∂s, the regressor's products
    runs = []
    for _ in range(repeat):
        started, cpu = time.perf_counter(), time.process_time()
        result = excite(model, declared, 20.0)
        runs.append((result.design.seconds, time.perf_counter() - started,
                     [s.seconds for s in result.design.starts], result.predicted.log_det, time.process_time() - cpu))
    design = statistics.median(r[0] for r in runs)
    whole = statistics.median(r[1] for r in runs)
    per_start = statistics.median(s for r in runs for s in r[2])
    lines = ["## Panda: design time (20 s, 5 harmonics × 7 joints, 3 starts)", "",
             f"{repeat} designs of the same seed in one process after a warm-up design; seconds.", "",
             "| | median | runs |", "|---|---|---|",
             f"| design (3 starts, verification) | {design:.1f} | {', '.join(f'{r[0]:.1f}' for r in runs)} |",
             f"| one start | {per_start:.1f} | {', '.join(f'{s:.1f}' for r in runs for s in r[2])} |",
             f"| `excite` (design, prediction) | {whole:.1f} | {', '.join(f'{r[1]:.1f}' for r in runs)} |",
             f"| `excite`, CPU time of the process | {statistics.median(r[4] for r in runs):.1f} | "
             f"{', '.join(f'{r[4]:.1f}' for r in runs)} |", "",
             f"Goal: at most 60 s for the design: {'met' if design <= 60.0 else 'NOT met'} ({design:.1f} s; "
             f"{per_start:.1f} s a start). log det M of the design {runs[0][3]:.1f} in every run: "
             f"{'the same' if len({round(r[3], 6) for r in runs}) == 1 else 'NOT the same'}.", ""]
    return lines, {"design": design, "start": per_start}


def puma(references: int) -> list[str]:
    import symbolic
    from symbolic.errors import IdentificationError
    from symbolic.identify import excitation as ex
    from symbolic.identify.excitation_noise import equivalent_noise, resolve_noise, treatment
    from symbolic.identify.excitation_report import _predict_reference, excite, read_declarations
    from symbolic.robots import example_path

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # link 3's published inertia violates the triangle inequality (noted)
        model = symbolic.derive(symbolic.robots.load("puma560"))
    names = model.robot.generalized_coordinates
    declared = read_declarations(example_path("puma560_excitation"), names)
    period, harmonics = 20.0, 5
    started = time.perf_counter()
    result = excite(model, declared, period, harmonics=harmonics)
    seconds = time.perf_counter() - started
    where = ("experiment", declared.table.values)
    limits = ex.resolve_limits(model, where)
    noise = resolve_noise(model, declared.table.rate, where)
    middle = 0.5 * (limits.lower + limits.upper)
    sigma = equivalent_noise(model, noise, treatment(noise.rate, int(period * noise.rate) + 1, declared.settings), [middle])
    regressor = ex.casadi_regressor(model)
    K = max(100, 20 * harmonics)  # noqa: N806
    problem = ex.Problem(regressor, limits, period, harmonics, np.linspace(0.0, period, K, endpoint=False),
                         1.0 / sigma**2, "d")
    fine = np.linspace(0.0, period, ex.FINER * K, endpoint=False)
    rows = []
    for seed in range(100, 100 + references):
        z = ex.random_start(np.random.default_rng(seed), problem, fill=0.999)
        trajectory = problem.trajectory(z)
        worst = max(float(v.max()) for v in ex.violation(regressor, trajectory, limits, fine).values())
        p = _predict_reference(model, trajectory, noise, declared.settings, f"random {seed}")
        rows.append((seed, p.log_det, p.condition_number, worst))
    started = time.perf_counter()
    try:
        conditioned, refused = excite(model, declared, period, harmonics=harmonics, criterion="condition", starts=1), ""
    except IdentificationError as error:  # the criterion is not smooth: IPOPT may stop outside the limits
        conditioned, refused = None, str(error)
    seconds_condition = time.perf_counter() - started
    design = result.predicted
    log_dets = [r[1] for r in rows]
    conds = [r[2] for r in rows]
    b = len(design.names)
    best_det, median_det = max(log_dets), statistics.median(log_dets)
    lines = ["## PUMA 560: the D-optimal design against random references within the same limits", "",
             f"20 s, 5 harmonics × 6 joints, {b} base parameters; predicted at {noise.rate:g} Hz with the declared "
             f"noise. Design: 3 starts, {seconds:.0f} s (worst ratio to a limit "
             f"{max(float(v.max()) for v in result.design.worst.values()):.6f}). References: {references} random "
             "Fourier series (seeds 100…), each scaled until one of its limits is reached.", "",
             "| reference | log det M | cond(Σ^(−1/2)W) | worst ratio to a limit |", "|---|---|---|---|"]
    lines += [f"| random {s} | {d:.1f} | {c:.1f} | {w:.4f} |" for s, d, c, w in rows]
    lines += [f"| **design** (`--criterion d`) | **{design.log_det:.1f}** | **{design.condition_number:.1f}** | "
              f"{max(float(v.max()) for v in result.design.worst.values()):.4f} |",
              (f"| design `--criterion condition`, 1 start ({seconds_condition:.0f} s) | "
               f"{conditioned.predicted.log_det:.1f} | {conditioned.predicted.condition_number:.1f} | "
               f"{max(float(v.max()) for v in conditioned.design.worst.values()):.4f} |" if conditioned is not None else
               f"| design `--criterion condition`, 1 start ({seconds_condition:.0f} s) | refused: {refused} | | |"), "",
              f"Against the median random reference: det M × e^{design.log_det - median_det:.1f} (geometric-mean σ × "
              f"{math.exp(-(design.log_det - median_det) / (2 * b)):.3f}), condition number × "
              f"{design.condition_number / statistics.median(conds):.3f}; against the best random reference: det M × "
              f"e^{design.log_det - best_det:.1f}, condition number × {design.condition_number / min(conds):.3f} "
              "(against the best-conditioned one).", ""]
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/excitation.md")
    parser.add_argument("--repeat", type=int, default=3, help="Panda designs timed (default 3)")
    parser.add_argument("--references", type=int, default=10, help="random PUMA references (default 10)")
    parser.add_argument("--skip-panda", action="store_true")
    args = parser.parse_args()
    load_before = os.getloadavg()
    started = time.perf_counter()
    lines = ["# Excitation design: the Panda's design time, the PUMA 560 against random references", "",
             f"`make bench` on {platform.machine()}, Python {platform.python_version()}, NumPy {np.__version__}, "
             f"{os.cpu_count()} cores shared with other work; load average (1, 5, 15 min) "
             f"{', '.join(f'{x:.1f}' for x in load_before)} at the start.", ""]
    if not args.skip_panda:
        part, _ = panda(args.repeat)
        lines += part
        Path(args.out).write_text("\n".join(lines))  # kept should the PUMA part fail
    lines += puma(args.references)
    load_after = os.getloadavg()
    lines += [f"Load average at the end {', '.join(f'{x:.1f}' for x in load_after)}; the whole benchmark "
              f"{time.perf_counter() - started:.0f} s.", ""]
    Path(args.out).write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
