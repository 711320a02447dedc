"""Atomic file writes: a temporary file in the destination directory, then a rename.

An interrupted or failed write never leaves a truncated file under the final name: either
the old file (if any) or the complete new one is there. The temporary file of a write that
was killed outright is removed by the next write of the same name.
"""

from __future__ import annotations

import contextlib
import glob
import hashlib
import os
import socket
import tempfile
from collections.abc import Iterator
from pathlib import Path

from replication.errors import OutputError, shortened

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output_path",
    "writer_gone",
    "writer_tag",
]


def check_output_path(path: str | os.PathLike[str]) -> Path:
    """Return the file to write for ``path`` after checking its directory exists.

    A symbolic link is followed: the file it points to is written and the link stays (a
    rename onto the link itself would replace it with a regular file).
    """
    try:
        return _check_output_path(Path(path))
    except OutputError:
        raise
    except OSError as exc:  # Python's Path.is_symlink()/is_dir() raise on a name too long
        raise OutputError(f"cannot write {shortened(path)}: {exc.strerror or exc}") from exc


def _check_output_path(path: Path) -> Path:
    given = path
    via = ""
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


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it to ``path``.

    The temporary name keeps ``path``'s suffix, so writers that choose a format by suffix
    (VTK, numpy) work on it. On any exception the temporary file is removed and the
    destination is untouched; operating-system errors (an unwritable directory, a full
    disk) become :class:`~replication.errors.OutputError` naming the file.
    """
    final = check_output_path(path)
    _remove_abandoned(final)
    try:
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{final.name}.{writer_tag()}", suffix=f".tmp{final.suffix}", dir=final.parent
        )
    except OSError as exc:
        raise OutputError(f"cannot write {final}: {exc.strerror or exc}") from exc
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        with open(tmp, "rb+") as handle:  # make the bytes durable before the rename
            os.fsync(handle.fileno())
        os.chmod(tmp, _mode_for(final))
        os.replace(tmp, final)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise OutputError(f"cannot write {final}: {exc.strerror or exc}") from exc
        raise


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> int:
    """Write ``data`` atomically; return the number of bytes written."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return len(data)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> int:
    """Write UTF-8 ``text`` atomically (``\\n`` line ends); return the bytes written."""
    return atomic_write_bytes(path, text.encode("utf-8"))
