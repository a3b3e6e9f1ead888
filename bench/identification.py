"""Identification benchmark: EMPS IDIM-LS end to end (load the experiment + filter + decimate + LS).

The regressor is the EMPS model's, written by hand ([q̈, q̇, sign(q̇), 1]); the goal of issue 11 is
the whole identification in under 1 s. Wall time of each step, median of ``--repeat`` runs in this
process (after one warm-up run: imports and SciPy's first calls are not counted; the package import
is reported separately). The data are read from ../shared/data/emps or SYMBOLIC_DATA_PATH.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/identification.md")
    parser.add_argument("--repeat", type=int, default=21)
    args = parser.parse_args()
    folder = ROOT.parent / "shared" / "data" / "emps"
    if folder.is_dir():
        os.environ.setdefault("SYMBOLIC_DATA_PATH", str(folder))
    start = time.perf_counter()
    import numpy as np

    from symbolic import data, identify
    from symbolic.spec import robots

    imported = time.perf_counter() - start

    def regressor(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return np.stack([qdd, qd, np.sign(qd), np.ones_like(qd)], axis=-1)

    try:
        experiment = robots.example_path("emps_estimation")
        data.load(experiment, ["q"])
    except data.DataError as error:
        print(f"skipped: {error}")
        return 0
    steps: dict[str, list[float]] = {"load": [], "treatment": [], "least squares": [], "total": []}
    for run in range(args.repeat + 1):
        t0 = time.perf_counter()
        measurements = data.load(experiment, ["q"])
        t1 = time.perf_counter()
        observation = identify.observe(measurements, regressor, 4)
        t2 = time.perf_counter()
        result = identify.solve(observation, ["M", "Fv", "Fc", "offset"])
        t3 = time.perf_counter()
        if run:
            for key, value in zip(steps, (t1 - t0, t2 - t1, t3 - t2, t3 - t0)):
                steps[key].append(value)
    lines = ["# EMPS identification time", "", f"Median of {args.repeat} runs in one process (after a warm-up run), "
             f"milliseconds; 24 841 samples, decimated to {observation.samples}.", "",
             "| step | ms |", "|---|---|"]
    lines += [f"| {key} | {1e3 * statistics.median(values):.1f} |" for key, values in steps.items()]
    lines += ["", f"`import symbolic.data, symbolic.identify` (first import, SymPy included): {imported:.2f} s.",
              "Goal (issue 11): the EMPS identification end to end in under 1 s.", "",
              f"Result: M = {result['M'].value:.4f}, relative error {result.relative_error:.3f} %.", ""]
    lines += panda_lines()
    Path(args.out).write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


def panda_lines(samples: int = 20000) -> list[str]:
    """Panda, 20 000 samples: our base regressor (NumPy, vectorised over samples) and the LS solve, against
    Pinocchio's computeJointTorqueRegressor called per sample (Python binding loop; the C++ loop's per-call
    time is in runtime.md, 'joint-torque regressor')."""
    import warnings

    import numpy as np

    import symbolic
    from symbolic.identify.model import base_regressor, model_base

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = symbolic.robots.load("panda")
    model = symbolic.derive(robot)
    model_base(model)
    t0 = time.perf_counter()
    regressor = base_regressor(model)
    compile_time = time.perf_counter() - t0
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-np.pi, np.pi, (samples, 7)), rng.uniform(-2, 2, (samples, 7)), rng.uniform(-5, 5, (samples, 7)))
    regressor(q[:10], qd[:10], qdd[:10])  # warm-up
    t0 = time.perf_counter()
    Y = regressor(q, qd, qdd)
    t_eval = time.perf_counter() - t0
    W = Y.transpose(1, 0, 2).reshape(-1, Y.shape[2])
    y = W @ rng.uniform(-1, 1, W.shape[1])
    t0 = time.perf_counter()
    np.linalg.lstsq(W, y, rcond=None)
    t_ls = time.perf_counter() - t0
    lines = ["## Panda, 20 000 samples", "",
             f"Our base regressor ({Y.shape[2]} columns), NumPy over all samples at once: {t_eval:.3f} s "
             f"(building the evaluator: {compile_time:.2f} s); least squares on {W.shape[0]}×{W.shape[1]}: {t_ls:.3f} s."]
    try:
        import pinocchio as pin
        sys.path.insert(0, str(ROOT / "tests"))
        from reference_pinocchio import build

        pmodel = build(robot)
        pdata = pmodel.createData()
        t0 = time.perf_counter()
        for k in range(samples):
            pin.computeJointTorqueRegressor(pmodel, pdata, q[k], qd[k], qdd[k])
        t_pin = time.perf_counter() - t0
        lines.append(f"Pinocchio computeJointTorqueRegressor in a Python loop: {t_pin:.3f} s (ratio ours/Pinocchio "
                     f"×{t_eval / t_pin:.2f}).")
    except ImportError:
        lines.append("Pinocchio not installed: no anchor.")
    lines += ["The generated C regressor against Pinocchio's in one C++ binary: runtime.md. The pipeline does not call",
              "the generated C yet (it would need a compiler at identification time): see the closing notes.", ""]
    return lines


if __name__ == "__main__":
    sys.exit(main())
