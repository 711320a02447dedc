"""A dask worker plugin that gives every worker of a cluster one BLAS thread.

Registered by the GA's dask executor on the clusters it uses (its own local cluster or one
at a scheduler address): the GA's parallelism is one task per worker thread, so BLAS
threads would only compete with the other workers (:mod:`replication.threadlimits`
explains the choice and the measurements). The scheduler hands registered plugins to every
worker that joins later, so a worker that replaces a dead one gets the limit too. dask's
nanny already starts workers with ``OPENBLAS_NUM_THREADS=1`` by default
(``distributed.nanny.pre-spawn-environ``); the plugin does not rely on that configuration,
nor on workers having a nanny.

This module imports ``distributed``: import it only where dask is used.
"""

from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin

from replication.threadlimits import limit_worker_blas

__all__ = ["OneBlasThread", "register"]


class OneBlasThread(WorkerPlugin):
    """Calls :func:`replication.threadlimits.limit_worker_blas` in each worker process.

    Notes
    -----
    Paper section 6: the GA's fitness evaluations, one per worker at a time.
    """

    name = "replication-one-blas-thread"
    idempotent = True  # registering it again (another GA run on the cluster) changes nothing

    def setup(self, worker) -> None:
        limit_worker_blas()


def register(client) -> None:
    """Register :class:`OneBlasThread` on the cluster of a ``distributed.Client``."""
    client.register_plugin(OneBlasThread())
