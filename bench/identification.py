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
    from symbolic import robots

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


PIN_LOOP = r"""
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/regressor.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

int main(int argc, char **argv) {
  pinocchio::Model model;
@JOINTS@
  model.gravity.linear(Eigen::Vector3d(@GRAVITY@));
  pinocchio::Data data(model);
  const int N = model.nq;
  const long S = std::atol(argv[2]);
  std::vector<double> states(S * 3 * N);
  FILE *f = std::fopen(argv[1], "rb");
  if (std::fread(states.data(), sizeof(double), states.size(), f) != states.size()) return 1;
  std::fclose(f);
  const long width = N * 10 * (model.njoints - 1);
  std::vector<double> out(S * width);  // the stacked regressor, as an identification keeps it
  std::vector<double> times;
  for (int round = 0; round < 7; ++round) {
    auto t0 = std::chrono::steady_clock::now();
    for (long s = 0; s < S; ++s) {
      Eigen::Map<const Eigen::VectorXd> q(&states[s * 3 * N], N), qd(&states[s * 3 * N + N], N), qdd(&states[s * 3 * N + 2 * N], N);
      pinocchio::computeJointTorqueRegressor(model, data, q, qd, qdd);
      std::copy(data.jointTorqueRegressor.data(), data.jointTorqueRegressor.data() + width, &out[s * width]);
    }
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  std::printf("%.6f %.6f\n", times[times.size() / 2], out[width / 2]);
  return 0;
}
"""


def pinocchio_cpp_loop(robot, q: "np.ndarray", qd: "np.ndarray", qdd: "np.ndarray") -> float | None:
    """Median seconds of Pinocchio's computeJointTorqueRegressor called in a C++ loop (-O3, header-only as
    in runtime.py; our loop is built with -O1) over the samples, the regressor copied out as an identification stores it."""
    import subprocess
    import tempfile

    import numpy as np

    sys.path.insert(0, str(ROOT / "tests"))
    sys.path.insert(0, str(ROOT / "bench"))
    try:
        from reference_pinocchio import build
        from runtime import PIN_DEFINES, prefix
    except ImportError:
        return None
    model = build(robot)
    joints = []
    for j in range(1, model.njoints):
        M, Y = model.jointPlacements[j], model.inertias[j]
        fmt = lambda a: ", ".join(repr(float(x)) for x in np.ravel(a))  # noqa: E731
        joints.append(f"  {{ Eigen::Matrix3d R; R << {fmt(M.rotation)}; Eigen::Matrix3d I; I << {fmt(Y.inertia)};\n"
                      f"    auto j = model.addJoint({model.parents[j]}, pinocchio::JointModelRZ(), "
                      f"pinocchio::SE3(R, Eigen::Vector3d({fmt(M.translation)})), \"j{j}\");\n"
                      f"    model.appendBodyToJoint(j, pinocchio::Inertia({float(Y.mass)!r}, Eigen::Vector3d({fmt(Y.lever)}), I), "
                      "pinocchio::SE3::Identity()); }")
    source = PIN_LOOP.replace("@JOINTS@", "\n".join(joints)).replace("@GRAVITY@", ", ".join(repr(float(x)) for x in model.gravity.linear))
    pre = prefix()
    with tempfile.TemporaryDirectory() as work:
        folder = Path(work)
        (folder / "loop.cpp").write_text(source)
        np.hstack([q, qd, qdd]).astype(float).tofile(folder / "states.bin")
        subprocess.run(["g++", "-std=c++17", "-O3", *PIN_DEFINES, "-w", f"-I{pre / 'include'}", f"-I{pre / 'include' / 'eigen3'}",
                        str(folder / "loop.cpp"), "-o", str(folder / "loop"), f"-L{pre / 'lib'}", "-lpinocchio_default",
                        f"-Wl,-rpath,{pre / 'lib'}"], check=True)
        out = subprocess.run([str(folder / "loop"), str(folder / "states.bin"), str(len(q))], check=True,
                             capture_output=True, text=True).stdout.split()
    return float(out[0])


def panda_lines(samples: int = 20000) -> list[str]:
    """Panda, 20 000 samples: our base regressor (compiled C loop, and NumPy) and the LS solve of the
    pipeline (QR of [W y]), against Pinocchio's computeJointTorqueRegressor in a C++ loop over the same
    samples (the issue's anchor) and in a Python loop."""
    import warnings

    import numpy as np

    import symbolic
    from symbolic.identify.least_squares import _ols
    from symbolic.identify.model import base_regressor, model_base

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = symbolic.robots.load("panda")
    model = symbolic.derive(robot)
    model_base(model)
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-np.pi, np.pi, (samples, 7)), rng.uniform(-2, 2, (samples, 7)), rng.uniform(-5, 5, (samples, 7)))
    timed: dict[str, float] = {}
    for label, compiled in (("C loop", True), ("NumPy", False)):
        t0 = time.perf_counter()
        regressor = base_regressor(model, compiled=compiled)
        regressor(q[:10], qd[:10], qdd[:10])  # builds (and for C compiles once per machine) the evaluator
        timed[f"build {label}"] = time.perf_counter() - t0
        runs = []
        for _ in range(7):
            t0 = time.perf_counter()
            Y = regressor(q, qd, qdd)
            runs.append(time.perf_counter() - t0)
        timed[label] = statistics.median(runs)
    W = Y.transpose(1, 0, 2).reshape(-1, Y.shape[2])
    y = W @ rng.uniform(-1, 1, W.shape[1])
    runs = []
    for _ in range(5):
        t0 = time.perf_counter()
        _ols(y, W, tuple(map(str, range(W.shape[1]))))
        runs.append(time.perf_counter() - t0)
    timed["LS"] = statistics.median(runs)
    lines = ["## Panda, 20 000 samples", "",
             f"Median of 7 runs, seconds. Base regressor ({Y.shape[2]} columns, {W.shape[0]} rows stacked); "
             f"least squares as the pipeline solves it (QR of [W y], SVD of R).", "",
             "| step | s |", "|---|---|",
             f"| our base regressor, compiled C loop (the pipeline's default at this size) | {timed['C loop']:.4f} |",
             f"| our base regressor, NumPy (no compiler) | {timed['NumPy']:.4f} |",
             f"| least squares {W.shape[0]}×{W.shape[1]} | {timed['LS']:.4f} |",
             f"| building the evaluators: C (cached .so) / NumPy | {timed['build C loop']:.2f} / {timed['build NumPy']:.2f} |"]
    try:
        t_cpp = pinocchio_cpp_loop(robot, q, qd, qdd)
    except Exception as error:  # noqa: BLE001 — a benchmark without g++ or headers reports it and goes on
        t_cpp = None
        lines.append(f"| Pinocchio C++ loop | not measured: {error} |")
    if t_cpp is not None:
        lines += [f"| Pinocchio computeJointTorqueRegressor, C++ loop (-O3) | {t_cpp:.4f} |", "",
                  f"Ratio regressor/Pinocchio: ×{timed['C loop'] / t_cpp:.3f} (goal ≤ ×0.3); regressor + least squares "
                  f"against Pinocchio's regressor alone: ×{(timed['C loop'] + timed['LS']) / t_cpp:.2f}."]
    try:
        import pinocchio as pin
        sys.path.insert(0, str(ROOT / "tests"))
        from reference_pinocchio import build

        pmodel = build(robot)
        pdata = pmodel.createData()
        t0 = time.perf_counter()
        for k in range(samples):
            pin.computeJointTorqueRegressor(pmodel, pdata, q[k], qd[k], qdd[k])
        lines.append(f"Pinocchio from a Python loop: {time.perf_counter() - t0:.3f} s.")
    except ImportError:
        lines.append("Pinocchio not installed: no Python-loop anchor.")
    return lines + [""]


if __name__ == "__main__":
    sys.exit(main())
