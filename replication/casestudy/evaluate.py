"""Fitness evaluation for the GA: the fitness function and the executors that run it.

Evaluation goes through a :class:`concurrent.futures.Executor`: a serial one (in process),
a local process pool, or a dask.distributed cluster (``Client.get_executor()``), so an
expensive evaluator (the paper's 107 s SPH simulation) can be farmed out. The fitness is a
pure function of the genome, so results do not depend on where or in which order
evaluations run. Evaluations are sent in batches sized to their measured cost
(:mod:`.dispatch`). An evaluation that raises or returns a non-finite value is recorded as a
failure; an executor that breaks (a dead process-pool worker) is replaced and the evaluations
it lost are run again; dask reschedules the tasks of a dead worker by itself. Every process an
executor starts is gone when it closes.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import gc
import multiprocessing.resource_tracker
import os
import signal
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from replication.casestudy.dispatch import Dispatcher, Outcome
from replication.casestudy.ga import GAConfig, points_from_genome
from replication.casestudy.interrupts import (
    end_with_parent,
    exit_on_terminate,
    ignore_interrupts,
    quiet_worker_context,
)
from replication.cpus import usable_cpus
from replication.errors import DuplicatePointsWarning, InputError, UsageError
from replication.sigterm import terminating

__all__ = [
    "EXECUTORS",
    "Dispatcher",
    "Fitness",
    "Outcome",
    "SerialExecutor",
    "check_executor_options",
    "evaluate_batch",
    "executor",
]

EXECUTORS: tuple[str, ...] = ("auto", "serial", "process", "dask")


@dataclass(frozen=True)
class Fitness:
    """The GA's objective: the axial jet force (N) on the ADT surface of a genome.

    Each genome becomes a surface through ADT with the depth axis imposed as z (the jet
    axis), so every individual is a height field facing the jet, and with the configured
    duplicate policy (points on the same (x, y) lattice node are merged). Picklable, so
    process pools and dask workers can run it.
    """

    config: GAConfig

    def __call__(self, genome: np.ndarray) -> float:
        from replication.casestudy.jet import surface_force
        from replication.surfaces import adt

        points = points_from_genome(genome, self.config)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DuplicatePointsWarning)
            surface = adt(points, depth="z", duplicates=self.config.duplicates)  # type: ignore[arg-type]
        return surface_force(surface, self.config.jet, resolution=self.config.resolution).axial_force


class SerialExecutor(cf.Executor):
    """Runs each task at once in the calling process (for tiny runs and debugging)."""

    def worker_count(self) -> int:
        return 1

    def submit(self, fn: Callable, /, *args, **kwargs) -> cf.Future:  # type: ignore[override]
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # the caller inspects it, like a real executor
            future.set_exception(exc)
        return future


def run_bounded(
    pool: cf.Executor,
    tasks: Sequence[tuple[Any, Callable, tuple]],
    max_parallel: int,
    on_done: Callable[[Any, cf.Future], None],
) -> None:
    """Submit ``tasks`` (``(key, function, arguments)``) to ``pool`` in order, at most
    ``max_parallel`` in flight, and call ``on_done(key, future)`` as each finishes (those that
    finish together in the order they were submitted).

    For slow, independent work such as SPH simulations, where a batch would wait for its
    slowest member. Any exception (a Ctrl-C, a refused submit, one raised by ``on_done``)
    cancels the tasks not started yet and propagates; those under way are the executor's to
    wait for or abandon (see :func:`executor`).
    """
    waiting = list(tasks)
    running: dict[cf.Future, tuple[int, Any]] = {}
    order = 0
    try:
        while waiting or running:
            while waiting and len(running) < max_parallel:
                key, function, arguments = waiting.pop(0)
                running[pool.submit(function, *arguments)] = (order, key)
                order += 1
            finished, _ = cf.wait(running, return_when=cf.FIRST_COMPLETED)
            for future in sorted(finished, key=lambda f: running[f][0]):
                on_done(running.pop(future)[1], future)
    except BaseException:
        for future in running:
            future.cancel()
        raise


def evaluate_batch(
    pool: cf.Executor,
    fitness: Callable[[np.ndarray], float],
    genomes: Sequence[np.ndarray],
    *,
    interrupted: Callable[[], bool] = lambda: False,
) -> list[Outcome]:
    """Evaluate genomes on an open executor, in batches; failures become Outcomes with an error.

    ``interrupted`` is polled between submissions and while waiting (see
    :class:`.interrupts.InterruptGuard`): once it is true the batch stops with
    :class:`KeyboardInterrupt`, pending evaluations are cancelled, and an evaluation that
    failed because of the interrupt is never taken for a failed evaluation. See
    :class:`.dispatch.Dispatcher` for the batching, and for an executor that is replaced
    when it breaks.

    Raises
    ------
    concurrent.futures.BrokenExecutor
        When the executor itself broke (the batch should be retried on a new one).
    KeyboardInterrupt
        When the user interrupted the batch.
    """
    dispatcher = Dispatcher(lambda: contextlib.nullcontext(pool), retries=0)
    return dispatcher.evaluate(fitness, genomes, interrupted=interrupted)


def check_executor_options(kind: str, workers: int | None = None, scheduler: str | None = None) -> None:
    """Refuse option combinations an executor would silently ignore, and malformed addresses.

    Raises
    ------
    InputError
        An unknown executor, a non-positive worker count, ``workers`` or ``scheduler`` with
        the serial executor, ``scheduler`` with the process pool, both ``workers`` and
        ``scheduler`` (an existing cluster brings its own workers), a scheduler address
        that is malformed or names an unknown host, or dask asked for and not installed.
    """
    if kind not in EXECUTORS:
        raise InputError(f"unknown executor {kind!r}; choose one of {EXECUTORS}")
    if workers is not None and (isinstance(workers, bool) or workers < 1):
        raise InputError(f"workers must be a positive integer, got {workers!r}")
    if kind == "serial" and workers is not None:
        raise UsageError(
            f"--workers {workers} does not apply to the serial executor (it evaluates in this process); "
            "use --executor process or dask"
        )
    if scheduler is not None and kind in ("serial", "process"):
        raise UsageError(
            f"--scheduler names a dask cluster, which the {kind} executor does not use; "
            "drop --executor or use --executor dask"
        )
    if scheduler is not None and workers is not None:
        raise UsageError(
            "--workers starts a local cluster of that size; a cluster named by --scheduler "
            "brings its own workers: give one of them"
        )
    if kind == "dask" or scheduler is not None:  # before a run directory is made, not at the first generation
        from replication.casestudy.cluster import require_dask

        require_dask()
    if scheduler is not None:
        from replication.casestudy.cluster import check_scheduler_address

        check_scheduler_address(scheduler)


def worker_initializer(parent: int | None = None) -> None:
    """Process-pool initializer: workers ignore SIGINT, unwind on SIGTERM, run one BLAS thread
    and one kernel thread, end with ``parent`` (its pid) and drop the run-directory locks a
    fork copied.

    The parent decides when to stop (see :mod:`.interrupts`); the GA's parallelism is one
    evaluation per worker, so BLAS or kernel threads would only compete (see
    :mod:`replication.threadlimits`, :func:`replication.surfaces._threads.one_thread`).
    A parent killed outright left its workers waiting forever, holding its run directory's
    lock (:func:`.interrupts.end_with_parent`, :func:`replication.io.locks.close_inherited_locks`).
    """
    # Until the worker is set up, SIGTERM (its parent's death among others) ends it at once:
    # there is nothing to unwind yet, and a SystemExit raised inside the initializer would be
    # logged by concurrent.futures as a traceback on the user's terminal. First of all, before
    # any import: a forked worker has its parent's handler, which raises Terminated; the
    # parent started it with SIGTERM blocked (interrupts._starting_a_child), now lifted.
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):  # POSIX
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})
    from replication.io.locks import close_inherited_locks
    from replication.surfaces._threads import one_thread
    from replication.threadlimits import limit_worker_blas

    ignore_interrupts()
    if parent is not None:
        end_with_parent(parent)
    close_inherited_locks()  # (the run directory's and the reports directory's)
    limit_worker_blas()
    one_thread()
    exit_on_terminate()


@contextlib.contextmanager
def executor(
    kind: str = "auto",
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    on_interrupt: Callable[[], None] | None = None,
    abandon_on_interrupt: bool = False,
) -> Iterator[cf.Executor]:
    """An executor for fitness evaluations, closed on exit.

    Parameters
    ----------
    kind : {"auto", "serial", "process", "dask"}
        ``"auto"``: dask when a scheduler address is given, else a process pool when more
        than one worker is available, else serial.
    workers : int, optional
        Process-pool size, or the number of workers of a local dask cluster (default: the
        CPUs this process may use, :func:`replication.cpus.usable_cpus`).
    scheduler : str, optional
        Address of a running dask scheduler (``tcp://host:8786``); implies dask.
    on_interrupt : callable, optional
        Called when Ctrl-C leaves the block of a process pool or a local dask cluster, before
        it waits for the work under way (an SPH simulation can take minutes): the place to
        say so.
    abandon_on_interrupt : bool
        A process pool does not wait on Ctrl-C: its workers are ended at once, each killing
        the simulation it ran (for work that keeps nothing of an unfinished run, such as the
        SPH study; ``on_interrupt`` is then not called). A SIGTERM that the command takes as
        an interrupt (:mod:`replication.sigterm`) abandons the work of a process pool or a
        local dask cluster in any case, as a second Ctrl-C does.

    Raises
    ------
    InputError
        Options that do not go together (:func:`check_executor_options`), a malformed
        scheduler address, dask not installed.
    ExecutorError
        A scheduler that cannot be reached (see :mod:`.cluster`).

    Notes
    -----
    Worker processes (pool or local dask cluster) do not take SIGINT, so Ctrl-C in a
    terminal reaches the parent alone, which stops the run between evaluations (see
    :mod:`.interrupts`); pending evaluations are cancelled on the way out, and a process
    pool or a local dask cluster waits for those under way, so that finished work is kept.
    A second Ctrl-C during that wait abandons them: a pool's workers are terminated (each
    kills the simulation it was waiting for, see :func:`.interrupts.exit_on_terminate`), a
    local cluster's workers and their simulations' engines are killed (see :mod:`.cluster`).
    """
    check_executor_options(kind, workers, scheduler)
    n = workers or usable_cpus()
    if kind == "auto":
        kind = "dask" if scheduler else ("process" if n > 1 else "serial")
    if kind == "serial":
        yield SerialExecutor()
    elif kind == "process":
        from replication.kernels import release_threads

        release_threads()  # the jet force's kernel threads, idle: the workers can then be forked
        with _resource_tracker_stopped():
            pool = cf.ProcessPoolExecutor(
                max_workers=n,
                mp_context=quiet_worker_context(),
                initializer=worker_initializer,
                initargs=(os.getpid(),),
            )
            interrupted = abandoned = False
            try:
                yield pool
            except KeyboardInterrupt:
                interrupted = True
                if abandon_on_interrupt or terminating():  # SIGTERM does not wait (replication.sigterm)
                    abandoned = True
                    _abandon(pool)  # the workers end, and with them the pool's manager thread
                raise
            finally:
                if not abandoned:
                    _shut_down(pool, on_interrupt if interrupted else None)
                del pool
    else:
        from replication.casestudy.cluster import dask_executor

        with _resource_tracker_stopped(), dask_executor(scheduler, n, on_interrupt) as pool:
            yield pool


#: Seconds a terminated worker has to unwind (kill its simulation) before it is killed outright.
ABANDON_GRACE = 5.0


def _shut_down(pool: cf.ProcessPoolExecutor, announce: Callable[[], None] | None = None) -> None:
    """Wait for the work under way and close the pool; a Ctrl-C while waiting abandons that work.

    ``announce`` (the executor's ``on_interrupt``) is called inside the guarded block: a user
    who presses Ctrl-C again once told that the command waits is always heard. Called before
    it, a second Ctrl-C in between escaped the guard, and the interpreter's exit then waited
    for the simulation under way (a hang of minutes, seen once in CI on a loaded machine).
    """
    # Ctrl-C inside the first submit, after a fork pool started its workers but before its
    # management thread: shutdown cannot reach them, and the interpreter's exit then waited for
    # them forever (a hang after "interrupted"). Such workers are ended after the shutdown.
    from replication.casestudy.interrupts import unrecorded_workers

    unmanaged = getattr(pool, "_executor_manager_thread", None) is None
    recorded = list((getattr(pool, "_processes", None) or {}).values())
    # a worker the pool never recorded (an interrupt as it started) waits for a call for good
    stray = unrecorded_workers(pool)
    try:
        if announce is not None:
            announce()
        pool.shutdown(wait=True, cancel_futures=True)
    except KeyboardInterrupt:
        _abandon(pool)
        raise
    left = (recorded if unmanaged else []) + stray
    if left:
        _end(left)


def _abandon(pool: cf.ProcessPoolExecutor, grace: float = ABANDON_GRACE) -> None:
    """End every worker of ``pool`` for certain, each first killing the simulation it ran.

    SIGTERM makes a worker unwind (:func:`.interrupts.exit_on_terminate`), which kills the
    driver of its simulation (a session of its own), and then end without taking another
    call. A worker whose task swallows that exit is killed after ``grace`` seconds.
    ``shutdown`` is not called again: after an interrupted one, the pool's management thread
    may have closed its handles; it ends by itself once the workers are gone.
    """
    from replication.casestudy.interrupts import unrecorded_workers

    processes = list((getattr(pool, "_processes", None) or {}).values())  # (3.14: terminate_workers())
    processes += unrecorded_workers(pool)
    manager = getattr(pool, "_executor_manager_thread", None)
    with _cancelled_futures_quiet(manager):
        _end(processes, grace)
        if manager is not None:
            manager.join(grace)


@contextlib.contextmanager
def _cancelled_futures_quiet(manager: threading.Thread | None) -> Iterator[None]:
    """The pool's manager thread does not print a traceback for a cancelled future.

    Once its workers are ended, the pool's manager thread marks every pending work item
    failed. Before CPython 3.12 (gh-107219) it also tried the futures cancelled a moment
    earlier (the dispatcher cancels what it has not started), raised ``InvalidStateError``
    and died printing "Exception in thread" and a traceback on the command's stderr, after
    Ctrl-C had been pressed twice or SIGTERM received, both with a worker that was killed
    before it could answer. Only that exception of that thread is kept quiet; the hook is
    restored once the thread has ended (a thread still alive keeps the filter, which only
    ever concerns it).
    """
    if manager is None:
        yield
        return
    previous = threading.excepthook

    def hook(args: threading.ExceptHookArgs) -> None:
        if (
            args.thread is manager
            and args.exc_type is not None
            and issubclass(args.exc_type, cf.InvalidStateError)
        ):
            return
        previous(args)

    threading.excepthook = hook
    try:
        yield
    finally:
        if not manager.is_alive() and threading.excepthook is hook:
            threading.excepthook = previous


def _end(processes: list, grace: float = ABANDON_GRACE) -> None:
    """Terminate worker processes (each unwinds, killing its simulation), then kill the slow."""
    for process in processes:
        with contextlib.suppress(Exception):
            process.terminate()
    deadline = time.monotonic() + grace
    for process in processes:
        with contextlib.suppress(Exception):
            process.join(max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.kill()
                process.join()


@contextlib.contextmanager
def _resource_tracker_stopped() -> Iterator[None]:
    """Stop multiprocessing's resource tracker on exit if it was started inside the block.

    Spawned worker processes (a process pool, a local dask cluster's nannies) start the
    tracker, a process that otherwise outlives the command that started it by a moment,
    left to exit once it notices its parent is gone (issue 15). It is stopped only if it
    was not running before, and after the pool's semaphores are released, so that it has
    nothing left to clean up and a tracker somebody else relies on is never touched.
    """
    tracker = multiprocessing.resource_tracker._resource_tracker
    was_running = getattr(tracker, "_fd", None) is not None
    try:
        yield
    finally:
        stop = getattr(tracker, "_stop", None)
        # a child still running (one a SIGTERM left behind) holds the tracker's pipe: stopping
        # it would wait for that child for good; the tracker then ends with this process
        if not was_running and callable(stop) and not multiprocessing.active_children():
            gc.collect()  # release the pool's semaphores now, while the tracker is there to hear it
            stop()
