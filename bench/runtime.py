"""Runtime benchmark: generated C against Pinocchio's C++ in one binary, one run (``make bench``).

For PUMA 560 and Panda, a C++ program is generated that builds the Pinocchio model from the same
numbers as the test-suite's reference (tests/reference_pinocchio.py), links the generated C of
generated/<name>/ and times, in interleaved rounds over the same 64 random states:
rnea vs NAME_inverse_dynamics, crba vs NAME_inertia, computeCoriolisMatrix vs NAME_coriolis_matrix,
computeGeneralizedGravity vs NAME_gravity, computeJointTorqueRegressor vs NAME_regressor,
computeRNEADerivatives vs NAME_inverse_dynamics_derivatives and computeABADerivatives vs
NAME_forward_dynamics_derivatives (at the τ of rnea). computeRNEADerivatives also fills ∂τ/∂q̈ = M, which
NAME_inverse_dynamics_derivatives leaves to NAME_inertia: a third row times the two together against it.
It first checks that both sides compute the same numbers.
Reported: median ns per call over rounds and the median of the per-round ratio ours/Pinocchio, for a
portable build (-O3) and a native one (-O3 -march=native); Pinocchio is compiled header-only with the same flags.

Needs g++, the pin wheel (headers and libpinocchio_default) and cmeel-eigen (Eigen headers);
Pinocchio's C++ build takes 1-2 minutes per robot and configuration (two at a time on 2 cores).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import warnings  # noqa: E402

import symbolic  # noqa: E402
from reference_pinocchio import build  # noqa: E402
from symbolic.codegen.exported import batched_programs, programs  # noqa: E402

PAIRS = [
    ("inverse dynamics", "pin_rnea", "our_id"),
    ("inertia D(q)", "pin_crba", "our_inertia"),
    ("Coriolis matrix", "pin_coriolis", "our_coriolis_matrix"),
    ("gravity", "pin_gravity", "our_gravity"),
    ("joint-torque regressor", "pin_regressor", "our_regressor"),
    ("∂τ/∂(q, q̇)", "pin_rnea_derivatives", "our_id_derivatives"),
    ("∂q̈/∂(q, q̇, τ)", "pin_aba_derivatives", "our_fd_derivatives"),
    ("∂τ/∂(q, q̇) and D = ∂τ/∂q̈", "pin_rnea_derivatives_again", "our_id_derivatives_and_inertia"),
]
TARGETS = {"inverse dynamics": 0.15, "inertia D(q)": 0.30, "Coriolis matrix": 0.28, "gravity": 0.08, "joint-torque regressor": 0.3,
           "∂τ/∂(q, q̇)": 0.5, "∂q̈/∂(q, q̇, τ)": 0.5, "∂τ/∂(q, q̇) and D = ∂τ/∂q̈": None}
FUNCTION_OF = {"inverse dynamics": "inverse_dynamics", "inertia D(q)": "inertia", "Coriolis matrix": "coriolis_matrix", "gravity": "gravity",
               "joint-torque regressor": "regressor", "∂τ/∂(q, q̇)": "inverse_dynamics_derivatives",
               "∂q̈/∂(q, q̇, τ)": "inverse_dynamics_derivatives", "∂τ/∂(q, q̇) and D = ∂τ/∂q̈": "inverse_dynamics_derivatives"}
CASES = len(PAIRS) * 2
CASE_NAMES = ", ".join(f'"{key}"' for _, pin_key, our_key in PAIRS for key in (pin_key, our_key))
"""The timed cases in the order of the C++ switch: each pair's Pinocchio case even, ours the next (odd) one."""


def prefix() -> Path:
    import cmeel

    return Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix"


def eigen_include() -> Path:
    """Eigen's headers: cmeel-eigen's (the bench extra), else the copy CasADi's wheel bundles (both Eigen 3.4)."""
    cmeel_eigen = prefix() / "include" / "eigen3"
    if (cmeel_eigen / "Eigen" / "Core").is_file():
        return cmeel_eigen
    import casadi

    bundled = Path(casadi.__file__).resolve().parent / "include" / "eigen3"
    if (bundled / "Eigen" / "Core").is_file():
        return bundled
    raise SystemExit("no Eigen headers: pip install cmeel-eigen (pip install -e '.[bench]')")


def eigen_version(include: Path) -> str:
    """``3.4.0``, read from Eigen's Macros.h."""
    text = (include / "Eigen" / "src" / "Core" / "util" / "Macros.h").read_text()
    parts = [re.search(rf"#define EIGEN_{k}_VERSION (\d+)", text) for k in ("WORLD", "MAJOR", "MINOR")]
    return ".".join(m.group(1) if m else "?" for m in parts)


def cpp_source(name: str, model, states: np.ndarray, rounds: int, calls: int) -> str:
    lines = []
    for j in range(1, model.njoints):
        M = model.jointPlacements[j]
        Y = model.inertias[j]
        R = ", ".join(repr(float(x)) for x in M.rotation.ravel())
        t = ", ".join(repr(float(x)) for x in M.translation)
        c = ", ".join(repr(float(x)) for x in Y.lever)
        I = ", ".join(repr(float(x)) for x in Y.inertia.ravel())
        lines.append(
            f"  {{ Eigen::Matrix3d R; R << {R}; Eigen::Matrix3d I; I << {I};\n"
            f"    auto j = model.addJoint({model.parents[j]}, pinocchio::JointModelRZ(), pinocchio::SE3(R, Eigen::Vector3d({t})), \"j{j}\");\n"
            f"    model.appendBodyToJoint(j, pinocchio::Inertia({float(Y.mass)!r}, Eigen::Vector3d({c}), I), pinocchio::SE3::Identity()); }}"
        )
    g = ", ".join(repr(float(x)) for x in model.gravity.linear)
    data = ", ".join(repr(float(x)) for x in states.ravel())
    n = model.nq
    return f"""
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/regressor.hpp>
#include <pinocchio/algorithm/rnea-derivatives.hpp>
#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <chrono>
#include <cstdio>
#include <cmath>
#include "{name}.h"

static const int N = {n};
static const int S = {len(states)};
static const double STATES[] = {{ {data} }};  // per state: q, qd, qdd

int main() {{
  pinocchio::Model model;
{chr(10).join(lines)}
  model.gravity.linear(Eigen::Vector3d({g}));
  pinocchio::Data data(model);
  const double *p = {name}_parameter_defaults;
  std::vector<Eigen::VectorXd> q(S), qd(S), qdd(S), taus(S);
  for (int s = 0; s < S; ++s) {{
    q[s] = Eigen::Map<const Eigen::VectorXd>(STATES + s * 3 * N, N);
    qd[s] = Eigen::Map<const Eigen::VectorXd>(STATES + s * 3 * N + N, N);
    qdd[s] = Eigen::Map<const Eigen::VectorXd>(STATES + s * 3 * N + 2 * N, N);
    taus[s] = pinocchio::rnea(model, data, q[s], qd[s], qdd[s]);
  }}
  static double out[N * ({name}_NTHETA > N ? {name}_NTHETA : N)];
  static double out2[N * N], out3[N * N];
  double theta[{name}_NTHETA];
  {name}_standard_parameters(p, theta);
  double check = 0.0, worst[7] = {{0, 0, 0, 0, 0, 0, 0}};
  for (int s = 0; s < S; ++s) {{  // both sides compute the same numbers
    Eigen::VectorXd tau = pinocchio::rnea(model, data, q[s], qd[s], qdd[s]);
    {name}_inverse_dynamics(q[s].data(), qd[s].data(), qdd[s].data(), p, out);
    for (int i = 0; i < N; ++i) worst[0] = std::fmax(worst[0], std::fabs(out[i] - tau[i]));
    pinocchio::crba(model, data, q[s]);
    data.M.triangularView<Eigen::StrictlyLower>() = data.M.transpose().triangularView<Eigen::StrictlyLower>();
    {name}_inertia(q[s].data(), p, out);
    for (int i = 0; i < N * N; ++i) worst[1] = std::fmax(worst[1], std::fabs(out[i] - data.M(i / N, i % N)));
    pinocchio::computeCoriolisMatrix(model, data, q[s], qd[s]);
    Eigen::VectorXd hp = data.C * qd[s];
    {name}_coriolis_matrix(q[s].data(), qd[s].data(), p, out);
    for (int i = 0; i < N; ++i) {{ double h = 0; for (int j = 0; j < N; ++j) h += out[i * N + j] * qd[s][j]; worst[2] = std::fmax(worst[2], std::fabs(h - hp[i])); }}
    Eigen::VectorXd gp = pinocchio::computeGeneralizedGravity(model, data, q[s]);
    {name}_gravity(q[s].data(), p, out);
    for (int i = 0; i < N; ++i) worst[3] = std::fmax(worst[3], std::fabs(out[i] - gp[i]));
    {name}_regressor(q[s].data(), qd[s].data(), qdd[s].data(), p, out);  // Y theta against rnea
    for (int i = 0; i < N; ++i) {{ double t = 0; for (int j = 0; j < {name}_NTHETA; ++j) t += out[i * {name}_NTHETA + j] * theta[j]; worst[4] = std::fmax(worst[4], std::fabs(t - tau[i])); }}
    pinocchio::computeRNEADerivatives(model, data, q[s], qd[s], qdd[s]);  // our derivatives against Pinocchio's
    {name}_inverse_dynamics_derivatives(q[s].data(), qd[s].data(), qdd[s].data(), p, out, out2);
    for (int i = 0; i < N * N; ++i) worst[5] = std::fmax(worst[5], std::fmax(std::fabs(out[i] - data.dtau_dq(i / N, i % N)),
                                                                           std::fabs(out2[i] - data.dtau_dv(i / N, i % N))));
    pinocchio::computeABADerivatives(model, data, q[s], qd[s], taus[s]);
    {name}_forward_dynamics_derivatives(q[s].data(), qd[s].data(), taus[s].data(), p, out, out2, out3);
    for (int i = 0; i < N * N; ++i) {{
      worst[6] = std::fmax(worst[6], std::fmax(std::fabs(out[i] - data.ddq_dq(i / N, i % N)), std::fabs(out2[i] - data.ddq_dv(i / N, i % N))));
      if (i % N >= i / N) worst[6] = std::fmax(worst[6], std::fabs(out3[i] - data.Minv(i / N, i % N)));  // Pinocchio fills its upper triangle
    }}
  }}
  std::printf("{{\\"check\\": [%.3e, %.3e, %.3e, %.3e, %.3e, %.3e, %.3e]}}\\n", worst[0], worst[1], worst[2], worst[3], worst[4], worst[5], worst[6]);
  const char *names[{CASES}] = {{{CASE_NAMES}}};
  for (int r = 0; r < {rounds}; ++r) {{
    double ns[{CASES}];
    for (int step = 0; step < {CASES}; ++step) {{
      const int k = step ^ (r & 1);  // each pair in alternating order: drifts within a round cancel
      auto start = std::chrono::steady_clock::now();
      for (int c = 0; c < {calls}; ++c) {{
        int s = c % S;
        switch (k) {{
          case 0: check += pinocchio::rnea(model, data, q[s], qd[s], qdd[s])[0]; break;
          case 1: {name}_inverse_dynamics(q[s].data(), qd[s].data(), qdd[s].data(), p, out); check += out[0]; break;
          case 2: check += pinocchio::crba(model, data, q[s])(0, 0); break;
          case 3: {name}_inertia(q[s].data(), p, out); check += out[0]; break;
          case 4: check += pinocchio::computeCoriolisMatrix(model, data, q[s], qd[s])(0, 0); break;
          case 5: {name}_coriolis_matrix(q[s].data(), qd[s].data(), p, out); check += out[0]; break;
          case 6: check += pinocchio::computeGeneralizedGravity(model, data, q[s])[0]; break;
          case 7: {name}_gravity(q[s].data(), p, out); check += out[0]; break;
          case 8: check += pinocchio::computeJointTorqueRegressor(model, data, q[s], qd[s], qdd[s])(0, 0); break;
          case 9: {name}_regressor(q[s].data(), qd[s].data(), qdd[s].data(), p, out); check += out[0]; break;
          case 10: case 14: pinocchio::computeRNEADerivatives(model, data, q[s], qd[s], qdd[s]); check += data.dtau_dq(0, 0); break;
          case 11: {name}_inverse_dynamics_derivatives(q[s].data(), qd[s].data(), qdd[s].data(), p, out, out2); check += out[0]; break;
          case 12: pinocchio::computeABADerivatives(model, data, q[s], qd[s], taus[s]); check += data.ddq_dq(0, 0); break;
          case 13: {name}_forward_dynamics_derivatives(q[s].data(), qd[s].data(), taus[s].data(), p, out, out2, out3); check += out[0]; break;
          case 15: {name}_inverse_dynamics_derivatives(q[s].data(), qd[s].data(), qdd[s].data(), p, out, out2);
                   {name}_inertia(q[s].data(), p, out3); check += out[0] + out3[0]; break;
        }}
      }}
      ns[k] = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count() / {calls};
    }}
    std::printf("{{\\"round\\": %d", r);
    for (int k = 0; k < {CASES}; ++k) std::printf(", \\"%s\\": %.2f", names[k], ns[k]);
    std::printf("}}\\n");
  }}
  std::fprintf(stderr, "checksum %g\\n", check);
  return 0;
}}
"""


CONFIGURATIONS = {
    "portable": ["-O3"],
    "native": ["-O3", "-march=native"],
}
PIN_DEFINES = ["-DNDEBUG", "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "-DBOOST_MPL_LIMIT_LIST_SIZE=30",
               "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30", "-DBOOST_FUSION_INVOKE_MAX_ARITY=12"]


def compile_benchmark(name: str, flags: list[str], rounds: int, calls: int, work: Path) -> tuple[Path, dict]:
    """Both sides from source with the same flags: our C with gcc, Pinocchio header-only with g++."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = symbolic.robots.load(name)
    model = build(robot)
    rng = np.random.default_rng(2026)
    n = model.nq
    states = np.hstack([rng.uniform(-np.pi, np.pi, (64, n)), rng.uniform(-2, 2, (64, n)), rng.uniform(-2, 2, (64, n))])
    tag = f"{name}_{'_'.join(f.strip('-').replace('=', '') for f in flags)}"
    source = work / f"bench_{tag}.cpp"
    source.write_text(cpp_source(name, model, states, rounds, calls))
    pre = prefix()
    gen = ROOT / "generated" / name
    obj = work / f"{tag}.o"
    subprocess.run(["gcc", "-std=c99", *flags, "-c", str(gen / f"{name}.c"), "-o", str(obj)], check=True)
    exe = work / f"bench_{tag}"
    command = ["g++", "-std=c++17", *flags, *PIN_DEFINES, "-w", f"-I{pre / 'include'}", f"-I{eigen_include()}", f"-I{gen}"]
    cpp_object = work / f"bench_{tag}.cpp.o"
    declarations = re.sub(r"/\*.*?\*/", "", (gen / f"{name}.h").read_text(), flags=re.S)  # the header but its comments
    key = hashlib.sha256("\0".join([*command, source.read_text(), declarations]).encode()).hexdigest()
    key_file = work / f"bench_{tag}.cpp.key"
    if not (cpp_object.is_file() and key_file.is_file() and key_file.read_text() == key):  # --work keeps it between runs
        subprocess.run([*command, "-c", str(source), "-o", str(cpp_object)], check=True)
        key_file.write_text(key)
    subprocess.run([*command, str(cpp_object), str(obj), "-o", str(exe), f"-L{pre / 'lib'}", "-lpinocchio_default",
                    f"-Wl,-rpath,{pre / 'lib'}"], check=True)
    return exe, {"robot": robot}


def measure(name: str, exe: Path, robot) -> dict:
    """Run pinned to one CPU (fewer migrations between the two sides of a round)."""
    cpu = max(os.sched_getaffinity(0))
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True,
                         preexec_fn=lambda: os.sched_setaffinity(0, {cpu})).stdout.splitlines()
    check = json.loads(out[0])["check"]
    samples = [json.loads(line) for line in out[1:]]
    derived = symbolic.derive(robot)
    built = programs(derived)
    batched = batched_programs(derived)
    result = {"check": check, "rows": []}
    for label, pin_key, our_key in PAIRS:
        pin_ns = statistics.median(s[pin_key] for s in samples)
        our_ns = statistics.median(s[our_key] for s in samples)
        ratios = [s[our_key] / s[pin_key] for s in samples]
        ratio = statistics.median(ratios)
        quartiles = statistics.quantiles(ratios, n=4)
        program = built[FUNCTION_OF[label]]
        angles = len(batched[FUNCTION_OF[label]].angles)
        result["rows"].append((label, pin_ns, our_ns, ratio, (quartiles[0], quartiles[2]), program.operations, angles))
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/runtime.md")
    parser.add_argument("--rounds", type=int, default=1001)
    parser.add_argument("--calls", type=int, default=400)
    parser.add_argument("--robots", default="puma560,panda")
    parser.add_argument("--configurations", default=",".join(CONFIGURATIONS))
    parser.add_argument("--work", help="keep the build here and reuse Pinocchio's compiled side while its source, flags and "
                                       "our header are unchanged (a re-run after a change of our C then takes seconds to build)")
    args = parser.parse_args()
    robots = args.robots.split(",")
    configurations = args.configurations.split(",")
    gcc_version = subprocess.run(["gcc", "-dumpfullversion"], capture_output=True, text=True).stdout.strip()
    lines = [
        "# Runtime: generated C vs Pinocchio C++",
        "",
        f"`make bench` on {platform.machine()} ({cpu_model()}), gcc/g++ {gcc_version}, Pinocchio {pinocchio_version()} compiled",
        f"header-only from the pin wheel with the same flags as the generated C (one binary per robot and configuration; Eigen {eigen_version(eigen_include())}",
        f"headers from {'cmeel-eigen' if eigen_include() == prefix() / 'include' / 'eigen3' else 'the copy in the casadi wheel'}).",
        f"{args.rounds} interleaved rounds × {args.calls} calls over 64 random states, pinned to one CPU; medians.",
        "In each round every pair is timed back to back, Pinocchio first in even rounds and ours first in odd ones.",
        "Our C is compiled with `gcc -std=c99` and the flags shown. Without -march, its sin/cos loop runs a copy",
        "compiled for AVX2+FMA when the processor has them (run-time dispatch, as glibc's libm does for the sin/cos Pinocchio calls).",
        "Ratio = median over rounds of (ours / Pinocchio) measured in the same round, with the rounds' quartiles. Target ratios from issue 4 (derivatives: issue 36).",
        "Angles: distinct sin/cos arguments, evaluated in one batched vectorisable call (templates/sincos.c.j2).",
        "On a shared virtual machine the ratios move by up to ±30 % from run to run (compare several runs before concluding).",
        "",
    ]
    if args.work:
        Path(args.work).mkdir(parents=True, exist_ok=True)
    folder = contextlib.nullcontext(args.work) if args.work else tempfile.TemporaryDirectory()
    with folder as tmp, ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        print(f"compiling {len(robots) * len(configurations)} benchmarks against Pinocchio (1-2 minutes each)...", flush=True)
        jobs = {(name, config): pool.submit(compile_benchmark, name, CONFIGURATIONS[config], args.rounds, args.calls, Path(tmp))
                for config in configurations for name in robots}
        built = {key: job.result() for key, job in jobs.items()}  # measure only once nothing else runs
        derivatives = []
        for config in configurations:
            lines += [f"## {config}: `{' '.join(CONFIGURATIONS[config])}`", ""]
            for name in robots:
                exe, info = built[(name, config)]
                r = measure(name, exe, info["robot"])
                lines += [f"### {name}", "",
                          f"Agreement (max abs difference, τ / D / C·q̇ / g / our Y·θ against rnea / ∂τ/∂(q, q̇) / ∂q̈/∂(q, q̇, τ)): "
                          f"{', '.join(f'{x:.1e}' for x in r['check'])}", "",
                          "| function | Pinocchio [ns] | generated C [ns] | ratio | rounds' quartiles | target | operations | angles |",
                          "|---|---|---|---|---|---|---|---|"]
                for label, pin_ns, our_ns, ratio, (low, high), ops, angles in r["rows"]:
                    target = TARGETS[label]
                    mark = "—" if target is None else "met" if ratio <= target else "not met"
                    goal = "—" if target is None else f"≤ ×{target} ({mark})"
                    lines.append(f"| {label} | {pin_ns:.0f} | {our_ns:.0f} | ×{ratio:.3f} | {low:.3f}–{high:.3f} | {goal} | {ops} | {angles} |")
                    print(f"{config:8s} {name:8s} {label:18s} pin {pin_ns:8.0f} ns  ours {our_ns:8.0f} ns  ×{ratio:.3f} ({mark})", flush=True)
                    if label in DERIVATIVE_ROWS:
                        derivatives.append((config, name, label, pin_ns, our_ns, ratio, goal))
                lines.append("")
    lines += derivative_summary(derivatives)
    lines += [
        "Team reference figures (not re-measured here): Panda rnea 805 ns, Pinocchio traced through CasADi 201 ns (×0.24),",
        "SymPyBotics C 144 ns (×0.17); PUMA 560 rnea 696 ns, 130 ns (×0.19), 121 ns (×0.17); crba 329 ns (PUMA), 386 ns (Panda).",
        "",
    ]
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text("\n".join(lines))
    print(f"written {args.out}")
    return 0


DERIVATIVE_ROWS = {"∂τ/∂(q, q̇)": "NAME_inverse_dynamics_derivatives vs computeRNEADerivatives",
                   "∂q̈/∂(q, q̇, τ)": "NAME_forward_dynamics_derivatives vs computeABADerivatives",
                   "∂τ/∂(q, q̇) and D = ∂τ/∂q̈": "NAME_inverse_dynamics_derivatives + NAME_inertia vs computeRNEADerivatives"}


def derivative_summary(rows: list[tuple]) -> list[str]:
    """The derivative rows of every configuration and robot in one section (quoted by docs/contracts.md)."""
    lines = ["## Derivatives against Pinocchio", "",
             "The derivative rows of the tables above (same run, same medians). Pinocchio's computeRNEADerivatives also",
             "computes ∂τ/∂q̈ = M, which our derivative function leaves to NAME_inertia (third row: both, timed together).", "",
             "| build | robot | functions | Pinocchio [ns] | generated C [ns] | ratio | target |", "|---|---|---|---|---|---|---|"]
    for config, name, label, pin_ns, our_ns, ratio, goal in rows:
        lines.append(f"| {config} | {name} | {DERIVATIVE_ROWS[label]} | {pin_ns:.0f} | {our_ns:.0f} | ×{ratio:.3f} | {goal} |")
    return lines + [""]


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def pinocchio_version() -> str:
    import pinocchio

    return pinocchio.__version__


if __name__ == "__main__":
    sys.exit(main())
