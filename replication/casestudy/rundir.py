"""GA run directories: the recorded configuration (``config.json``) and the checkpoints held.

``config.json`` records the :class:`~replication.casestudy.ga.GAConfig` of a run; it is
validated when read (malformed JSON, unknown or missing settings, values GAConfig refuses)
and a run directory with checkpoints but no ``config.json`` is refused, each with a
:class:`~replication.errors.CheckpointError` naming the file and the fault.

A command that runs the GA holds its run directory (:func:`hold`, an exclusive lock on
``.lock`` in it): a second command on the same directory at the same time is refused
instead of writing into the first one's run or removing it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import re
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import Any

from replication.casestudy.ga import GAConfig
from replication.casestudy.jet import JetConfig
from replication.errors import CheckpointError, InputError
from replication.io.atomic import atomic_write_text
from replication.io.locks import register_lock, unregister_lock
from replication.io.paths import is_browser_file

__all__ = [
    "CONFIG_NAME",
    "LOCK_NAME",
    "RunDirBusyError",
    "checkpoints",
    "config_from_dict",
    "foreign_entries",
    "hold",
    "read_config",
    "read_json",
    "write_config",
]

CONFIG_NAME = "config.json"
LOCK_NAME = ".lock"


class RunDirBusyError(InputError):
    """Another process holds the run directory."""


@contextlib.contextmanager
def hold(run_dir: str | os.PathLike[str]) -> Iterator[Path]:
    """Create ``run_dir`` if needed and hold it for this process while the block runs.

    The lock is an exclusive ``flock`` on ``run_dir/.lock``, released by the system when the
    process ends however it ends (a crash leaves no stale lock). Where ``fcntl`` does not
    exist (Windows) the directory is not locked.

    Raises
    ------
    RunDirBusyError
        When another process holds ``run_dir`` (nothing is created or changed then, beyond
        the directory and its lock file).
    """
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not on POSIX
        yield run_dir
        return
    fd = os.open(run_dir / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RunDirBusyError(
                f"{run_dir} is in use by another command running the GA there; wait for it to end, or use "
                "another run directory"
            ) from None
        register_lock(fd)  # a forked worker closes its copy (io.locks.close_inherited_locks)
        yield run_dir
    finally:
        unregister_lock(fd)
        os.close(fd)


#: A checkpoint's name; ``run-<k>.json``.
_CHECKPOINT = re.compile(r"run-\d+\.json")
_CHECKPOINT_TMP = re.compile(r"run-\d+\.json\.")


def foreign_entries(run_dir: str | os.PathLike[str], own: Collection[str] = ()) -> list[str]:
    """Names in ``run_dir`` that a GA run does not write there, sorted (none if it does not exist).

    A run writes its configuration, its checkpoints, its lock and the temporary files of
    their atomic writes (``.config.json.<tag>.tmp.json``); ``own`` names what else the
    caller writes there (the fitness record, the default reports directory). The files a file
    browser leaves behind (``.DS_Store``, ``Thumbs.db``, ``desktop.ini``, ``.directory``,
    ``._<name>``) are no one's work and count as neither.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return []
    ours = {CONFIG_NAME, LOCK_NAME, *own}

    def is_ours(name: str) -> bool:
        if is_browser_file(name):
            return True  # not written by a run, but no user's work either
        if name.startswith(".") and ".tmp" in name:  # an atomic write's temporary: .<name>.<tag>.tmp<suffix>
            name = name[1:].split(".tmp", 1)[0]
            return any(name.startswith(f"{n}.") for n in ours) or bool(_CHECKPOINT_TMP.match(name))
        return name in ours or bool(_CHECKPOINT.fullmatch(name))

    return sorted(entry.name for entry in run_dir.iterdir() if not is_ours(entry.name))


def checkpoints(run_dir: str | os.PathLike[str]) -> list[Path]:
    """The checkpoint files ``run-<k>.json`` in a run directory, sorted by name."""
    run_dir = Path(run_dir)
    return sorted(run_dir.glob("run-*.json")) if run_dir.is_dir() else []


def read_json(path: Path, what: str) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise CheckpointError(f"{path}: not a {what} (not UTF-8 text)") from exc
    except OSError as exc:
        raise CheckpointError(f"{path}: cannot read the {what}: {exc.strerror or exc}") from exc
    try:
        return json.loads(text)
    except ValueError as exc:
        raise CheckpointError(f"{path}: not a {what} (malformed JSON: {exc})") from exc


def _jsonable(config: GAConfig) -> dict[str, Any]:
    return json.loads(json.dumps(config.as_dict()))


def config_from_dict(data: Any) -> GAConfig:
    """The :class:`GAConfig` recorded by :meth:`GAConfig.as_dict` (validated).

    Raises
    ------
    InputError
        Not a mapping, unknown or missing settings, or values GAConfig refuses.
    """
    if not isinstance(data, dict):
        raise InputError(f"expected a JSON object of GA settings, got {type(data).__name__}")
    names = {f.name for f in dataclasses.fields(GAConfig)}
    unknown, missing = sorted(set(data) - names), sorted(names - set(data))
    if unknown or missing:
        parts = [f"unknown setting(s) {', '.join(unknown)}" if unknown else "",
                 f"missing setting(s) {', '.join(missing)}" if missing else ""]  # fmt: skip
        raise InputError("; ".join(p for p in parts if p))
    values = dict(data)
    jet = values["jet"]
    if not isinstance(jet, dict):
        raise InputError(f"jet must be a JSON object, got {type(jet).__name__}")
    jet_names = {f.name for f in dataclasses.fields(JetConfig)}
    if set(jet) != jet_names:
        raise InputError(f"jet settings must be {', '.join(sorted(jet_names))}, got {', '.join(sorted(jet))}")
    try:
        domain = None if jet["domain"] is None else tuple(jet["domain"])
        values["jet"] = JetConfig(**{**jet, "center": tuple(jet["center"]), "domain": domain})
        values["box"] = tuple(values["box"])
        config = GAConfig(**values)
    except TypeError as exc:
        raise InputError(f"a setting has the wrong type ({exc})") from exc
    if _jsonable(config) != json.loads(json.dumps(data)):
        raise InputError("a setting has the wrong type (it does not read back as written)")
    return config


def read_config(run_dir: str | os.PathLike[str]) -> GAConfig | None:
    """The configuration recorded in ``run_dir/config.json``, or None when there is none.

    Raises
    ------
    CheckpointError
        A malformed or invalid ``config.json``, or checkpoints without a ``config.json``.
    """
    path = Path(run_dir) / CONFIG_NAME
    if not path.exists():
        found = checkpoints(run_dir)
        if found:
            raise CheckpointError(
                f"{run_dir} holds GA checkpoints ({found[0].name}) but no {CONFIG_NAME}, so they cannot be "
                "checked against any settings; restore the file or use a new run directory"
            )
        return None
    if not path.is_file():
        raise CheckpointError(f"{path}: not a file")
    data = read_json(path, "GA configuration")
    try:
        return config_from_dict(data)
    except InputError as exc:
        raise CheckpointError(f"{path}: not a valid GA configuration: {exc}") from exc


def write_config(run_dir: str | os.PathLike[str], config: GAConfig) -> Path:
    """Create ``run_dir`` and record ``config``, or check it against the recorded one.

    Raises
    ------
    InputError
        When ``run_dir`` holds a run with another configuration (the settings that differ
        are named).
    CheckpointError
        When the recorded configuration is unreadable.
    """
    run_dir = Path(run_dir)
    recorded = read_config(run_dir) if run_dir.is_dir() else None
    if recorded is not None:
        previous, wanted = _jsonable(recorded), _jsonable(config)
        if previous != wanted:
            changed = sorted(k for k in set(previous) | set(wanted) if previous.get(k) != wanted.get(k))
            raise InputError(
                f"{run_dir} holds a run with a different configuration (differs in: {', '.join(changed)}); "
                "use a new run directory, or resume with the same settings"
            )
        return run_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(run_dir / CONFIG_NAME, json.dumps(_jsonable(config), indent=2, sort_keys=True) + "\n")
    return run_dir
