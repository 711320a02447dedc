"""dask.distributed for fitness evaluations: a named scheduler or a local cluster.

A scheduler named by its address is checked before it is used: a malformed address or an
unknown host is an :class:`~replication.errors.InputError` at once, a refused connection an
:class:`~replication.errors.ExecutorError` at once, and a scheduler that does not answer
within ``CONNECT_TIMEOUT_S`` (dask's own default is 30 s) or answers in another protocol an
ExecutorError too, each in one line. A local cluster's worker processes ignore SIGINT, so
that Ctrl-C in a terminal reaches the parent alone (see :mod:`.interrupts`).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import logging
import socket
from collections.abc import Iterator

from replication.casestudy.interrupts import sigint_ignored_by_children
from replication.errors import ExecutorError, InputError

__all__ = ["CONNECT_TIMEOUT_S", "check_scheduler_address", "dask_executor"]

#: Seconds to wait for a dask scheduler named by its address before giving up.
CONNECT_TIMEOUT_S = 5.0


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
def dask_executor(scheduler: str | None, workers: int) -> Iterator[cf.Executor]:
    """A ``concurrent.futures`` executor on the scheduler at ``scheduler``, or on a local cluster
    of ``workers`` single-threaded worker processes; closed (quietly) on exit."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise InputError("dask evaluation needs the optional extra: pip install 'replication[dask]'") from exc
    if scheduler:
        with _log_levels_restored(), _connect(scheduler) as client:
            yield from _dask_executor(client)
    else:
        with sigint_ignored_by_children():  # the worker processes started now inherit it
            cluster = LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                # no dashboard, and the scheduler's HTTP server on a free port: with
                # dashboard_address=None it still binds the fixed port 8787
                dashboard_address="127.0.0.1:0",
                scheduler_kwargs={"dashboard": False},
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
    from distributed.cfexecutor import ClientExecutor

    from replication.casestudy.daskplugin import register as one_blas_thread

    class DaskExecutor(ClientExecutor):
        """The client's executor, which also tells how many tasks the cluster runs at once."""

        def worker_count(self) -> int:
            return max(1, sum(client.nthreads().values()))

    one_blas_thread(client)
    pool = DaskExecutor(client, pure=False)
    try:
        yield pool
    finally:
        for name in _DASK_LOGGERS:
            logging.getLogger(name).setLevel(logging.CRITICAL)
        pool.shutdown(wait=False)
