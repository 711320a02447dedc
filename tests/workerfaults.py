"""Faults injected into worker processes, for the executors' tests.

A process pool's workers import this module by name (a spawned process gets the parent's
``sys.path``, and pytest puts ``tests/`` on it); dask's workers cannot import ``tests/``, so
tests that ship these objects to a dask cluster pickle this module by value
(:func:`pickled_by_value`).
"""

import contextlib
import os

import pytest


class DiesOnceWhenArmed:
    """A fitness whose first evaluation after the file ``armed`` appears kills its worker process.

    It dies only once per ``died`` file (created atomically by the dying worker), so the
    evaluation it abandoned succeeds when the executor runs it again.
    """

    def __init__(self, inner, armed, died):
        self.inner, self.armed, self.died = inner, str(armed), str(died)

    def __call__(self, genome):
        if os.path.exists(self.armed):
            try:
                os.close(os.open(self.died, os.O_CREAT | os.O_EXCL))
            except FileExistsError:
                pass
            else:
                os._exit(1)  # the worker dies mid-evaluation, its task with it
        return self.inner(genome)


@contextlib.contextmanager
def pickled_by_value(*modules):
    """Let cloudpickle ship ``modules`` (and this one) by value, for workers that cannot import them."""
    import sys

    import cloudpickle

    modules = [sys.modules[__name__], *modules]
    for module in modules:
        cloudpickle.register_pickle_by_value(module)
    try:
        yield
    finally:
        for module in modules:
            cloudpickle.unregister_pickle_by_value(module)


#: A stand-in for the SPH driver: records its process id, sleeps, and marks that it finished.
SLEEPING_DRIVER = (
    "import os, sys, time; run_dir = sys.argv[2]; "
    "pid = os.path.join(run_dir, 'pid'); open(pid + '.part', 'w').write(str(os.getpid())); "
    "os.replace(pid + '.part', pid); "  # whole or absent: the tests read it as soon as it exists
    "time.sleep(float(sys.argv[1])); open(os.path.join(run_dir, 'finished'), 'w').close()"
)


def sleeping_simulation(run_dir, seconds):
    """Wait, as a worker does, for a driver child process that sleeps ``seconds``."""
    import sys

    from replication.casestudy.sph.process import run_child

    return run_child(
        run_dir, timeout=None, command=[sys.executable, "-c", SLEEPING_DRIVER, str(seconds)]
    ).status


def sleeping_fitness(run_dir, seconds, genome):
    """A GA fitness that is a :func:`sleeping_simulation` (the genome is not looked at)."""
    sleeping_simulation(run_dir, seconds)
    return 1.0


def assert_no_process_left(pgid):
    """Nothing of a finished command's process group (its pool, cluster, resource tracker) is left."""
    with pytest.raises(ProcessLookupError):
        os.killpg(pgid, 0)  # signal 0: does any process of the group exist?


def deaf_to_sigterm(marker, seconds):
    """A task whose worker ignores SIGTERM (then creates ``marker``) and sleeps: only SIGKILL ends it."""
    import pathlib
    import signal
    import time

    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    pathlib.Path(marker).touch()
    time.sleep(seconds)
    return seconds


def broken_cloud(message, n, k):
    """A cloud factory that fails (picklable by reference, for worker processes)."""
    raise ValueError(message)


def blocked_in_c(marker, seconds):
    """A task that starts an engine-like child in a session of its own (its pid into
    ``marker``), then sleeps in one C call: no Python code runs to take an exception raised
    in its thread, so only killing its process ends it, and only a killpg its child."""
    import pathlib
    import subprocess
    import sys
    import time

    child = subprocess.Popen(
        [sys.executable, "-c", f"import time; time.sleep({seconds})"], start_new_session=True
    )
    pathlib.Path(f"{marker}.part").write_text(str(child.pid))
    pathlib.Path(f"{marker}.part").replace(marker)  # whole or absent: read as soon as it exists
    time.sleep(seconds)
    return seconds


def unwinds_slowly(started, unwound, seconds, unwinding=0.0):
    """Say the task started (a file per task), sleep, and say so when SIGTERM unwinds it."""
    import time
    from pathlib import Path

    Path(f"{started}-{os.getpid()}-{time.monotonic_ns()}").touch()
    try:
        time.sleep(seconds)
    finally:
        time.sleep(unwinding)  # a simulation's child being killed takes a moment
        Path(f"{unwound}-{os.getpid()}").touch()
