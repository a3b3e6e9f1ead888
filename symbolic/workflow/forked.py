"""Half of a loop in a forked copy of this process: the search's round on two cores (issue 23 §2).

A round of the catalogue search evaluates some hundred independent candidates, most of whose time is NumPy
code that holds the GIL between array operations: threads gain little, a second process nearly halves it.
A *forked* child starts with the whole search in memory (the data, the current model's factors, the columns
already treated), so nothing is sent to it; it evaluates its share and sends back only the results.

Forking is used only where it is safe and useful: Linux (``fork`` is the platform's own start method; macOS
and Windows spawn, which would have to send the search), at least two CPUs available to this process, and not
inside a daemonic process (a Dask worker: its campaign already uses the cores, and daemons may not have
children). Both processes then use one BLAS thread each. Anywhere else, and when the child fails for any
reason, the work is done here: the results are the same either way, only the time differs.

:func:`interleaved` gives each process every other item; :func:`shared` lets each take the next item left, so
that the two finish together however the costs are spread (the search's rounds).
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing
import os
import sys
import traceback
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any, TypeVar

from symbolic.numeric.blas import one_blas_thread

T = TypeVar("T")
R = TypeVar("R")
X = TypeVar("X")


def usable_processes() -> int:
    """Processes a forked split may use here: 2 on Linux with two CPUs or more outside daemonic processes, else 1."""
    if sys.platform != "linux" or multiprocessing.current_process().daemon:
        return 1
    return 2 if len(os.sched_getaffinity(0)) >= 2 else 1


def in_two(work: Callable[[Sequence[T]], R], here: Sequence[T], there: Sequence[T]) -> tuple[R, R]:
    """``(work(here), work(there))``, the second computed in a forked child at the same time.

    ``work`` must return something picklable. Should the child fail (it cannot be started, it raises, it dies,
    its result cannot be pickled), ``work(there)`` is computed here afterwards: an error of ``work`` itself is
    then raised from this process, as without the child. A KeyboardInterrupt stops the child too.
    """
    if not there:
        return work(here), work(there)
    with one_blas_thread(), _frozen():  # two processes on two cores: BLAS threads of both would contend and spin
        return _split(work, here, there)


@contextlib.contextmanager
def _frozen() -> Iterator[None]:
    """The objects of this process kept out of the garbage collector's passes while a forked child lives
    (:func:`gc.freeze`): a pass writes to every object it visits, and in a forked child each page written is
    copied; the collector of either process would copy the whole inherited heap (a diagnosis of the Panda log:
    a quarter of the children's page copies, 0.2 s CPU). Left as it was when something else froze them."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def interleaved(work: Callable[[Sequence[T]], tuple[list[R], X]], items: Sequence[T]) -> tuple[list[R], tuple[X, X]]:
    """``work`` over ``items`` shared alternately with a forked child (:func:`in_two`): items 0, 2, 4, … here and
    1, 3, 5, … there, so that a run of costly neighbours (one effect on every coordinate) is split too. ``work``
    returns its results, one per item, and one more value; returns the results in the items' order and the two
    more values (here's, there's)."""
    (mine, extra_here), (theirs, extra_there) = in_two(work, items[0::2], items[1::2])
    out: list[R] = [None] * len(items)  # type: ignore[list-item]
    out[0::2], out[1::2] = mine, theirs
    return out, (extra_here, extra_there)


def shared(work: Callable[[Iterable[T]], tuple[list[R], X]], items: Sequence[T]) -> tuple[list[R], tuple[X, X]]:
    """``work`` over ``items`` shared with a forked child (:func:`in_two`) as they come: each process takes the next
    item neither has taken (a counter in shared memory) until none is left, so that neither waits idle while the
    other works through a few costly items (which items cost most depends on the data: put those expected to first).
    ``work`` iterates over the items it is given once and returns its results, one per item in that order, and one
    more value. Returns the results in the items' order and the two more values (here's, there's); items the child
    took but could not return (it failed, or died) are computed here."""
    counter = multiprocessing.get_context("fork").Value("q", 0)

    def claimed(_: Sequence[int]) -> tuple[list[int], list[R], X]:
        taken: list[int] = []
        results, extra = work(_claims(items, counter, taken))
        return taken, results, extra

    (mine, done_here, extra_here), (theirs, done_there, extra_there) = in_two(claimed, [0], [1])
    out: dict[int, R] = dict(zip(mine, done_here)) | dict(zip(theirs, done_there))
    missing = [k for k in range(len(items)) if k not in out]
    if missing:  # taken by a child that did not return: its work(there) ran here after the counter was spent
        redone, _ = work([items[k] for k in missing])
        out |= dict(zip(missing, redone))
    return [out[k] for k in range(len(items))], (extra_here, extra_there)


def _claims(items: Sequence[T], counter: Any, taken: list[int]) -> Iterator[T]:
    """The items not taken yet by either process, one at a time, each index recorded in ``taken``."""
    while True:
        with counter.get_lock():
            k = counter.value
            counter.value = k + 1
        if k >= len(items):
            return
        taken.append(k)
        yield items[k]


def _split(work: Callable[[Sequence[T]], R], here: Sequence[T], there: Sequence[T]) -> tuple[R, R]:
    context = multiprocessing.get_context("fork")
    reader, writer = context.Pipe(duplex=False)
    try:
        child = context.Process(target=_child, args=(work, there, writer), daemon=True)
        child.start()
    except OSError:  # no more processes or memory for one: the same work, one after the other
        reader.close()
        writer.close()
        return work(here), work(there)
    writer.close()
    try:
        mine = work(here)
        try:
            status, theirs = reader.recv()
        except (EOFError, OSError):  # the child died (killed, out of memory) before sending
            status, theirs = "failed", None
        if status != "done":
            theirs = work(there)
        return mine, theirs
    finally:
        reader.close()
        if child.is_alive():
            child.kill()
        child.join()


def _child(work: Callable[[Sequence[Any]], Any], items: Sequence[Any], writer: Any) -> None:
    try:
        result = ("done", work(items))
    except BaseException:  # noqa: BLE001 - reported to the parent, which redoes the work and raises it there
        result = ("failed", traceback.format_exc())
    try:
        writer.send(result)
    except Exception:  # noqa: BLE001 - e.g. an unpicklable result: the parent redoes the work
        writer.send(("failed", traceback.format_exc()))
    finally:
        writer.close()
