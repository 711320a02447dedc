"""Ctrl-C during a GA run, for real: SIGINT to a running ``replication casestudy`` process group.

Each run is interrupted at its own moment (a few milliseconds after a given generation was
checkpointed, so inside the next generation's evaluations, most of whose time is spent in the
compiled jet kernel), must stop with exit status 130, keep its last complete checkpoint with
no failure recorded, and, resumed, end bit-identical to an uninterrupted run.
"""

import functools
import json
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from replication.casestudy.evaluate import executor
from replication.casestudy.ga import GAConfig
from replication.casestudy.runner import run_ga

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


def _interrupt(run_dir, executor_args, after_generation, delay, timeout=120):
    """Start a GA run, press Ctrl-C (SIGINT to its process group) at the given moment."""
    process = subprocess.Popen(
        [sys.executable, "-m", "replication", "casestudy", *ARGS, *executor_args, "--run-dir", str(run_dir)],
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
            os.killpg(process.pid, signal.SIGINT)

    presser = threading.Thread(target=press_ctrl_c)
    presser.start()
    return process, presser


def _check_stopped(process, presser, run_dir, timeout=120):
    out, err = process.communicate(timeout=timeout)
    presser.join()
    assert process.returncode == 130, err
    assert "Traceback" not in err and err.rstrip().endswith("replication casestudy: interrupted"), err
    hint = f"resume with: replication casestudy --run-dir {run_dir} --resume"
    assert hint in err, err
    state = _state(run_dir)
    assert 1 <= state["generation"] < CONFIG.generations
    assert state["failures"] == [] and all(f is not None for f in state["fitness"])
    return state


def _resume_and_compare(run_dir, uninterrupted):
    run_ga(CONFIG, 0, run_dir=run_dir, pool_factory=serial, resume=True)
    assert _state(run_dir) == uninterrupted


MOMENTS = [(1, 0.0), (1, 0.013), (2, 0.029), (3, 0.007)]


def test_ctrl_c_in_serial_runs_at_several_moments(tmp_path, uninterrupted):
    started = []
    for k, (generation, delay) in enumerate(MOMENTS):  # all at once: each has its own moment
        run_dir = tmp_path / f"run{k}"
        started.append((run_dir, *_interrupt(run_dir, ["--executor", "serial"], generation, delay)))
    for run_dir, process, presser in started:
        _check_stopped(process, presser, run_dir)
    for run_dir, _, _ in started:
        _resume_and_compare(run_dir, uninterrupted)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["process", "dask"])
def test_ctrl_c_with_worker_processes(tmp_path, uninterrupted, kind):
    """Ctrl-C reaches the workers too (one process group): still no failure, a clean stop."""
    if kind == "dask":
        pytest.importorskip("dask.distributed")
    run_dir = tmp_path / "run"
    process, presser = _interrupt(run_dir, ["--executor", kind, "--workers", "1"], 2, 0.01)
    _check_stopped(process, presser, run_dir)
    _resume_and_compare(run_dir, uninterrupted)
