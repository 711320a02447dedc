"""Dask worker plugins: one BLAS thread per worker, and no simulation outlives its worker.

Registered by the GA's dask executor on the clusters it uses (its own local cluster or one
at a scheduler address): the GA's parallelism is one task per worker thread, so BLAS
threads would only compete with the other workers (:mod:`replication.threadlimits`
explains the choice and the measurements). The scheduler hands registered plugins to every
worker that joins later, so a worker that replaces a dead one gets the limit too. dask's
nanny already starts workers with ``OPENBLAS_NUM_THREADS=1`` by default
(``distributed.nanny.pre-spawn-environ``); the plugin does not rely on that configuration,
nor on workers having a nanny.

A worker whose parent (its nanny, or the command that started a local cluster) dies ends
at once with ``os._exit``, which runs no cleanup: an SPH simulation it was waiting for, a
process in a session of its own, ran on until its time limit (:class:`EngineReaper`).

This module imports ``distributed``: import it only where dask is used.
"""

from __future__ import annotations

import os
import signal

from distributed.diagnostics.plugin import WorkerPlugin

from replication.surfaces._threads import one_thread
from replication.threadlimits import limit_worker_blas

__all__ = ["EngineReaper", "OneBlasThread", "kill_engine_sessions", "register"]


class OneBlasThread(WorkerPlugin):
    """Calls :func:`replication.threadlimits.limit_worker_blas` and
    :func:`replication.surfaces._threads.one_thread` in each worker process.

    Notes
    -----
    Paper section 6: the GA's fitness evaluations, one per worker at a time.
    """

    name = "replication-one-blas-thread"
    idempotent = True  # registering it again (another GA run on the cluster) changes nothing

    def setup(self, worker) -> None:
        limit_worker_blas()
        one_thread()


def kill_engine_sessions() -> None:
    """Kill the process groups of this process's children that lead sessions of their own.

    Those are the SPH engines (:mod:`replication.casestudy.sph.process` starts each in a
    session of its own, so that a Ctrl-C in the terminal does not reach it); nothing else
    that a dask worker starts leads a session.
    """
    import psutil  # a dependency of distributed

    try:
        children = psutil.Process().children()
    except psutil.Error:
        return
    for child in children:
        try:
            if os.getsid(child.pid) == child.pid:
                os.killpg(child.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass


class EngineReaper(WorkerPlugin):
    """Makes the worker kill its simulations' engines when it ends through ``os._exit``.

    distributed ends a worker whose parent has gone with ``os._exit(-1)`` from a thread of
    its own, which runs no ``finally`` and no ``atexit``; the engine, in a session of its
    own, then ran on (up to its time limit, an hour by default) after the command was
    killed. The plugin wraps ``os._exit`` in the worker process so that
    :func:`kill_engine_sessions` runs first. Installed once per process, and only in a
    worker process of its own (a nanny's): a worker running in threads of another program
    (``LocalCluster(processes=False)`` behind ``--scheduler``) leaves that program alone.

    Notes
    -----
    Paper section 6: the GA's SPH fitness evaluations on a dask cluster.
    """

    name = "replication-engine-reaper"
    idempotent = True

    def setup(self, worker) -> None:
        import multiprocessing

        real_exit = os._exit
        if getattr(real_exit, "reaps_engines", False) or multiprocessing.parent_process() is None:
            return

        def _exit(status: int) -> None:
            try:
                kill_engine_sessions()
            finally:
                real_exit(status)

        _exit.reaps_engines = True  # type: ignore[attr-defined]
        os._exit = _exit  # type: ignore[assignment]


def register(client) -> None:
    """Register :class:`OneBlasThread` and :class:`EngineReaper` on the cluster of a
    ``distributed.Client``."""
    client.register_plugin(OneBlasThread())
    client.register_plugin(EngineReaper())
