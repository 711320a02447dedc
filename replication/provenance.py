"""How a result was made: command, commit, versions, machine, date (stated in every report)."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

__all__ = ["PACKAGES", "cpu_model", "git_state", "provenance"]

PACKAGES: tuple[str, ...] = (
    "replication",
    "numpy",
    "scipy",
    "numba",
    "geomdl",
    "pyvista",
    "vtk",
    "pandas",
    "matplotlib",
)


def cpu_model() -> str:
    """The CPU's model name (from /proc/cpuinfo on Linux, else platform)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def git_state(directory: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """Commit hash and whether the work tree had uncommitted changes (None outside git)."""
    cwd = Path(directory) if directory else Path(__file__).resolve().parent
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=cwd, capture_output=True, text=True, check=True, timeout=10
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=cwd,
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}
    return {"commit": commit, "dirty": bool(dirty)}


def _version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


def provenance(command: str | None = None, **extra: Any) -> dict[str, Any]:
    """A JSON-ready record of the command, code, software and machine, plus ``extra``.

    ``command`` is the invocation to record (the CLI passes its own); by default the
    process's command line.
    """
    return {
        "command": command or " ".join([Path(sys.argv[0]).name if sys.argv else "python", *sys.argv[1:]]),
        **git_state(),
        "date_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "versions": {name: _version(name) for name in PACKAGES},
        **extra,
    }
