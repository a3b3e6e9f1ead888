"""Joint elasticity and backlash from two encoders, and from the motor encoder alone (issue 34): cases with nothing
missing, and the values named.

Truth from tests/elastic_reference.py (Spong's elastic joint, set-valued rotor Coulomb friction, the industrial
PI velocity cascade on the motor encoder), never from the product's simulator. Each case is diagnosed with the
whole catalogue (the inverse path: the two-encoder test runs on both paths alike):

* null cases — the geared joint and the two-link arm with rigid transmissions, over seeds, motor and link encoder
  resolutions and force noise: count what is named (goal: nothing);
* elastic cases — stiffnesses from 400 to 20000 N·m/rad, backlash from 2 to 10 mrad, on the joint and on the arm's
  joint 2: the values named against the truth's;
* the same with the link encoder left out (``one_encoder``): rigid joints over seeds, motor encoders and noise,
  stiffnesses from 150 to 4000 N·m/rad and backlash from 2 to 10 mrad read from the motor encoder alone.

Results to bench/results/joint_elasticity.md (``python bench/joint_elasticity.py``; ``--quick`` for a few cases).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

import elastic_reference as truth  # noqa: E402

from symbolic.workflow import diagnose  # noqa: E402


def run(kind: str, one_encoder: bool = False, **options) -> tuple[list[tuple[str, str, dict]], float]:
    """(named as (effect, coordinate, parameters), seconds) of one synthetic case; ``one_encoder``: the link encoder
    left out of the experiment (the motor encoder alone)."""
    with tempfile.TemporaryDirectory() as folder:
        model, experiment = truth.case_files(Path(folder), kind, one_encoder, **options)
        started = time.perf_counter()
        result = diagnose(str(model), str(experiment), figures=False)
        seconds = time.perf_counter() - started
    return [(f.effect, f.coordinate, f.parameters) for f in result.found], seconds


def _nulls(quick: bool) -> list[tuple[str, dict]]:
    encoders = [(2**17 * truth.GEAR, 2**20), (2**17 * truth.GEAR, 2**14), (2**12 * truth.GEAR, 2**12),
                (2**20 * truth.GEAR, 2**20)]
    joint = [("joint", dict(rigid=True, seed=s, motor_counts=m, link_counts=l, force_noise=n))
             for s in range(3) for m, l in encoders for n in (0.02, 0.1)]
    arm = [("arm", dict(rigid=True, seed=s, force_noise=n)) for s in range(2) for n in (0.02, 0.1)]
    offsets = [("joint", dict(rigid=True, seed=s, link_offset=0.01)) for s in range(2)]
    cases = joint + arm + offsets
    return cases[:3] if quick else cases


def _one_encoder_nulls(quick: bool) -> list[tuple[str, dict]]:
    joint = [("joint", dict(rigid=True, one_encoder=True, seed=s, motor_counts=m * truth.GEAR, force_noise=n))
             for s in range(3) for m in (2**12, 2**17, 2**20) for n in (0.02, 0.1)]
    arm = [("arm", dict(rigid=True, one_encoder=True, seed=s, force_noise=n)) for s in range(2) for n in (0.02, 0.1)]
    cases = joint + arm
    return cases[:2] if quick else cases


CASES = [
    ("geared joint, k 400", "joint", dict(), {"stiffness": truth.TRUTH["k"], "motor_inertia": truth.TRUTH["Jm"]}),
    ("geared joint, k 4000", "joint", dict(stiffness=4000.0), {"stiffness": 4000.0, "motor_inertia": truth.TRUTH["Jm"]}),
    ("geared joint, k 20000", "joint", dict(stiffness=20000.0), {"stiffness": 20000.0,
                                                                 "motor_inertia": truth.TRUTH["Jm"]}),
    ("geared joint, k 400, 2^14 link encoder, force noise 0.1", "joint", dict(link_counts=2**14, force_noise=0.1),
     {"stiffness": truth.TRUTH["k"], "motor_inertia": truth.TRUTH["Jm"]}),
    ("geared joint, k 2000, backlash 10 mrad", "joint", dict(stiffness=2000.0, backlash=0.01),
     {"stiffness": 2000.0, "width": 0.01}),
    ("geared joint, k 2000, backlash 2 mrad", "joint", dict(stiffness=2000.0, backlash=0.002),
     {"stiffness": 2000.0, "width": 0.002}),
    ("arm joint 2, k 300", "arm", dict(), {"stiffness": truth.ARM_TRUTH["k2"], "motor_inertia": truth.ARM_TRUTH["Jm2"]}),
    ("arm joint 2, k 2000, backlash 8 mrad", "arm", dict(stiffness=2000.0, backlash=0.008),
     {"stiffness": 2000.0, "width": 0.008}),
]

ONE_ENCODER = [(f"geared joint, k {k:g}, motor encoder alone", "joint", dict(stiffness=k, one_encoder=True),
                {"stiffness": k}) for k in (150.0, 400.0, 1500.0, 4000.0)] + [
    ("arm joint 2, k 300, motor encoders alone", "arm", dict(one_encoder=True), {"stiffness": truth.ARM_TRUTH["k2"]}),
    ("arm joint 2, k 1000, motor encoders alone", "arm", dict(stiffness=1000.0, one_encoder=True), {"stiffness": 1000.0}),
    ("geared joint, k 2000, backlash 10 mrad, motor encoder alone", "joint",
     dict(stiffness=2000.0, backlash=0.01, one_encoder=True), {"width": 0.01, "stiffness": 2000.0}),
    ("geared joint, k 2000, backlash 2 mrad, motor encoder alone", "joint",
     dict(stiffness=2000.0, backlash=0.002, one_encoder=True), {"width": 0.002, "stiffness": 2000.0}),
    ("geared joint, k 400, backlash 10 mrad, motor encoder alone", "joint",
     dict(stiffness=400.0, backlash=0.01, one_encoder=True), {"width": 0.01, "stiffness": 400.0}),
    ("arm joint 2, k 2000, backlash 8 mrad, motor encoders alone", "arm",
     dict(stiffness=2000.0, backlash=0.008, one_encoder=True), {"width": 0.008, "stiffness": 2000.0})]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=HERE / "results" / "joint_elasticity.md")
    args = parser.parse_args()
    lines = ["# Joint elasticity and backlash from two encoders, and from the motor encoder alone", "",
             "`python bench/joint_elasticity.py` (issue 34); truth from tests/elastic_reference.py (Spong's elastic "
             "joint, set-valued rotor friction, the PI velocity cascade on the motor encoder), diagnosed with the "
             "whole catalogue.", "", "## Nothing missing (rigid transmissions)", "",
             "| case | named | seconds |", "|---|---|---|"]
    lines += _null_table(_nulls(args.quick))
    lines += ["", "## Nothing missing, the motor encoder alone", "",
              "The same rigid joints with the link encoder left out of the experiment: what the one-encoder reading "
              "(`joint_elasticity (one encoder)`, a motor declared on the joint) and the rest of the catalogue name.",
              "", "| case | named | seconds |", "|---|---|---|"]
    lines += _null_table(_one_encoder_nulls(args.quick))
    lines += ["", "## Elastic transmissions: the values named", "",
              "| case | named | value (truth) | seconds |", "|---|---|---|---|"]
    cases = CASES[:2] + ONE_ENCODER[:1] if args.quick else CASES + ONE_ENCODER
    for title, kind, options, expected in cases:
        named, seconds = run(kind, **options)
        values = {k: v for _, _, p in named for k, v in p.items()}
        shown = ", ".join(f"{e}({c})" for e, c, _ in named) or "nothing"
        compared = "; ".join(f"{k} {values[k]:.5g} ({v:g}, {100 * (values[k] / v - 1):+.2g} %)" if k in values
                             else f"{k} not named ({v:g})" for k, v in expected.items())
        lines.append(f"| {title} | {shown} | {compared} | {seconds:.1f} |")
        print(title, shown, compared, file=sys.stderr)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(args.out.read_text())


def _null_table(nulls: list[tuple[str, dict]]) -> list[str]:
    """The table's rows of null cases, and the count of those naming anything."""
    lines, false = [], 0
    for kind, options in nulls:
        named, seconds = run(kind, **options)
        false += bool(named)
        shown = ", ".join(f"{e}({c})" for e, c, _ in named) or "nothing"
        lines.append(f"| {kind} {options} | {shown} | {seconds:.1f} |")
        print(kind, options, shown, f"{seconds:.1f} s", file=sys.stderr)
    return lines + ["", f"**{len(nulls)} null cases, {false} with anything named.**"]


if __name__ == "__main__":
    main()
