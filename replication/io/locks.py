"""A command's hold on the reports directory it writes: one writer at a time.

Two commands writing reports into one directory at once interleaved their saves and pages:
``casestudy --quick --seed 1 --output-dir mix`` and ``--seed 2`` beside it left seed 1's page
over seed 2's data, both with exit 0. Each data set is published whole (a lock on its
``data/``), but a page is drawn from the data after the save, so the pair must not mix.

:func:`hold_reports_dir` takes an exclusive ``flock`` on a lock file named after the
directory's resolved path, in ``/tmp`` (no file among the reports, and the directory need
not exist yet), for as long as the command runs (:func:`held_until_the_command_ends`); a
second command is refused at once. The system releases the lock when the process ends,
however it ends; a command that ends normally also removes the file. The place is fixed,
not ``$TMPDIR``: two commands run with different temporary directories must still find each
other's lock (``tempfile.gettempdir()`` only where there is no writable ``/tmp``). Where
``fcntl`` is missing, or no lock file can be opened, the directory is not guarded, as before.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
from collections.abc import Iterator
from pathlib import Path

from replication.errors import OutputError

__all__ = [
    "close_inherited_locks",
    "held_until_the_command_ends",
    "hold_reports_dir",
    "register_lock",
    "unregister_lock",
]

_STACK: contextvars.ContextVar[contextlib.ExitStack | None] = contextvars.ContextVar("_STACK", default=None)
#: The directories this process holds (their resolved paths), and the lock descriptors.
_HELD: dict[str, int] = {}


@contextlib.contextmanager
def held_until_the_command_ends() -> Iterator[None]:
    """Release the holds :func:`hold_reports_dir` takes inside the block when it ends."""
    with contextlib.ExitStack() as stack:
        token = _STACK.set(stack)
        try:
            yield
        finally:
            _STACK.reset(token)


#: Where the lock files are: one place per machine, whatever ``$TMPDIR`` says.
LOCK_DIR = "/tmp"


def _lock_file(key: str) -> Path:
    import hashlib  # (here, not at import: every command's start-up imports this module)
    import tempfile

    digest = hashlib.sha256(key.encode()).hexdigest()[:20]
    shared = os.path.isdir(LOCK_DIR) and os.access(LOCK_DIR, os.W_OK | os.X_OK)
    return Path(LOCK_DIR if shared else tempfile.gettempdir()) / f"replication-reports-{digest}.lock"


#: Not through a symbolic link: the lock's name in the shared /tmp is predictable.
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)


def _open_lock(path: Path) -> int:
    """A descriptor of the lock file, made if missing.

    A file made here is made readable by every user whatever the umask (a file of mode 0600
    left another user's command unguarded: it could not open it). A file that exists is only
    opened, never through a symbolic link and never changed: its name is predictable, and a
    link planted there must not lead this command to any other file. Opening it without
    ``O_CREAT`` also suits ``fs.protected_regular``, which refuses that on another user's file.

    Raises
    ------
    FileNotFoundError
        The file was removed between the two opens (its holder released it): try again.
    OSError
        It cannot be opened (a symbolic link, another user's unreadable file).
    """
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o644)
    except FileExistsError:
        return os.open(path, os.O_RDONLY | _NOFOLLOW)
    with contextlib.suppress(OSError):
        os.fchmod(fd, 0o644)  # just made, by this process
    return fd


def _names(path: Path, fd: int) -> bool:
    """Whether ``path`` still names the file open as ``fd``."""
    try:
        named = os.stat(path, follow_symlinks=False)
    except FileNotFoundError:
        return False
    held = os.fstat(fd)
    return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)


def _locked(path: Path) -> int | None:
    """A descriptor holding the exclusive lock of ``path``; None where locks cannot be had.

    A holder removes the file when it releases it (:func:`hold_reports_dir`), so a file opened
    just before may be gone by the time its lock is granted: the lock is kept only while the
    path still names the file locked, else taken again on the path's new file.

    Raises
    ------
    BlockingIOError
        Another process holds it.
    """
    import fcntl

    for _ in range(8):
        try:
            fd = _open_lock(path)
        except FileNotFoundError:  # released between the open that found it and the next
            continue
        except OSError:  # a symbolic link, an unreadable lock file of another user's
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise
        except OSError:  # pragma: no cover - a file system without locks
            os.close(fd)
            return None
        if _names(path, fd):
            return fd
        os.close(fd)  # the file was removed under us: lock the one the path names now
    return None  # pragma: no cover - removed eight times in a row


def hold_reports_dir(out: str | os.PathLike[str], what: str = "--output-dir") -> None:
    """Hold the reports directory ``out`` for the running command (reentrant: ``reproduce``
    holds it for the reports it draws one after the other). Outside a command, nothing is held.

    Raises
    ------
    OutputError
        Another command holds it.
    """
    stack = _STACK.get()
    key = str(Path(os.path.abspath(out)).resolve())
    if stack is None or key in _HELD:
        return
    try:
        import fcntl  # noqa: F401 - only to know that locks exist here
    except ImportError:  # pragma: no cover - not on POSIX
        return
    path = _lock_file(key)
    try:
        fd = _locked(path)
    except BlockingIOError:
        raise OutputError(
            f"{what} {out} is in use by another command writing its reports there; wait for it to end, "
            "or name another --output-dir"
        ) from None
    if fd is None:  # pragma: no cover - no lock to be had here
        return
    _HELD[key] = fd
    register_lock(fd)

    def release() -> None:
        if _HELD.pop(key, None) is not None:
            unregister_lock(fd)
            with contextlib.suppress(OSError):  # (before the unlock: no file is left in /tmp per
                if _names(path, fd):  # directory ever written; another user's file stays)
                    os.unlink(path)
            with contextlib.suppress(OSError):
                os.close(fd)

    stack.callback(release)


#: Every lock descriptor this process holds, the reports directory's and the GA run
#: directory's (:func:`replication.casestudy.rundir.hold` registers its own).
_DESCRIPTORS: set[int] = set()


def register_lock(fd: int) -> None:
    """Count ``fd`` among the locks a forked worker must not keep (:func:`close_inherited_locks`)."""
    _DESCRIPTORS.add(fd)


def unregister_lock(fd: int) -> None:
    _DESCRIPTORS.discard(fd)


def close_inherited_locks() -> None:
    """In a forked worker: close its copies of the parent's locks.

    A forked child shares its parent's open lock, which stays held while any process keeps it
    open: a worker outliving a killed parent kept the run directory (or the reports
    directory) locked. Closing the child's copy leaves the parent's lock as it is.
    """
    for fd in list(_DESCRIPTORS):
        with contextlib.suppress(OSError):
            os.close(fd)
    _DESCRIPTORS.clear()
    _HELD.clear()
