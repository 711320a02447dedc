"""Batched dispatch of fitness evaluations, sized to the work, on one executor per command.

A thin-sheet evaluation takes about 3 ms; a process-pool task costs about as much again in
pickling and inter-process messages, so one task per evaluation wastes half of every worker
(issue 15: 2 workers were 1.12x as fast as 1). An SPH evaluation takes minutes; a task of
several of them would hold a whole generation hostage to the slowest. One rule serves both
(guided self-scheduling with a cap on a task's duration):

* a task takes ``ceil(remaining / (workers * tasks_per_worker))`` evaluations - large tasks
  while much is left, single evaluations at the end of a generation, so no worker waits
  long for another - but never more than ``task_seconds`` worth of evaluations at their
  measured cost, and one evaluation per task while no cost has been measured yet;
* while no cost has been measured, one single evaluation per worker is in flight; from the
  first result on, the rest of the batch is cut and submitted at once, so the workers never
  wait for the calling process between tasks (on a loaded machine or a dask cluster every
  round trip through it costs milliseconds to seconds). An evaluation that takes longer than
  ``task_seconds`` is therefore always one task of its own, and the executor hands the tasks
  to the workers as they become free.

The cost is measured in the worker (the time of the fitness calls alone; the estimate is the
median of the last evaluations, robust to a worker's slow first call). Failed or
non-finite evaluations are recorded in the worker as data. A task that fails as a whole (its
worker died more often than the scheduler allows, an unpicklable result) is cut into single
evaluations and tried again, so that only the evaluation at fault is recorded as failed. A
process pool that breaks (a worker died) is replaced; the evaluations in flight are run again
on the new one and the results already received are kept. dask re-runs the tasks of a lost
worker by itself.

The :class:`Dispatcher` owns the executor: it is created on first use, shared by every GA run
of a command, and closed once at the end (see :func:`.evaluate.executor`).
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import statistics
import time
from collections import deque
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any

import numpy as np

from replication.casestudy.interrupts import caused_by_interrupt
from replication.cpus import usable_cpus
from replication.errors import InputError, no_room

__all__ = ["Batching", "Dispatcher", "Outcome", "evaluate_chunk", "worker_count"]

ExecutorFactory = Callable[[], AbstractContextManager[cf.Executor]]
MAX_EXECUTOR_RETRIES = 3  #: new executors tried for one batch after the previous one broke
POLL_SECONDS = 0.1  #: how often a wait for results looks at the interrupt flag
#: Evaluations whose median is the cost estimate: the median, since a worker's first
#: evaluation also loads the compiled kernels and takes a hundred times longer than the rest.
COST_WINDOW = 64


@dataclass(frozen=True)
class Outcome:
    """One evaluation: a finite value, or the error that stood in its way."""

    value: float | None
    error: str | None = None


@dataclass(frozen=True)
class Batching:
    """How evaluations are cut into tasks (see the module notes).

    Parameters
    ----------
    task_seconds : float
        Longest work a task of several evaluations is given, at the measured cost.
    tasks_per_worker : int
        The divisor of the remaining work: about the number of tasks a worker gets per batch.
    """

    task_seconds: float = 0.1
    tasks_per_worker: int = 2

    def __post_init__(self) -> None:
        if not (isinstance(self.task_seconds, (int, float)) and self.task_seconds > 0):
            raise InputError(f"task_seconds must be a positive number, got {self.task_seconds!r}")
        if (
            isinstance(self.tasks_per_worker, bool)
            or not isinstance(self.tasks_per_worker, int)
            or (self.tasks_per_worker < 1)
        ):
            raise InputError(f"tasks_per_worker must be a positive integer, got {self.tasks_per_worker!r}")

    def chunk(self, remaining: int, workers: int, cost: float | None) -> int:
        """Evaluations in the next task: ``remaining`` left, ``cost`` seconds each (None: unknown)."""
        if remaining <= 0:
            return 0
        if cost is None:
            return 1
        balance = math.ceil(remaining / (max(workers, 1) * self.tasks_per_worker))
        if cost * balance <= self.task_seconds:
            return balance
        return max(1, min(balance, int(self.task_seconds // cost)))


def evaluate_chunk(
    fitness: Callable[[np.ndarray], float], genomes: Sequence[np.ndarray]
) -> list[tuple[float | None, str | None, float]]:
    """Evaluate genomes one by one (in a worker): ``(value, error, seconds)`` for each.

    An evaluation that raises or returns a non-finite value is a result with an error
    message, not a failed task, unless a :class:`KeyboardInterrupt` caused it (then the
    interrupt propagates, see :mod:`.interrupts`) or it says that no result can be written
    (:func:`replication.errors.no_room`: a full disk propagates too).
    """
    rows: list[tuple[float | None, str | None, float]] = []
    for genome in genomes:
        started = time.perf_counter()
        try:
            value = fitness(genome)
        except Exception as exc:  # an evaluation failure is data, not a crash...
            if caused_by_interrupt(exc) or no_room(exc):  # ...unless Ctrl-C caused it, or a full disk
                raise
            rows.append((None, f"{type(exc).__name__}: {exc}", time.perf_counter() - started))
            continue
        seconds = time.perf_counter() - started
        if isinstance(value, (int, float, np.floating)) and math.isfinite(float(value)):
            rows.append((float(value), None, seconds))
        else:
            rows.append((None, f"non-finite fitness {value!r}", seconds))
    return rows


def worker_count(pool: cf.Executor) -> int:
    """Evaluations an executor runs at once: its ``worker_count()``, a pool's size, or the CPUs."""
    counter = getattr(pool, "worker_count", None)
    if callable(counter):
        return max(1, int(counter()))
    size = getattr(pool, "_max_workers", None)  # concurrent.futures pools
    return max(1, int(size)) if isinstance(size, int) else usable_cpus()


class Dispatcher:
    """Evaluates batches of genomes on one executor, opened on first use and replaced when it breaks.

    Parameters
    ----------
    factory : callable
        Returns a context manager yielding the executor (:func:`.evaluate.executor`).
    batching : Batching
        How evaluations are cut into tasks.
    retries : int
        New executors tried, one after another, when the executor breaks during a batch.

    Notes
    -----
    Paper section 6: the GA's fitness evaluations (2400 per run in the paper, each an SPH
    simulation of 107.53 s). Use as a context manager, or call :meth:`close`.
    """

    def __init__(
        self,
        factory: ExecutorFactory,
        *,
        batching: Batching | None = None,
        retries: int = MAX_EXECUTOR_RETRIES,
    ) -> None:
        self.factory = factory
        self.batching = batching or Batching()
        self.retries = retries
        self.cost: float | None = None  # seconds per evaluation: median of the last COST_WINDOW
        self.measured = 0  # evaluations measured
        self._recent: deque[float] = deque(maxlen=COST_WINDOW)
        self.tasks = 0  # tasks submitted (for tests and benchmarks)
        self.replaced = 0  # executors replaced after they broke
        self._context: AbstractContextManager[cf.Executor] | None = None
        self._executor: cf.Executor | None = None

    def __enter__(self) -> Dispatcher:
        return self

    def __exit__(self, kind: object, error: BaseException | None, traceback: object) -> None:
        self.close(error)

    def executor(self) -> cf.Executor:
        """The executor, created now if there is none."""
        if self._executor is None:
            context = self.factory()
            self._executor = context.__enter__()
            self._context = context
        return self._executor

    def close(self, error: BaseException | None = None) -> None:
        """Close the executor (cancelling what is pending); a later batch opens a new one.

        ``error`` is the exception that ends the caller's work, if any: the executor's context
        (:func:`.evaluate.executor`) takes it as its own block's. After Ctrl-C it then says so
        (its ``on_interrupt``) and waits for the simulations under way, or abandons them when
        the command was told to terminate; closed as if nothing had happened, it waited
        without a word, even for a command told to terminate.
        """
        if self._context is not None:
            context, self._context, self._executor = self._context, None, None
            if error is None:
                context.__exit__(None, None, None)
            else:
                context.__exit__(type(error), error, error.__traceback__)

    def _observe(self, seconds: float) -> None:
        self.measured += 1
        self._recent.append(seconds)
        self.cost = statistics.median(self._recent)

    def _replace_broken(self, broken: int, error: cf.BrokenExecutor) -> int:
        """Close a broken executor (a dead worker took the pool down) so that the next batch
        opens a new one; returns the count of breaks so far, raising ``error`` once it
        exceeds ``retries``."""
        self.close()
        self.replaced += 1
        if broken + 1 > self.retries:
            raise error
        return broken + 1

    def run_calls(self, calls: Sequence[Callable[[], Any]]) -> list[Any]:
        """Run independent calls as one task each on the executor; their results, in order.

        For work beside the GA (the case study's reference shapes and timing): each call is
        submitted at once, so the workers share them. When the executor breaks, it is
        replaced and the calls without a result run again (``retries`` times at most, as for
        evaluations). A call that raises raises here; Ctrl-C cancels what has not started.

        Raises
        ------
        concurrent.futures.BrokenExecutor
            When the executor broke and ``retries`` new executors broke in turn.
        """
        results: dict[int, Any] = {}
        broken = 0
        while len(results) < len(calls):
            futures: dict[cf.Future, int] = {}
            try:
                pool = self.executor()
                for index, call in enumerate(calls):
                    if index not in results:
                        futures[pool.submit(call)] = index
                for future in cf.as_completed(futures):
                    results[futures[future]] = future.result()
            except cf.BrokenExecutor as exc:
                broken = self._replace_broken(broken, exc)
            finally:
                for future in futures:
                    future.cancel()
        return [results[index] for index in range(len(calls))]

    def evaluate(
        self,
        fitness: Callable[[np.ndarray], float],
        genomes: Sequence[np.ndarray],
        *,
        interrupted: Callable[[], bool] = lambda: False,
    ) -> list[Outcome]:
        """The outcome of every genome, in order.

        Raises
        ------
        KeyboardInterrupt
            When ``interrupted()`` turned true (polled between submissions and while waiting);
            what is in flight is cancelled and nothing of the batch is returned.
        concurrent.futures.BrokenExecutor
            When the executor broke and ``retries`` new executors broke in turn.
        """
        results: list[Outcome | None] = [None] * len(genomes)
        pending: deque[int] = deque(range(len(genomes)))
        singles: deque[int] = deque()  # evaluations of failed tasks, to be tried one by one
        broken = 0
        while pending or singles:
            try:
                self._run(fitness, genomes, pending, singles, results, interrupted)
            except cf.BrokenExecutor as exc:
                if interrupted():
                    raise KeyboardInterrupt from None
                broken = self._replace_broken(broken, exc)
        done = [r for r in results if r is not None]
        assert len(done) == len(genomes), "every genome has an outcome"
        return done

    def _run(
        self,
        fitness: Callable[[np.ndarray], float],
        genomes: Sequence[np.ndarray],
        pending: deque[int],
        singles: deque[int],
        results: list[Outcome | None],
        interrupted: Callable[[], bool],
    ) -> None:
        """Dispatch until everything is evaluated; on a broken executor the lost work goes back."""
        in_flight: dict[cf.Future, list[int]] = {}
        try:
            pool = self.executor()
            workers = worker_count(pool)
            while pending or singles or in_flight:
                while (pending or singles) and (self.cost is not None or len(in_flight) < workers):
                    if interrupted():
                        raise KeyboardInterrupt
                    if singles:
                        chunk = [singles.popleft()]
                    else:
                        size = self.batching.chunk(len(pending), workers, self.cost)
                        chunk = [pending.popleft() for _ in range(size)]
                    try:
                        future = pool.submit(evaluate_chunk, fitness, [genomes[i] for i in chunk])
                    except cf.BrokenExecutor:
                        pending.extendleft(reversed(chunk))  # not sent: it goes to the next executor
                        raise
                    in_flight[future] = chunk
                    self.tasks += 1
                done, _ = cf.wait(in_flight, timeout=POLL_SECONDS, return_when=cf.FIRST_COMPLETED)
                if interrupted():
                    raise KeyboardInterrupt
                for future in done:  # a chunk leaves in_flight once collected (see BrokenExecutor)
                    self._collect(future, in_flight[future], singles, results, interrupted)
                    del in_flight[future]
        except cf.BrokenExecutor:
            for chunk in in_flight.values():  # lost with the executor: evaluate them again
                pending.extendleft(reversed(chunk))
            in_flight.clear()
            raise
        finally:
            for future in in_flight:
                future.cancel()

    def _collect(
        self,
        future: cf.Future,
        chunk: list[int],
        singles: deque[int],
        results: list[Outcome | None],
        interrupted: Callable[[], bool],
    ) -> None:
        try:
            rows: Any = future.result()
        except cf.BrokenExecutor:
            raise
        except Exception as exc:  # the task failed as a whole...
            if interrupted() or caused_by_interrupt(exc):  # ...because of Ctrl-C
                raise KeyboardInterrupt from exc
            if no_room(exc):  # ...or no result can be written (errors.no_room): stop, record nothing
                raise
            if len(chunk) > 1:  # find the evaluation at fault: one by one
                singles.extend(chunk)
            else:
                results[chunk[0]] = Outcome(None, f"{type(exc).__name__}: {exc}")
            return
        for index, (value, error, seconds) in zip(chunk, rows):
            results[index] = Outcome(value, error)
            self._observe(seconds)
