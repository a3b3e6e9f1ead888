"""Fleet benchmark (issue 25, "Scale"): a campaign's speed-up over one log at a time, the scheduler's overhead,
and 1 000 short logs with the workers' memory.

Synthetic fleets of the two-link arm (tests/fleet_cases.py: the logs are written into a temporary folder):

1. **Speed-up.** 24 logs of 120 s at 200 Hz (4 robots × 6), task ``diagnose`` (a few seconds per log).
   *One at a time*: the whole campaign with ``workers=0`` (``symbolic campaign --workers 0``: each log in turn
   in this process, no Dask, then the same analysis, report and figures: the same files); its tasks alone
   (:func:`symbolic.fleet.tasks.run_log` on each log in turn) are reported too.
   *Campaign*: ``symbolic.fleet.run`` on a local cluster of 2 worker processes (started before, its start
   reported apart; warm: each worker has run one log before, as on a cluster that outlives a campaign; the
   cold campaign is reported too), the whole campaign: planning, the tasks, the analysis, report and
   figures. The two are run :data:`ROUNDS` times, interleaved, and the medians compared (the machine is
   shared); CPU times give what two idle cores would give.
2. **Scheduler overhead.** The same 24 tasks through :func:`symbolic.fleet.execution.execute` on a cluster
   of 1 worker: (wall time − Σ the tasks' own run times) / Σ the tasks' run times.
3. **1 000 short logs.** 10 robots × 100 daily logs of 2 s, task ``identify``, on 2 workers: wall time,
   logs per second, and each worker's resident memory after the first 100 and after all 1 000.

BLAS runs one thread per process everywhere, as Dask starts its workers (``OMP_NUM_THREADS=1`` ...), so that
one at a time and in parallel do the same work. Wall times on a machine shared with other sessions depend
on their load; CPU times do not, and give the speed-up two idle cores would give. Each part starts from an
empty campaign cache; the derivation cache (``SYMBOLIC_CACHE_DIR``) is a
temporary folder filled by a first derivation before the timings. The machine is shared: its load
average is printed with the results.

    python bench/fleet.py --out bench/results/fleet.md
"""

from __future__ import annotations

import argparse
import datetime as dt
import logging
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")  # as Dask starts its workers: the same work one at a time and in parallel

import numpy as np  # noqa: E402  (after the thread counts)

ROOT = Path(__file__).resolve().parents[1]
ROUNDS = 2
"""Rounds of (one at a time, campaign), interleaved; the medians are reported."""
SECONDS = 120.0
"""Length of each log of the speed-up's first campaign (about 1 s of diagnosis per log) and of the trim test."""
LONGER: tuple[float, ...] = ()
"""Lengths of the logs of further speed-up campaigns (``--seconds 120 360``: diagnoses of a few seconds)."""
SHORT = 1000
"""Short logs of the memory part (10 robots)."""
SMALL_SECONDS = 100.0
"""Length of the logs of the small-task campaign: about 0.1 s of identification each (issue 38 §4)."""
SMALL_ROUNDS = 3
"""Rounds of the small-task campaign (1 worker, 2 workers; batched, one log per task), interleaved."""
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


def cluster(workers: int):
    from dask.distributed import Client

    from symbolic.fleet.execution import local_cluster

    started = time.perf_counter()
    local = local_cluster(workers)  # as symbolic campaign starts it
    client = Client(local)
    return local, client, time.perf_counter() - started


def trim_cost(folder: Path) -> dict:
    """CPU time of 8 diagnoses (120 s logs) in a fresh process, with and without Dask's MALLOC_TRIM_THRESHOLD_=65536."""
    import subprocess

    import fleet_cases
    from symbolic import fleet
    from symbolic.fleet.execution import plan
    from symbolic.fleet.store import Store

    path = fleet_cases.fleet(folder / "trim", logs=4, robots=2, seconds=SECONDS, kind="diagnose")
    code = ("import resource, sys, pickle; from symbolic.fleet.tasks import run_log; jobs = pickle.load(open(sys.argv[1], 'rb')); "
            "run_log(jobs[0]); r0 = resource.getrusage(resource.RUSAGE_SELF); [run_log(j) for j in jobs]; "
            "r1 = resource.getrusage(resource.RUSAGE_SELF); print(r1.ru_utime - r0.ru_utime, r1.ru_stime - r0.ru_stime)")
    import pickle

    _, jobs = plan(fleet.load(path), Store(folder / "trim_out"))
    (folder / "jobs.pickle").write_bytes(pickle.dumps(jobs))
    out = {}
    for label, value in (("glibc default", None), ("MALLOC_TRIM_THRESHOLD_=65536", "65536")):
        env = {k: v for k, v in os.environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
        if value:
            env["MALLOC_TRIM_THRESHOLD_"] = value
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
        done = subprocess.run([sys.executable, "-c", code, str(folder / "jobs.pickle")], env=env, capture_output=True,
                              text=True, check=True)
        user, system = map(float, done.stdout.split()[-2:])
        out[label] = (user, system)
    return out


def rss(client) -> list[float]:
    """Resident memory of each worker process, MB."""
    import psutil

    return sorted(v / 1e6 for v in client.run(lambda: psutil.Process().memory_info().rss).values())


def cpu(client) -> dict[str, float]:
    """CPU seconds (user + system) each worker has used so far."""
    import psutil

    return client.run(lambda: sum(psutil.Process().cpu_times()[:2]))


def warm(job) -> None:
    """What a worker does once per model (imports, the derivation read from the cache, the regressor's
    evaluators): done before the timing of a warm campaign, as on a cluster that outlives one campaign."""
    from symbolic.fleet.tasks import run_log

    run_log(job)


def speed_up(folder: Path, seconds: float) -> dict:
    import fleet_cases
    from symbolic import fleet
    from symbolic.fleet.execution import execute, plan
    from symbolic.fleet.store import Store
    from symbolic.fleet.tasks import run_log

    folder = folder / f"speed_{seconds:g}"
    path = fleet_cases.fleet(folder / "long", logs=6, robots=4, seconds=seconds, kind="diagnose")
    campaign = fleet.load(path)
    _, jobs = plan(campaign, Store(folder / "serial"))
    run_log(jobs[0])  # derivation, regressor and base parameters into the derivation cache (as a worker reads them)
    from symbolic.plotting import figure_class

    figure_class()  # the report's imports (Matplotlib), before either side is timed: both run in this process
    serial_times, campaign_times, starts, serial_cpu, worker_cpu, client_cpu, cold_times = [], [], [], [], [], [], []
    workers_cpu, whole_times, whole_cpu, one_worker = [], [], [], []
    for round_ in range(ROUNDS):  # interleaved: the machine is shared, its load moves between the phases
        started, used = time.perf_counter(), time.process_time()
        serial = [run_log(job) for job in jobs]
        serial_times.append(time.perf_counter() - started)
        serial_cpu.append(time.process_time() - used)
        started, used = time.perf_counter(), time.process_time()
        fleet.run(campaign, folder / f"serial_{round_}", workers=0)  # the whole campaign, one log at a time, no Dask
        whole_times.append(time.perf_counter() - started)
        whole_cpu.append(time.process_time() - used)
        local, client, start_2 = cluster(2)
        starts.append(start_2)
        try:
            if round_ == 0:  # cold: each worker imports and reads the model during the campaign
                started = time.perf_counter()
                fleet.run(campaign, folder / "cold", scheduler=local.scheduler_address)
                cold_times.append(time.perf_counter() - started)
            client.run(warm, jobs[0])
            used, own = cpu(client), time.process_time()
            started = time.perf_counter()
            outcome = fleet.run(campaign, folder / f"out2_{round_}", scheduler=local.scheduler_address)
            campaign_times.append(time.perf_counter() - started)
            after = cpu(client)
            worker_cpu.append(max(after[w] - used[w] for w in after))
            workers_cpu.append(sum(after[w] - used[w] for w in after))
            client_cpu.append(time.process_time() - own)
        finally:
            client.close()
            local.close()
        local, client, _ = cluster(1)
        try:
            client.run(warm, jobs[0])
            one_worker.append(campaign_on(local, client, campaign, folder / f"out1w_{round_}"))
        finally:
            client.close()
            local.close()
    one_at_a_time, campaign_2, start_2 = (float(np.median(x)) for x in (serial_times, campaign_times, starts))
    local, client, start_1 = cluster(1)
    try:
        started = time.perf_counter()
        results = execute(jobs, Store(folder / "out1"), scheduler=local.scheduler_address)
        wall_1 = time.perf_counter() - started
    finally:
        client.close()
        local.close()
    own = sum(r["seconds"] for r in results.values())
    return {"seconds": seconds, "logs": len(jobs), "errors": sum(r["status"] != "ok" for r in serial),
            "one_at_a_time": one_at_a_time,
            "task_mean": sum(r["seconds"] for r in serial) / len(serial), "campaign_2": campaign_2, "start_2": start_2,
            "speed_up": one_at_a_time / campaign_2, "speed_up_with_start": one_at_a_time / (campaign_2 + start_2),
            "wall_1": wall_1, "own_1": own, "overhead": (wall_1 - own) / own, "start_1": start_1,
            "rounds": [(a, b) for a, b in zip(serial_times, campaign_times)],
            "serial_cpu": float(np.median(serial_cpu)), "worker_cpu": float(np.median(worker_cpu)),
            "client_cpu": float(np.median(client_cpu)), "cold": cold_times[0],
            "workers_cpu": float(np.median(workers_cpu)),
            "whole": float(np.median(whole_times)), "whole_cpu": float(np.median(whole_cpu)),
            "whole_rounds": whole_times, "one_worker": one_worker,
            "computed": outcome.computed, "campaign_errors": len(outcome.errors),
            "overhead_errors": sum(r["status"] != "ok" for r in results.values())}


def campaign_on(local, client, campaign, out: Path) -> tuple[float, float, float, float]:
    """Wall time of the whole campaign on the warm cluster ``local``, the busier worker's CPU time, all workers'
    CPU time, and this process's (the client's, hosting the scheduler) CPU time."""
    from symbolic import fleet

    used, own = cpu(client), time.process_time()
    started = time.perf_counter()
    fleet.run(campaign, out, scheduler=local.scheduler_address)
    wall = time.perf_counter() - started
    after = cpu(client)
    spent = [after[w] - used[w] for w in after]
    return wall, max(spent), sum(spent), time.process_time() - own


def small_tasks(folder: Path) -> dict:
    """36 logs of about 0.1 s of identification each: the whole campaign on 1 warm worker against 2, with the
    logs batched per task (symbolic.fleet.execution.batches) and one log per task, :data:`SMALL_ROUNDS` rounds
    interleaved."""
    import fleet_cases
    from symbolic import fleet
    from symbolic.fleet import execution
    from symbolic.fleet.execution import plan
    from symbolic.fleet.store import Store
    from symbolic.fleet.tasks import run_log

    folder = folder / "small"
    path = fleet_cases.fleet(folder / "logs", logs=6, robots=6, seconds=SMALL_SECONDS, kind="identify")
    campaign = fleet.load(path)
    _, jobs = plan(campaign, Store(folder / "serial"))
    run_log(jobs[0])
    started = time.perf_counter()
    serial = [run_log(job) for job in jobs]
    tasks_alone = time.perf_counter() - started
    clusters = {n: cluster(n) for n in (1, 2)}
    runs: dict[tuple[str, int], list[tuple[float, float, float, float]]] = {}
    try:
        for local, client, _ in clusters.values():
            client.run(warm, jobs[0])
        k = 0
        for _ in range(SMALL_ROUNDS):
            for label, most in (("batched", execution.MOST_PER_TASK), ("one per task", 1)):
                kept, execution.MOST_PER_TASK = execution.MOST_PER_TASK, most
                try:
                    for n, (local, client, _) in clusters.items():
                        k += 1
                        runs.setdefault((label, n), []).append(campaign_on(local, client, campaign, folder / f"out{k}"))
                finally:
                    execution.MOST_PER_TASK = kept
        groups = {n: len(execution.batches(jobs, n)) for n in (1, 2)}
    finally:
        for local, client, _ in clusters.values():
            client.close()
            local.close()
    return {"logs": len(jobs), "seconds": SMALL_SECONDS, "task_mean": tasks_alone / len(jobs),
            "tasks_alone": tasks_alone, "errors": sum(r["status"] != "ok" for r in serial), "runs": runs,
            "batches": groups}


def short_logs(folder: Path) -> dict:
    import fleet_cases
    from symbolic import fleet
    from symbolic.fleet.execution import execute, plan
    from symbolic.fleet.store import Store

    path = fleet_cases.fleet(folder / "short", logs=SHORT // 10, robots=10, seconds=2.0, spacing=dt.timedelta(days=1))
    campaign = fleet.load(path)
    _, jobs = plan(campaign, Store(folder / "short_out"))
    local, client, _ = cluster(2)
    try:
        execute(jobs[:SHORT // 10], Store(folder / "short_out"), scheduler=local.scheduler_address)
        after_100 = rss(client)
        started = time.perf_counter()
        results = execute(jobs, Store(folder / "short_all"), scheduler=local.scheduler_address)
        wall = time.perf_counter() - started
        after_all = rss(client)
    finally:
        client.close()
        local.close()
    return {"logs": len(jobs), "wall": wall, "rate": len(jobs) / wall, "after_100": after_100, "after_all": after_all,
            "errors": sum(r["status"] != "ok" for r in results.values())}


def speed_section(a: dict) -> list[str]:
    """The Markdown of one speed-up campaign."""
    one = float(np.median([r[0] for r in a["one_worker"]]))
    one_cpu = float(np.median([r[2] + r[3] for r in a["one_worker"]]))
    return [
        f"## Speed-up: {a['logs']} logs of {a['seconds']:g} s, task diagnose",
        "",
        "| | seconds |",
        "|---|---|",
        f"| the whole campaign one log at a time (`--workers 0`: the tasks in turn in this process, no Dask, then "
        f"the same analysis, report and figures; median of {len(a['rounds'])} rounds) | {a['whole']:.1f} |",
        f"| its tasks alone (run_log in turn; median of {len(a['rounds'])} rounds) | {a['one_at_a_time']:.1f} "
        f"(mean task {a['task_mean']:.2f} s) |",
        f"| campaign on 1 warm local worker (median of {len(a['one_worker'])} rounds) | {one:.1f} |",
        f"| campaign on 2 warm local workers (plan, tasks, analysis, report, figures) | {a['campaign_2']:.1f} |",
        f"| **2 workers over 1, wall time** | **{one / a['campaign_2']:.2f}×** |",
        f"| the same on 2 cold workers (each imports and reads the model during the campaign) | {a['cold']:.1f} |",
        f"| starting the 2-worker local cluster | {a['start_2']:.1f} |",
        f"| **speed-up of the campaign, wall time** (the same files written) | **{a['whole'] / a['campaign_2']:.2f}×** "
        f"(cold workers: {a['whole'] / a['cold']:.2f}×) |",
        f"| speed-up against the tasks alone (the report and figures counted on the campaign's side only) | "
        f"{a['speed_up']:.2f}× (cold workers: {a['one_at_a_time'] / a['cold']:.2f}×) |",
        "",
        "Rounds (tasks alone, whole campaign one at a time, campaign on 2 workers), s: "
        + ", ".join(f"({x:.1f}, {w:.1f}, {y:.1f})" for (x, y), w in zip(a["rounds"], a["whole_rounds"])) + ".",
        "",
        f"CPU time, which the machine's other load does not change: the whole campaign one at a time "
        f"{a['whole_cpu']:.1f} s, its tasks alone {a['serial_cpu']:.1f} s; in the "
        f"campaign the two workers {a['workers_cpu']:.1f} s together, the busier {a['worker_cpu']:.1f} s, and the client (planning, analysis, report, figures) "
        f"{a['client_cpu']:.1f} s. On two idle cores the campaign would take about the busier worker's time plus the "
        f"client's: **{a['whole_cpu'] / (a['worker_cpu'] + a['client_cpu']):.2f}×** faster than the whole campaign "
        f"one at a time ({a['serial_cpu'] / (a['worker_cpu'] + a['client_cpu']):.2f}× its tasks alone), and "
        f"**{one_cpu / (a['worker_cpu'] + a['client_cpu']):.2f}×** faster than on 1 worker (its worker and client "
        f"{one_cpu:.1f} s).",
        "",
        f"Error rows: {a['errors']} one at a time, {a['campaign_errors']} in the campaign, {a['overhead_errors']} on 1 worker.",
        "",
    ]


def small_section(a: dict) -> list[str]:
    """The Markdown of the small-task campaign (issue 38 §4: 2 workers at least 1.7× faster than 1)."""
    def median(label: str, n: int, k: int) -> float:
        return float(np.median([r[k] for r in a["runs"][(label, n)]]))

    def idle(label: str, n: int) -> float:  # on idle cores: the busier worker's CPU time plus the client's
        return float(np.median([r[1] + r[3] for r in a["runs"][(label, n)]]))

    lines = [f"## Small tasks: {a['logs']} logs of {a['seconds']:g} s, task identify (mean task "
             f"{a['task_mean']:.3f} s)", "",
             f"The whole campaign (plan, tasks, analysis, report, figures) on 1 and on 2 warm local workers, median of "
             f"{len(a['runs'][('batched', 1)])} interleaved rounds; the tasks alone, in turn in this process: "
             f"{a['tasks_alone']:.2f} s. Batched: {a['batches'][1]} tasks on 1 worker, {a['batches'][2]} on 2 "
             "(symbolic.fleet.execution.batches); one per task: as before this change.", "",
             "| tasks | 1 worker (s) | 2 workers (s) | **2 over 1, wall** | on idle cores (CPU: busier worker + client), "
             "2 over 1 | client CPU, 1 / 2 workers (s) |", "|---|---|---|---|---|---|"]
    for label in ("batched", "one per task"):
        w1, w2 = median(label, 1, 0), median(label, 2, 0)
        lines.append(f"| {label} | {w1:.2f} | {w2:.2f} | **{w1 / w2:.2f}×** | {idle(label, 1) / idle(label, 2):.2f}× | "
                     f"{median(label, 1, 3):.2f} / {median(label, 2, 3):.2f} |")
    lines += ["", "Rounds (1 worker, 2 workers), s: " + "; ".join(
        f"{label}: " + ", ".join(f"({x[0]:.2f}, {y[0]:.2f})" for x, y in zip(a["runs"][(label, 1)], a["runs"][(label, 2)]))
        for label in ("batched", "one per task")) + ".", "", f"Error rows: {a['errors']} (the fleet's bad file).", ""]
    return lines


def markdown(speeds: list[dict], b: dict, c: dict, small: dict | None = None) -> str:
    load = os.getloadavg()
    return "\n".join([
        "# Fleet benchmark (bench/fleet.py)",
        "",
        f"Run {dt.date.today().isoformat()} on {platform.machine()}, {os.cpu_count()} processors (shared with other "
        f"sessions: load average {START_LOAD[0]:.2f} at the start, {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} at the end), "
        f"Python {platform.python_version()}. "
        "Regenerate: `python bench/fleet.py --out bench/results/fleet.md`.",
        "",
        *(small_section(small) if small else []),
        *[line for a in speeds for line in speed_section(a)],
        "## Scheduler overhead: the same tasks on 1 worker",
        "",
        "(wall time through Dask − Σ the tasks' own run times) / Σ their run times; the cluster's start apart.",
        "",
        "| logs | mean task (s) | wall through Dask (s) | Σ own run times (s) | **overhead** | cluster start (s) |",
        "|---|---|---|---|---|---|",
        *[f"| {x['logs']} of {x['seconds']:g} s | {x['own_1'] / x['logs']:.2f} | {x['wall_1']:.2f} | {x['own_1']:.2f} | "
          f"**{100 * x['overhead']:.1f} %** | {x['start_1']:.1f} |" for x in speeds],
        "",
        "## Dask's MALLOC_TRIM_THRESHOLD_ (why symbolic's local cluster leaves it out)",
        "",
        f"CPU time of 8 diagnoses of {SECONDS:g} s logs in a fresh process (one BLAS thread), user + system, s:",
        "",
        "| glibc malloc | user | system |",
        "|---|---|---|",
        *[f"| {label} | {u:.1f} | {s_:.1f} |" for label, (u, s_) in c.items()],
        "",
        f"## {b['logs']} short logs (2 s each, identify) on 2 workers",
        "",
        f"{b['wall']:.1f} s, {b['rate']:.1f} logs/s ({b['errors']} error row(s): the fleet's bad file is among them). Resident memory "
        f"per worker after {b['logs'] // 10} logs: {', '.join(f'{m:.0f}' for m in b['after_100'])} MB; after all "
        f"{b['logs']}: {', '.join(f'{m:.0f}' for m in b['after_all'])} MB.",
        "",
    ])


START_LOAD = os.getloadavg()


def main() -> None:
    global SECONDS, LONGER, SHORT
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="write the results as Markdown here")
    parser.add_argument("--skip-short", action="store_true", help="leave out the 1 000 short logs")
    parser.add_argument("--skip-small", action="store_true", help="leave out the 36 small tasks")
    parser.add_argument("--only-small", action="store_true", help="only the 36 small tasks (a quick look)")
    parser.add_argument("--seconds", type=float, nargs="+", default=[SECONDS, *LONGER],
                        help="lengths of the speed-up campaigns' logs (the first also for the trim test)")
    parser.add_argument("--short", type=int, default=1000, help="number of short logs, a multiple of 10 (smoke runs)")
    args = parser.parse_args()
    (SECONDS, *LONGER), SHORT = args.seconds, args.short
    with tempfile.TemporaryDirectory(prefix="symbolic-bench-fleet-") as tmp:
        os.environ["SYMBOLIC_CACHE_DIR"] = str(Path(tmp) / "derivations")
        small = small_tasks(Path(tmp)) if not args.skip_small else None
        print(small, flush=True)
        if args.only_small:
            print("\n".join(small_section(small)))
            return
        speeds = [speed_up(Path(tmp), seconds) for seconds in (SECONDS, *LONGER)]
        print(speeds, flush=True)
        c = trim_cost(Path(tmp))
        print(c, flush=True)
        b = short_logs(Path(tmp)) if not args.skip_short else {"logs": 0, "wall": 0, "rate": 0, "after_100": [],
                                                               "after_all": [], "errors": 0}
        print(b, flush=True)
    text = markdown(speeds, b, c, small)
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
