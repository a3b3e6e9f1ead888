"""Models whose coordinates the data do not all measure, judged on the response alone (issue 34; docs/workflow.md,
"Coordinates the data do not measure"): the values named, and cases with nothing wrong.

Truth from tests/elastic_reference.py (Spong's elastic joint and the two-link arm with joint 2 elastic, set-valued
rotor Coulomb friction, the industrial PI velocity cascade on the motor encoders), never from the product's
simulator; the link-side encoders' columns are left out of the experiment. The model file is the elastic model a
user writes (tests/elastic_reference.elastic_model_text / elastic_arm_text), with the truth's values except the
stiffness where a case says.

* wrong stiffness — the file's k a factor off the truth's: what is named, and k against the truth's;
* null cases — the file right, over seeds, stiffnesses and motor encoder resolutions: count what is named (goal:
  nothing).

Results to bench/results/unmeasured.md (``python bench/unmeasured.py``; ``--quick`` for a few cases, ``--arm`` for the
two-link arm's cases too: many minutes each).
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


def run(kind: str, file_values: dict, **options) -> tuple[list[str], dict, dict, float]:
    """(labels named, the corrected values, held-out force error before/after per coordinate, seconds)."""
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        if kind == "joint":
            experiment = truth.write_joint_experiment(tmp, **options)
            text = truth.elastic_model_text(**file_values)
        else:
            experiment = truth.write_arm_joint_experiment(tmp, **options)
            text = truth.elastic_arm_text(**file_values)
        truth.motor_encoder_only(experiment)
        model = tmp / f"{kind}.toml"
        model.write_text(text, encoding="utf-8")
        started = time.perf_counter()
        result = diagnose(str(model), str(experiment), figures=False)
        seconds = time.perf_counter() - started
    corrected = {c["parameter"]: c["value"] for c in result.response.corrections}
    force = {c: (result.before["validation"]["force"][c], result.after["validation"]["force"][c])
             for c in result.before["validation"]["force"]}
    return [f["label"] for f in result.found], corrected, force, seconds


def _wrong(quick: bool, arm: bool) -> list[tuple[str, str, float, dict, dict]]:
    """(kind, parameter, truth, file values, options)."""
    joint = [("joint", "k", truth.TRUTH["k"], {"k": factor * truth.TRUTH["k"]}, {}) for factor in (1.7, 0.6)]
    joint += [("joint", "k", 1500.0, {"k": 1.7 * 1500.0}, {"stiffness": 1500.0})]
    arms = [("arm", "k2", truth.ARM_TRUTH["k2"], {"k2": 1.7 * truth.ARM_TRUTH["k2"]}, {})] if arm else []
    return joint[:1] + arms if quick else joint + arms


def _nulls(quick: bool, arm: bool) -> list[tuple[str, dict, dict]]:
    """(kind, file values, options): the file right."""
    cases = []
    for seed in range(5):
        for stiffness in (400.0, 1500.0):
            for counts in (2**17 * truth.GEAR, 2**14 * truth.GEAR):
                for noise in (0.02, 0.05):
                    cases.append(("joint", {"k": stiffness}, dict(seed=seed, stiffness=stiffness, motor_counts=counts,
                                                                  force_noise=noise)))
    arms = [("arm", {}, dict(seed=0))] if arm else []  # the arm's search takes many minutes
    return cases[:2] + arms if quick else cases + arms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(HERE / "results" / "unmeasured.md"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--arm", action="store_true", help="the two-link arm's cases too (many minutes each)")
    args = parser.parse_args()
    lines = ["# Models the data do not fully measure, judged on the response alone", "",
             "`python bench/unmeasured.py` (docs/workflow.md, \"Coordinates the data do not measure\"). Truth: "
             "tests/elastic_reference.py, the link encoders left out; the model file the elastic model with the "
             "truth's values except where said. Held-out simulated force error (%) before → after.", "",
             "## Wrong stiffness in the model file", "",
             "| case | file | truth | named | corrected | error (%) | seconds |", "|---|---|---|---|---|---|---|"]
    for kind, parameter, value, file_values, options in _wrong(args.quick, args.arm):
        named, corrected, force, seconds = run(kind, file_values, **options)
        got = corrected.get(parameter)
        text = "—" if got is None else f"{got:.4g} ({100 * (got / value - 1):+.2f} %)"
        errors = ", ".join(f"{c} {b:.3g} → {a:.3g}" for c, (b, a) in force.items())
        lines.append(f"| {kind} | {parameter} = {file_values[parameter]:.4g} | {value:.4g} | {', '.join(named) or 'nothing'} "
                     f"| {text} | {errors} | {seconds:.0f} |")
        print(lines[-1], flush=True)
    lines += ["", "## Nothing wrong in the model file", "",
              "| case | options | named | error (%) | seconds |", "|---|---|---|---|---|"]
    count = named_count = 0
    for kind, file_values, options in _nulls(args.quick, args.arm):
        named, _, force, seconds = run(kind, file_values, **options)
        count += 1
        named_count += bool(named)
        shown = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in options.items())
        errors = ", ".join(f"{c} {b:.3g} → {a:.3g}" for c, (b, a) in force.items())
        lines.append(f"| {kind} | {shown} | {', '.join(named) or 'nothing'} | {errors} | {seconds:.0f} |")
        print(lines[-1], flush=True)
    lines += ["", f"Null cases: {count}, with something named: {named_count}.", ""]
    Path(args.out).write_text("\n".join(lines), encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
