"""A small thread pool for the compiled kernels (they release the GIL while they run).

The number of threads is numba's (``numba.set_num_threads``, ``NUMBA_NUM_THREADS``), so one
setting governs every parallel kernel of the package. Work is always split into the same
pieces whatever the thread count, and each piece writes only its own output, so results
never depend on how many threads ran them. Executor workers run every kernel on one thread
(:func:`one_thread`). A forked child drops the pool it copied (its threads were not copied)
and starts its own when it needs one.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Any

import numpy as np

__all__ = ["frozen", "one_thread", "release", "run", "threads"]

_pool: ThreadPoolExecutor | None = None
_lock = threading.Lock()
_one = False  # set in executor workers: their parallelism is the executor's


def _forget_pool() -> None:
    """In a forked child: the parent's pool threads were not copied, so its pool is dropped."""
    global _pool, _lock
    _pool = None
    _lock = threading.Lock()  # it may have been held by another thread at the fork


if hasattr(os, "register_at_fork"):  # POSIX
    os.register_at_fork(after_in_child=_forget_pool)


def frozen(a: np.ndarray, dtype=None) -> np.ndarray:
    """``a`` as a C-contiguous, aligned, read-only array (a view when it already is one).

    numba compiles a separate version of a kernel for writable and read-only arrays (and for
    misaligned ones, which a buffer read at an odd offset gives); the package's kernels take
    their inputs read-only and aligned (a Surface's arrays are), so each keeps one compiled
    signature whoever calls it, and the ahead-of-time kernels (:mod:`replication._aot`) serve
    every call.
    """
    a = np.ascontiguousarray(a, dtype=dtype)
    if not a.flags.aligned:
        a = a.copy()
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def threads() -> int:
    """numba's thread count (the threading layer is started on first use); 1 in a process
    that called :func:`one_thread`."""
    if _one:
        return 1
    import numba

    return int(numba.get_num_threads())


def one_thread() -> None:
    """Run this process's kernels on its own thread from now on (an executor worker's setup).

    The GA's parallelism is one fitness evaluation per worker process (paper section 6); a
    worker that also split each evaluation across threads would only compete with the other
    workers for the cores.
    """
    global _one
    _one = True


def release() -> None:
    """Stop the pool's idle threads; the next parallel kernel starts them again.

    A process whose only thread is the main one can fork its worker processes (see
    :func:`replication.casestudy.interrupts.quiet_worker_context`), which start in
    milliseconds instead of a second each.
    """
    global _pool
    with _lock:
        pool, _pool = _pool, None
    if pool is not None:
        pool.shutdown(wait=True)


def run(tasks: Sequence[Callable[[], Any]]) -> list[Any]:
    """Run the callables, this thread and ``threads() - 1`` pool threads taking them in order."""
    if len(tasks) < 2:
        return [task() for task in tasks]
    count = min(len(tasks), threads())
    if count < 2:
        return [task() for task in tasks]
    global _pool
    with _lock:
        if _pool is None or _pool._max_workers < count - 1:
            _pool = ThreadPoolExecutor(max_workers=count - 1, thread_name_prefix="replication-kernels")
        pool = _pool
    results: list[Any] = [None] * len(tasks)
    queue = iter(range(len(tasks)))  # next() on a range iterator is atomic: no lock to leave held
    stopped: list[bool] = []

    def work() -> None:
        while not stopped:
            k = next(queue, None)
            if k is None:
                return
            results[k] = tasks[k]()

    helpers = [pool.submit(work) for _ in range(count - 1)]
    try:
        work()
    finally:
        stopped.append(True)  # an interrupted or failed run starts no further task
        _wait_through_interrupts(helpers)
    for helper in helpers:
        helper.result()
    return results


def _wait_through_interrupts(futures: Sequence[Any]) -> None:
    """Wait until the pool threads have finished their tasks, even through Ctrl-C.

    The tasks write into arrays that the caller frees when an exception (Ctrl-C) unwinds it:
    leaving while a compiled kernel still runs on another thread crashed the interpreter
    (a segmentation fault in 4 of 50 interrupted 2e6-point ``replication adt`` runs). A
    task is one block's kernel, seconds at most; a Ctrl-C during the wait is raised after it.
    """
    interrupted = False
    while True:
        try:
            wait(futures)
            break
        except KeyboardInterrupt:
            interrupted = True
    if interrupted:
        raise KeyboardInterrupt
