"""How many threads BLAS may use: one, where a pool of threads costs more than it gives."""

from __future__ import annotations

import contextlib
from typing import ContextManager


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
