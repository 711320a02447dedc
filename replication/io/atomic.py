"""Atomic file writes: a temporary file in the destination directory, then a rename.

An interrupted or failed write never leaves a truncated file under the final name: either
the old file (if any) or the complete new one is there. The temporary file of a write that
was killed outright is removed by the next write of the same name.

Several files written inside :func:`all_or_none` are moved into place together: a command
whose second output fails leaves the first one as it was, new or old.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import glob
import hashlib
import os
import re
import secrets
import shutil
import signal
import socket
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from types import FrameType
from typing import Any

from replication import sigterm
from replication.errors import OutputError, shortened

__all__ = [
    "all_or_none",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output_path",
    "interrupt_deferred",
    "note_written",
    "open_descriptor",
    "sync_directory",
    "writer_gone",
    "writer_tag",
    "written_before",
]


def check_output_path(path: str | os.PathLike[str]) -> Path:
    """Return the file to write for ``path`` after checking its directory exists.

    A symbolic link is followed: the file it points to is written and the link stays (a
    rename onto the link itself would replace it with a regular file). A name ending in
    ``/`` (or ``/.``) is a directory's, as the shell takes it: refused unless it is one (then
    refused as a directory), not written as the file without the slash, which ``Path`` drops.
    """
    if not os.fspath(path):  # Path("") is the working directory
        raise OutputError("cannot write '': an empty file name")
    given = Path(path)
    try:
        if _directory_name(os.fspath(path)) and not given.is_dir():
            what = "is not a directory" if given.exists() else "does not exist"
            raise OutputError(
                f"cannot write {os.fsdecode(path)}: {given} {what} (a name ending in '/' names a "
                "directory; drop the '/' to write the file)"
            )
        return _check_output_path(given)
    except OutputError:
        raise
    except OSError as exc:  # Python's Path.is_symlink()/is_dir() raise on a name too long
        raise OutputError(f"cannot write {shortened(path)}: {exc.strerror or exc}") from exc


def _directory_name(name: str | bytes) -> bool:
    """Whether ``name`` ends in a path separator or in ``/.``, which only a directory can have."""
    text = os.fsdecode(name)
    seps = tuple(sep for sep in (os.sep, os.altsep) if sep)
    return text.endswith(seps) or text.endswith(tuple(sep + "." for sep in seps))


def _check_output_path(path: Path) -> Path:
    given = path
    via = ""
    descriptor = open_descriptor(path)
    if descriptor is not None:
        through = "" if descriptor == os.path.abspath(given) else f" ({descriptor})"
        raise OutputError(
            f"output path {given} names an open file descriptor{through}, not a file: writing it would "
            "replace whatever it is open on (a log opened with >>); choose a file name"
        )
    if path.is_symlink():
        try:
            path = path.resolve()
        except (OSError, RuntimeError) as exc:  # RuntimeError: a loop of links (Python 3.11)
            raise OutputError(f"cannot write {given}: cannot follow the symbolic link ({exc})") from exc
        via = f" (the symbolic link {given} points to {path})"
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        if parent.exists():  # "does not exist" was wrong for -o notes.txt/x.vtk
            raise OutputError(f"cannot write {given}: {parent} is a file, not a directory{via}")
        raise OutputError(f"output directory does not exist: {parent}{via}")
    if path.is_dir():
        raise OutputError(f"output path is a directory: {given}{via}")
    if path.exists() and not path.is_file():  # a FIFO, socket or device: a rename would replace it
        raise OutputError(f"output path {given} exists and is not a regular file{via}: choose a file name")
    return path


def open_descriptor(path: Path) -> str | None:
    """The descriptor link (``/proc/self/fd/1``) that ``path`` is or leads to, or None.

    ``-o /dev/stdout`` resolved to the file the shell had opened (``>> log``), which the rename
    of an atomic write replaced whole; a pipe resolved to a name that is no file and was
    refused as "the directory /proc/NNN/fd cannot hold new files".
    """
    name = os.path.abspath(path)
    for _ in range(40):  # the system's own limit on a chain of links
        # the name, and the name in its directory's real place (a link d -> /proc/self/fd, then d/1)
        real = os.path.join(os.path.realpath(os.path.dirname(name)), os.path.basename(name))
        if any(re.fullmatch(r"/dev/(std(in|out|err)|fd/.*)|/proc/.+/fd/[^/]*", n) for n in (name, real)):
            return name
        try:
            target = os.readlink(name)
        except OSError:  # not a link (or gone): the end of the chain
            return None
        name = os.path.normpath(os.path.join(os.path.dirname(name), target))
    return None


#: This machine, in the temporary names: a write is abandoned when its process no longer runs
#: here; a temporary of another machine (a shared file system) is never taken for one.
_HOST = hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


def _remove_abandoned(final: Path) -> None:
    """Remove the temporaries of earlier writes of ``final`` whose process no longer runs.

    A write killed outright (SIGKILL, a power cut) cannot remove its temporary file; the
    final name is never damaged, but a 80 MB temporary would otherwise stay for good.
    """
    head, tail = f".{final.name}.", f".tmp{final.suffix}"
    for path in final.parent.glob(glob.escape(head) + "*" + glob.escape(tail)):
        if writer_gone(path.name[len(head) :]):
            with contextlib.suppress(OSError):
                path.unlink()


def writer_tag() -> str:
    """``"<pid>.<host>-"``: what starts the name of a temporary this process writes, so that a
    later process can tell whether its writer still runs (:func:`writer_gone`)."""
    return f"{os.getpid()}.{_HOST}-"


def writer_gone(tagged: str) -> bool:
    """Whether the process whose :func:`writer_tag` starts ``tagged`` ran on this machine and
    has ended (its temporary is abandoned). Another machine's, or a running process's, is not."""
    pid, _, rest = tagged.partition(".")
    if not pid.isdigit() or not rest.startswith(f"{_HOST}-"):
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except OSError:  # a process of another user: running
        return False
    return False


def _mode_for(final: Path) -> int:
    """The replaced file's permissions, or the umask's default for a new file."""
    if final.exists():
        return final.stat().st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


#: fsync's answers where a directory cannot be synced at all (no failure of the disk).
_CANNOT_SYNC = frozenset({errno.EINVAL, errno.EBADF, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EROFS})


def sync_directory(directory: str | os.PathLike[str]) -> None:
    """Make the renames into ``directory`` durable (fsync the directory itself).

    A file is synced before its rename, but the rename lives in the directory: after a power
    cut the old file could be back, or none. Where a directory cannot be opened or synced
    (Windows, some network file systems) nothing is done: the rename is still atomic.

    Raises
    ------
    OutputError
        The directory could not be synced for another reason (an I/O error): the renames
        are in place, but may not survive a power cut.
    """
    try:
        fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError as exc:
        if exc.errno not in _CANNOT_SYNC:
            raise OutputError(
                f"cannot make the files just written in {directory} durable: {exc.strerror or exc}"
            ) from exc
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it to ``path``.

    The temporary name keeps ``path``'s suffix, so writers that choose a format by suffix
    (VTK, numpy) work on it. On any exception the temporary file is removed and the
    destination is untouched; operating-system errors (an unwritable directory, a full
    disk) become :class:`~replication.errors.OutputError` naming the file. Inside
    :func:`all_or_none` the complete temporary file waits there for the other writes.
    """
    final = check_output_path(path)
    _remove_abandoned(final)
    tmp: Path | None = None
    try:
        # a Ctrl-C or SIGTERM between creating the file and naming it here left it behind (a
        # stopped GA run kept a checkpoint's temporary): held until it is named, then raised
        with interrupt_deferred():
            fd, tmp_name = tempfile.mkstemp(
                prefix=f".{final.name}.{writer_tag()}", suffix=f".tmp{final.suffix}", dir=final.parent
            )
            tmp = Path(tmp_name)
            os.close(fd)
        yield tmp
        with open(tmp, "rb+") as handle:  # make the bytes durable before the rename
            os.fsync(handle.fileno())
        os.chmod(tmp, _mode_for(final))
        staged = _STAGED.get()
        if staged is None:
            os.replace(tmp, final)
        else:
            staged.append((tmp, final))
    except BaseException as exc:
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise OutputError(f"cannot write {final}: {exc.strerror or exc}") from exc
        raise
    if staged is None:  # (after the block: its errors say the destination is untouched)
        sync_directory(final.parent)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> int:
    """Write ``data`` atomically; return the number of bytes written."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return len(data)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> int:
    """Write UTF-8 ``text`` atomically (``\\n`` line ends); return the bytes written."""
    return atomic_write_bytes(path, text.encode("utf-8"))


@contextlib.contextmanager
def interrupt_deferred() -> Iterator[None]:
    """Hold a Ctrl-C (SIGINT), and a SIGTERM taken as one, until the block ends, then raise it.

    Only where Python's own SIGINT handler, or :mod:`replication.sigterm`'s SIGTERM handler,
    is in place (in the main thread): an ignored SIGINT (a background job) or an
    application's own handler is left to do what it does. A SIGTERM held here is raised as
    :class:`~replication.sigterm.Terminated`, before a Ctrl-C held with it. When the block
    fails while an interrupt is held, the interrupt is raised all the same, with the error as
    its ``__cause__`` (it was dropped, and a caller that handles the error went on).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: dict[int, Callable[[int, FrameType | None], Any]] = {}
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        held[signal.SIGINT] = signal.default_int_handler
    if sigterm.handler_installed():
        held[signal.SIGTERM] = signal.getsignal(signal.SIGTERM)  # type: ignore[assignment]
    caught: list[int] = []
    error: Exception | None = None
    try:
        for signum in held:  # (inside the try: a signal between the two leaves neither replaced)
            signal.signal(signum, lambda signum, frame: caught.append(signum))
        try:
            yield
        except Exception as exc:
            if not caught:
                raise
            error = exc  # the held interrupt still ends the command, this error as its cause
    finally:
        for signum, handler in held.items():
            signal.signal(signum, handler)
    try:
        if signal.SIGTERM in caught:
            held[signal.SIGTERM](signal.SIGTERM, None)  # raises Terminated, unless a SIGTERM came before
        if signal.SIGINT in caught:
            raise KeyboardInterrupt
    except KeyboardInterrupt as stop:
        if error is not None:
            raise stop from error
        raise
    if error is not None:
        raise error


#: The (temporary, final) files of the :func:`all_or_none` block running, in the order written.
_STAGED: contextvars.ContextVar[list[tuple[Path, Path]] | None] = contextvars.ContextVar(
    "_STAGED", default=None
)


@contextlib.contextmanager
def all_or_none() -> Iterator[None]:
    """Write the files of the block (:func:`atomic_path` and its users) all, or none of them.

    Each write goes to its temporary file as usual, but stays there; when the block ends
    without an error, the files are moved into place one after the other, with Ctrl-C held
    meanwhile. An error or a Ctrl-C in the block removes the temporaries and leaves every
    destination as it was. Should a move fail, the files already moved are put back: the
    old file of each (kept under a temporary name until the moves are done) or, for a new
    one, none. A nested block joins the outer one; when it fails, its own files are dropped,
    so an outer block that catches the error moves only the others. The block's files are
    those written in its context: a thread started inside it writes outside it.

    Raises
    ------
    OutputError
        When a file cannot be moved into place (the destinations are then as they were).
    """
    outer = _STAGED.get()
    if outer is not None:  # a nested block: its files join the outer one's, unless it fails
        start = len(outer)
        try:
            yield
        except BaseException:
            _drop(outer[start:])  # a caller that catches the error must not see them moved
            del outer[start:]
            raise
        return
    staged: list[tuple[Path, Path]] = []
    token = _STAGED.set(staged)
    try:
        try:
            yield
        finally:
            _STAGED.reset(token)
        moved = False
        try:
            with interrupt_deferred():
                _move_all(staged)
                moved = True
        except KeyboardInterrupt as exc:  # held during the moves, raised once they were done
            if moved:
                note_written(exc, [final for _, final in staged])
            raise
    finally:
        _drop(staged)  # what was not moved (all of them after an error)


def note_written(exc: BaseException, paths: Iterable[Path]) -> None:
    """Record on the interrupt ``exc`` that ``paths`` were moved into place while it was held
    (:func:`written_before` tells them)."""
    exc.written = (*written_before(exc), *paths)  # type: ignore[attr-defined]


def written_before(exc: BaseException) -> tuple[Path, ...]:
    """The files :func:`all_or_none` had moved into place when it raised the Ctrl-C (or
    SIGTERM) ``exc`` that it held meanwhile: the block's writes are complete, so a message
    must not say that the previous files are as they were. Empty for any other interrupt."""
    return tuple(getattr(exc, "written", ()))


def _drop(staged: list[tuple[Path, Path]]) -> None:
    """Remove the temporary files of ``staged`` (those already moved are gone: nothing to do)."""
    for tmp, _ in staged:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _keep_old(final: Path) -> Path | None:
    """A second name for ``final`` (a hard link, or a copy) to restore it from; None if there is none."""
    if not final.exists():
        return None
    backup = final.with_name(f".{final.name}.{writer_tag()}old{secrets.token_hex(4)}.tmp{final.suffix}")
    try:
        os.link(final, backup)
    except OSError:  # a file system without hard links
        try:
            shutil.copy2(final, backup)
        except BaseException:
            with contextlib.suppress(OSError):
                backup.unlink()
            raise
    return backup


def _move_all(staged: list[tuple[Path, Path]]) -> None:
    """Move each temporary onto its final name; on a failure, put back the ones already moved."""
    moved: list[tuple[Path, Path | None]] = []
    final = None
    try:
        for k, (tmp, final) in enumerate(staged):
            # the last move needs no second name: it fails whole, and nothing follows it
            backup = _keep_old(final) if k < len(staged) - 1 else None
            try:
                os.replace(tmp, final)
            except BaseException:
                if backup is not None:  # the old file is still in place
                    with contextlib.suppress(OSError):
                        backup.unlink()
                raise
            moved.append((final, backup))
    except BaseException as exc:
        for done, backup in reversed(moved):
            with contextlib.suppress(OSError):
                if backup is None:
                    done.unlink()
                else:
                    os.replace(backup, done)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise OutputError(f"cannot write {final}: {exc.strerror or exc}") from exc
        raise
    for _, backup in moved:
        if backup is not None:
            with contextlib.suppress(OSError):
                backup.unlink()
    for directory in dict.fromkeys(done.parent for done, _ in moved):  # (its error leaves no backup)
        sync_directory(directory)
