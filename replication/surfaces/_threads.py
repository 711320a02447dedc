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
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["frozen", "one_thread", "pool_threads", "release", "run", "threads"]

_idle: list[_Helper] = []  # pool threads waiting for work
_started = 0  # pool threads alive, idle or working for a run()
_lock = threading.Lock()
_one = False  # set in executor workers: their parallelism is the executor's


class _Helper:
    """One pool thread. It sleeps on a lock until :meth:`start` gives it a job and releases
    a second lock when the job is done: a :func:`run` of two short tasks costs about 22 us
    of hand-over, against 48 us through a ``concurrent.futures`` pool (the jet force's two
    pieces take about 0.85 ms). A daemon: an idle pool never holds up the interpreter's exit.

    The jobs given and finished are counted, so a wait cut short by Ctrl-C (before or after
    it took the "done" signal) is simply waited again: it returns once the counts agree.
    """

    def __init__(self) -> None:
        self._go = threading.Lock()
        self._go.acquire()
        self._done = threading.Lock()
        self._done.acquire()
        self._job: Callable[[], None] | None = None
        self.error: BaseException | None = None
        self._given = 0
        self._finished = 0
        self._thread = threading.Thread(target=self._loop, name="replication-kernels", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        while True:
            self._go.acquire()
            job, self._job = self._job, None
            if job is None:  # stop()
                return
            try:
                job()
            except BaseException as error:  # raised by the caller of run()
                self.error = error
            finally:
                self._finished += 1
                self._done.release()

    def start(self, job: Callable[[], None]) -> None:
        """Give the (idle) thread a job."""
        self._done.acquire(blocking=False)  # a "done" signal that an interrupted wait left
        self.error = None
        self._job = job
        self._given += 1  # no signal can be raised between this count and the release
        self._go.release()

    def wait(self) -> None:
        """Until the jobs given are done (at once if there are none)."""
        while self._finished < self._given:
            self._done.acquire()

    def stop(self) -> None:
        self._job = None
        self._go.release()
        self._thread.join()


def _forget_pool() -> None:
    """In a forked child: the parent's pool threads were not copied, so its pool is dropped."""
    global _idle, _started, _lock
    _idle, _started = [], 0
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
    that called :func:`one_thread`.

    In a process that has not imported numba (its ahead-of-time kernels,
    :mod:`replication._aot`, serve it), the count numba would start with, read without importing
    it: ``NUMBA_NUM_THREADS`` when set, else the CPUs this process may run on.
    """
    if _one:
        return 1
    get = getattr(sys.modules.get("numba"), "get_num_threads", None)  # None: numba not (yet) loaded
    return _numba_default() if get is None else int(get())


def _numba_default() -> int:
    """numba's default thread count (``numba.config.NUMBA_NUM_THREADS``), without importing numba."""
    text = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    if text.isdigit() and int(text) >= 1:
        return int(text)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # no affinity on this system (macOS, Windows)
        return max(1, os.cpu_count() or 1)


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
    global _idle, _started
    with _lock:
        idle, _idle = _idle, []
        _started -= len(idle)
    for helper in idle:
        helper.stop()


def pool_threads() -> int:
    """The pool threads alive in this process (idle or working)."""
    return _started


def _take(count: int) -> list[_Helper]:
    """Up to ``count`` idle pool threads, started as needed while the pool has fewer than
    ``threads() - 1``; fewer when other threads' runs hold them (those runs then share the
    cores with this one, and the results are the same whoever runs the tasks)."""
    global _started
    with _lock:
        taken = [_idle.pop() for _ in range(min(count, len(_idle)))]
        new = max(0, min(count - len(taken), threads() - 1 - _started))
        _started += new
    try:
        for _ in range(new):
            taken.append(_Helper())
            new -= 1
    except RuntimeError:  # the system will not start another thread: fewer run the tasks
        pass
    finally:
        if new:
            with _lock:
                _started -= new
    return taken


def _give_back(helpers: list[_Helper]) -> None:
    with _lock:
        _idle.extend(helpers)


def _compile_locks() -> list[Any]:
    """The reentrant locks a numba compile takes, of the modules loaded: llvmlite's, around
    every call into LLVM, and numba's compiler lock (private attributes: none when they move)."""
    ffi = sys.modules.get("llvmlite.binding.ffi")
    compiler = sys.modules.get("numba.core.compiler_lock")
    found = (
        getattr(getattr(getattr(ffi, "lib", None), "_lock", None), "_lock", None),
        getattr(getattr(compiler, "global_compiler_lock", None), "_lock", None),
    )
    return [lock for lock in found if callable(getattr(lock, "_is_owned", None))]


def _release_leaked_compile_locks() -> None:
    """Release the compile locks (:func:`_compile_locks`) if this thread holds them.

    Ctrl-C is raised wherever the main thread's Python code is, a compile's included; raised
    inside llvmlite's lock between its acquire and the ``with`` block (numba's event callbacks
    run there), or between the block and the release, it leaves the lock held by the main
    thread for good. A pool thread that then compiled a kernel waited for it forever, and the
    main thread waited for that pool thread: ``replication adt`` hung after Ctrl-C during a
    first, cold compile (1 of 16 tries). :func:`run` is never called inside a compile, so a
    compile lock its thread holds when it starts, or once a task of its own has failed, is
    such a leak.
    """
    for lock in _compile_locks():
        while lock._is_owned():
            lock.release()


def run(tasks: Sequence[Callable[[], Any]]) -> list[Any]:
    """Run the callables, this thread and ``threads() - 1`` pool threads taking them in order."""
    if len(tasks) < 2:
        return [task() for task in tasks]
    count = min(len(tasks), threads())
    if count < 2:
        return [task() for task in tasks]
    _release_leaked_compile_locks()  # an earlier interrupt's, or the pool threads could wait for it
    results: list[Any] = [None] * len(tasks)
    queue = iter(range(len(tasks)))  # next() on a range iterator is atomic: no lock to leave held
    stopped: list[bool] = []

    def work() -> None:
        while not stopped:
            k = next(queue, None)
            if k is None:
                return
            results[k] = tasks[k]()

    helpers = _take(count - 1)
    try:
        for helper in helpers:
            helper.start(work)
        work()
    except BaseException:
        _release_leaked_compile_locks()  # before waiting for pool threads that may compile
        raise
    finally:
        stopped.append(True)  # an interrupted or failed run starts no further task
        try:
            _wait_through_interrupts(helpers)
        finally:
            _give_back(helpers)
    for helper in helpers:
        if helper.error is not None:
            raise helper.error
    return results


def _wait_through_interrupts(helpers: Sequence[_Helper]) -> None:
    """Wait until the pool threads have finished their tasks, even through Ctrl-C.

    The tasks write into arrays that the caller frees when an exception (Ctrl-C) unwinds it:
    leaving while a compiled kernel still runs on another thread crashed the interpreter
    (a segmentation fault in 4 of 50 interrupted 2e6-point ``replication adt`` runs). A
    task is one block's kernel, seconds at most; a Ctrl-C during the wait is raised after it.
    """
    interrupted = False
    for helper in helpers:
        while True:
            try:
                helper.wait()
                break
            except KeyboardInterrupt:
                interrupted = True
    if interrupted:
        raise KeyboardInterrupt
