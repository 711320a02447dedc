"""Ctrl-C during a GA run: stop between evaluations, never inside one.

Python delivers SIGINT by raising :class:`KeyboardInterrupt` at whatever bytecode runs next.
Inside a compiled (numba) kernel that turns into a ``SystemError`` ("returned a result with
an exception set"), which an evaluator that treats exceptions as failed evaluations would
record as a failure, and the run would go on. While an :class:`InterruptGuard` is active,
the first SIGINT only *requests* a stop; the GA checks the request between evaluations and
raises :class:`KeyboardInterrupt` there, so an evaluation is either complete or not done, and
the last checkpoint (a complete generation) stays the run's state. A second SIGINT raises at
once, for a user who does not want to wait for the current evaluation.
"""

from __future__ import annotations

import contextlib
import multiprocessing.context
import multiprocessing.resource_tracker
import os
import select
import signal
import sys
import threading
import time
from collections.abc import Iterator
from types import FrameType
from typing import Any

from replication.sigterm import Terminated, handler_installed, terminating

__all__ = [
    "end_with_parent",
    "InterruptGuard",
    "caused_by_interrupt",
    "exit_on_terminate",
    "ignore_interrupts",
    "quiet_spawn_context",
    "quiet_worker_context",
    "unrecorded_workers",
]


class InterruptGuard:
    """Context manager turning SIGINT into a stop request (see the module notes).

    The handler is installed only in the main thread and only over Python's default
    handler, so a guard inside a program with its own SIGINT handling changes nothing;
    :meth:`requested` is then always False and Ctrl-C behaves as before.
    """

    def __init__(self) -> None:
        self._requested = False
        self._previous: object = None
        self._installed = False

    def __enter__(self) -> InterruptGuard:
        if threading.current_thread() is threading.main_thread():
            current = signal.getsignal(signal.SIGINT)
            if current is signal.default_int_handler:
                self._previous = current
                signal.signal(signal.SIGINT, self._handle)
                self._installed = True
        return self

    def __exit__(self, *exc: object) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._previous)  # type: ignore[arg-type]
            self._installed = False

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self._requested:
            raise KeyboardInterrupt
        self._requested = True

    def requested(self) -> bool:
        """Whether Ctrl-C was pressed while the guard was active, or SIGTERM arrived (whose raise
        may have been lost, see :func:`replication.sigterm.terminating`)."""
        return self._requested or terminating()

    def check(self) -> None:
        """Raise :class:`~replication.sigterm.Terminated` after a SIGTERM, :class:`KeyboardInterrupt`
        if a stop was requested."""
        if terminating():
            raise Terminated
        if self._requested:
            raise KeyboardInterrupt


def caused_by_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` is, or was raised while handling, a :class:`KeyboardInterrupt`."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        if isinstance(current, KeyboardInterrupt):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False


@contextlib.contextmanager
def _starting_a_child() -> Iterator[None]:
    """SIGINT blocked in the calling thread while a child process starts, and SIGTERM too while
    the command takes it as an interrupt (:mod:`replication.sigterm`); the child inherits the block.

    Ctrl-C in a terminal signals every process of the foreground group, worker processes
    included. Workers started with SIGINT blocked never see it: the parent alone decides
    when to stop (between evaluations), and no worker prints a traceback or dies in the
    middle of an evaluation. A SIGINT that reaches the parent meanwhile stays pending and is
    delivered when the block ends. Without ``pthread_sigmask`` (Windows) nothing is blocked.

    A ``Terminated`` raised while a fork runs the parent's fork hooks (Python code: logging's
    lock release, say) is only reported there, and lost; and a forked child keeps the
    parent's handler until its initializer replaces it. Held, the signal reaches the parent
    after the start, and the child, which inherits the block, only once its initializer has
    set its own handler and unblocked it (:func:`replication.casestudy.evaluate.worker_initializer`).
    """
    signals = {signal.SIGINT, signal.SIGTERM} if handler_installed() else {signal.SIGINT}
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - POSIX only
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _served_queue(process: multiprocessing.process.BaseProcess) -> Any:
    """The call queue of the process pool whose worker ``process`` is to be (None for another
    process), read before ``start()``, which drops the target and its arguments."""
    from concurrent.futures import process as pools

    target, args = getattr(process, "_target", None), getattr(process, "_args", ())
    return args[0] if target is pools._process_worker and args else None


class _QuietSpawnProcess(multiprocessing.context.SpawnProcess):
    def start(self) -> None:
        # the resource tracker, which a spawned child needs, is started first: starting it
        # unblocks both signals for a moment, and the child started then would not have them held
        multiprocessing.resource_tracker.ensure_running()
        queue = _served_queue(self)
        with _starting_a_child():
            super().start()
            self.pool_queue = queue  # before a held signal is raised: see unrecorded_workers


class _QuietSpawnContext(multiprocessing.context.SpawnContext):
    Process = _QuietSpawnProcess


def quiet_spawn_context() -> multiprocessing.context.SpawnContext:
    """A "spawn" multiprocessing context whose processes start with SIGINT blocked."""
    return _QuietSpawnContext()


class _QuietForkProcess(multiprocessing.context.ForkProcess):
    def start(self) -> None:
        queue = _served_queue(self)
        with _starting_a_child():  # (multiprocessing flushes stdout and stderr before it forks)
            super().start()
            self.pool_queue = queue  # before a held signal is raised: see unrecorded_workers


def unrecorded_workers(pool: Any) -> list[multiprocessing.process.BaseProcess]:
    """The live worker processes of a process pool, started in this module's contexts, that the
    pool has not recorded in ``_processes``.

    A Ctrl-C or SIGTERM held while a worker forks is raised as its ``start()`` returns, before
    the pool records the worker in ``_processes``: ending the recorded workers left that one
    waiting for a call for good, and the interpreter's exit waiting for it (a hang after
    "interrupted"). Each worker knows the pool's call queue (``pool_queue``, set in ``start``).
    """
    queue = getattr(pool, "_call_queue", None)
    if queue is None:
        return []
    recorded = list((getattr(pool, "_processes", None) or {}).values())
    return [
        p
        for p in multiprocessing.active_children()
        if getattr(p, "pool_queue", None) is queue and all(p is not r for r in recorded)
    ]


class _QuietForkContext(multiprocessing.context.ForkContext):
    Process = _QuietForkProcess


def quiet_worker_context() -> multiprocessing.context.BaseContext:
    """The context for worker processes: "fork" where that is safe, else "spawn"; SIGINT blocked.

    A spawned worker starts a fresh interpreter, imports the package and loads the compiled
    kernels from numba's cache: about a second of a 2-core machine per worker and per pool
    (issue 15). A forked worker inherits all of that from the parent in milliseconds. Fork
    is used only on Linux and only while the calling process runs a single thread (a fork
    copies only the calling thread, so locks that other threads hold would stay locked in
    the child); :class:`concurrent.futures.ProcessPoolExecutor` starts all its workers
    before its own management thread when the start method is fork. Elsewhere, and with
    other threads running, workers are spawned.
    """
    if sys.platform.startswith("linux") and threading.active_count() == 1:
        return _QuietForkContext()
    return _QuietSpawnContext()


@contextlib.contextmanager
def sigint_ignored_by_children() -> Iterator[None]:
    """Ignore SIGINT process-wide while worker processes are started in other threads.

    A local dask cluster starts its worker processes from its own threads, which a
    thread-level block (:func:`_starting_a_child`) does not reach; an ignored SIGINT, however,
    stays ignored across ``exec``, and Python keeps it so in the child. The price: a Ctrl-C
    in the second or so the cluster takes to start is ignored (press it again). Only in the
    main thread (elsewhere nothing changes).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def exit_on_terminate() -> None:
    """Worker initializer: SIGTERM raises :class:`SystemExit`, so the worker unwinds, and then ends.

    Python's default for SIGTERM ends the process at once, skipping every ``finally``; a
    worker waiting for an SPH simulation's child process would leave that child running
    (it has a session of its own, see :mod:`.sph.process`). Raising instead runs the
    ``finally`` that kills the child. The parent terminates workers only to abandon work
    under way (a second Ctrl-C, :func:`.evaluate.executor`).

    A process pool's worker loop catches the exception of its task (it is the task's result)
    and takes the next one: the worker went on to queued work, or waited for more, until the
    parent killed it after its grace (5 s on every second Ctrl-C). Called from that loop (as a
    pool's initializer), this also makes the worker's next take from its queue of calls raise
    the same exit, so the worker ends as soon as its task has unwound, and starts no other.
    Only the first SIGTERM is taken: the parent kills a worker that has not ended in its grace.
    """
    calls = _pool_call_queue()

    def _exit(signum: int, frame: FrameType | None) -> None:
        # once: the pool's manager terminates the other workers again when one ends, and a
        # second exit raised inside the first one's finally would skip what is left of it
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        if calls is not None:

            def refuse(*args: object, **kwargs: object) -> None:
                raise SystemExit(128 + signum)

            calls.get = refuse  # this worker's own queue object: the next take ends the worker
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, _exit)


def _pool_call_queue() -> object | None:
    """The queue a ``concurrent.futures`` process-pool worker takes its calls from, when called
    (in its initializer) from that worker's loop; None elsewhere."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "_process_worker" and frame.f_globals.get("__name__") == (
            "concurrent.futures.process"
        ):
            calls = frame.f_locals.get("call_queue")
            return calls if callable(getattr(calls, "get", None)) else None
        frame = frame.f_back
    return None


def _exists(pid: int) -> bool:
    """Whether a process ``pid`` exists (a zombie counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - someone else's process
        return True
    return True


#: Seconds an orphaned worker has to unwind (kill its simulation) before it ends at once.
ORPHAN_GRACE = 5.0


def end_with_parent(parent: int) -> None:
    """Worker initializer: the worker gets SIGTERM when the process ``parent`` dies.

    A parent killed outright (SIGKILL, the OOM killer) cannot shut its pool down: its
    workers waited for work forever, and held what they inherited, such as the GA run
    directory's lock (so ``--resume`` was refused). A daemon thread waits for the parent's
    end (on a pidfd where the kernel has them, else by polling the parent pid twice a
    second) and then signals the worker's main thread, which unwinds
    (:func:`exit_on_terminate`).

    A worker still alive :data:`ORPHAN_GRACE` seconds later ends at once: its results have
    nowhere to go. The SystemExit can be lost: :mod:`concurrent.futures` catches every
    exception while a worker sends a result back (and so does a task that catches
    ``BaseException``), after which the worker waited for the next task forever; this left
    a worker behind in about 1 killed command in 10. A signal that lands just before the
    main thread blocks is noted but does not interrupt the call either.

    The signal goes to the main thread itself: the kernel's parent-death signal
    (``PR_SET_PDEATHSIG``) goes to the process, whose other threads (OpenBLAS's) may take
    it, and it follows the *thread* that started the worker rather than the process.
    A parent already gone before the call is checked for. The worker must be the child of
    ``parent`` (fork or spawn); otherwise (a fork server's worker) nothing is watched.
    """
    main = threading.main_thread().ident
    assert main is not None
    if os.getppid() != parent and _exists(parent):  # not its child (a fork server's worker): no watch
        return

    def wait_for_parent() -> None:
        try:
            handle = os.pidfd_open(parent)
        except (AttributeError, OSError):  # no pidfds here, or the parent has gone already
            handle = None
        try:
            if handle is not None and os.getppid() == parent:
                waiter = select.poll()  # not select(): a forked worker's fds may be >= FD_SETSIZE
                waiter.register(handle, select.POLLIN)
                waiter.poll()
        finally:
            if handle is not None:
                os.close(handle)

    def watch() -> None:
        try:
            wait_for_parent()
        except Exception:  # noqa: BLE001 - whatever failed, polling the parent pid still works
            pass
        while os.getppid() == parent:
            time.sleep(0.5)
        signal.pthread_kill(main, signal.SIGTERM)
        time.sleep(ORPHAN_GRACE)
        os._exit(128 + signal.SIGTERM)

    threading.Thread(target=watch, name="end-with-parent", daemon=True).start()


def ignore_interrupts() -> None:
    """Process-pool initializer: workers ignore SIGINT; the parent decides when to stop.

    The second line of defence after :func:`quiet_spawn_context` (and the only one where
    signals cannot be blocked): a worker killed in the middle of an evaluation would return
    a spurious failure or break the pool; the parent stops the run between evaluations.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
