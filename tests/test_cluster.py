"""The dask executor's teardown after Ctrl-C or an error: quiet from the cancellation on.

Cancelling the evaluations makes the executor's callbacks on the client's event loop fail
with ``FutureCancelledError``, which tornado logs with a traceback on ``tornado.application``.
distributed's configuration gives that logger a level of its own (ERROR), so quietening
``tornado`` did not silence it, and a Ctrl-C printed the traceback whenever the loop ran a
callback before closing (seen intermittently in ``test_interrupts``). The dispatcher also
cancels the evaluations in flight itself, before the executor's teardown begins, so tornado's
report of a cancelled future is dropped for as long as the executor is open. Here a fake
client logs those errors synchronously: the worst timing, deterministic.
"""

import logging
import sys

import pytest

pytest.importorskip("distributed")

from replication.casestudy import cluster  # noqa: E402


class FakeClient:
    """What ``_dask_executor`` uses of a ``distributed.Client``; ``cancel`` logs as tornado would."""

    loop = None

    def __init__(self):
        self.cancelled = []
        self.ran = []

    def run(self, function, on_error="raise"):
        self.ran.append(function)

    def register_plugin(self, plugin):
        pass

    def nthreads(self):
        return {"worker": 1}

    def cancel(self, futures):
        self.cancelled.append(futures)
        tornado = logging.getLogger("tornado.application")
        tornado.error("Exception in callback\nTraceback (most recent call last)")
        logging.getLogger("distributed.client").error("cancelled for reason: unknown")


class Recorder(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.records = []

    def emit(self, record):
        self.records.append(record)


@pytest.mark.parametrize("error", [KeyboardInterrupt, RuntimeError], ids=["ctrl-c", "error"])
@pytest.mark.parametrize("local", [False, True], ids=["scheduler", "local"])
def test_cancellation_logs_nothing_and_levels_are_restored(monkeypatch, error, local):
    monkeypatch.setattr(cluster, "_wait_until_idle", lambda client: True)
    recorder = Recorder()
    root = logging.getLogger()
    root.addHandler(recorder)
    client = FakeClient()
    said = []
    try:
        with pytest.raises(error), cluster._log_levels_restored():
            executor = cluster._dask_executor(client, lambda: said.append("stopping"), local=local)
            pool = next(executor)
            assert pool.worker_count() == 1
            assert logging.getLogger("tornado.application").isEnabledFor(logging.ERROR)  # as configured
            try:
                executor.throw(error())
            except StopIteration:  # pragma: no cover - the generator must re-raise
                pytest.fail("the executor swallowed the exception")
    finally:
        root.removeHandler(recorder)
    assert client.cancelled, "the pending evaluations were not cancelled"
    assert [r.getMessage() for r in recorder.records if r.levelno < logging.CRITICAL] == []
    assert said == (["stopping"] if local and error is KeyboardInterrupt else [])
    assert logging.getLogger("tornado.application").isEnabledFor(logging.ERROR)  # restored after


def _cancelled_error():
    from distributed.client import FutureCancelledError

    try:
        raise FutureCancelledError("evaluate_chunk-1", reason="unknown")
    except FutureCancelledError:
        return sys.exc_info()


def test_a_future_cancelled_while_the_executor_is_open_is_not_reported(monkeypatch):
    """The dispatcher's own ``future.cancel()`` on Ctrl-C comes before any teardown."""
    recorder = Recorder()
    callbacks = logging.getLogger("tornado.application")
    callbacks.addHandler(recorder)
    try:
        with cluster._log_levels_restored():
            executor = cluster._dask_executor(FakeClient(), None, local=False)
            next(executor)
            callbacks.error("Exception in callback", exc_info=_cancelled_error())  # dropped
            callbacks.error("Exception in callback", exc_info=(RuntimeError, RuntimeError("news"), None))
            executor.close()
        callbacks.error("Exception in callback", exc_info=_cancelled_error())  # the filter is gone
    finally:
        callbacks.removeHandler(recorder)
    shown = [record.exc_info[0].__name__ for record in recorder.records]
    assert shown == ["RuntimeError", "FutureCancelledError"]


@pytest.mark.parametrize("local", [False, True], ids=["scheduler", "local"])
def test_a_local_clusters_workers_are_quietened_before_it_closes(local):
    """Closing a local cluster raced its workers' heartbeats: a loaded machine printed a
    worker's "Failed to communicate with scheduler during heartbeat" after a finished run."""
    client = FakeClient()
    with cluster._log_levels_restored():
        executor = cluster._dask_executor(client, None, local=local)
        next(executor)
        with pytest.raises(StopIteration):  # the block ended normally
            next(executor)
    assert client.ran == ([cluster._quiet] if local else [])  # a user's own workers are left alone


def _record(error):
    try:
        raise error
    except Exception:
        info = sys.exc_info()
    return logging.LogRecord("tornado.application", logging.ERROR, __file__, 1, "callback", None, info)


def test_the_teardown_filter_drops_the_results_that_reach_cancelled_futures_only():
    """A task that finishes as Ctrl-C cancels its future makes the executor's callback fail with
    InvalidStateError('CANCELLED: ...'); other states and other errors still show."""
    import concurrent.futures as cf

    from distributed.client import FutureCancelledError

    keep = cluster._CancelledFutureFilter().filter
    future = cf.Future()
    future.cancel()
    with pytest.raises(cf.InvalidStateError) as cancelled:
        future.set_result(1)  # what distributed.cfexecutor._cascade_future runs into
    assert not keep(_record(cancelled.value))
    assert not keep(_record(FutureCancelledError("key", "cancelled")))
    done = cf.Future()
    done.set_result(1)
    with pytest.raises(cf.InvalidStateError) as finished:
        done.set_result(2)  # a result set twice is a real bug: it shows
    assert keep(_record(finished.value))
    assert keep(_record(RuntimeError("CANCELLED")))
