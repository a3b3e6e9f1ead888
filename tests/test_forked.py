"""The search's round split between this process and a forked copy (symbolic.workflow.forked): the same
results as in one process, whatever happens to the child."""

from __future__ import annotations

import json
import multiprocessing
import os
import sys
import warnings
from pathlib import Path

import pytest

import models
import symbolic
import workflow_cases as cases
from symbolic.workflow import SearchSettings, diagnose
from symbolic.workflow import forked

needs_fork = pytest.mark.skipif(forked.usable_processes() < 2, reason="forking needs Linux and two CPUs or more")


def tagged(items):
    return [(x, x * x, os.getpid()) for x in items]


@needs_fork
def test_the_second_half_is_computed_in_another_process() -> None:
    mine, theirs = forked.in_two(tagged, [1, 2], [3, 4, 5])
    assert [(x, y) for x, y, _ in mine] == [(1, 1), (2, 4)] and [(x, y) for x, y, _ in theirs] == [(3, 9), (4, 16), (5, 25)]
    assert {pid for *_, pid in mine} == {os.getpid()}
    assert len({pid for *_, pid in theirs}) == 1 and theirs[0][2] != os.getpid()


@needs_fork
def test_interleaved_alternates_the_items_and_keeps_their_order() -> None:
    """Items 0, 2, 4 here and 1, 3 in the child; the results in the items' order, each half's extra value apart."""
    out, (here, there) = forked.interleaved(lambda part: (tagged(part), os.getpid()), [1, 2, 3, 4, 5])
    assert [(x, y) for x, y, _ in out] == [(1, 1), (2, 4), (3, 9), (4, 16), (5, 25)]
    assert {pid for *_, pid in out[0::2]} == {here} == {os.getpid()} and {pid for *_, pid in out[1::2]} == {there} != {here}


def tagged_with_extra(items):
    return tagged(items), os.getpid()


def test_an_empty_second_half_forks_nothing() -> None:
    assert forked.in_two(tagged, [7], []) == ([(7, 49, os.getpid())], [])


def failing_there(items):
    if os.getpid() != PARENT:
        raise RuntimeError("the child fails")
    return [x + 1 for x in items]


def unpicklable_there(items):
    if os.getpid() != PARENT:
        return [lambda: x for x in items]  # a result that cannot be sent back
    return [x + 1 for x in items]


def dying_there(items):
    if os.getpid() != PARENT:
        os._exit(3)  # killed, out of memory: nothing is sent
    return [x + 1 for x in items]


PARENT = os.getpid()


@needs_fork
@pytest.mark.parametrize("work", [failing_there, unpicklable_there, dying_there])
def test_what_the_child_could_not_do_is_done_here(work) -> None:
    assert forked.in_two(work, [1], [2, 3]) == ([2], [3, 4])


@needs_fork
def test_shared_items_are_taken_as_they_come_and_returned_in_order() -> None:
    """Each process takes the next item left: the process that takes the costly first item (here, one that waits
    until the last is taken) leaves all the others to the other process; the results in the items' order, each
    process's extra value apart."""
    last = multiprocessing.get_context("fork").Event()

    def first_waits(items):
        out = []
        for x in items:
            if x == 0:
                last.wait(60)
            out.append((x, x * x, os.getpid()))
            if x == 7:
                last.set()
        return out, os.getpid()

    out, (here, there) = forked.shared(first_waits, list(range(8)))
    assert [(x, y) for x, y, _ in out] == [(x, x * x) for x in range(8)]
    assert here == os.getpid() and there != here
    assert {pid for *_, pid in out[1:]} == {here, there} - {out[0][2]}


@needs_fork
@pytest.mark.parametrize("work", [failing_there, unpicklable_there, dying_there])
def test_shared_items_the_child_could_not_do_are_done_here(work) -> None:
    out, _ = forked.shared(lambda items: (work(list(items)), None), [1, 2, 3, 4])
    assert out == [2, 3, 4, 5]


def always_failing(items):
    raise ValueError(f"bad items {list(items)}")


@needs_fork
def test_an_error_of_the_work_itself_is_raised_here() -> None:
    with pytest.raises(ValueError, match="bad items"):
        forked.in_two(always_failing, [1], [2])


def _report(queue) -> None:
    queue.put(forked.usable_processes())


def test_no_fork_inside_a_daemonic_process_nor_off_linux() -> None:
    context = multiprocessing.get_context("fork" if sys.platform == "linux" else "spawn")
    queue = context.Queue()
    process = context.Process(target=_report, args=(queue,), daemon=True)
    process.start()
    assert queue.get(timeout=60) == 1  # a Dask worker is such a process
    process.join()
    if sys.platform != "linux":
        assert forked.usable_processes() == 1


@pytest.mark.parametrize("value", [0, 3, 1.5, True, "2"])
def test_processes_setting_is_checked(value) -> None:
    with pytest.raises(ValueError, match="SearchSettings.processes: expected None"):
        SearchSettings(processes=value)


@needs_fork
def test_a_diagnosis_on_two_processes_equals_the_one_in_one(tmp_path: Path) -> None:
    """Rounds split between two processes (the child's treated columns joining the store for the next round)
    give the same candidates, figures and written files as one process, to the last bit."""
    model, truth = models.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), models.axis()
    data, path = cases.measurements(truth, 1, 0.01), cases.model_file(tmp_path, model)
    runs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        for processes in (1, 2):
            runs[processes] = diagnose(path, data, out=tmp_path / str(processes), figures=False,
                                       search=SearchSettings(processes=processes))
    one, two = (json.dumps(runs[p].to_dict(), sort_keys=True, default=str).replace(str(tmp_path / str(p)), "OUT")
                for p in (1, 2))
    assert one == two
    assert [f.effect for f in runs[2].found] == ["coulomb"]
    assert len(runs[2].search.rounds) >= 2  # the second round used the columns the child had treated
    for name in ("report.md", "axis_patched.toml"):
        assert (tmp_path / "1" / name).read_bytes() == (tmp_path / "2" / name).read_bytes(), name
