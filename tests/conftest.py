"""Shared test configuration: hypothesis profiles and headless plotting."""

import os

import matplotlib
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")

# CI: fixed example database-free runs (derandomized) so a failure reproduces exactly.
settings.register_profile(
    "ci",
    max_examples=60,
    deadline=None,
    derandomize=True,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci" if os.environ.get("CI") else os.environ.get("HYPOTHESIS_PROFILE", "dev"))


import pytest  # noqa: E402


def _xdist_role(config) -> str:
    """This process's part in a pytest-xdist run: "worker", "controller" or "" (no workers).

    The suite runs on pytest-xdist's workers by default (``addopts`` in pyproject.toml);
    ``-n 0`` runs it in one process.
    """
    if hasattr(config, "workerinput"):
        return "worker"
    if getattr(config.option, "numprocesses", None) and getattr(config.option, "dist", "no") != "no":
        return "controller"
    return ""


def pytest_xdist_auto_num_workers(config):
    """Workers for ``--numprocesses=logical`` (``addopts``): one more than this process may use.

    About a tenth of a worker's time is spent waiting (on the commands, dask clusters and SPH
    runs that tests start as processes, whose CPU time is counted there), and a third worker
    fills it: on 2 cores, runs alternated on 2026-11-25 took 122, 132, 129 and 130 s on 3
    workers against 132, 145 and 136 s on 2 (4 workers: 141-144 s). ``--maxprocesses`` caps it.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return cores + 1


def pytest_configure(config):
    """Python's own SIGINT handler in every test process, as in a terminal.

    A test session started in the background by a non-interactive shell (``pytest &`` in a
    script) inherits SIGINT ignored, in the controller, its xdist workers and every child
    they start: the commands then rightly ignore Ctrl-C (see
    ``test_a_command_that_ignores_sigint_is_not_interrupted_by_it``), and the tests that
    press it saw their commands finish. The tests are of Ctrl-C as a terminal delivers it.
    """
    import signal

    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_sessionstart(session):
    """With xdist workers: compile (or load) the kernels once, here, before the workers start,
    so that in a fresh clone they do not all compile the same kernels at once (xdist starts its
    workers in a later hook of this same stage)."""
    config = session.config
    if _xdist_role(config) == "controller" and not config.option.collectonly:
        from replication.kernels import warm_up

        warm_up(processes=2)  # a fresh clone compiles on both cores: 18 s instead of 31 s


def pytest_collection_finish(session):
    """Compile (or load from numba's cache) every compiled kernel once, before the first test,
    so that in a fresh clone no single test carries the compilation (issue 15 item 5).

    In an xdist worker the controller has compiled them already: this only loads them, so
    every test runs with numba's kernels loaded, as in a one-process run."""
    if not session.config.option.collectonly and session.items:
        from replication.kernels import warm_up

        warm_up(processes=1 if _xdist_role(session.config) == "worker" else 2)


def pytest_collection_modifyitems(session, config, items):
    """Run one test that needs the shared quick reports first and the others last.

    Building the reports (``reproduce --quick``) takes about half a minute on one core.
    In collection order, an xdist worker that reached a second such test waited for the
    first worker to finish it, with its core idle (18 s of a 2.8-minute run). With one of
    them first, the worker that takes it builds the reports while the other worker runs
    the tests that do not need them; the rest come when the reports are there. The order
    is the same in every worker, as xdist requires.
    """
    needing = [item for item in items if "quick_reports" in getattr(item, "fixturenames", ())]
    if len(needing) > 1:
        others = [item for item in items if "quick_reports" not in getattr(item, "fixturenames", ())]
        items[:] = [needing[0], *others, *needing[1:]]


@pytest.fixture(scope="session")
def quick_reports(tmp_path_factory):
    """``replication reproduce --quick`` once per test run, run from a scratch directory.

    The directory is a stand-in for a project checkout (the README and pyproject.toml beside
    the reports), so the run also shows that a quick run leaves a checkout's README alone: its
    reports go to ``reports-quick/``, never into the committed ``reports/``.
    Under pytest-xdist the workers share one run: the first worker to ask runs it in the
    directory all workers' temporary directories share, the others wait for it (a file
    lock) and read the same reports. Tests must not change them: they work on a copy.
    """
    import os
    import shutil
    from pathlib import Path

    from replication.cli import main

    def run(work: Path) -> Path:  # an empty directory
        root = Path(__file__).resolve().parents[1]
        for name in ("README.md", "pyproject.toml"):
            shutil.copy(root / name, work / name)
        previous = os.getcwd()
        os.chdir(work)  # the GA's checkpoints go to ./casestudy-runs, the reports to ./reports-quick
        try:
            assert main(["reproduce", "--quick"]) == 0
        finally:
            os.chdir(previous)
        return work / "reports-quick"

    try:
        import fcntl
    except ImportError:  # no POSIX file locks: every worker runs its own
        fcntl = None
    if os.environ.get("PYTEST_XDIST_WORKER") is None or fcntl is None:
        return run(tmp_path_factory.mktemp("reproduce"))
    shared = tmp_path_factory.getbasetemp().parent
    status = shared / "reproduce-quick.status"
    work = shared / "reproduce-quick"
    with open(shared / "reproduce-quick.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if status.is_file():
            outcome = status.read_text()
            if outcome != "ok":
                pytest.fail(f"the quick reproduce failed in another xdist worker: {outcome}")
            return work / "reports-quick"
        try:
            shutil.rmtree(work, ignore_errors=True)  # left by a worker that died during the run
            work.mkdir()
            out = run(work)
        except BaseException as exc:
            status.write_text(f"{type(exc).__name__}: {exc}".splitlines()[0])
            raise
        status.write_text("ok")
        return out


@pytest.fixture
def quick_reports_copy(quick_reports, tmp_path):
    """A copy of the quick reports for a test that re-renders or changes them (the originals
    are shared by every test, and under xdist by every worker)."""
    import shutil

    return shutil.copytree(quick_reports, tmp_path / "reports")


@pytest.fixture
def port_8787_taken():
    """Port 8787, dask's default dashboard port, is in use while the test runs.

    Binds it when it is free; when another program has it already, that is just as good.
    Tests that start dask clusters use this, so a cluster that tries the fixed port fails
    here as it would next to another program's dashboard.
    """
    import socket

    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind(("", 8787))
        sock.listen()
    except OSError:
        sock.close()
        sock = None
    try:
        yield 8787
    finally:
        if sock is not None:
            sock.close()


@pytest.fixture
def restore_global_rng():
    """Tests that set numpy's legacy global seed (to prove it does not matter) restore it."""
    import numpy as np

    state = np.random.get_state()
    yield
    np.random.set_state(state)


@pytest.fixture(autouse=True)
def _signal_handlers_restored():
    """Every test leaves SIGINT's and SIGTERM's handlers as it found them.

    A handler left ignored (``SIG_IGN``) outlives the test: later tests of the same worker
    then never see their Ctrl-C, and child processes inherit the ignored signal across
    ``exec``. The test that changed it fails here, by name, and the handler is restored.
    """
    import signal

    before = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    yield
    changed = {}
    for signum, handler in before.items():
        now = signal.getsignal(signum)
        if now is not handler and now != handler:
            changed[signal.Signals(signum).name] = now
            signal.signal(signum, handler)
    if changed:
        pytest.fail(f"the test left signal handlers changed: {changed}")


@pytest.fixture(autouse=True)
def _no_sigterm_remembered(monkeypatch):
    """Every test starts as if no SIGTERM had come: ``replication.sigterm`` keeps the answer of
    its last block for the caller's exit status, so a test that sent SIGTERM made a later test
    of the same worker that reads the status without a block of its own (``_stopped``) say
    "terminated" (exit 143 for a Ctrl-C, 1 run in 6 of tests/test_io.py on two workers)."""
    from replication import sigterm

    monkeypatch.setattr(sigterm, "_terminated", False)
