"""Single-precision C: the float functions' measured error against the double ones, every built-in robot and the
URDF arms of example-robot-data that tests/test_urdf.py imports (docs/contracts.md, "Single-precision C").

The figures are those ``symbolic generate NAME --precision float`` writes into ``NAME_float.h``
(:func:`symbolic.codegen.c_accuracy.float_accuracy`: both C sources compiled, called through ctypes at 1000 random
states inside the joint limits, seed 36; the worst over the states of ‖f_float − f_double‖₂ / ‖f_double‖₂).

    python bench/float_accuracy.py --out bench/results/float_accuracy.md
"""

from __future__ import annotations

import argparse
import importlib.metadata
import platform
import sys
import warnings
from pathlib import Path

import numpy as np

import symbolic
from symbolic.codegen.c_accuracy import NOTED, SEED, STATES, FunctionError, float_accuracy, sample_states
from symbolic.numeric import numeric_model

ARMS = {  # the arms of tests/test_urdf.py (ARMS), by their file in example-robot-data's robots folder
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "panda (URDF)": "panda_description/urdf/panda.urdf",
    "kinova": "kinova_description/robots/kinova.urdf",
    "xarm7": "xarm_description/urdf/xarm7.urdf",
    "z1": "z1_description/urdf/z1.urdf",
    "so101": "so_arm_description/urdf/so101.urdf",
}
SHOWN = ("inertia", "gravity", "inverse_dynamics", "forward_dynamics")


def models() -> list[tuple[str, symbolic.Robot]]:
    """The built-in robots, then the URDF arms (skipped, saying so, without example-robot-data)."""
    found = [(name, symbolic.robots.load(name)) for name in symbolic.robots.names()]
    try:
        folder = Path(importlib.metadata.distribution("example-robot-data").locate_file(
            "cmeel.prefix/share/example-robot-data/robots"))
    except importlib.metadata.PackageNotFoundError:
        print("example-robot-data is not installed: the URDF arms are left out", file=sys.stderr)
        return found
    return found + [(label, symbolic.load(folder / path)) for label, path in ARMS.items()]


def cell(error: FunctionError) -> str:
    """``3.2e-07``; above NOTED with ‖f_double‖ at that state (no ``|``: it would split the Markdown table)."""
    return error.figure("‖f_double‖")


def conditioning(model: symbolic.DynamicModel) -> tuple[float, float]:
    """Over the same states: the largest condition number of D(q), and the largest ‖τ‖ / ‖D q̈‖ (how much
    τ − bias cancels). Forward dynamics loses about their product with float's 6e-8 (docs/contracts.md)."""
    num = numeric_model(model)
    states = sample_states(model)
    cond, cancel = 0.0, 0.0
    for q, qd, qdd, t in zip(*(states[a].astype(float) for a in ("q", "qd", "qdd", "t"))):
        D = num.inertia(q)
        tau = num.inverse_dynamics(q, qd, qdd, t=float(t[0]))
        cond, cancel = max(cond, np.linalg.cond(D)), max(cancel, np.linalg.norm(tau) / np.linalg.norm(D @ qdd))
    return cond, cancel


def row(label: str, robot: symbolic.Robot) -> str:
    """The table's row of one robot: D, g, τ and forward dynamics, the conditioning, the other functions above NOTED."""
    model = symbolic.derive(robot)
    accuracy = float_accuracy(model)
    errors = {e.name: e for e in accuracy.errors}
    shown = [cell(errors[name]) if name in errors else "—" for name in SHOWN]
    above = [f"{e.name} {cell(e)}" for e in accuracy.errors if e.name not in SHOWN and e.worst is not None and e.worst > NOTED]
    cond, cancel = conditioning(model)
    return f"| {label} | " + " | ".join(shown) + f" | {cond:.2g} | {cancel:.2g} | {'; '.join(above) or '—'} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # model notes (units, URDF conversions) are not what is measured here
        rows = [row(label, robot) for label, robot in models()]
    text = "\n".join([
        "# Single-precision C: measured error against double",
        "",
        f"`python bench/float_accuracy.py` on {platform.machine()} / Python {platform.python_version()}: each robot's "
        f"float and double C compiled and called through ctypes at {STATES} random states inside the joint limits "
        f"(seed {SEED}); the worst over the states of ‖f_float − f_double‖₂ / ‖f_double‖₂ (D: Frobenius), as "
        "`symbolic generate NAME --precision float` states it in `NAME_float.h`. Above "
        f"{NOTED:g}, ‖f_double‖ at the worst state against its median: a much smaller output is a difference of larger "
        "terms (cancellation), a much larger one a configuration near a singular one. Forward dynamics solves "
        "D q̈ = τ − bias: its error grows with the condition number of D and with the cancellation in τ − bias, "
        "both given over the same states (double, from the numeric model).",
        "",
        f"| robot | D | g | τ | q̈ (forward dynamics) | max cond(D) | max ‖τ‖/‖D q̈‖ | other functions above {NOTED:g} |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
        "",
    ])
    args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
