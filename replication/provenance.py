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


def _git(args: list[str], cwd: Path) -> str | None:
    try:
        result = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return result.stdout.strip() if result.returncode == 0 else None


def git_state(directory: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """Commit of the project checkout and whether its code had uncommitted changes.

    The checkout is looked for from ``directory`` (default: the working directory, where
    ``replication reproduce`` is run), then from this package's own location (an editable
    install). Only the code counts as a change (``replication/`` and ``pyproject.toml``):
    reports being regenerated do not make the code dirty. Both values are None outside a
    checkout of this project.
    """
    here = Path(__file__).resolve().parent
    for base in (Path(directory) if directory else Path.cwd(), here):
        root = _git(["rev-parse", "--show-toplevel"], base) if base.is_dir() else None
        if root is None or not (Path(root) / "replication" / "provenance.py").is_file():
            continue
        commit = _git(["rev-parse", "HEAD"], Path(root))
        status = _git(
            ["status", "--porcelain", "--untracked-files=no", "--", "replication", "pyproject.toml"],
            Path(root),
        )
        if commit is not None and status is not None:
            return {"commit": commit, "dirty": bool(status)}
    return {"commit": None, "dirty": None}


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
