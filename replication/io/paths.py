"""Checks on the files and directories a command will write, made before any work.

Two names can denote one file: ``c.csv`` and ``./c.csv``, a symbolic link and its target,
two hard links. Writing an output over an input (or two outputs over each other) would
destroy data while reporting success, so outputs are compared with the inputs and with one
another both by resolved path and, for files that exist, by device and inode. Directories
are checked for writability by really creating (and removing) a probe file, since
permission bits say nothing about a read-only file system and are ignored for root.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from replication.errors import InputError, OutputError, shortened

__all__ = [
    "REPORT_SUBDIRS",
    "check_distinct",
    "check_report_dir",
    "check_utf8_path",
    "check_writable_dir",
    "dangling",
    "is_browser_file",
    "lookup",
    "same_file",
]

#: The subdirectories a report command writes into its output directory.
REPORT_SUBDIRS = ("data", "figures")
#: Files a file browser leaves in a directory it showed (macOS Finder, Windows Explorer, KDE
#: Dolphin); macOS's ``._<name>`` companions on foreign file systems are matched by prefix.
BROWSER_FILES = frozenset({".DS_Store", "Thumbs.db", "desktop.ini", ".directory"})


def is_browser_file(name: str) -> bool:
    """Whether a directory entry named ``name`` is a file browser's, not a user's work or a
    run's: a run directory holding one is still empty, as far as a command is concerned."""
    return name in BROWSER_FILES or name.startswith("._")


Named = tuple[str, str | os.PathLike[str]]


#: What ``Path.exists()`` answers False for (no such entry, a file as a directory, a link loop).
_ABSENT = frozenset({errno.ENOENT, errno.ENOTDIR, errno.EBADF, errno.ELOOP})


@dataclass(frozen=True)
class Found:
    """What :func:`lookup` found at a path (symbolic links followed)."""

    exists: bool
    is_dir: bool
    is_file: bool

    @classmethod
    def of(cls, mode: int | None) -> Found:
        """From a ``stat`` mode, or None for no entry."""
        if mode is None:
            return cls(False, False, False)
        return cls(True, stat.S_ISDIR(mode), stat.S_ISREG(mode))


def lookup(path: str | os.PathLike[str], error: Callable[[str], Exception], what: str) -> Found:
    """Whether ``path`` exists and is a directory or a regular file, with one ``stat``.

    ``Path.exists()`` and ``Path.is_dir()`` raise where the system refuses the lookup itself
    (Python 3.11: a name too long, a directory that may not be searched); that becomes
    ``error(f"{what} {path}: {reason}")``, the path shortened, so that the command says in
    one line which of its paths was refused.
    """
    try:
        return Found.of(os.stat(path).st_mode)
    except ValueError:  # a NUL byte, or a name the file system's encoding cannot take
        return Found.of(None)
    except OSError as exc:
        if exc.errno in _ABSENT:
            return Found.of(None)
        raise error(f"{what} {shortened(path)}: {exc.strerror or exc}") from exc


def dangling(path: str | os.PathLike[str]) -> str:
    """For a "not found" message: that ``path`` is a symbolic link to nothing (its target is
    missing, or the links loop), which "not found" alone hides; else nothing."""
    try:
        link = os.path.islink(path)
    except (OSError, ValueError):
        return ""
    if not link:
        return ""
    if _looped(Path(path)):
        return " (a loop of symbolic links)"
    return f" (a symbolic link to {shortened(os.readlink(path))}, which does not exist)"


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        st = path.stat()  # follows symbolic links: a link and its target are one file
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _looped(path: Path) -> bool:
    try:
        path.resolve()
    except (OSError, RuntimeError):
        return True
    return False


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two names denote the same file (resolved path, or device and inode)."""
    pa, pb = Path(a), Path(b)
    try:
        if pa.resolve() == pb.resolve():
            return True
    except (OSError, RuntimeError) as exc:  # RuntimeError: a symbolic link loop (Python 3.11)
        loop = pa if _looped(pa) else pb
        raise OutputError(f"{loop}: cannot follow the symbolic link ({exc})") from exc
    ia, ib = _identity(pa), _identity(pb)
    return ia is not None and ia == ib


def check_distinct(outputs: Iterable[Named], inputs: Iterable[Named] = ()) -> None:
    """Refuse outputs that are the same file as an input or as another output.

    Parameters
    ----------
    outputs, inputs : iterable of (label, path)
        The label names the option in the message (``"-o"``, ``"--save-cloud"``, ``"INPUT"``).
        Entries whose path is None are skipped.

    Raises
    ------
    OutputError
        Naming both options and both paths.
    """
    outs = [(label, path) for label, path in outputs if path is not None]
    ins = [(label, path) for label, path in inputs if path is not None]
    for k, (label, path) in enumerate(outs):
        for in_label, in_path in ins:
            if same_file(path, in_path):
                raise OutputError(
                    f"{label} {path} is the same file as {in_label} {in_path}: writing it would destroy "
                    "the input; choose another output name"
                )
        for other_label, other in outs[:k]:
            if same_file(path, other):
                raise OutputError(
                    f"{other_label} {other} and {label} {path} are the same file: one output would "
                    "overwrite the other; choose two different names"
                )


def _nearest_existing(target: Path, what: str) -> Path:
    """``target`` or its nearest ancestor that exists."""
    existing = target
    while not existing.exists():
        if existing.is_symlink():
            raise OutputError(f"{what} {target}: {existing} is a broken symbolic link")
        parent = existing.parent
        if parent == existing:
            break
        existing = parent
    return existing


def _no_new_files(exc: OSError) -> str:
    """What a directory in which no file could be created is: "not writable" for a permission
    error only ("not writable: No such file or directory", /proc's answer, said two things)."""
    refused = exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS)
    return "is not writable" if refused else "cannot hold new files"


def check_writable_dir(path: str | os.PathLike[str], what: str) -> Path:
    """Check, without creating it, that directory ``path`` exists or can be created, and is writable.

    The nearest existing ancestor must be a directory in which a file can be created (a
    probe file is created and removed at once). ``what`` names the option in the message
    (``"--output-dir"``).

    Raises
    ------
    OutputError
        When ``path`` (or an ancestor) is a file, or no file can be created there.
    """
    target = Path(path)
    try:
        existing = _nearest_existing(target, what)
    except OutputError:  # (an OSError itself) already names the option
        raise
    except OSError as exc:  # Python's Path.exists() raises on a name too long
        raise OutputError(f"{what} {shortened(target)}: {exc.strerror or exc}") from exc
    if not existing.is_dir():
        where = "is a file" if existing == target else f"cannot be created: {existing} is a file"
        raise OutputError(f"{what} {target} {where}, not a directory")
    try:
        with tempfile.TemporaryFile(dir=existing, prefix=".replication-probe-"):
            pass
    except OSError as exc:
        reason = exc.strerror or str(exc)
        where = "" if existing == target else f" (it would be created in {existing})"
        raise OutputError(f"{what} {target} {_no_new_files(exc)}{where}: {reason}") from exc
    return target


def check_report_dir(
    path: str | os.PathLike[str], what: str, subdirs: Iterable[str] = REPORT_SUBDIRS
) -> Path:
    """:func:`check_writable_dir` for a reports directory, and its ``subdirs`` (relative paths).

    A report command writes its data and figures into subdirectories (``data/``,
    ``figures/``); a file of one of those names would stop it only when it saves, after all
    the work. Subdirectories that exist must be writable directories.

    Raises
    ------
    OutputError
        When ``path`` cannot be written, or a subdirectory is a file, a broken symbolic
        link or not writable.
    """
    target = check_writable_dir(path, what)
    for name in subdirs:
        sub = target / name
        if sub.is_symlink() and not sub.exists():
            raise OutputError(f"{what} {target}: {sub} is a broken symbolic link")
        if not sub.exists():
            continue
        if not sub.is_dir():
            raise OutputError(f"{what} {target}: {sub} is a file, not a directory")
        try:
            with tempfile.TemporaryFile(dir=sub, prefix=".replication-probe-"):
                pass
        except OSError as exc:
            raise OutputError(f"{what} {target}: {sub} {_no_new_files(exc)}: {exc.strerror or exc}") from exc
    return target


def _escaped(path: Path) -> str:
    """``path`` for a message, its bytes that are not UTF-8 shown as ``\\udcff``: printable on any stream."""
    return str(path).encode("utf-8", "backslashreplace").decode("utf-8")


def check_utf8_path(path: str | os.PathLike[str], what: str, needed_by: str = "the SPH engine") -> Path:
    """Refuse a path whose absolute form is not valid UTF-8 (a name Python holds with surrogate escapes).

    The SPH engine's binding takes its paths as UTF-8 text and is given absolute ones: a
    directory name that is not UTF-8, or one under a working directory whose path is not,
    made every simulation crash with a TypeError. ``what`` names the option in the message.

    Returns the absolute path.

    Raises
    ------
    InputError
        Naming the path (and its absolute form, when only that is not UTF-8).
    """
    given = Path(path)
    try:
        absolute = given.resolve()
    except (OSError, RuntimeError):  # a loop of symbolic links: the caller's other checks name it
        absolute = Path(os.path.abspath(given))
    try:
        os.fsencode(absolute).decode("utf-8")
    except UnicodeDecodeError:
        try:
            os.fsencode(given).decode("utf-8")
        except UnicodeDecodeError:
            where = ""
        else:
            where = f", and its absolute path {_escaped(absolute)} is not"
        raise InputError(
            f"{what} {_escaped(given)}: {needed_by} needs a path that is valid UTF-8{where}"
        ) from None
    return absolute
