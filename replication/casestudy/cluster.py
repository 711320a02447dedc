"""dask.distributed for fitness evaluations: a named scheduler or a local cluster.

A scheduler named by its address is checked before it is used: a malformed address or an
unknown host is an :class:`~replication.errors.InputError` at once, a refused connection an
:class:`~replication.errors.ExecutorError` at once, and a scheduler that does not answer
within ``CONNECT_TIMEOUT_S`` (dask's own default is 30 s) or answers in another protocol an
ExecutorError too, each in one line. A local cluster's worker processes ignore SIGINT, so
that Ctrl-C in a terminal reaches the parent alone (see :mod:`.interrupts`).

Ctrl-C (or an error) cancels the evaluations not yet started. On a local cluster, those under
way (an SPH simulation can take minutes) then finish, each into the SPH cache, before the
cluster closes, as on a process pool: closing it at once would kill the workers but leave
their simulations' engine processes (sessions of their own) running. A second Ctrl-C
abandons them: the tasks under way are interrupted in their worker threads (the exception
:class:`AbandonedTask`), so each unwinds as a process-pool worker does on SIGTERM, killing
its engine and removing its scratch directory, and nothing of theirs enters the cache.
Workers that do not unwind within ``ABANDON_GRACE_S`` are killed, then their engines. A
named cluster outlives the command: its simulations under way finish there, into the cache.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import logging
import os
import signal
import socket
import time
from collections.abc import Callable, Iterator

from replication.casestudy.interrupts import sigint_ignored_by_children
from replication.errors import ExecutorError, InputError
from replication.io.atomic import interrupt_deferred
from replication.sigterm import terminating

__all__ = [
    "CONNECT_TIMEOUT_S",
    "check_scheduler_address",
    "check_scheduler_reachable",
    "cluster_threads",
    "dask_executor",
    "require_dask",
]

#: Seconds to wait for a dask scheduler named by its address before giving up.
CONNECT_TIMEOUT_S = 5.0


#: What to install for the dask executor: the extra of this project's checkout, as for SPH
#: (``replication`` on PyPI is another project, so ``pip install 'replication[dask]'`` would
#: install that one).
DASK_HINT = 'dask evaluation needs the optional extra: pip install ".[dask]" in the project\'s checkout'


def require_dask() -> None:
    """Raise an InputError when dask.distributed is not installed (found, not imported: fast)."""
    import importlib.util

    if any(importlib.util.find_spec(name) is None for name in ("dask", "distributed")):
        raise InputError(DASK_HINT)


def check_scheduler_address(scheduler: str) -> str:
    """The resolved address of a dask scheduler (``tcp://host:8786``), or an InputError."""
    try:
        from distributed.comm import resolve_address
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise InputError(DASK_HINT) from exc

    try:
        address = resolve_address(scheduler)  # the syntax, and the host name
        if address.startswith("tcp://"):
            from distributed.comm import get_address_host_port

            port = get_address_host_port(address)[1]
            if not 0 < port < 65536:  # was "Connection refused" for tcp://127.0.0.1:99999
                raise ValueError(f"port {port} is not in 1..65535")
    except (ValueError, OSError) as exc:
        raise InputError(
            f"--scheduler {scheduler!r} is not a dask scheduler address like tcp://host:8786 ({exc})"
        ) from exc
    return address


def check_scheduler_reachable(scheduler: str) -> str:
    """The scheduler's address, after a TCP connection to it (a refused one fails at once).

    Called before a command makes its run directory and prints how to resume the run: an
    unreachable scheduler printed a resume command for a directory it then removed.

    Raises
    ------
    ExecutorError
        Nothing listens at a ``tcp://`` address (other protocols are tried by dask itself).
    """
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
    return address


def cluster_threads(scheduler: str) -> int:
    """The tasks the dask cluster at ``scheduler`` runs at once now: its workers' threads (>= 1).

    Raises
    ------
    ExecutorError
        No dask scheduler answers at ``scheduler``.
    """
    client = _connect(scheduler)
    try:
        return max(1, sum(client.nthreads().values()))
    finally:
        client.close()


def _connect(scheduler: str):  # type: ignore[no-untyped-def]
    """A dask Client of the scheduler at ``scheduler``, or a one-line error quickly."""
    from dask.distributed import Client

    address = check_scheduler_reachable(scheduler)
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as exc:
        raise ExecutorError(
            f"cannot reach a dask scheduler at {scheduler} within {CONNECT_TIMEOUT_S:g} s: is it running, "
            "and is the address right?"
        ) from exc
    except Exception as exc:
        why = " ".join(f"{type(exc).__name__}: {exc}".split())
        if address.startswith("tcp://"):  # the port took a connection: something else listens there
            raise ExecutorError(
                f"no dask scheduler at {scheduler}: something answers there but not in dask's protocol "
                f"({why})"
            ) from exc
        raise ExecutorError(f"cannot connect to a dask scheduler at {scheduler} ({why})") from exc


#: Seconds between two looks at a local cluster's workers while Ctrl-C waits for their tasks.
IDLE_POLL_S = 0.2
#: Seconds the interrupted tasks of a local cluster have to unwind before their workers are killed.
ABANDON_GRACE_S = 5.0


class AbandonedTask(BaseException):
    """Raised in a dask worker's task thread by a second Ctrl-C: the task unwinds (its ``finally``
    blocks kill its engine and remove its scratch files). A BaseException, so that no handler
    of ordinary errors records it as a failed simulation."""


@contextlib.contextmanager
def dask_executor(
    scheduler: str | None, workers: int, on_interrupt: Callable[[], None] | None = None
) -> Iterator[cf.Executor]:
    """A ``concurrent.futures`` executor on the scheduler at ``scheduler``, or on a local cluster
    of ``workers`` single-threaded worker processes; closed (quietly) on exit.

    ``on_interrupt`` is called when Ctrl-C leaves the block of a local cluster, before it waits
    for the tasks under way (see the module notes).
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise InputError(DASK_HINT) from exc
    if scheduler:
        with _log_levels_restored(), _connect(scheduler) as client:
            yield from _dask_executor(client, on_interrupt, local=False)
    else:
        # SIGTERM is held while the cluster and its client are made and closed: raised inside
        # them, it left a worker process that no one closed, and the resource tracker's stop
        # then waited for it for good (replication.sigterm)
        with _log_levels_restored(), contextlib.ExitStack() as closing:
            with sigint_ignored_by_children(), interrupt_deferred():  # the workers started now inherit it
                cluster = LocalCluster(
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=True,
                    # no dashboard, and the scheduler's HTTP server on a free port: with
                    # dashboard_address=None it still binds the fixed port 8787
                    dashboard_address="127.0.0.1:0",
                    scheduler_kwargs={"dashboard": False},
                )
                closing.callback(_held, cluster.close)
                client = Client(cluster)
                closing.callback(_held, client.close)
            yield from _dask_executor(client, on_interrupt, local=True)


def _held(close: Callable[[], object]) -> None:
    """``close()`` with Ctrl-C and SIGTERM held until it returns."""
    with interrupt_deferred():
        close()


_DASK_LOGGERS = ("distributed", "tornado")


def _dask_loggers() -> list[logging.Logger]:
    """dask's and tornado's loggers, with every child that exists: distributed's configuration
    gives some their own level (``tornado.application``: ERROR, under ``tornado``: CRITICAL),
    which quietening the parent does not touch."""
    names = {name for name in logging.root.manager.loggerDict if name.split(".")[0] in _DASK_LOGGERS}
    return [logging.getLogger(name) for name in sorted(names | set(_DASK_LOGGERS))]


class _CancelledFutureFilter(logging.Filter):
    """Drops tornado's report of an executor callback that found its future cancelled.

    The dispatcher cancels the evaluations in flight when Ctrl-C stops a batch (before the
    executor is closed); the client's event loop then runs the executor's callbacks, whose
    ``FutureCancelledError`` tornado logs on ``tornado.application`` with a traceback. An
    evaluation that finished just as its future was cancelled fails the same way with
    ``InvalidStateError: CANCELLED: <Future ...>`` (the executor hands the result to a
    future that no longer takes one; seen once in a full test run). A future cancelled on
    purpose is not news; every other error still shows.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        error = record.exc_info[1] if record.exc_info else None
        if isinstance(error, cf.InvalidStateError):  # "CANCELLED: ..." or "CANCELLED_AND_NOTIFIED: ..."
            return not str(error).startswith("CANCELLED")
        return not isinstance(error, cf.CancelledError)  # distributed's FutureCancelledError is one


@contextlib.contextmanager
def _log_levels_restored() -> Iterator[None]:
    """The levels of dask's and tornado's loggers as they were (NOTSET for loggers made since);
    meanwhile tornado does not report cancelled futures (:class:`_CancelledFutureFilter`)."""
    levels = {logger.name: logger.level for logger in _dask_loggers()}
    callbacks, cancelled = logging.getLogger("tornado.application"), _CancelledFutureFilter()
    callbacks.addFilter(cancelled)
    try:
        yield
    finally:
        callbacks.removeFilter(cancelled)
        for logger in _dask_loggers():
            logger.setLevel(levels.get(logger.name, logging.NOTSET))


def _dask_executor(client, on_interrupt, *, local: bool) -> Iterator[cf.Executor]:  # type: ignore[no-untyped-def]
    """The client's executor; on exit pending evaluations are cancelled and the teardown is quiet.

    After Ctrl-C a local cluster waits for the tasks under way (a second Ctrl-C abandons
    them, :func:`_abandon_local`). What dask and tornado log from the cancellation on, while
    the client and cluster close (cancelled futures, connections closed, results that cannot
    be gathered), is not shown: nobody waits for those results any more. The levels are
    restored by :func:`_log_levels_restored` once everything is closed.
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
    except (Exception, KeyboardInterrupt) as exc:
        # quiet from here: cancelling makes the executor's callbacks on the client's event
        # loop fail with FutureCancelledError, which tornado logs with a traceback, at once
        # or a moment later
        _quiet()
        try:
            client.cancel(list(pool._futures))  # the evaluations not started never start
            if local and terminating():  # SIGTERM does not wait for the tasks under way
                raise KeyboardInterrupt
            if local:
                if on_interrupt is not None and isinstance(exc, KeyboardInterrupt):
                    on_interrupt()
                _wait_until_idle(client)
        except KeyboardInterrupt:  # Ctrl-C (again): abandon the tasks under way
            if local:
                _abandon_local(client)
            raise
        raise
    else:
        if local:
            _quiet_workers(client)
    finally:
        _quiet()
        pool.shutdown(wait=False)


def _quiet_workers(client) -> None:  # type: ignore[no-untyped-def]
    """The local cluster's workers log nothing below CRITICAL either, before it closes.

    Closing a local cluster races the workers' heartbeats: on a loaded machine a worker
    whose heartbeat met the closed scheduler logged "Failed to communicate with scheduler
    during heartbeat" with a traceback, on the command's stderr, after every result was in.
    Only on a normal exit (after an error or Ctrl-C a worker may not answer) and only for a
    local cluster (a user's scheduler and its workers are left as they are).
    """
    try:
        client.run(_quiet, on_error="ignore")
    except Exception:  # the cluster cannot be asked: it has nothing more to say either
        pass


def _quiet() -> None:
    """dask's and tornado's loggers show nothing below CRITICAL (restored by
    :func:`_log_levels_restored`)."""
    for logger in _dask_loggers():
        logger.setLevel(logging.CRITICAL)


def running_tasks(dask_worker) -> int:  # type: ignore[no-untyped-def]
    """Tasks that occupy a thread of ``dask_worker``, cancelled ones still running included
    (``client.run`` calls it in every worker)."""
    return len(dask_worker.state.all_running_tasks)


def _wait_until_idle(client, poll: float = IDLE_POLL_S, deadline: float | None = None) -> bool:  # type: ignore[no-untyped-def]
    """Return True once no worker of the cluster runs a task (seen twice in a row, so that a task
    handed to a worker just before the cancellation is not missed); False at ``deadline``
    (``time.monotonic()``). A worker that does not answer (gone) is not waited for; a
    cluster that cannot be asked at all has nothing left to wait for."""
    idle = 0
    while True:
        try:
            answers = client.run(running_tasks, on_error="return")
        except Exception:  # the scheduler or the client is gone
            return True
        busy = sum(n for n in answers.values() if isinstance(n, int))
        idle = idle + 1 if not busy else 0
        if idle >= 2:
            return True
        if deadline is not None and time.monotonic() >= deadline:
            return False
        time.sleep(poll)


def abandon_tasks(dask_worker) -> int:  # type: ignore[no-untyped-def]
    """Raise :class:`AbandonedTask` in every thread of ``dask_worker`` that runs a task; return
    how many (``client.run`` calls it in every worker). The exception is raised when the
    thread next runs Python code: a simulation's wait loop polls every 0.1 s."""
    import ctypes

    with dask_worker.active_threads_lock:
        threads = list(dask_worker.active_threads)
    raised = 0
    for ident in threads:
        raised += ctypes.pythonapi.PyThreadState_SetAsyncExc(
            ctypes.c_ulong(ident), ctypes.py_object(AbandonedTask)
        )
    return raised


def _abandon_local(client, grace: float | None = None) -> None:  # type: ignore[no-untyped-def]
    """End the tasks under way on the local cluster: interrupt them (:func:`abandon_tasks`), and
    if they have not unwound after ``grace`` seconds (default ``ABANDON_GRACE_S``), kill their
    workers (a task blocked in C code cannot be interrupted), then the engines
    their simulations ran (sessions of their own, which no signal to the cluster reaches).

    A killed worker writes nothing more into the SPH cache: a simulation enters the cache
    only when its worker renames the finished scratch directory (:mod:`.sph_batch`), so the
    workers die first (a worker that outlived its engine would record a crash). Killed
    workers are left for their nannies to reap; their engines, reparented, for the system.
    """
    import psutil

    try:
        client.run(abandon_tasks, on_error="return")
        if _wait_until_idle(
            client, deadline=time.monotonic() + (ABANDON_GRACE_S if grace is None else grace)
        ):
            return
        pids = [pid for pid in client.run(os.getpid, on_error="return").values() if isinstance(pid, int)]
    except Exception:  # the workers are out of reach: nothing here to kill
        return
    workers, engines = [], []
    for pid in pids:
        with contextlib.suppress(psutil.Error):
            worker = psutil.Process(pid)
            engines += worker.children(recursive=True)
            workers.append(worker)
    groups = [engine.pid for engine in engines if _leads_its_group(engine.pid)]
    for process in workers + engines:
        with contextlib.suppress(psutil.Error):
            process.kill()
    for pgid in groups:  # and whatever an engine started in its session
        with contextlib.suppress(OSError):
            os.killpg(pgid, signal.SIGKILL)


def _leads_its_group(pid: int) -> bool:
    try:
        return os.getpgid(pid) == pid
    except OSError:
        return False
