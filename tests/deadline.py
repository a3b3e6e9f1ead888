"""A time bound for one call in a test: a hang fails the test instead of stalling the suite."""

from __future__ import annotations

import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager


class TookTooLong(BaseException):
    """Raised by :func:`within` (a BaseException, so that no ``except Exception`` in the code under
    test can swallow it)."""


@contextmanager
def within(seconds: float, what: str = "") -> Iterator[None]:
    """Run the body under a SIGALRM timer of ``seconds`` and check the elapsed time afterwards.

    The timer interrupts Python code; a single long C call (a huge integer power) finishes before
    the signal is handled, so the elapsed time is checked as well.
    """
    def expire(signum: int, frame: object) -> None:
        raise TookTooLong(f"took more than {seconds} s: {what[:200]!r}")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    start = time.perf_counter()
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    elapsed = time.perf_counter() - start
    if elapsed > seconds:
        raise TookTooLong(f"took {elapsed:.1f} s (more than {seconds} s): {what[:200]!r}")
