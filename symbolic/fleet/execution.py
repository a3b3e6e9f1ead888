"""A campaign on Dask: the logs as tasks, results kept as they arrive, then what the fleet tells (docs/fleet.md).

:func:`run` takes a checked :class:`~symbolic.fleet.campaign.Campaign` and an output folder and

1. keys each log by content (:func:`symbolic.fleet.store.job_key`) and takes the results the cache
   already holds (a rerun after an interruption, or with new logs, computes only what is new);
2. submits the others to Dask, one or more logs per task (:func:`batches`,
   :func:`symbolic.fleet.tasks.run_batch`): without a scheduler address on a local cluster of worker
   processes on this machine (``workers`` of them, one thread each; default: the processors, at most one
   per log), else on the existing cluster at that address; each result is written to the cache as it arrives, and progress goes to the ``symbolic``
   logger (stderr in the command line, silenced by ``-q``);
3. assembles one row per log — robot, log, time, the parameters with σ, the gap, the effects, the events,
   the run time, or the error — and tests drift (:mod:`.drift`), outliers (:mod:`.outliers`) and judges
   each log's bursts against its siblings' logs (:mod:`.siblings`): the events, and the model's misfits;
4. writes ``results.csv``, ``report.md`` and the figures into the folder as one set
   (:func:`symbolic.export.write_files`: files of others and sub-folders are never touched; the cache
   is the sub-folder ``cache/``).

Only this module imports Dask, and only inside :func:`execute`: the rest of the package works without it.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import datetime as dt
import hashlib
import logging
import os
import re
import signal
import threading
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from symbolic.cache import stamp
from symbolic.errors import PROGRESS_EVERY, ClusterError, one_line, shorten
from symbolic.fleet.campaign import Campaign
from symbolic.fleet.drift import Drift, drifts, series_of
from symbolic.fleet.outliers import Outlier, outliers
from symbolic.fleet.store import Store, job_key, table
from symbolic.fleet.tasks import Job, run_batch, run_log

log = logging.getLogger("symbolic")

INSTALL = "symbolic campaign needs dask.distributed: pip install 'symbolic[fleet]' (or pip install 'dask[distributed]')"
WAIT_FOR_WORKERS = 120.0
"""Seconds to wait for the workers of an existing cluster (``--scheduler``) before giving up."""
CONNECT_TIMEOUT = 10.0
"""Seconds to wait for the scheduler at ``--scheduler`` to accept the connection and answer Dask's handshake."""
SCHEMES = ("tcp", "tls", "ws", "wss")
"""The schemes of a scheduler's address a campaign connects to (Dask's ``inproc`` is within one process only,
``ucx`` needs a library of its own)."""
ADDRESS = re.compile(r"(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+)"
                     r"(?::(?P<port>[0-9]{1,5}))?")
"""``[scheme://]host[:port]``: a host name, an IPv4 address or an IPv6 address in brackets."""
BATCHING = 2
"""A task takes 1/(BATCHING · workers) of the bytes of the logs not yet given to a task (:func:`batches`)."""
MOST_PER_TASK = 16
"""Logs in one task at most: an interrupted campaign loses at most the tasks running (their results arrive whole)."""


@dataclass(frozen=True, eq=False)
class Outcome:
    """What a campaign found: the rows, the drift and outlier tests, the files written, and how many logs were
    computed now or taken from the cache."""

    campaign: Campaign = field(repr=False)
    rows: tuple[dict[str, Any], ...]
    drifts: tuple[Drift, ...]
    outliers: tuple[Outlier, ...]
    computed: int
    cached: int
    files: tuple[Path, ...] = ()
    notes: tuple[str, ...] = ()
    misfits: tuple[dict[str, Any], ...] = ()
    """The systematic misfits of the models (:mod:`symbolic.fleet.siblings`)."""

    @property
    def errors(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]

    @property
    def events(self) -> list[dict[str, Any]]:
        return [{"robot": r["robot"], "log": r["log"], "time": r["time"], **e} for r in self.rows
                for e in r.get("events") or []]

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` contract (docs/fleet.md)."""
        return {
            "campaign": self.campaign.name,
            "logs": len(self.rows),
            "robots": len(self.campaign.robots),
            "computed": self.computed,
            "cached": self.cached,
            "errors": [{"robot": r["robot"], "log": r["log"], "error": r["error"]} for r in self.errors],
            "drift": [d.to_dict() for d in self.drifts if d.flagged],
            "outliers": [o.to_dict() for o in self.outliers if o.flagged],
            "events": self.events,
            "misfits": list(self.misfits),
            "tested": {"series": len(self.drifts), "outlier_tests": len(self.outliers)},
            "files": [str(p) for p in self.files],
            "notes": list(self.notes),
        }


def plan(campaign: Campaign, store: Store) -> tuple[list[dict[str, Any]], list[Job]]:
    """One row per log (robot, log, time when known before reading it, task, key) and the jobs of the logs
    that can be run (a log whose file name gives no time is an error row at once)."""
    rows, jobs = [], []
    pairs = [(robot, entry) for robot in campaign.robots for entry in robot.logs]
    keys = _keys(store, [(r, e) for r, e in pairs if not (e.refused or e.time_problem)])
    for robot, entry in pairs:
        row = {"robot": robot.id, "log": entry.name, "time": entry.time.isoformat() if entry.time else None,
               "task": robot.task.kind, "model": robot.model_digest}
        problem = entry.refused or entry.time_problem  # a refused log is not even hashed
        if problem:
            rows.append({**row, "key": None, "status": "error", "error": f"{entry.name}: {problem}"})
            continue
        key = keys[id(entry)]
        if isinstance(key, OSError):  # unreadable log: a row, not a stopped campaign
            rows.append({**row, "key": None, "status": "error", "error": one_line(f"{entry.name}: {key.strerror}")})
            continue
        rows.append({**row, "key": key})
        jobs.append(Job(key, robot.id, entry.name, str(entry.path), robot.model_source, robot.model_text,
                        robot.model_digest, robot.task, None if robot.experiment is None else str(robot.experiment),
                        robot.time_column, robot.chain))
    return rows, jobs


def _keys(store: Store, pairs: Sequence[tuple[Any, Any]]) -> dict[int, str | OSError]:
    """The cache key of each (robot, log), or the OSError reading it, by ``id`` of the log; the logs hashed by
    threads, one per processor (SHA-256 lets go of the GIL: a campaign's first run reads every log's bytes before
    its tasks start, 80 MB for 36 logs of 100 s)."""
    from concurrent.futures import ThreadPoolExecutor

    def key(pair: tuple[Any, Any]) -> str | OSError:
        try:
            return job_key(store, *pair)
        except OSError as error:
            return error

    with ThreadPoolExecutor(max_workers=max(1, min(os.cpu_count() or 1, len(pairs)))) as pool:
        return {id(entry): found for (_, entry), found in zip(pairs, pool.map(key, pairs))}


def run(campaign: Campaign, out: str | os.PathLike, *, scheduler: str | None = None, workers: int | None = None,
        figures: bool = True, connect_timeout: float = CONNECT_TIMEOUT, html: bool = False) -> Outcome:
    """Run ``campaign`` and write its results into ``out`` (module docstring).

    Nothing is written before the cluster is reached: a scheduler address that is refused leaves ``out`` as
    it was. ``connect_timeout`` bounds the wait for the scheduler at ``scheduler`` (s). ``html``: report.html and
    a page per robot too (:mod:`symbolic.fleet.html_report`; needs plotly, checked before the work)."""
    from symbolic.export import write_files
    from symbolic.fleet import report

    if scheduler:
        scheduler = check_scheduler(scheduler)
    if html:
        from symbolic.htmlpage import require

        require()
    store = Store(out)
    rows, jobs = plan(campaign, store)
    results: dict[str, dict[str, Any]] = {}
    for job in jobs:
        kept = store.get(job.key)
        if kept is not None:
            results[job.key] = kept
    todo = list({job.key: job for job in jobs if job.key not in results}.values())  # one task per distinct content
    cached = len(jobs) - sum(1 for job in jobs if job.key not in results)
    log.info("campaign %s: %d logs of %d robots, %d from the cache, %d to compute", campaign.name, len(rows),
             len(campaign.robots), cached, len(jobs) - cached)
    on_cluster = bool(todo) and (workers != 0 or bool(scheduler))
    importing = _import_ahead(figures) if on_cluster else None
    if todo:
        results.update(execute(todo, store, scheduler=scheduler, workers=workers, connect_timeout=connect_timeout))
    if importing is not None:
        importing.join()
    store.save_digests()
    rows = assemble(rows, results)
    found_series = series_of(rows, 0.0)
    tested = drifts(found_series, campaign.analysis)
    models = {r.id: r.model_digest for r in campaign.robots}
    different = outliers(found_series, tested, models, campaign.analysis)
    misfits = judge_bursts(rows, campaign)
    outcome = Outcome(campaign, tuple(rows), tuple(tested), tuple(different), len(jobs) - cached, cached,
                      misfits=tuple(misfits))
    files, notes = report.render(outcome, figures=figures, html=html)
    files["results.csv"] = table(rows).encode("utf-8")
    written = write_files(files, out)
    return dataclasses.replace(outcome, files=tuple(written), notes=tuple(notes))


def _import_ahead(figures: bool) -> threading.Thread:
    """A thread importing, while the workers compute the logs (the caller waits for their results), the modules
    the analysis and the report import when they first need them: scipy.special (the drift and siblings' tests)
    and, with ``figures``, Matplotlib. A fresh process, as ``symbolic campaign`` is, spent 0.14 s and 0.3 s on
    them after the last task, with the workers idle. Imports only: the report chooses Matplotlib's backend
    (:func:`symbolic.plotting.figure_class`, in the caller's thread) and says when Matplotlib is missing, as
    before."""

    def load() -> None:
        with contextlib.suppress(Exception):  # a failure is met again, and reported, where the module is used
            import scipy.special  # noqa: F401
        if figures:
            with contextlib.suppress(Exception):
                import matplotlib.backends.backend_agg  # noqa: F401
                import matplotlib.figure  # noqa: F401

    thread = threading.Thread(target=load, name="symbolic: imports ahead", daemon=True)
    thread.start()
    return thread


def judge_bursts(rows: list[dict[str, Any]], campaign: Campaign) -> list[dict[str, Any]]:
    """Each row's events as its siblings judge them (:mod:`symbolic.fleet.siblings`), in place, its bursts and
    profile then dropped; the systematic misfits, each named by its model."""
    from symbolic.fleet.siblings import judge

    robots = {r.id: (r.model_digest, r.task.events) for r in campaign.robots}
    judged, misfits = judge(rows, robots, campaign.analysis.alpha)
    for row, events in zip(rows, judged):
        if events is not None:
            row["events"] = events
        row.pop("bursts", None)
        row.pop("profile", None)
    names = {r.id: r.robot.name for r in campaign.robots}
    return [{"model": names[m["robots"][0]], **m} for m in misfits]


def assemble(rows: Sequence[dict[str, Any]], results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows with their results, the time as days since the campaign's first log, in robot, time, log order."""
    out = []
    for row in rows:
        result = results.get(row.get("key")) if row.get("key") else None
        if result is not None:
            row = {**row, **{k: v for k, v in result.items() if k not in ("key", "stamp", "cacheable", "time")},
                   "time": row["time"] or result.get("time")}
        out.append(row)
    moments = [dt.datetime.fromisoformat(r["time"]) for r in out if r.get("time")]
    origin = min(moments) if moments else None
    for row in out:
        row["days"] = (dt.datetime.fromisoformat(row["time"]) - origin).total_seconds() / 86400.0 \
            if row.get("time") and origin is not None else None
    order = {}
    for row in out:
        order.setdefault(row["robot"], len(order))
    out.sort(key=lambda r: (order[r["robot"]], r["days"] is None, r["days"] or 0.0, r["log"]))
    return out


def execute(jobs: Sequence[Job], store: Store, *, scheduler: str | None = None, workers: int | None = None,
            connect_timeout: float = CONNECT_TIMEOUT) -> dict[str, dict[str, Any]]:
    """Run ``jobs`` on Dask (module docstring), or one at a time in this process when ``workers`` is 0 (no
    Dask needed: for debugging, and the baseline of bench/fleet.py); every result is kept in ``store`` as it
    arrives, the logs' digests once the cluster is reached. The largest logs go first, so that no long task
    starts last and leaves the other workers idle."""
    jobs = sorted(jobs, key=_size, reverse=True)
    results: dict[str, dict[str, Any]] = {}
    progress = _Progress(len(jobs))

    def keep(job: Job, result: dict[str, Any]) -> None:
        if result.get("cacheable") and result.get("stamp") == stamp():
            store.put(job.key, result)
        results[job.key] = result
        progress.step(result["status"] != "ok")

    if workers == 0 and not scheduler:
        store.save_digests()
        for job in jobs:
            keep(job, run_log(job))
    else:
        _on_cluster(jobs, keep, scheduler, workers, connect_timeout, reached=store.save_digests)
    progress.done()
    return results


def _on_cluster(jobs: Sequence[Job], keep, scheduler: str | None, workers: int | None,
                connect_timeout: float = CONNECT_TIMEOUT, reached=lambda: None) -> None:
    """The jobs as Dask tasks of one or more logs each (:func:`batches`); ``reached()`` once the cluster is
    there, ``keep(job, result)`` for each log as its task's results arrive."""
    try:
        from dask.distributed import as_completed
    except ImportError:
        raise ClusterError(INSTALL) from None
    with _client(scheduler, workers, len(jobs), connect_timeout) as client:
        reached()
        groups = batches(jobs, max(1, len(client.scheduler_info()["workers"])))
        keys = [f"symbolic-logs-{hashlib.sha256(' '.join(j.key for j in g).encode()).hexdigest()}" for g in groups]
        futures = client.map(run_batch, groups, key=keys, pure=False)
        by_key = {future.key: group for future, group in zip(futures, groups)}
        pending = as_completed(futures)
        del futures  # as_completed holds each until it is taken and released: results do not pile up on the cluster
        for future in pending:
            group = by_key.pop(future.key)
            results = _results(future, group)
            future.release()
            for job, result in zip(group, results):
                keep(job, result)


def batches(jobs: Sequence[Job], workers: int) -> list[list[Job]]:
    """The jobs, largest first, cut into Dask tasks by guided self-scheduling on the logs' bytes.

    Each task takes ``1/(BATCHING · workers)`` of the bytes not yet given to a task, at least one log and at
    most :data:`MOST_PER_TASK`: a campaign of many short logs is a few tasks per worker at first (the scheduler's
    round trip, the client's and scheduler's CPU time per task paid once for several logs:
    bench/results/fleet.md), and single logs at the end, so that the workers finish together. A log's bytes
    stand for its work (the logs of a campaign share their task and, mostly, their format).

    Parameters
    ----------
    jobs
        The logs to compute.
    workers
        The cluster's workers.

    Returns
    -------
    list of list of Job
        The tasks, in the order they are submitted (the largest first).

    >>> from symbolic.fleet.tasks import Job
    >>> [len(b) for b in batches([Job(str(k), "r", "x", "/nonexistent", "", "", "", None) for k in range(36)], 2)]
    [9, 6, 5, 4, 3, 2, 1, 1, 1, 1, 1, 1, 1]
    """
    ordered = sorted(jobs, key=_size, reverse=True)
    sizes = [max(_size(job), 1) for job in ordered]
    left = float(sum(sizes))
    out: list[list[Job]] = []
    k = 0
    while k < len(ordered):
        share = left / (BATCHING * workers)
        group, taken = [ordered[k]], sizes[k]
        k += 1
        while k < len(ordered) and len(group) < MOST_PER_TASK and taken + sizes[k] <= share:
            group.append(ordered[k])
            taken += sizes[k]
            k += 1
        left -= taken
        out.append(group)
    return out


def _size(job: Job) -> int:
    """Bytes of the job's log (0 when it cannot be read: its task reports why)."""
    try:
        return os.stat(job.path).st_size
    except (OSError, ValueError):
        return 0


def _results(future, group: Sequence[Job]) -> list[dict[str, Any]]:
    """The task's result of each log, or an error row for each when the cluster lost the task (a worker died,
    a task was cancelled)."""
    try:
        results = future.result()
    except Exception as error:  # noqa: BLE001 - the cluster's failure, not the logs': rows, not cached
        return [{"key": job.key, "status": "error", "cacheable": False,
                 "error": one_line(f"{job.log}: the cluster could not run this log: {type(error).__name__}: {error}")}
                for job in group]
    return [_checked(result, job) for result, job in zip(results, group)]


def _checked(result: dict[str, Any], job: Job) -> dict[str, Any]:
    """``result``, or an error row when the worker runs another symbolic than the client (another stamp)."""
    if result.get("stamp") != stamp():
        theirs = result.get("stamp", {})
        return {**result, "status": "error", "cacheable": False,
                "error": f"{job.log}: the worker runs symbolic {theirs.get('symbolic')} (sources "
                         f"{theirs.get('sources')}), this client {stamp()['symbolic']} ({stamp()['sources']}): "
                         "install the same version on both"}
    return result


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int | None, tasks: int, connect_timeout: float = CONNECT_TIMEOUT):
    """A Dask client of the cluster at ``scheduler``, or of a local cluster of worker processes (closed after).
    Interrupted (Ctrl-C), it closes the cluster without a word from Dask: the command says "interrupted"."""
    from dask.distributed import Client

    if scheduler:
        _reach(scheduler, connect_timeout)
        try:
            client = Client(scheduler, timeout="30s")
        except (OSError, TimeoutError) as error:
            raise ClusterError(f"--scheduler {scheduler}: cannot connect: {one_line(str(error))}") from None
        try:
            try:
                client.wait_for_workers(workers or 1, timeout=WAIT_FOR_WORKERS)
            except TimeoutError:
                raise ClusterError(f"--scheduler {scheduler}: fewer than {workers or 1} worker(s) after "
                                   f"{WAIT_FOR_WORKERS:g} s (start them with: dask worker {scheduler})") from None
            log.info("campaign: on the cluster at %s (%d workers)", scheduler, len(client.scheduler_info()["workers"]))
            yield client
        except KeyboardInterrupt:
            _silence_dask()
            raise
        finally:
            client.close()
        return
    count = workers or max(1, min(os.cpu_count() or 1, tasks))
    log.info("campaign: starting a local cluster of %d worker process(es)", count)
    cluster = None
    try:
        try:
            with _sigint_deferred():
                cluster = local_cluster(count)
        except OSError as error:
            raise ClusterError(f"cannot start a local Dask cluster: {one_line(str(error))}") from None
        with Client(cluster) as client:
            yield client
    except KeyboardInterrupt:
        _silence_dask()
        raise
    finally:
        if cluster is not None:
            cluster.close()


def check_scheduler(address: str) -> str:
    """``address`` when a campaign can connect to it, ``[SCHEME://]HOST:PORT`` with a scheme of :data:`SCHEMES`
    (without one: tcp), else :class:`ClusterError` naming what is allowed (Dask raises a ValueError of its own)."""
    allowed = "expected tcp://HOST:PORT (or tls://, ws://, wss://; HOST:PORT alone is tcp), e.g. tcp://10.0.0.5:8786"
    found = ADDRESS.fullmatch(address.strip())
    if found is None:
        raise ClusterError(f"--scheduler {shorten(address)}: not an address: {allowed}")
    if found["scheme"] is not None and found["scheme"] not in SCHEMES:
        raise ClusterError(f"--scheduler {address}: unknown scheme {found['scheme']!r}: {allowed}")
    if found["port"] is None or not 0 < int(found["port"]) < 65536:
        what = "no port" if found["port"] is None else f"port {found['port']} out of range (1-65535)"
        raise ClusterError(f"--scheduler {address}: {what}: {allowed}")
    return address.strip()


def _reach(address: str, seconds: float) -> None:
    """Connect to the scheduler at ``address`` and complete Dask's handshake within ``seconds``, else
    :class:`ClusterError`. Dask bounds the connection but not the handshake after it: a port that accepts
    connections and never answers would hold the client for ever."""
    from distributed.comm import connect
    from distributed.security import Security

    async def handshake() -> None:
        arguments = Security().get_connection_args("client")
        comm = await asyncio.wait_for(connect(address, timeout=seconds, **arguments), seconds)
        await comm.close()

    failed: list[BaseException] = []

    def attempt() -> None:  # a thread and an event loop of its own: the caller may be inside one (a notebook)
        try:
            asyncio.run(handshake())
        except BaseException as error:  # noqa: BLE001 - reported below, in the caller's thread
            failed.append(error)

    thread = threading.Thread(target=attempt, name="symbolic: reach the scheduler", daemon=True)
    thread.start()
    thread.join(seconds + 5.0)
    error = failed[0] if failed else None
    if thread.is_alive() or isinstance(error, TimeoutError):
        raise ClusterError(f"--scheduler {address}: no Dask scheduler answered within {seconds:g} s (is `dask "
                           "scheduler` running there, on that port?)")
    if isinstance(error, TypeError) and address.startswith(("tls://", "wss://")):  # Dask's words: no ssl_context
        raise ClusterError(f"--scheduler {address}: a TLS address needs Dask's TLS settings (distributed.comm.tls: "
                           "ca-file, client.cert, client.key in the Dask configuration)")
    if isinstance(error, OSError):
        raise ClusterError(f"--scheduler {address}: cannot connect: {one_line(str(error))}")
    if error is not None:
        raise error


@contextlib.contextmanager
def _sigint_deferred():
    """SIGINT blocked in this thread while the local cluster starts: the threads and the worker processes
    started meanwhile inherit the mask (across exec too), so that a Ctrl-C, which the terminal sends to every
    process of the group, reaches this process alone, which closes the cluster, instead of every worker
    printing its own traceback. A Ctrl-C meanwhile is delivered when the cluster has started.

    The kernel may still hand the signal to a thread started before (one that does not block it), and Python then
    raises KeyboardInterrupt in this thread wherever it is, inside Dask's start, which can swallow it (a campaign
    interrupted so ran to the end and exited 0, on a loaded machine): meanwhile Python's handler only records it,
    and it is raised here once the cluster has started."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()  # started later, it would unblock SIGINT in the thread that starts it
    pressed: list[int] = []
    handler = signal.signal(signal.SIGINT, lambda number, frame: pressed.append(number))
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)
        signal.signal(signal.SIGINT, handler)
        if pressed:
            raise KeyboardInterrupt


def _silence_dask() -> None:
    """Nothing more from Dask in this process after a Ctrl-C: its loggers off while the cluster closes."""
    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def local_cluster(workers: int):
    """A local Dask cluster of ``workers`` processes of one thread each, without a dashboard.

    Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536`` (to hand freed memory back to the
    system at once); that also turns off glibc's adaptive mmap threshold, so every array above 128 KB is a
    fresh mapping whose pages are faulted in again: on a diagnosis of a 120 s log it cost 70 % more CPU time
    (24 times the page faults; bench/results/fleet.md). The workers here keep the other settings (one BLAS
    thread each) and glibc's default; memory stays bounded (1 000 logs, bench/results/fleet.md). Dask's
    statistical profiler (a thread sampling every worker's stack each 10 ms, for the dashboard, which this
    cluster does not serve) is off: it cost about 3 % of a worker's CPU time on diagnoses. So are the
    scheduler's work stealing (its workers are equal and the scheduler hands out a task as a worker's thread
    frees: there is nothing to steal), and the event loops' 20 ms tick and 0.5 s system monitor run every 1 s
    and 5 s (they measure for the dashboard and for warnings about a blocked loop, which a campaign does not
    read): the client, which hosts the scheduler, spent 0.18 s of CPU instead of 0.75 s beside 24 diagnoses.
    The workers log nothing below CRITICAL: a task's failure comes back as its row's error, and what they would
    say as the cluster closes after a Ctrl-C (a heartbeat to a scheduler gone) is noise."""
    import dask
    from dask.distributed import LocalCluster

    for name in ("distributed", "tornado"):  # Dask's own lines (ports, plugins) are not the campaign's progress
        logging.getLogger(name).setLevel(logging.ERROR)
    environment = {k: v for k, v in dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
                   if k != "MALLOC_TRIM_THRESHOLD_"}
    settings = {"distributed.nanny.pre-spawn-environ": environment, "distributed.worker.profile.enabled": False,
                "distributed.scheduler.work-stealing": False, "distributed.admin.tick.interval": "1s",
                "distributed.admin.tick.limit": "10s", "distributed.admin.system-monitor.interval": "5s"}
    with dask.config.set(settings), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "port 8787 is in use": the scheduler's HTTP port, unused here
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, silence_logs=logging.CRITICAL,
                            dashboard_address=None, worker_dashboard_address=None)


class _Progress:
    """``symbolic: campaign: 12/30 logs (1 error), 4.1 s`` on the logger, at most every :data:`PROGRESS_EVERY` s."""

    def __init__(self, total: int) -> None:
        self.total, self.finished, self.failed = total, 0, 0
        self.start = self.last = time.perf_counter()

    def step(self, failed: bool) -> None:
        self.finished += 1
        self.failed += failed
        now = time.perf_counter()
        if now - self.last >= PROGRESS_EVERY and self.finished < self.total:
            self.last = now
            self._say()

    def done(self) -> None:
        self._say()

    def _say(self) -> None:
        errors = f" ({self.failed} error{'s' if self.failed != 1 else ''})" if self.failed else ""
        log.info("campaign: %d/%d logs computed%s, %.1f s", self.finished, self.total, errors,
                 time.perf_counter() - self.start)


def available() -> bool:
    """Whether ``dask.distributed`` can be imported (without importing it)."""
    import importlib.util

    return importlib.util.find_spec("dask") is not None and importlib.util.find_spec("distributed") is not None
