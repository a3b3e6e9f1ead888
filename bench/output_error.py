"""Output-error identification's cost: one Levenberg–Marquardt iteration against one simulation.

The 20 s, 1 kHz closed-loop PD run of the 7-DOF Panda of ``bench/simulate.py`` (its gains and reference) is
simulated once and written as a log with its ``[controller]``; then, on that log, the closed loop of
:func:`symbolic.identify.output_error.closed_loop` runs without sensitivities (one simulation) and with
the forward sensitivities to p parameters (what one iteration of the fit costs: the trial steps of an
iteration are plain simulations, the sensitivities are computed once per accepted step). p = 7 (the links'
Izz) and 14 (masses and Izz). Wall time, best of ``--repeat``; the build and compilation of the
sensitivity function (once per model, controller and parameter set) apart.

Run: ``python bench/output_error.py [--repeat 3] [--parameters 7,14] [--out bench/results/output_error.md]``
(``make bench`` writes the results file). Goal (issue 34): one iteration within 3× one simulation.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

SETS = {
    7: [f"Izz{i}" for i in range(1, 8)],
    14: [f"{a}{i}" for i in range(1, 8) for a in ("m", "Izz")],
}


def panda_log(folder: Path, truth_text: str | None = None, noise: float = 0.0):
    """The Panda's model and an experiment file of its simulated PD run (bench/simulate.py's loop); ``truth_text``:
    the model file that makes the log instead (the product's simulator: a timing case, not a test of findings),
    ``noise``: white noise on the logged force, that fraction of each joint's RMS, and a 20-bit encoder."""
    import symbolic
    from simulate import log_and_table
    from symbolic.data import load, write_columns
    from symbolic.description.modelfile import loads
    from symbolic.simulation import simulate

    model = symbolic.derive(symbolic.robots.load("panda"))
    truth = model if truth_text is None else symbolic.derive(loads(truth_text, "truth.toml"))
    q0 = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    names = [f"q{i}" for i in range(1, 8)]
    log, table = log_and_table(model, q0, names)
    run = simulate(truth, log, controller=table, initial=(q0, np.zeros(7)))
    q, tau = run.simulated.q.copy(), run.simulated.tau.copy()
    if noise:
        rng = np.random.default_rng(1)
        step = 2 * np.pi / 2**20
        q = np.round(q / step) * step
        tau += rng.normal(0.0, 1.0, tau.shape) * noise * np.sqrt(np.mean(tau**2, axis=0))
    columns = {"t": log.t}
    for j, c in enumerate(names):
        columns.update({f"q_{c}": q[:, j], f"tau_{c}": tau[:, j], f"ref_{c}": log.ref[:, j]})
    write_columns(columns, folder / "panda.csv")
    quoted = ", ".join(f'"{c}"' for c in names)
    lines = ['data = "panda.csv"', "[signals]", *(f'{k} = "{k}"' for k in columns), "[controller]", 'kind = "pd"',
             f"coordinates = [{quoted}]", f"kp = {table['kp']!r}", f"kd = {table['kd']!r}", 'reference = "ref"']
    (folder / "panda.experiment.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return model, load(folder / "panda.experiment.toml", model=model.robot)


GAZ_COULOMB = (0.2450, 0.1523, 0.1827, 0.3591, 0.2669, 0.1658, 0.2109)
"""Gaz et al.'s Coulomb levels of the Panda's joints (N·m; ../shared/data/franka_panda/README.md)."""


def diagnose_times(coulomb_too: bool = False) -> list[str]:
    """``diagnose`` and ``diagnose --simulate`` of a Panda PD log (1 % force noise, 20-bit encoders) made by the
    model with viscous friction 0.5 N·m·s/rad on joint 5, diagnosed with the built-in model (none): wall time per
    step; ``coulomb_too``: then the same with Coulomb friction on every joint (Gaz et al.'s levels) in the truth and
    the model (a local response search: long, see docs/data.md)."""
    import symbolic

    builtin = symbolic.robots.path("panda").read_text(encoding="utf-8")
    viscous = '\n[[friction]]\ncoordinate = "q5"\nviscous = "0.5"\n'

    def coulomb(missing: bool) -> str:
        return "".join(f'\n[[friction]]\ncoordinate = "q{j}"\ncoulomb = "{level!r}"\n'
                       + ('viscous = "0.5"\n' if missing and j == 5 else "") for j, level in enumerate(GAZ_COULOMB, 1))

    lines = ["## diagnose --simulate on the Panda (20 s, 1 kHz, PD; viscous friction 0.5 N·m·s/rad missing on joint 5)", "",
             "| model | path | found | wall (s) | steps (s) |", "|---|---|---|---|---|"]
    lines += _diagnose_rows("built-in", builtin + viscous, None)
    if coulomb_too:
        lines += _diagnose_rows("with Coulomb friction on every joint", builtin + coulomb(True), builtin + coulomb(False))
    return lines + ["", "Goal (issue 34): the whole diagnose --simulate of the Panda within 60 s on 2 cores."]


def _diagnose_rows(title: str, truth: str, model: str | None) -> list[str]:
    """The table's rows of one model: the log made by ``truth`` (text), diagnosed with the model file ``model``
    (text; the built-in Panda where ``None``)."""
    from symbolic.workflow import diagnose

    lines = []
    with tempfile.TemporaryDirectory() as folder:
        builtin, measurements = panda_log(Path(folder), truth, noise=0.01)
        if model is not None:  # a file, as a user's: the diagnosis patches it (and only then judges the response)
            (Path(folder) / "panda_coulomb.toml").write_text(model, encoding="utf-8")
            model = str(Path(folder) / "panda_coulomb.toml")
        model = model or builtin
        for simulate in (False, True):
            started = time.perf_counter()
            d = diagnose(model, measurements, out=Path(folder) / f"out{simulate}", figures=False, simulate=simulate)
            wall = time.perf_counter() - started
            found = ", ".join(f"{f.effect} on {f.coordinate}" for f in d.found) or "nothing"
            steps = "; ".join(f"{k} {v:.1f}" for k, v in d.seconds.items())
            note = f" ({d.response.notes[0]})" if simulate and d.response is not None and d.response.notes else ""
            lines.append(f"| {title} | {'simulated' if simulate else 'inverse'} | {found}{note} | {wall:.1f} | {steps} |")
            print(lines[-1])
    return lines


def best(repeat: int, function) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--parameters", default="7,14", help="comma-separated sizes among 7, 14")
    parser.add_argument("--out", type=Path, help="also write the table as Markdown to this file")
    parser.add_argument("--coulomb", action="store_true", help="also diagnose a Panda with Coulomb friction on every "
                        "joint (its response search is local and takes many minutes)")
    args = parser.parse_args()
    from symbolic.identify.output_error import closed_loop

    with tempfile.TemporaryDirectory() as folder:
        model, measurements = panda_log(Path(folder))
        values = {p.name: p.value for p in model.robot.parameters}
        lines = ["# Output error: one iteration against one simulation (bench/output_error.py)", "",
                 f"Panda, {measurements.samples} samples at 1 kHz, discrete PD. Wall time, best of {args.repeat}.", "",
                 "| p | simulation (s) | iteration: simulation with sensitivities (s) | ratio | build + compile (s) |",
                 "|---|---|---|---|---|"]
        print("\n".join(lines))
        for size in (int(s) for s in args.parameters.split(",")):
            free = SETS[size]
            loop = closed_loop(model, measurements, free, parameters={n: values[n] for n in free})
            theta = np.array([values[n] for n in free])
            loop.run(theta, sensitivities=False)
            started = time.perf_counter()
            chunked = loop.function(True)
            chunked.function(chunked.length(measurements.samples))
            build = time.perf_counter() - started
            plain = best(args.repeat, lambda: loop.run(theta, sensitivities=False))
            sensitive = best(args.repeat, lambda: loop.run(theta))
            lines.append(f"| {size} | {plain:.3f} | {sensitive:.3f} | {sensitive / plain:.1f} | {build:.1f} |")
            print(lines[-1])
    lines += ["", "Goal (issue 34): ratio ≤ 3. Forward sensitivities cost about one simulation per parameter.", ""]
    lines += diagnose_times(args.coulomb)
    if args.out:
        args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
