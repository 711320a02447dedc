"""Ctrl-C during a GA run, for real: SIGINT to a running ``replication casestudy`` process group.

Each run is interrupted at its own moment (a few milliseconds after a given generation was
checkpointed, so inside the next generation's evaluations, most of whose time is spent in the
compiled jet kernel), must stop with exit status 130, keep its last complete checkpoint with
no failure recorded, and, resumed, end bit-identical to an uninterrupted run.
"""

import concurrent.futures as cf
import contextlib
import functools
import json
import os
import shlex
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from replication.casestudy.evaluate import executor
from replication.casestudy.ga import GAConfig
from replication.casestudy.runner import run_ga
from workerfaults import assert_no_process_left

CONFIG = GAConfig(runs=1, generations=12, population=12)
ARGS = ["--runs", "1", "--generations", "12", "--population", "12"]
serial = functools.partial(executor, "serial")


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("uninterrupted")
    run_ga(CONFIG, 0, run_dir=run_dir, pool_factory=serial)
    return _state(run_dir)


def _state(run_dir):
    state = json.loads((run_dir / "run-0.json").read_text())
    state.pop("seconds")  # wall-clock times are not state
    return state


def _generation(run_dir):
    try:
        return json.loads((run_dir / "run-0.json").read_text())["generation"]
    except (OSError, ValueError):
        return 0


#: ``python -m replication`` named as the console script (its messages say "replication").
#: Its SIGINT handler is Python's own, as from a terminal, even in a test session started in
#: the background: conftest's ``pytest_configure`` restores it in every test process.
AS_FROM_A_TERMINAL = (
    "import runpy, sys; "
    "sys.argv[0] = 'replication'; runpy.run_module('replication', run_name='__main__', alter_sys=True)"
)


def _interrupt(run_dir, executor_args, after_generation, delay, timeout=120, sig=signal.SIGINT):
    """Start a GA run, press Ctrl-C (SIGINT to its process group) at the given moment; or send
    SIGTERM to the command alone, as ``kill PID`` or a supervisor's stop does."""
    process = subprocess.Popen(
        [sys.executable, "-c", AS_FROM_A_TERMINAL, "casestudy", *ARGS, *executor_args,
         "--run-dir", str(run_dir)],
        cwd=run_dir.parent, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip

    def press_ctrl_c():
        deadline = time.monotonic() + timeout
        while _generation(run_dir) < after_generation and process.poll() is None:
            if time.monotonic() > deadline:
                break
            time.sleep(0.002)
        time.sleep(delay)
        if process.poll() is None:
            if sig == signal.SIGINT:
                os.killpg(process.pid, sig)
            else:
                os.kill(process.pid, sig)

    presser = threading.Thread(target=press_ctrl_c)
    presser.start()
    return process, presser


def _check_stopped(process, presser, run_dir, timeout=180, status=130, said="interrupted"):
    out, err = process.communicate(timeout=timeout)
    presser.join()
    assert process.returncode == status, err
    with pytest.raises(ProcessLookupError):  # no worker, cluster or resource tracker is left behind
        os.killpg(process.pid, 0)
    assert "Traceback" not in err and err.rstrip().endswith(f"replication casestudy: {said}"), err
    assert not list(run_dir.glob(".*.tmp*"))  # no temporary of a write cut short
    hint = f"resume with: replication casestudy --run-dir {shlex.quote(str(run_dir))} --resume"  # as printed
    assert hint in err, err
    state = _state(run_dir)
    assert 1 <= state["generation"] < CONFIG.generations
    assert state["failures"] == [] and all(f is not None for f in state["fitness"])
    return state


#: (executor options, generation after whose checkpoint Ctrl-C is pressed, delay in seconds)
CASES = {
    "serial-1": (["--executor", "serial"], 1, 0.0),
    "serial-2": (["--executor", "serial"], 1, 0.013),
    "serial-3": (["--executor", "serial"], 2, 0.029),
    "serial-4": (["--executor", "serial"], 3, 0.007),
    "process": (["--executor", "process", "--workers", "1"], 2, 0.01),
    "dask": (["--executor", "dask", "--workers", "1"], 2, 0.01),
}
#: SIGTERM to the command alone: the same stop, without waiting, exit status 143.
TERMINATED = {
    "sigterm-serial": (["--executor", "serial"], 2, 0.01),
    "sigterm-process": (["--executor", "process", "--workers", "2"], 2, 0.01),
}


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    """Every case started at once (each is pressed at its own moment); their run directories."""
    base = tmp_path_factory.mktemp("interrupted")
    cases = {name: case for name, case in CASES.items() if name != "dask" or _has_dask()}
    started = {name: (base / name, *_interrupt(base / name, *case)) for name, case in cases.items()}
    for name, case in TERMINATED.items():
        started[name] = (base / name, *_interrupt(base / name, *case, sig=signal.SIGTERM))
    yield started
    for _, process, presser in started.values():  # after a failed check: stop what still runs
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        process.communicate()  # closes the pipes of a case whose test did not run, too
        presser.join()


def _has_dask():
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.parametrize("name", [n for n in CASES if n.startswith("serial")])
def test_ctrl_c_in_a_serial_run(interrupted, uninterrupted, name):
    run_dir, process, presser = interrupted[name]
    _check_stopped(process, presser, run_dir)
    run_ga(CONFIG, 0, run_dir=run_dir, pool_factory=serial, resume=True)
    assert _state(run_dir) == uninterrupted


@pytest.mark.parametrize("name", ["process", "dask"])
def test_ctrl_c_with_worker_processes(interrupted, uninterrupted, name):
    """Ctrl-C reaches the workers too (one process group): still no failure, a clean stop."""
    if name not in interrupted:
        pytest.skip("dask is not installed")
    run_dir, process, presser = interrupted[name]
    _check_stopped(process, presser, run_dir)
    run_ga(CONFIG, 0, run_dir=run_dir, pool_factory=serial, resume=True)
    assert _state(run_dir) == uninterrupted


@pytest.mark.parametrize("name", list(TERMINATED))
def test_sigterm_stops_a_run_as_ctrl_c_does_and_it_resumes_identically(interrupted, uninterrupted, name):
    """``kill PID`` used to end the command on the spot: no resume line, a write's temporary left."""
    run_dir, process, presser = interrupted[name]
    _check_stopped(process, presser, run_dir, status=143, said="terminated (SIGTERM)")
    run_ga(CONFIG, 0, run_dir=run_dir, pool_factory=serial, resume=True)
    assert _state(run_dir) == uninterrupted


@pytest.mark.slow
@pytest.mark.skipif(not _has_dask(), reason="dask is not installed")
def test_sigterm_while_a_local_cluster_starts_ends_the_command(tmp_path):
    """SIGTERM inside LocalCluster(...) left a worker that nobody closed, and the command waited
    for it for good (the resource tracker's stop)."""
    command = [sys.executable, "-c", AS_FROM_A_TERMINAL, "casestudy", *ARGS, "--executor", "dask",
               "--workers", "1", "--run-dir", str(tmp_path / "run")]  # fmt: skip
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    process = subprocess.Popen(command, cwd=tmp_path, start_new_session=True, **pipes)
    try:
        assert _wait_for(lambda: any("spawn_main" in line for line in _children(process.pid)), seconds=120)
        process.send_signal(signal.SIGTERM)  # the command alone, while its cluster starts
        _, err = process.communicate(timeout=60)
        assert process.returncode == 143 and err.rstrip().endswith("terminated (SIGTERM)"), err
        assert_no_process_left(process.pid)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.communicate(timeout=30)


def _children(pid):
    """The command lines of the processes ``pid`` started."""
    import psutil

    lines = []
    with contextlib.suppress(psutil.Error):
        for child in psutil.Process(pid).children(recursive=True):
            with contextlib.suppress(psutil.Error):
                lines.append(" ".join(child.cmdline()))
    return lines


_TERMINATED_AT_THE_FORK = """
import os, signal, sys, time
from replication.sigterm import sigterm_interrupts
from replication.casestudy.evaluate import executor

try:
    with sigterm_interrupts(), executor("process", workers=2) as pool:
        pool.submit(time.sleep, 1)
        os.kill(os.getpid(), signal.SIGTERM)  # while the workers start
        time.sleep(30)
except KeyboardInterrupt as exc:
    print(type(exc).__name__)
"""


def test_sigterm_while_workers_start_is_taken_once_and_leaves_them_quiet():
    """A forked worker kept the parent's SIGTERM handler: it printed an 'Exception in initializer'
    traceback when its pool was abandoned."""
    done = subprocess.run([sys.executable, "-c", _TERMINATED_AT_THE_FORK], capture_output=True, text=True,
                          timeout=60, start_new_session=True)  # fmt: skip
    assert done.stdout == "Terminated\n" and "Traceback" not in done.stderr, done.stderr


_SIMULATING = """
import os, signal, sys, time
sys.path.insert(0, sys.argv[3])
import workerfaults
from replication.casestudy.evaluate import executor

run_dir = sys.argv[1]
with executor(sys.argv[4], workers=1, on_interrupt=lambda: print("stopping", flush=True)) as pool:
    future = pool.submit(workerfaults.sleeping_simulation, run_dir, float(sys.argv[2]))
    while not os.path.exists(os.path.join(run_dir, "pid")):
        time.sleep(0.02)
    raise KeyboardInterrupt  # Ctrl-C while a simulation is under way
"""

#: The same, as the GA evaluates: through the dispatcher that owns the executor
#: (``replication casestudy --solver sph``). Its executor was closed as if nothing had happened:
#: the command waited for the simulation without saying so, and did not abandon it when told to
#: terminate. ``argv[5]``: "interrupt" (Ctrl-C once the simulation runs, as the GA's guard
#: reports it) or "terminate" (say "started" once, then wait for a SIGTERM from outside).
_IN_THE_GA = """
import functools, os, sys
sys.path.insert(0, sys.argv[3])
import numpy as np
import workerfaults
from replication.casestudy.dispatch import Dispatcher
from replication.casestudy.evaluate import executor
from replication.sigterm import sigterm_interrupts

run_dir, mode = sys.argv[1], sys.argv[5]
say = lambda: print("stopping" if mode == "interrupt" else "waiting", flush=True)
factory = functools.partial(executor, sys.argv[4], workers=1, on_interrupt=say)
fitness = functools.partial(workerfaults.sleeping_fitness, run_dir, float(sys.argv[2]))
said = []

def started():  # polled while the dispatcher waits
    running = os.path.exists(os.path.join(run_dir, "pid"))
    if mode == "interrupt":
        return running
    if running and not said:
        print("started", flush=True)
        said.append(True)
    return False

with sigterm_interrupts(), Dispatcher(factory) as dispatcher:
    dispatcher.evaluate(fitness, [np.zeros(3)], interrupted=started)
"""

#: Where the interrupted simulation runs: a process pool, and a local dask cluster if installed.
SIMULATION_EXECUTORS = ["process", pytest.param("dask", marks=pytest.mark.skipif(
    not _has_dask(), reason="dask is not installed"))]  # fmt: skip

#: How it is reached: the executor itself, or the GA's dispatcher that owns it.
SIMULATION_CALLERS = {"executor": _SIMULATING, "GA dispatcher": _IN_THE_GA}

#: (executor, caller) pairs: both executors directly, and the dispatcher on a process pool. The
#: dispatcher's part is to hand the exception to the executor's context, whichever it is; what
#: the dask context then does is the executor cases' (a local cluster costs seconds to start).
SIMULATION_CASES = [
    pytest.param("process", "executor"),
    pytest.param(
        "dask", "executor", marks=pytest.mark.skipif(not _has_dask(), reason="dask is not installed")
    ),
    pytest.param("process", "GA dispatcher"),
]


def _interrupted_simulation(tmp_path, seconds, kind, caller="executor"):
    script = SIMULATION_CALLERS[caller]
    process = subprocess.Popen(
        [sys.executable, "-c", script, str(tmp_path), str(seconds), str(Path(__file__).parent), kind,
         "interrupt"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    lines = []
    reader = threading.Thread(target=lambda: lines.append(process.stdout.readline()), daemon=True)
    reader.start()
    reader.join(timeout=60)  # never wait for ever on a child that does not get that far
    if lines != ["stopping\n"]:  # said before the pool waits
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        _, err = process.communicate(timeout=60)
        pytest.fail(f"the command did not say that it stops: {lines}, stderr: {err[-2000:]}")
    return process


@pytest.mark.slow
@pytest.mark.parametrize(("kind", "caller"), SIMULATION_CASES)
def test_ctrl_c_lets_a_simulation_under_way_finish(tmp_path, kind, caller):
    """On a local dask cluster too: closing it at once used to orphan the engine, which ran on."""
    process = _interrupted_simulation(tmp_path, 2.0, kind, caller)
    driver = int((tmp_path / "pid").read_text())
    _, err = process.communicate(timeout=60)
    assert "KeyboardInterrupt" in err and (tmp_path / "finished").exists()
    assert _reaped(driver)
    assert_no_process_left(process.pid)


def _reaped(pid):
    """Whether ``pid`` has ended and been reaped: its worker waited for it (not even a zombie is
    left, as an engine orphaned by a killed worker would be until init reaps it)."""
    import psutil

    return not psutil.pid_exists(pid)


@pytest.mark.slow
@pytest.mark.parametrize(("kind", "caller"), SIMULATION_CASES)
def test_ctrl_c_again_abandons_the_simulation_under_way_and_leaves_no_process(tmp_path, kind, caller):
    process = _interrupted_simulation(tmp_path, 600.0, kind, caller)
    driver = int((tmp_path / "pid").read_text())
    try:
        time.sleep(0.5)  # the pool is waiting for the simulation
        started = time.monotonic()
        process.send_signal(signal.SIGINT)  # Ctrl-C again
        _, err = process.communicate(timeout=60)
        assert time.monotonic() - started < 30 and "KeyboardInterrupt" in err
        assert not (tmp_path / "finished").exists()
        assert _reaped(driver)  # killed on the way out by its worker, though a session of its own
        assert_no_process_left(process.pid)
    finally:  # a failure leaves no sleeping driver behind, nor open pipes for a later test to trip on
        for pid, kill in ((driver, os.kill), (process.pid, os.killpg)):
            with contextlib.suppress(ProcessLookupError, PermissionError):
                kill(pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.communicate(timeout=30)


_TERMINATED_WHILE_SIMULATING = """
import os, sys, time
sys.path.insert(0, sys.argv[3])
import workerfaults
from replication.casestudy.evaluate import executor
from replication.sigterm import sigterm_interrupts

run_dir = sys.argv[1]
waiting = lambda: print("waiting", flush=True)
with sigterm_interrupts(), executor(sys.argv[4], workers=1, on_interrupt=waiting) as pool:
    future = pool.submit(workerfaults.sleeping_simulation, run_dir, float(sys.argv[2]))
    while not os.path.exists(os.path.join(run_dir, "pid")):
        time.sleep(0.02)
    print("started", flush=True)
    future.result()
"""


TERMINATED_CALLERS = {"executor": _TERMINATED_WHILE_SIMULATING, "GA dispatcher": _IN_THE_GA}


@pytest.mark.slow
@pytest.mark.parametrize(("kind", "caller"), SIMULATION_CASES)
def test_sigterm_abandons_the_simulation_under_way_at_once(tmp_path, kind, caller):
    """Ctrl-C lets a simulation under way finish (minutes); a command told to terminate does not wait."""
    process = subprocess.Popen(
        [sys.executable, "-c", TERMINATED_CALLERS[caller], str(tmp_path), "600", str(Path(__file__).parent),
         kind, "terminate"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    driver = None
    try:
        lines = []
        reader = threading.Thread(target=lambda: lines.append(process.stdout.readline()), daemon=True)
        reader.start()
        reader.join(timeout=60)
        assert lines == ["started\n"], process.stderr.read() if process.poll() is not None else lines
        driver = int((tmp_path / "pid").read_text())
        started = time.monotonic()
        process.send_signal(signal.SIGTERM)  # to the command alone
        out, err = process.communicate(timeout=60)
        assert time.monotonic() - started < 30 and "Terminated" in err and "waiting" not in out, err
        assert not (tmp_path / "finished").exists()
        assert _reaped(driver)  # killed on the way out by its worker, though a session of its own
        assert_no_process_left(process.pid)
    finally:
        for pid, kill in ((driver, os.kill), (process.pid, os.killpg)):
            if pid is not None:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    kill(pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.communicate(timeout=30)


_BLOCKED_ON_DASK = """
import os, signal, sys, time
sys.path.insert(0, sys.argv[2])
import workerfaults
from replication.casestudy import cluster
from replication.casestudy.evaluate import executor

cluster.ABANDON_GRACE_S = 1.0
marker = os.path.join(sys.argv[1], "blocked")
with executor("dask", workers=1, on_interrupt=lambda: print("stopping", flush=True)) as pool:
    future = pool.submit(workerfaults.blocked_in_c, marker, 600.0)
    while not (os.path.exists(marker) and open(marker).read()):
        time.sleep(0.02)
    raise KeyboardInterrupt
"""


@pytest.mark.slow
@pytest.mark.skipif(not _has_dask(), reason="dask is not installed")
def test_ctrl_c_again_kills_a_dask_worker_whose_task_does_not_unwind(tmp_path):
    process = subprocess.Popen(
        [sys.executable, "-c", _BLOCKED_ON_DASK, str(tmp_path), str(Path(__file__).parent)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    try:
        lines = []
        reader = threading.Thread(target=lambda: lines.append(process.stdout.readline()), daemon=True)
        reader.start()
        reader.join(timeout=60)
        assert lines == ["stopping\n"]
        time.sleep(0.5)  # waiting for the task, which sleeps in C for 600 s
        started = time.monotonic()
        process.send_signal(signal.SIGINT)  # Ctrl-C again
        _, err = process.communicate(timeout=60)
        assert time.monotonic() - started < 30 and "KeyboardInterrupt" in err
        assert_no_process_left(process.pid)
        engine = int((tmp_path / "blocked").read_text())
        assert not _alive(engine)  # the engine-like child, in a session of its own, was killed too
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        with contextlib.suppress(ProcessLookupError, ValueError, FileNotFoundError):
            os.killpg(int((tmp_path / "blocked").read_text()), signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):  # its pipes closed, whatever failed
            process.communicate(timeout=30)


def _alive(pid):
    """Whether ``pid`` runs (a zombie does not: an orphan killed with its worker waits for
    init to reap it)."""
    import psutil

    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def test_abandoning_a_pool_kills_a_worker_that_does_not_unwind(tmp_path):
    import concurrent.futures as cf
    import multiprocessing

    import workerfaults
    from replication.casestudy.evaluate import _abandon

    marker = tmp_path / "deaf"
    pool = cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
    future = pool.submit(workerfaults.deaf_to_sigterm, str(marker), 600.0)
    deadline = time.monotonic() + 60
    while not marker.exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    assert marker.exists()  # the worker ignores SIGTERM now
    processes = list(pool._processes.values())
    started = time.monotonic()
    _abandon(pool, grace=0.5)
    assert time.monotonic() - started < 20
    assert [_exit_code(p) for p in processes] == [-signal.SIGKILL]  # killed after the grace, not left running
    with pytest.raises(cf.process.BrokenProcessPool):
        future.result(timeout=20)


def test_abandoning_a_pool_with_cancelled_calls_prints_no_traceback(tmp_path):
    """The dispatcher cancels the calls it has not started before the pool is abandoned; the
    pool's manager thread, told that a killed worker broke the pool, then set an exception on
    those cancelled futures: before CPython 3.12 it died printing 'Exception in thread' and an
    InvalidStateError traceback on the command's stderr (seen once after SIGTERM in the GA).
    pytest reports an exception of any thread as an error of the test (warnings are errors)."""
    import concurrent.futures as cf
    import multiprocessing

    import workerfaults
    from replication.casestudy.evaluate import _abandon

    marker = tmp_path / "deaf"
    pool = cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
    futures = [pool.submit(workerfaults.deaf_to_sigterm, str(marker), 600.0)]
    futures += [pool.submit(time.sleep, 0) for _ in range(4)]
    deadline = time.monotonic() + 60
    while not marker.exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    assert marker.exists()  # the worker ignores SIGTERM: it is killed without an answer
    assert [f.cancel() for f in futures] == [False, False, True, True, True]  # two are in its queue
    manager, hook = pool._executor_manager_thread, threading.excepthook
    _abandon(pool, grace=0.5)
    assert not manager.is_alive() and threading.excepthook is hook  # ended, and the hook restored
    with pytest.raises(cf.process.BrokenProcessPool):
        futures[0].result(timeout=20)


def test_the_manager_thread_filter_hides_nothing_else():
    """Only the cancelled-future error of the pool's manager thread is kept quiet, and the hook is
    restored once that thread has ended."""
    import concurrent.futures as cf

    from replication.casestudy.evaluate import _cancelled_futures_quiet

    def raising(error):
        raise error

    def thread(error, name):
        return threading.Thread(target=raising, args=(error,), name=name)

    seen = []
    previous = threading.excepthook

    def record(args):
        seen.append((args.thread.name, args.exc_type))

    threading.excepthook = record
    try:
        for manager, others in (
            (thread(cf.InvalidStateError("CANCELLED"), "manager"),
             [thread(cf.InvalidStateError("CANCELLED"), "another thread")]),
            (thread(RuntimeError("boom"), "a manager that fails otherwise"), []),
        ):  # fmt: skip
            with _cancelled_futures_quiet(manager):
                for each in (manager, *others):
                    each.start()
                    each.join()
            assert threading.excepthook is record
        assert seen == [
            ("another thread", cf.InvalidStateError),
            ("a manager that fails otherwise", RuntimeError),
        ]
    finally:
        threading.excepthook = previous


def test_an_abandoned_worker_ends_once_its_task_has_unwound(tmp_path):
    """A pool's worker loop takes the SystemExit of SIGTERM for its task's result and takes the
    next call: workers went on to queued work, or waited for more, until killed after the grace
    (5 s on every second Ctrl-C). They now end by themselves, and start nothing else."""
    import concurrent.futures as cf

    import workerfaults
    from replication.casestudy.evaluate import _abandon, worker_initializer
    from replication.casestudy.interrupts import quiet_worker_context

    pool = cf.ProcessPoolExecutor(
        2, mp_context=quiet_worker_context(), initializer=worker_initializer, initargs=(os.getpid(),)
    )
    started, unwound = tmp_path / "started", tmp_path / "unwound"
    futures = [pool.submit(workerfaults.unwinds_slowly, str(started), str(unwound), 600.0) for _ in range(6)]
    assert _wait_for(lambda: len(list(tmp_path.glob("started-*"))) == 2)
    processes = list(pool._processes.values())
    _abandon(pool)  # the default grace
    # each ended by itself (SystemExit(128 + SIGTERM)), not killed (-SIGKILL) after the grace
    assert sorted(_exit_code(p) for p in processes) == [128 + signal.SIGTERM] * 2
    assert len(list(tmp_path.glob("unwound-*"))) == 2  # each task's finally ran
    assert len(list(tmp_path.glob("started-*"))) == 2  # and no queued task started
    for future in futures:
        with contextlib.suppress(cf.CancelledError, cf.process.BrokenProcessPool, SystemExit):
            future.result(timeout=20)


def test_a_second_sigterm_does_not_cut_a_worker_s_unwinding_short(tmp_path):
    """When one worker ends, the pool's manager terminates the others again: a second
    SystemExit raised inside the first one's finally would skip the rest of it (the kill of
    an SPH simulation's child)."""
    import concurrent.futures as cf

    import workerfaults
    from replication.casestudy.evaluate import worker_initializer
    from replication.casestudy.interrupts import quiet_worker_context

    pool = cf.ProcessPoolExecutor(
        1, mp_context=quiet_worker_context(), initializer=worker_initializer, initargs=(os.getpid(),)
    )
    started, unwound = tmp_path / "started", tmp_path / "unwound"
    future = pool.submit(workerfaults.unwinds_slowly, str(started), str(unwound), 600.0, 1.0)
    assert _wait_for(lambda: any(tmp_path.glob("started-*")))
    (process,) = pool._processes.values()
    process.terminate()
    time.sleep(0.3)  # inside the finally now
    process.terminate()
    assert _exit_code(process) == 128 + signal.SIGTERM and len(list(tmp_path.glob("unwound-*"))) == 1
    with contextlib.suppress(cf.process.BrokenProcessPool, SystemExit):
        future.result(timeout=20)
    pool.shutdown(wait=True)


_CTRL_C_DURING_THE_MESSAGE = """
import time
from replication.casestudy.evaluate import executor

def second_ctrl_c():  # the user presses Ctrl-C again as the command says that it waits
    raise KeyboardInterrupt

with executor("process", workers=1, on_interrupt=second_ctrl_c) as pool:
    future = pool.submit(time.sleep, 600)
    while not future.running():
        time.sleep(0.01)
    time.sleep(0.5)
    raise KeyboardInterrupt
"""


def test_ctrl_c_again_while_the_pool_says_it_waits_is_heard():
    """The message is given inside the guard: the second Ctrl-C abandons the work under way
    (it used to escape the guard, and the interpreter's exit waited for the task)."""
    process = subprocess.Popen(
        [sys.executable, "-c", _CTRL_C_DURING_THE_MESSAGE], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, start_new_session=True,
    )  # fmt: skip
    try:
        _, err = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail("the second Ctrl-C was not heard: the command waited for the task under way")
    assert process.returncode != 0 and "KeyboardInterrupt" in err
    assert_no_process_left(process.pid)


def _wait_for(condition, seconds=20.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.1)
    return False


def _exit_code(process, seconds=30.0):
    """The exit code of a pool's worker once it has ended (None if it has not in ``seconds``).

    Not ``join()`` then ``exitcode``: the pool's management thread reaps its workers too, and
    when it reaps one first, ``join`` in this thread returns before the exit code is recorded
    (an exit code of None, seen 1 time in 40 on a loaded machine).
    """
    _wait_for(lambda: process.exitcode is not None, seconds)
    return process.exitcode


def _ended(pid):
    """Whether process ``pid`` has ended: gone, or a zombie (an orphan's exit status waits for
    whoever adopted it, and not every init process collects it)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rpartition(")")[2].split()[0] in ("Z", "X")
    except FileNotFoundError:
        return True
    except OSError:  # no /proc: ask the kernel whether the pid exists at all
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        return False


def _assert_ends(pid, message):
    """Assert that process ``pid`` ends soon; kill it either way, so no test leaves it behind."""
    try:
        assert _wait_for(lambda: _ended(pid)), message
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


def test_a_killed_command_leaves_no_pool_worker_and_no_lock(tmp_path):
    """SIGKILL of the command: its forked workers waited forever, holding the run directory's
    lock, so --resume was refused until they were found and killed by hand."""
    from replication.casestudy.rundir import RunDirBusyError, hold

    script = f"""
import time
from replication.casestudy.evaluate import executor
from replication.casestudy.rundir import hold
with hold({str(tmp_path / "run")!r}), executor("process", workers=2) as pool:
    pool.submit(time.sleep, 0).result()
    print(*(p.pid for p in pool._processes.values()), flush=True)
    time.sleep(120)
"""
    with subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True) as child:
        workers = [int(pid) for pid in child.stdout.readline().split()]
        child.kill()
    assert len(workers) == 2

    try:
        assert _wait_for(lambda: all(_ended(pid) for pid in workers)), "pool workers outlived their parent"
    finally:
        for pid in workers:  # never leave them behind, even when the test fails
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)

    def free():
        try:
            with hold(tmp_path / "run"):
                return True
        except RunDirBusyError:
            return False

    assert _wait_for(free)


def _workers_left_after(interrupt: str) -> tuple[int, str]:
    """Exit status and output of a process that runs ``interrupt`` (code patching the pool so
    that a Ctrl-C arrives while it starts), then one call on a 2-worker process pool, and prints
    how many child processes are left once the KeyboardInterrupt has unwound."""
    script = (
        "import concurrent.futures.process as P, multiprocessing, os, signal, sys\n"
        "import multiprocessing.process as MP\n"
        "from replication.casestudy.evaluate import executor\n"
        + interrupt
        + """
try:
    with executor("process", workers=2) as pool:
        pool.submit(abs, -1).result()
except KeyboardInterrupt:
    print("left:", len(multiprocessing.active_children()), flush=True)
    sys.exit(130)
"""
    )
    with subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, start_new_session=True
    ) as child:
        try:
            out, _ = child.communicate(timeout=60)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(child.pid, signal.SIGKILL)  # a hang's workers too
    return child.returncode, out


def test_ctrl_c_as_a_fork_pool_starts_its_workers_does_not_hang():
    """Ctrl-C inside the first submit, after the workers were forked but before the pool's
    management thread: the command said "interrupted", then waited for them forever."""
    code, out = _workers_left_after("""
launch = P.ProcessPoolExecutor._launch_processes
def interrupted_launch(self):
    launch(self)
    os.kill(os.getpid(), signal.SIGINT)
P.ProcessPoolExecutor._launch_processes = interrupted_launch
""")
    assert code == 130 and out.strip() == "left: 0", out


def test_ctrl_c_as_a_worker_forks_leaves_no_worker_behind():
    """Ctrl-C held while a worker forked was raised as its start() returned, before the pool
    recorded the worker: the command said "interrupted", then its exit waited for that worker
    for good (table1 --quick and reproduce --quick, SIGINT or SIGTERM a few seconds in)."""
    code, out = _workers_left_after("""
start = MP.BaseProcess.start
fired = []
def interrupted_start(self):
    worker = self._target is P._process_worker  # (start() drops the target)
    start(self)
    if worker and not fired:
        fired.append(1)
        os.kill(os.getpid(), signal.SIGINT)  # held until the worker has started
MP.BaseProcess.start = interrupted_start
""")
    assert code == 130 and out.strip() == "left: 0", out


def test_a_worker_terminated_while_it_starts_ends_without_a_traceback():
    """SIGTERM (for instance its killed parent's) while a worker ran its initializer raised
    SystemExit there, which concurrent.futures printed as "Exception in initializer" with a
    traceback; until the worker is set up, SIGTERM now ends it at once."""
    script = """
import os, signal, replication.threadlimits as T
from replication.casestudy.evaluate import executor
T.limit_worker_blas = lambda: os.kill(os.getpid(), signal.SIGTERM)
try:
    with executor("process", workers=1) as pool:
        pool.submit(abs, -1).result()
except Exception as error:
    print(type(error).__name__, flush=True)
"""
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, start_new_session=True
    )
    assert "BrokenProcessPool" in result.stdout, result.stdout + result.stderr
    assert "Traceback" not in result.stderr and "initializer" not in result.stderr, result.stderr


def test_an_orphaned_worker_that_swallows_the_signal_still_ends():
    """The SystemExit that SIGTERM raises in an orphaned worker can be caught (concurrent.futures
    catches everything while it sends a result back, and so may a task): the worker then
    waited for its next task forever. It now ends ORPHAN_GRACE seconds after its parent.

    The grace is shortened to 1 s here (the forked worker inherits the module's value, which the
    watch reads when its parent has gone): the test waited 5 s doing nothing. A worker that did
    not end after its grace would still outlive the 20 s the test waits for it."""
    script = """
import os, time
from replication.casestudy import interrupts
from replication.casestudy.evaluate import executor

interrupts.ORPHAN_GRACE = 1.0

def stubborn():
    print(os.getpid(), flush=True)
    try:
        time.sleep(120)
    except BaseException:
        pass

with executor("process", workers=1) as pool:
    pool.submit(stubborn).result()
"""
    with subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True) as child:
        worker = int(child.stdout.readline())
        child.kill()
    _assert_ends(worker, "an orphaned worker outlived its grace")


def test_a_killed_command_with_many_open_files_leaves_no_worker():
    """A forked worker inherits its parent's descriptors, so its pidfd could be numbered 1024 or
    more, which select() refuses: the watch died with a traceback and the worker stayed."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 1200:
        pytest.skip(f"the open-file limit ({hard}) is too low")
    script = """
import os, resource, time
soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, 1200), hard))  # the test skips below 1200
keep = [os.open(os.devnull, os.O_RDONLY) for _ in range(1100)]
from replication.casestudy.evaluate import executor
with executor("process", workers=1) as pool:
    print(pool.submit(os.getpid).result(), flush=True)
    time.sleep(120)
"""
    with subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    ) as child:
        worker = int(child.stdout.readline())
        child.kill()
        _assert_ends(worker, "the worker outlived its parent")
        err = child.stderr.read()  # the end of file comes once the worker, which shares it, has ended
    assert "Traceback" not in err, err


def test_a_fork_server_worker_is_not_taken_for_an_orphan():
    """A fork server's worker is not the child of the pool's process: it must not end itself."""
    import multiprocessing

    from replication.casestudy.evaluate import worker_initializer

    if "forkserver" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork server here")
    with cf.ProcessPoolExecutor(
        1, mp_context=multiprocessing.get_context("forkserver"), initializer=worker_initializer,
        initargs=(os.getpid(),),
    ) as pool:  # fmt: skip
        assert pool.submit(abs, -3).result(timeout=60) == 3
        time.sleep(1.0)  # a wrong watch would have ended the worker by now
        assert pool.submit(abs, -4).result(timeout=60) == 4


_KILLED_WHILE_SIMULATING = """
import os, sys, time
sys.path.insert(0, sys.argv[2])
import workerfaults
from replication.casestudy.evaluate import executor

run_dir = sys.argv[1]
with executor(sys.argv[3], workers=1) as pool:
    future = pool.submit(workerfaults.sleeping_simulation, run_dir, 600.0)
    time.sleep(600)
"""


@pytest.mark.slow
@pytest.mark.parametrize("kind", SIMULATION_EXECUTORS)
def test_a_killed_command_leaves_no_simulation_running(tmp_path, kind):
    """SIGKILL of the command while a worker waited for a simulation: on a local dask cluster,
    distributed ends the worker with os._exit, which ran no cleanup, so the engine (a session
    of its own) ran on until its time limit."""
    with subprocess.Popen(
        [sys.executable, "-c", _KILLED_WHILE_SIMULATING, str(tmp_path), str(Path(__file__).parent), kind],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    ) as command:  # fmt: skip
        engine = None
        try:
            assert _wait_for(lambda: (tmp_path / "pid").exists(), seconds=120), "no simulation started"
            engine = int((tmp_path / "pid").read_text())
            command.kill()  # the command alone, as the OOM killer would
            assert _wait_for(lambda: _ended(engine)), "the simulation outlived the killed command"
        finally:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(command.pid, signal.SIGKILL)  # whatever is left of its group
            if engine is not None:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(engine, signal.SIGKILL)


def test_the_engine_reaper_leaves_a_program_that_is_not_a_worker_process_alone():
    """A worker in threads of another program (LocalCluster(processes=False) behind --scheduler)
    must not change that program's os._exit."""
    pytest.importorskip("distributed")
    from replication.casestudy.daskplugin import EngineReaper

    real = os._exit
    EngineReaper().setup(None)
    assert os._exit is real
