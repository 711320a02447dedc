"""Run the engine's driver in a child process: timeout, progress, and what became of it.

Why a child started with :mod:`subprocess` (a fresh interpreter running ``driver.py`` by
path) rather than :mod:`multiprocessing`:

* the engine writes to the process's standard output from C++; the child's output goes to
  ``engine.log`` without touching the caller's descriptors (``--json`` output stays clean);
* a segmentation fault or the engine's ``exit()`` only ends the child, and shows up as its
  exit status (a signal number, a status without a result file);
* it works where multiprocessing cannot start children: inside the daemonic workers of a
  process pool or a dask cluster, which is where the GA's evaluations run;
* the child imports neither the caller's ``__main__`` nor the ``replication`` package.

The child gets a session of its own, so a timeout or an interrupt of the caller kills it
with everything it started.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["DRIVER", "ChildOutcome", "run_child"]

#: The child's program, run by path.
DRIVER = Path(__file__).with_name("driver.py")
#: Statuses of a simulation.
STATUSES = ("ok", "blowup", "timeout", "crash")


@dataclass(frozen=True)
class ChildOutcome:
    """How the child ended: a status of :data:`STATUSES`, the reason if it failed, its report."""

    status: str
    reason: str | None
    info: dict[str, Any] = field(default_factory=dict)  # outcome.json of the driver, if any
    wall_seconds: float = 0.0
    returncode: int | None = None
    simulated_time: float = 0.0  # the last progress report


def _read_json(path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _log_hint(log: Path) -> str:
    """The last line of the engine's log that names an error, or its last line."""
    try:
        lines = [line.strip() for line in log.read_text(errors="replace").splitlines() if line.strip()]
    except OSError:
        return ""
    errors = [line for line in lines if "error" in line.lower()]
    hint = (errors or lines or [""])[-1]
    return hint[:300]


def _kill(proc: subprocess.Popen) -> None:
    """Kill the child and its process group; reap it."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError, PermissionError, OSError):
            if hasattr(os, "killpg"):
                os.killpg(proc.pid, signal.SIGKILL)
            else:  # pragma: no cover - Windows
                proc.kill()
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=10)


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def run_child(
    run_dir: str | os.PathLike[str],
    *,
    timeout: float | None,
    threads: int = 1,
    progress: Callable[[float], None] | None = None,
    command: Sequence[str] | None = None,
    poll: float = 0.1,
) -> ChildOutcome:
    """Run the driver on ``run_dir`` and wait for it, at most ``timeout`` seconds.

    Parameters
    ----------
    run_dir
        Holds ``job.json`` and the scene; receives ``engine.log`` and the driver's files.
    timeout : float or None
        Wall-clock limit (s); the child is killed when it is reached.
    threads : int
        OpenMP threads of the engine (``OMP_NUM_THREADS``).
    progress : callable, optional
        Called with the simulated time (s) whenever the child reports progress.
    command : sequence of str, optional
        The program to run instead of the driver (``run_dir`` is appended); for tests.

    Returns
    -------
    ChildOutcome
        ``ok`` or ``blowup`` as the driver reported them; ``timeout``; ``crash`` for a signal,
        an exit without a result file, or an error the driver caught (the reason says which).
    """
    run_dir = Path(run_dir)
    argv = [*(command or [sys.executable, str(DRIVER)]), str(run_dir)]
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), PYTHONUNBUFFERED="1")
    log_path = run_dir / "engine.log"
    for stale in ("outcome.json", "progress.json", "steps.csv"):
        with contextlib.suppress(FileNotFoundError):
            (run_dir / stale).unlink()
    start = time.monotonic()
    reported = 0.0
    timed_out = False
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(
            argv,
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=env,
            cwd=run_dir,
            start_new_session=hasattr(os, "setsid"),
        )
        try:
            while True:
                try:
                    proc.wait(timeout=poll)
                    break
                except subprocess.TimeoutExpired:
                    pass
                state = _read_json(run_dir / "progress.json")
                if state and state.get("time", 0.0) > reported:
                    reported = float(state["time"])
                    if progress is not None:
                        progress(reported)
                if timeout is not None and time.monotonic() - start > timeout:
                    timed_out = True
                    _kill(proc)
                    break
        finally:
            _kill(proc)  # an interrupt or an error of the caller leaves no orphan
    wall = time.monotonic() - start
    state = _read_json(run_dir / "progress.json")
    if state:
        reported = max(reported, float(state.get("time", 0.0)))
        if progress is not None:
            progress(reported)
    info = _read_json(run_dir / "outcome.json") or {}
    rc = proc.returncode

    def outcome(status: str, reason: str | None) -> ChildOutcome:
        return ChildOutcome(status, reason, info, wall, rc, reported)

    if timed_out:
        return outcome(
            "timeout", f"no result after {timeout:g} s (simulated {1e3 * reported:.4g} ms by then)"
        )
    status = info.get("status")
    if status == "ok" and rc == 0:
        return outcome("ok", None)
    if status == "blowup":
        return outcome("blowup", f"{info.get('reason')} at t = {1e3 * reported:.4g} ms")
    if status == "error":
        return outcome("crash", f"the simulation failed: {info.get('reason')}")
    hint = _log_hint(log_path)
    detail = f"; engine log: {hint}" if hint else ""
    if rc is not None and rc < 0:
        return outcome(
            "crash", f"the engine crashed ({_signal_name(-rc)}) at t = {1e3 * reported:.4g} ms{detail}"
        )
    return outcome("crash", f"the engine exited with status {rc} without a result{detail}")
