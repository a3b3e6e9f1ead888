"""How many threads BLAS may use: one, where a pool of threads costs more than it gives."""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable
from typing import ContextManager, TypeVar

F = TypeVar("F", bound=Callable)


def one_blas_thread() -> ContextManager[object]:
    """A context in which BLAS runs on one thread (threadpoolctl, where installed).

    For small matrices factored many times (the consistent fit factors matrices of about 100 × 70 hundreds of
    times: on a busy two-core machine an SVD of 113 × 70 took 35 ms with OpenBLAS's threads, 2.4 ms with one),
    and wherever this program runs two processes of its own on two cores (the catalogue search's forked round):
    threads of both would contend for the same cores, and OpenBLAS's waiting threads spin.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # without it the results are the same, only slower where BLAS threads contend
        return contextlib.nullcontext()
    return threadpool_limits(1, user_api="blas")


def on_one_blas_thread(function: F) -> F:
    """``function`` run within :func:`one_blas_thread` (a decorator).

    For work whose matrices are tall and thin (a diagnosis's stacked regressor, some 10⁴–10⁵ rows by 50 columns):
    OpenBLAS's threaded Householder QR of such a matrix took 3× the wall time of one thread on an idle two-core
    machine (140 000 × 50: 1.85 s against 0.56 s), and far more on a busy one, where its waiting threads spin.
    """
    @functools.wraps(function)
    def limited(*args, **kwargs):
        with one_blas_thread():
            return function(*args, **kwargs)

    return limited  # type: ignore[return-value]
