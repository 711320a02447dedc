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


def pytest_collection_finish(session):
    """Compile (or load from numba's cache) every compiled kernel once, before the first test,
    so that in a fresh clone no single test carries the compilation (issue 15 item 5)."""
    if not session.config.option.collectonly and session.items:
        from replication.kernels import warm_up

        warm_up(processes=2)  # a fresh clone compiles on both cores: 18 s instead of 31 s


@pytest.fixture(scope="session")
def quick_reports(tmp_path_factory):
    """``replication reproduce --quick`` once per session, run from a scratch directory.

    The directory is a stand-in for a project checkout (the README and pyproject.toml beside
    ``reports/``), so the run also shows what reproducing into a checkout does to its README.
    """
    import os
    import shutil
    from pathlib import Path

    from replication.cli import main

    work = tmp_path_factory.mktemp("reproduce")
    root = Path(__file__).resolve().parents[1]
    for name in ("README.md", "pyproject.toml"):
        shutil.copy(root / name, work / name)
    out = work / "reports"
    previous = os.getcwd()
    os.chdir(work)  # the GA's checkpoints go to ./casestudy-runs
    try:
        assert main(["reproduce", "--quick", "--output-dir", str(out)]) == 0
    finally:
        os.chdir(previous)
    return out


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
