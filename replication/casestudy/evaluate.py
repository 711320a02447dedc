"""Fitness evaluation for the GA: the fitness function and the executors that run it.

Evaluation goes through a :class:`concurrent.futures.Executor`: a serial one (in process),
a local process pool, or a dask.distributed cluster (``Client.get_executor()``), so an
expensive evaluator (the paper's 107 s SPH simulation) can be farmed out. The fitness is a
pure function of the genome, so results do not depend on where or in which order
evaluations run. An evaluation that raises or returns a non-finite value is recorded as a
failure; an executor that breaks (a dead process-pool worker) is replaced and the batch
retried; dask reschedules the tasks of a dead worker by itself.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import logging
import math
import os
import socket
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from replication.casestudy.ga import GAConfig, points_from_genome
from replication.casestudy.interrupts import (
    caused_by_interrupt,
    ignore_interrupts,
    quiet_spawn_context,
    sigint_ignored_by_children,
)
from replication.errors import DuplicatePointsWarning, ExecutorError, InputError

__all__ = [
    "EXECUTORS",
    "Fitness",
    "Outcome",
    "SerialExecutor",
    "check_executor_options",
    "check_scheduler_address",
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


@dataclass(frozen=True)
class Outcome:
    """One evaluation: a finite value, or the error that stood in its way."""

    value: float | None
    error: str | None = None


class SerialExecutor(cf.Executor):
    """Runs each task at once in the calling process (for tiny runs and debugging)."""

    def submit(self, fn: Callable, /, *args, **kwargs) -> cf.Future:  # type: ignore[override]
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # the caller inspects it, like a real executor
            future.set_exception(exc)
        return future


def evaluate_batch(
    pool: cf.Executor,
    fitness: Callable[[np.ndarray], float],
    genomes: Sequence[np.ndarray],
    *,
    interrupted: Callable[[], bool] = lambda: False,
) -> list[Outcome]:
    """Evaluate genomes on an executor; failures become Outcomes with an error message.

    ``interrupted`` is polled before each submission and after each result (see
    :class:`.interrupts.InterruptGuard`): once it is true the batch stops with
    :class:`KeyboardInterrupt`, pending evaluations are cancelled, and an evaluation that
    failed because of the interrupt is never taken for a failed evaluation.

    Raises
    ------
    concurrent.futures.BrokenExecutor
        When the executor itself broke (the batch should be retried on a new one).
    KeyboardInterrupt
        When the user interrupted the batch.
    """
    futures: list[cf.Future] = []
    outcomes: list[Outcome] = []
    try:
        for genome in genomes:
            if interrupted():
                raise KeyboardInterrupt
            futures.append(pool.submit(fitness, genome))
        for future in futures:
            try:
                value = future.result()
            except cf.BrokenExecutor:
                if interrupted():
                    raise KeyboardInterrupt from None
                raise
            except Exception as exc:  # an evaluation failure is data, not a crash...
                if interrupted() or caused_by_interrupt(exc):  # ...unless Ctrl-C caused it
                    raise KeyboardInterrupt from exc
                outcomes.append(Outcome(None, f"{type(exc).__name__}: {exc}"))
                continue
            if interrupted():
                raise KeyboardInterrupt
            if isinstance(value, (int, float, np.floating)) and math.isfinite(float(value)):
                outcomes.append(Outcome(float(value)))
            else:
                outcomes.append(Outcome(None, f"non-finite fitness {value!r}"))
    except BaseException:
        for future in futures:
            future.cancel()
        raise
    return outcomes


#: Seconds to wait for a dask scheduler named by its address before giving up.
CONNECT_TIMEOUT_S = 5.0


def check_executor_options(kind: str, workers: int | None = None, scheduler: str | None = None) -> None:
    """Refuse option combinations an executor would silently ignore, and malformed addresses.

    Raises
    ------
    InputError
        An unknown executor, a non-positive worker count, ``workers`` or ``scheduler`` with
        the serial executor, ``scheduler`` with the process pool, both ``workers`` and
        ``scheduler`` (an existing cluster brings its own workers), or a scheduler address
        that is malformed or names an unknown host.
    """
    if kind not in EXECUTORS:
        raise InputError(f"unknown executor {kind!r}; choose one of {EXECUTORS}")
    if workers is not None and (isinstance(workers, bool) or workers < 1):
        raise InputError(f"workers must be a positive integer, got {workers!r}")
    if kind == "serial" and workers is not None:
        raise InputError(
            f"--workers {workers} does not apply to the serial executor (it evaluates in this process); "
            "use --executor process or dask"
        )
    if scheduler is not None and kind in ("serial", "process"):
        raise InputError(
            f"--scheduler names a dask cluster, which the {kind} executor does not use; "
            "drop --executor or use --executor dask"
        )
    if scheduler is not None and workers is not None:
        raise InputError(
            "--workers starts a local cluster of that size; a cluster named by --scheduler "
            "brings its own workers: give one of them"
        )
    if scheduler is not None:
        check_scheduler_address(scheduler)


def check_scheduler_address(scheduler: str) -> str:
    """The resolved address of a dask scheduler (``tcp://host:8786``), or an InputError."""
    try:
        from distributed.comm import resolve_address
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise InputError("dask evaluation needs the optional extra: pip install 'replication[dask]'") from exc

    try:
        return resolve_address(scheduler)  # the syntax, and the host name
    except (ValueError, OSError) as exc:
        raise InputError(
            f"--scheduler {scheduler!r} is not a dask scheduler address like tcp://host:8786 ({exc})"
        ) from exc


def _connect(scheduler: str):  # type: ignore[no-untyped-def]
    """A dask Client of the scheduler at ``scheduler``, or a one-line error quickly."""
    from dask.distributed import Client

    address = check_scheduler_address(scheduler)
    if address.startswith("tcp://"):  # a refused connection fails at once, not after the timeout
        from distributed.comm import get_address_host_port

        host, port = get_address_host_port(address)
        try:
            socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S).close()
        except OSError as exc:
            raise ExecutorError(
                f"cannot reach a dask scheduler at {scheduler}: {exc.strerror or exc}; is it running, and is "
                "the address right?"
            ) from exc
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as exc:
        raise ExecutorError(
            f"cannot reach a dask scheduler at {scheduler} within {CONNECT_TIMEOUT_S:g} s: is it running, "
            "and is the address right?"
        ) from exc
    except Exception as exc:  # something answered, but not in dask's protocol
        raise ExecutorError(
            f"no dask scheduler at {scheduler}: something answers there but not in dask's protocol "
            f"({type(exc).__name__})"
        ) from exc


@contextlib.contextmanager
def executor(
    kind: str = "auto", *, workers: int | None = None, scheduler: str | None = None
) -> Iterator[cf.Executor]:
    """An executor for fitness evaluations, closed on exit.

    Parameters
    ----------
    kind : {"auto", "serial", "process", "dask"}
        ``"auto"``: dask when a scheduler address is given, else a process pool when more
        than one worker is available, else serial.
    workers : int, optional
        Process-pool size, or the number of workers of a local dask cluster (default: the
        number of CPUs).
    scheduler : str, optional
        Address of a running dask scheduler (``tcp://host:8786``); implies dask.

    Raises
    ------
    InputError
        Options that do not go together (:func:`check_executor_options`), a malformed
        scheduler address, dask not installed.
    ExecutorError
        A scheduler that does not answer within ``CONNECT_TIMEOUT_S``.

    Notes
    -----
    Worker processes (pool or local dask cluster) start with SIGINT blocked, so Ctrl-C in a
    terminal reaches the parent alone, which stops the run between evaluations (see
    :mod:`.interrupts`); pending evaluations are cancelled on the way out.
    """
    check_executor_options(kind, workers, scheduler)
    n = workers or os.cpu_count() or 1
    if kind == "auto":
        kind = "dask" if scheduler else ("process" if n > 1 else "serial")
    if kind == "serial":
        yield SerialExecutor()
    elif kind == "process":
        pool = cf.ProcessPoolExecutor(
            max_workers=n, mp_context=quiet_spawn_context(), initializer=ignore_interrupts
        )
        try:
            yield pool
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    else:
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the optional extra
            raise InputError(
                "dask evaluation needs the optional extra: pip install 'replication[dask]'"
            ) from exc
        if scheduler:
            with _log_levels_restored(), _connect(scheduler) as client:
                yield from _dask_executor(client)
        else:
            with sigint_ignored_by_children():  # the worker processes started now inherit it
                cluster = LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None
                )
            with _log_levels_restored(), cluster, Client(cluster) as client:
                yield from _dask_executor(client)


_DASK_LOGGERS = ("distributed", "tornado")


@contextlib.contextmanager
def _log_levels_restored() -> Iterator[None]:
    loggers = [logging.getLogger(name) for name in _DASK_LOGGERS]
    levels = [logger.level for logger in loggers]
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)


def _dask_executor(client) -> Iterator[cf.Executor]:  # type: ignore[no-untyped-def]
    """The client's executor; on exit pending evaluations are cancelled and the teardown is quiet.

    After Ctrl-C evaluations may still be under way: they are cancelled, and what dask and
    tornado log while the client and cluster close under them (connections closed, results
    that cannot be gathered) is not shown: nobody waits for those results any more. The
    levels are restored by :func:`_log_levels_restored` once everything is closed.
    """
    pool = client.get_executor(pure=False)
    try:
        yield pool
    finally:
        for name in _DASK_LOGGERS:
            logging.getLogger(name).setLevel(logging.CRITICAL)
        pool.shutdown(wait=False)
