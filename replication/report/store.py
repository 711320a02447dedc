"""Atomic reading and writing of the data behind the reports (CSV and JSON).

Each file is written atomically, and an experiment's files are published together
(:func:`data_set`): a run stopped while it saves leaves the previous data set whole, never
files of two runs side by side under one provenance.
"""

from __future__ import annotations

import contextlib
import contextvars
import csv
import io
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Collection, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from replication.errors import ReportDataError
from replication.io.atomic import (
    atomic_write_text,
    interrupt_deferred,
    note_written,
    sync_directory,
    writer_gone,
    writer_tag,
)

__all__ = [
    "PUBLISH_WAIT",
    "dashless",
    "data_set",
    "interrupt_deferred",
    "read_csv",
    "read_json",
    "read_provenance",
    "rerun_into",
    "run_again",
    "write_csv",
    "write_json",
]

#: Called with the data directory when :func:`data_set` must wait for another save to finish
#: publishing into it (the library does not print; the command line says that it waits).
PUBLISH_WAIT: contextvars.ContextVar[Callable[[Path], None] | None] = contextvars.ContextVar(
    "PUBLISH_WAIT", default=None
)


def write_csv(frame: pd.DataFrame, path: str | os.PathLike[str]) -> int:
    """Write a DataFrame as CSV atomically (full float precision); return bytes written."""
    buffer = io.StringIO()
    frame.to_csv(buffer, index=False, float_format="%.17g", lineterminator="\n")
    return atomic_write_text(path, buffer.getvalue())


def read_csv(
    path: str | os.PathLike[str],
    columns: tuple[str, ...] = (),
    *,
    text: tuple[str, ...] = (),
    strings: Collection[str] | None = None,
) -> pd.DataFrame:
    """Read report data; a missing, malformed or incomplete file is a :class:`ReportDataError`.

    ``columns`` are required: a file without one of them is refused, naming them. Columns
    named in ``text`` are read as strings, empty fields as ``""`` (a commit hash such as
    ``1234e567`` is not a number). When ``strings`` is given, it names the columns that hold
    text: every other column must hold numbers (or true/false; an empty field is a missing
    value), and a field that is not one is refused, naming its line and column. pandas alone
    read such a column as text, and a report drew it (a figure as categories) or failed
    without naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise ReportDataError(f"report data not found: {path} (run the experiment first)")
    try:
        with open(path, encoding="utf-8", newline="") as handle:  # "\r\n" in a quoted field stays
            content = handle.read()
        _check_rows(content)
        if text:  # only an empty field is missing ("None" may be a parameter's name)
            frame = pd.read_csv(
                io.StringIO(content), dtype=dict.fromkeys(text, str), keep_default_na=False, na_values=[""]
            )
            present = [c for c in text if c in frame.columns]
            frame[present] = frame[present].fillna("")
        else:
            frame = pd.read_csv(io.StringIO(content))
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError) as exc:
        reason = " ".join(str(exc).split())
        raise ReportDataError(
            f"{path}: not a readable CSV table ({reason}); regenerate the report data"
        ) from exc
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ReportDataError(
            f"{path}: missing column(s) {', '.join(missing)} (the file is damaged or from another version); "
            "regenerate the report data"
        )
    if strings is not None:
        _check_numbers(frame, path, exempt={*strings, *text})
    return frame


def _check_numbers(frame: pd.DataFrame, path: Path, exempt: set[str]) -> None:
    """Refuse the first field of a column outside ``exempt`` that is not a number (see :func:`read_csv`)."""
    for column in frame.columns:
        values = frame[column]
        if column in exempt or pd.api.types.is_numeric_dtype(values):
            continue
        bad = values.notna() & ~values.isin([True, False]) & pd.to_numeric(values, errors="coerce").isna()
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise ReportDataError(
                f"{path}: line {row + 2}, column {column}: {values.iloc[row]!r} is not a number "
                "(the file is damaged or from another version); regenerate the report data"
            )


def _check_rows(text: str) -> None:
    """Refuse a table cut short: every row has the header's fields, and the text ends a line.

    :func:`write_csv` ends every row with a newline; pandas alone would read a row cut in
    half (a copy or download that stopped) with its missing fields as NaN.
    """
    if text and not text.endswith("\n"):
        raise ValueError("the last row is incomplete (no line end): the file was cut short")
    rows = csv.reader(io.StringIO(text))
    try:
        header = next(rows, None)
        if header is None:
            return  # empty: pandas names it
        for row in rows:
            if row and len(row) != len(header):
                raise ValueError(f"line {rows.line_num} has {len(row)} fields, the header {len(header)}")
    except csv.Error as exc:  # (a field over the csv module's size limit, for one)
        raise ValueError(f"line {rows.line_num}: {exc}") from exc


def write_json(data: dict[str, Any], path: str | os.PathLike[str]) -> int:
    return atomic_write_text(path, json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")


#: The provenance's record of its data set's files: name -> {"sha256", "bytes"} (see data_set).
DATA_FILES = "data_files"


def _digest(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def _record_files(staging: Path, provenance: str, staged: list[Path]) -> None:
    """Add to the staged provenance the checksum and size of every other file of the set, so
    that a file changed after the save (a lost row, an edited number) is found when the report
    is drawn (:func:`read_provenance`): ``report`` drew a page with a surface missing, exit 0."""
    record = read_json(staging / provenance)
    record[DATA_FILES] = {
        name.as_posix(): {"sha256": _digest(staging / name), "bytes": (staging / name).stat().st_size}
        for name in staged
        if name != Path(provenance)
    }
    write_json(record, staging / provenance)


def rerun_into(command: str, out: str | os.PathLike[str]) -> str:
    """``command`` (a recorded invocation) with its ``--output-dir`` made ``out``.

    The committed validation study records ``--output-dir /work/wt-study/reports``, a
    directory of the machine that ran it: "run ... again" named it for a copy of the reports
    anywhere. Without an ``--output-dir`` the command writes to its default directory, which
    need not be ``out`` either, so one is added. A case study given its ``--run-dir`` gets
    ``--resume`` (without it the run directory, holding checkpoints, is refused). A command
    that cannot be split is returned as it is.
    """
    import shlex

    try:
        words = shlex.split(command)
    except ValueError:
        return command
    kept: list[str] = []
    skip = False
    for word in words:
        if skip:
            skip = False
        elif word == "--output-dir":
            skip = True
        elif not word.startswith("--output-dir="):
            kept.append(word)
    # a case study's run directory holds its checkpoints: run again, it is refused without
    # --resume, which saves the finished runs' data again from them
    resume = kept[1:2] == ["casestudy"] and any(w.split("=")[0] == "--run-dir" for w in kept)
    if resume and "--resume" not in kept:
        kept.append("--resume")
    return shlex.join([*kept, "--output-dir", dashless(out)])


def dashless(path: str | os.PathLike[str]) -> str:
    """``path`` as a word that no command takes for an option: ``./-e`` for ``-e``."""
    text = os.fspath(path)
    return f"./{text}" if text.startswith("-") else text


def run_again(record: object, command: str, out: str | os.PathLike[str]) -> str:
    """The command that makes a data set again into ``out``: the one its provenance ``record``
    records (the run's own invocation, its settings included), else ``command``
    (:func:`rerun_into`)."""
    recorded = record.get("command") if isinstance(record, dict) else None
    if isinstance(recorded, str) and recorded.startswith("replication "):
        command = recorded
    return rerun_into(command, out)


def read_provenance(data: str | os.PathLike[str], provenance: str, command: str) -> dict[str, Any]:
    """The provenance record of a data set, after checking its files against the checksums it
    records (a set saved before they were recorded is read as it is).

    Raises
    ------
    ReportDataError
        A file of the set is missing or differs from what was saved (a lost or edited row):
        the report would draw other numbers than the run computed. The message names the
        command the provenance records (the run's own, settings included), else ``command``,
        writing into the directory that holds ``data`` (:func:`rerun_into`).
    """
    data = Path(data)
    record = read_json(data / provenance)
    files = record.get(DATA_FILES)
    if files is None:
        return record
    command = run_again(record, command, data.parent)
    if not isinstance(files, dict):
        raise ReportDataError(
            f"{data / provenance}: its {DATA_FILES} record is not a mapping; run `{command}` again"
        )
    for name, saved in files.items():
        path = data / name
        if not path.is_file():
            raise ReportDataError(
                f"{path} is missing from the data set {provenance} records; run `{command}` again"
            )
        if not isinstance(saved, dict) or _digest(path) != saved.get("sha256"):
            raise ReportDataError(
                f"{path} differs from the file saved with {provenance} (its checksum does not match: a lost "
                f"or edited row?), so the report would not show what the run computed; run `{command}` again"
            )
    return record


def read_json(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a JSON object of report data (a provenance record); refuse anything else clearly."""
    path = Path(path)
    if not path.is_file():
        raise ReportDataError(f"report data not found: {path} (run the experiment first)")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ReportDataError(f"{path}: malformed JSON ({exc}); regenerate the report data") from exc
    if not isinstance(data, dict):
        raise ReportDataError(f"{path}: expected a JSON object, got {type(data).__name__}")
    return data


STAGING = ".staging-"


@contextlib.contextmanager
def _publishing(data: Path) -> Iterator[None]:
    """Hold an exclusive lock on the directory ``data`` while a data set is published.

    Two saves into one directory interleaved their steps: one's files under the other's
    provenance. The lock is a ``flock`` on the directory itself (no lock file among the data),
    released by the system however the process ends. It guards saves on one machine: on NFS
    a directory's flock is local to each client. Where ``fcntl`` or directory locks are not
    available, publishing is unguarded, as before. When the lock is held by another save,
    :data:`PUBLISH_WAIT`'s callback (if set) hears of it before the wait.
    """
    try:
        import fcntl

        handle = os.open(data, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except (ImportError, OSError):  # pragma: no cover - no fcntl, or the directory cannot be opened
        handle = None
    if handle is None:  # pragma: no cover - (outside the except: no stray context on later errors)
        yield
        return
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:  # another save is publishing: say so, then wait for it
            notice = PUBLISH_WAIT.get()
            if notice is not None:
                notice(data)
            fcntl.flock(handle, fcntl.LOCK_EX)
        except OSError:  # pragma: no cover - a file system without locks
            pass
        yield
    finally:
        os.close(handle)


#: Written into a staging directory when its data set starts to be published: the plan of the
#: moves, so that a save killed while publishing is finished by the next one (roll forward).
PUBLISHING = ".publishing.json"


def _remove_abandoned_staging(data: Path) -> None:
    """Finish or remove the staging directories of :func:`data_set` whose process no longer runs.

    A save killed while it wrote its files (no plan) left the data as they were: its staging
    directory is removed. One killed while it published them (a plan) had removed the old
    provenance and replaced some files: its remaining moves are made, the provenance last, so
    the data are the new set whole instead of a mix of two sets without a provenance.
    """
    for path in data.glob(f"{STAGING}*"):
        if not path.is_dir() or path.is_symlink() or not writer_gone(path.name[len(STAGING) :]):
            continue
        with contextlib.suppress(OSError, ValueError, KeyError, TypeError):
            plan = json.loads((path / PUBLISHING).read_text(encoding="utf-8"))
            _publish_set(path, data, plan["provenance"], [Path(p) for p in plan["staged"]], plan["stale"])
        shutil.rmtree(path, ignore_errors=True)


def _write_plan(path: Path, plan: dict[str, Any]) -> None:
    """Write the publishing plan into the staging directory (its own: no atomic rename needed;
    a plan cut short is unreadable, and then no move had been made)."""
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(json.dumps(plan) + "\n")
        handle.flush()
        os.fsync(handle.fileno())


def recover_data_sets(data: str | os.PathLike[str]) -> None:
    """Finish a data set whose save was killed while it was published (see :func:`data_set`),
    and remove what killed saves left; for a command that reads ``data`` without saving."""
    data = Path(data)
    if not any(data.glob(f"{STAGING}*")):
        return
    with _publishing(data), interrupt_deferred():
        _remove_abandoned_staging(data)


def _publish_set(staging: Path, data: Path, provenance: str, staged: list[Path], stale: list[str]) -> None:
    """The moves of a data set, each of which may have been made already (a roll forward):
    the old provenance removed, the stale files removed, the files moved, the provenance last."""
    if (staging / provenance).is_file():
        (data / provenance).unlink(missing_ok=True)
    for name in stale:
        (data / name).unlink(missing_ok=True)
    for name in staged:
        if name != Path(provenance) and (staging / name).is_file():
            _publish(staging / name, data / name)
    if (staging / provenance).is_file():
        _publish(staging / provenance, data / provenance)
    for directory in sorted({(data / name).resolve().parent for name in staged} | {data.resolve()}):
        sync_directory(directory)


def _publish(source: Path, target: Path) -> None:
    """Move a staged file into place, as :func:`~replication.io.atomic.atomic_path` writes one:
    through a symbolic link to its target, keeping a replaced file's permissions."""
    if target.is_symlink():
        target = target.resolve()
    if target.is_file():
        os.chmod(source, target.stat().st_mode & 0o777)
    target.parent.mkdir(parents=True, exist_ok=True)
    os.replace(source, target)


@contextlib.contextmanager
def data_set(
    data: Path, provenance: str, *, stale: Iterable[str] = (), checksums: bool = False
) -> Iterator[Path]:
    """Stage an experiment's data files, then publish them together, the provenance last.

    Yields a staging directory inside ``data``: write the files there under their final
    names (subdirectories included). With ``checksums``, the staged provenance (a JSON object)
    gains the checksum and size of every other file of the set (:func:`read_provenance`).
    When the block ends without an error, the old provenance is removed, the files matching
    the ``stale`` glob patterns (relative to ``data``) that this run does not write are
    removed, the staged files replace those in ``data`` and the new provenance comes last,
    with Ctrl-C held meanwhile.

    A Ctrl-C or an error while the files are written leaves ``data`` as it was. A crash in the
    short publishing step (a SIGKILL, a power cut) left the data without their provenance, a
    mix of two sets; the plan of the moves is now written first, and the next save (or
    ``replication report``, :func:`recover_data_sets`) makes the moves left, so the new set is
    whole. A staging directory left by a save killed before it published is removed. Two
    commands saving into one ``data`` at once publish one after the other (an exclusive
    ``flock`` on the directory), so each set is whole and the later one replaces the earlier
    whole.
    """
    data.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f"{STAGING}{writer_tag()}", dir=data))
    try:
        yield staging
        staged = sorted(p.relative_to(staging) for p in staging.rglob("*") if p.is_file())
        if Path(provenance) not in staged:
            raise ValueError(f"the staged data set has no provenance {provenance}")
        if checksums:  # (the provenance is then a JSON object: the experiments' records are)
            _record_files(staging, provenance, staged)
        published = False
        try:
            with _publishing(data), interrupt_deferred():
                _remove_abandoned_staging(data)  # (one killed while this save waited for the lock)
                old = {p.relative_to(data) for pattern in stale for p in data.glob(pattern) if p.is_file()}
                removed = [str(name) for name in sorted(old - set(staged))]
                plan = {"provenance": provenance, "staged": [str(n) for n in staged], "stale": removed}
                _write_plan(staging / PUBLISHING, plan)  # durable before the first move
                _publish_set(staging, data, provenance, staged, removed)
                published = True
        except KeyboardInterrupt as exc:  # held while publishing, raised once the set was whole
            if published:
                note_written(exc, [data / name for name in staged])
            raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
