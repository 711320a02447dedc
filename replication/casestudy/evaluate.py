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
import math
import os
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from replication.casestudy.ga import GAConfig, points_from_genome
from replication.errors import DuplicatePointsWarning, InputError

__all__ = ["Fitness", "Outcome", "SerialExecutor", "evaluate_batch", "executor", "EXECUTORS"]

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
    pool: cf.Executor, fitness: Callable[[np.ndarray], float], genomes: Sequence[np.ndarray]
) -> list[Outcome]:
    """Evaluate genomes on an executor; failures become Outcomes with an error message.

    Raises
    ------
    concurrent.futures.BrokenExecutor
        When the executor itself broke (the batch should be retried on a new one).
    """
    futures = [pool.submit(fitness, g) for g in genomes]
    outcomes = []
    for future in futures:
        try:
            value = future.result()
        except cf.BrokenExecutor:
            raise
        except Exception as exc:  # an evaluation failure is data, not a crash
            outcomes.append(Outcome(None, f"{type(exc).__name__}: {exc}"))
            continue
        if isinstance(value, (int, float, np.floating)) and math.isfinite(float(value)):
            outcomes.append(Outcome(float(value)))
        else:
            outcomes.append(Outcome(None, f"non-finite fitness {value!r}"))
    return outcomes


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
    """
    if kind not in EXECUTORS:
        raise InputError(f"unknown executor {kind!r}; choose one of {EXECUTORS}")
    if workers is not None and workers < 1:
        raise InputError(f"workers must be positive, got {workers}")
    n = workers or os.cpu_count() or 1
    if kind == "auto":
        kind = "dask" if scheduler else ("process" if n > 1 else "serial")
    if kind == "serial":
        yield SerialExecutor()
    elif kind == "process":
        import multiprocessing

        from replication.threadlimits import limit_worker_blas  # one BLAS thread per worker

        with cf.ProcessPoolExecutor(
            max_workers=n, mp_context=multiprocessing.get_context("spawn"), initializer=limit_worker_blas
        ) as pool:
            yield pool
    else:
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the optional extra
            raise InputError(
                "dask evaluation needs the optional extra: pip install 'replication[dask]'"
            ) from exc
        from replication.casestudy.daskplugin import register as one_blas_thread

        if scheduler:
            with Client(scheduler) as client:
                one_blas_thread(client)
                yield client.get_executor(pure=False)
        else:
            with (
                LocalCluster(
                    n_workers=n,
                    threads_per_worker=1,
                    processes=True,
                    # no dashboard, and the scheduler's HTTP server on a free port: with
                    # dashboard_address=None it still binds the fixed port 8787
                    dashboard_address="127.0.0.1:0",
                    scheduler_kwargs={"dashboard": False},
                ) as cluster,
                Client(cluster) as client,
            ):
                one_blas_thread(client)
                yield client.get_executor(pure=False)
