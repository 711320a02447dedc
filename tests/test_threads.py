"""The kernels' thread pool (replication.surfaces._threads): an interrupted run waits for its
pool threads before it unwinds, since their tasks write into arrays the caller then frees."""

import os
import signal
import threading
import time

import numba
import pytest

from replication.surfaces import _threads


@pytest.fixture
def two_threads():
    before = numba.get_num_threads()
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba allows one thread here")
    numba.set_num_threads(2)
    yield
    numba.set_num_threads(before)


def _tasks(started, finished, interrupt, slow=None):
    """Two tasks whose part depends on the thread that takes them (either may take task 0):
    on the calling thread, wait until the pool thread runs its task, then raise ``interrupt``;
    on the pool thread, take a while (``slow``). Tasks 2.. must then never start."""

    def default_slow():
        started.set()
        time.sleep(0.3)
        finished.set()

    caller = threading.current_thread()  # the thread that will call run()

    def either():
        if threading.current_thread() is caller:
            assert started.wait(5)
            raise interrupt
        (slow or default_slow)()

    def never():
        raise AssertionError("a task started after the run was interrupted")

    return [either, either, never, never]


@pytest.mark.parametrize("interrupt", [KeyboardInterrupt, ValueError("a task failed")])
def test_an_interrupted_run_waits_for_the_task_under_way_and_starts_no_other(two_threads, interrupt):
    started, finished = threading.Event(), threading.Event()
    with pytest.raises(type(interrupt) if isinstance(interrupt, Exception) else interrupt):
        _threads.run(_tasks(started, finished, interrupt))
    assert finished.is_set()  # before: run() returned while the pool thread still worked


def test_a_second_ctrl_c_while_waiting_is_raised_after_the_wait(two_threads):
    started, finished = threading.Event(), threading.Event()

    def slow_and_interrupting():
        started.set()
        time.sleep(0.1)
        os.kill(os.getpid(), signal.SIGINT)  # the main thread is waiting now
        time.sleep(0.3)
        finished.set()

    tasks = _tasks(started, finished, KeyboardInterrupt, slow_and_interrupting)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            _threads.run(tasks)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert finished.is_set()


def test_results_in_task_order(two_threads):
    assert _threads.run([lambda k=k: k * k for k in range(7)]) == [k * k for k in range(7)]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork here")
def test_a_forked_child_starts_a_pool_of_its_own(two_threads):
    """The parent's pool threads are not copied by a fork: the child must not hand its tasks
    to the copied pool (they would never run, and the child would wait for ever)."""
    assert _threads.run([lambda: 1, lambda: 2]) == [1, 2]  # the parent's pool is up
    assert _threads.pool_threads() > 0
    pid = os.fork()
    if pid == 0:  # the child: leave with 0 only if both tasks ran, whatever happens
        code = 1
        try:
            signal.alarm(20)  # a hang ends the child (SIGALRM's default is to exit)
            code = 0 if _threads.run([lambda: 3, lambda: 4]) == [3, 4] else 1
        finally:
            os._exit(code)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        time.sleep(0.05)
    else:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        pytest.fail("the forked child hung in run()")
    assert os.waitstatus_to_exitcode(status) == 0


def test_a_wait_cut_short_after_its_signal_leaves_the_pool_thread_usable():
    """A Ctrl-C that lands just after a wait took the "done" signal, or just before it, is
    waited again; either way the next job's wait must wait for that job, not take an old
    signal for its end (and the thread must not fail releasing a lock that is free)."""
    helper = _threads._Helper()
    try:
        helper.start(lambda: None)
        helper.wait()
        helper._done.release()  # the state a wait interrupted before taking the signal leaves
        finished = threading.Event()

        def slow():
            time.sleep(0.2)
            finished.set()

        helper.start(slow)
        helper.wait()
        assert finished.is_set()
        assert helper.error is None
        helper._done.release()  # again, and now the job ends before the wait begins
        helper.start(lambda: None)
        time.sleep(0.1)
        helper.wait()
        assert helper._thread.is_alive()  # it did not fail releasing its signal
        helper.start(finished.clear)
        helper.wait()
        assert not finished.is_set()
    finally:
        helper.stop()


def test_an_error_in_a_pool_thread_is_raised_by_run(two_threads):
    caller = threading.current_thread()

    def fails_on_the_pool_thread():
        if threading.current_thread() is not caller:
            raise ValueError("failed on the pool thread")
        time.sleep(0.2)  # the pool thread has taken the other task by now

    with pytest.raises(ValueError, match="pool thread"):
        _threads.run([fails_on_the_pool_thread, fails_on_the_pool_thread])
    assert _threads.run([lambda: 1, lambda: 2]) == [1, 2]  # and the pool still works


def test_runs_from_several_threads_at_once_each_get_their_own_results(two_threads):
    outcomes = {}

    def caller(name):
        outcomes[name] = [_threads.run([lambda k=k: (name, k) for k in range(5)]) for _ in range(50)]

    callers = [threading.Thread(target=caller, args=(name,)) for name in "abc"]
    for thread in callers:
        thread.start()
    for thread in callers:
        thread.join()
    for name in "abc":
        assert outcomes[name] == [[(name, k) for k in range(5)]] * 50
    # no pool threads per caller (numba's thread count is per thread: the callers have the default)
    assert _threads.pool_threads() <= numba.config.NUMBA_NUM_THREADS - 1


def test_a_thread_the_system_refuses_leaves_the_run_to_fewer_threads(two_threads, monkeypatch):
    _threads.release()

    def refuse(self, *args, **kwargs):
        raise RuntimeError("can't start new thread")

    monkeypatch.setattr(threading.Thread, "start", refuse)
    assert _threads.run([lambda k=k: k for k in range(4)]) == [0, 1, 2, 3]
    assert _threads.pool_threads() == 0  # counted only once started
    monkeypatch.undo()
    assert _threads.run([lambda k=k: k for k in range(4)]) == [0, 1, 2, 3]
    assert _threads.pool_threads() == 1


@pytest.mark.parametrize("setting", [None, "1", "3", "", "two", "0"])
def test_without_numba_the_count_is_the_one_numba_starts_with(setting, monkeypatch):
    """A process that has not imported numba (the ahead-of-time kernels serve it) splits its
    work as numba would: NUMBA_NUM_THREADS when it is a count, else the CPUs it may run on."""
    import sys

    if setting is None:
        monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    else:
        monkeypatch.setenv("NUMBA_NUM_THREADS", setting)
    monkeypatch.delitem(sys.modules, "numba")  # as if never imported (restored afterwards)
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    expected = int(setting) if setting in ("1", "3") else cpus
    assert _threads.threads() == expected
    monkeypatch.undo()
    assert "numba" in sys.modules
    assert _threads.threads() == numba.get_num_threads()


def test_numba_s_default_is_read_as_numba_reads_it():
    if os.environ.get("NUMBA_NUM_THREADS"):
        pytest.skip("NUMBA_NUM_THREADS is set here")
    assert _threads._numba_default() == numba.config.NUMBA_NUM_THREADS


_LEAKED_COMPILE_LOCKS = """
import threading, time
import llvmlite.binding as llvm
from llvmlite.binding import ffi
from numba.core.compiler_lock import global_compiler_lock
from replication.surfaces import _threads

def leak():  # as Ctrl-C inside a lock's own __enter__ (after its acquire) leaves it
    ffi.lib._lock.__enter__()
    global_compiler_lock.acquire()

def compile_like():  # what a pool thread's compile takes: LLVM's lock, numba's compiler lock
    with global_compiler_lock:
        return llvm.get_process_triple()

leak()
print(_threads.run([compile_like, compile_like]) == [llvm.get_process_triple()] * 2, flush=True)
caller, started = threading.current_thread(), threading.Event()

def either():
    if threading.current_thread() is caller:
        assert started.wait(5)
        leak()
        raise KeyboardInterrupt
    started.set()
    time.sleep(0.2)  # the caller leaks the locks and is interrupted meanwhile
    compile_like()

try:
    _threads.run([either, either])
except KeyboardInterrupt:
    print("interrupted", flush=True)
"""


def test_a_compile_lock_that_an_interrupt_left_held_does_not_hang_the_pool():
    """Ctrl-C during a first, cold compile of the kernels can land inside llvmlite's lock
    between its acquire and its ``with`` block, leaving it held by the main thread: a pool
    thread compiling a kernel then waited for it forever, and the main thread for the pool
    thread (``replication adt`` hung, 1 of 16 tries). Run in a child process, with a timeout."""
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_NUM_THREADS": "2"}
    done = subprocess.run(
        [sys.executable, "-c", _LEAKED_COMPILE_LOCKS], capture_output=True, text=True, timeout=60, env=env
    )
    assert done.returncode == 0 and done.stdout.split() == ["True", "interrupted"], done.stderr
